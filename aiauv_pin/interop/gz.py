"""Gazebo (gz-sim) interop: import of hydrodynamic parameters from SDF, export of an SDF model.

Conventions of gz-sim's Hydrodynamics system (``gz::sim::systems::Hydrodynamics``, file
``src/systems/hydrodynamics/Hydrodynamics.cc`` and ``HydrodynamicsUtils.hh`` of gazebosim/gz-sim,
read at commit 93bbf3e, 2026; the sign convention below holds since gz-sim 7 "Garden", PRs #1617
and #1784 of 2022; the older Fortress plugin took positive added mass and had non-zero defaults):

- Frame and point: the plugin rotates the link origin's world velocity minus the current into the
  link frame, ``state = (u, v, w, p, q, r)``, and applies its wrench at the link origin
  (``Link::AddWorldWrench`` without offset). gz link frames are x forward, z up, like ours, so no
  axis flip is needed (unlike UUV Simulator's forward-right-down matrices).
- Names (SNAME 1950): the force axis ``x y z k m n`` then the velocity ``U V W P Q R``.
- Damping: the applied wrench is ``f_i = sum_j (X_ij + sum_k X_ij|k| |v_k|) v_j`` with
  ``X_ij`` = ``<{i}{J}>`` (e.g. ``<xU>``, ``<nR>``, cross terms such as ``<xR>``) and ``X_ij|k|`` =
  ``<{i}{J}abs{K}>`` (``<xUabsU>``); dissipative derivatives are negative. Hence our
  ``D_L[i, j] = -<{i}{J}>`` and ``D_Q[i, j] = -<{i}{J}abs{J}>`` (wrench ``-D_Q (|nu| * nu)``). Terms
  ``<{i}{J}abs{K}>`` with ``K != J`` (``|v_k| v_j``) and the plain quadratic ``<{i}{J}{K}>`` (``v_k v_j``,
  which gz itself warns may destabilise) have no form in our block and are refused.
- Added mass, plugin form: ``<{i}Dot{J}>`` (``<xDotU>``, cross terms ``<xDotR>``) in Fossen's sign
  convention, negative for a physical added mass: ``M_A[i, j] = -<{i}Dot{J}>``. The plugin applies it
  with a finite-difference acceleration and a Coriolis matrix built from its diagonal only
  (``buildCoriolisMatrix``).
- Added mass, SDF form (SDF 1.11, gz-sim 8 "Harmonic" with DART): ``<inertial><fluid_added_mass>`` with
  the 21 entries ``xx xy ... rr`` of the symmetric 6x6 matrix about the link origin in the link frame,
  positive physical values: ``M_A`` as is. The physics engine integrates it implicitly with the full
  Coriolis matrix; the plugin must then carry no added mass (gz reports double counting otherwise).
- Buoyancy (``gz::sim::systems::Buoyancy``, a world system, ``src/systems/buoyancy/Buoyancy.cc``): the
  displaced volume of a link is the sum of its collision shapes' volumes (box, sphere, cylinder,
  capsule, ellipsoid, cone; meshes by their mesh volume) and its centre of buoyancy their
  volume-weighted pose positions in the link frame; density ``<uniform_fluid_density>`` (default 1000).

The reading of these conventions (plugin terms, poses, collision volumes) lives in
:mod:`aiauv_pin.description.sdf_reading`, which also loads whole SDF models as vehicles
(``load_vehicle("model.sdf")``); this module imports and exports.

Import (:func:`import_gz`) maps a model's plugins and ``<fluid_added_mass>`` onto ``fossen`` links of
our block for the URDF links of the same names; it requires the SDF link frames to be the URDF link
frames (true for ``gz sdf -p robot.urdf`` and for our export), and checks it on the link poses at
``q = 0`` when the SDF gives them relative to the model frame.

Export (:func:`export_sdf`) writes one link per URDF link (pose at ``q = 0``, inertial, primitive
visuals), one joint per URDF joint, the added mass as ``<fluid_added_mass>`` (or, with
``added_mass="plugin"``, as ``<{i}Dot{J}>`` plugin parameters for engines without native added
mass), one Hydrodynamics plugin per link with every non-zero damping entry, and the volume as a
non-colliding buoyancy sphere at the centre of buoyancy for gz's Buoyancy system. Dropped, and said
so in the file's header comment: the crossflow strip drag, thrusters, and mesh geometry.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement, indent, tostring

import numpy as np

from aiauv_hydro.spec import HydroError, LinkHydrodynamics
from aiauv_hydro.urdf.block_reader import parse_robot_text, read_hydrodynamics
from aiauv_hydro.urdf.block_writer import format_number, format_numbers, fossen_link_element
from aiauv_pin._internal.atomic import atomic_path
from aiauv_pin._internal.atomic import write_text as atomic_write_text
from aiauv_pin.description.input_limits import read_text
from aiauv_pin.description.sdf_reading import (
    FLUID_ADDED_MASS_ENTRIES,
    FORCE_AXES,
    GZ_DEFAULT_FLUID_DENSITY,
    MAX_SDF_BYTES,
    VELOCITIES,
    PluginTerms,
    Pose,
    collision_volume,
    is_buoyancy_plugin,
    is_hydrodynamics_plugin,
    link_hydrodynamics,
    number,
    numbers,
    plugin_terms,
    read_sdf_file,
    sdf_pose,
)
from aiauv_pin.errors import AiauvError
from aiauv_pin.interop.export_source import ExportSource, load_export_source, rpy_of
from aiauv_pin.interop.interop_errors import InteropError
from aiauv_pin.model.loading import load_vehicle

#: Largest distance [m] (or rotation difference [rad]) between an SDF link pose and the URDF's.
POSE_TOLERANCE = 1e-6
#: Re-exported: the SDF size limit (:mod:`aiauv_pin.description.sdf_reading`).
__all__ = ["MAX_SDF_BYTES", "POSE_TOLERANCE", "export_sdf", "import_gz", "read_gz_model"]


@dataclass(frozen=True)
class GzModel:
    """The hydrodynamics of one SDF model, in our conventions.

    Attributes:
        name: Model name.
        links: Per-link parameters (``fossen`` model), for every link with a Hydrodynamics plugin
            or a ``<fluid_added_mass>``.
        fluid_density: ``<uniform_fluid_density>`` of a Buoyancy plugin in the file [kg/m^3], or
            ``None``.
        gravity: Magnitude of the world's ``<gravity>`` in the file [m/s^2], or ``None``.
        link_poses: ``{link: Pose}`` of every SDF link, as written.
    """

    name: str
    links: tuple[LinkHydrodynamics, ...]
    fluid_density: float | None
    gravity: float | None
    link_poses: dict[str, Pose]


def _parse_sdf(path: Path) -> Element:
    """The SDF file's ``<sdf>`` element (:func:`aiauv_pin.description.sdf_reading.read_sdf_file`:
    regular files within MAX_SDF_BYTES, no DTD, undeclared prefixes such as ``gz:`` read)."""
    return read_sdf_file(path)


def read_gz_model(path: str | os.PathLike, model: str | None = None) -> GzModel:
    """Read the hydrodynamics of one model of an SDF file, in our conventions.

    Args:
        path: SDF file (a model, or a world holding models).
        model: Name of the model; may be omitted when the file has exactly one.

    Raises:
        InteropError: Unreadable or malformed SDF, a term with no form in our block, added mass
            given both as ``<fluid_added_mass>`` and as plugin parameters, or a non-physical value
            (one line).
        InputLimitError: Not a regular file (FIFO, device), or larger than :data:`MAX_SDF_BYTES`.
    """
    path = Path(path)
    root = _parse_sdf(path)
    models = root.findall("model") + root.findall("world/model")
    names = [m.get("name", "") for m in models]
    if model is None:
        if len(models) != 1:
            listed = ", ".join(repr(n) for n in names) or "none"
            raise InteropError(f"{path}: {len(models)} models ({listed}); choose one with --model")
        chosen = models[0]
    else:
        matching = [m for m in models if m.get("name") == model]
        if not matching:
            raise InteropError(f"{path}: no model named '{model}' (models: {', '.join(names)})")
        chosen = matching[0]
    model_name = chosen.get("name", "")

    links = {}
    for link in chosen.findall("link"):
        name = link.get("name")
        if not name:
            raise InteropError(f"SDF model '{model_name}': <link> without a name")
        if name in links:
            raise InteropError(f"SDF model '{model_name}': link '{name}' defined twice")
        links[name] = link
    plugins = [p for p in chosen.findall("plugin") if is_hydrodynamics_plugin(p)]
    terms_of: dict[str, PluginTerms] = {}
    for plugin in plugins:
        terms = plugin_terms(plugin, model_name)
        if terms.link_name not in links:
            raise InteropError(
                f"SDF model '{model_name}': Hydrodynamics plugin for link '{terms.link_name}', "
                "which is not a link of the model"
            )
        if terms.link_name in terms_of:
            raise InteropError(
                f"SDF model '{model_name}': two Hydrodynamics plugins for link '{terms.link_name}'"
            )
        terms_of[terms.link_name] = terms

    result = []
    for name, link in links.items():
        fluid = link.find("inertial/fluid_added_mass")
        terms = terms_of.get(name)
        if fluid is None and terms is None:
            continue
        volume, center = collision_volume(link, name)
        result.append(link_hydrodynamics(name, fluid, terms, volume, center))

    fluid_density = None
    for plugin in root.iter("plugin"):
        if is_buoyancy_plugin(plugin) and plugin.find("uniform_fluid_density") is not None:
            fluid_density = number(
                plugin.findtext("uniform_fluid_density"), "Buoyancy <uniform_fluid_density>"
            )
            if fluid_density <= 0.0:
                raise InteropError(
                    f"Buoyancy <uniform_fluid_density> must be > 0, got {fluid_density}"
                )
    gravity = None
    gravity_text = root.findtext("world/gravity")
    if gravity_text is not None:
        gravity = float(np.linalg.norm(numbers(gravity_text, 3, "world <gravity>")))
    poses = {
        name: sdf_pose(link.find("pose"), f"SDF link '{name}'") for name, link in links.items()
    }
    return GzModel(model_name, tuple(result), fluid_density, gravity, poses)


# --------------------------------------------------------------------------------------------------
# Import onto a URDF
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ImportReport:
    """What :func:`import_gz` wrote.

    Attributes:
        output: The URDF written.
        model: The SDF model's name.
        links: Links whose hydrodynamics came from the SDF.
        fluid_density: Fluid density of the written block [kg/m^3].
        pose_checked: Whether the SDF link poses were checked against the URDF's link frames.
    """

    output: Path
    model: str
    links: tuple[str, ...]
    fluid_density: float
    pose_checked: bool


def _check_poses(gz: GzModel, source_placements, root_link: str) -> bool:
    poses = gz.link_poses
    if any(pose.relative_to not in ("", "__model__") for pose in poses.values()):
        return False
    names = [name for name in poses if name in source_placements]
    if root_link not in poses or not names:
        return False
    base = poses[root_link]
    for name in names:
        pose = poses[name]
        rotation = base.rotation.T @ pose.rotation
        translation = base.rotation.T @ (pose.translation - base.translation)
        urdf = source_placements[name]
        offset = float(np.linalg.norm(translation - urdf.translation))
        turn = float(np.linalg.norm(rotation - urdf.rotation))
        if offset > POSE_TOLERANCE or turn > POSE_TOLERANCE:
            raise InteropError(
                f"SDF link '{name}' is not where the URDF puts it at q = 0 (off by {offset:.3g} m, "
                f"{turn:.3g} in rotation): the SDF and URDF link frames differ"
            )
    return True


def import_gz(
    sdf: str | os.PathLike,
    urdf: str | os.PathLike,
    output: str | os.PathLike,
    *,
    model: str | None = None,
    fluid_density: float | None = None,
) -> ImportReport:
    """Write a copy of ``urdf`` whose ``<hydrodynamics>`` block carries the SDF model's parameters.

    Each SDF link with a Hydrodynamics plugin or a ``<fluid_added_mass>`` becomes a ``fossen`` link
    of the block (replacing the URDF's own entry for that link, if any); the block's other links,
    thrusters and attributes are kept. Fluid density: ``fluid_density`` if given, else the SDF's
    Buoyancy ``<uniform_fluid_density>``, else the URDF block's, else gz's default 1000 kg/m^3.

    Args:
        sdf: The SDF file.
        urdf: The URDF giving kinematics and inertia (its link names must match the SDF's).
        output: The URDF file to write.
        model: The SDF model to read, if the file has several.
        fluid_density: Override of the fluid density [kg/m^3].

    Returns:
        What was written.

    Raises:
        InteropError, VehicleLoadError: Bad input (one line); nothing is written then.
    """
    gz = read_gz_model(sdf, model)
    source = load_export_source(urdf)
    if not gz.links:
        raise InteropError(
            f"{sdf}: model '{gz.name}' has no Hydrodynamics plugin and no <fluid_added_mass>"
        )
    for link in gz.links:
        if link.link not in source.placements:
            raise InteropError(f"SDF link '{link.link}' is not a link of {source.path}")
    pose_checked = _check_poses(gz, source.placements, source.structure.root)

    root = parse_robot_text(read_text(source.path, "URDF"))
    block = root.find("hydrodynamics")
    if block is None:
        block = SubElement(root, "hydrodynamics")
    imported = {link.link for link in gz.links}
    for element in list(block):
        if element.tag == "link" and element.get("name") in imported:
            block.remove(element)
    density = fluid_density
    if density is None:
        density = gz.fluid_density
    if density is None and source.vehicle.hydro.links:
        density = source.vehicle.hydro.fluid_density  # the block's, or UUV Simulator's
    if density is None:
        density = GZ_DEFAULT_FLUID_DENSITY
    if not (math.isfinite(density) and density > 0.0):
        raise InteropError(f"fluid density must be positive, got {density}")
    block.set("fluid_density", format_number(density))
    if gz.gravity is not None:
        block.set("gravity", format_number(gz.gravity))
    position = sum(1 for element in block if element.tag == "link")
    for offset, link in enumerate(gz.links):
        block.insert(position + offset, fossen_link_element(link))
    indent(root, space="  ")
    text = '<?xml version="1.0"?>\n' + tostring(root, encoding="unicode") + "\n"
    try:
        read_hydrodynamics(parse_robot_text(text, str(output)))
    except HydroError as exc:
        raise InteropError(f"imported block is not valid: {exc}") from None
    output = Path(output)
    with atomic_path(output) as temporary:  # refuses a FIFO, device, folder or link at ``output``
        temporary.write_text(text, encoding="utf-8", newline="\n")
        try:  # the validation gate, before the file is put in place (as ``build`` does)
            load_vehicle(temporary, backend="pinocchio")
        except AiauvError as exc:
            message = str(exc).replace(str(temporary), "the imported URDF")
            raise InteropError(f"{output}: the imported URDF does not load: {message}") from None
    return ImportReport(output, gz.name, tuple(sorted(imported)), density, pose_checked)


# --------------------------------------------------------------------------------------------------
# Export of an SDF model
# --------------------------------------------------------------------------------------------------


def _pose_text(rotation: np.ndarray, translation: np.ndarray) -> str:
    return format_numbers(np.concatenate([translation, rpy_of(rotation)]))


def _add_geometry(parent: Element, shape) -> None:
    geometry = SubElement(parent, "geometry")
    if shape.shape == "box":
        SubElement(SubElement(geometry, "box"), "size").text = format_numbers(shape.size)
    elif shape.shape == "cylinder":
        cylinder = SubElement(geometry, "cylinder")
        SubElement(cylinder, "radius").text = format_number(shape.size[0])
        SubElement(cylinder, "length").text = format_number(shape.size[1])
    else:
        SubElement(SubElement(geometry, "sphere"), "radius").text = format_number(shape.size[0])


def _header(source: ExportSource, added_mass: str, crossflow: list[str]) -> str:
    lines = [
        f"SDF model of {source.structure.name}, written by `aiauv export` from {source.path.name}.",
        "Conventions (gz-sim >= 8 'Harmonic'): link frames are the URDF link frames (x forward,",
        "z up); each link's Hydrodynamics plugin takes SNAME derivatives in Fossen's sign",
        "convention (negative when dissipative): <{i}{J}> = -D_L[i,j], <{i}{J}abs{J}> = -D_Q[i,j].",
    ]
    if added_mass == "sdf":
        lines.append(
            "Added mass: <fluid_added_mass> (physical, positive, about the link origin); needs the"
        )
        lines.append("DART physics engine. Use `aiauv export --gz-added-mass plugin` for others.")
    else:
        lines.append(
            "Added mass: plugin parameters <{i}Dot{J}> = -M_A[i,j] (explicit, gz's Coriolis uses its"
        )
        lines.append("diagonal only); for DART prefer the default <fluid_added_mass> export.")
    lines += [
        "Buoyancy: each link's displaced volume is a non-colliding sphere collision named",
        "<link>_buoyancy centred at the centre of buoyancy; add gz's Buoyancy world system with",
        "<uniform_fluid_density> to the world (the density used here is given below).",
        "Not exported: thrusters, meshes, contact collisions (gz would count their volume),"
        " and the crossflow strip drag"
        + (f" of {', '.join(crossflow)}" if crossflow else "")
        + " (gz has no such term).",
    ]
    return "\n  ".join(["", *lines]) + "\n"


def sdf_text(source: ExportSource, *, added_mass: str = "sdf") -> str:
    """The SDF model of a loaded vehicle (see the module docstring).

    Args:
        source: The vehicle (from :func:`~aiauv_pin.interop.export_source.load_export_source`).
        added_mass: ``"sdf"`` (``<fluid_added_mass>``) or ``"plugin"`` (``<xDotU>``-style terms).
    """
    if added_mass not in ("sdf", "plugin"):
        raise InteropError(f"unknown added-mass form '{added_mass}' (expected sdf or plugin)")
    structure = source.structure
    hydro = {link.link: link for link in source.vehicle.hydro.links}
    parent_joint = {joint.child: joint for joint in structure.joints}
    frames = []  # massless links on fixed joints become SDF <frame>s
    for link in structure.links:
        if link in structure.inertials:
            continue
        joint = parent_joint.get(link)
        if joint is None or joint.type != "fixed" or link in hydro:
            raise InteropError(
                f"{source.path}: link '{link}' has no <inertial>; SDF would give it 1 kg "
                "(give it an inertial, or attach it by a fixed joint without hydrodynamics)"
            )
        frames.append(link)
    crossflow = sorted(name for name, link in hydro.items() if link.crossflow is not None)
    sdf = Element("sdf", {"version": "1.11"})
    model = SubElement(sdf, "model", {"name": structure.name})
    for name in structure.links:
        placement = source.placements[name]
        if name in frames:
            frame = SubElement(
                model, "frame", {"name": name, "attached_to": parent_joint[name].parent}
            )
            pose = _pose_text(placement.rotation, placement.translation)
            SubElement(frame, "pose", {"relative_to": "__model__"}).text = pose
            continue
        link = SubElement(model, "link", {"name": name})
        SubElement(link, "pose").text = _pose_text(placement.rotation, placement.translation)
        inertial_spec = structure.inertials[name]
        inertial = SubElement(link, "inertial")
        SubElement(inertial, "pose").text = format_numbers(
            np.concatenate([inertial_spec.xyz, inertial_spec.rpy])
        )
        SubElement(inertial, "mass").text = format_number(inertial_spec.mass)
        inertia = SubElement(inertial, "inertia")
        matrix = inertial_spec.inertia
        for tag, (i, j) in (
            ("ixx", (0, 0)),
            ("ixy", (0, 1)),
            ("ixz", (0, 2)),
            ("iyy", (1, 1)),
            ("iyz", (1, 2)),
            ("izz", (2, 2)),
        ):
            SubElement(inertia, tag).text = format_number(matrix[i, j])
        parameters = hydro.get(name)
        if parameters is not None and added_mass == "sdf":
            fluid = SubElement(inertial, "fluid_added_mass")
            for key, i, j in FLUID_ADDED_MASS_ENTRIES:
                if parameters.added_mass[i, j] != 0.0:
                    SubElement(fluid, key).text = format_number(parameters.added_mass[i, j])
        for index, shape in enumerate(s for s in source.shapes[name] if s.kind == "visual"):
            visual = SubElement(link, "visual", {"name": f"{name}_visual_{index}"})
            SubElement(visual, "pose").text = format_numbers(np.concatenate([shape.xyz, shape.rpy]))
            _add_geometry(visual, shape)
        if parameters is not None and parameters.volume > 0.0:
            collision = SubElement(link, "collision", {"name": f"{name}_buoyancy"})
            SubElement(collision, "pose").text = format_numbers(
                np.concatenate([parameters.center_of_buoyancy, np.zeros(3)])
            )
            radius = (3.0 * parameters.volume / (4.0 * math.pi)) ** (1.0 / 3.0)
            SubElement(
                SubElement(SubElement(collision, "geometry"), "sphere"), "radius"
            ).text = format_number(radius)
            contact = SubElement(SubElement(collision, "surface"), "contact")
            SubElement(contact, "collide_bitmask").text = "0x00"
    for joint in structure.joints:
        if joint.child in frames:
            continue
        element = SubElement(model, "joint", {"name": joint.name, "type": joint.type})
        SubElement(element, "parent").text = joint.parent
        SubElement(element, "child").text = joint.child
        if joint.type in ("revolute", "prismatic", "continuous"):
            axis = SubElement(element, "axis")
            SubElement(axis, "xyz").text = format_numbers(joint.axis)
            limit = SubElement(axis, "limit")
            lower, upper = joint.lower, joint.upper
            if joint.type == "continuous" or lower is None or upper is None:
                lower, upper = -1e16, 1e16
            SubElement(limit, "lower").text = format_number(lower)
            SubElement(limit, "upper").text = format_number(upper)
            if joint.effort is not None:
                SubElement(limit, "effort").text = format_number(joint.effort)
            if joint.velocity is not None:
                SubElement(limit, "velocity").text = format_number(joint.velocity)
    for name in structure.links:
        parameters = hydro.get(name)
        if parameters is None:
            continue
        plugin = SubElement(
            model,
            "plugin",
            {"filename": "gz-sim-hydrodynamics-system", "name": "gz::sim::systems::Hydrodynamics"},
        )
        SubElement(plugin, "link_name").text = name
        for i in range(6):
            for j in range(6):
                # the diagonal is always written: gz versions before 7 had non-zero defaults
                if parameters.linear_damping[i, j] != 0.0 or i == j:
                    tag = f"{FORCE_AXES[i]}{VELOCITIES[j]}"
                    SubElement(plugin, tag).text = format_number(-parameters.linear_damping[i, j])
        for i in range(6):
            for j in range(6):
                if parameters.quadratic_damping[i, j] != 0.0:
                    tag = f"{FORCE_AXES[i]}{VELOCITIES[j]}abs{VELOCITIES[j]}"
                    SubElement(plugin, tag).text = format_number(
                        -parameters.quadratic_damping[i, j]
                    )
        if added_mass == "plugin":
            for i in range(6):
                for j in range(6):
                    if parameters.added_mass[i, j] != 0.0 or i == j:
                        tag = f"{FORCE_AXES[i]}Dot{VELOCITIES[j]}"
                        SubElement(plugin, tag).text = format_number(-parameters.added_mass[i, j])
    density = source.vehicle.hydro.fluid_density
    gravity = source.vehicle.hydro.gravity
    indent(sdf, space="  ")
    header = _header(source, added_mass, crossflow)
    header += f"  Fluid density {format_number(density)} kg/m^3, gravity {format_number(gravity)} m/s^2.\n"
    return (
        '<?xml version="1.0"?>\n<!--'
        + header.replace("--", "- -")
        + "-->\n"
        + tostring(sdf, encoding="unicode")
        + "\n"
    )


def export_sdf(
    urdf: str | os.PathLike, output: str | os.PathLike, *, added_mass: str = "sdf"
) -> list[str]:
    """Write the SDF model of a vehicle URDF.

    Args:
        urdf: The vehicle URDF.
        output: The ``.sdf`` file to write.
        added_mass: ``"sdf"`` or ``"plugin"`` (see :func:`sdf_text`).

    Returns:
        Notes on what the export dropped (one line each), for the command line to print.
    """
    source = load_export_source(urdf)
    text = sdf_text(source, added_mass=added_mass)
    atomic_write_text(Path(output), text)
    notes = []
    crossflow = [link.link for link in source.vehicle.hydro.links if link.crossflow is not None]
    if crossflow:
        off_axis = [  # their axial / roll drag rides the crossflow record (no link-frame form)
            link.link
            for link in source.vehicle.hydro.links
            if link.crossflow is not None
            and (link.crossflow.axial_drag_coefficient or link.crossflow.roll_drag_coefficient)
        ]
        notes.append(
            f"crossflow drag of {len(crossflow)} link(s) not exported (gz has no such term)"
            + (
                f", with the axial/roll drag of {len(off_axis)} off-axis cylinder(s)"
                if off_axis
                else ""
            )
        )
    forward = [
        link.link for link in source.vehicle.hydro.links if np.any(link.forward_speed_damping)
    ]
    if forward:
        notes.append(
            f"forward-speed damping of {len(forward)} link(s) not exported (gz has no such term)"
        )
    if source.vehicle.hydro.thrusters:
        notes.append(f"{len(source.vehicle.hydro.thrusters)} thruster(s) not exported")
    if source.vehicle.hydro.fins:
        notes.append(f"{len(source.vehicle.hydro.fins)} fin(s) not exported")
    return notes
