"""Build the compiled kernels shipped with the package (``hydro/prebuilt/<python tag>.zip``).

Run after any change to a compiled source (``hydro``, ``control``, ``aiauv_pin/fast``,
``aiauv_pin/disturbances.py``; ``tests/test_prebuilt.py`` fails until then)::

    python -m aiauv_pin.prebuilt                 # for this Python
    python -m aiauv_pin.prebuilt --python /path/to/python3.10 /path/to/python3.12 ...

For this Python, a child process runs :data:`WORKLOADS` with an empty numba cache
(``NUMBA_CACHE_DIR``), the portable CPU target of :mod:`hydro.prebuilt` and the shipped kernels
switched off; whatever numba wrote is packed per source folder with a manifest. For another Python,
the package is installed (not editable) into a temporary virtual environment of that Python, which
then builds its own archive the same way; its sources must hash as this checkout's.
How seeding works and why the target is portable: :mod:`hydro.prebuilt`.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from hydro import prebuilt
from hydro.jit import _project_files, source_hash

from .compilation import default_target_environment

#: What the build runs (``aiauv`` command lines, and the README's batch rollout): the quick start
#: and the commands a new user tries next. Each simulates 1 s; the compiled code does not depend on
#: the duration.
WORKLOADS = (
    ("simulate", "--duration", "1"),
    ("simulate", "--duration", "1", "--no-html", "--method", "rk4"),
    ("simulate", "--duration", "1", "--no-html", "--case", "stabilised"),
    ("simulate", "--duration", "1", "--no-html", "--method", "midpoint", "--dt", "0.02"),
    ("rollout",),
)

_ROOT = Path(__file__).resolve().parent.parent


def compiled_folders() -> list[str]:
    """The source folders (relative to the project root) that hold compiled functions."""
    return sorted({f.parent.relative_to(_ROOT).as_posix() for f in _project_files()})


def _rollout_workload() -> None:
    """The README's batch rollout, shortened (two gains, 1 s), and the same with the midpoint
    method at 0.02 s (the batches of ``aiauv bench --only throughput``)."""
    import dataclasses

    import aiauv_pin
    from aiauv_pin.paper_controller import VehiclePathFollowing
    from aiauv_pin.scenario import PaperScenario, initial_state

    vehicle = aiauv_pin.load_vehicle()
    scenario = PaperScenario(duration=1.0)
    q0, v0 = initial_state(vehicle, scenario)
    laws = [
        VehiclePathFollowing(
            vehicle, dataclasses.replace(scenario.controller_gains, k_e=(k, k))
        ).compiled()
        for k in (0.05, 0.1)
    ]
    aiauv_pin.rollout(
        vehicle, q0, v0, scenario.duration, scenario.dt, laws, method=scenario.method, log_every=10
    )
    aiauv_pin.rollout(vehicle, q0, v0, scenario.duration, 0.02, laws, method="midpoint")


def _run_workloads(out: Path) -> None:
    """Child process: run :data:`WORKLOADS` (the environment is set by :func:`build_here`)."""
    import hydro.jit
    from aiauv_pin.cli import main

    if not hydro.jit.PORTABLE_TARGET:
        raise SystemExit(
            f"aiauv: error: numba does not compile for {prebuilt.PORTABLE_CPU_NAME} here "
            "(the host lacks it, or NUMBA_CPU_NAME is set): nothing portable to ship"
        )
    for number, workload in enumerate(WORKLOADS):
        if workload == ("rollout",):
            _rollout_workload()
            continue
        code = main([*workload, "--out", str(out / f"run{number}")])
        if code != 0:
            raise SystemExit(f"aiauv: error: workload {' '.join(workload)} exited with {code}")


def pack(cache_dir: Path, archive: Path) -> int:
    """Pack the cache files numba wrote under ``cache_dir`` into ``archive``; return their number.

    numba's ``NUMBA_CACHE_DIR`` layout puts the functions of the source folder ``F`` in
    ``<cache_dir>/<name of F>_<sha1 of F's absolute path>``; the archive names them ``<F relative
    to the project root>/<file>`` instead, so that they can be unpacked under any installation.
    """
    from hydro.jit import _numba_name

    locator = _numba_name("CacheLocator")
    subpaths = {
        locator.get_suitable_cache_subpath(str(_ROOT / folder / "_.py")): folder
        for folder in compiled_folders()
    }
    import llvmlite.binding as llvm
    import numba

    manifest = prebuilt.Manifest(
        source_hash=source_hash(),
        numba=numba.__version__,
        python_tag=prebuilt.python_tag(),
        triple=llvm.get_process_triple(),
        cpu_name=prebuilt.PORTABLE_CPU_NAME,
        workloads=tuple(" ".join(w) for w in WORKLOADS),
    )
    entries = []
    for sub in sorted(p for p in cache_dir.iterdir() if p.is_dir()):
        if sub.name not in subpaths:
            raise SystemExit(f"aiauv: error: numba cached functions outside the project: {sub}")
        entries.extend(
            (f"{subpaths[sub.name]}/{file.name}", file)
            for file in sorted(sub.iterdir())
            if file.suffix in (".nbi", ".nbc")
        )
    if not any(name.endswith(".nbi") for name, _ in entries):
        raise SystemExit("aiauv: error: the workloads left numba's cache empty")
    from .atomic import atomic_path

    # a killed build leaves the previous archive whole; a link or FIFO at ``archive`` is refused
    with (
        atomic_path(archive) as partial,
        zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as packed,
    ):
        packed.writestr(prebuilt.MANIFEST, manifest.to_json())
        for name, file in entries:
            packed.write(file, name)
    return len(entries)


def build_here(out_dir: Path) -> Path:
    """Build this Python's archive into ``out_dir``; return its path."""
    archive = out_dir / f"{prebuilt.python_tag()}.zip"
    with tempfile.TemporaryDirectory(prefix="aiauv-prebuilt-") as temporary:
        cache_dir = Path(temporary) / "cache"
        env = default_target_environment()
        env.update(NUMBA_CACHE_DIR=str(cache_dir), AIAUV_PREBUILT_KERNELS="0")
        code = [sys.executable, "-m", "aiauv_pin.prebuilt", "--workloads", temporary]
        subprocess.run(code, env=env, check=True)
        count = pack(cache_dir, archive)
    print(f"{archive}: {count} files, {archive.stat().st_size / 1e6:.2f} MB")
    return archive


