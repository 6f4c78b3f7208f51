"""The ``aiauv`` command line.

Every failure the user can cause (bad arguments, a broken URDF, a diverging run) ends with one
line on standard error, ``aiauv: error: ...``, and a non-zero exit status (2 for bad arguments, 1
otherwise); never a traceback (set ``AIAUV_DEBUG=1`` to get one for an unexpected internal error).
Python warnings are printed as single ``aiauv: warning: ...`` lines.
"""

from __future__ import annotations

import argparse
import atexit
import dataclasses
import functools
import gc
import os
import sys
import threading
import time
import warnings
from pathlib import Path

import aiauv_pin
from aiauv_pin._internal.argument_types import (  # noqa: F401  (positive_seconds is part of the CLI's public helpers)
    EXIT_FAILED,
    EXIT_USAGE,
    OneLineArgumentParser,
    filter_coefficient,
    finite_number,
    positive_density,
    positive_seconds,
)
from aiauv_pin.scenario.defaults import DEFAULT_DT, DEFAULT_METHOD

#: Figure formats of ``--figure-format`` (PNG raster, SVG and PDF vector).
FIGURE_FORMATS = ("png", "svg", "pdf")  # outputs.FIGURE_FORMATS, here so parsing stays light

#: Largest number of integration steps ``aiauv simulate`` accepts (the logs are preallocated).
MAX_STEPS = 5_000_000


def _add_simulate(subparsers) -> None:
    parser = subparsers.add_parser(
        "simulate",
        help="run a scenario (default: the paper's path-following scenario)",
        description="Run a scenario file (vehicle, path, start, current, controller; see the "
        "docs' scenario page), or the paper's scenario without one, and write timeseries.csv, "
        "summary.json, figures/ and playback.html into the output folder. Flags override the "
        "file. If the simulation diverges, the files are written for what was computed before "
        "(without playback.html), and the command fails naming the time and the cause.",
    )
    parser.add_argument(
        "scenario", nargs="?", type=Path, help="scenario file (TOML); default: the paper's scenario"
    )
    parser.add_argument(
        "--vehicle",
        type=Path,
        help="URDF, .xacro, MJCF (MuJoCo) or SDF (.sdf, .world) file (default: the bundled paper "
        "vehicle of --case)",
    )
    _add_description_options(parser)
    _add_load_options(parser)
    _add_sdf_options(parser)
    parser.add_argument(
        "--case",
        choices=("uniform", "stabilised"),
        default=None,
        help="the paper's vehicle case and its gains: uniform density (k_D = 19) or passively "
        "roll-stabilised (k_D = 12) (uniform)",
    )
    parser.add_argument("--duration", type=positive_seconds, default=None, help="[s] (300)")
    parser.add_argument(
        "--dt", type=positive_seconds, default=None, help=f"step [s] ({DEFAULT_DT:g})"
    )
    parser.add_argument(
        "--method",
        choices=("rk4", "euler", "midpoint"),
        default=None,
        help="integrator: semi-implicit Euler, RK4 (Munthe-Kaas), or the midpoint method with "
        f"the controller sampled inside each step ({DEFAULT_METHOD})",
    )
    parser.add_argument(
        "--current",
        nargs=3,
        type=finite_number,
        metavar=("VX", "VY", "VZ"),
        default=None,
        help="constant water velocity in the world frame [m/s] (0 0 0)",
    )
    parser.add_argument(
        "--controller",
        choices=("paper", "none", "thruster_turning", "gait", "station", "torpedo"),
        default=None,
        help="the paper's path following, none (a passive run), the thruster-turning "
        "baseline, a serpentine gait (the file's [gait], else its defaults), or station keeping "
        "(the file's [station], else hold the start pose), or a torpedo AUV's path following by "
        "its fins (the file's [torpedo], else its defaults) (paper)",
    )
    parser.add_argument(
        "--added-mass",
        choices=("exact", "lagged"),
        default=None,
        help="added mass in the mass matrix, or lagged as UUV Simulator and gz-sim apply it "
        "(the previous steps' filtered acceleration; runs the Python controller) (exact)",
    )
    parser.add_argument(
        "--lagged-filter",
        type=filter_coefficient,
        default=None,
        metavar="ALPHA",
        help="the lagged scheme's acceleration filter, in (0, 1]: 0.3 is UUV Simulator's, "
        "1 gz-sim's (unfiltered) (0.3)",
    )
    parser.add_argument("--out", type=Path, default=None, help="output folder (results/<name>/)")
    parser.add_argument("--no-html", action="store_true", help="do not write playback.html")
    parser.add_argument(
        "--no-figures", action="store_true", help="do not draw figures/ (data files only)"
    )
    parser.add_argument(
        "--feedforward",
        choices=("exact", "paper"),
        default=None,
        help="attitude-law feedforward: the exact one, or eq. (23) as printed (exact)",
    )
    parser.add_argument(
        "--figure-format",
        choices=FIGURE_FORMATS,
        default="png",
        help="figures as PNG at 200 dpi, or vector SVG or PDF (png)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--view", action="store_true", help="show the run live in meshcat (opens a browser tab)"
    )
    parser.set_defaults(handler=_run_simulate)


