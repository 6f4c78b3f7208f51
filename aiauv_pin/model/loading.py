"""Loading vehicle descriptions: bundled URDFs, user URDFs, and their hydrodynamics blocks.

A user's URDF goes through three gates, each ending in a one-line :class:`VehicleLoadError`:

1. safe XML parsing (:func:`aiauv_hydro.urdf.block_reader.parse_robot_text`: no DTD, hence no
entity expansion and no
   external entities) and the URDF structure check of :mod:`aiauv_pin.description.urdf_validation`;
2. the ``<hydrodynamics>`` (and UUV Simulator) blocks
(:func:`aiauv_hydro.urdf.block_reader.read_hydrodynamics`);
3. Pinocchio's parser, with the process's standard error (file descriptor 2) redirected to a
   temporary file while it runs: urdfdom prints its complaints there, and they are turned into the
   one-line error instead of reaching the terminal. The model is then cross-checked against the
   validated URDF (total mass, joint types), since urdfdom can silently drop a bad value.
"""

from __future__ import annotations

import contextlib
import importlib.resources
import math
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from xml.etree import ElementTree

import pinocchio as pin

from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.block_reader import parse_robot_text, read_hydrodynamics
from aiauv_hydro.urdf.uuv_simulator import freeze_thruster_joints
from aiauv_pin.description.input_limits import MAX_FILE_BYTES, check_xml_text, read_text
from aiauv_pin.description.mjcf_reading import is_mjcf_text, read_mjcf
from aiauv_pin.description.safe_names import check_name
from aiauv_pin.description.sdf_reading import is_sdf_file, read_sdf_vehicle
from aiauv_pin.description.urdf_validation import UrdfStructure, validate_urdf
from aiauv_pin.description.xacro_loading import read_description
from aiauv_pin.errors import VehicleLoadError
from aiauv_pin.model.lenient_repairs import repair, world_root
from aiauv_pin.model.validation import validate_mass_matrix, validate_parameters
from aiauv_pin.model.vehicle import Vehicle

#: Cases of the paper's vehicle shipped with the package (PAPER_DATA.md, Sec. 4.2 of the paper).
BUNDLED_CASES = ("uniform", "stabilised")
#: Joint types a vehicle may have (1-DOF joints and rigid attachments).
SUPPORTED_JOINT_TYPES = ("revolute", "prismatic", "fixed")
#: Largest URDF accepted [bytes] (see :mod:`aiauv_pin.description.input_limits`).
MAX_URDF_BYTES = MAX_FILE_BYTES


def bundled_urdf(case: str = "uniform") -> Path:
    """Path of a bundled paper-vehicle URDF.

    Args:
        case: ``"uniform"`` (uniform density links) or ``"stabilised"`` (passively roll-stabilised).
    """
    if case not in BUNDLED_CASES:
        raise VehicleLoadError(
            f"unknown case '{case}' (expected one of {', '.join(BUNDLED_CASES)})"
        )
    resource = importlib.resources.files("aiauv_pin.urdf") / f"paper_{case}.urdf"
    return Path(str(resource))


def _read_text(path: str | os.PathLike) -> str:
    """A URDF's text, through the limits of :mod:`aiauv_pin.description.input_limits` (regular
    file, byte cap)."""
    return read_text(path, "URDF")


@contextlib.contextmanager
def captured_stderr_fd() -> Iterator[list[str]]:
    """Redirect file descriptor 2 to a temporary file; yield a list that receives what was written.

    Catches what C++ libraries print straight to the process's standard error (Python's own
    ``sys.stderr`` is flushed first). Other threads writing to standard error meanwhile are captured
    too.
    """
    captured: list[str] = []
    try:
        sys.stderr.flush()
    except (AttributeError, ValueError):
        pass
    saved = os.dup(2)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield captured
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            captured.append(sink.read().decode("utf-8", errors="replace"))


