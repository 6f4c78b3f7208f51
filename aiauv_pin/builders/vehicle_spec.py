"""Vehicle specification of an articulated AUV built from cylindrical modules (tail to head).

A spec is a small TOML file; :func:`load_spec` reads it and :func:`spec_from_dict` validates the
parsed table into frozen dataclasses. :mod:`aiauv_pin.builders.urdf_builder` turns a
:class:`VehicleSpec` into a
URDF.

The spec format (every key, its unit and default; keys not listed there are errors) is documented in
``docs/source/vehicle_spec.md`` ("Vehicle spec" on the documentation site). Positions are in the
module's link frame: origin on the module's rear joint axis (the tail module's rear end), x forward
along the module, z up.
"""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from aiauv_pin._internal.schema_validation import NAME_PATTERN, validate
from aiauv_pin.builders.vehicle_spec_schema import (
    DEFAULT_FLUID_DENSITY,
    DEFAULT_GRAVITY,
    DEFAULT_JOINT_EFFORT,
    DEFAULT_JOINT_LIMIT_DEG,
    DEFAULT_JOINT_VELOCITY,
    DIRECTIONS,
    JOINT_AXES,
    VehicleSpecFile,
)
from aiauv_pin.errors import AiauvError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib


class SpecError(AiauvError, ValueError):
    """Malformed vehicle spec; the message is one line naming the field (and module)."""


END_EFFECTOR_LINK = "end_effector"
END_EFFECTOR_JOINT = "end_effector_joint"
_RESERVED_NAMES = frozenset({END_EFFECTOR_LINK, END_EFFECTOR_JOINT, "universe", "root_joint"})
_NAME_PATTERN = re.compile(NAME_PATTERN)


def joint_name(index: int) -> str:
    """Name of the joint at the front of module ``index`` (0-based): ``joint1``, ``joint2``, ..."""
    return f"joint{index + 1}"