def scenario_for_args(args):
    """The scenario of ``aiauv simulate``'s arguments: the file's (or the paper's), flags applied."""
    from aiauv_hydro.currents import Current
    from aiauv_pin.errors import AiauvError
    from aiauv_pin.scenario.definition import Scenario

    if args.scenario is not None:  # the file's schemas (pydantic, ~0.05 s) only for a file
        from aiauv_pin.scenario.toml_file import load_scenario

        scenario = load_scenario(args.scenario)
    else:
        scenario = Scenario()
    changes = {}
    if args.case is not None:
        changes["case"] = args.case
        if scenario.gains is None or args.scenario is None:
            changes["gains"] = None
    for name in ("duration", "dt", "method", "controller", "added_mass", "lagged_filter"):
        if getattr(args, name) is not None:
            changes[name] = getattr(args, name)
    if args.vehicle is not None:
        changes["vehicle"] = str(args.vehicle)
    if args.current is not None:
        from aiauv_pin.scenario.file_schemas import MAX_SPEED

        # the scenario file's plausible range (a current of 1e6 m/s ran, then diverged)
        if not all(abs(component) <= MAX_SPEED for component in args.current):
            raise AiauvError(
                f"--current: each component must be within the plausible range "
                f"[-{MAX_SPEED:g}, {MAX_SPEED:g}] m/s, got {' '.join(f'{c:g}' for c in args.current)}"
            )
        changes["current"] = Current.constant(args.current)
    scenario = dataclasses.replace(scenario, **changes)
    if args.lagged_filter is not None and scenario.added_mass != "lagged":
        raise AiauvError(
            "--lagged-filter applies to lagged added mass only: add --added-mass lagged"
        )
    if args.feedforward is not None:
        gains = scenario.controller_gains.with_changes(feedforward=args.feedforward)
        scenario = dataclasses.replace(scenario, gains=gains)
    return scenario


def _run_simulate(args) -> int:
    # (imports numpy alone: forked before the simulation's modules are imported)
    from aiauv_pin.results.figure_workers import FigureWorkers

    workers = None
    if not args.no_figures:
        # forked first, while no other thread runs: it imports matplotlib on the second core,
        # idle while this process imports numba and Pinocchio, reads the vehicle and loads the
        # compiled loop
        workers = FigureWorkers.start()
    try:
        aiauv_pin.import_all()
        if args.view:  # the collector runs during a live view: the modules out of its reach
            gc.freeze()
        from aiauv_pin.errors import AiauvError
        from aiauv_pin.model import loading

        scenario = scenario_for_args(args)
        steps = scenario.duration / scenario.dt
        if steps > MAX_STEPS:
            raise AiauvError(
                f"duration / dt = {steps:.3g} steps exceeds {MAX_STEPS}; "
                "use a larger --dt or a shorter --duration"
            )
        path = (
            scenario.vehicle
            if scenario.vehicle is not None
            else loading.bundled_urdf(scenario.case)
        )
        return _simulate_with(args, scenario, path, workers)
    finally:
        if workers is not None:
            workers.close()


