"""``aiauv annotate``: estimate the hydrodynamics of every link of a URDF or xacro file.

The estimation itself is :func:`aiauv_hydro.urdf.annotate.annotate_robot` (no Pinocchio); this module reads
the description (expanding xacro), resolves mesh files through the package search path
(:mod:`aiauv_pin.description.ros_packages`), writes the annotated URDF atomically and loads it once, so that a
file that would not load is never left claiming to be usable.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.annotate import Annotation, annotate_robot
from aiauv_hydro.urdf.block_reader import parse_robot_text
from aiauv_pin._internal.atomic import write_text
from aiauv_pin.description.ros_packages import package_search_path, resolve_uri
from aiauv_pin.description.xacro_loading import read_description
from aiauv_pin.errors import VehicleLoadError


def annotate_file(
    path: str | os.PathLike,
    output: str | os.PathLike,
    *,
    fluid_density: float | None = None,
    neutral: bool = False,
    xacro_args: Mapping[str, str] | None = None,
    package_path: Sequence[str | os.PathLike] = (),
    trust_xacro: bool = False,
    lenient: bool = False,
) -> Annotation:
    """Annotate a URDF (or ``.xacro``) file and write the result.

    Args:
        path: Input URDF or xacro file.
        output: URDF file to write (the expanded, annotated description).
        fluid_density: ``rho`` [kg/m^3]; ``None`` keeps the file's (else 1025).
        neutral: Volumes ``m / rho`` per link instead of the shapes' volumes.
        xacro_args: ``$(arg NAME)`` values for a xacro file.
        package_path: Folders searched for ``$(find pkg)`` and ``package://`` first.
        trust_xacro: Expand a xacro file with full xacro (see :func:`aiauv_pin.load_vehicle`).
        lenient: Check that the output loads with ``lenient=True`` (the robot's own data
            repaired as :mod:`aiauv_pin.model.lenient_repairs` does; load it the same way).

    Returns:
        The annotation (its ``links`` are the per-link table).

    Raises:
        VehicleLoadError: Unreadable or malformed input, or an output that does not load; one line.
    """
    from aiauv_pin.model.loading import _read_text, load_vehicle

    path = Path(path)
    text = read_description(path, xacro_args, package_path, trust_xacro=trust_xacro)
    if text is None:
        text = _read_text(path).removeprefix("\ufeff")
    search_path = package_search_path(package_path)

    def resolve(uri: str) -> Path | None:
        return resolve_uri(uri, search_path, base=path.parent)

    try:
        root = parse_robot_text(text, str(path))
        annotation = annotate_robot(
            root, fluid_density=fluid_density, neutral=neutral, resolve_mesh=resolve
        )
    except HydroError as exc:
        raise VehicleLoadError(f"{path}: {exc}") from None
    written = write_text(output, annotation.text())
    try:
        load_vehicle(written, package_path=package_path, lenient=lenient)
    except VehicleLoadError as exc:
        Path(written).unlink(missing_ok=True)
        own = _own_data_failure(path, xacro_args, package_path, trust_xacro, lenient)
        if own is not None:  # the robot's own data, not the annotation, is what fails
            raise VehicleLoadError(
                f"annotated file not written: the robot's own data fails validation, not the "
                f"annotation: {own}"
                + ("" if lenient else " (--lenient repairs what published files are known to trip)")
            ) from None
        raise VehicleLoadError(
            f"annotated file does not load (the annotation's data), not written: {exc}"
        ) from None
    return annotation


def _own_data_failure(path, xacro_args, package_path, trust_xacro, lenient) -> str | None:
    """The one-line reason the input itself (without the annotation) does not load, or ``None``."""
    import warnings

    from aiauv_pin.model.loading import load_vehicle

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            load_vehicle(
                path,
                xacro_args=dict(xacro_args or {}),
                package_path=package_path,
                trust_xacro=trust_xacro,
                lenient=lenient,
            )
    except VehicleLoadError as exc:
        return str(exc)
    return None
