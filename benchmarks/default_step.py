"""The scenario's default integrator and step: error against a converged reference, every setting.

Issue 15's rule: the default is the cheapest (method, step) whose end-effector path stays within
2 mm (:data:`aiauv_pin.tools.run_benchmarks.ACCURACY_TARGET`) of a converged reference (RK4 at 0.5 ms) over
the whole 300 s run; ours adds that the paper's attitude loop must keep a gain margin of 2
(:data:`aiauv_pin.tools.run_benchmarks.MARGIN_TARGET`: it still converges with ``k_p, k_d`` doubled). This
script measures the error (and, with the controller, the margin) of the candidates
(:func:`aiauv_pin.tools.run_benchmarks.accuracy_per_cost`) on both bundled vehicles with the
paper's controller
in still water, and checks the default also stays well-behaved (finite, close to the reference) with
the paper's controller in a current and in a passive drift in that current. It writes
``benchmarks/default_step.json`` (rewritten after every configuration, so a kill loses only the one
under way) and a table on stdout.

The costs here are single runs on a shared machine: the ranking by cost comes from
``aiauv bench --only accuracy-per-cost`` (interleaved repeats, ``benchmarks/results.json``).

    .venv/bin/python benchmarks/default_step.py [--duration 300] [--repeats 1]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from aiauv_pin.tools import run_benchmarks as bench_run

HERE = Path(__file__).resolve().parent
OUT = HERE / "default_step.json"
#: A current across and along the path [m/s] (world frame).
CURRENT = (0.1, 0.1, 0.0)
STILL = (0.0, 0.0, 0.0)
#: Settings near the 2 mm line (each a divisor of the 0.04 s comparison grid).
NEAR_TARGET = (
    ("rk4", 0.01),
    ("rk4", 0.008),
    ("euler", 0.005),
    ("euler", 0.004),
    ("euler", 0.0025),
    ("midpoint", 0.02),
    ("midpoint", 0.01),
)
AROUND_DEFAULT = (("rk4", 0.01), ("euler", 0.005), ("euler", 0.004), ("midpoint", 0.02))
CONFIGURATIONS = (
    ("uniform", "paper", STILL, NEAR_TARGET),
    ("stabilised", "paper", STILL, NEAR_TARGET),
    ("uniform", "paper", CURRENT, NEAR_TARGET),
    ("stabilised", "paper", CURRENT, NEAR_TARGET),
    ("uniform", "none", CURRENT, AROUND_DEFAULT),
    ("stabilised", "none", CURRENT, AROUND_DEFAULT),
)


def write(results: list[dict]) -> None:
    tmp = OUT.with_suffix(".json.tmp")
    tmp.write_text(json.dumps({"configurations": results}, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, OUT)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=300.0, help="[s]")
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    results = []
    for case, controller, current, candidates in CONFIGURATIONS:
        result = bench_run.accuracy_per_cost(
            case,
            args.duration,
            candidates=candidates,
            repeats=args.repeats,
            controller=controller,
            current=current,
        )
        results.append(result)
        write(results)
        print(
            f"\n{case}, controller {controller}, current {current} m/s; reference converged to "
            f"{1000 * result['reference_convergence_m']:.3f} mm"
        )
        for row in result["rows"]:
            error = row["max_end_effector_error_m"]
            text = "diverges" if error is None else f"{1000 * error:.3f} mm"
            if "gain_margin" in row:
                margin = row["gain_margin"]
                text += ", gain margin " + ("< 1" if margin is None else f"{margin:g}")
            print(f"  {row['method']:<8} dt={row['dt']:<7g} {text}")
        print(
            f"  cheapest within 2 mm: {result['cheapest_within_2mm']} "
            f"(default {result['default']}: {result['cheapest_is_default']})"
        )
        if "cheapest_robust" in result:
            print(
                f"  cheapest within 2 mm with gain margin >= {result['margin_target']:g}: "
                f"{result['cheapest_robust']} (the default: {result['default_follows_rule']})"
            )


if __name__ == "__main__":
    main()
