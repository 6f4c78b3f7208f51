"""Estimate a ``<hydrodynamics>`` block for any URDF (``aiauv annotate``; plain numpy, no Pinocchio).

Per link, from its first ``<collision>`` element with a geometry (else its first ``<visual>`` one):

* ``<cylinder>``: the slender-cylinder model (``model="slender_cylinder"``,
  :mod:`aiauv_hydro.estimate.slender_cylinder`), which reads the same cylinder when the vehicle is loaded;
  a cylinder off the link axis keeps its added mass and linear damping (moved exactly), its
  transverse (crossflow) drag, a strip integral evaluated by quadrature at any placement, and its
  axial or roll quadratic drag, which has no exact constant form in the link frame there
  (:func:`aiauv_hydro.estimate.slender_cylinder.exact_axial_and_roll`) and is evaluated in the
  cylinder frame with the crossflow term instead (exact there; said in the table);
* ``<box>``, ``<sphere>``: the equivalent ellipsoid (same volume and axis proportions) with Lamb's
  added-mass coefficients (``model="fossen"``, :mod:`aiauv_hydro.estimate.ellipsoid`);
* ``<mesh>``: the ellipsoid fitted to the mesh: centroid, principal axes and axis proportions of the
  solid mesh's second moments (its convex hull if it is not watertight), scaled to its volume
  (:func:`mesh_ellipsoid`; meshes are read with trimesh);
* no geometry (or a mesh that cannot be read): the inertia-equivalent ellipsoid of the link's
  ``<inertial>``; if those moments describe no ellipsoid (zero or degenerate inertia), a sphere of
  the link's neutral volume ``m / rho`` at its centre of mass.

Volumes are the shapes' volumes, or with ``neutral=True`` the link's ``m / rho`` (the centre of
buoyancy stays at the shape's centre). Links without mass are left without hydrodynamics (frames,
anchors), and so are links that already have them (this package's block or UUV Simulator's).
"""

from __future__ import annotations

import copy
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import Element

import numpy as np

from aiauv_hydro.estimate.ellipsoid import (
    Ellipsoid,
    ellipsoid_hydrodynamics,
    inertia_equivalent_ellipsoid,
    scaled_to_volume,
)
from aiauv_hydro.estimate.slender_cylinder import exact_axial_and_roll
from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.block_reader import (
    parse_robot,
    parse_scalar,
    parse_vector,
    read_hydrodynamics,
    rpy_matrix,
)
from aiauv_hydro.urdf.xml_reading import read_link

#: Resolves a mesh ``filename`` (``package://...``, ``file://...`` or a path) to a file, or ``None``.
MeshResolver = Callable[[str], "Path | None"]


def primitive_ellipsoid(shape: Element, xyz: np.ndarray, rpy: np.ndarray) -> Ellipsoid | None:
    """Equivalent ellipsoid of a URDF ``<box>``, ``<cylinder>`` or ``<sphere>`` (else ``None``).

    A sphere is itself; a box or cylinder (along its local z) becomes the ellipsoid with its volume
    and axis proportions, centred at the shape's centre.

    Args:
        shape: The geometry element.
        xyz: Its ``<origin xyz>`` in the link frame [m].
        rpy: Its ``<origin rpy>`` [rad].

    Raises:
        HydroError: Missing, non-numeric or non-positive dimensions.
    """
    rotation = rpy_matrix(rpy)
    center = np.asarray(xyz, dtype=float)
    what = f"<{shape.tag}>"
    if shape.tag == "sphere":
        radius = parse_scalar(shape.get("radius"), f"{what} radius")
        half = np.full(3, radius)
        volume = 4.0 / 3.0 * math.pi * radius**3
    elif shape.tag == "box":
        half = 0.5 * parse_vector(shape.get("size"), 3, f"{what} size")
        volume = 8.0 * float(np.prod(half))
    elif shape.tag == "cylinder":
        radius = parse_scalar(shape.get("radius"), f"{what} radius")
        length = parse_scalar(shape.get("length"), f"{what} length")
        half = np.array([radius, radius, 0.5 * length])
        volume = math.pi * radius * radius * length
    else:
        return None
    if not np.all(half > 0.0):
        raise HydroError(f"{what}: dimensions must be positive, got {2.0 * half}")
    return scaled_to_volume(Ellipsoid(half, rotation, center), volume)


