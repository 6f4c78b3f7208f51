"""Reading SDF (gz-sim, SDFormat) models as vehicles: links, joints, frames, includes and plugins.

No SDF library fits on PyPI (``python-sdformat`` pins numpy < 2 and lxml < 5 and stopped in 2022;
``sdformat14-py-bindings`` is a 145 MB single-Python-version binary of one person; gz's own
``sdformat`` bindings are not on PyPI), so this is a parser of its own, with the safety of the
URDF path: regular files within :data:`MAX_SDF_BYTES`, the element limits of
:func:`aiauv_pin.description.input_limits.check_xml_text`, DTDs and entities refused. Prefixes
that SDF files use without declaring them (``gz:type="salinity"``, ``<experimental:params>``) are
read as plain names (expat without namespace processing), as libsdformat does; such custom
elements are not SDF and are skipped.

What is read, and how (SDFormat 1.4-1.11, http://sdformat.org/spec):

- a model file, or a world whose model is chosen by name (``model``); ``<include>`` elements (in a
  world or a model, ``merge="true"`` too) bring models from ``model://NAME`` URIs, folder or file
  paths (relative to the including file), searched in ``model_path`` then ``GZ_SIM_RESOURCE_PATH``
  (and the older ``IGN_GAZEBO_RESOURCE_PATH``, ``SDF_PATH``); a folder's ``model.config`` names its
  SDF file (else ``model.sdf``). The ``<plugin>`` elements inside an ``<include>`` belong to the
  included model, as in gz-sim. A Gazebo Fuel URI (``https://fuel.gazebosim.org/...``) is read
  from a local copy only: a folder named like the Fuel model (its last path component, any case)
  on the model path, or gz's Fuel cache (``GZ_FUEL_CACHE_PATH``, else ``~/.gz/fuel``); without
  one, one line says which URI and how to give a copy;
- poses with SDF 1.7+ frame semantics: ``relative_to`` any link, joint, ``<frame>`` or nested
  model of the same model (default: the model frame for links, frames and nested models, the
  child link for joints), ``<frame attached_to>``, ``degrees="true"`` and ``quat_xyzw``; joint
  axes ``expressed_in`` a frame (default: the joint frame). Nested models are flattened, their
  names scoped with ``/`` (``arm/base``, where gz writes ``arm::base``). A loop of ``relative_to``
  references, or of joints, is one line;
- links: inertial (SDF's defaults, 1 kg and unit inertia, when absent, as gz takes them), visual
  and collision shapes; joints ``revolute``, ``prismatic``, ``fixed`` (``continuous`` and the
  others are refused as for URDFs), a ``world`` parent written as a massless ``world`` link;
- gz-sim systems: ``Hydrodynamics`` (added mass and damping, the conventions of
  :mod:`aiauv_pin.interop.gz`), ``<fluid_added_mass>``, ``Buoyancy`` (displaced volume and centre
  of buoyancy of each link from its collision shapes, uniform density, or graded density taken at
  the model's start height), ``Thruster`` (a ``<thruster>`` on the propeller's link, its joint
  made rigid) and ``LiftDrag`` (fins, FORMATS' ``<fin>`` attributes: :func:`lift_drag_fin`).

The model becomes a URDF with our ``<hydrodynamics>`` block, in memory (:func:`read_sdf_vehicle`),
which ``aiauv_pin.load_vehicle`` then loads through its usual gates. The URDF link frames are the
SDF link frames; a movable joint whose frame is not its child link's frame gets a massless link
``<child>_joint_frame`` between the joint and the child (fixed to it), so every link keeps its
frame and the hydrodynamic matrices stay about its origin.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urlparse
from xml.etree.ElementTree import Element, SubElement, TreeBuilder, indent, tostring
from xml.parsers import expat

import numpy as np
import pinocchio as pin

from aiauv_hydro.spec import HydroError, LinkHydrodynamics
from aiauv_hydro.urdf.block_writer import format_number, format_numbers, fossen_link_element
from aiauv_hydro.urdf.xml_reading import parse_bool, rpy_matrix
from aiauv_pin.description.input_limits import check_xml_text, read_text
from aiauv_pin.description.plausible_ranges import MAX_DISTANCE
from aiauv_pin.errors import InputLimitError, InteropError, VehicleLoadError

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
#: Largest SDF file accepted [bytes].
MAX_SDF_BYTES = 50_000_000

_ADDED_MASS_RE = re.compile(r"^([xyzkmn])Dot([UVWPQR])$")
_LINEAR_RE = re.compile(r"^([xyzkmn])([UVWPQR])$")
_ABS_RE = re.compile(r"^([xyzkmn])([UVWPQR])abs([UVWPQR])$")
_QUADRATIC_RE = re.compile(r"^([xyzkmn])([UVWPQR])([UVWPQR])$")
#: Plugin elements that import reads without mapping them (with a warning where they matter).
_IGNORED_PLUGIN_ELEMENTS = ("namespace", "water_density", "waterDensity")
_CURRENT_ELEMENTS = ("default_current", "lookup_current_x", "lookup_current_y", "lookup_current_z")


def one_line(text) -> str:
    return " ".join(str(text).split())


def is_hydrodynamics_plugin(plugin: Element) -> bool:
    name = plugin.get("name", "")
    filename = plugin.get("filename", "")
    return name.endswith("systems::Hydrodynamics") or "hydrodynamics-system" in filename


def is_buoyancy_plugin(plugin: Element) -> bool:
    name = plugin.get("name", "")
    filename = plugin.get("filename", "")
    return name.endswith("systems::Buoyancy") or "buoyancy-system" in filename


# --------------------------------------------------------------------------------------------------
# Reading SDF
# --------------------------------------------------------------------------------------------------


def number(text: str | None, what: str) -> float:
    try:
        value = float((text or "").strip())
    except ValueError:
        raise InteropError(f"{what}: '{one_line(text)}' is not a number") from None
    if not math.isfinite(value):
        raise InteropError(f"{what}: '{one_line(text)}' is not a finite number")
    return value


def numbers(text: str | None, count: int, what: str) -> np.ndarray:
    tokens = (text or "").split()
    if len(tokens) != count:
        raise InteropError(f"{what}: expected {count} numbers, got {len(tokens)}")
    return np.array([number(token, what) for token in tokens])


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


def sdf_pose(element: Element | None, what: str) -> Pose:
    """An SDF pose (``x y z r p y``, ``degrees="true"``, or ``rotation_format="quat_xyzw"``)."""
    if element is None:
        return Pose(np.eye(3), np.zeros(3))
    relative_to = element.get("relative_to", "")
    if element.get("rotation_format", "euler_rpy") == "quat_xyzw":
        values = numbers(element.text, 7, f"{what} <pose>")
        return Pose(_quaternion_matrix(*values[3:]), values[:3], relative_to)
    if element.get("rotation_format", "euler_rpy") != "euler_rpy":
        raise InteropError(
            f"{what} <pose>: unknown rotation_format '{element.get('rotation_format')}'"
        )
    text = element.text or ""
    values = numbers(text, 6, f"{what} <pose>") if text.split() else np.zeros(6)
    angles = values[3:]
    if element.get("degrees") is not None and _parse_bool(
        element.get("degrees"), f"{what} degrees"
    ):
        angles = np.radians(angles)
    return Pose(rpy_matrix(angles), values[:3], relative_to)


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
        return sizes(number(shape.findtext(tag), f"{what} {shape.tag} <{tag}>"), tag)

    if shape.tag == "box":
        size = sizes(np.abs(numbers(shape.findtext("size"), 3, f"{what} box <size>")), "size")
        return float(np.prod(size))
    if shape.tag == "sphere":
        return 4.0 / 3.0 * math.pi * scalar("radius") ** 3
    if shape.tag == "cylinder":
        return math.pi * scalar("radius") ** 2 * scalar("length")
    if shape.tag == "capsule":
        radius = scalar("radius")
        return math.pi * radius**2 * scalar("length") + 4.0 / 3.0 * math.pi * radius**3
    if shape.tag == "ellipsoid":
        radii = np.abs(numbers(shape.findtext("radii"), 3, f"{what} ellipsoid <radii>"))
        return 4.0 / 3.0 * math.pi * float(np.prod(sizes(radii, "radii")))
    if shape.tag == "cone":
        return math.pi * scalar("radius") ** 2 * scalar("length") / 3.0
    if shape.tag == "plane":
        return 0.0
    raise InteropError(
        f"{what}: {shape.tag} collision; import-gz takes the displaced volume from box, sphere, "
        "cylinder, capsule, ellipsoid and cone collisions only (replace it by a primitive)"
    )


def collision_volume(link: Element, name: str, resolve=None) -> tuple[float, np.ndarray]:
    """Displaced volume [m^3] and centre of buoyancy [m] of an SDF link, as gz's Buoyancy has them.

    ``resolve(pose)`` gives a collision's pose in the link frame (an SDF 1.7+ ``relative_to``);
    without it only poses relative to the link are accepted."""
    total, moment = 0.0, np.zeros(3)
    for collision in link.findall("collision"):
        what = f"SDF link '{name}' collision '{collision.get('name', '')}'"
        pose = sdf_pose(collision.find("pose"), what)
        if resolve is not None:
            pose = resolve(pose)
        elif pose.relative_to not in ("", name):
            raise InteropError(f"{what}: pose relative_to '{pose.relative_to}' is not supported")
        geometry = collision.find("geometry")
        if geometry is None:
            raise InteropError(f"{what}: no <geometry>")
        volume = _shape_volume(geometry, what)
        total += volume
        moment += volume * pose.translation
    return total, (moment / total if total > 0.0 else np.zeros(3))


def fluid_added_mass(element: Element, name: str) -> np.ndarray:
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
        matrix[i, j] = matrix[j, i] = number(child.text, f"{what} <{child.tag}>")
    return matrix


@dataclass
class PluginTerms:
    link_name: str
    added_mass: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    linear_damping: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    quadratic_damping: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    disable_added_mass: bool = False
    added_mass_given: bool = False  # a non-zero <{i}Dot{J}> that is not disabled


def plugin_terms(plugin: Element, model_name: str) -> PluginTerms:
    link_name = (plugin.findtext("link_name") or "").strip()
    if not link_name:
        raise InteropError(f"SDF model '{model_name}': Hydrodynamics plugin without <link_name>")
    what = f"Hydrodynamics plugin of link '{link_name}'"
    terms = PluginTerms(link_name)
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
            terms.added_mass[i, j] = -number(child.text, f"{what} <{tag}>")
            added_mass_given = added_mass_given or terms.added_mass[i, j] != 0.0
            continue
        match = _LINEAR_RE.match(tag)
        if match:
            i, j = FORCE_AXES.index(match[1]), VELOCITIES.index(match[2])
            terms.linear_damping[i, j] = -number(child.text, f"{what} <{tag}>")
            continue
        match = _ABS_RE.match(tag)
        if match:
            i, j, k = (
                FORCE_AXES.index(match[1]),
                VELOCITIES.index(match[2]),
                VELOCITIES.index(match[3]),
            )
            value = number(child.text, f"{what} <{tag}>")
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
            if number(child.text, f"{what} <{tag}>") != 0.0:
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


# --------------------------------------------------------------------------------------------------
# XML with undeclared prefixes
# --------------------------------------------------------------------------------------------------

#: Suffixes of the files :func:`is_sdf_file` takes for SDF.
SDF_SUFFIXES = (".sdf", ".world")
#: Deepest chain of ``<include>`` s followed.
MAX_INCLUDE_DEPTH = 16
#: SDF's default gravity [m/s^2] (``<world><gravity>0 0 -9.8``).
SDF_DEFAULT_GRAVITY = 9.8
#: Environment variables naming model folders, searched in this order after ``model_path``.
RESOURCE_PATH_VARIABLES = ("GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH", "SDF_PATH")
#: Rotation or translation differences below this are an identity pose.
IDENTITY_TOLERANCE = 1e-12


class _Refused(Exception):
    """A DTD or an entity declaration: refused."""


def parse_sdf_text(text: str, where: str) -> Element:
    """Parse SDF text safely and return its ``<sdf>`` element.

    Expat without namespace processing: a prefix such as ``gz:`` stays part of the name, declared
    or not (SDF files use them undeclared). DTDs and entity declarations are refused.

    Raises:
        InteropError: Not well-formed, a DTD, or a root other than ``<sdf>`` (one line).
        InputLimitError: More elements or attributes than the URDF limits allow.
    """
    text = text.removeprefix("\ufeff")
    check_xml_text(text, where)
    builder = TreeBuilder()
    parser = expat.ParserCreate()

    def refuse(*_) -> None:
        raise _Refused

    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.StartElementHandler = builder.start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    try:
        parser.Parse(text, True)
    except _Refused:
        raise InteropError(f"{where} refused: XML with a DTD/entities") from None
    except expat.ExpatError as exc:
        raise InteropError(f"{where} is not well-formed XML: {one_line(exc)}") from None
    root = builder.close()
    if root.tag != "sdf":
        raise InteropError(f"{where} is not an SDF file: root element is <{root.tag}>, not <sdf>")
    return root


def read_sdf_file(path: Path) -> Element:
    """:func:`parse_sdf_text` of a file read within :data:`MAX_SDF_BYTES` (regular files only)."""
    try:
        text = read_text(path, "SDF file", MAX_SDF_BYTES)
    except InputLimitError:
        raise
    except VehicleLoadError as exc:  # missing, a directory, unreadable, not UTF-8
        raise InteropError(str(exc)) from None
    return parse_sdf_text(text, str(path))


def is_sdf_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` names an SDF file (suffix ``.sdf`` or ``.world``)."""
    return Path(path).suffix.lower() in SDF_SUFFIXES


