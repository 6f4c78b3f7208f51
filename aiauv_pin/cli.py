"""The ``aiauv`` command line.

Every failure the user can cause (bad arguments, a broken URDF, a diverging run) ends with one
line on standard error, ``aiauv: error: ...``, and a non-zero exit status (2 for bad arguments, 1
otherwise); never a traceback (set ``AIAUV_DEBUG=1`` to get one for an unexpected internal error).
Python warnings are printed as single ``aiauv: warning: ...`` lines.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import math
import os
import sys
import time
import warnings
from pathlib import Path

EXIT_USAGE = 2
EXIT_FAILED = 1
#: Largest number of integration steps ``aiauv simulate`` accepts (the logs are preallocated).
MAX_STEPS = 5_000_000


class OneLineArgumentParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on standard error (exit status 2)."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {' '.join(message.split())}\n")


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
        "summary.json, figures/ and playback.html into the output folder. If the simulation "
        "diverges, the files are written for what was computed before (without playback.html), "
        "and the command fails naming the time and the cause.",
    )
    parser.add_argument(
        "--vehicle", type=Path, help="URDF file (default: the bundled paper vehicle)"
    )
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
    from .errors import AiauvError, SimulationDiverged
    from .outputs import preload_plotting, write_results
    from .result_folder import check_output_folder, staged_folder
    from .scenario import PaperScenario, ScenarioResult, run_paper_scenario
    from .validation import explain_divergence

    options = {"dt": args.dt} if args.dt is not None else {}
    scenario = PaperScenario(case=args.case, duration=args.duration, **options)
    steps = scenario.duration / scenario.dt
    if steps > MAX_STEPS:
        raise AiauvError(
            f"duration / dt = {steps:.3g} steps exceeds {MAX_STEPS}; "
            "use a larger --dt or a shorter --duration"
        )
    path = args.vehicle if args.vehicle is not None else loading.bundled_urdf(args.case)
    vehicle = loading.load_vehicle(path)
    if vehicle.fallback_reason is not None:
        print(
            f"aiauv: warning: compiled backend unavailable ({vehicle.fallback_reason}); "
            "using the Pinocchio reference, about 50x slower",
            file=sys.stderr,
        )
    gains = scenario.controller_gains.with_changes(feedforward=args.feedforward)
    scenario = dataclasses.replace(scenario, gains=gains)
    out = args.out if args.out is not None else Path("results") / args.case
    check_output_folder(out)  # refuse a file or a foreign folder before simulating
    on_log = None
    if args.view:
        from .viewer import live_view

        on_log = live_view(vehicle)
    start = time.perf_counter()
    try:
        result = run_paper_scenario(
            vehicle,
            scenario,
            progress=not args.quiet,
            on_log=on_log,
            after_first_chunk=preload_plotting,
        )
    except SimulationDiverged as exc:
        cause = " ".join(explain_divergence(vehicle, scenario.dt, str(exc)).split())
        partial = exc.trajectory
        if partial is None or len(partial.t) == 0:
            raise AiauvError(f"simulation diverged: {cause}; nothing to write") from None
        result = ScenarioResult(
            scenario,
            partial,
            time.perf_counter() - start,
            vehicle.joint_names,
            vehicle.thruster_names,
        )
        with staged_folder(out) as staging:  # nothing of an earlier run survives
            write_results(result, staging, {"vehicle": str(path)})
        raise AiauvError(
            f"simulation diverged: {cause}; partial results up to t = {partial.t[-1]:.6g} s "
            f"({len(partial.t)} samples) written to {out}"
        ) from None
    with staged_folder(out) as staging:  # in place only once every file is written
        content = write_results(result, staging, {"vehicle": str(path)})
        if not args.no_html:
            from .playback import write_playback

            write_playback(vehicle, result.trajectory, staging / "playback.html")
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


def _add_check(subparsers) -> None:
    parser = subparsers.add_parser(
        "check",
        help="validate a vehicle URDF and print its parameters",
        description="Validate a vehicle URDF and print a table of its links (mass, volume, "
        "buoyancy margin, CG, CB, added-mass diagonal), joints and thrusters. Exit status 0 for a "
        "usable vehicle, even with warnings (e.g. not neutrally buoyant, no surge thruster); "
        "1 with a one-line reason otherwise.",
    )
    parser.add_argument("urdf", type=Path, help="URDF file")
    parser.set_defaults(handler=_run_check)


def _run_check(args) -> int:
    from .check import check_vehicle, format_report

    report = check_vehicle(args.urdf)
    print(format_report(report))
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The ``aiauv`` argument parser with every subcommand."""
    parser = OneLineArgumentParser(
        prog="aiauv",
        description="Simulation and control of articulated intervention AUVs.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    from .bench import add_bench_parser
    from .sweep import add_sweep_subcommand

    _add_simulate(subparsers)
    _add_build(subparsers)
    _add_check(subparsers)
    add_bench_parser(subparsers)
    add_sweep_subcommand(subparsers)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"aiauv: warning: {' '.join(str(message).split())}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``aiauv`` console script."""
    from .errors import AiauvError

    parser = build_parser()
    args = parser.parse_args(argv)
    previous = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print("aiauv: interrupted", file=sys.stderr)
        return 130
    except (AiauvError, ValueError, OSError, MemoryError, RecursionError) as exc:
        message = " ".join(str(exc).split()) or exc.__class__.__name__
        if isinstance(exc, (MemoryError, RecursionError)):
            message = f"{exc.__class__.__name__}: {message} (input too large or too deep)"
        print(f"aiauv: error: {message}", file=sys.stderr)
        return EXIT_FAILED
    except Exception as exc:
        if os.environ.get("AIAUV_DEBUG"):
            raise
        message = " ".join(str(exc).split())
        print(
            f"aiauv: error: internal error ({exc.__class__.__name__}: {message}); "
            "rerun with AIAUV_DEBUG=1 for the traceback",
            file=sys.stderr,
        )
        return EXIT_FAILED
    finally:
        warnings.showwarning = previous


def console_main() -> None:
    """The ``aiauv`` console script: :func:`main`, then a quick interpreter exit.

    Everything is written (atomically) before :func:`main` returns. Freezing the garbage collector's
    generations then spares the interpreter's final collection over the many long-lived objects of
    numba and Pinocchio, about 0.25 s of every run.
    """
    status = main()
    gc.freeze()
    sys.exit(status)


if __name__ == "__main__":
    console_main()