@dataclass(frozen=True)
class AnnotatedLink:
    """What ``annotate`` chose for one link (one row of its table).

    Attributes:
        link: Link name.
        mass: Link mass [kg] (0 without an inertial).
        source: Where the shape came from (``"collision cylinder"``, ``"mesh base.stl"``,
            ``"inertia"``, ...), or why the link was left alone.
        model: ``"slender_cylinder"``, ``"fossen"``, or ``"-"`` (no hydrodynamics written).
        dimensions: Semi-axes ``(a, b, c)`` of the ellipsoid, or ``(length, radius)`` of the
            cylinder [m] (empty when nothing was written).
        volume: Displaced volume as loaded [m^3].
        added_mass_diagonal: Diagonal of ``M_A`` about the link origin, as loaded (6,)
            [kg, kg m^2].
    """

    link: str
    mass: float
    source: str
    model: str
    dimensions: tuple[float, ...]
    volume: float
    added_mass_diagonal: np.ndarray


@dataclass(frozen=True)
class Annotation:
    """A URDF with its estimated ``<hydrodynamics>`` block.

    Attributes:
        root: The annotated ``<robot>`` element (a copy; the input is not changed).
        links: One row per URDF link, in URDF order.
        fluid_density: ``rho`` [kg/m^3].
        gravity: [m/s^2].
    """

    root: Element
    links: tuple[AnnotatedLink, ...]
    fluid_density: float
    gravity: float

    def text(self) -> str:
        """The annotated URDF as text."""
        return (
            '<?xml version="1.0" encoding="utf-8"?>\n'
            + ET.tostring(self.root, encoding="unicode")
            + "\n"
        )


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in np.ravel(values))


def _origin(element: Element, what: str) -> tuple[np.ndarray, np.ndarray]:
    origin = element.find("origin")
    if origin is None:
        return np.zeros(3), np.zeros(3)
    return (
        parse_vector(origin.get("xyz", "0 0 0"), 3, f"{what} <origin> xyz"),
        parse_vector(origin.get("rpy", "0 0 0"), 3, f"{what} <origin> rpy"),
    )


