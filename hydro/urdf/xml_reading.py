"""Reading a URDF's XML once: safe parsing, numbers, link origins and collision cylinders.

The plain-XML layer under :mod:`aiauv_hydro.urdf.block_reader` (our ``<hydrodynamics>`` block),
:mod:`aiauv_hydro.urdf.uuv_simulator` (UUV Simulator's blocks) and
:mod:`aiauv_pin.description.urdf_validation`: URDFs are
parsed with DTDs and entities refused (defusedxml), every number is checked, and
:func:`read_link` reads each ``<link>`` element for all of them (:func:`robot_links` walks them
once; a vehicle load gets the same records from its validation walk). See :mod:`aiauv_hydro.urdf.block_reader`
for the cylinder-frame convention of :func:`cylinder_frame`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import Element, ParseError

import defusedxml
import defusedxml.ElementTree as SafeElementTree
import numpy as np

from aiauv_hydro.spec import HydroError

#: Axis-direction components below this are treated as zero (URDF angles are rounded).
AXIS_SNAP_TOLERANCE = 1e-6
#: Relative tolerance of the symmetry and positive semi-definiteness checks of added mass.
MATRIX_TOLERANCE = 1e-9

DEFAULT_GRAVITY = 9.81


# --------------------------------------------------------------------------------------------------
# XML and number parsing shared with aiauv_hydro.urdf.uuv_simulator
# --------------------------------------------------------------------------------------------------


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def parse_robot(source: str | os.PathLike | Element) -> Element:
    """Parse URDF text or a URDF file safely and return its ``<robot>`` element.

    Args:
        source: A path, the XML text itself (a string whose first non-blank character is ``<``),
            or an already parsed ``<robot>`` element (returned as is).

    Returns:
        The root ``<robot>`` element.

    Raises:
        HydroError: Unreadable file, not XML, XML with a DTD or entities, or a root that is not
            ``<robot>``.
    """
    if isinstance(source, Element):
        return source
    if isinstance(source, bytes):
        source = source.decode("utf-8", errors="replace")
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return parse_robot_text(source)
    path = Path(source)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise HydroError(f"cannot read URDF file {path}: {_one_line(error)}") from None
    return parse_robot_text(text, str(path))


def parse_robot_text(text: str, where: str = "URDF text") -> Element:
    """Parse URDF text (never a file name) safely and return its ``<robot>`` element.

    Args:
        text: The XML text.
        where: How error messages name the source.

    Raises:
        HydroError: Not XML, XML with a DTD or entities, or a root that is not ``<robot>``.
    """
    try:
        root = SafeElementTree.fromstring(text, forbid_dtd=True)
    except defusedxml.DefusedXmlException:
        raise HydroError(f"{where} refused: XML with a DTD/entities") from None
    except ParseError as error:
        raise HydroError(f"{where} is not well-formed XML: {_one_line(error)}") from None
    if root.tag != "robot":
        raise HydroError(f"{where} is not a URDF file: root element is <{root.tag}>, not <robot>")
    return root


def parse_bool(text: str | None, what: str) -> bool:
    """An XML boolean (``1``, ``true``, ``0``, ``false``, any case, spaces around), as URDF and SDF
    files write them."""
    value = (text or "").strip().lower()
    if value in ("1", "true"):
        return True
    if value in ("0", "false"):
        return False
    raise HydroError(f"{what}: expected 0, 1, true or false, got '{_one_line(text or '')}'")


def parse_numbers(text: str | None, what: str) -> np.ndarray:
    """Whitespace-separated finite numbers.

    Args:
        text: The text to parse (``None`` counts as empty).
        what: Name used in error messages.

    Returns:
        The numbers as a 1-D float array.
    """
    values = []
    for token in (text or "").split():
        try:
            value = float(token)
        except ValueError:
            raise HydroError(f"{what}: '{token}' is not a number") from None
        if not math.isfinite(value):
            raise HydroError(f"{what}: '{token}' is not a finite number")
        values.append(value)
    return np.array(values, dtype=float)


def parse_vector(text: str | None, count: int, what: str) -> np.ndarray:
    """Exactly ``count`` finite numbers."""
    values = parse_numbers(text, what)
    if values.size != count:
        raise HydroError(f"{what}: expected {count} numbers, got {values.size}")
    return values


def parse_scalar(text: str | None, what: str) -> float:
    """Exactly one finite number."""
    return float(parse_vector(text, 1, what)[0])


def parse_matrix(text: str | None, what: str) -> np.ndarray:
    """A 6x6 matrix from 6 numbers (its diagonal) or 36 numbers (row-major)."""
    values = parse_numbers(text, what)
    if values.size == 6:
        return np.diag(values)
    if values.size == 36:
        return values.reshape(6, 6)
    raise HydroError(f"{what}: expected 6 (diagonal) or 36 (row-major) numbers, got {values.size}")


def check_added_mass(matrix: np.ndarray, what: str) -> None:
    """Raise unless ``matrix`` is symmetric PSD (tolerance relative to its 2-norm)."""
    scale = float(np.linalg.norm(matrix, 2))
    if np.max(np.abs(matrix - matrix.T), initial=0.0) > MATRIX_TOLERANCE * scale:
        raise HydroError(f"{what} is not symmetric")
    smallest = float(np.min(np.linalg.eigvalsh(0.5 * (matrix + matrix.T))))
    if smallest < -MATRIX_TOLERANCE * scale:
        raise HydroError(f"{what} is not positive semi-definite (eigenvalue {smallest:.6g})")


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    roll, pitch, yaw = (float(angle) for angle in rpy)
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _origin(element: Element, what: str) -> tuple[np.ndarray, np.ndarray]:
    """``(xyz, rpy)`` of an element's ``<origin>`` child (zeros if absent)."""
    origin = element.find("origin")
    if origin is None:
        return np.zeros(3), np.zeros(3)
    xyz = parse_vector(origin.get("xyz", "0 0 0"), 3, f"{what} <origin> xyz")
    rpy = parse_vector(origin.get("rpy", "0 0 0"), 3, f"{what} <origin> rpy")
    return xyz, rpy