def _is_sdf_tag(tag) -> bool:
    return isinstance(tag, str) and ":" not in tag


# --------------------------------------------------------------------------------------------------
# Model URIs
# --------------------------------------------------------------------------------------------------


def model_search_path(model_path: Sequence[str | os.PathLike] = ()) -> list[Path]:
    """Folders searched for models: ``model_path``, then :data:`RESOURCE_PATH_VARIABLES`."""
    folders = [Path(p) for p in model_path]
    for variable in RESOURCE_PATH_VARIABLES:
        folders += [Path(p) for p in os.environ.get(variable, "").split(os.pathsep) if p]
    return folders


def _model_file(folder: Path, uri: str) -> Path:
    """The SDF file of a model folder: the one ``model.config`` names, else ``model.sdf``."""
    config = folder / "model.config"
    if config.is_file():  # <sdf version="...">file</sdf>; the first one that exists
        text = read_text(config, "model.config", MAX_SDF_BYTES)
        for match in re.finditer(r"<sdf\b[^>]*>\s*([^<]+?)\s*</sdf>", text):
            candidate = folder / match[1]
            if candidate.is_file():
                return candidate
    candidate = folder / "model.sdf"
    if candidate.is_file():
        return candidate
    raise InteropError(
        f"model '{uri}': folder {folder} has no model.sdf (nor one model.config names)"
    )


