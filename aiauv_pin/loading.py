"""Loading vehicle descriptions: bundled URDFs, user URDFs, and their hydrodynamics blocks."""

from __future__ import annotations

import importlib.resources
import os
import re
from pathlib import Path

import pinocchio as pin

from hydro.spec import HydroError
from hydro.urdf_block import read_hydrodynamics

from .errors import VehicleLoadError
from .vehicle import Vehicle

#: Cases of the paper's vehicle shipped with the package (PAPER_DATA.md, Sec. 4.2 of the paper).
BUNDLED_CASES = ("uniform", "stabilised")


def bundled_urdf(case: str = "uniform") -> Path:
    """Path of a bundled paper-vehicle URDF.

    Args:
        case: ``"uniform"`` (uniform density links) or ``"stabilised"`` (passively roll-stabilised).
    """
    if case not in BUNDLED_CASES:
        raise VehicleLoadError(f"unknown case '{case}' (expected one of {', '.join(BUNDLED_CASES)})")
    resource = importlib.resources.files("aiauv_pin.urdf") / f"paper_{case}.urdf"
    return Path(str(resource))


def _read_text(path: str | os.PathLike) -> str:
    path = Path(path)
    if not path.exists():
        raise VehicleLoadError(f"{path}: no such file")
    if path.is_dir():
        raise VehicleLoadError(f"{path}: is a directory, not a URDF file")
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise VehicleLoadError(f"{path}: cannot read ({exc.__class__.__name__})") from None


def _robot_name(text: str) -> str:
    match = re.search(r"<robot[^>]*\sname\s*=\s*[\"']([^\"']*)[\"']", text)
    return match.group(1) if match else "vehicle"


def load_vehicle(
    path: str | os.PathLike | None = None,
    *,
    added_mass: bool = True,
    damping: bool = True,
    restoring: bool = True,
) -> Vehicle:
    """Load an underwater vehicle from a URDF with an optional ``<hydrodynamics>`` block.

    Args:
        path: URDF file; ``None`` loads the bundled paper vehicle with uniform density.
        added_mass: Include added mass (and its Coriolis terms).
        damping: Include linear, quadratic and crossflow damping.
        restoring: Include weight and buoyancy.

    Returns:
        The vehicle, with a free-flyer joint on the URDF's root link.

    Raises:
        VehicleLoadError: One line naming the problem (missing file, not XML, not a URDF, unsafe XML,
            unknown link, non-physical parameter, ...).
    """
    source = bundled_urdf("uniform") if path is None else Path(path)
    text = _read_text(source)
    try:
        hydro = read_hydrodynamics(text)
    except HydroError as exc:
        raise VehicleLoadError(f"{source}: {exc}") from None
    try:
        model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
    except (RuntimeError, ValueError) as exc:
        reason = " ".join(str(exc).split()) or "the URDF parser rejected it"
        raise VehicleLoadError(f"{source}: not a valid URDF ({reason})") from None
    for joint in model.joints[2:]:
        if joint.nq != 1 or joint.nv != 1:
            raise VehicleLoadError(
                f"{source}: joint '{model.names[joint.id]}' is not a 1-DOF joint"
            )
    for name in [link.link for link in hydro.links] + [t.link for t in hydro.thrusters]:
        if not model.existFrame(name, pin.FrameType.BODY):
            raise VehicleLoadError(f"{source}: hydrodynamics refer to unknown link '{name}'")
    for inertia, name in zip(model.inertias[1:], model.names[1:]):
        if not inertia.mass >= 0.0:
            raise VehicleLoadError(f"{source}: body of joint '{name}' has a negative or NaN mass")
    return Vehicle(
        model,
        hydro,
        name=_robot_name(text),
        added_mass=added_mass,
        damping=damping,
        restoring=restoring,
    )
