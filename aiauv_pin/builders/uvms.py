"""An underwater vehicle-manipulator system (UVMS): a cylindrical hull carrying a robot arm.

:func:`uvms_urdf` writes the URDF text of a hull link (root) with a fixed joint to the arm's base,
the arm's ``<link>`` and ``<joint>`` elements copied from its example-robot-data URDF (visual and
mesh collision geometry stripped: Pinocchio ignores them for the dynamics), and a
``<hydrodynamics>`` block:

* hull: a solid circular cylinder along its x-axis, ``model="slender_cylinder"`` (strip theory,
  :mod:`aiauv_hydro.estimate.slender_cylinder`); its mass is chosen so the whole vehicle is
  neutrally buoyant, with
  its centre of gravity ``hull_cg_drop`` below the axis for a roll/pitch restoring moment;
* each arm link with mass: ``model="fossen"`` with explicit 6x6 matrices derived from its
  *equivalent ellipsoid* (:mod:`aiauv_hydro.estimate.ellipsoid`: from the link's first
  ``<collision>`` primitive,
  else from its ``<inertial>``; Lamb's added-mass coefficients, coarse bluff-body damping).
"""

from __future__ import annotations

import copy
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.etree.ElementTree import Element

import numpy as np

from aiauv_hydro.estimate.ellipsoid import (
    DRAG_COEFFICIENT,
    LINEAR_DAMPING_SPEED,
    Ellipsoid,
    EllipsoidHydrodynamics,
    ellipsoid_added_mass,
    ellipsoid_hydrodynamics,
    inertia_equivalent_ellipsoid,
    lamb_coefficients,
)
from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.annotate import primitive_ellipsoid
from aiauv_hydro.urdf.block_reader import parse_robot, rpy_matrix
from aiauv_pin.description.robots import example_robot_urdf
from aiauv_pin.description.urdf_validation import validate_urdf
from aiauv_pin.errors import VehicleLoadError

HULL_LINK = "hull"
HULL_JOINT = "hull_to_arm"
#: Default arm: Franka Emika Panda from example-robot-data (mesh-only collision geometry, except
#: the fingers). Its ``<mimic>`` tag is dropped: the two finger joints become independent. (UR5
#: works too, but its wrist inertias, about 0.11 kg m^2 for 1.2 kg, give 0.15 m^3 equivalent
#: ellipsoids.)
DEFAULT_ARM = "panda_description/urdf/panda.urdf"
__all__ = [
    "DEFAULT_ARM",
    "DRAG_COEFFICIENT",
    "LINEAR_DAMPING_SPEED",
    "Ellipsoid",
    "EllipsoidHydrodynamics",
    "ellipsoid_added_mass",
    "ellipsoid_hydrodynamics",
    "inertia_equivalent_ellipsoid",
    "lamb_coefficients",
    "primitive_ellipsoid",
    "uvms_urdf",
    "write_uvms_urdf",
]


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _origin_of(element: Element) -> tuple[np.ndarray, np.ndarray]:
    origin = element.find("origin")
    if origin is None:
        return np.zeros(3), np.zeros(3)
    xyz = np.array([float(v) for v in origin.get("xyz", "0 0 0").split()])
    rpy = np.array([float(v) for v in origin.get("rpy", "0 0 0").split()])
    return xyz, rpy


def _link_ellipsoid(link: Element, inertial) -> Ellipsoid | None:
    for collision in link.findall("collision"):
        geometry = collision.find("geometry")
        shapes = [] if geometry is None else [s for s in geometry if isinstance(s.tag, str)]
        if shapes:
            xyz, rpy = _origin_of(collision)
            found = primitive_ellipsoid(shapes[0], xyz, rpy)
            if found is not None:
                return found
    if inertial is None or inertial.mass <= 0.0:
        return None
    return inertia_equivalent_ellipsoid(
        inertial.mass, inertial.inertia, rpy_matrix(inertial.rpy), inertial.xyz
    )


