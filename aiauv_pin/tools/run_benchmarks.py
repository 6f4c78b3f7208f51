"""Benchmarks of whole runs (``aiauv bench --only ...``): batches, end to end, first run, accuracy per cost.

* :func:`throughput`: runs per minute of the 300 s paper scenario on this machine, interleaved in
  rounds: a sweep on the Dask cluster of earlier versions (one single-threaded worker process per
  core), the local sweep of this version (one worker process, one thread per core, see
  :mod:`aiauv_pin.scenario.sweep_runner`) and :func:`aiauv_pin.rollout` in this process
  (arrays only, no summary);
  both clusters are started and warmed up before the first round.
* :func:`end_to_end`: wall time of fresh ``aiauv simulate`` processes (warm numba cache), with and
  without the playback page, interleaved.
* :func:`memory`: peak resident memory of fresh processes simulating chains of 9 to 127 links.
* :func:`first_run`: CPU and wall time of a new installation's first run (empty numba cache), with
  the kernels shipped with the package and, interleaved, with everything compiled.
* :func:`accuracy_per_cost`: the largest end-effector distance over the whole path between each
  method and step and a converged reference (RK4 at a small step and at twice it, extrapolated to
  a zero step, checked against the midpoint method at the small step), and the CPU time of each
  run.

Every figure is reported as the median and range of its repeats (the machine is shared).
"""

from __future__ import annotations

import math
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np


def _spread(values: list[float]) -> dict:
    return {
        "median": statistics.median(values),
        "min": min(values),
        "max": max(values),
        "all": values,
    }


