"""What both exporters need from a vehicle URDF: its validated tree, geometry and link placements."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import Element

import numpy as np
import pinocchio as pin

from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.block_reader import parse_robot_text, parse_scalar, parse_vector
from aiauv_pin.description.urdf_validation import UrdfStructure, validate_urdf
from aiauv_pin.interop.interop_errors import InteropError
from aiauv_pin.model.loading import load_vehicle
from aiauv_pin.model.vehicle import Vehicle

#: URDF primitive shapes both exporters carry over (meshes are left out).
PRIMITIVE_SHAPES = ("box", "cylinder", "sphere")


@dataclass(frozen=True)
class Shape:
    """A URDF ``<visual>`` or ``<collision>`` primitive.

    Attributes:
        kind: ``"visual"`` or ``"collision"``.
        shape: ``"box"``, ``"cylinder"`` or ``"sphere"``.
        size: Box edge lengths (3) [m], cylinder ``(radius, length)`` [m] or sphere ``(radius,)`` [m].
        xyz: Origin of the shape in the link frame [m].
        rpy: Orientation of the shape in the link frame [rad] (a cylinder lies along its z-axis).
    """

    kind: str
    shape: str
    size: tuple[float, ...]
    xyz: np.ndarray
    rpy: np.ndarray


@dataclass(frozen=True)
class ExportSource:
    """A loaded vehicle with what its URDF says beyond the Pinocchio model.

    Attributes:
        path: The URDF file.
        vehicle: The loaded vehicle (validated, with its hydrodynamics).
        structure: The validated URDF tree (inertials and joints as written).
        shapes: ``{link: [Shape, ...]}``: the primitive visuals and collisions of each link.
        placements: ``{link: pin.SE3}``: each link frame in the root link frame at ``q = 0``.
    """

    path: Path
    vehicle: Vehicle
    structure: UrdfStructure
    shapes: dict[str, list[Shape]]
    placements: dict[str, pin.SE3]


def _shapes(link: Element) -> list[Shape]:
    name = link.get("name")
    found = []
    for kind in ("visual", "collision"):
        for element in link.findall(kind):
            geometry = element.find("geometry")
            shape = None if geometry is None else next(iter(geometry), None)
            if shape is None or shape.tag not in PRIMITIVE_SHAPES:
                continue
            what = f"link '{name}' {kind} {shape.tag}"
            if shape.tag == "box":
                size = tuple(parse_vector(shape.get("size"), 3, f"{what} size"))
            elif shape.tag == "cylinder":
                size = (
                    parse_scalar(shape.get("radius"), f"{what} radius"),
                    parse_scalar(shape.get("length"), f"{what} length"),
                )
            else:
                size = (parse_scalar(shape.get("radius"), f"{what} radius"),)
            origin = element.find("origin")
            xyz = parse_vector("0 0 0" if origin is None else origin.get("xyz", "0 0 0"), 3, what)
            rpy = parse_vector("0 0 0" if origin is None else origin.get("rpy", "0 0 0"), 3, what)
            found.append(Shape(kind, shape.tag, tuple(float(s) for s in size), xyz, rpy))
    return found


def load_export_source(path: str | os.PathLike) -> ExportSource:
    """Load a vehicle URDF for export.

    Args:
        path: The URDF file (anything :func:`aiauv_pin.load_vehicle` accepts).

    Raises:
        VehicleLoadError: The URDF cannot be loaded (one line).
    """
    path = Path(path)
    vehicle = load_vehicle(path, backend="pinocchio")
    root = parse_robot_text(vehicle.urdf_text, str(path))  # an MJCF file's URDF, too
    structure = validate_urdf(root)
    try:
        shapes = {link.get("name"): _shapes(link) for link in root.findall("link")}
    except HydroError as exc:
        raise InteropError(f"{path}: {exc}") from None
    model, data = vehicle.model, vehicle.model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    placements = {
        link: data.oMf[model.getFrameId(link, pin.FrameType.BODY)].copy()
        for link in structure.links
    }
    return ExportSource(path, vehicle, structure, shapes, placements)


def rpy_of(rotation: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw [rad] of a rotation matrix (URDF/SDF convention ``R = Rz(y) Ry(p) Rx(r)``)."""
    return np.asarray(pin.rpy.matrixToRpy(np.asarray(rotation, dtype=float)), dtype=float)


def rpy_to_matrix(rpy) -> np.ndarray:
    """Rotation matrix of roll, pitch, yaw [rad] (``R = Rz(y) Ry(p) Rx(r)``)."""
    r, p, y = (float(a) for a in rpy)
    return np.asarray(pin.rpy.rpyToMatrix(r, p, y), dtype=float)