def _fuel_cache_copy(host: str, owner: str, name: str) -> Path | None:
    """The newest version of a Fuel model in gz's local cache, if there."""
    cache = os.environ.get("GZ_FUEL_CACHE_PATH") or str(Path.home() / ".gz" / "fuel")
    folder = Path(cache) / host / owner.lower() / "models" / name.lower()
    if not folder.is_dir():
        return None
    versions = sorted(
        (p for p in folder.iterdir() if p.is_dir() and p.name.isdigit()), key=lambda p: int(p.name)
    )
    return versions[-1] if versions else None


def resolve_model_uri(uri: str, base: Path, search: Sequence[Path]) -> Path:
    """The SDF file a model URI names (``model://``, a path, or a Fuel URL with a local copy).

    Raises:
        InteropError: Not found, or a network URI without a local copy (one line).
    """
    uri = uri.strip()
    parsed = urlparse(uri)
    if parsed.scheme in ("http", "https"):
        parts = [unquote(p) for p in parsed.path.split("/") if p]
        name = parts[-1] if parts else ""
        if parts and parts[-1].isdigit() and len(parts) > 1:  # .../models/NAME/VERSION
            name = parts[-2]
        for folder in search:
            if folder.is_dir():
                for child in folder.iterdir():
                    if child.is_dir() and child.name.lower() == name.lower():
                        return _model_file(child, uri)
        owner = ""
        if "models" in parts:
            index = parts.index("models")
            owner = parts[index - 1] if index > 0 else ""
        cached = _fuel_cache_copy(parsed.netloc, owner, name) if name else None
        if cached is not None:
            return _model_file(cached, uri)
        raise InteropError(
            f"model URI '{uri}' is on the network, which is not read; give a local copy: "
            f"download it (gz fuel download -u '{uri}') and put its folder, named '{name}', on "
            "--model-path or GZ_SIM_RESOURCE_PATH"
        )
    if parsed.scheme == "model":
        relative = unquote(parsed.netloc + parsed.path)
        name, _, rest = relative.partition("/")
        for folder in search:
            candidate = folder / name
            if candidate.is_dir():
                target = candidate / rest if rest else candidate
                return _model_file(target, uri) if target.is_dir() else target
        searched = (
            ", ".join(str(f) for f in search)
            or "nothing (no --model-path, no GZ_SIM_RESOURCE_PATH)"
        )
        raise InteropError(f"model '{uri}' not found (searched {searched})")
    if parsed.scheme == "file":
        relative = unquote(parsed.path)
    elif parsed.scheme:
        raise InteropError(f"model URI '{uri}': scheme '{parsed.scheme}' is not supported")
    else:
        relative = uri
    for folder in (base, *search):
        candidate = folder / relative
        if candidate.is_dir():
            return _model_file(candidate, uri)
        if candidate.is_file():
            return candidate
    searched = ", ".join(str(f) for f in (base, *search))
    raise InteropError(f"model '{uri}' not found (searched {searched})")


# --------------------------------------------------------------------------------------------------
# Flattening a model: frames, links, joints and plugins with scoped names
# --------------------------------------------------------------------------------------------------


@dataclass
class _Node:
    """A frame of the flattened model: its pose relative to another node (``""``: the model)."""

    pose: Pose
    relative_to: str


@dataclass
class _Flat:
    """A model flattened into one scope: names are scoped with ``/`` for nested models."""

    name: str
    nodes: dict[str, _Node] = field(default_factory=dict)
    links: dict[str, Element] = field(default_factory=dict)
    joints: dict[str, Element] = field(default_factory=dict)
    joint_refs: dict[str, tuple[str, str]] = field(default_factory=dict)  # parent, child
    plugins: list[tuple[Element, str]] = field(default_factory=list)  # (plugin, scope prefix)
    link_files: dict[str, Path] = field(default_factory=dict)  # the file each link came from
    kinds: dict[str, str] = field(default_factory=dict)  # node -> link/joint/frame/model

    def add_node(self, name: str, node: _Node, kind: str) -> None:
        if name in self.nodes:
            raise InteropError(f"SDF model '{self.name}': two frames named '{name}'")
        self.nodes[name] = node
        self.kinds[name] = kind


def _scoped(reference: str, prefix: str, model_node: str) -> str:
    """A name as written inside a (nested) model, in the flattened scope."""
    reference = reference.strip()
    if reference in ("", "__model__"):
        return model_node
    if reference == "world":
        return "world"
    return prefix + reference.replace("::", "/")


def _flatten(
    flat: _Flat,
    model: Element,
    prefix: str,
    model_node: str,
    file: Path,
    search: Sequence[Path],
    depth: int,
) -> None:
    """Add a model's contents to ``flat``; its frame is the node ``model_node`` (already added)."""
    if depth > MAX_INCLUDE_DEPTH:
        raise InteropError(
            f"SDF model '{flat.name}': includes nested deeper than {MAX_INCLUDE_DEPTH}"
        )
    for link in model.findall("link"):
        name = link.get("name", "")
        if not name:
            raise InteropError(f"SDF model '{flat.name}': <link> without a name")
        scoped = prefix + name
        if scoped in flat.links:
            raise InteropError(f"SDF model '{flat.name}': link '{scoped}' defined twice")
        pose = sdf_pose(link.find("pose"), f"SDF link '{scoped}'")
        flat.add_node(scoped, _Node(pose, _scoped(pose.relative_to, prefix, model_node)), "link")
        flat.links[scoped] = link
        flat.link_files[scoped] = file
    for joint in model.findall("joint"):
        name = joint.get("name", "")
        if not name:
            raise InteropError(f"SDF model '{flat.name}': <joint> without a name")
        scoped = prefix + name
        parent = _scoped(joint.findtext("parent") or "", prefix, model_node)
        child = _scoped(joint.findtext("child") or "", prefix, model_node)
        if (
            not (joint.findtext("parent") or "").strip()
            or not (joint.findtext("child") or "").strip()
        ):
            raise InteropError(f"SDF joint '{scoped}': needs a <parent> and a <child>")
        pose = sdf_pose(joint.find("pose"), f"SDF joint '{scoped}'")
        relative_to = _scoped(pose.relative_to, prefix, model_node) if pose.relative_to else child
        flat.add_node(scoped, _Node(pose, relative_to), "joint")
        flat.joints[scoped] = joint
        flat.joint_refs[scoped] = (parent, child)
    for frame in model.findall("frame"):
        name = frame.get("name", "")
        if not name:
            raise InteropError(f"SDF model '{flat.name}': <frame> without a name")
        scoped = prefix + name
        pose = sdf_pose(frame.find("pose"), f"SDF frame '{scoped}'")
        attached = _scoped(frame.get("attached_to", ""), prefix, model_node)
        relative_to = (
            _scoped(pose.relative_to, prefix, model_node) if pose.relative_to else attached
        )
        flat.add_node(scoped, _Node(pose, relative_to), "frame")
    for plugin in model.findall("plugin"):
        flat.plugins.append((plugin, prefix))
    for nested in model.findall("model"):
        name = nested.get("name", "")
        if not name:
            raise InteropError(f"SDF model '{flat.name}': nested <model> without a name")
        scoped = prefix + name
        pose = sdf_pose(nested.find("pose"), f"SDF model '{scoped}'")
        flat.add_node(scoped, _Node(pose, _scoped(pose.relative_to, prefix, model_node)), "model")
        _flatten(flat, nested, scoped + "/", scoped, file, search, depth + 1)
    for include in model.findall("include"):
        _flatten_include(flat, include, prefix, model_node, file, search, depth + 1)


