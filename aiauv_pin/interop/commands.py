"""The ``aiauv import-gz`` and ``aiauv export`` subcommands."""

from __future__ import annotations

from pathlib import Path

from aiauv_pin._internal.argument_types import positive_density

#: Output suffixes of ``aiauv export`` and the format each selects.
EXPORT_FORMATS = {".sdf": "sdf", ".xml": "mjcf", ".mjcf": "mjcf"}


def add_interop_subcommands(subparsers) -> None:
    """Add ``import-gz`` and ``export`` to the ``aiauv`` parser."""
    parser = subparsers.add_parser(
        "import-gz",
        help="take a Gazebo model's hydrodynamics onto a URDF",
        description="Read the gz-sim Hydrodynamics plugin parameters (SNAME derivatives xU, "
        "xUabsU, xDotU, ...) and <fluid_added_mass> of an SDF model, and write a copy of the URDF "
        "whose <hydrodynamics> block carries them (fossen links, in our sign convention) for the "
        "links of the same names. Volumes and centres of buoyancy are taken from the SDF links' "
        "collision shapes, as gz's Buoyancy system takes them.",
    )
    parser.add_argument("sdf", type=Path, help="SDF file (a model, or a world with models)")
    parser.add_argument(
        "--urdf", type=Path, required=True, help="URDF giving the kinematics and inertias"
    )
    parser.add_argument("-o", "--output", type=Path, required=True, help="URDF file to write")
    parser.add_argument("--model", default=None, help="SDF model to read if the file has several")
    parser.add_argument(
        "--fluid-density",
        type=positive_density,
        default=None,
        help="fluid density [kg/m^3] (default: the SDF's Buoyancy plugin, else the URDF's, "
        "else 1000)",
    )
    parser.set_defaults(handler=_run_import_gz)

    parser = subparsers.add_parser(
        "export",
        help="write a vehicle as a Gazebo SDF or MuJoCo MJCF model",
        description="Write a vehicle URDF as an SDF model for gz-sim (one Hydrodynamics plugin per "
        "link with its damping, the full added mass, buoyancy spheres for gz's Buoyancy system) "
        "or as a MuJoCo MJCF model (bodies, joints, inertias, thrusters, MuJoCo's ellipsoid fluid "
        "model). The format follows the output's suffix: .sdf, or .xml/.mjcf. What the target "
        "cannot express is listed in the file's header comment.",
    )
    parser.add_argument("urdf", type=Path, help="vehicle URDF")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, help="file to write (.sdf, .xml or .mjcf)"
    )
    parser.add_argument(
        "--gz-added-mass",
        choices=("sdf", "plugin"),
        default="sdf",
        help="SDF only: added mass as <fluid_added_mass> (default; DART) or as the plugin's "
        "<xDotU>-style parameters (other physics engines)",
    )
    parser.set_defaults(handler=_run_export)


def _run_import_gz(args) -> int:
    from aiauv_pin.interop.gz import import_gz

    report = import_gz(
        args.sdf, args.urdf, args.output, model=args.model, fluid_density=args.fluid_density
    )
    checked = "link frames checked" if report.pose_checked else "link frames not checked"
    print(
        f"wrote {report.output}: hydrodynamics of {len(report.links)} link(s) from model "
        f"'{report.model}' ({', '.join(report.links)}), fluid density "
        f"{report.fluid_density:g} kg/m^3, {checked}"
    )
    return 0


def _run_export(args) -> int:
    from aiauv_pin.interop.interop_errors import InteropError

    kind = EXPORT_FORMATS.get(args.output.suffix.lower())
    if kind is None:
        raise InteropError(
            f"{args.output}: unknown output format '{args.output.suffix}' "
            "(expected .sdf, .xml or .mjcf)"
        )
    if kind == "sdf":
        from aiauv_pin.interop.gz import export_sdf

        notes = export_sdf(args.urdf, args.output, added_mass=args.gz_added_mass)
    else:
        from aiauv_pin.interop.mjcf import export_mjcf

        notes = export_mjcf(args.urdf, args.output)
    for note in notes:
        print(f"aiauv: note: {note}")
    print(f"wrote {args.output}")
    return 0
