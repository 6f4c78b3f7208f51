"""Schemas of scenario files and vehicle specs (pydantic v2, strict), their JSON Schema and errors.

Every key of a scenario file (:class:`ScenarioFile`) and of a vehicle spec
(:class:`VehicleSpecFile`) is declared once here with its type, its plausible range, its unit in
brackets and its meaning. Validation is strict: a bool is not a number, a string is not a number,
an unknown key is an error (``extra="forbid"``), a number outside its range is an error. The ranges
are plausibility bounds: a value beyond them would make a run diverge or overflow (a current of
1e6 m/s, a tidal period of 1e-300 s, ``k_d = 1e308``), not a physical limit of the method.

Sweep specs (:mod:`aiauv_pin.sweep_spec`) name the keys of :class:`ScenarioFile`; their schema is
generated from it (:func:`aiauv_pin.sweep_spec.sweep_file_model`). The models only check; the
readers (:func:`aiauv_pin.scenario_file.scenario_from_mapping`,
:func:`aiauv_pin.vehicle_spec.spec_from_dict`) build the data classes the rest of the code uses.

:func:`one_line` turns pydantic's :class:`~pydantic.ValidationError` into one line naming the key
path and what is expected (``controller.k_d: expected a number in (0, 10000] (bool is not a
number), got True``), computed from the JSON Schema that ``aiauv schema`` prints, so the message
and the schema cannot disagree.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Annotated, Any, Literal, get_args

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, ValidationError
from pydantic.json_schema import GenerateJsonSchema

from control.path_following import CURRENT_COMPENSATION_OPTIONS, PathFollowingGains
from control.reduced_attitude import FEEDFORWARD_OPTIONS

from .input_limits import MAX_LINKS
from .lagged import ADDED_MASS_SCHEMES
from .scenario import CASES, CONTROLLERS
from .vehicle_spec import (
    _DIRECTIONS,
    _NAME_PATTERN,
    DEFAULT_FLUID_DENSITY,
    DEFAULT_GRAVITY,
    DEFAULT_JOINT_EFFORT,
    DEFAULT_JOINT_LIMIT_DEG,
    DEFAULT_JOINT_VELOCITY,
    DEFAULT_MAX_THRUST,
)

#: Integrators of :func:`aiauv_pin.simulate`.
METHODS = ("rk4", "euler", "midpoint")
#: The JSON Schema dialect pydantic emits.
DIALECT = "https://json-schema.org/draft/2020-12/schema"
#: Pattern of link, joint and thruster names of a vehicle spec.
NAME_PATTERN = f"^{_NAME_PATTERN.pattern}$"


def _config(title: str | None = None) -> ConfigDict:
    return ConfigDict(strict=True, extra="forbid", allow_inf_nan=False, frozen=True, title=title)


# --------------------------------------------------------------------------------------------------
# Typed numbers with their ranges


@dataclass(frozen=True)
class Bounds:
    """Plausible range of a number: ``[low, high]``, either end open."""

    low: float
    high: float
    low_open: bool = False
    high_open: bool = False

    def text(self) -> str:
        """``[0, 10]``, ``(0, 1e4]``, ... as the documentation and the messages print it."""
        return (
            f"{'(' if self.low_open else '['}{_g(self.low)}, "
            f"{_g(self.high)}{')' if self.high_open else ']'}"
        )


def _g(x: float) -> str:
    if x == math.pi:
        return "pi"
    if x != 0.0 and math.isfinite(x) and not 1.0e-3 <= abs(x) < 1.0e4:
        mantissa, exponent = f"{x:e}".split("e")
        return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"
    return f"{x:g}"


def number(low: float, high: float, *, low_open: bool = False, high_open: bool = False):
    """A finite number in a range (an ``int`` is accepted, a ``bool`` or a string is not)."""
    bounds = Bounds(low, high, low_open, high_open)
    limits = {"gt" if low_open else "ge": low, "lt" if high_open else "le": high}
    return Annotated[float, Field(**limits), bounds]


def vector(low: float, high: float, length: int = 3):
    """A list of ``length`` numbers, each in ``[low, high]``."""
    return Annotated[list[number(low, high)], Field(min_length=length, max_length=length)]


def _bounds(annotation) -> Bounds | None:
    for item in getattr(annotation, "__metadata__", ()):
        if isinstance(item, Bounds):
            return item
    for arg in get_args(annotation):
        found = _bounds(arg)
        if found is not None:
            return found
    return None


def key(annotation, unit: str, meaning: str, default: Any = None, **extra):
    """A field: its meaning, unit in brackets and range in the description."""
    bounds = _bounds(annotation)
    each = "each " if str(annotation).startswith("typing.Annotated[list[") else ""
    where = f", {each}in {bounds.text()}" if bounds else ""
    return Field(
        default, description=f"{meaning} [{unit}]{where}", json_schema_extra={"unit": unit}, **extra
    )


# --------------------------------------------------------------------------------------------------
# Plausibility ranges (documented in docs/source/scenario.md through SCHEMA's table)

#: Largest distance from the origin of a position [m].
MAX_POSITION = 1.0e5
#: Largest water or vehicle speed [m/s] (ten times a strong tidal current).
MAX_SPEED = 10.0
#: Largest simulated duration [s] (about 28 hours).
MAX_DURATION = 1.0e5

Position = vector(-MAX_POSITION, MAX_POSITION)
#: A direction (normalised by its reader); the bound keeps its square from overflowing.
Direction = vector(-1.0e6, 1.0e6)
Speed3 = vector(-MAX_SPEED, MAX_SPEED)


class StartTable(BaseModel):
    """``[start]``: where and how the vehicle starts (straight, at rest but for ``surge``)."""

    model_config = _config("start")
    position: Position | None = key(
        Position, "m", "end-effector start, world axes; the vehicle straight (default 0, 2, 2)"
    )
    heading: Direction | None = key(
        Direction, "-", "direction the vehicle points at the start (default: the path's tangent)"
    )
    surge: number(-MAX_SPEED, MAX_SPEED) | None = key(
        number(-MAX_SPEED, MAX_SPEED), "m/s", "initial forward speed"
    )


class LineTable(BaseModel):
    """``[path] type = "line"``: :class:`control.paths.LinePath`."""

    model_config = _config("line")
    type: Literal["line"] = key(Literal["line"], "-", "path type", "line")
    point: Position = key(Position, "m", "a point of the line (s = 0 there)", ...)
    direction: Direction = key(Direction, "-", "direction of the line (normalised; nonzero)", ...)


class HelixTable(BaseModel):
    """``[path] type = "helix"``: :class:`control.paths.HelixPath`."""

    model_config = _config("helix")
    type: Literal["helix"] = key(Literal["helix"], "-", "path type", ...)
    centre: Position = key(Position, "m", "a point of the helix axis", ...)
    axis: Direction = key(
        Direction, "-", "helix axis (normalised; pitch > 0 turns right-handed about it)", ...
    )
    radius: number(1.0e-3, MAX_POSITION) = key(
        number(1.0e-3, MAX_POSITION), "m", "helix radius", ...
    )
    pitch: number(-MAX_POSITION, MAX_POSITION) = key(
        number(-MAX_POSITION, MAX_POSITION),
        "m/turn",
        "advance along the axis per turn (0: a circle)",
        ...,
    )
    start_angle: number(-1.0e3, 1.0e3) = key(
        number(-1.0e3, 1.0e3), "rad", "angle of the point s = 0 about the axis", 0.0
    )


Waypoints = Annotated[list[Position], Field(min_length=2, max_length=10_000)]


class WaypointsTable(BaseModel):
    """``[path] type = "waypoints"``: :class:`control.paths.WaypointPath`."""

    model_config = _config("waypoints")
    type: Literal["waypoints"] = key(Literal["waypoints"], "-", "path type", ...)
    points: Waypoints = key(Waypoints, "m", "waypoints [[x, y, z], ...], 2 to 10000", ...)
    corner_radius: number(1.0e-3, MAX_POSITION) = key(
        number(1.0e-3, MAX_POSITION), "m", "radius of the arcs rounding the corners", 1.0
    )


def _type_of(default: str | None):
    def tag(value) -> str | None:
        if not isinstance(value, Mapping):
            return None
        found = value.get("type", default)
        return found if isinstance(found, str) else None

    return tag


#: The path tables by ``type`` (the same keys as the classes of :data:`control.paths.PATH_TYPES`).
PATH_TABLES: dict[str, type[BaseModel]] = {
    "line": LineTable,
    "helix": HelixTable,
    "waypoints": WaypointsTable,
}
PathTable = Annotated[
    Annotated[LineTable, Tag("line")]
    | Annotated[HelixTable, Tag("helix")]
    | Annotated[WaypointsTable, Tag("waypoints")],
    Discriminator(_type_of(None)),
]

Velocity = key(Speed3, "m/s", "water velocity, world axes", [0.0, 0.0, 0.0])


class ConstantCurrentTable(BaseModel):
    """``[current] type = "constant"`` (the default): uniform and steady."""

    model_config = _config("constant")
    type: Literal["constant"] = key(Literal["constant"], "-", "current type", "constant")
    velocity: Speed3 = Velocity


class TidalCurrentTable(BaseModel):
    """``[current] type = "tidal"``: ``V(t) = V_0 + A sin(2 pi t / T + phi)``."""

    model_config = _config("tidal")
    type: Literal["tidal"] = key(Literal["tidal"], "-", "current type", ...)
    velocity: Speed3 = key(Speed3, "m/s", "mean water velocity V_0, world axes", [0.0, 0.0, 0.0])
    amplitude: Speed3 = key(Speed3, "m/s", "amplitude A of the oscillation, world axes", ...)
    period: number(1.0, 1.0e7) = key(
        number(1.0, 1.0e7), "s", "period T of the oscillation (a tide: hours)", ...
    )
    phase: number(-1.0e3, 1.0e3) = key(number(-1.0e3, 1.0e3), "rad", "phase phi", 0.0)


class ShearCurrentTable(BaseModel):
    """``[current] type = "shear"``: ``V(z) = V_0 + G (z - z_0)``."""

    model_config = _config("shear")
    type: Literal["shear"] = key(Literal["shear"], "-", "current type", ...)
    velocity: Speed3 = key(Speed3, "m/s", "water velocity V_0 at z_0, world axes", [0.0, 0.0, 0.0])
    gradient: vector(-1.0, 1.0) = key(vector(-1.0, 1.0), "1/s", "shear G, world axes", ...)
    reference_z: number(-1.0e4, 1.0e4) = key(
        number(-1.0e4, 1.0e4), "m", "depth z_0 where the current is V_0", 0.0
    )


#: The current tables by ``type`` (the keys of :data:`hydro.currents.CURRENT_KEYS`).
CURRENT_TABLES: dict[str, type[BaseModel]] = {
    "constant": ConstantCurrentTable,
    "tidal": TidalCurrentTable,
    "shear": ShearCurrentTable,
}
CurrentTable = Annotated[
    Annotated[ConstantCurrentTable, Tag("constant")]
    | Annotated[TidalCurrentTable, Tag("tidal")]
    | Annotated[ShearCurrentTable, Tag("shear")],
    Discriminator(_type_of("constant")),
]

_GAINS = PathFollowingGains()


def _gain_field(low: float, high: float, unit: str, meaning: str, *, low_open: bool = True):
    return key(number(low, high, low_open=low_open), unit, meaning)


CrossTrackGain = number(0.0, 100.0, low_open=True)
KE = CrossTrackGain | Annotated[list[CrossTrackGain], Field(min_length=2, max_length=2)]
G = number  # shorthand below


class ControllerTable(BaseModel):
    """``[controller]``: the controller and the gains of
    :class:`control.path_following.PathFollowingGains` (gains not given: the paper's for the case).
    """

    model_config = _config("controller")
    type: Literal[CONTROLLERS] = key(
        Literal[CONTROLLERS],
        "-",
        "paper (path following), none (passive: thrusters and joints idle) or thruster_turning",
        "paper",
    )
    u_d: G(0.0, MAX_SPEED, low_open=True) | None = _gain_field(
        0.0, MAX_SPEED, "m/s", f"desired surge speed (eq. 21, 25); default {_GAINS.u_d:g}"
    )
    k_e: KE | None = key(
        KE, "1/s", "cross-track gain (eq. 21), a number or [k_y, k_z]; default u_d / 10"
    )
    alpha: G(0.0, 100.0, low_open=True) | None = _gain_field(
        0.0, 100.0, "-", f"joint-reference shape parameter (eq. 22); default {_GAINS.alpha:g}"
    )
    k_p: G(0.0, 1.0e3, low_open=True) | None = _gain_field(
        0.0, 1.0e3, "-", f"pointing-error gain (eq. 23); default {_GAINS.k_p:g}"
    )
    k_d: G(0.0, 1.0e4, low_open=True) | None = _gain_field(
        0.0, 1.0e4, "s", "angular-velocity-error gain (eq. 23); default 19 or 12 by case"
    )
    k_qp: G(0.0, 1.0e6, low_open=True) | None = _gain_field(
        0.0, 1.0e6, "N m/rad", f"joint proportional gain (eq. 24); default {_GAINS.k_qp:g}"
    )
    k_qd: G(0.0, 1.0e6) | None = _gain_field(
        0.0,
        1.0e6,
        "N m s/rad",
        f"joint derivative gain (eq. 24); default {_GAINS.k_qd:g}",
        low_open=False,
    )
    k_1p: G(0.0, 1.0e6) | None = _gain_field(
        0.0,
        1.0e6,
        "N s/m",
        f"surge proportional gain (eq. 25); default {_GAINS.k_1p:g}",
        low_open=False,
    )
    k_1i: G(0.0, 1.0e6) | None = _gain_field(
        0.0,
        1.0e6,
        "N/m",
        f"surge integral gain (eq. 25); default {_GAINS.k_1i:g}",
        low_open=False,
    )
    q_max: G(0.0, math.pi, low_open=True) | None = _gain_field(
        0.0, math.pi, "rad", f"saturation of the base angles (eq. 22); default {_GAINS.q_max:.4g}"
    )
    feedforward: Literal[FEEDFORWARD_OPTIONS] | None = key(
        Literal[FEEDFORWARD_OPTIONS], "-", "feedforward of eq. (23): exact or as printed"
    )
    turn_feedforward: bool | None = key(
        bool,
        "-",
        "beyond the paper: feed the reference turn rate (path curvature) forward through the "
        "identified turn dynamics",
    )
    turn_curvature_gain: G(0.0, 1.0e3, low_open=True) | None = _gain_field(
        0.0, 1.0e3, "1/(m rad)", "turn model: steady path curvature per radian of base angle"
    )
    turn_time_constant: G(0.0, 1.0e4) | None = _gain_field(
        0.0, 1.0e4, "s", "turn model: time constant of the turn rate", low_open=False
    )
    current_compensation: Literal[CURRENT_COMPENSATION_OPTIONS] | None = key(
        Literal[CURRENT_COMPENSATION_OPTIONS],
        "-",
        "none (the paper's LOS) or integral_los (integral LOS against currents)",
    )
    los_integral_gain: G(0.0, 1.0e3, low_open=True) | None = _gain_field(
        0.0, 1.0e3, "-", "integral gain sigma of the integral LOS"
    )
    hydrostatic_compensation: bool | None = key(
        bool, "-", "beyond the paper: base angles balance the vehicle's restoring moment"
    )
    turn_moment_gain: G(0.0, 1.0e6, low_open=True) | None = _gain_field(
        0.0, 1.0e6, "N m/rad", "effective hydrodynamic moment per radian of base angle"
    )


class OutputTable(BaseModel):
    """``[output]``: what a run writes."""

    model_config = _config("output")
    csv_period: number(1.0e-6, MAX_DURATION) | None = key(
        number(1.0e-6, MAX_DURATION), "s", "time between rows of timeseries.csv (<= duration)"
    )


Seconds = number(0.0, MAX_DURATION, low_open=True)
#: An integration step [s]: a step of more than 10 s says nothing about the vehicle (it may still
#: diverge, which a run reports); the lower bound keeps duration / dt countable.
Step = number(1.0e-6, 10.0)


class ScenarioFile(BaseModel):
    """A scenario file (every key optional; a key not given keeps the paper scenario's value)."""

    model_config = _config("scenario")
    case: Literal[CASES] | None = key(
        Literal[CASES], "-", "paper case: the bundled vehicle and its k_d (default uniform)"
    )
    vehicle: Annotated[str, Field(min_length=1, max_length=4096)] | None = key(
        str, "-", "URDF or xacro of the vehicle, relative to the file naming it"
    )
    duration: Seconds | None = key(Seconds, "s", "simulated time (default 300)")
    dt: Step | None = key(Step, "s", "integration step (<= duration; default 0.004)")
    method: Literal[METHODS] | None = key(Literal[METHODS], "-", "integrator (default euler)")
    control_period: number(1.0e-6, 100.0) | None = key(
        number(1.0e-6, 100.0),
        "s",
        "sampling period of the guidance, base-angle and surge loops, a whole multiple of dt "
        "(default: every step)",
    )
    continuous_joints: bool | None = key(
        bool, "-", "joint PD (eq. 24) as a continuous servo (true) or sampled with the controller"
    )
    added_mass: Literal[ADDED_MASS_SCHEMES] | None = key(
        Literal[ADDED_MASS_SCHEMES],
        "-",
        "exact (in the mass matrix) or lagged (UUV Simulator's and gz-sim's scheme; Python "
        "controller)",
    )
    lagged_filter: number(0.0, 1.0, low_open=True) | None = key(
        number(0.0, 1.0, low_open=True),
        "-",
        "filter coefficient alpha of the lagged scheme: 0.3 UUV Simulator, 1 gz-sim",
    )
    start: StartTable | None = key(StartTable, "-", "the start")
    path: PathTable | None = key(PathTable, "-", "the path to follow (default: the world x-axis)")
    current: CurrentTable | None = key(CurrentTable, "-", "the water current (default: none)")
    controller: ControllerTable | None = key(ControllerTable, "-", "the controller and its gains")
    output: OutputTable | None = key(OutputTable, "-", "outputs")


# --------------------------------------------------------------------------------------------------
# Vehicle specs

Name = Annotated[str, Field(pattern=NAME_PATTERN, max_length=200)]
Length = number(0.0, 100.0, low_open=True)
Offset = vector(-100.0, 100.0)
#: Thruster directions by letter.
DIRECTION_LETTERS = tuple(_DIRECTIONS)
Thrust = number(0.0, 1.0e7, low_open=True)


class ThrusterTable(BaseModel):
    """``[[module.thruster]]``: a fixed thruster on a module."""

    model_config = _config("thruster")
    name: Name = key(Name, "-", "thruster name, unique in the vehicle", ...)
    x: number(-100.0, 100.0) = key(
        number(-100.0, 100.0), "m", "point of action along the module, in [0, length]", ...
    )
    y: number(-100.0, 100.0) = key(number(-100.0, 100.0), "m", "point of action, y", 0.0)
    z: number(-100.0, 100.0) = key(number(-100.0, 100.0), "m", "point of action, z", 0.0)
    direction: Literal[DIRECTION_LETTERS] | Direction = key(
        Literal[DIRECTION_LETTERS] | Direction,
        "-",
        "direction of positive thrust: x, y, z, -x, -y, -z or a nonzero [dx, dy, dz]",
        ...,
    )
    max_thrust: Thrust | None = key(
        Thrust, "N", "thrust magnitude limit (default: the top-level max_thrust)"
    )


class ModuleTable(BaseModel):
    """``[[module]]``: one cylindrical module (one URDF link), tail first."""

    model_config = _config("module")
    name: Name = key(Name, "-", "link name, unique", ...)
    length: Length = key(Length, "m", "module length L", ...)
    mass: number(0.0, 1.0e7, low_open=True) | None = key(
        number(0.0, 1.0e7, low_open=True), "kg", "module mass (or density)"
    )
    density: number(0.0, 1.0e5, low_open=True) | None = key(
        number(0.0, 1.0e5, low_open=True), "kg/m^3", "density of a solid cylinder (or mass)"
    )
    radius: number(0.0, 10.0, low_open=True) | None = key(
        number(0.0, 10.0, low_open=True), "m", "cylinder radius (default: the top-level radius)"
    )
    cg_offset: Offset = key(
        Offset, "m", "centre of gravity minus the module centre (L/2, 0, 0)", [0.0, 0.0, 0.0]
    )
    cb_offset: Offset = key(
        Offset, "m", "centre of buoyancy minus the module centre (L/2, 0, 0)", [0.0, 0.0, 0.0]
    )
    volume: number(0.0, 1.0e4, low_open=True) | None = key(
        number(0.0, 1.0e4, low_open=True),
        "m^3",
        "displaced volume (default mass / fluid_density: neutrally buoyant)",
    )
    joint: Literal["x", "y", "z"] | None = key(
        Literal["x", "y", "z"],
        "-",
        "axis of the revolute joint at the module's front; every module but the head",
    )
    thruster: list[ThrusterTable] = key(
        list[ThrusterTable], "-", "thrusters on the module", [], max_length=1000
    )


class VehicleSpecFile(BaseModel):
    """A vehicle spec: modules tail to head (``aiauv build``)."""

    model_config = _config("vehicle spec")
    name: Name = key(Name, "-", "robot name", ...)
    radius: number(0.0, 10.0, low_open=True) | None = key(
        number(0.0, 10.0, low_open=True), "m", "default radius of the modules"
    )
    fluid_density: number(0.0, 1.0e5, low_open=True) = key(
        number(0.0, 1.0e5, low_open=True), "kg/m^3", "water density rho", DEFAULT_FLUID_DENSITY
    )
    gravity: number(0.0, 100.0) = key(
        number(0.0, 100.0), "m/s^2", "gravitational acceleration g", DEFAULT_GRAVITY
    )
    joint_limit_deg: number(0.0, 180.0, low_open=True) = key(
        number(0.0, 180.0, low_open=True), "deg", "symmetric joint limit", DEFAULT_JOINT_LIMIT_DEG
    )
    joint_effort: number(0.0, 1.0e9, low_open=True) = key(
        number(0.0, 1.0e9, low_open=True), "N m", "URDF joint effort limit", DEFAULT_JOINT_EFFORT
    )
    joint_velocity: number(0.0, 1.0e6, low_open=True) = key(
        number(0.0, 1.0e6, low_open=True),
        "rad/s",
        "URDF joint velocity limit",
        DEFAULT_JOINT_VELOCITY,
    )
    max_thrust: Thrust = key(
        Thrust, "N", "default thrust limit of the thrusters", DEFAULT_MAX_THRUST
    )
    module: list[ModuleTable] = key(
        list[ModuleTable],
        "-",
        "the modules, tail first",
        ...,
        min_length=2,
        max_length=MAX_LINKS - 1,  # plus the end-effector link
    )


def markdown_keys() -> str:
    """The keys of a vehicle spec as a Markdown table (for the documentation site)."""
    lines = ["| key | unit | meaning |", "|---|---|---|"]
    for prefix, model in (
        ("", VehicleSpecFile),
        ("module.", ModuleTable),
        ("module.thruster.", ThrusterTable),
    ):
        for name, info in model.model_fields.items():
            unit = (info.json_schema_extra or {}).get("unit", "-")
            text = (info.description or "").replace("|", "/")
            lines.append(f"| `{prefix}{name}` | {unit} | {text} |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------------
# JSON Schema


class _Generator(GenerateJsonSchema):
    """pydantic's JSON Schema, with optional keys shown as their type (TOML has no null)."""

    def nullable_schema(self, schema):
        return self.generate_inner(schema["schema"])

    def default_schema(self, schema):
        out = super().default_schema(schema)
        if out.get("default", 0) is None:
            del out["default"]
        return out


def json_schema(model: type[BaseModel]) -> dict:
    """The JSON Schema (draft 2020-12) of a file model."""
    out = model.model_json_schema(schema_generator=_Generator)
    return {"$schema": DIALECT, **out}


# --------------------------------------------------------------------------------------------------
# Errors: one line naming the key path and what is expected


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _resolve(root: dict, node: dict) -> dict:
    while "$ref" in node:
        node = root["$defs"][node["$ref"].rsplit("/", 1)[1]]
    return node


def _variants(root: dict, node: dict) -> list[dict] | None:
    options = node.get("anyOf") or node.get("oneOf")
    if options is None:
        return None
    return [_resolve(root, v) for v in options if v.get("type") != "null"]


def _tag(node: dict) -> str | None:
    """The ``type`` of a table whose ``type`` key selects it (path and current tables)."""
    const = node.get("properties", {}).get("type", {}).get("const")
    return const if isinstance(const, str) else None


def describe(root: dict, node: dict) -> str:
    """What a JSON Schema node accepts, in words (``a number in [0, 10]``)."""
    node = _resolve(root, node)
    variants = _variants(root, node)
    if variants is not None:
        words = list(dict.fromkeys(describe(root, v) for v in variants))
        return " or ".join(words)
    if "const" in node:
        return repr(node["const"])
    if "enum" in node:
        return "one of " + ", ".join(str(v) for v in node["enum"])
    kind = node.get("type")
    if kind in ("number", "integer"):
        low = node.get("exclusiveMinimum", node.get("minimum"))
        high = node.get("exclusiveMaximum", node.get("maximum"))
        noun = "a number" if kind == "number" else "a whole number"
        if low is None and high is None:
            return noun
        bounds = Bounds(
            -math.inf if low is None else low,
            math.inf if high is None else high,
            "exclusiveMinimum" in node,
            "exclusiveMaximum" in node,
        )
        return f"{noun} in {bounds.text()}"
    if kind == "boolean":
        return "true or false"
    if kind == "string":
        if node.get("pattern") == NAME_PATTERN:
            return "a name of letters, digits, '_', '-', '.' (not starting with a digit)"
        return "a non-empty string" if node.get("minLength") else "a string"
    if kind == "array":
        low, high = node.get("minItems"), node.get("maxItems")
        item = describe(root, node.get("items", {})) if "items" in node else "a value"
        for one, many in _PLURALS:
            if item.startswith(one):
                item = many + item[len(one) :]
                break
        if item.startswith(("numbers in", "whole numbers in")):
            item = item.replace(" in ", ", each in ", 1)
        if low is not None and low == high:
            return f"a list of {low} {item}"
        if low is not None and high is not None:
            return f"a list of {low} to {high} {item}"
        if low == 1:
            return f"a non-empty list of {item}"
        if low:
            return f"a list of at least {low} {item}"
        return f"a list of {item}"
    if kind == "object":
        required = node.get("required", [])
        if len(node.get("properties", {})) == 1 and required:
            inner = describe(root, node["properties"][required[0]])
            return f"a table {{ {required[0]} = {inner} }}"
        return "a table"
    return "a value"


_PLURALS = (
    ("a list of", "lists of"),
    ("a number", "numbers"),
    ("a whole number", "whole numbers"),
    ("a table", "tables"),
    ("a string", "strings"),
    ("a name", "names"),
    ("a non-empty string", "non-empty strings"),
    ("a value", "values"),
    ("one of", "values, each one of"),
)


@dataclass
class _Place:
    key: str  # the key path as the file writes it
    node: dict | None  # schema where the walk stopped (None: a key the schema does not have)
    parent: dict | None  # the table schema holding the last key
    value: Any  # the input there
    complete: bool  # every part of the location walked


def _walk(root: dict, loc: tuple, data: Any) -> _Place:
    node: dict | None = root
    parent: dict | None = None
    key, value, index = "", data, 0
    while index < len(loc):
        part = loc[index]
        node = _resolve(root, node)
        variants = _variants(root, node)
        if variants is not None:
            if len(variants) == 1:
                node = variants[0]
                continue
            match = next((v for v in variants if v.get("title") == part), None)
            if match is None:  # a label of an untagged union: the value matched no member
                return _Place(key, node, parent, value, False)
            node = match
            if _tag(match) == part:
                key += f".{part}"
            index += 1
            continue
        if isinstance(part, int):
            item = value[part] if isinstance(value, list) and part < len(value) else None
            name = item.get("name") if isinstance(item, Mapping) else None
            named = isinstance(name, str) and re.fullmatch(NAME_PATTERN, name)
            key += f" '{name}'" if named else f"[{part}]"
            prefix = node.get("prefixItems")
            node = prefix[part] if prefix and part < len(prefix) else node.get("items", {})
            value = item
        else:
            parent = node
            key = f"{key}.{part}" if key else str(part)
            properties = node.get("properties", {})
            if part in properties:
                node = properties[part]
            elif isinstance(node.get("additionalProperties"), dict):
                node = node["additionalProperties"]
            else:
                return _Place(key, None, parent, None, index == len(loc) - 1)
            value = value.get(part) if isinstance(value, Mapping) else None
        index += 1
    return _Place(key, node, parent, value, True)


def problem_line(problem: Mapping, root: dict, data: Any, what: str) -> str:
    """One pydantic error (an item of ``ValidationError.errors()``) as one line."""
    kind = problem["type"]
    place = _walk(root, tuple(problem["loc"]), data)
    where = place.key or what
    if kind == "extra_forbidden":
        known = list((place.parent or {}).get("properties", {}))
        if len(known) <= 30:
            return f"{where}: unknown key (expected {', '.join(known)})"
        kind = what.split()[0]
        return f"{where}: unknown key ({len(known)} keys known: `aiauv schema {kind}` lists them)"
    if kind == "missing":
        return f"{where}: missing"
    if kind in ("value_error", "assertion_error"):
        message = str(problem.get("ctx", {}).get("error", problem["msg"]))
        return f"{place.key}: {message}" if place.key else message
    node = place.node or {}
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tags = [_tag(v) for v in _variants(root, _resolve(root, node)) or []]
        if tags and all(tags):
            got = problem.get("ctx", {}).get("tag")
            shown = "missing" if got is None else f"got {_shown(got)}"
            return f"{where}.type: expected one of {', '.join(tags)}, {shown}"
    value = place.value if not place.complete else problem.get("input")
    if kind in ("too_short", "too_long") and place.complete and isinstance(value, list):
        got = f"{len(value)} {'entry' if len(value) == 1 else 'entries'}"
    else:
        got = _shown(value)
    note = ""
    if isinstance(value, bool) and "number" in describe(root, node):
        note = " (a bool is not a number)"
    return f"{where}: expected {describe(root, node)}{note}, got {got}"


def one_line(error: ValidationError, root: dict, data: Any, what: str) -> str:
    """The first problem of a validation error as one line (and how many more there are)."""
    problems = error.errors(include_url=False)
    problems.sort(key=lambda p: p["type"] != "extra_forbidden")  # a misspelt key first
    lines = list(dict.fromkeys(problem_line(p, root, data, what) for p in problems))
    more = len(lines) - 1
    suffix = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
    return " ".join((lines[0] + suffix).split())


@cache
def _schema_of(model: type[BaseModel]) -> str:
    return json.dumps(json_schema(model))


def validate(model: type[BaseModel], data: Any, error: type[Exception], what: str) -> BaseModel:
    """``model.model_validate(data)``, a failure raised as ``error`` with one line.

    Args:
        model: A file model (:class:`ScenarioFile`, :class:`VehicleSpecFile`, a sweep model).
        data: The parsed file (nested tables).
        error: The project's error type to raise.
        what: What the file is, for a problem at its top level (``scenario``).
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        root = json.loads(_schema_of(model))
        raise error(one_line(exc, root, data, what)) from None


def given(table: BaseModel | None) -> dict:
    """The keys a table gives (not ``None``), as plain Python values."""
    if table is None:
        return {}
    return {
        name: getattr(table, name)
        for name in table.model_fields_set
        if getattr(table, name) is not None
    }


# --------------------------------------------------------------------------------------------------
# aiauv schema


def file_models() -> dict[str, type[BaseModel]]:
    """The models ``aiauv schema`` prints, by file kind."""
    from .sweep_spec import sweep_file_model

    return {"scenario": ScenarioFile, "sweep": sweep_file_model(), "vehicle": VehicleSpecFile}


def add_schema_parser(subparsers) -> None:
    """Register ``aiauv schema scenario|sweep|vehicle`` on ``add_subparsers()``."""
    parser = subparsers.add_parser(
        "schema",
        help="print the JSON Schema of scenario files, sweep specs or vehicle specs",
        description="Print the JSON Schema (draft 2020-12) of a file format, for editors that "
        "complete and check TOML files against a schema (e.g. Taplo / Even Better TOML).",
    )
    parser.add_argument("kind", choices=("scenario", "sweep", "vehicle"), help="file format")
    parser.set_defaults(handler=_run_schema)


def _run_schema(args) -> int:
    print(json.dumps(json_schema(file_models()[args.kind]), indent=2))
    return 0
