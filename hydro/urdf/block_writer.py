"""Writer of the ``<hydrodynamics>`` block (the inverse of :mod:`aiauv_hydro.urdf.block_reader`).

Links are written as ``model="fossen"`` with their full 6x6 matrices (36 numbers, row-major) and
numbers in Python's shortest round-trip form, so that reading the block back reproduces every value
exactly. A crossflow term (``slender_cylinder`` links) has no ``fossen`` form and is not written.
"""

from __future__ import annotations

from xml.etree.ElementTree import Element, SubElement

import numpy as np

from aiauv_hydro.spec import LinkHydrodynamics


def format_number(value: float) -> str:
    """Shortest text that parses back to the same float (``repr``), with ``-0`` written as ``0``."""
    value = float(value)
    return "0" if value == 0.0 else repr(value)


def format_numbers(values) -> str:
    """Space-separated :func:`format_number` of every element (row-major for matrices)."""
    return " ".join(format_number(v) for v in np.asarray(values, dtype=float).ravel())


def fossen_link_element(link: LinkHydrodynamics) -> Element:
    """A ``<link model="fossen">`` element carrying ``link``'s volume, centre of buoyancy and matrices.

    Args:
        link: The link's parameters (its crossflow, if any, is not written).

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