# --------------------------------------------------------------------------------------------------
# URDF links
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CylinderGeometry:
    """A link's cylinder, placed as the slender-cylinder model needs it.

    Attributes:
        length: Cylinder length [m].
        radius: Cylinder radius [m].
        rotation: Orientation in the link frame of the cylinder frame (x on the axis) (3x3).
        translation: Rear end of the cylinder (cylinder-frame origin) in the link frame [m].
    """

    length: float
    radius: float
    rotation: np.ndarray
    translation: np.ndarray


@dataclass(frozen=True)
class UrdfLink:
    """What the hydrodynamics readers need from one URDF ``<link>``.

    Attributes:
        name: Link name.
        mass: ``<inertial><mass value>`` [kg], or ``None`` without an inertial.
        inertial_origin: Centre of mass in the link frame [m] (zeros without an inertial).
        cylinder: The link's first collision (else visual) cylinder, or ``None``.
        element: The ``<link>`` element itself, for readers that need more of it (UUV Simulator's
            blocks, :mod:`aiauv_pin.builders.uvms`) without walking the links again.
    """

    name: str
    mass: float | None
    inertial_origin: np.ndarray
    cylinder: CylinderGeometry | None
    element: Element | None = field(default=None, repr=False, compare=False)


def _minimal_rotation_from_x(axis: np.ndarray) -> np.ndarray:
    """Smallest rotation taking ``e_x`` to the unit vector ``axis`` (requires ``axis[0] > -1``)."""
    cosine = float(axis[0])
    if cosine == 1.0:
        return np.eye(3)
    k = np.cross([1.0, 0.0, 0.0], axis)  # sin(angle) times the unit rotation axis
    skew_k = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    # Rodrigues' formula with (1 - cos) / sin^2 = 1 / (1 + cos).
    return np.eye(3) + skew_k + skew_k @ skew_k / (1.0 + cosine)


