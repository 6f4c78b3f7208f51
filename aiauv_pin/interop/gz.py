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
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import Element, ParseError, SubElement, indent, tostring

import defusedxml
import defusedxml.ElementTree as SafeElementTree
import numpy as np

from aiauv_hydro.spec import HydroError, LinkHydrodynamics
from aiauv_hydro.urdf.block_reader import parse_robot_text, read_hydrodynamics
from aiauv_hydro.urdf.block_writer import format_number, format_numbers, fossen_link_element
from aiauv_hydro.urdf.xml_reading import parse_bool
from aiauv_pin._internal.atomic import atomic_path
from aiauv_pin._internal.atomic import write_text as atomic_write_text
from aiauv_pin.description.input_limits import check_xml_text, read_text
from aiauv_pin.description.plausible_ranges import MAX_DISTANCE
from aiauv_pin.errors import AiauvError, InputLimitError, VehicleLoadError
from aiauv_pin.interop.export_source import ExportSource, load_export_source, rpy_of, rpy_to_matrix
from aiauv_pin.interop.interop_errors import InteropError
from aiauv_pin.model.loading import load_vehicle

#: SNAME letters of the force/moment axes and of the velocities, in our twist order.
FORCE_AXES = "xyzkmn"
VELOCITIES = "UVWPQR"
#: Letters of ``<fluid_added_mass>`` entries, in our twist order.
ADDED_MASS_AXES = "xyzpqr"
#: The 21 element names of ``<fluid_added_mass>`` and their (row, column).
FLUID_ADDED_MASS_ENTRIES = tuple(
    (ADDED_MASS_AXES[i] + ADDED_MASS_AXES[j], i, j) for i in range(6) for j in range(i, 6)
)
#: gz Buoyancy's default fluid density [kg/m^3].
GZ_DEFAULT_FLUID_DENSITY = 1000.0
#: Largest distance [m] (or rotation difference [rad]) between an SDF link pose and the URDF's.
POSE_TOLERANCE = 1e-6
#: Largest SDF file accepted [bytes].
MAX_SDF_BYTES = 50_000_000

_ADDED_MASS_RE = re.compile(r"^([xyzkmn])Dot([UVWPQR])$")
_LINEAR_RE = re.compile(r"^([xyzkmn])([UVWPQR])$")
_ABS_RE = re.compile(r"^([xyzkmn])([UVWPQR])abs([UVWPQR])$")
_QUADRATIC_RE = re.compile(r"^([xyzkmn])([UVWPQR])([UVWPQR])$")
#: Plugin elements that import reads without mapping them (with a warning where they matter).
_IGNORED_PLUGIN_ELEMENTS = ("namespace", "water_density", "waterDensity")
_CURRENT_ELEMENTS = ("default_current", "lookup_current_x", "lookup_current_y", "lookup_current_z")


def _one_line(text) -> str:
    return " ".join(str(text).split())


def _is_hydrodynamics_plugin(plugin: Element) -> bool:
    name = plugin.get("name", "")
    filename = plugin.get("filename", "")
    return name.endswith("systems::Hydrodynamics") or "hydrodynamics-system" in filename


def _is_buoyancy_plugin(plugin: Element) -> bool:
    name = plugin.get("name", "")
    filename = plugin.get("filename", "")
    return name.endswith("systems::Buoyancy") or "buoyancy-system" in filename


# --------------------------------------------------------------------------------------------------
# Reading SDF
# --------------------------------------------------------------------------------------------------


def _number(text: str | None, what: str) -> float:
    try:
        value = float((text or "").strip())
    except ValueError:
        raise InteropError(f"{what}: '{_one_line(text)}' is not a number") from None
    if not math.isfinite(value):
        raise InteropError(f"{what}: '{_one_line(text)}' is not a finite number")
    return value


def _numbers(text: str | None, count: int, what: str) -> np.ndarray:
    tokens = (text or "").split()
    if len(tokens) != count:
        raise InteropError(f"{what}: expected {count} numbers, got {len(tokens)}")
    return np.array([_number(token, what) for token in tokens])


