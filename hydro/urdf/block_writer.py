"""Writer of the ``<hydrodynamics>`` block (the inverse of :mod:`aiauv_hydro.urdf.block_reader`).

Links are written as ``model="fossen"`` with their full 6x6 matrices (36 numbers, row-major) and
numbers in Python's shortest round-trip form, so that reading the block back reproduces every value
exactly. A crossflow term (``slender_cylinder`` links) has no ``fossen`` form and is not written,
nor is the axial/roll quadratic drag an off-axis cylinder carries with it (no link-frame ``D_Q``
form; :class:`aiauv_hydro.spec.CrossflowDrag`).
Thrusters and fins are written with every attribute that differs from its default
(:func:`thruster_element`, :func:`fin_element`); :func:`hydrodynamics_element` writes a whole block.
"""

from __future__ import annotations

import math
from xml.etree.ElementTree import Element, SubElement

import numpy as np

from aiauv_hydro.spec import Fin, HydroSpec, LinkHydrodynamics, Thruster


def format_number(value: float) -> str:
    """Shortest text that parses back to the same float (``repr``), with ``-0`` written as ``0``
    and infinity as ``inf``."""
    value = float(value)
    return "0" if value == 0.0 else repr(value)


def format_numbers(values) -> str:
    """Space-separated :func:`format_number` of every element (row-major for matrices)."""
    return " ".join(format_number(v) for v in np.asarray(values, dtype=float).ravel())


def fossen_link_element(link: LinkHydrodynamics) -> Element:
    """A ``<link model="fossen">`` element carrying ``link``'s volume, centre of buoyancy and matrices.

    Args:
        link: The link's parameters (its crossflow, with any cylinder-frame axial/roll drag, is
            not written).

    Returns:
        The element, ready to append to a ``<hydrodynamics>`` block.
    """
    element = Element("link", {"name": link.link, "model": "fossen"})
    SubElement(element, "volume").text = format_number(link.volume)
    SubElement(element, "center_of_buoyancy").text = format_numbers(link.center_of_buoyancy)
    for tag in ("added_mass", "linear_damping", "quadratic_damping"):
        SubElement(element, tag).text = format_numbers(getattr(link, tag))
    if np.any(link.forward_speed_damping != 0.0):
        SubElement(element, "linear_damping_forward_speed").text = format_numbers(
            link.forward_speed_damping
        )
    return element


def thruster_element(thruster: Thruster) -> Element:
    """A ``<thruster>`` element; ``time_constant`` and ``max_rate`` only when not their defaults."""
    attributes = {
        "name": thruster.name,
        "link": thruster.link,
        "xyz": format_numbers(thruster.position),
        "direction": format_numbers(thruster.direction),
        "max_thrust": format_number(thruster.max_thrust),
    }
    if thruster.time_constant != 0.0:
        attributes["time_constant"] = format_number(thruster.time_constant)
    if thruster.max_rate != math.inf:
        attributes["max_rate"] = format_number(thruster.max_rate)
    return Element("thruster", attributes)


def fin_element(fin: Fin) -> Element:
    """A ``<fin>`` element; the optional attributes only when not their defaults."""
    attributes = {
        "name": fin.name,
        "link": fin.link,
        "xyz": format_numbers(fin.position),
        "axis": format_numbers(fin.axis),
        "chord": format_numbers(fin.chord),
        "area": format_number(fin.area),
        "lift_slope": format_number(fin.lift_slope),
        "max_angle": format_number(fin.max_angle),
    }
    for name, default in (
        ("drag_zero", 0.0),
        ("drag_slope", 0.0),
        ("stall_angle", math.inf),
        ("max_rate", math.inf),
        ("time_constant", 0.0),
    ):
        if getattr(fin, name) != default:
            attributes[name] = format_number(getattr(fin, name))
    return Element("fin", attributes)


def hydrodynamics_element(spec: HydroSpec) -> Element:
    """A whole ``<hydrodynamics>`` block of ``spec``: its links (:func:`fossen_link_element`),
    thrusters and fins, in order; reading it back gives ``spec`` again (crossflow terms aside)."""
    block = Element(
        "hydrodynamics",
        {
            "fluid_density": format_number(spec.fluid_density),
            "gravity": format_number(spec.gravity),
        },
    )
    for link in spec.links:
        block.append(fossen_link_element(link))
    for thruster in spec.thrusters:
        block.append(thruster_element(thruster))
    for fin in spec.fins:
        block.append(fin_element(fin))
    return block
