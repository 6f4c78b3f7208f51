"""Reader of UUV Simulator per-link hydrodynamic blocks, converted to this package's conventions.

UUV Simulator (github.com/uuvsimulator/uuv_simulator, Apache-2.0) describes a vehicle's
hydrodynamics inside ``<gazebo><plugin filename="libunderwater_object_ros_plugin.so">``::

    <fluid_density>1028.0</fluid_density>
    <link name="rexrov/base_link">          <!-- the URDF link name, namespace prefix included -->
      <neutrally_buoyant>0</neutrally_buoyant>
      <volume>1.83826</volume>
      <center_of_buoyancy>0 0 0.3</center_of_buoyancy>
      <hydrodynamic_model>
        <type>fossen</type>
        <added_mass>36 numbers</added_mass>
        <linear_damping>6 or 36 numbers</linear_damping>
        <quadratic_damping>6 or 36 numbers</quadratic_damping>
      </hydrodynamic_model>
    </link>

What UUV Simulator's source does with them (uuv_gazebo_plugins ``HydrodynamicModel.cc``,
``BuoyantObject.cc``, ``UnderwaterObjectPlugin.cc``, checked for this module):

* ``HMFossen::ApplyHydrodynamicForces`` flips the link's (forward-left-up) velocity to the SNAME
  forward-right-down axes (``ToNEDConvention``: y and z of both the linear and angular parts change
  sign), evaluates ``tau = -M_A nu_dot - C_A(nu) nu - D(nu) nu`` there and flips the wrench back.
  So ``added_mass`` and the damping are in FRD axes about the link origin. With
  ``T = diag(1, -1, -1, 1, -1, -1)`` (``T = T^-1 = T^T``) our link-frame matrices are ``T M T``.
  (Early releases, before ``ToNEDConvention`` was added, used the Gazebo axes directly; the vehicle
  descriptions shipped with the current code, e.g. RexROV's SNAME data from Berg 2012, are FRD.)
* ``ComputeDampingMatrix`` builds ``D = -DLin - u DLinForwardSpeed - diag(DNonLin_ii |nu_i|)`` and
  applies ``-D nu``: the coefficients are hydrodynamic derivatives (``X_u``, ``X_|u|u``, ...),
  negative for a dissipative body. Ours (wrench ``-D nu``, positive = dissipative) are
  ``D_L = -T DLin T`` and ``D_Q = -diag(DNonLin)`` (only the diagonal of a 36-number quadratic
  damping is used, as UUV Simulator does; ``T`` leaves diagonals unchanged). Converted damping
  with a negative diagonal entry (a positive coefficient in the file, which would feed energy into
  the vehicle) is refused.
* ``center_of_buoyancy`` is NOT flipped: ``BuoyantObject::ApplyBuoyancyForce`` applies the buoyancy
  with ``AddForceAtRelativePosition(force, CoB)``, i.e. the CoB is in the Gazebo link frame, which
  is already forward-left-up (RexROV gives ``0 0 0.3``, above its centre of gravity).
* ``neutrally_buoyant`` true sets ``volume = link mass / fluid density``; we take the mass from the
  link's URDF ``<inertial>`` and use the vehicle's final fluid density.
* Link names are looked up verbatim (``model->GetLink(name)``); the vehicle descriptions use
  ``${namespace}/base_link``, so the expanded names carry the namespace prefix
  (``rexrov/base_link``), exactly as the URDF ``<link>`` names do. We match them verbatim too.
* ``fluid_density`` defaults to 1028 kg/m^3 when a plugin omits it.

Not representable here and therefore reported by a warning: ``linear_damping_forward_speed`` (a
damping proportional to surge speed), off-diagonal quadratic damping (ignored by UUV Simulator as
well) and surface-vessel (metacentric) parameters. UUV Simulator applies the hydrodynamic wrench
with Gazebo's ``AddRelativeForce``, i.e. at the link's centre of mass; we read the parameters as
given about the link origin (as its velocities are), so a warning is issued when the link's inertial
origin is offset from it. A slightly asymmetric added mass (as RexROV's, 10.774 vs 10.775) is
symmetrised with a warning; an asymmetry above 1e-3 of its norm is refused. A missing
``center_of_buoyancy`` is computed as UUV Simulator does (volume-weighted centroid of the collision
shapes) when all collision shapes are boxes, cylinders or spheres, and refused otherwise.
"""