def _parse_bool(text: str | None, what: str) -> bool:
    """:func:`aiauv_hydro.urdf.xml_reading.parse_bool`, its error as an :class:`InteropError`."""
    try:
        return parse_bool(text, what)
    except HydroError as exc:
        raise InteropError(str(exc)) from None


@dataclass(frozen=True)
class Pose:
    """An SDF ``<pose>``: rotation and translation of a frame in the frame it is relative to."""

    rotation: np.ndarray
    translation: np.ndarray
    relative_to: str = ""


def _quaternion_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm == 0.0:
        raise InteropError("pose quaternion is zero")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _pose(element: Element | None, what: str) -> Pose:
    """An SDF pose (``x y z r p y``, ``degrees="true"``, or ``rotation_format="quat_xyzw"``)."""
    if element is None:
        return Pose(np.eye(3), np.zeros(3))
    relative_to = element.get("relative_to", "")
    if element.get("rotation_format", "euler_rpy") == "quat_xyzw":
        values = _numbers(element.text, 7, f"{what} <pose>")
        return Pose(_quaternion_matrix(*values[3:]), values[:3], relative_to)
    if element.get("rotation_format", "euler_rpy") != "euler_rpy":
        raise InteropError(
            f"{what} <pose>: unknown rotation_format '{element.get('rotation_format')}'"
        )
    text = element.text or ""
    values = _numbers(text, 6, f"{what} <pose>") if text.split() else np.zeros(6)
    angles = values[3:]
    if element.get("degrees") is not None and _parse_bool(
        element.get("degrees"), f"{what} degrees"
    ):
        angles = np.radians(angles)
    return Pose(rpy_to_matrix(angles), values[:3], relative_to)


def _shape_volume(geometry: Element, what: str) -> float:
    """Volume [m^3] of an SDF geometry as gz's Buoyancy system takes it (gz-math shape volumes)."""
    shape = next((child for child in geometry if isinstance(child.tag, str)), None)
    if shape is None:
        raise InteropError(f"{what}: empty <geometry>")

    def sizes(values, tag: str):
        # sizes within the validation gate's distances (a radius of 1e308 overflowed the volume)
        for value in np.atleast_1d(values):
            if not 0.0 <= value <= MAX_DISTANCE:
                raise InteropError(
                    f"{what} {shape.tag} <{tag}>: must be in [0, {MAX_DISTANCE:g}] m, got {value:g}"
                )
        return values

    def scalar(tag: str) -> float:
        return sizes(_number(shape.findtext(tag), f"{what} {shape.tag} <{tag}>"), tag)

    if shape.tag == "box":
        size = sizes(np.abs(_numbers(shape.findtext("size"), 3, f"{what} box <size>")), "size")
        return float(np.prod(size))
    if shape.tag == "sphere":
        return 4.0 / 3.0 * math.pi * scalar("radius") ** 3
    if shape.tag == "cylinder":
        return math.pi * scalar("radius") ** 2 * scalar("length")
    if shape.tag == "capsule":
        radius = scalar("radius")
        return math.pi * radius**2 * scalar("length") + 4.0 / 3.0 * math.pi * radius**3
    if shape.tag == "ellipsoid":
        radii = np.abs(_numbers(shape.findtext("radii"), 3, f"{what} ellipsoid <radii>"))
        return 4.0 / 3.0 * math.pi * float(np.prod(sizes(radii, "radii")))
    if shape.tag == "cone":
        return math.pi * scalar("radius") ** 2 * scalar("length") / 3.0
    if shape.tag == "plane":
        return 0.0
    raise InteropError(
        f"{what}: {shape.tag} collision; import-gz takes the displaced volume from box, sphere, "
        "cylinder, capsule, ellipsoid and cone collisions only (replace it by a primitive)"
    )