def _included_model(include: Element, file: Path, search: Sequence[Path]) -> tuple[Element, Path]:
    uri = include.findtext("uri")
    if not uri or not uri.strip():
        raise InteropError(f"{file}: <include> without a <uri>")
    target = resolve_model_uri(uri, file.parent, search)
    root = read_sdf_file(target)
    models = root.findall("model")
    if len(models) != 1:
        raise InteropError(f"{target}: included file holds {len(models)} models, expected one")
    return models[0], target


def _flatten_include(
    flat: _Flat, include: Element, prefix: str, model_node: str, file: Path, search, depth: int
) -> None:
    model, target = _included_model(include, file, search)
    name = (include.findtext("name") or "").strip() or model.get("name", "")
    pose_element = include.find("pose")
    if pose_element is None:
        pose_element = model.find("pose")
    pose = sdf_pose(pose_element, f"SDF include '{name}'")
    merge = include.get("merge") is not None and parse_bool(include.get("merge"), "include merge")
    if merge:  # the included model's frame becomes a frame of this model (SDF 1.9 merge)
        node = f"{prefix}_merged__{name}__model__"
        flat.add_node(node, _Node(pose, _scoped(pose.relative_to, prefix, model_node)), "frame")
        _flatten(flat, model, prefix, node, target, search, depth)
    else:
        scoped = prefix + name
        flat.add_node(scoped, _Node(pose, _scoped(pose.relative_to, prefix, model_node)), "model")
        _flatten(flat, model, scoped + "/", scoped, target, search, depth)
        prefix = scoped + "/"
    for plugin in include.findall("plugin"):
        flat.plugins.append((plugin, prefix))