from __future__ import annotations

import math
import os
import warnings
from xml.etree.ElementTree import Element

import numpy as np

from hydro.spec import HydroError, HydroSpec, LinkHydrodynamics
from hydro.urdf_block import (
    DEFAULT_GRAVITY,
    MATRIX_TOLERANCE,
    UrdfLink,
    check_added_mass,
    parse_numbers,
    parse_robot,
    parse_scalar,
    parse_vector,
    robot_links,
)

#: UUV Simulator's default fluid density (BuoyantObject / UnderwaterObjectPlugin) [kg/m^3].
UUV_DEFAULT_FLUID_DENSITY = 1028.0
#: Velocity/wrench axis flip between FRD (SNAME) and FLU link axes; its own inverse.
FRD_TO_FLU = np.diag([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])
#: Largest added-mass asymmetry (relative to its 2-norm) that is symmetrised with a warning.
MAX_SYMMETRISED_ASYMMETRY = 1e-3


def _is_hydro_plugin(plugin: Element) -> bool:
    if "underwater_object" in plugin.get("filename", ""):
        return True
    return any(link.find("hydrodynamic_model") is not None for link in plugin.findall("link"))


def uuv_plugins(root: Element) -> list[Element]:
    """The UUV Simulator underwater-object plugin elements of a ``<robot>``."""
    return [plugin for plugin in root.findall("gazebo/plugin") if _is_hydro_plugin(plugin)]


def uuv_fluid_density(root: Element) -> float | None:
    """Fluid density of the UUV Simulator plugins (1028 if omitted); ``None`` without plugins."""
    densities = set()
    for plugin in uuv_plugins(root):
        if not plugin.findall("link"):
            continue
        element = plugin.find("fluid_density")
        if element is None:
            densities.add(UUV_DEFAULT_FLUID_DENSITY)
        else:
            densities.add(parse_scalar(element.text, "UUV Simulator plugin fluid_density"))
    if not densities:
        return None
    if len(densities) > 1:
        raise HydroError(f"UUV Simulator plugins disagree on fluid_density: {sorted(densities)}")
    density = densities.pop()
    if not density > 0.0:
        raise HydroError(f"UUV Simulator fluid_density must be positive, got {density}")
    return density


