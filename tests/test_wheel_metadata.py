"""``python -m build --wheel`` makes a wheel whose metadata carries the licence and the classifiers.

The build runs on a copy of the checkout in ``tmp_path`` (setuptools writes ``build/`` and an
``.egg-info`` folder next to the sources, and the checkout is never written to), in the isolated
build environment ``build`` makes from ``[build-system] requires`` (as ``pip install .`` does).
"""

from __future__ import annotations

import email.parser
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]

#: Folders and files of a working checkout that are not sources of the distribution.
_SKIPPED = shutil.ignore_patterns(
    ".git", ".venv", "__pycache__", "build", "dist", "*.egg-info", "_build", "_generated"
)


def _NOT_SOURCES(folder: str, names: list[str]) -> set[str]:
    """What the copy leaves out: build leftovers anywhere, and the results of runs at the top
    (``aiauv_pin/results/`` is a package)."""
    skipped = set(_SKIPPED(folder, names))
    if Path(folder).resolve() == ROOT and "results" in names:
        skipped.add("results")
    return skipped


@pytest.mark.slow  # an isolated build environment: about a minute on 2 cores
def test_wheel_metadata_carries_licence_and_classifiers(tmp_path):
    pytest.importorskip("build")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=_NOT_SOURCES)
    completed = subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--outdir", str(tmp_path / "dist"), str(source)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert completed.returncode == 0, (completed.stdout + completed.stderr)[-3000:]
    (wheel,) = (tmp_path / "dist").glob("aiauv_pin-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        metadata_name = next(n for n in names if n.endswith(".dist-info/METADATA"))
        metadata = email.parser.Parser().parsestr(archive.read(metadata_name).decode("utf-8"))
        licence_name = next(n for n in names if n.endswith(".dist-info/licenses/LICENSE"))
        licence_text = archive.read(licence_name).decode("utf-8")

    assert metadata["License-Expression"] == "BSD-3-Clause"
    assert metadata.get_all("License-File") == ["LICENSE"]
    assert licence_text == (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "BSD 3-Clause License" in licence_text and "aiauv-pin developers" in licence_text
    classifiers = metadata.get_all("Classifier")
    assert classifiers == project["classifiers"]
    for expected in (
        "Intended Audience :: Science/Research",
        "Operating System :: POSIX :: Linux",
        "Topic :: Scientific/Engineering",
        *(f"Programming Language :: Python :: 3.{minor}" for minor in (10, 11, 12, 13)),
    ):
        assert expected in classifiers
    assert metadata["Requires-Python"] == project["requires-python"]
    # the data the package cannot run without is in the wheel
    assert "aiauv_pin/urdf/paper_uniform.urdf" in names
    assert any(
        name.startswith("aiauv_pin/kernels/shipped/") and name.endswith(".zip") for name in names
    )