# ---------------------------------------------------------------------- throughput
def _process_cpu() -> float:
    """User plus system CPU time of this process, all threads [s]."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _warm(duration: float) -> str:
    """One short run in a worker thread (loads the compiled code and this thread's vehicle)."""
    from aiauv_pin.model.loading import bundled_urdf
    from aiauv_pin.scenario.sweep_runner import execute_run
    from aiauv_pin.scenario.sweep_spec import file_sha256, sweep_spec_from_dict

    path = bundled_urdf("uniform")
    point = sweep_spec_from_dict({"duration": duration}).points()[0]
    record = execute_run(
        point.run_id, point.parameters, path.read_text(encoding="utf-8"), file_sha256(path)
    )
    return record["status"]


#: The sparse rollout's log period in steps: every 10th step, the CSV's 0.04 s at the default step.
ROLLOUT_SPARSE_LOG = 10

#: The midpoint method's step in the batches [s]: the largest divisor of the CSV's 0.04 s within
#: its stability on the paper's vehicles (0.025 s holds, 0.03 s does not on the uniform one), and
#: its sparse log period in steps (0.04 s).
ROLLOUT_MIDPOINT_DT = 0.02
ROLLOUT_MIDPOINT_SPARSE_LOG = 2


def throughput(
    case: str = "uniform", duration: float = 300.0, runs: int = 8, rounds: int = 3, cores: int = 2
) -> dict:
    """Runs per minute of ``runs`` paper-scenario runs (cross-track gain varied): the sweep in
    processes and in threads, and :func:`aiauv_pin.rollout` logging every step (its default) and
    every :data:`ROLLOUT_SPARSE_LOG` th step (the CSV's 0.04 s at the default step); and the same
    rollouts with the midpoint method at :data:`ROLLOUT_MIDPOINT_DT` (not the default: see the
    README's accuracy per cost)."""
    import logging

    from dask.distributed import Client, LocalCluster

    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.definition import Scenario, initial_state
    from aiauv_pin.scenario.sweep_runner import run_sweep
    from aiauv_pin.scenario.sweep_spec import sweep_spec_from_dict
    from aiauv_pin.simulation.rollout import rollout

    gains = [float(x) for x in np.linspace(0.03, 0.1, runs)]
    spec = sweep_spec_from_dict({"case": case, "duration": duration, "grid": {"k_e": gains}})
    vehicle = loading.load_vehicle(loading.bundled_urdf(case))
    scenario = Scenario(case=case, duration=duration)
    q0, v0 = initial_state(vehicle, scenario)
    base = scenario.controller_gains

    def laws():
        return [VehiclePathFollowing(vehicle, replace(base, k_e=(k, k))).compiled() for k in gains]

    clusters = {
        "sweep_processes": LocalCluster(
            n_workers=cores,
            threads_per_worker=1,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ),
        "sweep_threads": LocalCluster(
            n_workers=1,
            threads_per_worker=cores,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        ),
    }
    times: dict[str, list[float]] = {
        "sweep_processes": [],
        "sweep_threads": [],
        "rollout": [],
        "rollout_sparse_log": [],
        "rollout_midpoint": [],
        "rollout_midpoint_sparse_log": [],
    }
    # CPU time [s] of each rollout batch (this process's user + system time: the stable figure on
    # a shared machine, where wall time depends on the other processes)
    cpu: dict[str, list[float]] = {name: [] for name in times if name.startswith("rollout")}
    try:
        for cluster in clusters.values():
            with Client(cluster) as client:
                statuses = client.gather(
                    [client.submit(_warm, 1.0, pure=False) for _ in range(2 * cores)]
                )
                assert set(statuses) == {"complete"}, statuses
        rollout(
            vehicle, q0, v0, 1.0, scenario.dt, laws()[:cores], method=scenario.method, threads=cores
        )
        rollout(
            vehicle,
            q0,
            v0,
            1.0,
            ROLLOUT_MIDPOINT_DT,
            laws()[:cores],
            method="midpoint",
            threads=cores,
        )
        for _ in range(rounds):
            for name, cluster in clusters.items():
                with tempfile.TemporaryDirectory() as folder:
                    start = time.perf_counter()
                    report = run_sweep(
                        spec,
                        Path(folder) / "out",
                        scheduler=cluster.scheduler_address,
                        progress=False,
                        plots=False,
                    )
                    times[name].append(time.perf_counter() - start)
                if report.counts["complete"] != runs:
                    raise RuntimeError(
                        f"{name}: expected {runs} complete runs, got {report.counts}"
                    )
            for name, method, dt, log_every in (
                ("rollout", scenario.method, scenario.dt, 1),
                ("rollout_sparse_log", scenario.method, scenario.dt, ROLLOUT_SPARSE_LOG),
                ("rollout_midpoint", "midpoint", ROLLOUT_MIDPOINT_DT, 1),
                (
                    "rollout_midpoint_sparse_log",
                    "midpoint",
                    ROLLOUT_MIDPOINT_DT,
                    ROLLOUT_MIDPOINT_SPARSE_LOG,
                ),
            ):
                controllers = laws()
                cpu_start = _process_cpu()
                start = time.perf_counter()
                batch = rollout(
                    vehicle,
                    q0,
                    v0,
                    duration,
                    dt,
                    controllers,
                    method=method,
                    threads=cores,
                    log_every=log_every,
                )
                times[name].append(time.perf_counter() - start)
                cpu[name].append(_process_cpu() - cpu_start)
                if not (batch.status == "complete").all():
                    raise RuntimeError(f"{name}: a run diverged")
                del batch  # up to 57 MB per run, freed before the next batch
    finally:
        for cluster in clusters.values():
            cluster.close()
    results = {
        "case": case,
        "duration_s": duration,
        "dt_s": scenario.dt,
        "method": scenario.method,
        "runs_per_round": runs,
        "rounds": rounds,
        "cores": cores,
        "rollout_sparse_log_every": ROLLOUT_SPARSE_LOG,
        "rollout_midpoint_dt_s": ROLLOUT_MIDPOINT_DT,
        "rollout_midpoint_sparse_log_every": ROLLOUT_MIDPOINT_SPARSE_LOG,
    }
    for name, walls in times.items():
        results[name] = {
            "wall_s": _spread(walls),
            "runs_per_minute": _spread([60.0 * runs / w for w in walls]),
        }
        if name in cpu:
            results[name]["cpu_per_run_s"] = _spread([c / runs for c in cpu[name]])
            # what ``cores`` idle cores would give: cores x 60 s / CPU per run
            results[name]["runs_per_minute_idle_cores"] = _spread(
                [60.0 * cores * runs / c for c in cpu[name]]
            )
    results["ratio_sweep_threads_to_processes"] = (
        results["sweep_threads"]["runs_per_minute"]["median"]
        / results["sweep_processes"]["runs_per_minute"]["median"]
    )
    results["ratio_rollout_to_sweep_processes"] = (
        results["rollout"]["runs_per_minute"]["median"]
        / results["sweep_processes"]["runs_per_minute"]["median"]
    )
    return results


# ---------------------------------------------------------------------- end to end
def _simulate_command(
    case: str, duration: float, out: Path, html: bool, figures: bool = True
) -> list[str]:
    command = [sys.executable, "-m", "aiauv_pin.app.cli", "simulate", "--case", case]
    command += ["--duration", f"{duration:g}", "--quiet", "--out", str(out)]
    command += [] if html else ["--no-html"]
    return command if figures else [*command, "--no-figures"]


#: A fresh process that starts numba and calls one trivial function from its warm on-disk cache:
#: the least any run of numba-compiled code costs before it computes anything (``end_to_end``).
_NUMBA_FLOOR_SCRIPT = """\
import numba
import numpy


@numba.njit(cache=True)
def total(x):
    s = 0.0
    for i in range(x.shape[0]):
        s += x[i]
    return s


total(numpy.ones(3))
"""

#: The floor of a run of a vehicle: :data:`_NUMBA_FLOOR_SCRIPT`, numba started as this package
#: starts it (without ``scipy.linalg``: :mod:`aiauv_pin._internal.numba_blas`, loaded from its file
#: alone, ``NUMBA_BLAS`` in ``results.json``), Pinocchio, which reads every vehicle, imported, and
#: the interpreter ended as ``aiauv`` ends it (``os._exit`` once the output is flushed, without
#: the teardown of every module, 0.1-0.17 s with numba loaded, which numba's floor pays).
_RUN_FLOOR_SCRIPT = (
    """\
import importlib.util

spec = importlib.util.spec_from_file_location("numba_blas", {numba_blas!r})
spec.loader.exec_module(importlib.util.module_from_spec(spec))

"""
    + _NUMBA_FLOOR_SCRIPT.replace("import numpy\n", "import numpy\nimport pinocchio\n")
    + """
import os
import sys

sys.stdout.flush()
os._exit(0)
"""
)


def _run_floor_script() -> str:
    from aiauv_pin._internal import numba_blas

    return _RUN_FLOOR_SCRIPT.format(numba_blas=numba_blas.__file__)


#: The run whose figures are drawn for the figures' layout alone [s]: a few samples of the
#: scenario, the same figures (panels, scales, labels, legends) with almost no data.
_LAYOUT_SECONDS = 0.02


def _loop_and_figures(case: str, duration: float, repeats: int, folder: Path) -> dict:
    """In this (warm) process, with nothing else running in it: the wall time of the simulation
    loop of ``aiauv simulate`` alone (``simulate`` of the same plan, loaded and compiled
    beforehand, as the command's ``wall_time``), and of its figures drawn as the command draws
    them (:func:`~aiauv_pin.results.outputs.write_figures`, two processes), from the run and from a
    :data:`_LAYOUT_SECONDS` run of the same scenario (their layout: panels, ticks, text, the PNG
    files); each ``repeats`` times after an untimed round."""
    import warnings

    from aiauv_pin.model import loading
    from aiauv_pin.results.outputs import write_figures
    from aiauv_pin.scenario.definition import Scenario, finish_run, plan_run
    from aiauv_pin.simulation.fixed_step import simulate

    vehicle = loading.load_vehicle(loading.bundled_urdf(case))

    def run(seconds: float):
        plan = plan_run(vehicle, Scenario(case=case, duration=seconds))
        simulate(*plan.arguments, **plan.options, compile_only=True)
        start = time.perf_counter()
        trajectory = simulate(*plan.arguments, **plan.options)
        wall = time.perf_counter() - start
        with warnings.catch_warnings():  # a run of a few samples may warn (settling, oscillation)
            warnings.simplefilter("ignore")
            return finish_run(plan, trajectory, wall), wall

    loops = []
    for k in range(repeats + 1):  # the first round untimed; the last run's result is drawn
        result, wall = run(duration)
        loops += [wall] if k else []
    layout, _ = run(_LAYOUT_SECONDS)

    def figures(of, name: str) -> float:
        start = time.perf_counter()
        write_figures(of, folder / name, parallel=True)
        return time.perf_counter() - start

    drawn, empty = [], []
    for k in range(repeats + 1):  # interleaved; the first round untimed (matplotlib's start)
        drawn.append(figures(result, f"figures-{k}"))
        empty.append(figures(layout, f"layout-{k}"))
    return {
        "loop_alone_s": _spread(loops),
        "figures_s": _spread(drawn[1:]),
        "figure_layout_s": _spread(empty[1:]),
        "figures": len(list((folder / "figures-0").iterdir())),
    }


def end_to_end(case: str = "uniform", duration: float = 300.0, repeats: int = 5) -> dict:
    """Wall time of fresh ``aiauv simulate`` processes (warm cache), with and without playback,
    and without playback and figures (``--no-figures``), interleaved; plus a fresh
    ``python -c "import aiauv_pin"`` for the import share, and two floors: a fresh
    ``python -c "import numpy"``, and a fresh process that calls one trivial numba function from
    its warm cache (numba's own start: its import and the set-up of its
    compiler target, which loading any cached function needs). Warm means numba's cache and
    Python's bytecode cache in place (the untimed first round writes both), as in an installed
    copy.

    ``breakdown`` splits each run's wall time with its own ``summary.json``: ``setup_s`` (vehicle
    loading and the compiled code's loading, ``setup_time``), ``simulation_s`` (``wall_time``), and
    ``rest_s``, the remainder: start-up and imports (about ``import_only``), writing the files
    (CSV, summary, figures, page) and the exit.
    """
    import json
    import os

    walls: dict[str, list[float]] = {
        "no_html": [],
        "no_figures": [],
        "with_html": [],
        "import_only": [],
        "numpy_floor": [],
        "numba_floor": [],
        "run_floor": [],
    }
    parts: dict[str, dict[str, list[float]]] = {
        name: {"setup_s": [], "simulation_s": [], "rest_s": []}
        for name in ("no_html", "no_figures", "with_html")
    }
    with tempfile.TemporaryDirectory() as folder:
        base = Path(folder)
        outs = {"no_html": base / "a", "with_html": base / "b", "no_figures": base / "c"}
        floor_script = base / "numba_floor.py"
        floor_script.write_text(_NUMBA_FLOOR_SCRIPT, encoding="utf-8")
        run_floor_script = base / "run_floor.py"
        run_floor_script.write_text(_run_floor_script(), encoding="utf-8")
        commands = {
            "no_html": _simulate_command(case, duration, outs["no_html"], html=False),
            "no_figures": _simulate_command(
                case, duration, outs["no_figures"], html=False, figures=False
            ),
            "with_html": _simulate_command(case, duration, outs["with_html"], html=True),
            "import_only": [sys.executable, "-c", "import aiauv_pin.app.cli"],
            "numpy_floor": [sys.executable, "-c", "import numpy"],
            "numba_floor": [sys.executable, str(floor_script)],
            "run_floor": [sys.executable, str(run_floor_script)],
        }
        # warm as an installed copy is: Python's bytecode cached too (PYTHONDONTWRITEBYTECODE, set
        # in some shells and containers, made every run of an editable checkout compile its ~115
        # modules again, about 0.15 s that no installed copy pays: pip writes the .pyc files);
        # the floor's cache in the temporary folder (the project's cache is left as it is)
        warm_env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        floor_env = {**warm_env, "NUMBA_CACHE_DIR": str(base / "numba-cache")}
        envs = {name: (floor_env if "floor" in name else warm_env) for name in commands}
        for name, command in commands.items():  # one untimed run each (page cache, numba cache)
            subprocess.run(command, capture_output=True, check=True, cwd=base, env=envs[name])
        for _ in range(repeats):
            for name, command in commands.items():
                start = time.perf_counter()
                subprocess.run(command, capture_output=True, check=True, cwd=base, env=envs[name])
                walls[name].append(time.perf_counter() - start)
                if name in parts:
                    summary = json.loads((outs[name] / "summary.json").read_text(encoding="utf-8"))
                    parts[name]["setup_s"].append(summary["setup_time"])
                    parts[name]["simulation_s"].append(summary["wall_time"])
                    rest = walls[name][-1] - summary["setup_time"] - summary["wall_time"]
                    parts[name]["rest_s"].append(rest)
        alone = _loop_and_figures(case, duration, repeats, base / "in-process")
    # in each round, what a run costs before and beside anything of ours: the run floor (numba
    # started as we start it, Pinocchio imported) then the loop alone, and, with figures, then the
    # figures' layout on two processes
    loop, layout = alone["loop_alone_s"]["median"], alone["figure_layout_s"]["median"]
    pairs = list(zip(walls["run_floor"], walls["numba_floor"], strict=True))
    bounds = {
        "no_figures": _spread([(p + loop) / f for p, f in pairs]),
        "no_html": _spread([(p + loop + layout) / f for p, f in pairs]),
    }
    return {
        "case": case,
        "duration_s": duration,
        "repeats": repeats,
        "commands": {
            name: "aiauv " + " ".join(c[3:]).replace(str(base), "DIR")
            if "aiauv_pin.app.cli" in c[:3]
            else "python " + " ".join(c[1:]).replace(str(base), "DIR")
            for name, c in commands.items()
        },
        "numba_floor_script": _NUMBA_FLOOR_SCRIPT,
        **{f"{name}_wall_s": _spread(w) for name, w in walls.items()},
        # each run over the floor of its own round (the runs are interleaved)
        "ratio_to_numba_floor": {
            name: _spread([w / f for w, f in zip(walls[name], walls["numba_floor"], strict=True)])
            for name in ("no_html", "no_figures", "with_html")
        },
        "breakdown": {
            name: {part: _spread(values) for part, values in split.items()}
            for name, split in parts.items()
        },
        "run_floor_script": _RUN_FLOOR_SCRIPT.replace("{numba_blas!r}", "NUMBA_BLAS"),
        "in_process": alone,
        "bound_to_numba_floor": bounds,
    }


# ---------------------------------------------------------------------- memory
#: The links of :func:`memory`'s chains (:func:`aiauv_pin.tools.native_benchmarks.chain_spec`):
#: the paper's 9, and the scaling figure's 65 and 127.
MEMORY_LINKS = (9, 65, 127)

#: The peak resident set of this process [MiB]: ``VmHWM`` of ``/proc/self/status`` (proc(5)),
#: the high-water mark of this address space. ``ru_maxrss`` is not used: Linux carries it over
#: ``fork`` and ``exec``, so a child reports at least the (large) benchmark process's peak.
_PEAK = (
    "def peak():\n"
    "    for line in open('/proc/self/status'):\n"
    "        if line.startswith('VmHWM:'):\n"
    "            return int(line.split()[1]) / 1024\n"
)

#: A fresh process: load a vehicle, run it compiled (passive, no controller), print its peak
#: resident set [MiB] and a digest of the trajectory (the same on every run).
_MEMORY_SCRIPT = (
    _PEAK
    + """\
import hashlib, json, sys
import numpy as np
import aiauv_pin
vehicle = aiauv_pin.load_vehicle(sys.argv[1])
q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
run = aiauv_pin.simulate(vehicle, q0, v0, float(sys.argv[2]), 0.01)
digest = hashlib.sha256(np.ascontiguousarray(run.q).tobytes() + np.ascontiguousarray(run.v).tobytes())
print(json.dumps({
    "peak_mib": peak(),
    "backend": vehicle.active_backend,
    "trajectory_sha256": digest.hexdigest(),
}))
"""
)


def memory(links: tuple[int, ...] = MEMORY_LINKS, duration: float = 10.0, repeats: int = 3) -> dict:
    """Peak resident memory [MiB] of a fresh process that loads a chain of ``links`` modules
    (built by :mod:`aiauv_pin.builders`, as ``aiauv build`` does) and simulates ``duration``
    seconds compiled, interleaved over ``repeats`` rounds; and the floor, a fresh
    ``python -c "import aiauv_pin"`` (numpy, numba and Pinocchio imported)."""
    import json

    from aiauv_pin.builders.urdf_builder import build_urdf
    from aiauv_pin.builders.vehicle_spec import spec_from_dict
    from aiauv_pin.tools.native_benchmarks import chain_spec

    import_only = [sys.executable, "-c", _PEAK_OF_IMPORT]
    peaks: dict[str, list[float]] = {"import_only": [], **{str(n): [] for n in links}}
    digests: dict[str, set[str]] = {str(n): set() for n in links}
    backends: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as folder:
        commands = {"import_only": import_only}
        for n in links:
            urdf = Path(folder) / f"chain{n}.urdf"
            urdf.write_text(build_urdf(spec_from_dict(chain_spec(n))), encoding="utf-8")
            commands[str(n)] = [sys.executable, "-c", _MEMORY_SCRIPT, str(urdf), f"{duration:g}"]
        for _ in range(repeats):
            for name, command in commands.items():
                done = subprocess.run(command, capture_output=True, text=True, check=True)
                row = json.loads(done.stdout.strip().splitlines()[-1])
                peaks[name].append(row["peak_mib"])
                if name in digests:
                    digests[name].add(row["trajectory_sha256"])
                    backends[name] = row["backend"]
    return {
        "duration_s": duration,
        "repeats": repeats,
        "import_only_peak_mib": _spread(peaks["import_only"]),
        "rows": [
            {
                "links": n,
                "backend": backends[str(n)],
                "peak_mib": _spread(peaks[str(n)]),
                "trajectory_sha256": sorted(digests[str(n)]),
            }
            for n in links
        ],
    }


_PEAK_OF_IMPORT = _PEAK + "import json\nimport aiauv_pin\nprint(json.dumps({'peak_mib': peak()}))\n"


# ---------------------------------------------------------------------- first run
def first_run(case: str = "uniform", repeats: int = 3, compile_repeats: int = 2) -> dict:
    """A new installation's first ``aiauv simulate --duration 1 --no-html``: CPU and wall time.

    Each run is a fresh process with an empty numba cache (``NUMBA_CACHE_DIR``), as in a new
    virtual environment, and numba's default settings (no ``NUMBA_CPU_*``): ``shipped`` unpacks
    the kernels shipped with the package (:mod:`aiauv_hydro.numerics.kernel_cache`); ``compiled``,
    the comparator,
    has them switched off (``AIAUV_PREBUILT_KERNELS=0``) and compiles everything. The two are
    interleaved; ``compiled`` runs ``compile_repeats`` times only (about a minute each). CPU time
    is the child's user and system time; ``functions_compiled`` counts the compiled functions
    numba saved to its cache (``NUMBA_DEBUG_CACHE``).
    """
    import resource

    from aiauv_pin.simulation.compilation import default_target_environment

    base_env = default_target_environment()
    variants = {"shipped": {}, "compiled": {"AIAUV_PREBUILT_KERNELS": "0"}}
    measured = {name: {"cpu_s": [], "wall_s": [], "functions_compiled": []} for name in variants}
    with tempfile.TemporaryDirectory() as folder:
        for repeat in range(repeats):
            for name, extra in variants.items():
                if name == "compiled" and repeat >= compile_repeats:
                    continue
                run = Path(folder) / f"{name}{repeat}"
                env = {**base_env, **extra, "NUMBA_DEBUG_CACHE": "1"}
                env["NUMBA_CACHE_DIR"] = str(run / "cache")
                command = _simulate_command(case, 1.0, run / "out", html=False)
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                start = time.perf_counter()
                done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=folder)
                wall = time.perf_counter() - start
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                if done.returncode != 0:
                    from aiauv_pin.errors import AiauvError

                    said = (done.stderr.strip().splitlines() or ["no message"])[-1]
                    raise AiauvError(f"first run ({name}) failed: {said}")
                cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
                measured[name]["cpu_s"].append(cpu)
                measured[name]["wall_s"].append(wall)
                output = done.stdout + done.stderr
                measured[name]["functions_compiled"].append(output.count("data saved"))
    from aiauv_hydro.numerics import kernel_cache as prebuilt

    return {
        "case": case,
        "command": "aiauv simulate --duration 1 --no-html (empty NUMBA_CACHE_DIR)",
        "shipped_archive": prebuilt.archive_path().name,
        **{
            name: {
                "cpu_s": _spread(values["cpu_s"]),
                "wall_s": _spread(values["wall_s"]),
                "functions_compiled": values["functions_compiled"],
            }
            for name, values in measured.items()
        },
        "cpu_ratio_shipped_to_compiled": statistics.median(measured["shipped"]["cpu_s"])
        / statistics.median(measured["compiled"]["cpu_s"]),
    }