def _positive(value: float, what: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise SpecError(f"{what} must be positive and finite, got {value!r}")
    return value


def _finite_vector(value: Any, what: str) -> tuple[float, float, float]:
    try:
        vector = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise SpecError(f"{what} must be a list of 3 numbers, got {value!r}") from None
    if len(vector) != 3:
        raise SpecError(f"{what} must have 3 components, got {len(vector)}")
    if not all(math.isfinite(v) for v in vector):
        raise SpecError(f"{what} must be finite, got {list(vector)!r}")
    return vector  # type: ignore[return-value]


def _check_name(name: Any, what: str) -> str:
    if not isinstance(name, str) or not _NAME_PATTERN.fullmatch(name):
        raise SpecError(
            f"{what} must be a name of letters, digits, '_', '-', '.' (not starting with a digit), "
            f"got {name!r}"
        )
    return name


@dataclass(frozen=True)
class ThrusterSpec:
    """A fixed thruster on a module.

    Attributes:
        name: Thruster name, unique in the vehicle.
        position: Point of action in the module's link frame [m].
        direction: Unit direction of positive thrust in the module's link frame.
        max_thrust: Thrust magnitude limit [N].
    """

    name: str
    position: tuple[float, float, float]
    direction: tuple[float, float, float]
    max_thrust: float

    def __post_init__(self) -> None:
        what = f"thruster '{self.name}'"
        _check_name(self.name, "thruster name")
        object.__setattr__(self, "position", _finite_vector(self.position, f"{what}: position"))
        direction = _finite_vector(self.direction, f"{what}: direction")
        norm = math.sqrt(sum(d * d for d in direction))
        if norm == 0.0:
            raise SpecError(f"{what}: direction must be nonzero")
        object.__setattr__(self, "direction", tuple(d / norm for d in direction))
        object.__setattr__(self, "max_thrust", _positive(self.max_thrust, f"{what}: max_thrust"))


@dataclass(frozen=True)
class ModuleSpec:
    """One cylindrical module (one URDF link) of the vehicle.

    Attributes:
        name: Link name.
        length: Module length ``L`` [m]; the module spans x in [0, L] of its link frame.
        mass: Module mass ``m`` [kg].
        radius: Cylinder radius ``r`` [m].
        cg_offset: Centre of gravity minus the module centre ``(L/2, 0, 0)`` [m].
        volume: Displaced volume [m^3].
        cb_offset: Centre of buoyancy minus the module centre ``(L/2, 0, 0)`` [m].
        joint: Axis letter of the revolute joint at the module's front, ``None`` on the head.
        thrusters: Thrusters mounted on the module, in file order.
    """

    name: str
    length: float
    mass: float
    radius: float
    cg_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    volume: float | None = None
    cb_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    joint: str | None = None
    thrusters: tuple[ThrusterSpec, ...] = ()

    def __post_init__(self) -> None:
        _check_name(self.name, "module name")
        what = f"module '{self.name}'"
        for field_name in ("length", "mass", "radius"):
            value = _positive(getattr(self, field_name), f"{what}: {field_name}")
            object.__setattr__(self, field_name, value)
        if self.volume is not None:
            object.__setattr__(self, "volume", _positive(self.volume, f"{what}: volume"))
        for field_name in ("cg_offset", "cb_offset"):
            offset = _finite_vector(getattr(self, field_name), f"{what}: {field_name}")
            object.__setattr__(self, field_name, offset)
            self._check_inside(offset, f"{what}: {field_name}")
        if self.joint is not None and self.joint not in JOINT_AXES:
            raise SpecError(f"{what}: joint must be one of 'x', 'y', 'z', got {self.joint!r}")
        object.__setattr__(self, "thrusters", tuple(self.thrusters))
        for thruster in self.thrusters:
            x = thruster.position[0]
            if not 0.0 <= x <= self.length:
                raise SpecError(
                    f"{what}: thruster '{thruster.name}' x = {x!r} m lies outside the module "
                    f"length [0, {self.length!r}]"
                )

    def _check_inside(self, offset: tuple[float, float, float], what: str) -> None:
        half = 0.5 * self.length
        radial = math.hypot(offset[1], offset[2])
        if abs(offset[0]) > half or radial > self.radius:
            raise SpecError(
                f"{what} = {list(offset)!r} puts the point outside the module cylinder "
                f"(|x| <= {half!r}, sqrt(y^2 + z^2) <= {self.radius!r})"
            )

    @property
    def center_of_gravity(self) -> tuple[float, float, float]:
        """Centre of gravity in the link frame [m]: ``(L/2, 0, 0) + cg_offset``."""
        return (0.5 * self.length + self.cg_offset[0], self.cg_offset[1], self.cg_offset[2])

    @property
    def center_of_buoyancy(self) -> tuple[float, float, float]:
        """Centre of buoyancy in the link frame [m]: ``(L/2, 0, 0) + cb_offset``."""
        return (0.5 * self.length + self.cb_offset[0], self.cb_offset[1], self.cb_offset[2])

    @property
    def inertia_about_cg(self) -> tuple[float, float, float]:
        """Principal moments ``(Ixx, Iyy, Izz)`` about the CG, link axes [kg m^2].

        Solid homogeneous circular cylinder along x (standard closed form, e.g. Meriam & Kraige,
        Engineering Mechanics: Dynamics, Table D/4): ``Ixx = m r^2 / 2``,
        ``Iyy = Izz = m (3 r^2 + L^2) / 12``. The same moments are used when the CG is offset
        (a modelling choice: the offset is taken as a point-mass shift of a ballast that does not
        change the moments about the CG).
        """
        m, r, length = self.mass, self.radius, self.length
        axial = 0.5 * m * r * r
        transverse = m * (3.0 * r * r + length * length) / 12.0
        return (axial, transverse, transverse)


@dataclass(frozen=True)
class VehicleSpec:
    """An articulated AUV: modules tail to head joined by revolute joints.

    Attributes:
        name: Robot name.
        modules: Modules, tail first (at least two).
        fluid_density: Water density ``rho`` [kg/m^3].
        gravity: Gravitational acceleration magnitude ``g`` [m/s^2].
        joint_limit_deg: Symmetric joint limit [deg]; each joint moves in ``[-lim, +lim]``.
        joint_effort: URDF joint effort limit [N m].
        joint_velocity: URDF joint velocity limit [rad/s].
    """

    name: str
    modules: tuple[ModuleSpec, ...]
    fluid_density: float = DEFAULT_FLUID_DENSITY
    gravity: float = DEFAULT_GRAVITY
    joint_limit_deg: float = DEFAULT_JOINT_LIMIT_DEG
    joint_effort: float = DEFAULT_JOINT_EFFORT
    joint_velocity: float = DEFAULT_JOINT_VELOCITY

    def __post_init__(self) -> None:
        _check_name(self.name, "name")
        for field_name in ("fluid_density", "joint_effort", "joint_velocity"):
            object.__setattr__(self, field_name, _positive(getattr(self, field_name), field_name))
        gravity = float(self.gravity)
        if not (math.isfinite(gravity) and gravity >= 0.0):
            raise SpecError(f"gravity must be >= 0 and finite, got {gravity!r}")
        object.__setattr__(self, "gravity", gravity)
        limit = float(self.joint_limit_deg)
        if not (math.isfinite(limit) and 0.0 < limit <= 180.0):
            raise SpecError(f"joint_limit_deg must be in (0, 180], got {limit!r}")
        object.__setattr__(self, "joint_limit_deg", limit)
        modules = tuple(self.modules)
        object.__setattr__(self, "modules", modules)
        if len(modules) < 2:
            raise SpecError(f"a vehicle needs at least 2 modules, got {len(modules)}")
        from aiauv_pin.description.input_limits import MAX_LINKS

        if len(modules) > MAX_LINKS - 1:  # plus the end-effector link
            raise SpecError(
                f"{len(modules)} modules, more than the {MAX_LINKS - 1} supported "
                "(aiauv_pin.description.input_limits.MAX_LINKS)"
            )
        for index, module in enumerate(modules):
            is_head = index == len(modules) - 1
            if is_head and module.joint is not None:
                raise SpecError(f"module '{module.name}': the head module must not have a joint")
            if not is_head and module.joint is None:
                raise SpecError(
                    f"module '{module.name}': missing field 'joint' (axis 'x', 'y' or 'z')"
                )
        names = [module.name for module in modules]
        joints = {joint_name(i) for i in range(len(modules) - 1)}
        seen: set[str] = set()
        for name in names:
            if name in seen:
                raise SpecError(f"module name '{name}' used twice")
            if name in _RESERVED_NAMES or name in joints:
                raise SpecError(f"module name '{name}' is reserved for a generated joint or frame")
            seen.add(name)
        thruster_names: set[str] = set()
        for module in modules:
            for thruster in module.thrusters:
                if thruster.name in thruster_names:
                    raise SpecError(f"thruster name '{thruster.name}' used twice")
                thruster_names.add(thruster.name)

    @property
    def total_mass(self) -> float:
        """Sum of the module masses [kg]."""
        return math.fsum(module.mass for module in self.modules)

    @property
    def total_length(self) -> float:
        """Sum of the module lengths [m] (tail end to end effector in the straight pose)."""
        return math.fsum(module.length for module in self.modules)

    @property
    def joint_limit(self) -> float:
        """Symmetric joint limit [rad]."""
        return math.radians(self.joint_limit_deg)

    @property
    def link_names(self) -> tuple[str, ...]:
        """Link names, tail to head."""
        return tuple(module.name for module in self.modules)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Revolute joint names, tail to head (``joint1`` .. ``joint{n-1}``)."""
        return tuple(joint_name(i) for i in range(len(self.modules) - 1))

    def module_volume(self, module: ModuleSpec) -> float:
        """Displaced volume of ``module`` [m^3]: its ``volume``, else ``mass / fluid_density``."""
        if module.volume is not None:
            return module.volume
        return module.mass / self.fluid_density  # neutrally buoyant on its own

    @property
    def thrusters(self) -> tuple[tuple[str, ThrusterSpec], ...]:
        """``(link name, thruster)`` pairs in vehicle order (tail to head, file order)."""
        return tuple((module.name, t) for module in self.modules for t in module.thrusters)


# --------------------------------------------------------------------------------------------------
# Reading the TOML table (checked by the schema, aiauv_pin.builders.vehicle_spec_schema.VehicleSpecFile)


def spec_from_dict(table: Mapping[str, Any]) -> VehicleSpec:
    """Validate a parsed spec table (the TOML document as a dict) into a :class:`VehicleSpec`.

    The table is checked by the schema
    (:class:`aiauv_pin.builders.vehicle_spec_schema.VehicleSpecFile`: types,
    unknown keys, plausible ranges); the data classes check what depends on several keys (names
    used twice, the head's joint, a thruster or a CG/CB outside its module).

    Args:
        table: The spec, in the format described in this module's docstring.

    Returns:
        The vehicle spec.

    Raises:
        SpecError: On any unknown key, missing field, wrong type, non-positive, non-finite or
            implausible quantity, bad axis or direction, duplicate name, fewer than two modules, a
            thruster outside its module, or a CG/CB outside its module; the message is one line
            naming the key path (``module 'link2'.mass``).
    """
    checked = validate(VehicleSpecFile, table, SpecError, "vehicle spec")
    modules = []
    for index, module in enumerate(checked.module):
        where = f"module '{module.name}'"
        radius = module.radius if module.radius is not None else checked.radius
        if radius is None:
            raise SpecError(f"{where}: missing field 'radius' (and no top-level radius)")
        if (module.mass is None) == (module.density is None):
            raise SpecError(f"{where}: give exactly one of 'mass' [kg] or 'density' [kg/m^3]")
        mass = module.mass
        if mass is None:
            mass = module.density * math.pi * radius * radius * module.length  # solid cylinder
        thrusters = []
        for thruster in module.thruster:
            direction = thruster.direction
            if isinstance(direction, str):
                direction = DIRECTIONS[direction]
            limit = thruster.max_thrust if thruster.max_thrust is not None else checked.max_thrust
            position = (thruster.x, thruster.y, thruster.z)
            try:
                thrusters.append(ThrusterSpec(thruster.name, position, tuple(direction), limit))
            except SpecError as error:
                raise SpecError(f"{where}: {error}") from None
        if index < len(checked.module) - 1 and module.joint is None:
            raise SpecError(f"{where}: missing field 'joint' (axis 'x', 'y' or 'z')")
        modules.append(
            ModuleSpec(
                name=module.name,
                length=module.length,
                mass=mass,
                radius=radius,
                cg_offset=tuple(module.cg_offset),
                volume=module.volume,
                cb_offset=tuple(module.cb_offset),
                joint=module.joint,
                thrusters=tuple(thrusters),
            )
        )
    same = {f.name: getattr(checked, f.name) for f in fields(VehicleSpec) if f.name != "modules"}
    return VehicleSpec(modules=tuple(modules), **same)  # the other fields keep their file names


def spec_from_toml(text: str) -> VehicleSpec:
    """Parse and validate a spec given as TOML text.

    Raises:
        SpecError: On invalid TOML or an invalid spec (one-line message).
    """
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SpecError(f"invalid TOML: {' '.join(str(error).split())}") from None
    return spec_from_dict(table)


def load_spec(path: str | Path) -> VehicleSpec:
    """Read and validate a vehicle spec TOML file.

    Args:
        path: Spec file.

    Returns:
        The vehicle spec.

    Raises:
        SpecError: If the file cannot be read, is not valid TOML or is not a valid spec; the
            message is one line and starts with the file name.
    """
    from aiauv_pin.description.input_limits import read_text

    try:
        text = read_text(path, "vehicle spec")  # regular file, byte cap
    except AiauvError as error:
        reason = str(error).removeprefix(f"{path}: ")
        raise SpecError(f"{path}: cannot read vehicle spec: {reason}") from None
    path = Path(path)
    try:
        return spec_from_toml(text)
    except SpecError as error:
        raise SpecError(f"{path}: {error}") from None
