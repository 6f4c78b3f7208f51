"""aiauv_pin._internal.numba_blas: numba starts without scipy.linalg, results unchanged."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

_RUN = """\
import json, sys
from aiauv_pin.app.cli import main
main(["simulate", "--case", "uniform", "--duration", "5", "--quiet", "--out", sys.argv[1],
      "--no-html", "--no-figures"])
import numba.np.arraymath
loaded = "scipy.linalg" in sys.modules
import scipy.linalg  # still importable afterwards
print(json.dumps([loaded, numba.np.arraymath._HAVE_BLAS]))
"""


def _run(out: Path, check: str) -> list:
    env = {**os.environ, "AIAUV_NUMBA_BLAS_CHECK": check}
    done = subprocess.run(
        [sys.executable, "-c", _RUN, str(out)],
        capture_output=True,
        text=True,
        check=True,
        env=env,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_simulate_skips_scipy_linalg_with_the_same_results(tmp_path):
    skipped = _run(tmp_path / "skipped", "0")
    checked = _run(tmp_path / "checked", "1")
    assert skipped == [False, False]  # scipy.linalg not imported by numba's start
    assert checked == [True, True]  # numba's own check
    csv = "timeseries.csv"
    assert (tmp_path / "skipped" / csv).read_bytes() == (tmp_path / "checked" / csv).read_bytes()


def test_finder_refuses_only_numba_check_and_removes_itself():
    from aiauv_pin._internal import numba_blas

    finder = numba_blas._SkipNumbaBlasCheck()
    assert finder.find_spec("scipy.linalg") is None  # not called from numba's _check_blas
    assert finder.find_spec("scipy") is None
    numba_blas.remove()
    assert numba_blas._FINDER not in sys.meta_path
