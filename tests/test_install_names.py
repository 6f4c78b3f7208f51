"""Install names that cannot clash: our folders ``hydro/`` and ``control/`` install as ``aiauv_hydro``
and ``aiauv_control``, so python-control (``import control``) lives beside us (issue 28)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_our_packages_import_under_their_own_names():
    import aiauv_control
    import aiauv_hydro

    assert Path(aiauv_hydro.__file__).resolve().parent == ROOT / "hydro"
    assert Path(aiauv_control.__file__).resolve().parent == ROOT / "control"
    for clash in ("hydro", "control"):
        spec = importlib.util.find_spec(clash)
        found = Path(spec.origin).resolve().parent if spec is not None and spec.origin else None
        assert found != ROOT / clash, (
            f"'import {clash}' finds this checkout's folder: the test command must not put the "
            "repository root on sys.path (run .venv/bin/pytest, not python -m pytest)"
        )


def test_python_control_and_this_project_live_in_one_environment():
    """python-control is in the test extra: ``import control`` is it, and ``control.tf`` works,
    in a fresh interpreter started from the repository root (the user's usual working folder)."""
    if importlib.util.find_spec("control") is None:
        pytest.skip("python-control is not installed (it is in the test extra)")
    code = (
        "import control, aiauv_control, aiauv_pin; "
        "s = control.tf([1], [1, 1]); "
        "print(type(s).__module__.split('.')[0], aiauv_control.__name__)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd="/", capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["control", "aiauv_control"]
