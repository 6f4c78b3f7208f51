"""The paper's vehicle following its straight path below waves: cross-track error statistics,
with the full unsteady model and with the quasi-steady one.

Runs the eight scenario files ``examples/waves_{regular,irregular}_{head,beam}_{5,20}m.toml``
(a regular wave H = 1 m, T = 6 s, or a JONSWAP sea H_s = 1.5 m, T_p = 8 s, gamma = 3.3; the path
5 m or 20 m below the still-water level; head or beam seas; start on the path) and the same start
in still water, each with the paper's law and with integral LOS (``current_compensation =
"integral_los"``, ``los_integral_gain = 0.5``, as ``examples/current_across_ilos.toml``), for 300 s
with the files' step (semi-implicit Euler, 0.004 s), and each with two models of the water:

* ``unsteady`` (the files as they are): the water's velocity in the relative-velocity terms and
  its acceleration in the Froude-Krylov force and the added mass's reaction
  (:mod:`aiauv_hydro.laws.unsteady_flow`);
* ``quasi_steady``: the same file with ``[current] unsteady = false`` (the acceleration
  neglected), applied here as an override (:meth:`aiauv_hydro.currents.Current.quasi_steady`).

Records, per run, the mean and the maximum of the distance of the end-effector from the path over
the last 60 s, its mean lateral and vertical offsets there, the largest water speed met at the
end-effector (the wave's orbital speed there) and the largest force of the actuators on the base
(``|tau[:3]|``, body frame) over the last 60 s, into
``benchmarks/waves_campaign.json`` (rewritten after every run; runs already there with the same
duration are kept unless ``--rerun``).

    .venv/bin/python benchmarks/waves_campaign.py [--duration 300] [--models unsteady quasi_steady]
"""

from __future__ import annotations

import argparse
import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

import aiauv_pin
from aiauv_control.path_following import PathFollowingGains
from aiauv_hydro.currents import as_current
from aiauv_pin._internal.atomic import write_text
from aiauv_pin.model.loading import bundled_urdf
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import load_scenario

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "examples"
OUT = HERE / "waves_campaign.json"
#: The laws compared (``[controller]`` keys): the paper's, and integral LOS as the examples set it.
LAWS = {
    "paper": {},
    "integral_los": {"current_compensation": "integral_los", "los_integral_gain": 0.5},
}
SEAS = [
    f"waves_{kind}_{heading}_{depth}m"
    for kind in ("regular", "irregular")
    for heading in ("head", "beam")
    for depth in (5, 20)
]
#: The water's models compared: the files as they are, and with ``[current] unsteady = false``.
MODELS = ("unsteady", "quasi_steady")


def with_model(scenario, model: str):
    """``scenario`` with the water's model ``model`` (:data:`MODELS`)."""
    if model == "unsteady":
        return scenario
    return replace(scenario, current=as_current(scenario.current).quasi_steady())


def figures(result, scenario) -> dict:
    """Cross-track statistics over the last 60 s, and the water speed met at the end-effector."""
    tr = result.trajectory
    t, info = tr.t, tr.info
    cross = info["cross_track"]
    distance = np.hypot(cross[:, 0], cross[:, 1])
    last60 = t >= t[-1] - 60.0
    water = scenario.water
    p = info["p"]
    speeds = [
        np.linalg.norm(water.velocity(ti, pi)) for ti, pi in zip(t[::25], p[::25], strict=True)
    ]
    return {
        "status": tr.status,
        "mean_cross_track_last_60s": float(distance[last60].mean()),
        "max_cross_track_last_60s": float(distance[last60].max()),
        "mean_p_y_last_60s": float(cross[last60, 0].mean()),
        "mean_p_z_last_60s": float(cross[last60, 1].mean()),
        "max_water_speed_at_end_effector": float(max(speeds)),
        "max_base_force_last_60s": float(np.linalg.norm(tr.tau[last60, :3], axis=1).max()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=300.0)
    parser.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS))
    parser.add_argument("--rerun", action="store_true", help="rerun runs already in the JSON")
    args = parser.parse_args()
    vehicle = aiauv_pin.load_vehicle(bundled_urdf("uniform"))
    runs: dict = {}
    if OUT.exists() and not args.rerun:
        previous = json.loads(OUT.read_text())
        if previous.get("duration") == args.duration and "models" in previous:
            runs = previous["runs"]
    out: dict = {
        "duration": args.duration,
        "load_average": os.getloadavg(),
        "models": {
            "unsteady": "the scenario files as they are (the water's acceleration applied)",
            "quasi_steady": "the same with [current] unsteady = false",
        },
        "note": "start on the path; statistics over the last 60 s",
        "runs": runs,
    }
    for model in args.models:
        for name in ["still_water", *SEAS]:
            source = "waves_regular_head_5m" if name == "still_water" else name
            base = load_scenario(EXAMPLES / f"{source}.toml")
            if name == "still_water":
                base = replace(base, waves=None)
            for law, keys in LAWS.items():
                key = f"{model}/{name}/{law}"
                if key in runs:
                    continue
                gains = PathFollowingGains.for_case(base.case, **keys)
                scenario = with_model(replace(base, duration=args.duration, gains=gains), model)
                assert scenario.water.unsteady == (model == "unsteady")
                result = run_scenario(vehicle, scenario)
                record = figures(result, scenario)
                runs[key] = record
                out["load_average"] = os.getloadavg()
                write_text(OUT, json.dumps(out, indent=1, sort_keys=True) + "\n")
                print(
                    f"{key}: mean {record['mean_cross_track_last_60s']:.4f} m, "
                    f"max {record['max_cross_track_last_60s']:.4f} m over the last 60 s; "
                    f"water up to {record['max_water_speed_at_end_effector']:.3f} m/s",
                    flush=True,
                )


if __name__ == "__main__":
    main()
