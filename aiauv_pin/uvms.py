"""An underwater vehicle-manipulator system (UVMS): a cylindrical hull carrying a robot arm.

:func:`uvms_urdf` writes the URDF text of a hull link (root) with a fixed joint to the arm's base,
the arm's ``<link>`` and ``<joint>`` elements copied from its example-robot-data URDF (visual and
mesh collision geometry stripped: Pinocchio ignores them for the dynamics), and a
``<hydrodynamics>`` block:

* hull: a solid circular cylinder along its x-axis, ``model="slender_cylinder"`` (strip theory,
  :mod:`hydro.slender_cylinder`); its mass is chosen so the whole vehicle is neutrally buoyant, with
  its centre of gravity ``hull_cg_drop`` below the axis for a roll/pitch restoring moment;
* each arm link with mass: ``model="fossen"`` with explicit 6x6 matrices derived from an
  *equivalent ellipsoid* (semi-axes ``a, b, c`` along the link's principal axes, centred at the
  shape's centre, which is the centre of buoyancy):

  - from the link's first ``<collision>`` primitive: a sphere exactly; a box or a cylinder (along
    its local z) by the ellipsoid with the same volume and the same axis proportions;
  - links with mesh-only collision geometry (UR5, Panda): the *inertia-equivalent ellipsoid* of the
    link's ``<inertial>``: the homogeneous solid ellipsoid with the link's mass and principal
    moments, ``I_1 = m (b^2 + c^2) / 5`` and cyclic, so ``a^2 = 5 (I_2 + I_3 - I_1) / (2 m)``
    (standard solid-ellipsoid moments). Its volume is the link's volume at a uniform density, an
    approximation: the real link's displaced volume depends on its hollow parts.

Added mass of an ellipsoid in an ideal fluid (Lamb 1932, *Hydrodynamics*, Sec. 114-115): with
``alpha_0 = a b c int_0^inf dl / ((a^2 + l) D(l))``, ``D = sqrt((a^2+l)(b^2+l)(c^2+l))`` and
``beta_0``, ``gamma_0`` alike,

    m_11 = alpha_0 / (2 - alpha_0) rho V                                     (Lamb 1932, Sec. 115)
    m_44 = rho V / 5 (b^2 - c^2)^2 (gamma_0 - beta_0)
           / (2 (b^2 - c^2) + (b^2 + c^2)(beta_0 - gamma_0))                 (Lamb 1932, Sec. 115)

and cyclic permutations; the integrals are Carlson's ``R_D`` (``alpha_0 = 2/3 a b c R_D(b^2, c^2,
a^2)``; Carlson 1995, Numer. Algorithms 10, eq. (2.5) with the DLMF 19.16.5 definition). A sphere
gives ``m_11 = rho V / 2`` and no rotational added mass. The diagonal matrix in the ellipsoid frame
is moved to the link origin with the motion transform ``X`` of the ellipsoid frame,
``M_A = X^T diag(m) X`` (Fossen 2021, eq. (6.71) in matrix form), which keeps it symmetric PSD.

Damping (coarse, order of magnitude; switched off in the conservation tests): quadratic drag
``1/2 rho C_D A`` per translational axis with ``C_D = 1`` (bluff body; Hoerner 1965, *Fluid-Dynamic
Drag*, Ch. 3) and ``A`` the ellipsoid's projected area ``pi sqrt(b^2 c^2 n_1^2 + a^2 c^2 n_2^2 +
a^2 b^2 n_3^2)`` normal to the link axis ``n``; rotational quadratic drag of the flat strip of half
length ``l`` (largest semi-axis across the rotation axis) and width ``w`` (twice the other),
``rho C_D w l^4 / 4`` (the strip integral ``2 int_0^l 1/2 rho C_D w (omega x)^2 x dx``); linear
damping is the quadratic coefficient times ``v_ref = 0.1 m/s``, moved to the link origin like the
added mass. The quadratic matrices stay diagonal in the link frame (rotated diagonals, no lever
arm).
"""

from __future__ import annotations

import copy
import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import Element

import numpy as np
from scipy.special import elliprd

from hydro.spatial import motion_transform
from hydro.urdf_block import parse_robot, rpy_matrix