# ---------------------------------------------------------------------- accuracy per cost
#: Largest end-effector distance [m] from the converged path over the whole 300 s run that the
#: scenario's default step may have (the default is the cheapest setting within it).
ACCURACY_TARGET = 0.002

#: Factors by which :func:`accuracy_per_cost` scales the paper's attitude gains ``k_p, k_d``
#: (eq. 23, the loop that curves the body) to find a setting's gain margin [-].
MARGIN_FACTORS = (1.0, 1.25, 1.5, 2.0, 2.5, 3.0)

#: Gain margin the default step must keep on the paper's attitude loop [-]: 2 (6 dB), the low end
#: of the 2-5 asked of a feedback design (Astrom and Murray, *Feedback Systems*, 2nd ed., 2021,
#: ch. 10, stability margins). A step chosen for accuracy alone can sit just inside the stability
#: limit of the sampled loop, where a user's retuned gains make it oscillate at every sample.
MARGIN_TARGET = 2.0


def accuracy_per_cost(
    case: str = "uniform",
    duration: float = 300.0,
    candidates: tuple[tuple[str, float], ...] = (
        ("rk4", 0.02),
        ("rk4", 0.01),
        ("rk4", 0.008),
        ("rk4", 0.005),
        ("euler", 0.04),
        ("euler", 0.02),
        ("euler", 0.01),
        ("euler", 0.005),
        ("euler", 0.004),
        ("euler", 0.0025),
        ("euler", 0.001),
        ("midpoint", 0.04),
        ("midpoint", 0.02),
        ("midpoint", 0.01),
        ("midpoint", 0.004),
    ),
    reference_dt: float = 0.0005,
    repeats: int = 3,
    grid: float = 0.04,
    controller: str = "paper",
    current: tuple[float, float, float] = (0.0, 0.0, 0.0),
    margin_factors: tuple[float, ...] = MARGIN_FACTORS,
) -> dict:
    """End-effector error of each (method, step) against a converged reference, and the gain
    margin of the settings within the target.

    The controller is sampled at every integration step (the scenario's default; the midpoint
    method samples it at the middle of each step), so the errors include the effect of the
    sampling. Holding the controller over a step makes RK4's error first order in its step, so the
    reference is Richardson's extrapolation to a zero step of RK4 at ``reference_dt`` and at twice
    it, ``2 p(h) - p(2h)`` (e.g. Hairer, Norsett and Wanner 1993, Sec. II.9), which removes that
    first-order term (RK4 at ``reference_dt`` alone is ``u_d reference_dt / 2`` behind it along the
    path). ``reference_convergence_m`` is its largest distance from an independent estimate, the
    midpoint method (second order with the controller sampled at the middle of each step) at
    ``reference_dt``; ``reference_correction_m`` the size of the extrapolation, ``|p(h) - p(2h)|``.
    Paths are compared every ``grid`` seconds [s] (a multiple of every step).
    Costs are CPU seconds of the compiled run (median of ``repeats``, interleaved).

    ``controller`` is ``"paper"`` (the paper's path following) or ``"none"`` (a passive run);
    ``current`` a constant water velocity in the world [m/s]. Each row also gives the largest
    distance across the path (in the y-z plane; the rest is a lag along it). The result names the
    cheapest candidate within :data:`ACCURACY_TARGET` over the whole path (the rule for the
    default step) and whether it is the scenario's default (:mod:`aiauv_pin.scenario.defaults`,
    added to ``candidates`` if missing).

    With the paper's controller, each candidate within the target (and the default) also gets a
    ``gain_margin``: the largest of ``margin_factors`` up to which the run, with the attitude gains
    ``k_p, k_d`` (eq. 23) scaled by every factor, stays finite and free of an every-sample
    oscillation (:func:`aiauv_pin.simulation.step_stability.every_sample_oscillation` of the joint rates at
    most :data:`~aiauv_pin.simulation.step_stability.OSCILLATION_THRESHOLD`); ``None`` if it fails at the
    first factor. ``cheapest_robust`` is the cheapest candidate within the target whose margin is
    at least :data:`MARGIN_TARGET`, the rule the default follows (``default_follows_rule``).

    The margin depends on the method, not only on the controller's sample rate (a scalar model in
    :mod:`aiauv_pin.simulation.step_stability`'s docstring). Measured on the paper's uniform vehicle, 300 s:
    semi-implicit Euler at 0.004 s keeps a margin of 3 or more, the midpoint method at 0.02 s and at
    0.01 s oscillates at 1.25 (``benchmarks/default_step.json``), and at 0.004 s at 2.
    """
    from aiauv_pin.controllers.compiled_controller import CompiledController
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.errors import SimulationDiverged
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.defaults import DEFAULT_DT, DEFAULT_METHOD
    from aiauv_pin.scenario.definition import Scenario, initial_state, tip_frame
    from aiauv_pin.simulation.fixed_step import simulate
    from aiauv_pin.simulation.step_stability import OSCILLATION_THRESHOLD, every_sample_oscillation

    if controller not in ("paper", "none"):
        raise ValueError(f"accuracy_per_cost: controller must be paper or none, got {controller!r}")
    vehicle = loading.load_vehicle(loading.bundled_urdf(case))

    def scenario_run(method: str, dt: float, log_every: int, gain_scale: float = 1.0):
        """The scenario's run (as :func:`aiauv_pin.scenario.definition.run_scenario` runs it), with the
        attitude gains ``k_p, k_d`` scaled by ``gain_scale``, logged every ``log_every`` steps."""
        scenario = Scenario(
            case=case,
            duration=duration,
            dt=dt,
            method=method,
            controller=controller,
            current=tuple(current),
        )
        if controller == "paper":
            gains = scenario.controller_gains
            gains = replace(gains, k_p=gain_scale * gains.k_p, k_d=gain_scale * gains.k_d)
            law = VehiclePathFollowing(vehicle, gains, path=scenario.path_to_follow).compiled()
            servo = law.servo
        else:
            law, servo = CompiledController.passive(), None
        q0, v0 = initial_state(vehicle, scenario)
        return simulate(
            vehicle,
            q0,
            v0,
            duration,
            dt,
            law,
            method=method,
            servo=servo,
            current=scenario.water,
            log_every=log_every,
        )

    def gain_margin(method: str, dt: float) -> float | None:
        """The largest of ``margin_factors`` up to which the scaled loop converges (docstring)."""
        margin = None
        for factor in margin_factors:
            try:  # every step logged: one row per controller sample
                run = scenario_run(method, dt, 1, factor)
            except SimulationDiverged:
                break
            if every_sample_oscillation(np.asarray(run.v)[:, 6:]) > OSCILLATION_THRESHOLD:
                break
            margin = factor
        return margin

    def path(method: str, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The scenario's end-effector every ``grid`` seconds only (a 0.5 ms reference logged
        every step would take gigabytes)."""
        run = scenario_run(method, dt, max(1, round(grid / dt)))
        # the end-effector of the logged state: with the midpoint method a row's diagnostics (the
        # controller's measured p) are those of the sample half a step earlier
        frame = vehicle.frame_id(tip_frame(vehicle))
        return run.t, vehicle.fast.frame_positions(np.asarray(run.q), frame)

    reference_t, fine_p = path("rk4", reference_dt)
    coarse_t, coarse_p = path("rk4", 2 * reference_dt)
    check_t, check_p = path("midpoint", reference_dt)
    if not (np.allclose(coarse_t, reference_t, atol=1e-9) and np.allclose(check_t, reference_t)):
        raise RuntimeError("accuracy: the reference runs' log times differ")
    reference_p = 2.0 * fine_p - coarse_p  # Richardson: the first-order term removed

    def difference_to_reference(t: np.ndarray, p: np.ndarray) -> np.ndarray:
        """End-effector position minus the reference's at the same times [m] (n x 3)."""
        stride = round((t[1] - t[0]) / (reference_t[1] - reference_t[0]))
        fine = reference_p[::stride]
        if not np.allclose(reference_t[::stride], t, atol=1e-9):
            raise RuntimeError("accuracy: log times do not coincide with the reference's")
        return p - fine

    def error_against_reference(t: np.ndarray, p: np.ndarray) -> float:
        return float(np.linalg.norm(difference_to_reference(t, p), axis=1).max())

    default = (DEFAULT_METHOD, DEFAULT_DT)
    if not any(m == default[0] and math.isclose(dt, default[1]) for m, dt in candidates):
        candidates = (*candidates, default)
    rows = []
    cpu: dict[tuple[str, float], list[float]] = {c: [] for c in candidates}
    errors: dict[tuple[str, float], float | None] = {}
    # largest distance across the paper's path (the world x-axis: in the y-z plane) [m]
    across: dict[tuple[str, float], float] = {}
    for _ in range(repeats):
        for method, dt in candidates:
            if errors.get((method, dt), 0.0) is None:
                continue
            start = time.process_time()
            try:
                t, p = path(method, dt)
            except SimulationDiverged:
                errors[(method, dt)] = None
                continue
            cpu[(method, dt)].append(time.process_time() - start)
            difference = difference_to_reference(t, p)
            errors[(method, dt)] = float(np.linalg.norm(difference, axis=1).max())
            across[(method, dt)] = float(np.linalg.norm(difference[:, 1:], axis=1).max())
    rk4_cost = statistics.median(cpu[("rk4", 0.01)]) if cpu.get(("rk4", 0.01)) else None
    for method, dt in candidates:
        error = errors.get((method, dt))
        costs = cpu[(method, dt)]
        row = {"method": method, "dt": dt, "max_end_effector_error_m": error}
        if error is not None:
            row["max_across_path_error_m"] = across[(method, dt)]
        if error is not None and costs:
            row["cpu_s"] = _spread(costs)
            if rk4_cost:
                row["cost_relative_to_rk4_0.01"] = statistics.median(costs) / rk4_cost
        rows.append(row)
    reachable = [r for r in rows if r["max_end_effector_error_m"] is not None]
    within = [
        r for r in reachable if r["max_end_effector_error_m"] <= ACCURACY_TARGET and "cpu_s" in r
    ]
    cheapest = min(within, key=lambda r: r["cpu_s"]["median"]) if within else None
    robust = None
    if controller == "paper":
        for row in rows:
            is_default = row["method"] == default[0] and math.isclose(row["dt"], default[1])
            if row in within or is_default:
                row["gain_margin"] = gain_margin(row["method"], row["dt"])
        kept = [r for r in within if (r.get("gain_margin") or 0.0) >= MARGIN_TARGET]
        robust = min(kept, key=lambda r: r["cpu_s"]["median"]) if kept else None
    return {
        "case": case,
        "controller": controller,
        "current_m_s": [float(c) for c in current],
        "duration_s": duration,
        "reference": {"method": "rk4", "dt": reference_dt, "extrapolated_from": 2 * reference_dt},
        "reference_convergence_m": error_against_reference(check_t, check_p),
        "reference_correction_m": float(np.linalg.norm(fine_p - coarse_p, axis=1).max()),
        "target_m": ACCURACY_TARGET,
        "rows": rows,
        "default": {"method": default[0], "dt": default[1]},
        "cheapest_within_2mm": (
            None if cheapest is None else {"method": cheapest["method"], "dt": cheapest["dt"]}
        ),
        "cheapest_is_default": cheapest is not None
        and cheapest["method"] == default[0]
        and math.isclose(cheapest["dt"], default[1]),
        **(
            {}
            if controller != "paper"
            else {
                "margin_factors": list(margin_factors),
                "margin_target": MARGIN_TARGET,
                "cheapest_robust": (
                    None if robust is None else {"method": robust["method"], "dt": robust["dt"]}
                ),
                "default_follows_rule": robust is not None
                and robust["method"] == default[0]
                and math.isclose(robust["dt"], default[1]),
            }
        ),
    }


