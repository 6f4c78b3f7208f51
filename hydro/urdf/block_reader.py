"""Reader of the ``<hydrodynamics>`` block of a URDF file.

The block is a top-level child of ``<robot>`` (URDF parsers ignore unknown top-level elements)::

    <hydrodynamics fluid_density="1000" gravity="9.81">
      <link name="hull" model="fossen">        <!-- link frame, about the link origin -->
        <volume>0.0305</volume>                                   <!-- [m^3], required -->
        <center_of_buoyancy>0.05 0 0.02</center_of_buoyancy>      <!-- [m], default 0 -->
        <added_mass>6 (diagonal) or 36 (row-major, symmetric PSD) numbers</added_mass>
        <linear_damping>6 or 36; wrench -D_L nu, positive = dissipative</linear_damping>
        <quadratic_damping>6 or 36; wrench -D_Q (|nu| * nu)</quadratic_damping>
        <linear_damping_forward_speed>6 or 36; wrench -u D_F nu</linear_damping_forward_speed>
      </link>
      <link name="link3" model="slender_cylinder" C_dC="0.9"/>
      <thruster name="t1" link="link3" xyz="0.237 0 0" direction="0 0 1" max_thrust="50"
                time_constant="0.2" max_rate="100"/>    <!-- both optional: [s], [N/s] -->
      <fin name="rudder" link="tail" xyz="-0.4 0 0.05" axis="0 0 1" chord="1 0 0" area="0.01"
           lift_slope="3.0" drag_zero="0.01" drag_slope="1.2" stall_angle="0.4"
           max_angle="0.5" max_rate="1.0" time_constant="0.1"/>
    </hydrodynamics>

A ``<fin>`` (:class:`aiauv_hydro.spec.Fin`, law :func:`aiauv_hydro.laws.lift.fin_force`) needs
``name``, ``link``, ``axis``, ``chord``, ``area``, ``lift_slope`` and ``max_angle``; ``xyz``
defaults to the link origin, ``drag_zero`` and ``drag_slope`` to 0, ``stall_angle``, ``max_rate`` to
``inf`` (no stall, no rate limit) and ``time_constant`` to 0.

Defaults: ``fluid_density`` 1025 kg/m^3, ``gravity`` 9.81 m/s^2; missing ``fossen`` matrices are
zero. A ``slender_cylinder`` link takes its length and radius from the link's first ``<collision>``
cylinder (else its first ``<visual>`` cylinder) and the coefficients of
:class:`aiauv_hydro.estimate.slender_cylinder.SlenderCylinderCoefficients`; attributes ``C_a``, ``alpha``,
``C_d1``, ``C_d4``, ``C_dC``, ``C_dL``, ``beta``, ``gamma``, ``v_ref``, ``length`` and ``radius``
override them, children ``<volume>`` and ``<center_of_buoyancy>`` override the cylinder's volume
and centroid.

Cylinder frame from a URDF cylinder (which lies along the local z-axis of its ``<origin>``, centred
on it): the cylinder frame's x-axis is the cylinder axis oriented so that it points forward along
the link (non-negative link-x component; for an axis perpendicular to link x, the orientation that
makes the end nearer the link origin the rear end). The frame's origin is the rear end, and its
orientation is the smallest rotation taking link x onto that axis, so a cylinder along link x gives
the link's own axes. Axis components below 1e-6 are set to zero (URDF files write pi/2 as
1.5707963). For the paper's links (``<origin xyz="L/2 0 0" rpy="0 1.5707963 0"/>``) the cylinder
frame is the link frame.

UUV Simulator blocks (``<gazebo><plugin>`` with ``<link><hydrodynamic_model>``) in the same file are
read too (:mod:`aiauv_hydro.urdf.uuv_simulator`), and so are its thruster and fin plugins; for a
link (or a thruster or fin name) given in both, this block wins. Fluid density:
this block's ``fluid_density`` attribute if given, else the UUV Simulator plugin's
``<fluid_density>`` (UUV Simulator's default 1028 if the plugin has UUV links but no density), else
1025.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping
from dataclasses import fields
from xml.etree.ElementTree import Element

import numpy as np

from aiauv_hydro.estimate.slender_cylinder import SlenderCylinderCoefficients, slender_cylinder_link
from aiauv_hydro.spec import Fin, HydroError, HydroSpec, LinkHydrodynamics, Thruster
from aiauv_hydro.urdf import uuv_simulator
from aiauv_hydro.urdf.xml_reading import (  # noqa: F401  (re-exported: the block's readers use them)
    AXIS_SNAP_TOLERANCE,
    DEFAULT_GRAVITY,
    MATRIX_TOLERANCE,
    CylinderGeometry,
    UrdfLink,
    check_added_mass,
    cylinder_frame,
    link_cylinders,
    parse_matrix,
    parse_numbers,
    parse_robot,
    parse_robot_text,
    parse_scalar,
    parse_vector,
    robot_links,
    rpy_matrix,
)

DEFAULT_FLUID_DENSITY = 1025.0

#: Plausible range of a cylinder's length and radius [m] (the table of
#: :data:`aiauv_pin.description.plausible_ranges.PLAUSIBLE_RANGES`): checked here before anything
#: is computed from
#: them (a length of 1e308 would overflow computing the cylinder's inertia).
LENGTH_RANGE = (1e-4, 1e3)
#: Largest dimensionless slender-cylinder coefficient (drag coefficients of cylinders are 0.1
#: to 2 and added-mass coefficients about 1; Hoerner 1965, Fossen 2021 Sec. 6.4).
MAX_DIMENSIONLESS = 1e3
#: Plausible range of the reference speed ``v_ref`` [m/s].
V_REF_RANGE = (1e-3, 1e3)


def _check_slender_ranges(length: float, radius: float, coefficients, what: str) -> None:
    """Refuse a slender cylinder outside the plausible ranges above (one line naming it)."""
    for name, value in (("length", length), ("radius", radius)):
        if not LENGTH_RANGE[0] <= value <= LENGTH_RANGE[1]:
            raise HydroError(
                f"{what}: cylinder {name} = {value:.4g} m outside the plausible range "
                f"[{LENGTH_RANGE[0]:g}, {LENGTH_RANGE[1]:g}]"
            )
    for item in fields(coefficients):
        value = getattr(coefficients, item.name)
        low, high = V_REF_RANGE if item.name == "v_ref" else (0.0, MAX_DIMENSIONLESS)
        if not low <= value <= high:
            raise HydroError(
                f"{what}: {item.name} = {value:.4g} outside the plausible range [{low:g}, {high:g}]"
            )


_COEFFICIENT_NAMES = tuple(item.name for item in fields(SlenderCylinderCoefficients))


def _children(element: Element, allowed: tuple[str, ...], what: str) -> dict[str, Element]:
    found: dict[str, Element] = {}
    for child in element:
        if not isinstance(child.tag, str):
            continue  # comments and processing instructions
        if child.tag not in allowed:
            raise HydroError(f"{what}: unknown element <{child.tag}>")
        if child.tag in found:
            raise HydroError(f"{what}: <{child.tag}> given twice")
        found[child.tag] = child
    return found


def _check_attributes(element: Element, allowed: tuple[str, ...], what: str) -> None:
    for attribute in element.attrib:
        if attribute not in allowed:
            raise HydroError(f"{what}: unknown attribute '{attribute}'")


def _volume(element: Element | None, what: str) -> float | None:
    if element is None:
        return None
    volume = parse_scalar(element.text, f"{what} volume")
    if volume < 0.0:
        raise HydroError(f"{what}: volume must be >= 0, got {volume}")
    return volume


def _fossen_link(element: Element, name: str) -> LinkHydrodynamics:
    what = f"<hydrodynamics> link '{name}'"
    _check_attributes(element, ("name", "model"), what)
    children = _children(
        element,
        (
            "volume",
            "center_of_buoyancy",
            "added_mass",
            "linear_damping",
            "quadratic_damping",
            "linear_damping_forward_speed",
        ),
        what,
    )
    volume = _volume(children.get("volume"), what)
    if volume is None:
        raise HydroError(f"{what}: fossen model needs <volume>")
    center = np.zeros(3)
    if "center_of_buoyancy" in children:
        center = parse_vector(children["center_of_buoyancy"].text, 3, f"{what} center_of_buoyancy")
    matrices = {}
    for tag in (
        "added_mass",
        "linear_damping",
        "quadratic_damping",
        "linear_damping_forward_speed",
    ):
        child = children.get(tag)
        matrices[tag] = (
            np.zeros((6, 6)) if child is None else parse_matrix(child.text, f"{what} {tag}")
        )
    check_added_mass(matrices["added_mass"], f"{what} added_mass")
    return LinkHydrodynamics(
        link=name,
        model="fossen",
        volume=volume,
        center_of_buoyancy=center,
        added_mass=matrices["added_mass"],
        linear_damping=matrices["linear_damping"],
        quadratic_damping=matrices["quadratic_damping"],
        forward_speed_damping=matrices["linear_damping_forward_speed"],
    )


def _slender_cylinder_link(
    element: Element, name: str, urdf_link: UrdfLink, fluid_density: float
) -> LinkHydrodynamics:
    what = f"<hydrodynamics> link '{name}'"
    _check_attributes(element, ("name", "model", "length", "radius", *_COEFFICIENT_NAMES), what)
    children = _children(element, ("volume", "center_of_buoyancy"), what)
    overrides = {
        key: parse_scalar(element.get(key), f"{what} {key}")
        for key in _COEFFICIENT_NAMES
        if key in element.attrib
    }
    coefficients = SlenderCylinderCoefficients(**overrides)
    geometry = urdf_link.cylinder
    length = geometry.length if geometry is not None else None
    radius = geometry.radius if geometry is not None else None
    if "length" in element.attrib:
        length = parse_scalar(element.get("length"), f"{what} length")
    if "radius" in element.attrib:
        radius = parse_scalar(element.get("radius"), f"{what} radius")
    if length is None or radius is None:
        raise HydroError(
            f"{what}: slender_cylinder model needs a <collision> or <visual> cylinder "
            "(or length and radius attributes)"
        )
    if not (length > 0.0 and radius > 0.0):
        raise HydroError(f"{what}: length and radius must be positive")
    _check_slender_ranges(length, radius, coefficients, what)
    center = None
    if "center_of_buoyancy" in children:
        center = parse_vector(children["center_of_buoyancy"].text, 3, f"{what} center_of_buoyancy")
    return slender_cylinder_link(
        name,
        length,
        radius,
        fluid_density,
        volume=_volume(children.get("volume"), what),
        center_of_buoyancy=center,
        coefficients=coefficients,
        rotation=None if geometry is None else geometry.rotation,
        translation=None if geometry is None else geometry.translation,
    )


def _attached_link(element: Element, links: Mapping[str, UrdfLink], what: str) -> str:
    """The robot link a ``<thruster>`` or ``<fin>`` element is attached to (its ``link``
    attribute); the element must have no child elements."""
    for child in element:
        if isinstance(child.tag, str):
            raise HydroError(f"{what}: unexpected child element <{child.tag}>")
    link = element.get("link")
    if not link:
        raise HydroError(f"{what}: missing link attribute")
    if link not in links:
        raise HydroError(f"{what}: link '{link}' is not a <link> of the robot")
    return link


def _thruster(element: Element, links: dict[str, UrdfLink]) -> Thruster:
    name = element.get("name")
    if not name:
        raise HydroError("<hydrodynamics> <thruster> without a name")
    what = f"thruster '{name}'"
    _check_attributes(
        element,
        ("name", "link", "xyz", "direction", "max_thrust", "time_constant", "max_rate"),
        what,
    )
    link = _attached_link(element, links, what)
    if "direction" not in element.attrib:
        raise HydroError(f"{what}: missing direction attribute")
    if "max_thrust" not in element.attrib:
        raise HydroError(f"{what}: missing max_thrust attribute")
    direction = parse_vector(element.get("direction"), 3, f"{what} direction")
    if not np.any(direction):
        raise HydroError(f"{what}: direction is the zero vector")
    return Thruster(
        name=name,
        link=link,
        position=parse_vector(element.get("xyz", "0 0 0"), 3, f"{what} xyz"),
        direction=direction,
        max_thrust=parse_scalar(element.get("max_thrust"), f"{what} max_thrust"),
        **_dynamics(element, what),
    )


def _optional_scalar(element: Element, name: str, what: str, default: float) -> float:
    """Attribute ``name`` as a float (``inf`` allowed), or ``default`` when absent."""
    text = element.get(name)
    if text is None:
        return default
    if text.strip() in ("inf", "+inf"):
        return math.inf
    return parse_scalar(text, f"{what} {name}")


def _dynamics(element: Element, what: str) -> dict[str, float]:
    """The optional ``time_constant`` [s] and ``max_rate`` of a thruster or fin."""
    return {
        "time_constant": _optional_scalar(element, "time_constant", what, 0.0),
        "max_rate": _optional_scalar(element, "max_rate", what, math.inf),
    }


#: Plausible ranges of a fin's numbers (the table of
#: :data:`aiauv_pin.description.plausible_ranges.PLAUSIBLE_RANGES` quotes them): areas from a
#: centimetre square to a ship's rudder; lift slopes up to three times the thin-airfoil ``2 pi``;
#: drag coefficients up to a flat plate's ~2, with a margin; angles up to a half turn; a time constant of
#: at most a minute.
FIN_RANGES = {
    "area": (1e-6, 1e3),
    "lift_slope": (0.0, 20.0),
    "drag_zero": (0.0, 10.0),
    "drag_slope": (0.0, 100.0),
    "stall_angle": (1e-3, math.pi / 2),
    "max_angle": (1e-3, math.pi),
    "max_rate": (1e-6, math.inf),
    "time_constant": (0.0, 60.0),
}


def _fin(element: Element, links: Mapping[str, UrdfLink]) -> Fin:
    name = element.get("name")
    if not name:
        raise HydroError("<hydrodynamics> <fin> without a name")
    what = f"fin '{name}'"
    _check_attributes(element, ("name", "link", "xyz", "axis", "chord", *FIN_RANGES), what)
    link = _attached_link(element, links, what)
    for required in ("axis", "chord", "area", "lift_slope", "max_angle"):
        if required not in element.attrib:
            raise HydroError(f"{what}: missing {required} attribute")
    position = parse_vector(element.get("xyz", "0 0 0"), 3, f"{what} xyz")
    if float(np.max(np.abs(position))) > LENGTH_RANGE[1]:
        raise HydroError(f"{what}: xyz {position.tolist()} farther than {LENGTH_RANGE[1]:g} m")
    vectors = {}
    for key in ("axis", "chord"):
        vectors[key] = parse_vector(element.get(key), 3, f"{what} {key}")
        if not np.any(vectors[key]):
            raise HydroError(f"{what}: {key} is the zero vector")
    defaults = {"drag_zero": 0.0, "drag_slope": 0.0, "stall_angle": math.inf, "max_rate": math.inf}
    values = {}
    for key, (low, high) in FIN_RANGES.items():
        value = _optional_scalar(element, key, what, defaults.get(key, 0.0))
        if key == "stall_angle" and value == math.inf:
            values[key] = value
            continue
        if not low <= value <= high:
            raise HydroError(
                f"{what}: {key} = {value:.4g} outside the plausible range [{low:g}, {high:g}]"
            )
        values[key] = value
    return Fin(name=name, link=link, position=position, **vectors, **values)


def _hydrodynamics_block(root: Element) -> Element | None:
    blocks = root.findall("hydrodynamics")
    if len(blocks) > 1:
        raise HydroError(f"URDF has {len(blocks)} <hydrodynamics> blocks; expected at most one")
    return blocks[0] if blocks else None


def read_hydrodynamics(
    source: str | os.PathLike | Element, links: Mapping[str, UrdfLink] | None = None
) -> HydroSpec:
    """Read a URDF's ``<hydrodynamics>`` block (and any UUV Simulator blocks).

    Args:
        source: URDF path, text or parsed ``<robot>`` element (see :func:`parse_robot`).
        links: The robot's links as :func:`robot_links` reads them, if already read (a vehicle
            load passes those of its validation walk, so the links are walked once); ``None``
            reads them here.

    Returns:
        The vehicle's hydrodynamic parameters; ``HydroSpec()`` without links if the file has neither
        a ``<hydrodynamics>`` block nor UUV Simulator blocks.

    Raises:
        HydroError: Any malformed or non-physical input; the message is one line.
    """
    root = parse_robot(source)
    if links is None:
        links = robot_links(root)
    block = _hydrodynamics_block(root)
    uuv_density = uuv_simulator.uuv_fluid_density(root)

    fluid_density, gravity = None, DEFAULT_GRAVITY
    if block is not None:
        _check_attributes(block, ("fluid_density", "gravity"), "<hydrodynamics>")
        if "fluid_density" in block.attrib:
            fluid_density = parse_scalar(
                block.get("fluid_density"), "<hydrodynamics> fluid_density"
            )
        if "gravity" in block.attrib:
            gravity = parse_scalar(block.get("gravity"), "<hydrodynamics> gravity")
    if fluid_density is not None and uuv_density is not None and fluid_density != uuv_density:
        warnings.warn(
            f"<hydrodynamics> fluid_density {fluid_density} overrides the UUV Simulator plugin's "
            f"{uuv_density}",
            stacklevel=2,
        )
    if fluid_density is None:
        fluid_density = uuv_density if uuv_density is not None else DEFAULT_FLUID_DENSITY
    if not (fluid_density > 0.0):
        raise HydroError(f"fluid_density must be positive, got {fluid_density}")

    ours: list[LinkHydrodynamics] = []
    thrusters: list[Thruster] = []
    fins: list[Fin] = []
    if block is not None:
        for element in block:
            if not isinstance(element.tag, str):
                continue
            if element.tag == "link":
                name = element.get("name")
                if not name:
                    raise HydroError("<hydrodynamics> <link> without a name")
                if name not in links:
                    raise HydroError(f"<hydrodynamics> link '{name}' is not a <link> of the robot")
                if any(link.link == name for link in ours):
                    raise HydroError(f"<hydrodynamics> link '{name}' given twice")
                model = element.get("model")
                if model == "fossen":
                    ours.append(_fossen_link(element, name))
                elif model == "slender_cylinder":
                    ours.append(_slender_cylinder_link(element, name, links[name], fluid_density))
                elif model is None:
                    raise HydroError(
                        f"<hydrodynamics> link '{name}': missing model (fossen or slender_cylinder)"
                    )
                else:
                    raise HydroError(
                        f"<hydrodynamics> link '{name}': unknown model '{model}' "
                        "(expected fossen or slender_cylinder)"
                    )
            elif element.tag == "thruster":
                thrusters.append(_thruster(element, links))
            elif element.tag == "fin":
                fins.append(_fin(element, links))
            else:
                raise HydroError(f"<hydrodynamics>: unknown element <{element.tag}>")

    # Our block wins for a link that both blocks describe.
    named = {link.link for link in ours}
    uuv_links = uuv_simulator.uuv_links(root, links, fluid_density, skip=named)
    ours_thrusters = {thruster.name for thruster in thrusters}
    thrusters += [
        thruster
        for thruster in uuv_simulator.uuv_thrusters(root, links)
        if thruster.name not in ours_thrusters
    ]
    ours_fins = {fin.name for fin in fins}
    fins += [
        fin
        for fin in uuv_simulator.uuv_fins(root, links, fluid_density)
        if fin.name not in ours_fins
    ]
    return HydroSpec(
        fluid_density=fluid_density,
        gravity=gravity,
        links=(*ours, *uuv_links),
        thrusters=tuple(thrusters),
        fins=tuple(fins),
    )
