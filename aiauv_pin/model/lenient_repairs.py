"""Lenient loading: the repairs of published files that the validation gate refuses.

The gate (:mod:`aiauv_pin.model.validation`, :mod:`aiauv_pin.description.urdf_validation`) keeps
its verdicts. ``load_vehicle(..., lenient=True)`` (``--lenient``) first repairs, on the parsed URDF
tree, what published vehicles are known to trip, each repair announced by one
:class:`aiauv_pin.errors.LenientRepairWarning` line naming whose data is wrong (the source file, or
our ``<hydrodynamics>`` annotation) and what was done:

* **names** we refuse (:mod:`aiauv_pin.description.safe_names`; UUV Simulator's Oberon7 arm with an
  empty namespace has ``/base``, ``/azimuth``): renamed to the nearest safe name (characters outside
  the set become ``_``, a leading ``/``, ``.`` or ``-`` is dropped), everywhere the file refers to
  them (joint ends, ``<gazebo reference>``, plugin ``<link name>``, ``linkName``, ``jointName``);
* **continuous joints**: read as revolute joints without limits (the same dynamics; the angle is
  not wrapped), since the kernels take 1-DOF joints with one coordinate;
* **placeholder collision shapes** below the plausible size (UUV Simulator's ``no_collision``,
  a cylinder of 1e-6 m on thruster and sensor links) are dropped;
* **joints whose limits allow no motion** (``lower == upper``: Oberon7's ``anchor`` and finger tips)
  are made fixed: Gazebo holds them at the limit;
* **massless or inertia-less links on movable joints** (LAUV's fins on revolute joints: their mass
  matrix is singular) are treated as in their home simulator, where the joint is driven
  kinematically: the joint is locked (fixed) and the link's subtree merges into the parent link;
  a fin becomes an actuated surface of the parent (:attr:`LenientRepairs.merged_links` maps each
  merged link to the link that carries it now);
* **inertias that break the triangle inequality** or have a negative principal moment (ECA A9:
  0.6, 30, 35 kg m^2) are replaced by the nearest valid tensor in the Frobenius norm
  (:func:`nearest_valid_inertia`), the change printed;
* **a missing UUV Simulator ``center_of_buoyancy``** that our estimate (centroid of primitive
  collision shapes) cannot give is UUV Simulator's default, the link origin (``BuoyantObject.cc``,
  line 33, of uuv_gazebo_plugins; the block's value is only read when present,
  ``HydrodynamicModel.cc``, lines 61-66);
* **UUV Simulator thrusters without a thrust limit** (RexROV's: no ``clampMin/Max``, no
  ``thrustMin/Max``; ThrusterPlugin.cc, lines 44-47 of uuv_gazebo_plugins, leaves them unbounded)
  get the limit that UUV Simulator itself applies to them: ``max_thrust`` of its thruster manager's
  configuration for the robot, ``config/<robot name>/thruster_manager.yaml`` of package
  ``uuv_thruster_manager`` on the package path (RexROV: 2000 N), which its ``thruster_manager.py``
  (lines 373-382) clips every thrust command to; written as the plugin's ``thrustMin/thrustMax``
  (:func:`_thruster_limits`). Without that configuration they stay out, as without ``lenient``.

A root link named ``world`` without mass fixed to the robot (:func:`world_root`) makes the vehicle
fixed-base on any load, lenient or not.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement

import numpy as np

from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.uuv_simulator import (
    collision_centroid_or_none,
    thrust_limits,
    thruster_plugins,
    uuv_plugins,
)
from aiauv_pin.description.plausible_ranges import PLAUSIBLE_RANGES
from aiauv_pin.description.ros_packages import find_package, package_search_path
from aiauv_pin.description.safe_names import MAX_NAME_LENGTH, is_safe_name, shown
from aiauv_pin.errors import LenientRepairWarning
from aiauv_pin.model.validation import TRIANGLE_TOLERANCE

#: Name of the root link that fixes a robot to the world (URDF's and Gazebo's convention).
WORLD_LINK = "world"
#: Joint limit [rad] given to a continuous joint read as revolute (no limit in effect).
UNLIMITED_ANGLE = 1.0e4
#: Attributes that hold a link or joint name.
_NAME_ATTRIBUTES = ("name", "link", "reference")
#: Elements whose text holds a link or joint name (UUV Simulator plugins).
_NAME_TEXTS = ("linkName", "jointName", "link_name", "joint_name")


@dataclass
class LenientRepairs:
    """What a lenient load repaired.

    Attributes:
        messages: The warnings issued, in order.
        renamed: ``{old name: new name}`` of links and joints.
        merged_links: ``{link: link that carries it now}`` for links merged into their parent
            (a locked massless joint): UUV Simulator fin plugins on such a link act on the
            parent.
        locked_joints: Joints made fixed.
        projected_inertias: ``{link: (old principal moments, new principal moments)}`` [kg m^2].
    """

    messages: list[str] = field(default_factory=list)
    renamed: dict[str, str] = field(default_factory=dict)
    merged_links: dict[str, str] = field(default_factory=dict)
    locked_joints: list[str] = field(default_factory=list)
    projected_inertias: dict[str, tuple[tuple[float, ...], tuple[float, ...]]] = field(
        default_factory=dict
    )

    def say(self, source: str, message: str) -> None:
        """Record and warn one repair (one line)."""
        line = f"{source}: lenient repair: {message}"
        self.messages.append(line)
        warnings.warn(line, LenientRepairWarning, stacklevel=4)


def _float(text: str | None, default: float = 0.0) -> float:
    try:
        return float(text) if text is not None else default
    except ValueError:
        return default


def _mass(link: Element) -> float:
    mass = link.find("inertial/mass")
    return 0.0 if mass is None else _float(mass.get("value"))


_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _inertia(link: Element) -> np.ndarray | None:
    element = link.find("inertial/inertia")
    if element is None:
        return None
    xx, xy, xz, yy, yz, zz = (_float(element.get(key)) for key in _INERTIA_KEYS)
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def world_root(root: Element) -> bool:
    """Whether the robot's root link is a massless ``world`` link fixed to the robot (a fixed base).

    UUV Simulator's and ROS's convention: ``<link name="world"/>`` and a ``fixed`` joint from it to
    the robot's first link.
    """
    links = {link.get("name"): link for link in root.findall("link")}
    world = links.get(WORLD_LINK)
    if world is None or _mass(world) > 0.0:
        return False
    ends = [(joint, joint.find("parent"), joint.find("child")) for joint in root.findall("joint")]
    if any(child is not None and child.get("link") == WORLD_LINK for _, _, child in ends):
        return False
    below = [
        joint
        for joint, parent, _ in ends
        if parent is not None and parent.get("link") == WORLD_LINK
    ]
    return len(below) == 1 and below[0].get("type") == "fixed"


#: The valid principal moments ``x`` form the convex cone ``G x >= 0``: ``x_i >= 0`` and
#: ``x_i + x_j >= x_k`` (the triangle inequality of a real body).
_VALID_MOMENTS = np.array(
    [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, -1], [1, -1, 1], [-1, 1, 1]], dtype=float
)


def _project_moments(moments: np.ndarray) -> np.ndarray:
    """Euclidean projection of principal moments onto the valid cone :data:`_VALID_MOMENTS`.

    The projection lies on the face whose active constraints ``G_A x = 0`` hold, and is the
    projection onto that face's span; every subset ``A`` of the six constraints is tried and the
    nearest feasible candidate kept (a convex cone: that candidate is the projection).
    """
    best, best_distance = None, np.inf
    for mask in range(64):
        rows = _VALID_MOMENTS[[k for k in range(6) if mask >> k & 1]]
        if len(rows):
            candidate = moments - rows.T @ (np.linalg.pinv(rows @ rows.T) @ (rows @ moments))
        else:
            candidate = moments.copy()
        scale = max(1.0, float(np.max(np.abs(moments))))
        if np.all(_VALID_MOMENTS @ candidate >= -1e-12 * scale):
            distance = float(np.linalg.norm(candidate - moments))
            if distance < best_distance:
                best, best_distance = candidate, distance
    return np.maximum(best, 0.0)


def nearest_valid_inertia(inertia: np.ndarray) -> np.ndarray:
    """The physically valid inertia tensor nearest ``inertia`` in the Frobenius norm.

    Valid: symmetric, principal moments ``a, b, c >= 0`` with ``a + b >= c`` (and its
    permutations). These constraints depend only on the eigenvalues and are symmetric under their
    permutation, so the nearest valid tensor keeps the eigenvectors and projects the eigenvalues
    onto the valid cone (Lewis 1995, "The convex analysis of unitarily invariant matrix
    functions", J. Convex Analysis 2, Thm. 2.3; :func:`_project_moments`). For a broken triangle
    alone, ``c > a + b``, that is ``d = (c - a - b) / 3``: ``(a + d, b + d, c - d)``.
    """
    symmetric = 0.5 * (inertia + inertia.T)
    moments, axes = np.linalg.eigh(symmetric)
    return axes @ np.diag(_project_moments(moments)) @ axes.T


def _safe_name(name: str, taken: set[str]) -> str:
    candidate = re.sub(r"[^A-Za-z0-9_.\-/]", "_", name).lstrip("/.-")[:MAX_NAME_LENGTH] or "link"
    stem, k = candidate, 1
    while candidate in taken or not is_safe_name(candidate):
        k += 1
        candidate = f"{stem[: MAX_NAME_LENGTH - 8]}_{k}"
    return candidate


def _rename(root: Element, source: str, repairs: LenientRepairs) -> None:
    links = [link.get("name") for link in root.findall("link")]
    joints = [joint.get("name") for joint in root.findall("joint")]
    taken = {name for name in links + joints if isinstance(name, str)}
    for names in (links, joints):
        for name in names:
            if not isinstance(name, str) or is_safe_name(name) or name in repairs.renamed:
                continue
            new = _safe_name(name, taken)
            taken.add(new)
            repairs.renamed[name] = new
    if not repairs.renamed:
        return
    pairs = [f"{shown(old)} -> '{new}'" for old, new in repairs.renamed.items()]
    more = f" and {len(pairs) - 3} more" if len(pairs) > 3 else ""
    repairs.say(
        source,
        f"{len(pairs)} link or joint names not allowed here (the source file's names: characters "
        f"outside letters, digits, '_', '-', '.', '/' or a leading '/'): renamed "
        f"{', '.join(pairs[:3])}{more}",
    )
    for element in root.iter():
        if element is root:
            continue
        for attribute in _NAME_ATTRIBUTES:
            value = element.get(attribute)
            if value in repairs.renamed:
                element.set(attribute, repairs.renamed[value])
        if element.tag in _NAME_TEXTS and element.text is not None:
            text = element.text.strip()
            if text in repairs.renamed:
                element.text = repairs.renamed[text]


def _lock(joint: Element) -> None:
    joint.set("type", "fixed")
    for tag in ("limit", "dynamics", "safety_controller", "mimic", "axis"):
        for child in joint.findall(tag):
            joint.remove(child)


def _subtree_has_inertia(link: str, children: dict, links: dict) -> bool:
    stack = [link]
    while stack:
        name = stack.pop()
        element = links.get(name)
        if element is not None:
            inertia = _inertia(element)
            if _mass(element) > 0.0 and inertia is not None and np.any(inertia != 0.0):
                return True
        stack.extend(child for _, child in children.get(name, ()))
    return False


def _joints(root: Element, source: str, repairs: LenientRepairs) -> None:
    links = {link.get("name"): link for link in root.findall("link")}
    children: dict[str, list[tuple[Element, str]]] = {}
    parent_of: dict[str, str] = {}
    for joint in root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            continue
        children.setdefault(parent.get("link"), []).append((joint, child.get("link")))
        parent_of[child.get("link")] = parent.get("link")
    held: list[str] = []
    for joint in root.findall("joint"):
        name, kind = joint.get("name"), joint.get("type")
        if kind not in ("revolute", "prismatic", "continuous"):
            continue
        parent = joint.find("parent").get("link") if joint.find("parent") is not None else None
        child = joint.find("child").get("link") if joint.find("child") is not None else None
        limit = joint.find("limit")
        lower = _float(limit.get("lower")) if limit is not None else None
        upper = _float(limit.get("upper")) if limit is not None else None
        if kind != "continuous" and limit is not None and lower == upper:
            _lock(joint)
            repairs.locked_joints.append(name)
            held.append(name)
            continue
        if child is not None and not _subtree_has_inertia(child, children, links):
            _lock(joint)
            repairs.locked_joints.append(name)
            carrier = parent
            while carrier in parent_of and carrier in repairs.merged_links:
                carrier = repairs.merged_links[carrier]
            stack = [child]
            while stack:
                merged = stack.pop()
                repairs.merged_links[merged] = carrier
                stack.extend(grandchild for _, grandchild in children.get(merged, ()))
            repairs.say(
                source,
                f"{kind} joint '{name}' moves link '{child}', which has no mass or inertia (the "
                f"source file's data; its home simulator drives it kinematically): joint locked, "
                f"link merged into '{carrier}' (a fin on it becomes an actuated surface of "
                f"'{carrier}')",
            )
            continue
        if kind == "continuous":
            joint.set("type", "revolute")
            if limit is None:
                limit = SubElement(joint, "limit", {"effort": "0", "velocity": "0"})
            limit.set("lower", f"{-UNLIMITED_ANGLE:g}")
            limit.set("upper", f"{UNLIMITED_ANGLE:g}")
            repairs.say(
                source,
                f"continuous joint '{name}' (the source file's type) read as a revolute joint "
                f"without limits (+-{UNLIMITED_ANGLE:g} rad; the same dynamics, the angle not "
                "wrapped)",
            )
    if held:
        more = f" and {len(held) - 3} more" if len(held) > 3 else ""
        repairs.say(
            source,
            f"{len(held)} movable joints whose limits allow no motion (lower = upper, the source "
            f"file's data; Gazebo holds them there: sensor mounts, locked fingers) made fixed: "
            f"{', '.join(repr(name) for name in held[:3])}{more}",
        )


def _placeholder_collisions(root: Element, source: str, repairs: LenientRepairs) -> None:
    """Drop collision shapes below the plausible geometry size: UUV Simulator's ``no_collision``
    macro (a cylinder of 1e-6 m, ``uuv_descriptions/urdf/common.urdf.xacro``) marks a link that
    has none."""
    smallest = PLAUSIBLE_RANGES["geometry size"][0]
    dropped = []
    for link in root.findall("link"):
        for collision in link.findall("collision"):
            shape = next(iter(collision.find("geometry") or ()), None)
            if shape is None or shape.tag not in ("box", "cylinder", "sphere"):
                continue
            if shape.tag == "box":
                sizes = (shape.get("size") or "").split()
            else:
                sizes = [shape.get(key) for key in ("radius", "length") if shape.get(key)]
            values = [_float(size, default=1.0) for size in sizes]
            if values and max(values) < smallest:
                link.remove(collision)
                dropped.append(link.get("name"))
    if dropped:
        more = f" and {len(dropped) - 3} more" if len(dropped) > 3 else ""
        repairs.say(
            source,
            f"{len(dropped)} placeholder collision shapes smaller than {smallest:g} m (the source "
            f"file's: UUV Simulator's no_collision macro) dropped, on "
            f"{', '.join(repr(name) for name in dropped[:3])}{more}",
        )


def _inertias(root: Element, source: str, repairs: LenientRepairs) -> None:
    for link in root.findall("link"):
        inertia = _inertia(link)
        if inertia is None or not np.all(np.isfinite(inertia)):
            continue
        moments = np.linalg.eigvalsh(inertia)
        broken = moments[0] + moments[1] < moments[2] - TRIANGLE_TOLERANCE * moments[2]
        if not (broken or moments[0] < -TRIANGLE_TOLERANCE * abs(moments[2])):
            continue
        repaired = nearest_valid_inertia(inertia)
        new_moments = np.linalg.eigvalsh(repaired)
        element = link.find("inertial/inertia")
        for key, (i, j) in zip(
            _INERTIA_KEYS, ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)), strict=True
        ):
            element.set(key, repr(float(repaired[i, j])))
        name = link.get("name")
        repairs.projected_inertias[name] = (tuple(moments), tuple(new_moments))
        change = float(np.linalg.norm(repaired - inertia))
        repairs.say(
            source,
            f"link '{name}': inertia breaks the triangle inequality (the source file's data: "
            f"principal moments {moments[0]:.4g}, {moments[1]:.4g}, {moments[2]:.4g} kg m^2): "
            f"projected to the nearest valid tensor ({new_moments[0]:.4g}, {new_moments[1]:.4g}, "
            f"{new_moments[2]:.4g} kg m^2; change {change:.4g} kg m^2, Frobenius norm)",
        )


def _buoyancy_centres(root: Element, source: str, repairs: LenientRepairs) -> None:
    links = {link.get("name"): link for link in root.findall("link")}
    for plugin in uuv_plugins(root):
        for element in plugin.findall("link"):
            name = element.get("name")
            if element.find("center_of_buoyancy") is not None or name not in links:
                continue
            what = f"UUV Simulator link '{name}'"
            if collision_centroid_or_none(links[name], what) is not None:
                continue
            SubElement(element, "center_of_buoyancy").text = "0 0 0"
            repairs.say(
                source,
                f"{what}: no center_of_buoyancy and no primitive collision shapes to estimate it "
                "(the source file's data): UUV Simulator's default, the link origin",
            )


#: UUV Simulator's thruster manager package and its per-robot configuration (launch/
#: thruster_manager.launch: ``$(find uuv_thruster_manager)/config/$(arg model_name)/...``).
THRUSTER_MANAGER = ("uuv_thruster_manager", "config/{robot}/thruster_manager.yaml")


def thruster_manager_limit(config: Path) -> list[float] | float | None:
    """``thruster_manager: max_thrust`` [N] of a UUV Simulator thruster manager configuration:
    a number or a one-line list (one per thruster; thruster_manager.py, lines 373-379), ``None``
    when absent or not a positive finite number."""
    section = None
    for line in config.read_text(encoding="utf-8").splitlines():
        text = line.split("#", 1)[0].rstrip()
        if text and not text[0].isspace():
            section = text.rstrip(":").strip()
            continue
        match = re.fullmatch(r"\s+max_thrust:\s*(.+)", text)
        if section != "thruster_manager" or match is None:
            continue
        value = match.group(1).strip()
        try:
            numbers = [float(x) for x in value.strip("[]").split(",")]
        except ValueError:
            return None
        if not all(math.isfinite(x) and x > 0.0 for x in numbers):
            return None
        return numbers if value.startswith("[") else numbers[0]
    return None


def _thruster_limits(
    root: Element, source: str, repairs: LenientRepairs, package_path: Sequence
) -> None:
    unlimited = []
    for plugin in thruster_plugins(root):
        name = plugin.get("name") or (plugin.findtext("linkName") or "").strip()
        try:
            forward, backward = thrust_limits(plugin, f"UUV Simulator thruster '{name}'")
        except HydroError:
            continue  # refused with its one line when the hydrodynamics are read
        if not (math.isfinite(forward) and math.isfinite(backward)):
            unlimited.append(plugin)
    if not unlimited:
        return
    package, relative = THRUSTER_MANAGER
    robot = root.get("name", "")
    folder = find_package(package, package_search_path(package_path))
    config = folder / relative.format(robot=robot) if folder is not None else None
    limit = thruster_manager_limit(config) if config is not None and config.is_file() else None
    if limit is None:
        return  # left out, each with its warning, as without lenient
    for plugin in unlimited:
        identifier = (plugin.findtext("thrusterID") or "").strip()
        try:
            value = limit[int(identifier)] if isinstance(limit, list) else limit
        except (ValueError, IndexError):
            return
        for tag, bound in (("thrustMin", -value), ("thrustMax", value)):
            element = plugin.find(tag)
            if element is None:
                element = SubElement(plugin, tag)
            element.text = repr(float(bound))
    shown_limit = f"{min(limit):g}-{max(limit):g} N" if isinstance(limit, list) else f"{limit:g} N"
    repairs.say(
        source,
        f"{len(unlimited)} UUV Simulator thrusters without a thrust limit (the source file's data; "
        f"ThrusterPlugin.cc l. 44-47 leaves them unbounded) limited to +-{shown_limit}, the "
        f"max_thrust that UUV Simulator's thruster manager clips their commands to "
        f"(thruster_manager.py l. 373-382), from {package}/{relative.format(robot=robot)}",
    )


def repair(root: Element, source: str, package_path: Sequence = ()) -> LenientRepairs:
    """Repair, in place, what published files trip (see the module docstring); warn each repair.

    Args:
        root: The parsed ``<robot>`` element.
        source: The file, named in the messages.
        package_path: Folders searched first for ROS packages (UUV Simulator's thruster manager
            configuration), as :func:`aiauv_pin.load_vehicle` takes them.

    Returns:
        What was repaired.
    """
    repairs = LenientRepairs()
    _rename(root, source, repairs)
    _joints(root, source, repairs)
    _placeholder_collisions(root, source, repairs)
    _inertias(root, source, repairs)
    _buoyancy_centres(root, source, repairs)
    _thruster_limits(root, source, repairs, package_path)
    return repairs