def _collision_volume(link: Element, name: str) -> tuple[float, np.ndarray]:
    """Displaced volume [m^3] and centre of buoyancy [m] of an SDF link, as gz's Buoyancy has them."""
    total, moment = 0.0, np.zeros(3)
    for collision in link.findall("collision"):
        what = f"SDF link '{name}' collision '{collision.get('name', '')}'"
        pose = _pose(collision.find("pose"), what)
        if pose.relative_to not in ("", name):
            raise InteropError(f"{what}: pose relative_to '{pose.relative_to}' is not supported")
        geometry = collision.find("geometry")
        if geometry is None:
            raise InteropError(f"{what}: no <geometry>")
        volume = _shape_volume(geometry, what)
        total += volume
        moment += volume * pose.translation
    return total, (moment / total if total > 0.0 else np.zeros(3))


def _fluid_added_mass(element: Element, name: str) -> np.ndarray:
    what = f"SDF link '{name}' <fluid_added_mass>"
    entries = {key: (i, j) for key, i, j in FLUID_ADDED_MASS_ENTRIES}
    matrix = np.zeros((6, 6))
    seen = set()
    for child in element:
        if not isinstance(child.tag, str):
            continue
        if child.tag not in entries:
            raise InteropError(f"{what}: unknown element <{child.tag}>")
        if child.tag in seen:
            raise InteropError(f"{what}: <{child.tag}> given twice")
        seen.add(child.tag)
        i, j = entries[child.tag]
        matrix[i, j] = matrix[j, i] = _number(child.text, f"{what} <{child.tag}>")
    return matrix


@dataclass
class _PluginTerms:
    link_name: str
    added_mass: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    linear_damping: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    quadratic_damping: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    disable_added_mass: bool = False
    added_mass_given: bool = False  # a non-zero <{i}Dot{J}> that is not disabled


