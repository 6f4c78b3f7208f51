"""The schema of vehicle specs (pydantic v2, strict): every key with its range, unit and meaning.

:class:`VehicleSpecFile` only checks; :func:`aiauv_pin.builders.vehicle_spec.spec_from_dict` builds the
data classes from it. The constants the data classes share with the schema (defaults, axis and
direction letters) are declared here, below :mod:`aiauv_pin.builders.vehicle_spec`, which imports them.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel

from aiauv_pin._internal.schema_validation import (
    Direction,
    Name,
    key,
    number,
    strict_config,
    vector,
)
from aiauv_pin.description.input_limits import MAX_LINKS

JOINT_AXES: dict[str, tuple[float, float, float]] = {
    "x": (1.0, 0.0, 0.0),
    "y": (0.0, 1.0, 0.0),
    "z": (0.0, 0.0, 1.0),
}
"""Unit joint axis in the parent link frame for each ``joint`` letter."""

#: Unit thruster directions by letter.
DIRECTIONS: dict[str, tuple[float, float, float]] = {
    **JOINT_AXES,
    "-x": (-1.0, 0.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "-z": (0.0, 0.0, -1.0),
}

DEFAULT_FLUID_DENSITY = 1000.0  # [kg/m^3]
DEFAULT_GRAVITY = 9.81  # [m/s^2]
DEFAULT_JOINT_LIMIT_DEG = 65.0  # [deg]
DEFAULT_JOINT_EFFORT = 1000.0  # [N m]
DEFAULT_JOINT_VELOCITY = 10.0  # [rad/s]
DEFAULT_MAX_THRUST = 50.0  # [N]

Offset = vector(-100.0, 100.0)
Coordinate = number(-100.0, 100.0)
Thrust = number(0.0, 1.0e7, low_open=True)
Radius = number(0.0, 10.0, low_open=True)
Density = number(0.0, 1.0e5, low_open=True)


class ThrusterTable(BaseModel):
    """``[[module.thruster]]``: a fixed thruster on a module."""

    model_config = strict_config("thruster")
    name: key(Name, "-", "thruster name, unique in the vehicle", ...)
    x: key(Coordinate, "m", "point of action along the module, in [0, length]", ...)
    y: key(Coordinate, "m", "point of action, y", 0.0)
    z: key(Coordinate, "m", "point of action, z", 0.0)
    direction: key(
        Literal[tuple(DIRECTIONS)] | Direction,
        "-",
        "direction of positive thrust: x, y, z, -x, -y, -z or a nonzero [dx, dy, dz]",
        ...,
    )
    max_thrust: key(Thrust, "N", "thrust magnitude limit (default: the top-level max_thrust)")


class ModuleTable(BaseModel):
    """``[[module]]``: one cylindrical module (one URDF link), tail first."""

    model_config = strict_config("module")
    name: key(Name, "-", "link name, unique", ...)
    length: key(number(0.0, 100.0, low_open=True), "m", "module length L", ...)
    mass: key(number(0.0, 1.0e7, low_open=True), "kg", "module mass (or density)")
    density: key(Density, "kg/m^3", "density of a solid cylinder (or mass)")
    radius: key(Radius, "m", "cylinder radius (default: the top-level radius)")
    cg_offset: key(
        Offset, "m", "centre of gravity minus the module centre (L/2, 0, 0)", [0.0, 0.0, 0.0]
    )
    cb_offset: key(
        Offset, "m", "centre of buoyancy minus the module centre (L/2, 0, 0)", [0.0, 0.0, 0.0]
    )
    volume: key(
        number(0.0, 1.0e4, low_open=True),
        "m^3",
        "displaced volume (default mass / fluid_density: neutrally buoyant)",
    )
    joint: key(
        Literal[tuple(JOINT_AXES)],
        "-",
        "axis of the revolute joint at the module's front; every module but the head",
    )
    thruster: key(list[ThrusterTable], "-", "thrusters on the module", [], max_length=1000)


class VehicleSpecFile(BaseModel):
    """A vehicle spec: modules tail to head (``aiauv build``)."""

    model_config = strict_config("vehicle spec")
    name: key(Name, "-", "robot name", ...)
    radius: key(Radius, "m", "default radius of the modules")
    fluid_density: key(Density, "kg/m^3", "water density rho", DEFAULT_FLUID_DENSITY)
    gravity: key(number(0.0, 100.0), "m/s^2", "gravitational acceleration g", DEFAULT_GRAVITY)
    joint_limit_deg: key(
        number(0.0, 180.0, low_open=True), "deg", "symmetric joint limit", DEFAULT_JOINT_LIMIT_DEG
    )
    joint_effort: key(
        number(0.0, 1.0e9, low_open=True), "N m", "URDF joint effort limit", DEFAULT_JOINT_EFFORT
    )
    joint_velocity: key(
        number(0.0, 1.0e6, low_open=True),
        "rad/s",
        "URDF joint velocity limit",
        DEFAULT_JOINT_VELOCITY,
    )
    max_thrust: key(Thrust, "N", "default thrust limit of the thrusters", DEFAULT_MAX_THRUST)
    module: key(
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