def _simulate_with(args, scenario, path, workers) -> int:
    """:func:`_run_simulate` once the figure process (``workers``, or ``None``) is started."""
    from aiauv_pin._internal.result_folder import check_output_folder, staged_folder
    from aiauv_pin.errors import AiauvError, SimulationDiverged
    from aiauv_pin.model import loading
    from aiauv_pin.model.validation import explain_divergence
    from aiauv_pin.results.outputs import (
        final_line,
        live_path_points,
        preload_plotting,
        write_results,
    )
    from aiauv_pin.results.streamed_table import TableStream
    from aiauv_pin.scenario.definition import finish_run, plan_run, result_of
    from aiauv_pin.simulation.compilation import CompilationWatch
    from aiauv_pin.simulation.fixed_step import simulate

    compile_start = time.perf_counter()
    vehicle = loading.load_vehicle(path, **_load_options(args, scenario))
    # watched once the vehicle passed the validation gate: a refused file gets its one line only;
    # the notice is printed when numba starts compiling (set-up or run), and only then
    compilation = CompilationWatch()
    if vehicle.fallback_reason is not None:
        print(
            f"aiauv: warning: compiled backend unavailable ({vehicle.fallback_reason}); "
            "using the Pinocchio reference, about 50x slower",
            file=sys.stderr,
        )
    if args.scenario is not None:
        name = args.scenario.stem
    elif scenario.vehicle is not None:
        name = Path(scenario.vehicle).stem
    else:
        name = scenario.case
    out = args.out if args.out is not None else Path("results") / name
    title = Path(out).resolve().name or name  # the figures' titles name the folder
    check_output_folder(out)  # refuse a file or a foreign folder before compiling or simulating
    if not args.no_html:  # a shape the playback cannot draw: say so before the run, not after it
        from aiauv_pin.results.viewer import vehicle_visuals

        try:
            vehicle_visuals(vehicle)
        except ValueError as exc:
            raise AiauvError(
                f"{' '.join(str(exc).split())}; --no-html runs without the playback"
            ) from None
    # the controller built once; the kernels compiled (or loaded) for the run's argument types
    # before the timed run, without a step: summary.json's real-time factor is the simulation's
    # alone; the set-up time is recorded beside it
    plan = plan_run(vehicle, scenario)
    if plan.compiled and not args.no_figures and workers is None:
        # matplotlib for the figures, imported by a second thread from here on: loading the
        # compiled loop (numba parses its bitcode, the GIL released) and the loop itself leave
        # it the GIL (started with the loop, it ended 0.06-0.08 s after it, which the run waited)
        preload_plotting()
    if vehicle.active_backend == "numba":
        with compilation:
            simulate(*plan.arguments, **plan.options, compile_only=True)
    timing = {"setup_time": time.perf_counter() - compile_start}
    on_log = None
    if args.view:
        from aiauv_pin.results.viewer import live_view

        on_log = live_view(vehicle, path_points=live_path_points(scenario))
    # while the loop runs (it releases the GIL), a second thread formats timeseries.csv's rows:
    # without figures from the start; with the figure process once it has warmed matplotlib up
    # (the two share the second core); not beside matplotlib's import in this process
    # (preload_plotting, above: the table then goes to the figure processes)
    if args.no_figures:
        stream = TableStream.for_plan(plan)
    elif workers is not None:
        stream = TableStream.for_plan(plan, workers.warm)
    else:
        stream = None
    streamed = None
    start = time.perf_counter()
    try:
        with compilation:
            trajectory = simulate(  # the run: the step's walk goes down from here
                *plan.arguments,
                **plan.options,
                progress=not args.quiet,
                on_log=on_log,
                log_reader=None if stream is None else stream.read,
                log_memory=None if workers is None else workers.log.empty,
            )
        wall_time = time.perf_counter() - start
    except SimulationDiverged as exc:
        timing["compiled_now"] = compilation.compiled_now
        cause = " ".join(explain_divergence(vehicle, scenario.dt, str(exc)).split())
        partial = exc.trajectory
        streamed = None if stream is None else stream.close()
        if partial is None or len(partial.t) == 0:
            raise AiauvError(f"simulation diverged: {cause}; nothing to write") from None
        from aiauv_pin.scenario.definition import add_path_errors

        add_path_errors(vehicle, scenario, partial)
        result = result_of(plan, partial, time.perf_counter() - start)
        with staged_folder(out) as staging:  # nothing of an earlier run survives
            write_results(
                result,
                staging,
                {"vehicle": str(path), **timing},
                figure_format=args.figure_format,
                vehicle_name=title,
                figures=not args.no_figures,
                streamed=streamed,
                figure_workers=workers,
            )
        raise AiauvError(
            f"simulation diverged: {cause}; partial results up to t = {partial.t[-1]:.6g} s "
            f"({len(partial.t)} samples) written to {out}"
        ) from None
    finally:
        if stream is not None and streamed is None:
            streamed = stream.close()  # the thread stops with the run, whatever ended it
    result = finish_run(plan, trajectory, wall_time)
    timing["compiled_now"] = compilation.compiled_now
    with staged_folder(out) as staging:  # in place only once every file is written
        also = []
        if not args.no_html:  # the page, written beside the figures (by whichever process is free)
            from aiauv_pin.results.outputs import default_path_points
            from aiauv_pin.results.playback import write_playback

            also.append(
                functools.partial(
                    write_playback,
                    vehicle,
                    result.trajectory,
                    staging / "playback.html",
                    path_points=default_path_points(result),
                    sea=result.scenario.waves,
                )
            )
        content = write_results(
            result,
            staging,
            {"vehicle": str(path), **timing},
            figure_format=args.figure_format,
            also=also,
            vehicle_name=title,
            figures=not args.no_figures,
            streamed=streamed,
            figure_workers=workers,
        )
    print(
        f"{name}: {content['simulated_time']:.1f} s simulated (set-up {timing['setup_time']:.1f} s, "
        f"simulation {content['wall_time']:.1f} s, {content['real_time_factor']:.0f}x real time); "
        f"{final_line(content)} -> {out}"
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
    from aiauv_pin.builders.urdf_builder import write_urdf
    from aiauv_pin.builders.vehicle_spec import load_spec

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
    parser.add_argument(
        "urdf", type=Path, help="URDF, .xacro, MJCF (MuJoCo) or SDF (.sdf, .world) file"
    )
    _add_description_options(parser)
    _add_load_options(parser)
    _add_sdf_options(parser)
    parser.add_argument(
        "--physics",
        action="store_true",
        help="run the dynamics-consistency checks instead (energy, impulse, damping, power "
        "balance, hydrostatics, invariance, backends, thrusters; see aiauv_pin.checks.consistency) and "
        "print a table of figures and tolerances; exit status 1 if any fails",
    )
    parser.set_defaults(handler=_run_check)


def _run_check(args) -> int:
    from aiauv_pin.checks.vehicle_check import check_vehicle, format_report

    if args.physics:
        from aiauv_pin.checks.consistency import run_physics_check

        return run_physics_check(args.urdf, **_load_options(args))
    report = check_vehicle(args.urdf, **_load_options(args))
    print(format_report(report))
    return 0


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("aiauv-pin")
    except Exception:  # not installed as a distribution (a source tree on sys.path)
        from aiauv_pin import __version__

        return __version__


def _xacro_argument(text: str) -> tuple[str, str]:
    """argparse type: ``NAME=VALUE``."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got '{text}'")
    return name.strip(), value


def _add_description_options(parser) -> None:
    """``--arg``, ``--package-path``, ``--trust-xacro``: for ``.xacro`` files and ``package://``."""
    parser.add_argument(
        "--arg",
        dest="xacro_args",
        metavar="NAME=VALUE",
        type=_xacro_argument,
        action="append",
        default=[],
        help="xacro argument for a .xacro vehicle (repeatable)",
    )
    parser.add_argument(
        "--package-path",
        dest="package_path",
        metavar="DIR",
        type=Path,
        action="append",
        default=[],
        help="folder searched for ROS packages named by $(find pkg) and package:// "
        "(repeatable; searched before ROS_PACKAGE_PATH and example-robot-data)",
    )
    parser.add_argument(
        "--trust-xacro",
        action="store_true",
        help="expand a .xacro vehicle with full xacro, whose ${...} expressions are Python eval "
        "and can run code: only for a file you trust (default: a safe evaluator of arithmetic, "
        "comparisons and math functions)",
    )


def _add_sdf_options(parser) -> None:
    """``--model``, ``--model-path``: for SDF files (a world's model, ``model://`` URIs)."""
    parser.add_argument(
        "--model",
        dest="sdf_model",
        metavar="NAME",
        default=None,
        help="SDF file: the model to load when the file (a world) holds several",
    )
    parser.add_argument(
        "--model-path",
        dest="model_path",
        metavar="DIR",
        type=Path,
        action="append",
        default=[],
        help="SDF file: folder searched for model:// URIs and local copies of Fuel models "
        "(repeatable; searched before GZ_SIM_RESOURCE_PATH)",
    )


def _description_options(args) -> dict:
    options = {
        "xacro_args": dict(args.xacro_args),
        "package_path": list(args.package_path),
        "trust_xacro": args.trust_xacro,
    }
    if getattr(args, "sdf_model", None) is not None:
        options["model"] = args.sdf_model
    if getattr(args, "model_path", None):
        options["model_path"] = list(args.model_path)
    return options


def _add_load_options(parser) -> None:
    """``--fixed-base``, ``--lenient``: how ``check`` and ``simulate`` load the vehicle."""
    parser.add_argument(
        "--fixed-base",
        action="store_true",
        help="fix the vehicle's root link to the world (a manipulator on a stand, a tank rig); "
        "a massless root link named 'world' fixes it without the flag",
    )
    parser.add_argument(
        "--lenient",
        action="store_true",
        help="repair what published vehicle files are known to trip (names, massless moving "
        "links, inertias breaking the triangle inequality, UUV Simulator defaults) instead of "
        "refusing them; each repair is printed (docs: vehicles)",
    )


def _load_options(args, scenario=None) -> dict:
    """:func:`_description_options` with ``fixed_base`` and ``lenient`` (flags or scenario)."""
    options = _description_options(args)
    options["fixed_base"] = bool(args.fixed_base or getattr(scenario, "fixed_base", False))
    options["lenient"] = bool(args.lenient or getattr(scenario, "lenient", False))
    # the command line's folders first, then the scenario file's
    options["package_path"] += list(getattr(scenario, "package_path", ()))
    return options


def _add_annotate(subparsers) -> None:
    parser = subparsers.add_parser(
        "annotate",
        help="estimate hydrodynamics for every link of a URDF",
        description="Write a copy of a URDF (or .xacro) with a <hydrodynamics> block estimated per "
        "link from its collision geometry (cylinder: slender-cylinder model; box, sphere: the "
        "equivalent ellipsoid with Lamb's added-mass coefficients; mesh: an ellipsoid fitted to "
        "the mesh), or from its inertia when it has none, and print a table of what was chosen "
        "per link for review. Links that already have hydrodynamics, and massless links, are left "
        "alone.",
    )
    parser.add_argument("urdf", type=Path, help="input URDF or .xacro file")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, help="annotated URDF file to write"
    )
    parser.add_argument(
        "--fluid-density",
        type=positive_density,
        default=None,
        metavar="RHO",
        help="water density [kg/m^3] (default: the file's, else 1025)",
    )
    parser.add_argument(
        "--neutral",
        action="store_true",
        help="give each link the volume m / rho (neutrally buoyant link by link) instead of its "
        "shape's volume",
    )
    parser.add_argument(
        "--lenient",
        action="store_true",
        help="check that the output loads with --lenient (the robot's own data repaired; load "
        "it with --lenient too)",
    )
    _add_description_options(parser)
    parser.set_defaults(handler=_run_annotate)