def build_with(python: str, out_dir: Path) -> None:
    """Install this checkout into a temporary virtual environment of ``python``; build there."""
    with tempfile.TemporaryDirectory(prefix="aiauv-prebuilt-venv-") as temporary:
        venv = Path(temporary) / "venv"
        subprocess.run([python, "-m", "venv", str(venv)], check=True)
        interpreter = venv / "bin" / "python"
        subprocess.run(
            [str(interpreter), "-m", "pip", "install", "-q", str(_ROOT)], check=True, cwd=temporary
        )
        check = "from hydro.jit import source_hash; print(source_hash())"
        installed = subprocess.run(
            [str(interpreter), "-c", check], check=True, capture_output=True, text=True,
            cwd=temporary,
        ).stdout.strip()  # fmt: skip
        if installed != source_hash():
            raise SystemExit(
                f"aiauv: error: the copy installed for {python} hashes differently from this "
                "checkout (a compiled source not packaged?)"
            )
        build = [str(interpreter), "-m", "aiauv_pin.prebuilt", "--out-dir", str(out_dir)]
        subprocess.run(build, check=True, cwd=temporary)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m aiauv_pin.prebuilt",
        description="Build the compiled kernels shipped in hydro/prebuilt/ (one archive per Python).",
    )
    parser.add_argument(
        "--python", nargs="+", metavar="EXE", help="build for these Python interpreters instead"
    )
    parser.add_argument(
        "--out-dir", type=Path, default=_ROOT / "hydro" / "prebuilt", help="where archives go"
    )
    parser.add_argument("--workloads", type=Path, help=argparse.SUPPRESS)  # the child's part
    args = parser.parse_args(argv)
    if args.workloads is not None:
        _run_workloads(args.workloads)
        return 0
    if args.python:
        for python in args.python:
            build_with(python, args.out_dir.resolve())
    else:
        build_here(args.out_dir.resolve())
    return 0


if __name__ == "__main__":
    sys.exit(main())
