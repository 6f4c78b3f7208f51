"""The ``aiauv`` command line.

Every failure the user can cause (bad arguments, a broken URDF, a diverging run) ends with one line on
standard error, ``aiauv: error: ...``, and a non-zero exit status; never a traceback.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path

EXIT_USAGE = 2
EXIT_FAILED = 1


def positive_seconds(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got '{text}'")
    return value


def _add_simulate(subparsers) -> None:
    parser = subparsers.add_parser(
        "simulate",
        help="run the paper's path-following scenario",
        description="Run the paper's path-following scenario and write timeseries.csv, "
        "summary.json, figures/ and playback.html into the output folder.",
    )
    parser.add_argument("--vehicle", type=Path, help="URDF file (default: the bundled paper vehicle)")
    parser.add_argument("--case", choices=("uniform", "stabilised"), default="uniform")
    parser.add_argument("--duration", type=positive_seconds, default=300.0, help="[s] (300)")
    parser.add_argument("--dt", type=positive_seconds, default=None, help="step [s] (0.01)")
    parser.add_argument("--out", type=Path, default=None, help="output folder (results/<case>/)")
    parser.add_argument("--no-html", action="store_true", help="do not write playback.html")
    parser.add_argument("--feedforward", choices=("exact", "paper"), default="exact")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--view", action="store_true", help="show the run live in meshcat (opens a browser tab)"
    )
    parser.set_defaults(handler=_run_simulate)


def _run_simulate(args) -> int:
    from . import loading
    from .errors import SimulationDiverged
    from .outputs import write_results
    from .scenario import PaperScenario, ScenarioResult, run_paper_scenario

    path = args.vehicle if args.vehicle is not None else loading.bundled_urdf(args.case)
    vehicle = loading.load_vehicle(path)
    options = {"dt": args.dt} if args.dt is not None else {}
    scenario = PaperScenario(case=args.case, duration=args.duration, **options)
    gains = scenario.controller_gains.with_changes(feedforward=args.feedforward)
    scenario = dataclasses.replace(scenario, gains=gains)
    out = args.out if args.out is not None else Path("results") / args.case
    on_log = None
    if args.view:
        from .viewer import live_view

        on_log = live_view(vehicle)
    try:
        result = run_paper_scenario(vehicle, scenario, progress=not args.quiet, on_log=on_log)
    except SimulationDiverged as exc:
        partial = ScenarioResult(scenario, exc.trajectory, float("nan"), vehicle.joint_names,
                                 vehicle.thruster_names)
        if exc.trajectory is not None and len(exc.trajectory.t) > 1:
            write_results(partial, out)
        raise
    content = write_results(result, out, {"vehicle": str(path)})
    if not args.no_html:
        from .playback import write_playback

        write_playback(vehicle, result.trajectory, out / "playback.html")
    final = content["final"]
    print(
        f"{args.case}: {content['simulated_time']:.1f} s simulated in {content['wall_time']:.1f} s "
        f"({content['real_time_factor']:.0f}x real time); final p_y = {final['p_y']:+.4f} m, "
        f"p_z = {final['p_z']:+.4f} m, u = {final['u']:.4f} m/s, "
        f"phi_tilde = {final['phi_tilde']:.4f} rad -> {out}"
    )
    return 0


def _add_build(subparsers) -> None:
    parser = subparsers.add_parser(
        "build",
        help="generate an AIAUV URDF from a TOML spec",
        description="Generate an AIAUV URDF (with its <hydrodynamics> block) from a TOML spec.",
    )
    parser.add_argument("spec", type=Path, help="TOML spec of the modules")
    parser.add_argument("-o", "--output", type=Path, required=True, help="URDF file to write")
    parser.set_defaults(handler=_run_build)


def _run_build(args) -> int:
    from .builder import write_urdf
    from .vehicle_spec import load_spec

    spec = load_spec(args.spec)
    path = write_urdf(spec, args.output)
    print(f"wrote {path} ({len(spec.modules)} modules)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``aiauv`` argument parser with every subcommand."""
    parser = argparse.ArgumentParser(
        prog="aiauv",
        description="Simulation and control of articulated intervention AUVs.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_simulate(subparsers)
    _add_build(subparsers)
    for extra in _EXTRA_SUBCOMMANDS:
        extra(subparsers)
    return parser


#: Subcommands registered by other modules (``check``, ``bench``, ...).
_EXTRA_SUBCOMMANDS: list = []


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``aiauv`` console script."""
    from .errors import AiauvError

    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print("aiauv: interrupted", file=sys.stderr)
        return 130
    except (AiauvError, ValueError, OSError) as exc:
        message = " ".join(str(exc).split()) or exc.__class__.__name__
        print(f"aiauv: error: {message}", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