def _run_annotate(args) -> int:
    from aiauv_pin.app.annotate_command import annotate_file
    from aiauv_pin.errors import AiauvError

    if args.output.resolve() == args.urdf.resolve():
        raise AiauvError(f"{args.output}: would overwrite the input; choose another output file")
    annotation = annotate_file(
        args.urdf,
        args.output,
        fluid_density=args.fluid_density,
        neutral=args.neutral,
        lenient=args.lenient,
        **_description_options(args),
    )
    from aiauv_hydro.urdf.annotate import format_annotation

    print(format_annotation(annotation))
    written = sum(1 for row in annotation.links if row.model != "-")
    print(
        f"wrote {args.output} ({written} links annotated); review the table, then "
        f"'aiauv check {args.output}'"
    )
    return 0


#: Subcommands defined in this module: parsing one of them needs no other module's parser.
LOCAL_COMMANDS = ("simulate", "build", "check", "annotate")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``aiauv`` argument parser with every subcommand.

    Args:
        command: The first argument, if known: for one of :data:`LOCAL_COMMANDS` the subcommands
            of other modules (bench, sweep, interop, linearize) are left out, sparing their
            imports (about 0.06 s); the parse is the same.
    """
    parser = OneLineArgumentParser(
        prog="aiauv",
        description="Simulation and control of articulated intervention AUVs.",
    )
    parser.add_argument(
        "--version", action="version", version=f"aiauv {_version()}", help="print the version"
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_simulate(subparsers)
    _add_build(subparsers)
    _add_check(subparsers)
    _add_annotate(subparsers)
    if command in LOCAL_COMMANDS:
        return parser
    from aiauv_pin.app.linearize_command import add_linearize_parser
    from aiauv_pin.app.schema_command import add_schema_parser
    from aiauv_pin.interop.commands import add_interop_subcommands
    from aiauv_pin.scenario.sweep_runner import add_sweep_subcommand
    from aiauv_pin.tools.bench_command import add_bench_parser

    add_bench_parser(subparsers)
    add_sweep_subcommand(subparsers)
    add_interop_subcommands(subparsers)
    add_linearize_parser(subparsers)
    add_schema_parser(subparsers)
    return parser


#: The warnings one command has shown: each is shown once (a controller built for the warm-up
#: and again for the run warns of the same layout twice).
_SHOWN_WARNINGS: set[str] = set()


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    text = " ".join(str(message).split())
    if text in _SHOWN_WARNINGS:
        return
    _SHOWN_WARNINGS.add(text)
    print(f"aiauv: warning: {text}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``aiauv`` console script."""
    return _main(argv, process_ends=False)