def uvms_urdf(
    arm: str | os.PathLike = DEFAULT_ARM,
    *,
    hull_length: float = 1.6,
    hull_radius: float = 0.3,
    hull_cg_drop: float = 0.05,
    mount_x: float = 1.0,
    fluid_density: float = 1025.0,
    name: str = "uvms",
) -> str:
    """URDF text of a hull carrying an example-robot-data arm, with hydrodynamics.

    Args:
        arm: Path relative to example-robot-data's ``robots`` folder
            (e.g. ``"panda_description/urdf/panda.urdf"``) or a URDF file path.
        hull_length: Hull cylinder length along its x-axis [m]; the hull frame is at its rear end.
        hull_radius: Hull radius [m]; the arm stands on top of it (``z = hull_radius``).
        hull_cg_drop: Hull centre of gravity below its axis [m].
        mount_x: Position of the arm's base along the hull [m].
        fluid_density: ``rho`` [kg/m^3].
        name: Robot name.

    Returns:
        The URDF text; load it with :func:`aiauv_pin.load_vehicle` (after writing it to a file).

    Raises:
        VehicleLoadError: Unknown arm file, a hull too small to float the arm, bad dimensions.
    """
    for value, what in ((hull_length, "hull_length"), (hull_radius, "hull_radius")):
        if not (math.isfinite(value) and value > 0.0):
            raise VehicleLoadError(f"{what} must be positive, got {value!r}")
    path = Path(arm)
    if not path.is_file():
        path = example_robot_urdf(str(arm))
    arm_root = parse_robot(path)
    structure = validate_urdf(arm_root)
    links = {name: link.element for name, link in structure.urdf_links.items()}  # read once
    # skip massless anchor links (e.g. "world") fixed to the arm's base
    base = structure.root
    dropped = set()
    while base not in structure.inertials:
        children = [j for j in structure.joints if j.parent == base]
        if len(children) != 1 or children[0].type != "fixed":
            break
        dropped.add(base)
        base = children[0].child
    robot = ET.Element("robot", name=name)
    hull = ET.SubElement(robot, "link", name=HULL_LINK)
    for link_name, element in links.items():
        if link_name in dropped:
            continue
        copied = ET.SubElement(robot, "link", name=link_name)
        for child in element:
            if child.tag == "inertial":
                copied.append(copy.deepcopy(child))
            elif child.tag == "collision":
                geometry = child.find("geometry")
                if geometry is not None and geometry.find("mesh") is None:
                    copied.append(copy.deepcopy(child))
    for element in arm_root.findall("joint"):
        if element.find("parent").get("link") in dropped:
            continue
        kept = copy.deepcopy(element)
        for tag in ("safety_controller", "calibration", "dynamics", "mimic"):
            for child in kept.findall(tag):
                kept.remove(child)
        robot.append(kept)
    mount = ET.SubElement(robot, "joint", name=HULL_JOINT, type="fixed")
    ET.SubElement(mount, "parent", link=HULL_LINK)
    ET.SubElement(mount, "child", link=base)
    ET.SubElement(mount, "origin", xyz=_numbers([mount_x, 0.0, hull_radius]), rpy="0 0 0")

    block = ET.SubElement(robot, "hydrodynamics", fluid_density=repr(float(fluid_density)))
    arm_mass = 0.0
    arm_volume = 0.0
    for link_name in structure.links:
        if link_name in dropped:
            continue
        inertial = structure.inertials.get(link_name)
        arm_mass += inertial.mass if inertial is not None else 0.0
        try:
            ellipsoid = _link_ellipsoid(links[link_name], inertial)
        except HydroError as exc:
            raise VehicleLoadError(f"arm link '{link_name}': {exc}") from None
        if ellipsoid is None:
            continue
        params = ellipsoid_hydrodynamics(ellipsoid, fluid_density)
        arm_volume += params.volume
        element = ET.SubElement(block, "link", name=link_name, model="fossen")
        ET.SubElement(element, "volume").text = repr(float(params.volume))
        ET.SubElement(element, "center_of_buoyancy").text = _numbers(params.center_of_buoyancy)
        ET.SubElement(element, "added_mass").text = _numbers(params.added_mass)
        ET.SubElement(element, "linear_damping").text = _numbers(params.linear_damping)
        ET.SubElement(element, "quadratic_damping").text = _numbers(params.quadratic_damping)
    hull_volume = math.pi * hull_radius**2 * hull_length
    hull_mass = fluid_density * (hull_volume + arm_volume) - arm_mass  # neutral buoyancy
    if hull_mass <= 0.0:
        raise VehicleLoadError(
            f"hull of {hull_volume:.3g} m^3 cannot float the arm ({arm_mass:.3g} kg); "
            "make it larger"
        )
    ET.SubElement(block, "link", name=HULL_LINK, model="slender_cylinder")
    # hull: solid cylinder along x (axial m r^2 / 2, transverse m (3 r^2 + L^2) / 12)
    inertial = ET.SubElement(hull, "inertial")
    ET.SubElement(
        inertial, "origin", xyz=_numbers([0.5 * hull_length, 0.0, -hull_cg_drop]), rpy="0 0 0"
    )
    ET.SubElement(inertial, "mass", value=repr(float(hull_mass)))
    axial = 0.5 * hull_mass * hull_radius**2
    transverse = hull_mass * (3.0 * hull_radius**2 + hull_length**2) / 12.0
    ET.SubElement(
        inertial,
        "inertia",
        ixx=repr(float(axial)),
        ixy="0",
        ixz="0",
        iyy=repr(float(transverse)),
        iyz="0",
        izz=repr(float(transverse)),
    )
    collision = ET.SubElement(hull, "collision")
    ET.SubElement(
        collision,
        "origin",
        xyz=_numbers([0.5 * hull_length, 0.0, 0.0]),
        rpy="0 1.5707963267948966 0",
    )
    ET.SubElement(
        ET.SubElement(collision, "geometry"),
        "cylinder",
        radius=repr(float(hull_radius)),
        length=repr(float(hull_length)),
    )
    ET.indent(robot)
    return (
        '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"
    )


def write_uvms_urdf(
    path: str | os.PathLike, arm: str | os.PathLike = DEFAULT_ARM, **options
) -> Path:
    """Write :func:`uvms_urdf` to ``path`` (atomically) and return the path."""
    from aiauv_pin._internal.atomic import write_text

    return write_text(path, uvms_urdf(arm, **options))
