"""Structural validation of a URDF before Pinocchio sees it.

Pinocchio's URDF parser (urdfdom) reports some errors only on standard error and carries on: an
``<inertia ixx="abc">`` leaves the link with zero inertia, and a model is returned. So every URDF is
checked here first, from the safely parsed XML tree
(:func:`aiauv_hydro.urdf.block_reader.parse_robot`: no DTD,
no entities), against the URDF specification (wiki.ros.org/urdf/XML):

* the root element is ``<robot name=...>`` with at least one ``<link>``;
* every ``<link>`` has a unique name; its ``<inertial>`` (optional) has ``<mass value>`` finite and
  ``>= 0``, six finite ``<inertia>`` entries forming a symmetric positive semi-definite matrix, and
  finite ``<origin>`` numbers; its visual and collision geometry has positive finite sizes;
* every ``<joint>`` has a unique name, a known ``type``, ``<parent link>`` and ``<child link>``
  naming existing, different links, a nonzero finite ``<axis>``, finite ``<origin>`` numbers and,
  for ``revolute`` and ``prismatic`` joints, a ``<limit>`` with finite ``lower <= upper`` and
  ``effort``, ``velocity >= 0``;
* the links form one tree: no link is the child of two joints, exactly one link (the root) is no
  joint's child, and every link is reachable from it (so there is no cycle).

Every failure raises :class:`UrdfStructureError` with a one-line message naming the element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from xml.etree.ElementTree import Element

import numpy as np

from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.block_reader import parse_numbers
from aiauv_hydro.urdf.xml_reading import UrdfLink, read_link
from aiauv_pin.errors import VehicleLoadError

#: Joint types of the URDF specification.
URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
#: Relative tolerance of the inertia symmetry / positive semi-definiteness check.
INERTIA_TOLERANCE = 1e-9


class UrdfStructureError(VehicleLoadError):
    """A URDF that breaks the URDF specification; the message is one line naming the element."""


@dataclass(frozen=True)
class UrdfInertial:
    """A link's ``<inertial>``.

    Attributes:
        mass: Mass [kg].
        xyz: Centre of mass in the link frame [m].
        rpy: Orientation of the inertia frame in the link frame [rad].
        inertia: Inertia about the centre of mass in the inertia frame (3x3) [kg m^2].
    """

    mass: float
    xyz: np.ndarray
    rpy: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class UrdfJoint:
    """A ``<joint>``.

    Attributes:
        name: Joint name.
        type: URDF joint type.
        parent: Parent link name.
        child: Child link name.
        xyz: Joint origin in the parent link frame [m].
        rpy: Joint orientation in the parent link frame [rad].
        axis: Unit joint axis in the joint frame.
        lower: Lower limit [rad or m] (``None`` without a limit or for continuous joints).
        upper: Upper limit [rad or m].
        effort: Effort limit [N m or N] (``None`` if not given).
        velocity: Velocity limit [rad/s or m/s] (``None`` if not given).
    """

    name: str
    type: str
    parent: str
    child: str
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    effort: float | None
    velocity: float | None


@dataclass(frozen=True)
class UrdfStructure:
    """The validated kinematic tree of a URDF.

    Attributes:
        name: Robot name.
        links: Link names in file order.
        inertials: ``{link: UrdfInertial}`` for the links that have one.
        joints: Joints in file order.
        root: Name of the root link.
        urdf_links: ``{link: aiauv_hydro.urdf.xml_reading.UrdfLink}``, what the hydrodynamics readers need of
            each link, read in the same walk (passed on to
            :func:`aiauv_hydro.urdf.block_reader.read_hydrodynamics`).
        geometry_extents: ``{link: largest distance from its origin reached by its visual and
            collision geometry}`` [m] (:func:`geometry_extent`), read in the same walk.
    """

    name: str
    links: tuple[str, ...]
    inertials: dict[str, UrdfInertial]
    joints: tuple[UrdfJoint, ...]
    root: str
    urdf_links: dict[str, UrdfLink] = field(default_factory=dict)
    geometry_extents: dict[str, float] = field(default_factory=dict)


def _numbers(text: str | None, count: int, what: str) -> np.ndarray:
    try:
        values = parse_numbers(text, what)
    except HydroError as error:
        raise UrdfStructureError(str(error)) from None
    if values.size != count:
        raise UrdfStructureError(f"{what}: expected {count} numbers, got {values.size}")
    return values


def _number(element: Element, attribute: str, what: str, default: float | None = None) -> float:
    text = element.get(attribute)
    if text is None:
        if default is None:
            raise UrdfStructureError(f"{what}: missing attribute '{attribute}'")
        return default
    return float(_numbers(text, 1, f"{what} {attribute}")[0])


def _origin(element: Element, what: str) -> tuple[np.ndarray, np.ndarray]:
    origin = element.find("origin")
    if origin is None:
        return np.zeros(3), np.zeros(3)
    return (
        _numbers(origin.get("xyz", "0 0 0"), 3, f"{what} <origin> xyz"),
        _numbers(origin.get("rpy", "0 0 0"), 3, f"{what} <origin> rpy"),
    )


def _inertial(element: Element, what: str) -> UrdfInertial:
    xyz, rpy = _origin(element, f"{what} <inertial>")
    mass_element = element.find("mass")
    if mass_element is None:
        raise UrdfStructureError(f"{what}: <inertial> without <mass>")
    mass = _number(mass_element, "value", f"{what} mass")
    if mass < 0.0:
        raise UrdfStructureError(f"{what}: mass must be >= 0, got {mass:g}")
    inertia_element = element.find("inertia")
    if inertia_element is None:
        raise UrdfStructureError(f"{what}: <inertial> without <inertia>")
    entries = {
        key: _number(inertia_element, key, f"{what} inertia")
        for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    }
    inertia = np.array(
        [
            [entries["ixx"], entries["ixy"], entries["ixz"]],
            [entries["ixy"], entries["iyy"], entries["iyz"]],
            [entries["ixz"], entries["iyz"], entries["izz"]],
        ]
    )
    scale = max(float(np.max(np.abs(inertia))), 1e-300)
    smallest = float(np.min(np.linalg.eigvalsh(inertia)))
    if smallest < -INERTIA_TOLERANCE * scale:
        raise UrdfStructureError(
            f"{what}: inertia is not positive semi-definite (eigenvalue {smallest:.6g} kg m^2)"
        )
    return UrdfInertial(mass, xyz, rpy, inertia)


def _geometry(element: Element, what: str) -> None:
    geometry = element.find("geometry")
    if geometry is None:
        raise UrdfStructureError(f"{what}: missing <geometry>")
    shapes = [child for child in geometry if isinstance(child.tag, str)]
    if len(shapes) != 1:
        raise UrdfStructureError(f"{what}: <geometry> must hold exactly one shape")
    shape = shapes[0]
    if shape.tag == "box":
        sizes = _numbers(shape.get("size"), 3, f"{what} box size")
    elif shape.tag == "cylinder":
        sizes = np.array(
            [
                _number(shape, "radius", f"{what} cylinder"),
                _number(shape, "length", f"{what} cylinder"),
            ]
        )
    elif shape.tag == "sphere":
        sizes = np.array([_number(shape, "radius", f"{what} sphere")])
    elif shape.tag == "mesh":
        if not shape.get("filename"):
            raise UrdfStructureError(f"{what}: <mesh> without a filename")
        if "scale" in shape.attrib:
            _numbers(shape.get("scale"), 3, f"{what} mesh scale")
        return
    else:
        raise UrdfStructureError(f"{what}: unknown geometry <{shape.tag}>")
    if np.any(sizes <= 0.0):
        raise UrdfStructureError(f"{what}: {shape.tag} sizes must be positive")


def _joint(element: Element, links: set[str]) -> UrdfJoint:
    name = element.get("name")
    if not name:
        raise UrdfStructureError("URDF <joint> without a name")
    what = f"joint '{name}'"
    kind = element.get("type")
    if kind not in URDF_JOINT_TYPES:
        raise UrdfStructureError(
            f"{what}: unknown type {kind!r} (expected one of {', '.join(URDF_JOINT_TYPES)})"
        )
    ends = {}
    for tag in ("parent", "child"):
        found = element.findall(tag)
        if len(found) != 1 or not found[0].get("link"):
            raise UrdfStructureError(f"{what}: needs exactly one <{tag} link=...>")
        link = found[0].get("link")
        if link not in links:
            raise UrdfStructureError(f"{what}: {tag} link '{link}' is not a <link> of the robot")
        ends[tag] = link
    if ends["parent"] == ends["child"]:
        raise UrdfStructureError(f"{what}: parent and child are the same link '{ends['child']}'")
    xyz, rpy = _origin(element, what)
    axis_element = element.find("axis")
    axis = np.array([1.0, 0.0, 0.0])
    if axis_element is not None:
        axis = _numbers(axis_element.get("xyz"), 3, f"{what} axis")
    norm = float(np.linalg.norm(axis))
    if norm == 0.0 and kind not in ("fixed", "floating"):
        raise UrdfStructureError(f"{what}: axis is the zero vector")
    axis = axis / norm if norm > 0.0 else axis
    lower = upper = effort = velocity = None
    limit = element.find("limit")
    if limit is None and kind in ("revolute", "prismatic"):
        raise UrdfStructureError(f"{what}: a {kind} joint needs a <limit>")
    if limit is not None:
        effort = _number(limit, "effort", f"{what} limit", default=math.inf)
        velocity = _number(limit, "velocity", f"{what} limit", default=math.inf)
        if effort < 0.0 or velocity < 0.0:
            raise UrdfStructureError(f"{what}: limit effort and velocity must be >= 0")
        if kind != "continuous":
            lower = _number(limit, "lower", f"{what} limit", default=0.0)
            upper = _number(limit, "upper", f"{what} limit", default=0.0)
            if lower > upper:
                raise UrdfStructureError(f"{what}: limit lower {lower:g} exceeds upper {upper:g}")
        effort = None if math.isinf(effort) else effort
        velocity = None if math.isinf(velocity) else velocity
    return UrdfJoint(
        name, kind, ends["parent"], ends["child"], xyz, rpy, axis, lower, upper, effort, velocity
    )


def geometry_extent(link: Element) -> float:
    """Largest distance from the link origin reached by its visual and collision geometry [m]."""
    extent = 0.0
    for kind in ("visual", "collision"):
        for element in link.findall(kind):
            origin = element.find("origin")
            offset = 0.0
            try:
                if origin is not None:
                    offset = float(
                        np.linalg.norm(np.array(origin.get("xyz", "0 0 0").split(), float))
                    )
                geometry = element.find("geometry")
                shape = next((c for c in geometry if isinstance(c.tag, str)), None)
                if shape is None:
                    continue
                if shape.tag == "box":
                    size = 0.5 * float(np.linalg.norm(np.array(shape.get("size").split(), float)))
                elif shape.tag == "cylinder":
                    size = math.hypot(0.5 * float(shape.get("length")), float(shape.get("radius")))
                elif shape.tag == "sphere":
                    size = float(shape.get("radius"))
                else:
                    size = 0.0
            except (TypeError, ValueError, AttributeError):
                continue
            extent = max(extent, offset + size)
    return extent


def validate_urdf(root: Element) -> UrdfStructure:
    """Check a parsed ``<robot>`` element against the URDF specification (see the module docstring).

    Args:
        root: The ``<robot>`` element (from :func:`aiauv_hydro.urdf.block_reader.parse_robot`).

    Returns:
        The validated tree.

    Raises:
        UrdfStructureError: One line naming the first problem found.
    """
    if root.tag != "robot":
        raise UrdfStructureError(f"not a URDF: root element is <{root.tag}>, not <robot>")
    robot_name = root.get("name")
    if not robot_name:
        raise UrdfStructureError("not a URDF: <robot> has no name attribute")
    names: list[str] = []
    inertials: dict[str, UrdfInertial] = {}
    urdf_links: dict[str, UrdfLink] = {}
    extents: dict[str, float] = {}
    for link in root.findall("link"):  # the one walk over the links of a vehicle load
        name = link.get("name")
        if not name:
            raise UrdfStructureError("URDF <link> without a name")
        if name in names:
            raise UrdfStructureError(f"link '{name}' defined twice")
        names.append(name)
        what = f"link '{name}'"
        found = link.findall("inertial")
        if len(found) > 1:
            raise UrdfStructureError(f"{what}: more than one <inertial>")
        if found:
            inertials[name] = _inertial(found[0], what)
        for kind in ("visual", "collision"):
            for element in link.findall(kind):
                _origin(element, f"{what} <{kind}>")
                _geometry(element, f"{what} <{kind}>")
        try:
            urdf_links[name] = read_link(link)
        except HydroError as exc:
            raise UrdfStructureError(str(exc)) from None
        extents[name] = geometry_extent(link)
    if not names:
        raise UrdfStructureError("not a URDF: <robot> has no <link>")
    link_set = set(names)
    joints: list[UrdfJoint] = []
    parent_joint: dict[str, str] = {}
    for element in root.findall("joint"):
        joint = _joint(element, link_set)
        if any(j.name == joint.name for j in joints):
            raise UrdfStructureError(f"joint '{joint.name}' defined twice")
        if joint.child in parent_joint:
            raise UrdfStructureError(
                f"link '{joint.child}' is the child of two joints "
                f"('{parent_joint[joint.child]}' and '{joint.name}')"
            )
        parent_joint[joint.child] = joint.name
        joints.append(joint)
    roots = [name for name in names if name not in parent_joint]
    if not roots:
        raise UrdfStructureError("the joints form a cycle: every link is some joint's child")
    if len(roots) > 1:
        raise UrdfStructureError(
            f"the URDF has {len(roots)} root links ({', '.join(roots[:4])}); expected one tree"
        )
    children: dict[str, list[str]] = {}
    for joint in joints:
        children.setdefault(joint.parent, []).append(joint.child)
    reached = {roots[0]}
    stack = [roots[0]]
    while stack:
        for child in children.get(stack.pop(), []):
            if child not in reached:
                reached.add(child)
                stack.append(child)
    unreached = [name for name in names if name not in reached]
    if unreached:
        raise UrdfStructureError(
            f"link '{unreached[0]}' is not connected to the root link '{roots[0]}' "
            "(the joints form a cycle)"
        )
    return UrdfStructure(
        robot_name, tuple(names), inertials, tuple(joints), roots[0], urdf_links, extents
    )