def _main(argv: list[str] | None, *, process_ends: bool) -> int:
    """:func:`main`; ``process_ends``: the process ends when this returns (:func:`console_main`).

    A collector paused for the command is then left paused: enabling it again would start, at the
    next allocation, a collection of every object the command made (about 0.07 s after the paper
    run), just before an exit that needs none.
    """
    from aiauv_pin.errors import AiauvError

    arguments = sys.argv[1:] if argv is None else list(argv)
    collecting = gc.isenabled()
    gc.disable()  # paused from here for simulate (below); the command line makes little garbage
    try:
        parser = build_parser(arguments[0] if arguments else None)
        args = parser.parse_args(arguments)
    except BaseException:  # (argparse's exit)
        if collecting:
            gc.enable()
        raise
    with warnings.catch_warnings():  # restores the filters and showwarning on return
        # Deprecations are for the developers of the code that issues them, not for the user of
        # the command: on Python 3.10, importing xacro warned that its enum's private names "will
        # be normal attributes in 3.11", which became a second line before a one-line error
        # wherever warnings are shown (under pytest, with PYTHONWARNINGS)
        warnings.simplefilter("ignore", DeprecationWarning)
        warnings.simplefilter("ignore", PendingDeprecationWarning)
        warnings.showwarning = _show_warning
        _SHOWN_WARNINGS.clear()
        # one run's cyclic garbage is small, and a collection during it would scan numba's
        # long-lived objects made by its first call (0.02-0.03 s): the collector waits for the
        # end of the command, but for a live view, which may run for long
        simulating = getattr(args, "command", None) == "simulate"
        pause = simulating and not getattr(args, "view", False)
        if collecting and not pause:
            gc.enable()
        try:
            if not simulating:  # (simulate first forks its figure process: _run_simulate)
                aiauv_pin.import_all()
                if process_ends:  # out of the collector's reach for the rest of the command
                    gc.freeze()
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
            if pause and collecting and not process_ends:
                gc.enable()


def console_main() -> None:
    """The ``aiauv`` console script: :func:`main`, then a quick interpreter exit.

    The simulation's modules (numba, Pinocchio, ours: several hundred thousand long-lived
    objects) are imported by the command (:func:`aiauv_pin.import_all`, after ``simulate`` forked
    its figure process), with the collector paused, and moved out of its reach; a collector paused
    for ``simulate`` stays paused to the end (:func:`_main`). Everything is written (atomically)
    before :func:`main` returns. Freezing the garbage collector's generations then spares the
    interpreter's final collection over the objects made since, mostly numba's; the exit handlers
    run (e.g. stopping a meshcat server of ``--view``), the standard streams are flushed, and the
    process ends without tearing down its modules one by one (another 0.05 s). A thread still
    running (not a daemon) gets the ordinary exit, which waits for it.
    """
    gc.freeze()
    status = _main(None, process_ends=True)
    gc.freeze()
    others = [t for t in threading.enumerate() if t is not threading.main_thread()]
    if any(t.is_alive() and not t.daemon for t in others):
        sys.exit(status)  # the interpreter waits for them first
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # closed or broken pipe: nothing more can be said
            pass
    os._exit(status)


if __name__ == "__main__":
    console_main()
