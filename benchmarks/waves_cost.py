"""Cost of waves in the compiled loop: a 300 s paper-vehicle run in still water, in a regular
wave and in irregular seas of N components (``aiauv bench``-style: median and range of repeats,
interleaved, with the load average; not a timed test).

The run is ``examples/waves_regular_head_5m.toml`` (the paper's vehicle on the x-axis 5 m below
the still-water level, semi-implicit Euler at 0.004 s, 75 000 steps, the compiled paper law),
timed around :func:`aiauv_pin.scenario.definition.run_scenario` (the loop and its logging; no
files written) after a warm-up run of each sea. Seas: still water (``waves = None``), the
regular wave of the file (H = 1 m, T = 6 s, one component), and JONSWAP seas (H_s = 1.5 m,
T_p = 8 s, gamma = 3.3, long-crested, head seas) of N = 10, 30, 100, 300 and 1000 components. The
current is sampled at each of the 9 links' probe points once per step (Euler; RK4: four times).
Writes ``benchmarks/waves_cost.json``.

    .venv/bin/python benchmarks/waves_cost.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from dataclasses import replace
from pathlib import Path

import aiauv_pin
from aiauv_hydro.waves import Waves
from aiauv_pin._internal.atomic import write_text
from aiauv_pin.model.loading import bundled_urdf
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import load_scenario
from aiauv_pin.tools.run_benchmarks import _spread

HERE = Path(__file__).resolve().parent
OUT = HERE / "waves_cost.json"
COMPONENTS = (10, 30, 100, 300, 1000)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    vehicle = aiauv_pin.load_vehicle(bundled_urdf("uniform"))
    base = load_scenario(HERE.parent / "examples" / "waves_regular_head_5m.toml")
    seas = {"still_water": None, "regular": base.waves}
    for count in COMPONENTS:
        seas[f"jonswap_{count}"] = Waves(
            type="jonswap",
            height=1.5,
            period=8.0,
            heading=base.waves.heading,
            surface_z=base.waves.surface_z,
            peak_enhancement=3.3,
            components=count,
        )
    scenarios = {name: replace(base, waves=sea) for name, sea in seas.items()}
    for scenario in scenarios.values():  # warm-up: compiled code loaded for every sea
        run_scenario(vehicle, replace(scenario, duration=1.0))
    times: dict[str, list[float]] = {name: [] for name in scenarios}
    loads = [os.getloadavg()[0]]
    for _ in range(args.repeats):
        for name, scenario in scenarios.items():
            start = time.perf_counter()
            result = run_scenario(vehicle, scenario)
            times[name].append(time.perf_counter() - start)
            assert result.trajectory.status == "complete", name
        loads.append(os.getloadavg()[0])
    still = statistics.median(times["still_water"])
    out = {
        "scenario": "examples/waves_regular_head_5m.toml, 300 s, euler 0.004 s, paper law",
        "load_average_1min": {"min": min(loads), "max": max(loads), "all": loads},
        "cpu_count": os.cpu_count(),
        "seconds": {name: _spread(values) for name, values in times.items()},
        "ratio_to_still_water": {
            name: statistics.median(values) / still for name, values in times.items()
        },
    }
    write_text(OUT, json.dumps(out, indent=1) + "\n")
    for name in times:
        spread = out["seconds"][name]
        print(
            f"{name}: median {spread['median']:.2f} s [{spread['min']:.2f}, {spread['max']:.2f}], "
            f"{out['ratio_to_still_water'][name]:.2f}x still water"
        )
    print(f"load average (1 min) {min(loads):.1f} to {max(loads):.1f}")


if __name__ == "__main__":
    main()
