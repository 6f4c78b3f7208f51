"""The README's quick start and examples stay true: its commands and code blocks run as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
CI_RUN = Path(__file__).resolve().parents[1] / ".ci" / "run"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", README.read_text(), flags=re.S | re.M)


def test_ci_runs_the_readme_test_command():
    """``.ci/run`` extracts the command after the ``ci:test`` marker; it must be the quick start's."""
    text = README.read_text()
    marker = text.index("<!-- ci:test -->")
    command = re.search(r"```bash\n(.*?)\n```", text[marker:], flags=re.S).group(1)
    assert "pytest" in command and "pip install" in command
    extracted = subprocess.run(
        [
            "bash",
            "-c",
            CI_RUN.read_text()
            .split("test_command=", 1)[1]
            .split("\n", 1)[0]
            .removeprefix("$(")
            .removesuffix(")"),
        ],
        cwd=README.parent,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    assert extracted == command


@pytest.mark.parametrize("index", range(len(_blocks("python"))))
def test_python_examples_run(index, tmp_path):
    code = _blocks("python")[index]
    completed = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=600
    )
    assert completed.returncode == 0, completed.stderr[-2000:]


def test_spec_example_builds_a_usable_vehicle(tmp_path):
    from aiauv_pin.builder import write_urdf
    from aiauv_pin.check import check_vehicle
    from aiauv_pin.vehicle_spec import spec_from_toml

    spec_text = next(b for b in _blocks("toml") if "[[module]]" in b)
    path = write_urdf(spec_from_toml(spec_text), tmp_path / "vehicle.urdf")
    report = check_vehicle(path)  # raises for an unusable vehicle
    assert report.total_mass == pytest.approx(21.0)
    assert report.smallest_mass_eigenvalue > 0.0
