"""Build the compiled kernels shipped with the package (``aiauv_pin/kernels/shipped/<python tag>.zip``).

Run after any change to a compiled source (the packages and modules declared in the entry-point
group ``aiauv.compiled_sources`` of ``pyproject.toml``; ``tests/tools/test_prebuilt.py`` fails until then)::

    python -m aiauv_pin.tools.kernel_archive                 # for this Python
    python -m aiauv_pin.tools.kernel_archive --python /path/to/python3.10 /path/to/python3.12 ...

For this Python, a child process runs :data:`WORKLOADS` with an empty numba cache
(``NUMBA_CACHE_DIR``), the portable CPU target of :mod:`aiauv_hydro.numerics.kernel_cache` and the
shipped kernels
switched off; whatever numba wrote is packed per source folder with a manifest. For another Python,
the package is installed (not editable) into a temporary virtual environment of that Python, which
then builds its own archive the same way; its sources must hash as this checkout's.
How seeding works and why the target is portable: :mod:`aiauv_hydro.numerics.kernel_cache`.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from aiauv_hydro.numerics import jit
from aiauv_hydro.numerics import kernel_cache as prebuilt
from aiauv_hydro.numerics.jit import source_hash
from aiauv_pin.simulation.compilation import default_target_environment

#: What the build runs (``aiauv`` command lines, the README's batch rollout and one step of each
#: Gymnasium environment): the quick start,
#: the commands a new user tries next, and each built-in controller (a passive run serves any
#: vehicle: the loop's types do not depend on the vehicle). Each simulates 1 s; the compiled code
#: does not depend on the duration.
WORKLOADS = (
    ("simulate", "--duration", "1"),
    ("simulate", "--duration", "1", "--no-html", "--method", "rk4"),
    ("simulate", "--duration", "1", "--no-html", "--case", "stabilised"),
    ("simulate", "--duration", "1", "--no-html", "--method", "midpoint", "--dt", "0.02"),
    ("simulate", "--duration", "1", "--no-html", "--controller", "none"),
    ("simulate", "--duration", "1", "--no-html", "--controller", "thruster_turning"),
    ("simulate", "--duration", "1", "--no-html", "--controller", "gait"),
    # station keeping: a Python controller on the compiled allocator (aiauv_control.allocation)
    (
        "simulate",
        "--duration",
        "1",
        "--no-html",
        "--controller",
        "station",
        "--vehicle",
        "{example_vehicles}/rov8.urdf",
    ),
    # a torpedo AUV steered by its fins (aiauv_pin.controllers.torpedo_compiled)
    (
        "simulate",
        "--duration",
        "1",
        "--no-html",
        "--controller",
        "torpedo",
        "--vehicle",
        "{example_vehicles}/torpedo.urdf",
    ),
    ("rollout",),
    ("envs",),
)

_ROOT = Path(__file__).resolve().parents[2]  # the checkout (this file: aiauv_pin/tools/)
#: Environment variable naming the checkout's ``examples/vehicles`` folder for the workloads'
#: ``{example_vehicles}``: the examples are not installed, so a build in another Python's virtual
#: environment (:func:`build_with`) takes them from the checkout that started it.
EXAMPLES_VARIABLE = "AIAUV_ARCHIVE_EXAMPLE_VEHICLES"


def compiled_folders() -> list[str]:
    """The source folders (project paths, :func:`aiauv_hydro.numerics.jit.project_path`) of
    compiled functions."""
    return sorted({str(jit.project_path(f).parent) for f in jit._project_files()})


def _rollout_workload() -> None:
    """The README's batch rollout, shortened (two gains, 1 s), and the same with the midpoint
    method at 0.02 s (the batches of ``aiauv bench --only throughput``)."""
    import dataclasses

    import aiauv_pin
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.scenario.definition import PaperScenario, initial_state

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


def _envs_workload() -> None:
    """One step of each Gymnasium environment and of ``Vehicle.step`` (the batched step and the
    thrust matrix through the handle); nothing when the optional gymnasium is missing."""
    import numpy as np

    import aiauv_pin

    vehicle = aiauv_pin.load_vehicle()
    vehicle.step(vehicle.neutral_configuration(), np.zeros(vehicle.nv), np.zeros(15), 0.01)
    try:
        from aiauv_pin import envs
    except ImportError:
        return
    for task in envs.ENVIRONMENTS.values():
        env = task()
        env.reset(seed=0)
        env.step(np.zeros(env.action_space.shape))
        env.close()


def _run_workloads(out: Path) -> None:
    """Child process: run :data:`WORKLOADS` (the environment is set by :func:`build_here`)."""
    import aiauv_hydro.numerics.jit

    if not aiauv_hydro.numerics.jit.PORTABLE_TARGET:
        raise SystemExit(
            f"aiauv: error: numba does not compile for {prebuilt.PORTABLE_CPU_NAME} here "
            "(the host lacks it, or NUMBA_CPU_NAME is set): nothing portable to ship"
        )
    for number, workload in enumerate(WORKLOADS):
        if workload == ("rollout",):
            _rollout_workload()
            continue
        if workload == ("envs",):
            _envs_workload()
            continue
        # as a user runs it: the command in a process of its own, with this one's environment
        examples = os.environ.get(EXAMPLES_VARIABLE, str(_ROOT / "examples" / "vehicles"))
        workload = tuple(w.replace("{example_vehicles}", examples) for w in workload)
        command = [sys.executable, "-m", "aiauv_pin", *workload, "--out", str(out / f"run{number}")]
        code = subprocess.run(command, check=False).returncode
        if code != 0:
            raise SystemExit(f"aiauv: error: workload {' '.join(workload)} exited with {code}")


def pack(cache_dir: Path, archive: Path) -> int:
    """Pack the cache files numba wrote under ``cache_dir`` into ``archive``; return their number.

    Runs in the build's child process, whose ``NUMBA_CACHE_DIR`` is ``cache_dir``: the project's
    functions are in its folder :func:`aiauv_hydro.numerics.jit.cache_folder`, each at its source
    folder's project
    path (e.g. ``aiauv_pin/kernels``); the archive keeps those paths, so that they can be unpacked into
    the cache folder of any installation of the same sources.
    """
    import llvmlite.binding as llvm
    import numba

    folder = jit.cache_folder()  # this process's: the build's child, whose cache is cache_dir
    if not folder.is_relative_to(cache_dir):
        raise SystemExit(f"aiauv: error: the project's cache {folder} is not in {cache_dir}")
    outside = [p for p in cache_dir.rglob("*") if p.is_file() and not p.is_relative_to(folder)]
    if outside:
        raise SystemExit(f"aiauv: error: numba cached functions outside the project: {outside[0]}")
    known = set(compiled_folders())
    entries = []
    for file in sorted(folder.rglob("*")) if folder.is_dir() else []:
        if file.suffix not in (".nbi", ".nbc"):
            continue
        name = file.relative_to(folder).as_posix()
        if name.rpartition("/")[0] not in known:
            raise SystemExit(f"aiauv: error: a cache file of no compiled source folder: {file}")
        entries.append((name, file))
    if not any(name.endswith(".nbi") for name, _ in entries):
        raise SystemExit("aiauv: error: the workloads left numba's cache empty")
    manifest = prebuilt.Manifest(
        source_hash=source_hash(),
        numba=numba.__version__,
        python_tag=prebuilt.python_tag(),
        triple=llvm.get_process_triple(),
        cpu_name=prebuilt.PORTABLE_CPU_NAME,
        workloads=tuple(" ".join(w) for w in WORKLOADS),
    )
    from aiauv_pin._internal.atomic import atomic_path

    archive.parent.mkdir(parents=True, exist_ok=True)
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
        code = [sys.executable, "-m", "aiauv_pin.tools.kernel_archive", "--workloads", temporary]
        subprocess.run([*code, "--archive", str(archive)], env=env, check=True)
    with zipfile.ZipFile(archive) as packed:
        count = len(packed.namelist()) - 1  # the manifest
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
        check = "from aiauv_hydro.numerics.jit import source_hash; print(source_hash())"
        installed = subprocess.run(
            [str(interpreter), "-c", check], check=True, capture_output=True, text=True,
            cwd=temporary,
        ).stdout.strip()  # fmt: skip
        if installed != source_hash():
            raise SystemExit(
                f"aiauv: error: the copy installed for {python} hashes differently from this "
                "checkout (a compiled source not packaged?)"
            )
        build = [
            str(interpreter),
            "-m",
            "aiauv_pin.tools.kernel_archive",
            "--out-dir",
            str(out_dir),
        ]
        examples = {**os.environ, EXAMPLES_VARIABLE: str(_ROOT / "examples" / "vehicles")}
        subprocess.run(build, check=True, cwd=temporary, env=examples)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m aiauv_pin.tools.kernel_archive",
        description="Build the compiled kernels shipped in aiauv_pin/kernels/shipped/ "
        "(one archive per Python).",
    )
    parser.add_argument(
        "--python", nargs="+", metavar="EXE", help="build for these Python interpreters instead"
    )
    parser.add_argument(
        "--out-dir", type=Path, default=prebuilt.archive_path().parent, help="where archives go"
    )
    parser.add_argument("--workloads", type=Path, help=argparse.SUPPRESS)  # the child's part
    parser.add_argument("--archive", type=Path, help=argparse.SUPPRESS)  # the child's output
    args = parser.parse_args(argv)
    if args.workloads is not None:
        _run_workloads(args.workloads)
        pack(Path(os.environ["NUMBA_CACHE_DIR"]).resolve(), args.archive)
        return 0
    if args.python:
        for python in args.python:
            build_with(python, args.out_dir.resolve())
    else:
        build_here(args.out_dir.resolve())
    return 0


if __name__ == "__main__":
    sys.exit(main())
