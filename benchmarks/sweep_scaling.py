"""Sweep throughput: runs per minute of :func:`aiauv_pin.scenario.sweep_runner.run_sweep` with 1,
2, ... workers.

For each worker count, the local cluster of :func:`aiauv_pin.scenario.sweep_runner.dask_client` (one worker
process running that many runs at once on its threads) is started and warmed up (the worker loads
the vehicle and runs one short simulation, so imports and compiled kernels are not counted; the
other threads still load their own copy of the vehicle in their first run); then the same sweep of
``--runs`` path-following runs (``--duration`` s of simulated time each, the cross-track gain
varied so that every run differs) is run through ``run_sweep`` into a fresh folder, records and
table included. Cluster start-up is reported
separately. The result is written atomically as JSON::

    python benchmarks/sweep_scaling.py --runs 8 --duration 30 --workers 1 2
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from aiauv_pin._internal.atomic import write_text
from aiauv_pin.model.loading import bundled_urdf
from aiauv_pin.scenario.defaults import DEFAULT_DT, DEFAULT_METHOD
from aiauv_pin.scenario.sweep_runner import dask_client, execute_run, run_sweep
from aiauv_pin.scenario.sweep_spec import file_sha256, sweep_spec_from_dict


def _warm_up(duration: float) -> None:
    """Load the vehicle and run one short simulation in this (worker) process."""
    path = bundled_urdf("uniform")
    spec = sweep_spec_from_dict({"duration": duration})
    point = spec.points()[0]
    execute_run(point.run_id, point.parameters, path.read_text(encoding="utf-8"), file_sha256(path))


def measure(workers: int, runs: int, duration: float, dt: float, method: str) -> dict:
    """Time one sweep of ``runs`` runs on a warmed-up local cluster of ``workers`` processes."""
    start = time.perf_counter()
    with dask_client(workers=workers) as client:
        startup = time.perf_counter() - start
        client.run(_warm_up, 1.0)
        spec = sweep_spec_from_dict(
            {
                "duration": duration,
                "dt": dt,
                "method": method,
                "grid": {"k_e": [float(x) for x in np.linspace(0.03, 0.1, runs)]},
            }
        )
        with tempfile.TemporaryDirectory() as folder:
            begin = time.perf_counter()
            report = run_sweep(
                spec,
                Path(folder) / "out",
                scheduler=client.scheduler.address,
                progress=False,
                plots=False,
            )
            elapsed = time.perf_counter() - begin
    if report.counts["complete"] != runs:
        raise RuntimeError(f"expected {runs} complete runs, got {report.counts}")
    return {
        "workers": workers,
        "runs": runs,
        "elapsed_s": elapsed,
        "runs_per_minute": 60.0 * runs / elapsed,
        "cluster_startup_s": startup,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=8, help="runs per sweep (8)")
    parser.add_argument("--duration", type=float, default=30.0, help="simulated time [s] (30)")
    parser.add_argument(
        "--dt", type=float, default=DEFAULT_DT, help=f"integration step [s] ({DEFAULT_DT:g})"
    )
    parser.add_argument(
        "--method", choices=("rk4", "euler"), default=DEFAULT_METHOD, help=f"({DEFAULT_METHOD})"
    )
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="(1 2)")
    parser.add_argument(
        "--out",
        type=Path,
        default=Path(__file__).parent / "sweep_scaling.json",
        help="JSON file (benchmarks/sweep_scaling.json)",
    )
    args = parser.parse_args(argv)
    results = []
    for workers in args.workers:
        result = measure(workers, args.runs, args.duration, args.dt, args.method)
        results.append(result)
        print(
            f"{workers} worker(s): {args.runs} runs of {args.duration:g} s in "
            f"{result['elapsed_s']:.1f} s -> {result['runs_per_minute']:.1f} runs/min "
            f"(cluster start {result['cluster_startup_s']:.1f} s)"
        )
    base = results[0]["runs_per_minute"] / results[0]["workers"]
    for result in results:
        result["speedup_over_one_worker"] = result["runs_per_minute"] / base
        result["parallel_efficiency"] = result["speedup_over_one_worker"] / result["workers"]
    import dask
    import distributed

    content = {
        "benchmark": "sweep_scaling",
        "duration_s": args.duration,
        "dt_s": args.dt,
        "method": args.method,
        "machine": {
            "cpus": os.cpu_count(),
            "usable_cpus": len(os.sched_getaffinity(0)),
            "platform": platform.platform(),
            "python": platform.python_version(),
            "dask": dask.__version__,
            "distributed": distributed.__version__,
        },
        "results": results,
    }
    write_text(args.out, json.dumps(content, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
