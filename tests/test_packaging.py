"""The distribution: every package of the source tree shipped (a missing one fails only when
installed), and an installation that runs never written to."""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]

#: Source folder -> the import name it installs as (``package-dir`` in pyproject.toml).
FOLDERS = {"aiauv_pin": "aiauv_pin", "hydro": "aiauv_hydro", "control": "aiauv_control"}


def test_every_source_package_is_listed_in_pyproject():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    mapped = {name: ROOT / folder for name, folder in config.get("package-dir", {}).items()}
    found = set()
    for folder, name in FOLDERS.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            if "__pycache__" in init.parts:
                continue
            found.add(".".join((name, *init.parent.relative_to(ROOT / folder).parts)))
    found |= set(mapped)
    assert found == listed
    for folder in mapped.values():
        assert (folder / "__init__.py").is_file()


#: The import packages the distribution installs (their folders in site-packages).
INSTALLED_PACKAGES = tuple(FOLDERS.values())


def _files_under(site: Path) -> set[str]:
    return {
        str(path.relative_to(site))
        for top in INSTALLED_PACKAGES
        if (site / top).exists()
        for path in (site / top).rglob("*")
    }


@pytest.mark.slow
def test_a_run_writes_nothing_into_the_installation_and_an_uninstall_leaves_nothing(tmp_path):
    """``pip install .``, ``aiauv simulate``, ``pip uninstall``: site-packages is as pip left it
    (issue 28: numba's caches there, left behind by an uninstall, broke the next install).

    The scratch environment reuses the dependencies installed for this test run (a ``.pth`` adds
    this interpreter's site-packages after its own) and builds without a download
    (``--no-build-isolation``; setuptools and wheel are test dependencies).
    """
    pytest.importorskip("setuptools", minversion="69")
    pytest.importorskip("wheel")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = Path(
        subprocess.run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            check=True, capture_output=True, text=True,
        ).stdout.strip()
    )  # fmt: skip
    ours = Path(sysconfig.get_paths()["purelib"])
    (site / "zz_test_dependencies.pth").write_text(f"import site; site.addsitedir({str(ours)!r})\n")
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
        "XDG_CACHE_HOME": str(tmp_path / "xdg"),
        "PIP_CACHE_DIR": str(tmp_path / "pip"),
    }

    def run(*arguments: str, cwd: Path = tmp_path) -> subprocess.CompletedProcess:
        done = subprocess.run(
            [str(python), *arguments], env=env, cwd=cwd, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stdout + done.stderr
        return done

    install = ("-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", str(ROOT))
    run(*install)
    found = run(
        "-c", "import aiauv_pin, aiauv_hydro, aiauv_control; print(aiauv_pin.__file__)"
    ).stdout
    assert Path(found.strip()).is_relative_to(site)  # the installed copy, not the checkout
    before = _files_under(site)
    assert "aiauv_pin/app/cli.py" in before and "aiauv_hydro/numerics/jit.py" in before
    out = tmp_path / "out"
    run("-m", "aiauv_pin", "simulate", "--duration", "0.2", "--no-html", "--out", str(out))
    assert (out / "summary.json").is_file()
    assert _files_under(site) == before  # nothing written inside the installation
    assert list((tmp_path / "cache" / "aiauv-pin").rglob("*.nbi"))  # the cache went here instead
    run("-m", "pip", "uninstall", "-q", "-y", "aiauv-pin")
    assert not [top for top in INSTALLED_PACKAGES if (site / top).exists()]