from .errors import VehicleLoadError
from .robots import example_robot_urdf
from .urdf_validation import validate_urdf

HULL_LINK = "hull"
HULL_JOINT = "hull_to_arm"
#: Default arm: Franka Emika Panda from example-robot-data (mesh-only collision geometry, except
#: the fingers). Its ``<mimic>`` tag is dropped: the two finger joints become independent. (UR5
#: works too, but its wrist inertias, about 0.11 kg m^2 for 1.2 kg, give 0.15 m^3 equivalent
#: ellipsoids.)
DEFAULT_ARM = "panda_description/urdf/panda.urdf"
#: Bluff-body drag coefficient of the arm links [-] (Hoerner 1965, Ch. 3).
DRAG_COEFFICIENT = 1.0
#: Speed turning quadratic drag coefficients into linear ones [m/s].
LINEAR_DAMPING_SPEED = 0.1
#: Relative difference of two semi-axes below which they count as equal.
_EQUAL_AXES = 1e-7


@dataclass(frozen=True)
class Ellipsoid:
    """A solid ellipsoid placed in a link frame.

    Attributes:
        semi_axes: ``(a, b, c)`` along the columns of ``rotation`` [m].
        rotation: Orientation of the ellipsoid's principal axes in the link frame (3x3).
        center: Centre in the link frame [m].
    """

    semi_axes: np.ndarray
    rotation: np.ndarray
    center: np.ndarray

    @property
    def volume(self) -> float:
        """``4/3 pi a b c`` [m^3]."""
        a, b, c = self.semi_axes
        return 4.0 / 3.0 * math.pi * a * b * c


def lamb_coefficients(semi_axes) -> np.ndarray:
    """Lamb's ``(alpha_0, beta_0, gamma_0)`` of an ellipsoid (they sum to 2).

    ``alpha_0 = 2/3 a b c R_D(b^2, c^2, a^2)`` (Lamb 1932, Sec. 114; Carlson's ``R_D``).
    """
    a, b, c = (float(s) for s in semi_axes)
    a2, b2, c2 = a * a, b * b, c * c
    abc = a * b * c
    return np.array(
        [
            2.0 / 3.0 * abc * elliprd(b2, c2, a2),
            2.0 / 3.0 * abc * elliprd(c2, a2, b2),
            2.0 / 3.0 * abc * elliprd(a2, b2, c2),
        ]
    )


def ellipsoid_added_mass(semi_axes, fluid_density: float) -> np.ndarray:
    """Diagonal added mass ``(m_11, m_22, m_33, m_44, m_55, m_66)`` in the ellipsoid's frame.

    Args:
        semi_axes: ``(a, b, c)`` [m].
        fluid_density: ``rho`` [kg/m^3].

    Returns:
        [kg, kg, kg, kg m^2, kg m^2, kg m^2] (Lamb 1932, Sec. 115).
    """
    axes = np.asarray(semi_axes, dtype=float)
    coefficients = lamb_coefficients(axes)
    displaced = fluid_density * 4.0 / 3.0 * math.pi * float(np.prod(axes))
    translational = coefficients / (2.0 - coefficients) * displaced  # Lamb 1932, Sec. 115
    rotational = np.zeros(3)
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        s2, t2 = axes[i] ** 2, axes[j] ** 2
        if abs(s2 - t2) <= _EQUAL_AXES * (s2 + t2):
            continue  # a body of revolution about this axis: no rotational added mass
        d = coefficients[i] - coefficients[j]
        # Lamb 1932, Sec. 115 (cyclic in (a, b, c))
        value = displaced / 5.0 * (s2 - t2) ** 2 * (-d) / (2.0 * (s2 - t2) + (s2 + t2) * d)
        rotational[k] = max(value, 0.0)
    return np.concatenate((translational, rotational))