def convert_fossen_matrices(
    added_mass: np.ndarray,
    linear_damping: np.ndarray,
    quadratic_damping: np.ndarray,
    what: str = "UUV Simulator link",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """UUV Simulator (FRD axes, negative damping) matrices to ours (FLU axes, positive damping).

    Args:
        added_mass: ``M_A`` as given (6x6, FRD); symmetrised with a warning if slightly asymmetric.
        linear_damping: ``DLin`` as given (6x6, FRD, negative = dissipative).
        quadratic_damping: ``DNonLin`` as given (6x6, FRD); only its diagonal is used.
        what: Name used in messages.

    Returns:
        ``(M_A, D_L, D_Q)`` in the link's FLU axes with ``M_A = T M T``, ``D_L = -T DLin T`` and
        ``D_Q = -diag(DNonLin)``, ``T = diag(1, -1, -1, 1, -1, -1)``.
    """
    added_mass = np.array(added_mass, dtype=float)
    scale = float(np.linalg.norm(added_mass, 2))
    asymmetry = float(np.max(np.abs(added_mass - added_mass.T)))
    if asymmetry > MATRIX_TOLERANCE * scale:
        if asymmetry > MAX_SYMMETRISED_ASYMMETRY * scale:
            raise HydroError(
                f"{what} added_mass is not symmetric (largest difference {asymmetry:.6g})"
            )
        warnings.warn(
            f"{what} added_mass is slightly asymmetric (largest difference {asymmetry:.6g}); "
            "using (M + M^T) / 2",
            stacklevel=3,
        )
        added_mass = 0.5 * (added_mass + added_mass.T)
    # M_ours = T M_frd T: nu_frd = T nu_flu and wrench_flu = T wrench_frd.
    added_mass = FRD_TO_FLU @ added_mass @ FRD_TO_FLU
    check_added_mass(added_mass, f"{what} added_mass")

    # UUV Simulator's damping wrench is +DLin nu (D = -DLin, tau = -D nu); ours is -D_L nu.
    linear = -(FRD_TO_FLU @ np.asarray(linear_damping, dtype=float) @ FRD_TO_FLU)
    quadratic_given = np.asarray(quadratic_damping, dtype=float)
    off_diagonal = quadratic_given - np.diag(np.diag(quadratic_given))
    if np.any(off_diagonal != 0.0):
        warnings.warn(
            f"{what} quadratic_damping has off-diagonal entries; UUV Simulator ignores them and so "
            "does this reader",
            stacklevel=3,
        )
    quadratic = -np.diag(np.diag(quadratic_given))
    for name, matrix in (("linear_damping", linear), ("quadratic_damping", quadratic)):
        diagonal = np.diag(matrix)
        if np.any(diagonal < 0.0):
            index = int(np.argmin(diagonal))
            raise HydroError(
                f"{what} {name}[{index}] is positive in the file; UUV Simulator expects negative "
                "(dissipative) damping coefficients"
            )
    return added_mass, linear, quadratic


def _uuv_matrix(element: Element | None, what: str, allow_diagonal: bool) -> np.ndarray:
    if element is None:
        return np.zeros((6, 6))
    values = parse_numbers(element.text, what)
    if values.size == 36:
        return values.reshape(6, 6)
    if values.size == 6 and allow_diagonal:
        return np.diag(values)
    expected = "6 or 36" if allow_diagonal else "36"
    raise HydroError(f"{what}: expected {expected} numbers, got {values.size}")


def _parse_bool(text: str | None, what: str) -> bool:
    value = (text or "").strip().lower()
    if value in ("1", "true"):
        return True
    if value in ("0", "false"):
        return False
    raise HydroError(f"{what}: expected 0, 1, true or false, got '{text}'")


def _collision_centroid(link: Element, name: str, what: str) -> np.ndarray:
    """Volume-weighted centroid of primitive collision shapes (UUV Simulator's CoB estimate)."""
    total, moment = 0.0, np.zeros(3)
    for collision in link.findall("collision"):
        geometry = collision.find("geometry")
        shape = None if geometry is None else next(iter(geometry), None)
        if shape is None or shape.tag not in ("box", "cylinder", "sphere"):
            raise HydroError(
                f"{what}: no center_of_buoyancy and a non-primitive collision shape to estimate it"
            )
        if shape.tag == "box":
            volume = float(np.prod(parse_vector(shape.get("size"), 3, f"{what} box size")))
        elif shape.tag == "cylinder":
            radius = parse_scalar(shape.get("radius"), f"{what} cylinder radius")
            volume = (
                math.pi * radius**2 * parse_scalar(shape.get("length"), f"{what} cylinder length")
            )
        else:
            volume = (
                4.0
                / 3.0
                * math.pi
                * parse_scalar(shape.get("radius"), f"{what} sphere radius") ** 3
            )
        origin = collision.find("origin")
        centre = (
            np.zeros(3)
            if origin is None
            else parse_vector(origin.get("xyz", "0 0 0"), 3, f"{what} collision origin xyz")
        )
        total += volume
        moment += volume * centre
    if total <= 0.0:
        raise HydroError(f"{what}: no center_of_buoyancy and no collision volume to estimate it")
    return moment / total


def _uuv_link(
    element: Element, urdf_link: UrdfLink, link_element: Element, fluid_density: float
) -> LinkHydrodynamics:
    name = urdf_link.name
    what = f"UUV Simulator link '{name}'"
    model = element.find("hydrodynamic_model")
    if model is None:
        raise HydroError(f"{what}: missing <hydrodynamic_model>")
    kind = (model.findtext("type") or "").strip()
    if kind != "fossen":
        raise HydroError(
            f"{what}: hydrodynamic_model type '{kind}' is not supported (only fossen is)"
        )
    added_mass = _uuv_matrix(model.find("added_mass"), f"{what} added_mass", allow_diagonal=False)
    linear = _uuv_matrix(model.find("linear_damping"), f"{what} linear_damping", True)
    quadratic = _uuv_matrix(model.find("quadratic_damping"), f"{what} quadratic_damping", True)
    forward = _uuv_matrix(
        model.find("linear_damping_forward_speed"), f"{what} linear_damping_forward_speed", True
    )
    if np.any(forward != 0.0):
        warnings.warn(
            f"{what}: linear_damping_forward_speed is not supported and is ignored", stacklevel=4
        )
    if (
        element.find("metacentric_width") is not None
        or element.find("metacentric_length") is not None
    ):
        warnings.warn(
            f"{what}: surface-vessel (metacentric) parameters unsupported; treated as submerged",
            stacklevel=4,
        )
    added_mass, linear, quadratic = convert_fossen_matrices(added_mass, linear, quadratic, what)

    neutral_element = element.find("neutrally_buoyant")
    neutral = neutral_element is not None and _parse_bool(
        neutral_element.text, f"{what} neutrally_buoyant"
    )
    if neutral:
        if urdf_link.mass is None:
            raise HydroError(f"{what}: neutrally_buoyant needs the link's <inertial> mass")
        volume = urdf_link.mass / fluid_density  # buoyancy rho V g equals weight m g
    else:
        volume_element = element.find("volume")
        if volume_element is None:
            raise HydroError(f"{what}: missing <volume> (and not neutrally_buoyant)")
        volume = parse_scalar(volume_element.text, f"{what} volume")
        if volume < 0.0:
            raise HydroError(f"{what}: volume must be >= 0, got {volume}")

    cob_element = element.find("center_of_buoyancy")
    if cob_element is None:
        center = _collision_centroid(link_element, name, what)
    else:
        # Gazebo link frame (forward-left-up) already: no axis flip (BuoyantObject.cc).
        center = parse_vector(cob_element.text, 3, f"{what} center_of_buoyancy")

    if np.any(urdf_link.inertial_origin != 0.0) and (
        np.any(added_mass) or np.any(linear) or np.any(quadratic)
    ):
        warnings.warn(
            f"{what}: inertial origin is offset from the link origin; the matrices are read about "
            "the link origin, whereas UUV Simulator applies its wrench at the centre of mass",
            stacklevel=4,
        )
    return LinkHydrodynamics(
        link=name,
        model="fossen",
        volume=volume,
        center_of_buoyancy=center,
        added_mass=added_mass,
        linear_damping=linear,
        quadratic_damping=quadratic,
    )


def uuv_links(
    root: Element,
    links: dict[str, UrdfLink],
    fluid_density: float,
    skip: set[str] | frozenset[str] = frozenset(),
) -> list[LinkHydrodynamics]:
    """Converted parameters of every link named in the UUV Simulator plugins.

    Args:
        root: The ``<robot>`` element.
        links: The robot's links (:func:`hydro.urdf_block.robot_links`).
        fluid_density: Density used for ``neutrally_buoyant`` links [kg/m^3].
        skip: Link names to leave out (given elsewhere).

    Returns:
        One ``fossen`` :class:`LinkHydrodynamics` per UUV Simulator link, in file order.
    """
    link_elements = {element.get("name"): element for element in root.findall("link")}
    result: list[LinkHydrodynamics] = []
    seen: set[str] = set()
    for plugin in uuv_plugins(root):
        for element in plugin.findall("link"):
            name = element.get("name")
            if not name:
                raise HydroError("UUV Simulator plugin <link> without a name")
            if name in seen:
                raise HydroError(f"UUV Simulator link '{name}' given twice")
            seen.add(name)
            if name in skip:
                continue
            if name not in links:
                raise HydroError(f"UUV Simulator link '{name}' is not a <link> of the robot")
            result.append(_uuv_link(element, links[name], link_elements[name], fluid_density))
    return result


def read_uuv_simulator(source: str | os.PathLike | Element) -> HydroSpec:
    """Read only the UUV Simulator blocks of a URDF.

    Args:
        source: URDF path, text or parsed ``<robot>`` element.

    Returns:
        The converted parameters, with the plugins' fluid density (1028 if absent) and gravity 9.81.
        :func:`hydro.urdf_block.read_hydrodynamics` reads these blocks too, merged with ours.
    """
    root = parse_robot(source)
    links = robot_links(root)
    density = uuv_fluid_density(root)
    if density is None:
        density = UUV_DEFAULT_FLUID_DENSITY
    return HydroSpec(
        fluid_density=density,
        gravity=DEFAULT_GRAVITY,
        links=tuple(uuv_links(root, links, density)),
    )