def _plugin_terms(plugin: Element, model_name: str) -> _PluginTerms:
    link_name = (plugin.findtext("link_name") or "").strip()
    if not link_name:
        raise InteropError(f"SDF model '{model_name}': Hydrodynamics plugin without <link_name>")
    what = f"Hydrodynamics plugin of link '{link_name}'"
    terms = _PluginTerms(link_name)
    seen: set[str] = set()
    added_mass_given = False
    for child in plugin:
        if not isinstance(child.tag, str):
            continue
        tag = child.tag
        if tag in seen:
            raise InteropError(f"{what}: <{tag}> given twice")
        seen.add(tag)
        if tag == "link_name" or tag in _IGNORED_PLUGIN_ELEMENTS:
            continue
        if tag in _CURRENT_ELEMENTS:
            warnings.warn(
                f"{what}: <{tag}> not imported (the current is a scenario parameter here)",
                stacklevel=3,
            )
            continue
        if tag == "disable_added_mass":
            terms.disable_added_mass = _parse_bool(child.text, f"{what} <{tag}>")
            continue
        if tag == "disable_coriolis":
            if _parse_bool(child.text, f"{what} <{tag}>"):
                warnings.warn(
                    f"{what}: disable_coriolis ignored (the added-mass Coriolis terms are part of "
                    "the model here)",
                    stacklevel=3,
                )
            continue
        match = _ADDED_MASS_RE.match(tag)
        if match:
            i, j = FORCE_AXES.index(match[1]), VELOCITIES.index(match[2])
            terms.added_mass[i, j] = -_number(child.text, f"{what} <{tag}>")
            added_mass_given = added_mass_given or terms.added_mass[i, j] != 0.0
            continue
        match = _LINEAR_RE.match(tag)
        if match:
            i, j = FORCE_AXES.index(match[1]), VELOCITIES.index(match[2])
            terms.linear_damping[i, j] = -_number(child.text, f"{what} <{tag}>")
            continue
        match = _ABS_RE.match(tag)
        if match:
            i, j, k = (
                FORCE_AXES.index(match[1]),
                VELOCITIES.index(match[2]),
                VELOCITIES.index(match[3]),
            )
            value = _number(child.text, f"{what} <{tag}>")
            if j != k:
                if value != 0.0:
                    raise InteropError(
                        f"{what}: <{tag}> (a force from |{match[3].lower()}| {match[2].lower()}) "
                        "has no form in the <hydrodynamics> block, whose quadratic damping is "
                        "D_Q (|nu| * nu)"
                    )
                continue
            terms.quadratic_damping[i, j] = -value
            continue
        match = _QUADRATIC_RE.match(tag)
        if match:
            if _number(child.text, f"{what} <{tag}>") != 0.0:
                raise InteropError(
                    f"{what}: <{tag}> is a signed quadratic term (v_j v_k); the <hydrodynamics> block "
                    f"has the |v| v form only (rename it <{match[1]}{match[2]}abs{match[3]}>, as gz "
                    "itself advises)"
                )
            continue
        warnings.warn(f"{what}: unknown element <{tag}> ignored (as gz ignores it)", stacklevel=3)
    if terms.disable_added_mass:
        terms.added_mass = np.zeros((6, 6))
    terms.added_mass_given = added_mass_given and not terms.disable_added_mass
    return terms


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
    # regular files only (a FIFO would block, /dev/zero never end), at most MAX_SDF_BYTES, read
    # with the cap enforced while reading
    try:
        text = read_text(path, "SDF model", MAX_SDF_BYTES)
    except InputLimitError:
        raise
    except VehicleLoadError as exc:  # missing, a directory, unreadable, not UTF-8
        raise InteropError(str(exc)) from None
    check_xml_text(text, str(path))  # the URDF's element and attribute limits, before any tree
    try:
        root = SafeElementTree.fromstring(text.removeprefix("\ufeff"), forbid_dtd=True)
    except defusedxml.DefusedXmlException:
        raise InteropError(f"{path} refused: XML with a DTD/entities") from None
    except ParseError as exc:
        raise InteropError(f"{path} is not well-formed XML: {_one_line(exc)}") from None
    if root.tag != "sdf":
        raise InteropError(f"{path} is not an SDF file: root element is <{root.tag}>, not <sdf>")
    return root


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
    plugins = [p for p in chosen.findall("plugin") if _is_hydrodynamics_plugin(p)]
    terms_of: dict[str, _PluginTerms] = {}
    for plugin in plugins:
        terms = _plugin_terms(plugin, model_name)
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
        terms = terms if terms is not None else _PluginTerms(name)
        added_mass = terms.added_mass
        if fluid is not None:
            if terms.added_mass_given:
                raise InteropError(
                    f"SDF link '{name}': added mass given both as <fluid_added_mass> and as "
                    "Hydrodynamics plugin parameters (gz would count it twice); remove one or set "
                    "<disable_added_mass>true</disable_added_mass>"
                )
            added_mass = _fluid_added_mass(fluid, name)
        volume, center = _collision_volume(link, name)
        try:
            result.append(
                LinkHydrodynamics(
                    link=name,
                    model="fossen",
                    volume=volume,
                    center_of_buoyancy=center,
                    added_mass=added_mass,
                    linear_damping=terms.linear_damping,
                    quadratic_damping=terms.quadratic_damping,
                )
            )
        except HydroError as exc:
            raise InteropError(f"SDF {exc}") from None

    fluid_density = None
    for plugin in root.iter("plugin"):
        if _is_buoyancy_plugin(plugin) and plugin.find("uniform_fluid_density") is not None:
            fluid_density = _number(
                plugin.findtext("uniform_fluid_density"), "Buoyancy <uniform_fluid_density>"
            )
            if fluid_density <= 0.0:
                raise InteropError(
                    f"Buoyancy <uniform_fluid_density> must be > 0, got {fluid_density}"
                )
    gravity = None
    gravity_text = root.findtext("world/gravity")
    if gravity_text is not None:
        gravity = float(np.linalg.norm(_numbers(gravity_text, 3, "world <gravity>")))
    poses = {name: _pose(link.find("pose"), f"SDF link '{name}'") for name, link in links.items()}
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
        notes.append(
            f"crossflow drag of {len(crossflow)} link(s) not exported (gz has no such term)"
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