def inertia_equivalent_ellipsoid(
    mass: float, inertia: np.ndarray, rotation: np.ndarray, center: np.ndarray
) -> Ellipsoid:
    """The homogeneous solid ellipsoid with a body's mass and principal moments.

    Args:
        mass: [kg] (> 0).
        inertia: Inertia about the centre of mass in the frame ``rotation`` (3x3) [kg m^2].
        rotation: Orientation of that frame in the link frame.
        center: Centre of mass in the link frame [m].

    Raises:
        VehicleLoadError: The moments break the triangle inequality (no ellipsoid has them).
    """
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    total = moments.sum()
    squared = 5.0 / (2.0 * mass) * (total - 2.0 * moments)  # a^2 = 5 (I_2 + I_3 - I_1) / (2 m)
    if np.any(squared <= 0.0):
        raise VehicleLoadError(
            f"inertia moments {moments} break the triangle inequality: no equivalent ellipsoid"
        )
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] *= -1.0
    return Ellipsoid(np.sqrt(squared), np.asarray(rotation) @ axes, np.asarray(center, dtype=float))


def primitive_ellipsoid(shape: Element, xyz: np.ndarray, rpy: np.ndarray) -> Ellipsoid | None:
    """Equivalent ellipsoid of a URDF ``<box>``, ``<cylinder>`` or ``<sphere>`` (else ``None``).

    A sphere is itself; a box or cylinder becomes the ellipsoid with its volume and axis
    proportions.
    """
    rotation = rpy_matrix(rpy)
    if shape.tag == "sphere":
        radius = float(shape.get("radius"))
        return Ellipsoid(np.full(3, radius), rotation, xyz)
    if shape.tag == "box":
        half = 0.5 * np.array([float(s) for s in shape.get("size").split()])
        volume = 8.0 * float(np.prod(half))
    elif shape.tag == "cylinder":
        radius, length = float(shape.get("radius")), float(shape.get("length"))
        half = np.array([radius, radius, 0.5 * length])
        volume = math.pi * radius * radius * length
    else:
        return None
    scale = (volume / (4.0 / 3.0 * math.pi * float(np.prod(half)))) ** (1.0 / 3.0)
    return Ellipsoid(scale * half, rotation, xyz)


@dataclass(frozen=True)
class EllipsoidHydrodynamics:
    """Fossen-model parameters of one link, about the link origin in link axes.

    Attributes:
        volume: [m^3].
        center_of_buoyancy: [m].
        added_mass: 6x6, symmetric PSD.
        linear_damping: 6x6, symmetric PSD.
        quadratic_damping: Diagonal (6,).
    """

    volume: float
    center_of_buoyancy: np.ndarray
    added_mass: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray


def ellipsoid_hydrodynamics(ellipsoid: Ellipsoid, fluid_density: float) -> EllipsoidHydrodynamics:
    """Added mass and damping of an ellipsoid, about the link origin (see the module docstring)."""
    a, b, c = ellipsoid.semi_axes
    rho = fluid_density
    transform = motion_transform(ellipsoid.rotation, ellipsoid.center)
    added = transform.T @ np.diag(ellipsoid_added_mass(ellipsoid.semi_axes, rho)) @ transform
    added = 0.5 * (added + added.T)
    # quadratic drag in the ellipsoid frame: projected areas and rotating strips
    areas = math.pi * np.array([b * c, a * c, a * b])
    semi = ellipsoid.semi_axes
    strips = np.zeros(3)
    for k in range(3):
        across = sorted((semi[(k + 1) % 3], semi[(k + 2) % 3]))
        strips[k] = rho * DRAG_COEFFICIENT * 2.0 * across[0] * across[1] ** 4 / 4.0
    principal = np.concatenate((0.5 * rho * DRAG_COEFFICIENT * areas, strips))
    linear = transform.T @ np.diag(LINEAR_DAMPING_SPEED * principal) @ transform
    linear = 0.5 * (linear + linear.T)
    weights = ellipsoid.rotation**2  # link axis i gets sum_j R_ij^2 d_j
    quadratic = np.concatenate((weights @ principal[:3], weights @ principal[3:]))
    return EllipsoidHydrodynamics(
        ellipsoid.volume, ellipsoid.center.copy(), added, linear, quadratic
    )


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
    links = {link.get("name"): link for link in arm_root.findall("link")}
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
    for element in arm_root.findall("link"):
        if element.get("name") in dropped:
            continue
        copied = ET.SubElement(robot, "link", name=element.get("name"))
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
        ellipsoid = _link_ellipsoid(links[link_name], inertial)
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
    from .atomic import write_text

    return write_text(path, uvms_urdf(arm, **options))