# ---------------------------------------------------------------------- table
def format_parts(results: dict) -> list[str]:
    """Lines of the table of ``aiauv bench`` for the parts measured here."""
    lines = []

    def spread(label: str, s: dict, unit: str, scale: float = 1.0) -> None:
        lines.append(
            f"{label:<48} {scale * s['median']:10.2f} {unit} "
            f"({scale * s['min']:.2f}-{scale * s['max']:.2f})"
        )

    tp = results.get("throughput")
    if tp:
        head = f"{tp['duration_s']:.0f} s runs/min on {tp['cores']} cores"
        spread(f"{head}: sweep, processes", tp["sweep_processes"]["runs_per_minute"], "")
        spread(f"{head}: sweep, threads", tp["sweep_threads"]["runs_per_minute"], "")
        spread(f"{head}: rollout()", tp["rollout"]["runs_per_minute"], "")
        if "cpu_per_run_s" in tp["rollout"]:
            spread(f"{head}: rollout(), CPU per run", tp["rollout"]["cpu_per_run_s"], "s")
            spread(
                f"{head}: rollout(), from CPU on idle cores",
                tp["rollout"]["runs_per_minute_idle_cores"],
                "",
            )
        if "rollout_sparse_log" in tp:
            spread(
                f"{head}: rollout(), log every {tp['rollout_sparse_log_every']}th step",
                tp["rollout_sparse_log"]["runs_per_minute"],
                "",
            )
        if "rollout_midpoint" in tp:
            midpoint = f"{head}: rollout(), midpoint dt={tp['rollout_midpoint_dt_s']:g}"
            spread(midpoint, tp["rollout_midpoint"]["runs_per_minute"], "")
            spread(
                f"{midpoint}, log every {tp['rollout_midpoint_sparse_log_every']}nd step",
                tp["rollout_midpoint_sparse_log"]["runs_per_minute"],
                "",
            )
    e2e = results.get("end_to_end")
    if e2e:
        spread("fresh 'aiauv simulate --no-html' wall", e2e["no_html_wall_s"], "s")
        if "no_figures_wall_s" in e2e:
            spread("fresh '... --no-html --no-figures' wall", e2e["no_figures_wall_s"], "s")
        spread("fresh 'aiauv simulate' (with playback) wall", e2e["with_html_wall_s"], "s")
        spread("fresh 'import aiauv_pin.app.cli' wall", e2e["import_only_wall_s"], "s")
        if "numba_floor_wall_s" in e2e:
            spread("floor: fresh 'import numpy' wall", e2e["numpy_floor_wall_s"], "s")
            spread("floor: fresh numba, one cached function", e2e["numba_floor_wall_s"], "s")
        if "run_floor_wall_s" in e2e:
            spread("floor of a run: no scipy.linalg, Pinocchio", e2e["run_floor_wall_s"], "s")
        for name, ratio in e2e.get("ratio_to_numba_floor", {}).items():
            spread(f"  {name} / numba floor (per round)", ratio, "x")
        alone = e2e.get("in_process")
        if alone:
            spread("simulation loop alone (in process)", alone["loop_alone_s"], "s")
            spread(f"{alone['figures']} figures, 2 processes (in process)", alone["figures_s"], "s")
            spread("  the same figures' layout (a few samples)", alone["figure_layout_s"], "s")
        for name, bound in e2e.get("bound_to_numba_floor", {}).items():
            what = "loop" if name == "no_figures" else "loop + layout"
            spread(f"  {name}: (run floor + {what}) / numba floor", bound, "x")
        labels = (
            ("no_html", "--no-html"),
            ("no_figures", "--no-figures"),
            ("with_html", "playback"),
        )
        for name, label in labels:
            for part, values in e2e.get("breakdown", {}).get(name, {}).items():
                spread(f"  {label}: {part[:-2]}", values, "s")
    mem = results.get("memory")
    if mem:
        spread("peak memory, fresh 'import aiauv_pin'", mem["import_only_peak_mib"], "MiB")
        for row in mem["rows"]:
            label = f"peak memory, {row['links']} links, {mem['duration_s']:g} s {row['backend']}"
            spread(label, row["peak_mib"], "MiB")
    first = results.get("first_run")
    if first:
        for name, label in (("shipped", "shipped kernels"), ("compiled", "all compiled")):
            spread(f"first run, empty cache, {label}: CPU", first[name]["cpu_s"], "s")
            spread(f"first run, empty cache, {label}: wall", first[name]["wall_s"], "s")
            compiled = ", ".join(str(n) for n in first[name]["functions_compiled"])
            lines.append(f"{'  functions compiled':<48} {compiled}")
        ratio = first["cpu_ratio_shipped_to_compiled"]
        lines.append(f"{'first run CPU, shipped / all compiled':<48} {ratio:10.3f}x")
    gym = results.get("gym")
    if gym and "note" in gym:
        lines.append(f"{'gym':<48} {gym['note']}")
    elif gym:
        from aiauv_pin.tools.gym_benchmarks import format_gym

        lines.extend(format_gym(results))
    acc = results.get("accuracy_per_cost")
    if acc:
        default = acc.get("default") or {}
        for r in acc["rows"]:
            error = r["max_end_effector_error_m"]
            is_default = r["method"] == default.get("method") and r["dt"] == default.get("dt")
            mark = " (default)" if is_default else ""
            label = f"EE error {r['method']} dt={r['dt']:g}{mark} vs converged"
            if error is None:
                lines.append(f"{label:<48} diverges")
            else:
                margin = ""
                if "gain_margin" in r:
                    value = r["gain_margin"]
                    margin = ", gain margin " + ("< 1" if value is None else f"{value:g}")
                lines.append(
                    f"{label:<48} {1000 * error:10.3f} mm, cost "
                    f"{r.get('cost_relative_to_rk4_0.01', float('nan')):.2f}x RK4 0.01{margin}"
                )
        if "cheapest_is_default" in acc:
            cheapest = acc.get("cheapest_within_2mm")
            text = "none" if cheapest is None else f"{cheapest['method']} dt={cheapest['dt']:g}"
            verdict = "is" if acc["cheapest_is_default"] else "is NOT"
            lines.append(f"{'cheapest within 2 mm':<48} {text} ({verdict} the default)")
        if "default_follows_rule" in acc:
            robust = acc.get("cheapest_robust")
            text = "none" if robust is None else f"{robust['method']} dt={robust['dt']:g}"
            verdict = "is" if acc["default_follows_rule"] else "is NOT"
            label = f"cheapest within 2 mm, gain margin >= {acc['margin_target']:g}"
            lines.append(f"{label:<48} {text} ({verdict} the default)")
    return lines