def _parser_complaint(text: str) -> str:
    """The first ``Error:`` message of urdfdom's output, on one line."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    for line in lines:
        if line.startswith("Error:"):
            return " ".join(line[len("Error:") :].split())
    return " ".join(lines[0].split()) if lines else ""


def _build_model(text: str, source: Path) -> pin.Model:
    with captured_stderr_fd() as captured:
        try:
            model = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
            failure = None
        except (RuntimeError, ValueError) as exc:
            model, failure = None, " ".join(str(exc).split())
    said = _parser_complaint(captured[0]) if captured else ""
    if model is None:
        reason = said or failure or "the URDF parser rejected it"
        raise VehicleLoadError(f"{source}: not a valid URDF ({reason})")
    if said:
        # urdfdom complained but returned a model: it dropped something, so refuse it
        raise VehicleLoadError(f"{source}: not a valid URDF ({said})")
    return model


def _cross_check(model: pin.Model, structure: UrdfStructure, source: Path) -> None:
    """The Pinocchio model carries what the validated URDF says."""
    for joint in model.joints[2:]:
        if joint.nq != 1 or joint.nv != 1:
            raise VehicleLoadError(
                f"{source}: joint '{model.names[joint.id]}' is not a 1-DOF joint"
            )
    urdf_mass = math.fsum(inertial.mass for inertial in structure.inertials.values())
    model_mass = math.fsum(inertia.mass for inertia in model.inertias[1:])
    if not math.isclose(model_mass, urdf_mass, rel_tol=1e-9, abs_tol=1e-12):
        raise VehicleLoadError(
            f"{source}: Pinocchio read a total mass of {model_mass:g} kg but the URDF says "
            f"{urdf_mass:g} kg"
        )
    for link in structure.links:
        if not model.existFrame(link, pin.FrameType.BODY):
            raise VehicleLoadError(f"{source}: Pinocchio dropped link '{link}'")


def load_vehicle(
    path: str | os.PathLike | None = None,
    *,
    added_mass: bool = True,
    damping: bool = True,
    restoring: bool = True,
    backend: str | None = None,
    xacro_args: dict[str, str] | None = None,
    package_path: list[str | os.PathLike] | tuple = (),
    trust_xacro: bool = False,
    fixed_base: bool = False,
    lenient: bool = False,
    model: str | None = None,
    model_path: list[str | os.PathLike] | tuple = (),
) -> Vehicle:
    """Load an underwater vehicle from a URDF with an optional ``<hydrodynamics>`` block, or an SDF.

    The URDF may also carry UUV Simulator hydrodynamic blocks
    (:mod:`aiauv_hydro.urdf.uuv_simulator`); they are
    read with it. A MuJoCo MJCF file (root ``<mujoco>``) is compiled by MuJoCo and read as the
    URDF it is (:mod:`aiauv_pin.description.mjcf_reading`).

    Args:
        path: URDF, ``.xacro`` or MJCF file; ``None`` loads the bundled paper vehicle with uniform density.
        added_mass: Include added mass (and its Coriolis terms).
        damping: Include linear, quadratic and crossflow damping.
        restoring: Include weight and buoyancy.
        backend: ``"auto"`` (compiled numba kernels when available, else Pinocchio), ``"numba"`` or
            ``"pinocchio"`` (the reference); ``None`` takes ``AIAUV_BACKEND`` or ``"auto"``.
        xacro_args: ``$(arg NAME)`` values when ``path`` is a ``.xacro`` file
            (:mod:`aiauv_pin.description.xacro_loading`).
        package_path: Folders searched first for ``$(find pkg)`` and ``package://``
            (then ``ROS_PACKAGE_PATH``, example-robot-data).
        trust_xacro: Expand a ``.xacro`` file with full xacro, whose expressions are Python
            ``eval`` and can run code: only for a file you trust. By default its expressions go
            to the safe evaluator (:mod:`aiauv_pin.description.xacro_safe_eval`).
        fixed_base: Fix the URDF's root link to the world (a manipulator on a stand, a tank
            rig): ``q`` and ``v`` keep the free-flyer layout, the base does not move
            (:attr:`Vehicle.fixed_base`). A root link named ``world`` without mass, fixed to the
            robot, makes the base fixed without it
            (:func:`aiauv_pin.model.lenient_repairs.world_root`).
        lenient: Repair what published files are known to trip instead of refusing them, each
            repair one :class:`aiauv_pin.errors.LenientRepairWarning`
            (:mod:`aiauv_pin.model.lenient_repairs`); the vehicle's ``lenient_repairs`` says what
            was done.
        model: For an SDF file (``.sdf``, ``.world``): the model to load when it holds several
            (a world); read by :mod:`aiauv_pin.description.sdf_reading` into a URDF with our
            block, then loaded as any URDF.
        model_path: For an SDF file: folders searched first for ``model://`` URIs and local
            copies of Fuel models (then ``GZ_SIM_RESOURCE_PATH``).

    Returns:
        The vehicle, with a free-flyer joint on the URDF's root link (locked with a fixed base).

    Raises:
        VehicleLoadError: One line naming the problem (missing file, not XML, not a URDF, unsafe
            XML, broken tree, unknown link, non-physical parameter, unsupported joint, ...).
    """
    notes: tuple[str, ...] = ()
    if (model is not None or model_path) and not (path is not None and is_sdf_file(path)):
        raise VehicleLoadError("model and model_path are only for SDF files (.sdf, .world)")
    if path is None:
        source = bundled_urdf("uniform")
        text = _read_text(source)
    elif isinstance(path, (str, os.PathLike)) and is_sdf_file(path):
        source = Path(path)
        if xacro_args:
            raise VehicleLoadError(f"{path}: --arg is only for .xacro files")
        sdf = read_sdf_vehicle(source, model, model_path)
        text, notes = sdf.urdf_text, sdf.notes
    elif isinstance(path, (str, os.PathLike)):
        source = Path(path)
        # None unless .xacro
        text = read_description(source, xacro_args, package_path, trust_xacro=trust_xacro)
        if text is None:
            # refuses URDF text passed as a path, FIFOs, devices, huge files
            text = _read_text(path)
    else:
        raise VehicleLoadError(
            f"path must be a file path (str or os.PathLike), not {type(path).__name__}"
        )
    text = text.removeprefix("\ufeff")
    check_xml_text(text, str(source))
    if path is not None and is_mjcf_text(text):
        mjcf = read_mjcf(source)  # MuJoCo compiles it; we read the URDF it is
        # a root body not on a free joint hangs from MuJoCo's world body: a fixed base
        fixed_base = bool(fixed_base) or mjcf.fixed_base
        text = mjcf.urdf_text
    try:
        root = parse_robot_text(text, str(source))
    except HydroError as exc:
        raise VehicleLoadError(str(exc)) from None
    changed = bool(freeze_thruster_joints(root))  # UUV Simulator propellers: rigid joints
    repairs = None
    if lenient:
        repairs = repair(root, str(source), package_path)
        changed = changed or bool(repairs.messages)
    if changed:
        text = ElementTree.tostring(root, encoding="unicode")
    fixed_base = bool(fixed_base) or world_root(root)
    try:
        structure = validate_urdf(root)
    except VehicleLoadError as exc:
        raise VehicleLoadError(f"{source}: {exc}") from None
    try:
        check_name(structure.name, "robot")
        for link in structure.links:
            check_name(link, "link")
        for joint in structure.joints:
            check_name(joint.name, "joint")
    except VehicleLoadError as exc:
        raise type(exc)(f"{source}: {exc}") from None
    for joint in structure.joints:
        if joint.type not in SUPPORTED_JOINT_TYPES:
            raise VehicleLoadError(
                f"{source}: joint '{joint.name}' has type {joint.type}, not supported "
                f"(expected one of {', '.join(SUPPORTED_JOINT_TYPES)})"
            )
    try:
        hydro = read_hydrodynamics(root, structure.urdf_links)  # the links read once, above
    except HydroError as exc:
        raise VehicleLoadError(f"{source}: {exc}") from None
    try:
        for thruster in hydro.thrusters:
            check_name(thruster.name, "thruster")
    except VehicleLoadError as exc:
        raise type(exc)(f"{source}: {exc}") from None
    validate_parameters(structure, hydro, str(source))
    model = _build_model(text, source)
    _cross_check(model, structure, source)
    for name in [link.link for link in hydro.links] + [t.link for t in hydro.thrusters]:
        if not model.existFrame(name, pin.FrameType.BODY):
            raise VehicleLoadError(f"{source}: hydrodynamics refer to unknown link '{name}'")
    vehicle = Vehicle(
        model,
        hydro,
        name=structure.name,
        added_mass=added_mass,
        damping=damping,
        restoring=restoring,
        backend=backend,
        fixed_base=fixed_base,
    )
    vehicle.lenient_repairs = repairs
    vehicle.merged_links = dict(repairs.merged_links) if repairs is not None else {}
    vehicle.urdf_path = source
    vehicle.urdf_text = text  # the expanded description (xacro files have no URDF on disk)
    vehicle.package_path = tuple(package_path)
    vehicle.urdf_structure = structure
    vehicle.description_notes = notes  # what an SDF's conversion changed or left out
    validate_mass_matrix(vehicle, str(source))
    return vehicle