def _resolver(flat: _Flat) -> Callable[[str], tuple[np.ndarray, np.ndarray]]:
    """``pose_of(node) -> (rotation, translation)`` in the model frame, with loop detection."""
    cache: dict[str, tuple[np.ndarray, np.ndarray]] = {"": (np.eye(3), np.zeros(3))}

    def pose_of(name: str, chain: tuple[str, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        if name in cache:
            return cache[name]
        if name == "world":
            raise InteropError(
                f"SDF model '{flat.name}': a pose relative_to 'world' (only the model's own "
                "pose may be)"
            )
        if name not in flat.nodes:
            raise InteropError(f"SDF model '{flat.name}': no frame named '{name}'")
        if name in chain:
            loop = " -> ".join((*chain[chain.index(name) :], name))
            raise InteropError(f"SDF model '{flat.name}': loop of relative_to frames: {loop}")
        node = flat.nodes[name]
        rotation, translation = pose_of(node.relative_to, (*chain, name))
        result = (rotation @ node.pose.rotation, translation + rotation @ node.pose.translation)
        cache[name] = result
        return result

    return pose_of


def _choose_model(root: Element, path: Path, model: str | None) -> tuple[Element, bool]:
    """The ``<model>`` or world ``<include>`` element named ``model`` (``True`` for an include)."""
    candidates: list[tuple[str, Element, bool]] = []
    for element in root.findall("model") + root.findall("world/model"):
        candidates.append((element.get("name", ""), element, False))
    for include in root.findall("world/include") + root.findall("include"):
        name = (include.findtext("name") or "").strip()
        candidates.append((name, include, True))
    if model is None:
        if len(candidates) != 1:
            listed = ", ".join(repr(n or "<include>") for n, _, _ in candidates) or "none"
            raise InteropError(
                f"{path}: {len(candidates)} models ({listed}); choose one with --model"
            )
        return candidates[0][1], candidates[0][2]
    for name, element, is_include in candidates:
        if name == model:
            return element, is_include
    unnamed = [(e, i) for n, e, i in candidates if i and not n]
    names = [n for n, _, _ in candidates if n]
    return _unnamed_include(unnamed, model, path, names)


def _unnamed_include(unnamed, model: str, path: Path, names: list[str]):
    """An ``<include>`` without ``<name>`` takes its model's name: look them up by URI name."""
    for element, is_include in unnamed:
        uri = (element.findtext("uri") or "").strip()
        last = unquote(urlparse(uri).path.rstrip("/").split("/")[-1]) if uri else ""
        if last.lower() == model.lower():
            return element, is_include
    raise InteropError(
        f"{path}: no model named '{model}' (models: {', '.join(names) or 'unnamed includes only'})"
    )


# --------------------------------------------------------------------------------------------------
# gz-sim systems: Buoyancy, Thruster, LiftDrag
# --------------------------------------------------------------------------------------------------


def _plugin_kind(plugin: Element) -> str:
    name = plugin.get("name", "")
    filename = plugin.get("filename", "")
    for kind, system, library in (
        ("hydrodynamics", "Hydrodynamics", "hydrodynamics-system"),
        ("buoyancy", "Buoyancy", "buoyancy-system"),
        ("thruster", "Thruster", "thruster-system"),
        ("lift_drag", "LiftDrag", "lift-drag-system"),
    ):
        if name.endswith("systems::" + system) or library in filename:
            return kind
    return ""


def _plugin_label(plugin: Element) -> str:
    name = plugin.get("name", "") or plugin.get("filename", "") or "plugin"
    return name.rsplit("::", 1)[-1]


def _warn_unknown(plugin: Element, known: Sequence[str], what: str) -> None:
    unknown = sorted({c.tag for c in plugin if _is_sdf_tag(c.tag) and c.tag not in known})
    if unknown:
        warnings.warn(
            f"{what}: unknown parameter(s) {', '.join(f'<{t}>' for t in unknown)} ignored "
            "(as gz ignores them)",
            stacklevel=4,
        )


@dataclass(frozen=True)
class BuoyancyWorld:
    """gz's Buoyancy system of a world: uniform or graded density, and the enabled entities.

    Attributes:
        default_density: Density below every layer [kg/m^3] (the uniform density if not graded).
        layers: ``(above_height [m], density [kg/m^3])`` of ``<density_change>``, sorted.
        enabled: ``<enable>`` names (``model`` or ``model::link``); empty: every link.
    """

    default_density: float
    layers: tuple[tuple[float, float], ...] = ()
    enabled: tuple[str, ...] = ()

    def density_at(self, height: float) -> float:
        """Fluid density [kg/m^3] at a world height [m]: gz's layers (Buoyancy.cc, lines 183-230)
        hold ``density`` above their ``above_depth`` height, ``default_density`` below all."""
        density = self.default_density
        for above, layer_density in self.layers:
            if height >= above:
                density = layer_density
        return density


_BUOYANCY_KNOWN = ("uniform_fluid_density", "graded_buoyancy", "enable")


def read_buoyancy(plugin: Element) -> BuoyancyWorld:
    """gz's Buoyancy parameters (``src/systems/buoyancy/Buoyancy.cc``, lines 487-556)."""
    what = "Buoyancy plugin"
    _warn_unknown(plugin, _BUOYANCY_KNOWN, what)
    enabled = tuple((e.text or "").strip() for e in plugin.findall("enable"))
    if plugin.find("uniform_fluid_density") is not None:
        density = number(
            plugin.findtext("uniform_fluid_density"), f"{what} <uniform_fluid_density>"
        )
        layers: list[tuple[float, float]] = []
    elif plugin.find("graded_buoyancy") is not None:
        graded = plugin.find("graded_buoyancy")
        density = number(graded.findtext("default_density"), f"{what} <default_density>")
        layers = []
        for change in graded.findall("density_change"):
            layers.append(
                (
                    number(change.findtext("above_depth"), f"{what} <above_depth>"),
                    number(change.findtext("density"), f"{what} <density>"),
                )
            )
        layers.sort()
    else:  # Buoyancy.cc line 541-546: gz's default
        density, layers = GZ_DEFAULT_FLUID_DENSITY, []
    for value in (density, *(d for _, d in layers)):
        if not value > 0.0:
            raise InteropError(f"{what}: fluid density must be > 0, got {value:g}")
    return BuoyancyWorld(density, tuple(layers), enabled)


_THRUSTER_KNOWN = (
    "namespace", "topic", "joint_name", "thrust_coefficient", "fluid_density",
    "propeller_diameter", "use_angvel_cmd", "max_thrust_cmd", "min_thrust_cmd",
    "velocity_control", "p_gain", "i_gain", "d_gain", "wake_fraction", "alpha_1", "alpha_2",
    "deadband", "power_load", "battery_name",
)  # fmt: skip


@dataclass(frozen=True)
class GzThruster:
    """gz's Thruster system on one joint, as our thruster.

    Attributes:
        joint: The propeller joint (made rigid: the thrust is the actuator, as for UUV Simulator).
        max_thrust: Thrust limit [N]: the command limits of a force command, or the thrust at the
            limiting rotor speed of an angular-velocity command.
    """

    joint: str
    max_thrust: float


def read_thruster(plugin: Element, prefix: str) -> GzThruster:
    """gz's Thruster parameters (``src/systems/thruster/Thruster.cc``, gazebosim/gz-sim 93bbf3e).

    Thrust ``T = C_t rho D^4 |omega| omega`` (``AngularVelToThrust``, lines 593-599); a force
    command is clamped to ``[min_thrust_cmd, max_thrust_cmd]`` (defaults -1000 and 1000, lines
    113-119, 430-450, 520-521), an angular-velocity command (``use_angvel_cmd``) to the same limits
    in rad/s. Our thruster is symmetric: its ``max_thrust`` is the larger magnitude.
    """
    joint = (plugin.findtext("joint_name") or "").strip()
    if not joint:
        raise InteropError("Thruster plugin without <joint_name>")
    what = f"Thruster plugin of joint '{joint}'"
    _warn_unknown(plugin, _THRUSTER_KNOWN, what)

    def value(tag: str, default: float) -> float:
        text = plugin.findtext(tag)
        return default if text is None else number(text, f"{what} <{tag}>")

    upper, lower = value("max_thrust_cmd", 1000.0), value("min_thrust_cmd", -1000.0)
    if upper < lower:  # Thruster.cc lines 440-446: gz reverts to its defaults
        upper, lower = 1000.0, -1000.0
    limit = max(abs(upper), abs(lower))
    angular = plugin.find("use_angvel_cmd") is not None and parse_bool(
        plugin.findtext("use_angvel_cmd"), f"{what} <use_angvel_cmd>"
    )
    if angular:
        coefficient = value("thrust_coefficient", 1.0)
        density = value("fluid_density", 1000.0)
        diameter = value("propeller_diameter", 0.02)
        limit = abs(coefficient) * density * diameter**4 * limit**2
    if not (math.isfinite(limit) and limit > 0.0):
        raise InteropError(f"{what}: the thrust limit is {limit:g} N, must be > 0")
    return GzThruster(prefix + joint, limit)


_LIFT_DRAG_KNOWN = (
    "link_name", "air_density", "cla", "cda", "cma", "alpha_stall", "cla_stall", "cda_stall",
    "cma_stall", "a0", "area", "cp", "forward", "upward", "radial_symmetry", "reversible",
    "control_joint_name", "control_joint_rad_to_cl", "cm_delta", "topic",
)  # fmt: skip


def lift_drag_fin(plugin: Element, prefix: str, axis: np.ndarray | None, max_angle: float | None):
    """A gz LiftDrag plugin as FORMATS' ``<fin>`` attributes (a dict of floats and vectors).

    gz (``src/systems/lift_drag/LiftDrag.cc``, 93bbf3e): lift coefficient ``cla alpha`` below the
    stall angle (line 425), drag coefficient ``|cda alpha|`` (lines 452-455), on the velocity of
    ``cp`` in the plane of ``forward`` and ``upward``; ``air_density`` is the fluid's. Mapped:
    ``xyz = cp``, ``chord = forward``, ``axis`` = the fin joint's axis (the rotation axis), else
    ``forward x upward``; ``lift_slope = cla``, ``stall_angle = alpha_stall``, ``drag_zero = 0``
    and ``drag_slope = cda / alpha_stall`` (gz's drag grows as ``|alpha|``, ours as ``alpha^2``:
    equal at zero and at the stall angle); ``max_angle`` the joint's limit.
    """
    link = (plugin.findtext("link_name") or "").strip()
    if not link:
        raise InteropError("LiftDrag plugin without <link_name>")
    what = f"LiftDrag plugin of link '{link}'"
    _warn_unknown(plugin, _LIFT_DRAG_KNOWN, what)

    def value(tag: str, default: float) -> float:
        text = plugin.findtext(tag)
        return default if text is None else number(text, f"{what} <{tag}>")

    def vector(tag: str, default) -> np.ndarray:
        text = plugin.findtext(tag)
        return np.array(default, float) if text is None else numbers(text, 3, f"{what} <{tag}>")

    forward = vector("forward", (1.0, 0.0, 0.0))
    upward = vector("upward", (0.0, 0.0, 1.0))
    if axis is None:
        axis = np.cross(forward, upward)
    norms = [float(np.linalg.norm(v)) for v in (forward, axis)]
    if min(norms) == 0.0:
        raise InteropError(f"{what}: <forward> and <upward> must be non-zero and not parallel")
    stall = value("alpha_stall", math.pi / 2.0)  # defaults: LiftDrag.cc lines 67-130
    cda = value("cda", 0.01)
    fin = {
        "name": (prefix + link).replace("/", "_") + "_fin",
        "link": prefix + link,
        "xyz": vector("cp", (0.0, 0.0, 0.0)),
        "axis": np.asarray(axis, float) / norms[1],
        "chord": forward / norms[0],
        "area": value("area", 1.0),
        "lift_slope": value("cla", 1.0),
        "drag_zero": 0.0,
        "drag_slope": abs(cda) / stall if stall > 0.0 else 0.0,
        "stall_angle": stall if stall > 0.0 else math.inf,
        "fluid_density": value("air_density", 1.2041),
    }
    if max_angle is not None:
        fin["max_angle"] = max_angle
    return fin


# --------------------------------------------------------------------------------------------------
# The vehicle: a URDF with our <hydrodynamics> block
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SdfVehicle:
    """An SDF model as a URDF with our ``<hydrodynamics>`` block.

    Attributes:
        urdf_text: The URDF.
        name: The model's name.
        source: The SDF file the model was read from (a world, or the model's own file).
        fins: LiftDrag fins as FORMATS' ``<fin>`` attributes (:func:`lift_drag_fin`).
        world_position: The model's position in the world [m] (its pose in a world file).
        notes: What the conversion changed or left out, one line each.
    """

    urdf_text: str
    name: str
    source: Path
    fins: tuple[dict, ...] = ()
    world_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    notes: tuple[str, ...] = ()


def _origin(parent: Element, rotation: np.ndarray, translation: np.ndarray, tag="origin") -> None:
    rpy = np.asarray(pin.rpy.matrixToRpy(np.asarray(rotation, dtype=float)), dtype=float)
    SubElement(parent, tag, {"xyz": format_numbers(translation), "rpy": format_numbers(rpy)})


def _is_identity(rotation: np.ndarray, translation: np.ndarray) -> bool:
    return bool(
        np.max(np.abs(rotation - np.eye(3))) <= IDENTITY_TOLERANCE
        and np.max(np.abs(translation)) <= IDENTITY_TOLERANCE
    )


class _Converter:
    """Builds the URDF of one flattened model."""

    def __init__(self, flat: _Flat, search: Sequence[Path]):
        self.flat = flat
        self.search = search
        self.pose_of = _resolver(flat)
        self.notes: list[str] = []
        self.undrawn: list[str] = []  # links whose visuals were meshes we cannot draw

    # -- poses ----------------------------------------------------------------------------------
    def scoped_in(self, entity: str, reference: str) -> str:
        """A frame name written inside the (nested) model of ``entity``, in the flattened scope:
        ``__model__`` is that model's frame (a nested model's node, or ``""`` at the top)."""
        model_node = entity.rpartition("/")[0]
        return _scoped(reference, f"{model_node}/" if model_node else "", model_node)

    def in_link(self, link: str, pose: Pose, default: str) -> tuple[np.ndarray, np.ndarray]:
        """A pose written in ``link`` (relative to ``default`` unless ``relative_to``), in the
        link frame."""
        reference = self.scoped_in(link, pose.relative_to) if pose.relative_to else default
        r_ref, t_ref = self.pose_of(reference)
        r_link, t_link = self.pose_of(link)
        rotation = r_link.T @ r_ref @ pose.rotation
        translation = r_link.T @ (r_ref @ pose.translation + t_ref - t_link)
        return rotation, translation

    # -- geometry -------------------------------------------------------------------------------
    def _mesh_file(self, uri: str, link: str) -> Path | None:
        base = self.flat.link_files[link].parent
        parsed = urlparse(uri.strip())
        try:
            if parsed.scheme in ("model", "file", ""):
                path = resolve_model_uri(uri, base, self.search)
                return path if path.is_file() else None
        except InteropError:
            return None
        return None

    def _geometry(self, parent: Element, geometry: Element, link: str, visual: bool) -> bool:
        shape = next((c for c in geometry if _is_sdf_tag(c.tag)), None)
        if shape is None:
            return False
        what = f"SDF link '{link}' {shape.tag}"
        out = Element("geometry")
        if shape.tag == "box":
            size = np.abs(numbers(shape.findtext("size"), 3, f"{what} <size>"))
            SubElement(out, "box", {"size": format_numbers(size)})
        elif shape.tag == "sphere":
            SubElement(
                out, "sphere", {"radius": format_number(number(shape.findtext("radius"), what))}
            )
        elif shape.tag in ("cylinder", "capsule") and (shape.tag == "cylinder" or visual):
            radius = number(shape.findtext("radius"), f"{what} <radius>")
            length = number(shape.findtext("length"), f"{what} <length>")
            if shape.tag == "capsule":
                length += 2.0 * radius  # drawn as its bounding cylinder
            attributes = {"radius": format_number(radius), "length": format_number(length)}
            SubElement(out, "cylinder", attributes)
        elif shape.tag == "mesh" and visual:
            uri = shape.findtext("uri") or ""
            if shape.find("submesh") is not None:
                return False  # URDF cannot pick a submesh: the collision shapes stand in
            path = self._mesh_file(uri, link)
            if path is None:
                return False
            attributes = {"filename": str(path.resolve())}
            if shape.findtext("scale"):
                attributes["scale"] = format_numbers(numbers(shape.findtext("scale"), 3, what))
            SubElement(out, "mesh", attributes)
        else:
            return False
        parent.append(out)
        return True

    def _shapes(self, element: Element, name: str, link: Element) -> None:
        drawn = 0
        for kind in ("visual", "collision"):
            for shape in link.findall(kind):
                geometry = shape.find("geometry")
                if geometry is None:
                    continue
                out = Element(kind, {"name": shape.get("name", kind)})
                pose = sdf_pose(shape.find("pose"), f"SDF link '{name}' {kind}")
                _origin(out, *self.in_link(name, pose, name))
                if self._geometry(out, geometry, name, kind == "visual"):
                    element.append(out)
                    drawn += kind == "visual"
        if drawn == 0 and link.findall("visual"):  # meshes we cannot draw: the collision shapes
            for shape in link.findall("collision"):
                geometry = shape.find("geometry")
                if geometry is None:
                    continue
                out = Element("visual", {"name": shape.get("name", "collision") + "_drawn"})
                pose = sdf_pose(shape.find("pose"), f"SDF link '{name}' collision")
                _origin(out, *self.in_link(name, pose, name))
                if self._geometry(out, geometry, name, True):
                    element.append(out)
            self.undrawn.append(name)

    # -- links and joints -----------------------------------------------------------------------
    def link_element(self, name: str, frame_rotation=None, frame_translation=None) -> Element:
        link = self.flat.links[name]
        element = Element("link", {"name": name})
        inertial = link.find("inertial")
        out = SubElement(element, "inertial")
        mass, inertia = 1.0, {"ixx": 1.0, "iyy": 1.0, "izz": 1.0}  # SDF's defaults
        pose = Pose(np.eye(3), np.zeros(3))
        if inertial is not None:
            if inertial.findtext("mass") is not None:
                mass = number(inertial.findtext("mass"), f"SDF link '{name}' <mass>")
            pose = sdf_pose(inertial.find("pose"), f"SDF link '{name}' inertial")
            block = inertial.find("inertia")
            if block is not None:
                for tag in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
                    if block.findtext(tag) is not None:
                        inertia[tag] = number(block.findtext(tag), f"SDF link '{name}' <{tag}>")
        _origin(out, *self.in_link(name, pose, name))
        SubElement(out, "mass", {"value": format_number(mass)})
        values = {
            tag: format_number(inertia.get(tag, 0.0))
            for tag in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        }
        SubElement(out, "inertia", values)
        self._shapes(element, name, link)
        return element

    def joint_axis(
        self, name: str, joint: Element
    ) -> tuple[np.ndarray, float | None, float | None]:
        """Unit axis in the joint frame, and the lower and upper limits."""
        what = f"SDF joint '{name}'"
        axis = joint.find("axis")
        if axis is None:
            raise InteropError(f"{what}: <axis> missing")
        xyz_element = axis.find("xyz")
        vector = numbers(
            xyz_element.text if xyz_element is not None else "0 0 1", 3, f"{what} <xyz>"
        )
        if not np.any(vector):
            raise InteropError(f"{what}: axis is the zero vector")
        vector = vector / np.linalg.norm(vector)
        expressed = xyz_element.get("expressed_in", "") if xyz_element is not None else ""
        parent_model = axis.findtext("use_parent_model_frame")
        if parent_model is not None and parse_bool(
            parent_model, f"{what} <use_parent_model_frame>"
        ):
            expressed = "__model__"
        if expressed:
            reference = self.scoped_in(name, expressed)
            r_ref, _ = self.pose_of(reference)
            r_joint, _ = self.pose_of(name)
            vector = r_joint.T @ r_ref @ vector
        lower = upper = None
        if axis.find("limit") is not None:
            if axis.findtext("limit/lower") is not None:
                lower = number(axis.findtext("limit/lower"), f"{what} <lower>")
            if axis.findtext("limit/upper") is not None:
                upper = number(axis.findtext("limit/upper"), f"{what} <upper>")
        return vector, lower, upper


def _plugins_by_kind(plugins) -> dict[str, list[tuple[Element, str]]]:
    kinds: dict[str, list[tuple[Element, str]]] = {}
    for plugin, prefix in plugins:
        kinds.setdefault(_plugin_kind(plugin), []).append((plugin, prefix))
    return kinds


def _relative(pose_of, frame: str, of: str) -> tuple[np.ndarray, np.ndarray]:
    """Pose of node ``of`` in node ``frame``."""
    r_f, t_f = pose_of(frame)
    r_o, t_o = pose_of(of)
    return r_f.T @ r_o, r_f.T @ (t_o - t_f)


def _tree_order(flat: _Flat, joints: dict[str, tuple[str, str]]) -> list[str]:
    """Links from the root down; one line for a link with two parents, a loop, or a forest."""
    parent_of: dict[str, str] = {}
    for joint, (parent, child) in joints.items():
        if child not in flat.links:
            raise InteropError(f"SDF joint '{joint}': child '{child}' is not a link of the model")
        if parent != "world" and parent not in flat.links:
            raise InteropError(f"SDF joint '{joint}': parent '{parent}' is not a link of the model")
        if child in parent_of:
            raise InteropError(
                f"SDF model '{flat.name}': link '{child}' is the child of two joints "
                f"('{parent_of[child]}' and '{joint}'): a loop in the tree"
            )
        parent_of[child] = joint
    for link in flat.links:  # follow parents up: a cycle never reaches a root
        seen = [link]
        current = link
        while current in parent_of:
            current = joints[parent_of[current]][0]
            if current in seen:
                loop = " -> ".join([*seen[seen.index(current) :], current])
                raise InteropError(f"SDF model '{flat.name}': loop in the tree of joints: {loop}")
            seen.append(current)
    roots = [link for link in flat.links if link not in parent_of]
    world_children = [c for j, (p, c) in joints.items() if p == "world"]
    if len(roots) + len(world_children) != 1:
        listed = ", ".join(repr(r) for r in (roots + world_children)[:4])
        raise InteropError(
            f"SDF model '{flat.name}': {len(roots) + len(world_children)} links without a parent "
            f"joint ({listed}); a vehicle is one tree of links (join them with fixed joints)"
        )
    order, queue = [], roots + world_children
    children: dict[str, list[str]] = {}
    for parent, child in joints.values():
        children.setdefault(parent, []).append(child)
    while queue:
        link = queue.pop(0)
        order.append(link)
        queue += children.get(link, [])
    return order


def link_hydrodynamics(
    name: str, fluid: Element | None, terms: PluginTerms | None, volume: float, center
) -> LinkHydrodynamics:
    """Our ``fossen`` record of SDF link ``name``: the Hydrodynamics plugin's ``terms`` (``None``:
    none), the link's ``<fluid_added_mass>`` element ``fluid`` (``None``: none; not both: gz would
    count the added mass twice), and its displaced ``volume`` [m^3] and centre of buoyancy
    ``center`` [m] (link frame). Used by the SDF reader and by ``aiauv import-gz``.

    Raises:
        InteropError: One line.
    """
    terms = terms if terms is not None else PluginTerms(name)
    added_mass = terms.added_mass
    if fluid is not None:
        if terms.added_mass_given:
            raise InteropError(
                f"SDF link '{name}': added mass given both as <fluid_added_mass> and as "
                "Hydrodynamics plugin parameters (gz would count it twice); remove one or set "
                "<disable_added_mass>true</disable_added_mass>"
            )
        added_mass = fluid_added_mass(fluid, name)
    try:
        return LinkHydrodynamics(
            link=name,
            model="fossen",
            volume=volume,
            center_of_buoyancy=center,
            added_mass=added_mass,
            linear_damping=terms.linear_damping,
            quadratic_damping=terms.quadratic_damping,
        )
    except HydroError as exc:
        raise InteropError(f"SDF {exc}") from None


def _urdf(flat: _Flat, search, world_plugins, world_pose: Pose, gravity: float):
    convert = _Converter(flat, search)
    pose_of = convert.pose_of
    notes = convert.notes
    plugins = _plugins_by_kind(flat.plugins + [(p, "") for p in world_plugins])
    unmapped = sorted({_plugin_label(p) for p, _ in flat.plugins if not _plugin_kind(p)})
    if unmapped:
        warnings.warn(
            f"SDF model '{flat.name}': plugin(s) {', '.join(unmapped)} not simulated here",
            stacklevel=3,
        )
    for name, joint in flat.joints.items():
        kind = joint.get("type", "")
        if kind not in ("revolute", "prismatic", "fixed", "continuous"):
            raise InteropError(
                f"SDF joint '{name}' has type {kind or 'none'}, not supported "
                "(expected revolute, prismatic or fixed)"
            )
    child_joint = {child: joint for joint, (_, child) in flat.joint_refs.items()}

    def axis_in_child(joint: str) -> np.ndarray:
        vector, _, _ = convert.joint_axis(joint, flat.joints[joint])
        rotation, _ = _relative(pose_of, flat.joint_refs[joint][1], joint)
        return rotation @ vector

    # Thrusters: their joints rigid, the thrust along the joint axis at the child link's origin
    thrusters, frozen = [], {}
    for plugin, prefix in plugins.get("thruster", []):
        thruster = read_thruster(plugin, prefix)
        if thruster.joint not in flat.joints:
            raise InteropError(
                f"Thruster plugin: joint '{thruster.joint}' is not a joint of model '{flat.name}'"
            )
        child = flat.joint_refs[thruster.joint][1]
        thrusters.append((thruster, child, axis_in_child(thruster.joint)))
        frozen[thruster.joint] = "Thruster"
    # Fins: LiftDrag on a link; the fin angle is an actuator, its joint rigid
    fins = []
    for plugin, prefix in plugins.get("lift_drag", []):
        link = prefix + (plugin.findtext("link_name") or "").strip()
        if link not in flat.links:
            raise InteropError(
                f"LiftDrag plugin: link '{link}' is not a link of model '{flat.name}'"
            )
        joint = child_joint.get(link)
        axis = max_angle = None
        if joint is not None and flat.joints[joint].get("type") == "revolute":
            axis = axis_in_child(joint)
            _, lower, upper = convert.joint_axis(joint, flat.joints[joint])
            if lower is not None and upper is not None:
                max_angle = max(abs(lower), abs(upper))
            frozen[joint] = "LiftDrag"
        fins.append(lift_drag_fin(plugin, prefix, axis, max_angle))
    # Hydrodynamics plugins
    terms_of: dict[str, PluginTerms] = {}
    for plugin, prefix in plugins.get("hydrodynamics", []):
        terms = plugin_terms(plugin, flat.name)
        terms.link_name = prefix + terms.link_name
        if terms.link_name not in flat.links:
            raise InteropError(
                f"SDF model '{flat.name}': Hydrodynamics plugin for link '{terms.link_name}', "
                "which is not a link of the model"
            )
        if terms.link_name in terms_of:
            raise InteropError(
                f"SDF model '{flat.name}': two Hydrodynamics plugins for link '{terms.link_name}'"
            )
        terms_of[terms.link_name] = terms
    # Buoyancy (a world system)
    buoyancy_plugins = plugins.get("buoyancy", [])
    buoyancy = read_buoyancy(buoyancy_plugins[-1][0]) if buoyancy_plugins else None
    density = None
    if buoyancy is not None:
        density = buoyancy.density_at(float(world_pose.translation[2]))
        if buoyancy.layers:
            warnings.warn(
                f"SDF model '{flat.name}': graded buoyancy: the density at the model's start "
                f"height z = {world_pose.translation[2]:g} m, {density:g} kg/m^3, holds for the "
                "whole run (the layers are not simulated)",
                stacklevel=3,
            )
    else:
        notes.append("no Buoyancy system in the file: the links carry no buoyancy (as in gz)")
    if density is None:
        densities = [
            number(p.findtext("fluid_density"), "Thruster <fluid_density>")
            for p, _ in plugins.get("thruster", [])
            if p.findtext("fluid_density")
        ]
        density = densities[0] if densities else GZ_DEFAULT_FLUID_DENSITY

    def buoyant(link: str) -> bool:
        if buoyancy is None:
            return False
        if not buoyancy.enabled:
            return True
        scoped = f"{flat.name}::{link.replace('/', '::')}"
        return flat.name in buoyancy.enabled or scoped in buoyancy.enabled

    order = _tree_order(flat, flat.joint_refs)
    robot = Element("robot", {"name": flat.name})
    if any(parent == "world" for parent, _ in flat.joint_refs.values()):
        SubElement(robot, "link", {"name": "world"})
    hydro_links = []
    for link in order:
        robot.append(convert.link_element(link))
        element = flat.links[link]
        fluid = element.find("inertial/fluid_added_mass")
        terms = terms_of.get(link)
        volume, center = 0.0, np.zeros(3)
        if buoyant(link):

            def resolve(pose: Pose, link=link) -> Pose:
                return Pose(*convert.in_link(link, pose, link))

            volume, center = collision_volume(element, link, resolve)
        if fluid is None and terms is None and volume == 0.0:
            continue
        hydro_links.append(link_hydrodynamics(link, fluid, terms, volume, center))
    for joint in flat.joints:
        parent, child = flat.joint_refs[joint]
        kind = "fixed" if joint in frozen else flat.joints[joint].get("type")
        if kind == "fixed":
            rotation, translation = _relative(pose_of, parent if parent != "world" else "", child)
            element = SubElement(robot, "joint", {"name": joint, "type": "fixed"})
            SubElement(element, "parent", {"link": parent})
            SubElement(element, "child", {"link": child})
            _origin(element, rotation, translation)
            continue
        vector, lower, upper = convert.joint_axis(joint, flat.joints[joint])
        target = child
        frame_rotation, frame_translation = _relative(pose_of, joint, child)
        if not _is_identity(frame_rotation, frame_translation):
            target = f"{child}_joint_frame"
            SubElement(robot, "link", {"name": target})
            fixed = SubElement(robot, "joint", {"name": f"{target}_fixed", "type": "fixed"})
            SubElement(fixed, "parent", {"link": target})
            SubElement(fixed, "child", {"link": child})
            _origin(fixed, frame_rotation, frame_translation)
        element = SubElement(robot, "joint", {"name": joint, "type": kind})
        SubElement(element, "parent", {"link": parent})
        SubElement(element, "child", {"link": target})
        _origin(element, *_relative(pose_of, parent if parent != "world" else "", joint))
        SubElement(element, "axis", {"xyz": format_numbers(vector)})
        if kind in ("revolute", "prismatic"):
            limit = {}
            if lower is not None and upper is not None and lower <= upper:
                limit.update(lower=format_number(lower), upper=format_number(upper))
            for tag in ("effort", "velocity"):
                text = flat.joints[joint].findtext(f"axis/limit/{tag}")
                value = number(text, f"SDF joint '{joint}' <{tag}>") if text is not None else -1.0
                limit[tag] = format_number(value if value > 0.0 else 1e16)  # SDF: -1 unlimited
            SubElement(element, "limit", limit)
    if convert.undrawn:
        notes.append(
            f"visual meshes of {', '.join(convert.undrawn)} not drawable here (a submesh, or the "
            "file missing): their collision shapes are drawn"
        )
    if frozen:
        notes.append(
            "joints held rigid (their motion is an actuator command here): "
            + ", ".join(f"{joint} ({why})" for joint, why in frozen.items())
        )
    if hydro_links or thrusters or fins:
        block = SubElement(
            robot,
            "hydrodynamics",
            {"fluid_density": format_number(density), "gravity": format_number(gravity)},
        )
        for link in hydro_links:
            block.append(fossen_link_element(link))
        for thruster, link, direction in thrusters:
            SubElement(
                block,
                "thruster",
                {
                    "name": thruster.joint,
                    "link": link,
                    "xyz": "0 0 0",
                    "direction": format_numbers(direction),
                    "max_thrust": format_number(thruster.max_thrust),
                },
            )
        _add_fins(block, fins, flat.name)
    indent(robot, space="  ")
    return tostring(robot, encoding="unicode") + "\n", fins, notes


def _add_fins(block: Element, fins: list[dict], model: str) -> None:
    """Write the fins as ``<fin>`` elements where our block has them, else warn once."""
    if not fins:
        return
    from aiauv_hydro import spec

    if not hasattr(spec, "Fin"):
        names = ", ".join(fin["link"] for fin in fins)
        warnings.warn(
            f"SDF model '{model}': LiftDrag fins ({names}) are read but not simulated "
            "(this version has no fin forces)",
            stacklevel=4,
        )
        return
    for fin in fins:
        attributes = {}
        for key, value in fin.items():
            if key == "fluid_density":
                continue
            if isinstance(value, str):
                attributes[key] = value
            elif np.ndim(value):
                attributes[key] = format_numbers(value)
            elif math.isfinite(value):
                attributes[key] = format_number(value)
        SubElement(block, "fin", attributes)


def read_sdf_vehicle(
    path: str | os.PathLike,
    model: str | None = None,
    model_path: Sequence[str | os.PathLike] = (),
) -> SdfVehicle:
    """Read one model of an SDF file (a model file or a world) as a URDF with our block.

    Args:
        path: The SDF file.
        model: The model's name when the file (a world) holds several.
        model_path: Folders searched first for ``model://`` URIs and Fuel copies.

    Raises:
        InteropError: One line naming the problem (and :class:`InputLimitError` for a file over
            the limits).
    """
    path = Path(path)
    root = read_sdf_file(path)
    search = model_search_path(model_path)
    element, is_include = _choose_model(root, path, model)
    if is_include:
        model_element, file = _included_model(element, path, search)
        name = (element.findtext("name") or "").strip() or model_element.get("name", "")
        pose_element = element.find("pose")
        if pose_element is None:
            pose_element = model_element.find("pose")
        extra_plugins = element.findall("plugin")
    else:
        file, name, model_element, extra_plugins = path, element.get("name", ""), element, []
        pose_element = element.find("pose")
    world_pose = sdf_pose(pose_element, f"SDF model '{name}'")
    flat = _Flat(name)
    _flatten(flat, model_element, "", "", file, search, 0)
    flat.plugins += [(plugin, "") for plugin in extra_plugins]
    gravity = SDF_DEFAULT_GRAVITY
    gravity_text = root.findtext("world/gravity")
    if gravity_text is not None:
        gravity = float(np.linalg.norm(numbers(gravity_text, 3, "world <gravity>")))
    world_plugins = root.findall("world/plugin")
    text, fins, notes = _urdf(flat, search, world_plugins, world_pose, gravity)
    position = tuple(float(x) for x in world_pose.translation)
    return SdfVehicle(text, name, path, tuple(fins), position, tuple(notes))
