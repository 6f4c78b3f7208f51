"""The parameters of a scenario, named once for scenario files and sweep specs.

:data:`SCHEMA` lists every key a scenario file (:mod:`aiauv_pin.scenario_file`) may hold, by its
dotted name (``duration``, ``start.position``, ``path.radius``, ``controller.k_d``), with its kind,
unit and meaning. The path keys are generated from the path classes of
:data:`control.paths.PATH_TYPES`, the current keys from :data:`hydro.currents.CURRENT_KEYS` and the
controller keys from :class:`control.path_following.PathFollowingGains`, so a new path type, current
type or gain appears here (and in the documentation tables) by itself; only its unit and meaning
are written here (an undocumented key stops the import).

Sweep specs (:mod:`aiauv_pin.sweep_spec`) use the same names: a scalar key is a sweep parameter as
it is (``path.radius``), a vector key either whole (``start.position = [x, y, z]``) or by component
(``start.position.y``; ``controller.k_e`` has components ``y`` and ``z``). The older sweep names
(``initial_offset.y``, ``initial_surge``, ``current.x``, ``k_e.y``, ``k_d``, ...) stay valid as
:data:`ALIASES` of these.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

from control.path_following import CURRENT_COMPENSATION_OPTIONS, PathFollowingGains
from control.paths import PATH_TYPES
from control.reduced_attitude import FEEDFORWARD_OPTIONS
from hydro.currents import CURRENT_KEYS

from .lagged import ADDED_MASS_SCHEMES
from .scenario import CASES, CONTROLLERS

#: Integrators of :func:`aiauv_pin.simulate`.
METHODS = ("rk4", "euler", "midpoint")
#: Components of a vector in world axes.
XYZ = ("x", "y", "z")


class Parameter(NamedTuple):
    """One key of a scenario file.

    Attributes:
        name: Dotted name: ``key`` at the top level, ``table.key`` in a table.
        kind: ``"number"``, ``"bool"``, ``"file"``, ``"points"`` (a list of ``[x, y, z]``),
            ``("choice", options)`` or ``("vector", components)``.
        unit: SI unit of a number or of each component (``"-"``: none).
        meaning: What it is.
        applies_to: Path or current types the key belongs to (empty: always).
        sweepable: Whether a sweep spec may set it (the path and current ``type`` and the waypoint
            list come from the base scenario; outputs do not change a run's results).
    """

    name: str
    kind: Any
    unit: str
    meaning: str
    applies_to: tuple[str, ...] = ()
    sweepable: bool = True

    @property
    def components(self) -> tuple[str, ...]:
        """Names of the components of a vector (``start.position.x``, ...); ``()`` otherwise."""
        if isinstance(self.kind, tuple) and self.kind[0] == "vector":
            return tuple(f"{self.name}.{c}" for c in self.kind[1])
        return ()


def _vector(components=XYZ) -> tuple:
    return ("vector", components)


_RUN = (
    Parameter("case", ("choice", CASES), "-", "paper case: the bundled vehicle and its k_d"),
    Parameter(
        "vehicle",
        "file",
        "-",
        "URDF of the vehicle, relative to the file naming it (default: the bundled URDF of case)",
    ),
    Parameter("duration", "number", "s", "simulated time"),
    Parameter("dt", "number", "s", "integration step"),
    Parameter("method", ("choice", METHODS), "-", "integrator"),
    Parameter(
        "control_period",
        "number",
        "s",
        "sampling period of the guidance, base-angle and surge loops, a whole multiple of dt "
        "(default: every step)",
    ),
    Parameter(
        "continuous_joints",
        "bool",
        "-",
        "joint PD (eq. 24) as a continuous servo (true) or sampled with the controller (false)",
    ),
    Parameter(
        "start.position",
        _vector(),
        "m",
        "end-effector start, world axes; the vehicle straight (default 0, 2, 2)",
    ),
    Parameter(
        "start.heading",
        _vector(),
        "-",
        "direction the vehicle points at the start (default: the path's tangent there)",
    ),
    Parameter("start.surge", "number", "m/s", "initial forward speed"),
    Parameter(
        "added_mass",
        ("choice", ADDED_MASS_SCHEMES),
        "-",
        "exact (in the mass matrix) or lagged (UUV Simulator's and gz-sim's scheme, from the "
        "previous steps' filtered acceleration; Python controller)",
        sweepable=False,
    ),
    Parameter(
        "lagged_filter",
        "number",
        "-",
        "filter coefficient alpha of the lagged scheme, in (0, 1]: 0.3 UUV Simulator, 1 gz-sim",
        sweepable=False,
    ),
)

#: Unit and meaning of each key of the path classes (``type`` is added by :func:`_path_keys`).
_PATH_KEYS = {
    "point": ("vector", "m", "a point of the line (s = 0 there)"),
    "direction": ("vector", "-", "direction of the line (normalised)"),
    "centre": ("vector", "m", "a point of the helix axis"),
    "axis": ("vector", "-", "helix axis (normalised; pitch > 0 turns right-handed about it)"),
    "radius": ("number", "m", "helix radius"),
    "pitch": ("number", "m/turn", "advance along the axis per turn (0: a circle)"),
    "start_angle": ("number", "rad", "angle of the point s = 0 about the axis"),
    "points": ("points", "m", "waypoints [[x, y, z], ...], at least 2"),
    "corner_radius": ("number", "m", "radius of the arcs rounding the corners"),
}

#: Unit and meaning of each key of the current tables (``type`` is added by :func:`_current_keys`).
_CURRENT_KEYS = {
    "velocity": (
        "vector",
        "m/s",
        "water velocity, world axes (the mean for tidal, at z_0 for shear)",
    ),
    "amplitude": ("vector", "m/s", "amplitude A of V(t) = V_0 + A sin(2 pi t / T + phi)"),
    "period": ("number", "s", "period T of the tidal oscillation"),
    "phase": ("number", "rad", "phase phi of the tidal oscillation"),
    "gradient": ("vector", "1/s", "shear G of V(z) = V_0 + G (z - z_0)"),
    "reference_z": ("number", "m", "depth z_0 where the shear current is V_0"),
}

#: Unit and meaning of each gain of :class:`control.path_following.PathFollowingGains`.
_GAIN_KEYS = {
    "u_d": ("number", "m/s", "desired surge speed (eq. 21, 25)"),
    "k_e": ("k_e", "1/s", "cross-track gain (eq. 21), a number or [k_y, k_z]; default u_d / 10"),
    "alpha": ("number", "-", "joint-reference shape parameter (eq. 22)"),
    "k_p": ("number", "-", "pointing-error gain (eq. 23)"),
    "k_d": ("number", "s", "angular-velocity-error gain (eq. 23); default 19 or 12 by case"),
    "k_qp": ("number", "N m/rad", "joint proportional gain (eq. 24)"),
    "k_qd": ("number", "N m s/rad", "joint derivative gain (eq. 24)"),
    "k_1p": ("number", "N s/m", "surge proportional gain (eq. 25)"),
    "k_1i": ("number", "N/m", "surge integral gain (eq. 25)"),
    "q_max": ("number", "rad", "saturation of the base angles (eq. 22)"),
    "feedforward": ("feedforward", "-", "feedforward of eq. (23): exact or as printed"),
    "turn_feedforward": (
        "bool",
        "-",
        "beyond the paper: feed the reference turn rate (path curvature) forward through the "
        "identified turn dynamics",
    ),
    "turn_curvature_gain": (
        "number",
        "1/(m rad)",
        "turn model: steady path curvature per radian of base angle (identified)",
    ),
    "turn_time_constant": (
        "number",
        "s",
        "turn model: time constant of the turn rate (identified)",
    ),
    "current_compensation": (
        "current_compensation",
        "-",
        "none (the paper's LOS) or integral_los (integral LOS against currents)",
    ),
    "los_integral_gain": ("number", "-", "integral gain sigma of the integral LOS"),
    "hydrostatic_compensation": (
        "bool",
        "-",
        "beyond the paper: base angles balance the vehicle's restoring moment",
    ),
    "turn_moment_gain": (
        "number",
        "N m/rad",
        "effective hydrodynamic moment per radian of base angle (calibrated)",
    ),
}


def _kind(tag: str):
    if tag == "vector":
        return _vector()
    if tag == "k_e":
        return _vector(("y", "z"))
    if tag == "feedforward":
        return ("choice", FEEDFORWARD_OPTIONS)
    if tag == "current_compensation":
        return ("choice", CURRENT_COMPENSATION_OPTIONS)
    return tag


def _path_keys() -> tuple[Parameter, ...]:
    out = [Parameter("path.type", ("choice", tuple(PATH_TYPES)), "-", "path type", sweepable=False)]
    owners: dict[str, list[str]] = {}
    for type_name, cls in PATH_TYPES.items():
        for f in dataclasses.fields(cls):
            if f.init:
                owners.setdefault(f.name, []).append(type_name)
    for key, types in owners.items():
        tag, unit, meaning = _PATH_KEYS[key]  # KeyError: document a new path key above
        out.append(
            Parameter(f"path.{key}", _kind(tag), unit, meaning, tuple(types), tag != "points")
        )
    return tuple(out)


def _current_keys() -> tuple[Parameter, ...]:
    out = [
        Parameter(
            "current.type",
            ("choice", tuple(CURRENT_KEYS)),
            "-",
            "current type (default constant)",
            sweepable=False,
        )
    ]
    owners: dict[str, list[str]] = {}
    for type_name, keys in CURRENT_KEYS.items():
        for key in keys:
            if key != "type":
                owners.setdefault(key, []).append(type_name)
    for key, types in owners.items():
        tag, unit, meaning = _CURRENT_KEYS[key]  # KeyError: document a new current key above
        applies = () if len(types) == len(CURRENT_KEYS) else tuple(types)
        out.append(Parameter(f"current.{key}", _kind(tag), unit, meaning, applies))
    return tuple(out)


def _controller_keys() -> tuple[Parameter, ...]:
    out = [
        Parameter(
            "controller.type",
            ("choice", CONTROLLERS),
            "-",
            "paper (path following) or none (passive: thrusters and joints idle)",
        )
    ]
    for f in dataclasses.fields(PathFollowingGains):
        tag, unit, meaning = _GAIN_KEYS[f.name]  # KeyError: document a new gain above
        out.append(Parameter(f"controller.{f.name}", _kind(tag), unit, meaning))
    return tuple(out)


#: Every key of a scenario file, in the order of the documentation.
SCHEMA: dict[str, Parameter] = {
    p.name: p
    for p in (
        *_RUN,
        *_path_keys(),
        *_current_keys(),
        *_controller_keys(),
        Parameter(
            "output.csv_period", "number", "s", "time between rows of timeseries.csv", (), False
        ),
    )
}

#: Keys of a scenario file's top level.
TOP_LEVEL: tuple[str, ...] = tuple(name for name in SCHEMA if "." not in name)
#: Tables of a scenario file and their keys (``None``: checked by the path or current reader).
TABLES: dict[str, tuple[str, ...] | None] = {
    "start": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("start.")),
    "path": None,
    "current": None,
    "controller": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("controller.")),
    "output": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("output.")),
}

#: Older sweep-spec names and the scenario names they stand for (a vector alias: its components).
ALIASES: dict[str, str | tuple[str, ...]] = {
    "initial_offset": ("start.position.y", "start.position.z"),
    "initial_offset.y": "start.position.y",
    "initial_offset.z": "start.position.z",
    "initial_surge": "start.surge",
    "current.x": "current.velocity.x",
    "current.y": "current.velocity.y",
    "current.z": "current.velocity.z",
    "k_e": ("controller.k_e.y", "controller.k_e.z"),
    "k_e.y": "controller.k_e.y",
    "k_e.z": "controller.k_e.z",
    **{
        f.name: f"controller.{f.name}"
        for f in dataclasses.fields(PathFollowingGains)
        if f.name != "k_e"
    },
}
ALIASES["current"] = ("current.velocity.x", "current.velocity.y", "current.velocity.z")


def scalar_parameters() -> dict[str, tuple[Parameter, str | None]]:
    """Every scalar a sweep may set, by name: its key and the component (``None`` for a scalar)."""
    out: dict[str, tuple[Parameter, str | None]] = {}
    for parameter in SCHEMA.values():
        if not parameter.sweepable:
            continue
        if parameter.components:
            for component in parameter.components:
                out[component] = (parameter, component.rsplit(".", 1)[1])
        else:
            out[parameter.name] = (parameter, None)
    return out


def describe_kind(parameter: Parameter) -> str:
    """The kind of a key as the documentation prints it."""
    kind = parameter.kind
    if isinstance(kind, tuple) and kind[0] == "choice":
        return "one of " + ", ".join(f"`{option}`" for option in kind[1])
    if isinstance(kind, tuple):
        return f"vector ({', '.join(kind[1])})"
    return {"file": "file name", "bool": "true/false", "points": "list of [x, y, z]"}.get(
        kind, kind
    )


def markdown_table() -> str:
    """The scenario keys as a Markdown table (for the documentation site)."""
    lines = ["| key | kind | unit | meaning |", "|---|---|---|---|"]
    for p in SCHEMA.values():
        meaning = p.meaning + (f" ({', '.join(p.applies_to)})" if p.applies_to else "")
        lines.append(
            f"| `{p.name}` | {describe_kind(p)} | {p.unit} | {meaning.replace('|', '/')} |"
        )
    return "\n".join(lines) + "\n"