def mesh_ellipsoid(path: str | os.PathLike, scale, xyz, rpy) -> Ellipsoid:
    """The ellipsoid fitted to a mesh, placed in the link frame.

    Its centre is the solid mesh's centroid, its principal axes and axis proportions those of the
    inertia-equivalent ellipsoid of the solid mesh at unit density
    (:mod:`aiauv_hydro.estimate.ellipsoid`), and it
    is scaled to the mesh's volume. A mesh that is not watertight (no enclosed volume) is replaced
    by its convex hull.

    Args:
        path: Mesh file (any format trimesh reads: STL, OBJ, PLY, DAE with pycollada, ...).
        scale: URDF ``<mesh scale>`` (3,) [-].
        xyz: The geometry's ``<origin xyz>`` [m].
        rpy: Its ``<origin rpy>`` [rad].

    Raises:
        HydroError: trimesh is missing, the file cannot be read, or the mesh encloses no volume.
    """
    try:
        import trimesh
    except ImportError:
        raise HydroError("reading meshes needs the trimesh package") from None
    try:
        mesh = trimesh.load(str(path), force="mesh")
    except Exception as exc:  # trimesh raises many kinds for unreadable files
        raise HydroError(f"cannot read mesh {path}: {' '.join(str(exc).split())}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise HydroError(f"mesh {path} has no triangles")
    mesh.apply_scale(np.asarray(scale, dtype=float))
    if not mesh.is_watertight or not mesh.volume > 0.0:
        mesh = mesh.convex_hull
    volume = float(mesh.volume)
    if not (math.isfinite(volume) and volume > 0.0):
        raise HydroError(f"mesh {path} encloses no volume")
    rotation = rpy_matrix(rpy)
    center = np.asarray(xyz, dtype=float) + rotation @ np.asarray(mesh.center_mass, dtype=float)
    # unit density: mass = volume, moments about the centroid in the mesh frame
    fitted = inertia_equivalent_ellipsoid(
        volume, np.asarray(mesh.moment_inertia, dtype=float), rotation, center
    )
    return scaled_to_volume(fitted, volume)


def _geometry_element(link: Element) -> tuple[Element, Element, str] | None:
    """``(owner, shape, kind)`` of the link's first collision (else visual) geometry."""
    for kind in ("collision", "visual"):
        for owner in link.findall(kind):
            geometry = owner.find("geometry")
            if geometry is None:
                continue
            shapes = [child for child in geometry if isinstance(child.tag, str)]
            if shapes:
                return owner, shapes[0], kind
    return None


@dataclass(frozen=True)
class _Inertial:
    """A link's ``<inertial>``: mass [kg], centre of mass [m], inertia frame, inertia [kg m^2]."""

    mass: float
    xyz: np.ndarray
    rotation: np.ndarray
    inertia: np.ndarray


def _link_inertial(link: Element, name: str) -> _Inertial:
    inertial = link.find("inertial")
    if inertial is None:
        return _Inertial(0.0, np.zeros(3), np.eye(3), np.zeros((3, 3)))
    mass_element = inertial.find("mass")
    mass = 0.0
    if mass_element is not None:
        mass = parse_scalar(mass_element.get("value"), f"link '{name}' mass")
    xyz, rpy = _origin(inertial, f"link '{name}' inertial")
    inertia = np.zeros((3, 3))
    element = inertial.find("inertia")
    if element is not None:
        v = {
            key: parse_scalar(element.get(key, "0"), f"link '{name}' inertia {key}")
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        }
        inertia = np.array(
            [
                [v["ixx"], v["ixy"], v["ixz"]],
                [v["ixy"], v["iyy"], v["iyz"]],
                [v["ixz"], v["iyz"], v["izz"]],
            ]
        )
    return _Inertial(mass, xyz, rpy_matrix(rpy), inertia)


def _inertia_shape(inertial: _Inertial, fluid_density: float) -> tuple[Ellipsoid, str]:
    try:
        return (
            inertia_equivalent_ellipsoid(
                inertial.mass, inertial.inertia, inertial.rotation, inertial.xyz
            ),
            "inertia",
        )
    except HydroError:
        radius = (3.0 * inertial.mass / (4.0 * math.pi * fluid_density)) ** (1.0 / 3.0)
        sphere = Ellipsoid(np.full(3, radius), np.eye(3), inertial.xyz.copy())
        return sphere, "inertia unusable: neutral sphere at the CG"


def _mesh_shape(
    shape: Element, owner: Element, kind: str, name: str, resolve: MeshResolver | None
) -> tuple[Ellipsoid | None, str]:
    filename = shape.get("filename", "")
    label = os.path.basename(filename) or "?"
    path = resolve(filename) if resolve is not None else None
    if path is None:
        return None, f"mesh {label} not found"
    scale = parse_vector(shape.get("scale", "1 1 1"), 3, f"link '{name}' {kind} mesh scale")
    if not np.all(scale > 0.0):
        return None, f"mesh {label} has a non-positive scale"
    xyz, rpy = _origin(owner, f"link '{name}' {kind}")
    try:
        return mesh_ellipsoid(path, scale, xyz, rpy), f"{kind} mesh {label}"
    except HydroError as exc:
        return None, f"mesh {label} unusable ({exc})"


def annotate_robot(
    source: str | os.PathLike | Element,
    *,
    fluid_density: float | None = None,
    neutral: bool = False,
    resolve_mesh: MeshResolver | None = None,
) -> Annotation:
    """Add an estimated ``<hydrodynamics>`` block to a URDF (see the module docstring).

    Args:
        source: URDF path, text or parsed ``<robot>`` element (not modified).
        fluid_density: ``rho`` [kg/m^3]; ``None`` keeps an existing block's (else 1025).
        neutral: Give each annotated link the volume ``m / rho`` (neutral buoyancy link by link).
        resolve_mesh: Maps a mesh ``filename`` to a readable file (``None`` if not found); without
            it, meshes are not read and those links fall back to their inertia.

    Returns:
        The annotated copy and its per-link table.

    Raises:
        HydroError: Malformed input (bad numbers, an existing block that does not read, a fluid
            density that conflicts with the existing block's).
    """
    root = copy.deepcopy(parse_robot(source))
    existing = read_hydrodynamics(root)
    blocks = root.findall("hydrodynamics")
    block = blocks[0] if blocks else None
    if fluid_density is not None:
        if not (math.isfinite(fluid_density) and fluid_density > 0.0):
            raise HydroError(f"fluid density must be positive, got {fluid_density!r}")
        if existing.links and not math.isclose(fluid_density, existing.fluid_density):
            raise HydroError(
                f"fluid density {fluid_density:g} conflicts with the {existing.fluid_density:g} "
                "kg/m^3 of the hydrodynamics already in the file"
            )
    rho = float(fluid_density if fluid_density is not None else existing.fluid_density)
    if block is None:
        block = ET.SubElement(root, "hydrodynamics")
    block.set("fluid_density", repr(rho))
    described = {link.link for link in existing.links}

    chosen: list[tuple[str, float, str, str, tuple[float, ...]]] = []
    for link in root.findall("link"):
        name = link.get("name")
        inertial = _link_inertial(link, name)
        if name in described:
            chosen.append((name, inertial.mass, "already in the file", "-", ()))
            continue
        if not inertial.mass > 0.0:
            chosen.append((name, inertial.mass, "no mass: left alone", "-", ()))
            continue
        found = _geometry_element(link)
        ellipsoid: Ellipsoid | None = None
        source_label = ""
        element = Element("link", name=name)
        if found is not None and found[1].tag == "cylinder":
            owner, shape, kind = found
            length = parse_scalar(shape.get("length"), f"link '{name}' cylinder length")
            radius = parse_scalar(shape.get("radius"), f"link '{name}' cylinder radius")
            # the reader takes the same cylinder: the first collision one, else the first visual
            element.set("model", "slender_cylinder")
            label = f"{kind} cylinder"
            placed = read_link(link).cylinder
            axial, roll = exact_axial_and_roll(placed.rotation, placed.translation)
            if not (axial and roll):
                # off the link axis: the transverse drag stays the crossflow strip integral
                # (quadrature, any placement); the axial / roll quadratic drag, with no exact
                # constant form in the link frame, is evaluated in the cylinder frame with it
                moved = [c for c, exact in (("C_d1", axial), ("C_d4", roll)) if not exact]
                label += (
                    " off the link axis (crossflow strip integral; "
                    f"{'/'.join(moved)} in the cylinder frame)"
                )
            if neutral:
                ET.SubElement(element, "volume").text = repr(inertial.mass / rho)
            block.append(element)
            chosen.append((name, inertial.mass, label, "slender_cylinder", (length, radius)))
            continue
        if found is not None:
            owner, shape, kind = found
            if shape.tag == "mesh":
                ellipsoid, source_label = _mesh_shape(shape, owner, kind, name, resolve_mesh)
            else:
                xyz, rpy = _origin(owner, f"link '{name}' {kind}")
                ellipsoid = primitive_ellipsoid(shape, xyz, rpy)
                source_label = f"{kind} {shape.tag}"
                if ellipsoid is None:
                    source_label = f"{kind} <{shape.tag}> unsupported"
        if ellipsoid is None:
            ellipsoid, label = _inertia_shape(inertial, rho)
            source_label = f"{source_label}; {label}" if source_label else label
        params = ellipsoid_hydrodynamics(ellipsoid, rho)
        volume = inertial.mass / rho if neutral else params.volume
        element.set("model", "fossen")
        ET.SubElement(element, "volume").text = repr(float(volume))
        ET.SubElement(element, "center_of_buoyancy").text = _numbers(params.center_of_buoyancy)
        ET.SubElement(element, "added_mass").text = _numbers(params.added_mass)
        ET.SubElement(element, "linear_damping").text = _numbers(params.linear_damping)
        ET.SubElement(element, "quadratic_damping").text = _numbers(params.quadratic_damping)
        block.append(element)
        chosen.append(
            (
                name,
                inertial.mass,
                source_label,
                "fossen",
                tuple(float(s) for s in ellipsoid.semi_axes),
            )
        )
    ET.indent(root)
    loaded = read_hydrodynamics(root)  # what a loader will see: the table shows exactly that
    by_link = {link.link: link for link in loaded.links}
    rows = []
    for name, mass, source_label, model, dimensions in chosen:
        link = by_link.get(name)
        volume = link.volume if link is not None else 0.0
        diagonal = np.diag(link.added_mass).copy() if link is not None else np.zeros(6)
        rows.append(AnnotatedLink(name, mass, source_label, model, dimensions, volume, diagonal))
    return Annotation(root, tuple(rows), loaded.fluid_density, loaded.gravity)


def format_annotation(annotation: Annotation) -> str:
    """The per-link table of what was chosen (SI units), for the user to review."""
    rho, g = annotation.fluid_density, annotation.gravity
    lines = [
        f"fluid density {rho:g} kg/m^3; margin = (rho V - m) g; dimensions: ellipsoid semi-axes "
        "a b c, or cylinder length radius [m]",
        f"{'link':<24} {'mass kg':>9} {'model':<16} {'V m^3':>10} {'margin N':>10} "
        f"{'dimensions m':>26}  {'source':<34} added-mass diagonal [kg, kg m^2]",
    ]
    total_mass = total_volume = 0.0
    for row in annotation.links:
        total_mass += row.mass
        total_volume += row.volume
        dims = " ".join(f"{d:.4g}" for d in row.dimensions) or "-"
        margin = (rho * row.volume - row.mass) * g
        diagonal = (
            " ".join(f"{v:.4g}" for v in row.added_mass_diagonal)
            if row.volume or any(row.added_mass_diagonal)
            else "-"
        )
        lines.append(
            f"{row.link:<24} {row.mass:>9.4g} {row.model:<16} {row.volume:>10.4g} "
            f"{margin:>+10.4g} {dims:>26}  {row.source:<34} {diagonal}"
        )
    lines.append(
        f"{'total':<24} {total_mass:>9.4g} {'':<16} {total_volume:>10.4g} "
        f"{(rho * total_volume - total_mass) * g:>+10.4g}"
    )
    return "\n".join(lines)


__all__ = [
    "AnnotatedLink",
    "Annotation",
    "MeshResolver",
    "annotate_robot",
    "format_annotation",
    "mesh_ellipsoid",
]
