"""Steps per second of the Gymnasium environments against MuJoCo's ``Swimmer-v5`` (issue 35).

The measurement of ``aiauv bench --only gym`` (:mod:`aiauv_pin.tools.gym_benchmarks`: what is
timed and how), run alone: prints the table and writes ``benchmarks/gym_steps.json``.

Run: ``python benchmarks/gym_steps.py [--quick] [--no-write]``.
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

from aiauv_pin.tools.gym_benchmarks import format_gym, gym_timings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 short rounds")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args()
    results = {"machine": platform.processor() or platform.machine()}
    results["gym"] = gym_timings(quick=args.quick)
    print("\n".join(format_gym(results)))
    if not args.no_write:
        out = Path(__file__).with_name("gym_steps.json")
        out.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
        print(f"-> {out}")


if __name__ == "__main__":
    main()