def cylinder_frame(
    length: float, radius: float, xyz: np.ndarray, rpy: np.ndarray
) -> CylinderGeometry:
    """Cylinder frame (x on the axis, origin at the rear end) of a URDF cylinder.

    Args:
        length: URDF cylinder ``length`` [m].
        radius: URDF cylinder ``radius`` [m].
        xyz: Its ``<origin xyz>`` (the cylinder centre) in the link frame [m].
        rpy: Its ``<origin rpy>`` [rad]; the cylinder lies along the rotated z-axis.

    Returns:
        The cylinder placed in the link frame (see the module docstring for the choice of end).
    """
    axis = rpy_matrix(rpy)[:, 2]
    axis[np.abs(axis) < AXIS_SNAP_TOLERANCE] = 0.0
    axis /= np.linalg.norm(axis)
    centre = np.asarray(xyz, dtype=float)
    half = 0.5 * length
    if axis[0] > 0.0:
        sign = 1.0
    elif axis[0] < 0.0:
        sign = -1.0
    else:
        # Axis across the link: the end nearer the link origin is the rear end.
        sign = (
            1.0
            if np.linalg.norm(centre - half * axis) <= np.linalg.norm(centre + half * axis)
            else -1.0
        )
    axis = sign * axis
    rear_end = centre - half * axis
    rear_end[np.abs(rear_end) < 1e-12 * max(1.0, length)] = 0.0
    return CylinderGeometry(
        length=float(length),
        radius=float(radius),
        rotation=_minimal_rotation_from_x(axis),
        translation=rear_end,
    )


def _link_cylinder(link: Element, name: str) -> CylinderGeometry | None:
    for kind in ("collision", "visual"):
        for element in link.findall(kind):
            cylinder = element.find("geometry/cylinder")
            if cylinder is None:
                continue
            what = f"link '{name}' {kind} cylinder"
            length = parse_scalar(cylinder.get("length"), f"{what} length")
            radius = parse_scalar(cylinder.get("radius"), f"{what} radius")
            if length <= 0.0 or radius <= 0.0:
                raise HydroError(f"{what}: length and radius must be positive")
            xyz, rpy = _origin(element, f"link '{name}' {kind}")
            return cylinder_frame(length, radius, xyz, rpy)
    return None


def read_link(link: Element) -> UrdfLink:
    """What the hydrodynamics readers need from one ``<link>`` element (see :class:`UrdfLink`)."""
    name = link.get("name")
    if not name:
        raise HydroError("URDF <link> without a name")
    mass = None
    inertial_origin = np.zeros(3)
    inertial = link.find("inertial")
    if inertial is not None:
        mass_element = inertial.find("mass")
        if mass_element is not None:
            mass = parse_scalar(mass_element.get("value"), f"link '{name}' mass")
        inertial_origin, _ = _origin(inertial, f"link '{name}' inertial")
    return UrdfLink(name, mass, inertial_origin, _link_cylinder(link, name), link)


def robot_links(root: Element) -> dict[str, UrdfLink]:
    """The ``<link>`` elements of a ``<robot>``, by name (one walk; :func:`read_link` each).

    :func:`aiauv_pin.description.urdf_validation.validate_urdf` builds the same records in its own walk, so a
    vehicle load reads the links once and hands them to
    :func:`aiauv_hydro.urdf.block_reader.read_hydrodynamics`.
    """
    links: dict[str, UrdfLink] = {}
    for element in root.findall("link"):
        link = read_link(element)
        if link.name in links:
            raise HydroError(f"URDF link '{link.name}' defined twice")
        links[link.name] = link
    return links


def link_cylinders(source: str | os.PathLike | Element) -> dict[str, CylinderGeometry]:
    """Cylinder frames of the links that have a collision or visual cylinder.

    Args:
        source: URDF path, text or parsed ``<robot>`` element.

    Returns:
        ``{link name: CylinderGeometry}``.
    """
    links = robot_links(parse_robot(source))
    return {name: link.cylinder for name, link in links.items() if link.cylinder is not None}


# --------------------------------------------------------------------------------------------------
# The <hydrodynamics> block
# --------------------------------------------------------------------------------------------------
