"""Cost of the argument checks at the compiled entry points (issue 29), per call [us].

Pairs, measured interleaved (one block of each per round, so that load changes hit both alike):

* ``acceleration``: the compiled evaluation called through its cached entry point with no check
  at all (``acceleration_of``, what ``FastModel.acceleration`` ran before the checks), against the
  public, checked ``Vehicle.fast.acceleration`` and ``Vehicle.acceleration`` (the state checked
  inside the compiled call, :func:`aiauv_pin.kernels.handle.state_verdict`);
* ``step``: the same for one RK4 step (``step_of`` against ``Vehicle.fast.step``);
* the Python path: ``Vehicle.acceleration`` with a constant current (its arguments checked in
  Python, :mod:`aiauv_pin._internal.array_checks`), reported alone (run this script in another checkout to
  compare it).

Reports the median and the range (min to max) over ``--rounds`` rounds of ``--calls`` calls (CPU
time of the measuring thread), the
median of the per-round differences (checked minus unchecked), and the machine load
(``os.getloadavg``, before and after). Writes ``benchmarks/entry_checks.json``.

Run: ``python benchmarks/entry_checks.py [--rounds 21] [--calls 2000] [--no-write]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

import aiauv_pin
from aiauv_pin.kernels import handle as compiled_handle
from aiauv_pin.kernels.evaluation import METHOD_CODES, _entry_point


def _per_call(function, calls: int) -> float:
    """Mean CPU time of one call [us] over ``calls`` calls: the thread's own time
    (``time.thread_time``), so that time slices lost to other processes on a loaded machine do
    not count (the wall clock's spread was 2x at a load of 10 on 2 cores)."""
    start = time.thread_time()
    for _ in range(calls):
        function()
    return (time.thread_time() - start) / calls * 1e6


def _summary(samples: list[float]) -> dict:
    values = np.array(samples)
    return {
        "median_us": round(float(np.median(values)), 3),
        "min_us": round(float(values.min()), 3),
        "max_us": round(float(values.max()), 3),
    }


def measure(rounds: int, calls: int) -> dict:
    vehicle = aiauv_pin.load_vehicle()
    fast = vehicle.fast
    if fast is None:
        raise SystemExit(f"no compiled backend: {vehicle.fallback_reason}")
    rng = np.random.default_rng(1)
    q = vehicle.neutral_configuration()
    q[7:] = rng.uniform(-0.5, 0.5, vehicle.nq - 7)
    v, tau = 0.3 * rng.normal(size=vehicle.nv), rng.normal(size=vehicle.nv)
    current = np.array([0.2, 0.1, 0.0])
    nq, nv = vehicle.nq, vehicle.nv
    handle = fast.handle
    env, servo = fast.still_water, fast.no_servo

    rk4 = METHOD_CODES["rk4"]
    out = np.empty(nv)
    acceleration_args = (handle, env, servo, 0.0, q, v, tau, out)
    step_args = (handle, env, servo, 0.0, q, v, tau, 0.01, rk4, np.empty(nq), np.empty(nv))
    compiled_handle.acceleration_of(*acceleration_args)  # compiled (or loaded) for these types
    compiled_handle.step_of(*step_args)
    acceleration_entry = _entry_point(compiled_handle.acceleration_of, acceleration_args)
    step_entry = _entry_point(compiled_handle.step_of, step_args)

    def unchecked_acceleration():
        result = np.empty(nv)
        acceleration_entry(handle, env, servo, 0.0, q, v, tau, result)
        return result

    def unchecked_step():
        q_out, v_out = np.empty(nq), np.empty(nv)
        step_entry(handle, env, servo, 0.0, q, v, tau, 0.01, rk4, q_out, v_out)
        return q_out, v_out

    cases = {
        "acceleration unchecked (compiled entry point)": unchecked_acceleration,
        "acceleration checked (Vehicle.fast.acceleration)": lambda: fast.acceleration(q, v, tau),
        "acceleration checked (Vehicle.acceleration)": lambda: vehicle.acceleration(q, v, tau),
        "step unchecked (compiled entry point)": unchecked_step,
        "step checked (Vehicle.fast.step)": lambda: fast.step(q, v, tau, 0.01),
        "Python path (Vehicle.acceleration with a current)": lambda: vehicle.acceleration(
            q, v, tau, current
        ),
    }
    assert np.array_equal(unchecked_acceleration(), fast.acceleration(q, v, tau))
    assert all(
        np.array_equal(a, b)
        for a, b in zip(unchecked_step(), fast.step(q, v, tau, 0.01), strict=True)
    )
    for function in cases.values():  # warm up
        _per_call(function, 200)
    samples: dict[str, list[float]] = {name: [] for name in cases}
    load_before = os.getloadavg()
    for _ in range(rounds):
        for name, function in cases.items():
            samples[name].append(_per_call(function, calls))
    load_after = os.getloadavg()
    names = list(cases)
    overhead = {
        "acceleration (Vehicle.fast.acceleration - unchecked)": _summary(
            list(np.subtract(samples[names[1]], samples[names[0]]))
        ),
        "acceleration (Vehicle.acceleration - unchecked)": _summary(
            list(np.subtract(samples[names[2]], samples[names[0]]))
        ),
        "step (Vehicle.fast.step - unchecked)": _summary(
            list(np.subtract(samples[names[4]], samples[names[3]]))
        ),
    }
    return {
        "vehicle": vehicle.name,
        "nv": nv,
        "rounds": rounds,
        "calls_per_round": calls,
        "per_call": {name: _summary(values) for name, values in samples.items()},
        "check_overhead_per_round": overhead,
        "load_average_1_5_15_before": [round(x, 2) for x in load_before],
        "load_average_1_5_15_after": [round(x, 2) for x in load_after],
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=21)
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--no-write", action="store_true")
    options = parser.parse_args()
    result = measure(options.rounds, options.calls)
    print(json.dumps(result, indent=2))
    if not options.no_write:
        path = Path(__file__).with_suffix(".json")
        path.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
