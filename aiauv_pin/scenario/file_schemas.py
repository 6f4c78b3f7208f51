"""The schema of scenario files (pydantic v2, strict) and the ``aiauv schema`` command.

Every key of a scenario file (:class:`ScenarioFile`) is declared once here with its type, its
plausible range, its unit in brackets and its meaning (the machinery:
:mod:`aiauv_pin._internal.schema_validation`). The ranges are plausibility bounds: a value beyond them would
make a run diverge or overflow (a current of 1e6 m/s, a tidal period of 1e-300 s, ``k_d =
1e308``), not a physical limit of the method.

Sweep specs (:mod:`aiauv_pin.scenario.sweep_spec`) name the keys of :class:`ScenarioFile`; their schema is
generated from it (:func:`aiauv_pin.scenario.sweep_spec.sweep_file_model`). Vehicle specs have theirs in
:mod:`aiauv_pin.builders.vehicle_spec_schema`. The models only check; the reader
(:func:`aiauv_pin.scenario.toml_file.scenario_from_mapping`) builds the data classes the rest of the
code uses.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Literal, Union

from pydantic import BaseModel, Discriminator, Field, Tag

from aiauv_control.laws.gait_laws import DEPTH_MODES, GAIT_KINDS
from aiauv_control.path_following import CURRENT_COMPENSATION_OPTIONS, PathFollowingGains
from aiauv_control.reduced_attitude import FEEDFORWARD_OPTIONS
from aiauv_hydro.waves.sea_state import KINDS as SEA_KINDS
from aiauv_hydro.waves.sea_state import MAX_COMPONENTS, SPREADINGS
from aiauv_pin._internal.schema_validation import Direction, key, number, strict_config, vector
from aiauv_pin.controllers.gait_controller import THRUST_MODES
from aiauv_pin.dynamics.lagged_added_mass import ADDED_MASS_SCHEMES
from aiauv_pin.scenario.definition import CASES, CONTROLLERS

#: Integrators of :func:`aiauv_pin.simulate`.
METHODS = ("rk4", "euler", "midpoint")

# Plausibility ranges (documented in docs/source/scenario.md through SCHEMA's table)

#: Largest distance from the origin of a position [m].
MAX_POSITION = 1.0e5
#: Largest water or vehicle speed [m/s] (ten times a strong tidal current).
MAX_SPEED = 10.0
#: Largest simulated duration [s] (about 28 hours).
MAX_DURATION = 1.0e5

Position = vector(-MAX_POSITION, MAX_POSITION)
Speed3 = vector(-MAX_SPEED, MAX_SPEED)
Distance = number(-MAX_POSITION, MAX_POSITION)
Size = number(1.0e-3, MAX_POSITION)
Angle = number(-1.0e3, 1.0e3)
ZERO = [0.0, 0.0, 0.0]


class StartTable(BaseModel):
    """``[start]``: where and how the vehicle starts (straight, at rest but for ``surge``)."""

    model_config = strict_config("start")
    position: key(
        Position, "m", "end-effector start, world axes; the vehicle straight (default 0, 2, 2)"
    )
    heading: key(
        Direction, "-", "direction the vehicle points at the start (default: the path's tangent)"
    )
    surge: key(number(-MAX_SPEED, MAX_SPEED), "m/s", "initial forward speed")


def _path_type(name: str, default=...):
    return key(Literal[name], "-", "path type", default)


class LineTable(BaseModel):
    """``[path] type = "line"``: :class:`aiauv_control.paths.LinePath`."""

    model_config = strict_config("line")
    type: _path_type("line", "line")
    point: key(Position, "m", "a point of the line (s = 0 there)", ...)
    direction: key(Direction, "-", "direction of the line (normalised; nonzero)", ...)


class HelixTable(BaseModel):
    """``[path] type = "helix"``: :class:`aiauv_control.paths.HelixPath`."""

    model_config = strict_config("helix")
    type: _path_type("helix")
    centre: key(Position, "m", "a point of the helix axis", ...)
    axis: key(Direction, "-", "helix axis (normalised; pitch > 0 turns right-handed about it)", ...)
    radius: key(Size, "m", "helix radius", ...)
    pitch: key(Distance, "m/turn", "advance along the axis per turn (0: a circle)", ...)
    start_angle: key(Angle, "rad", "angle of the point s = 0 about the axis", 0.0)


class WaypointsTable(BaseModel):
    """``[path] type = "waypoints"``: :class:`aiauv_control.paths.WaypointPath`."""

    model_config = strict_config("waypoints")
    type: _path_type("waypoints")
    points: key(
        Annotated[list[Position], Field(min_length=2, max_length=10_000)],
        "m",
        "waypoints [[x, y, z], ...], 2 to 10000",
        ...,
    )
    corner_radius: key(Size, "m", "radius of the arcs rounding the corners", 1.0)


def _tagged_union(tables: dict[str, type[BaseModel]], default: str | None):
    """The tables as one type, the member chosen by the ``type`` key (``default`` when absent)."""

    def tag(value) -> str | None:
        if not isinstance(value, Mapping):
            return None
        found = value.get("type", default)
        return found if isinstance(found, str) else None

    members = tuple(Annotated[model, Tag(name)] for name, model in tables.items())
    return Annotated[Union[members], Discriminator(tag)]  # noqa: UP007


#: The path tables by ``type`` (the same keys as the classes of :data:`aiauv_control.paths.PATH_TYPES`).
PATH_TABLES: dict[str, type[BaseModel]] = {
    "line": LineTable,
    "helix": HelixTable,
    "waypoints": WaypointsTable,
}


def _current_type(name: str, default=...):
    return key(Literal[name], "-", "current type", default)


def _unsteady():
    return key(
        bool,
        "-",
        "with the water's acceleration (Froude-Krylov force and the added mass's reaction); "
        "false: the quasi-steady model, for comparison",
        True,
    )


class ConstantCurrentTable(BaseModel):
    """``[current] type = "constant"`` (the default): uniform and steady."""

    model_config = strict_config("constant")
    type: _current_type("constant", "constant")
    velocity: key(Speed3, "m/s", "water velocity, world axes", ZERO)
    unsteady: _unsteady()


class TidalCurrentTable(BaseModel):
    """``[current] type = "tidal"``: ``V(t) = V_0 + A sin(2 pi t / T + phi)``."""

    model_config = strict_config("tidal")
    type: _current_type("tidal")
    velocity: key(Speed3, "m/s", "mean water velocity V_0, world axes", ZERO)
    amplitude: key(Speed3, "m/s", "amplitude A of the oscillation, world axes", ...)
    period: key(number(1.0, 1.0e7), "s", "period T of the oscillation (a tide: hours)", ...)
    phase: key(Angle, "rad", "phase phi", 0.0)
    unsteady: _unsteady()


class ShearCurrentTable(BaseModel):
    """``[current] type = "shear"``: ``V(z) = V_0 + G (z - z_0)``."""

    model_config = strict_config("shear")
    type: _current_type("shear")
    velocity: key(Speed3, "m/s", "water velocity V_0 at z_0, world axes", ZERO)
    gradient: key(vector(-1.0, 1.0), "1/s", "shear G, world axes", ...)
    reference_z: key(number(-1.0e4, 1.0e4), "m", "depth z_0 where the current is V_0", 0.0)
    unsteady: _unsteady()


#: The current tables by ``type`` (the keys of :data:`aiauv_hydro.currents.CURRENT_KEYS`).
CURRENT_TABLES: dict[str, type[BaseModel]] = {
    "constant": ConstantCurrentTable,
    "tidal": TidalCurrentTable,
    "shear": ShearCurrentTable,
}

_GAINS = PathFollowingGains()


def gain(high: float, unit: str, meaning: str, *, zero: bool = False):
    """An optional gain in ``(0, high]`` (``[0, high]`` if ``zero``)."""
    return key(number(0.0, high, low_open=not zero), unit, meaning)


CrossTrackGain = number(0.0, 100.0, low_open=True)
FiniteThrust = number(-1.0e9, 1.0e9)


class ControllerTable(BaseModel):
    """``[controller]``: the controller and the gains of
    :class:`aiauv_control.path_following.PathFollowingGains` (gains not given: the paper's for the case).
    """

    model_config = strict_config("controller")
    type: key(
        Literal[CONTROLLERS],
        "-",
        "paper (path following), none (passive: thrusters and joints idle), thruster_turning, "
        "gait (serpentine swimming, [gait]), station ([station]), velocity ([velocity]), "
        "intervention or transit_intervene ([intervention]), constant (constant thrusts, "
        "joints idle) or torpedo (a torpedo AUV steered by its fins, [torpedo])",
        "paper",
    )
    u_d: gain(MAX_SPEED, "m/s", f"desired surge speed (eq. 21, 25); default {_GAINS.u_d:g}")
    k_e: key(
        CrossTrackGain | Annotated[list[CrossTrackGain], Field(min_length=2, max_length=2)],
        "1/s",
        "cross-track gain (eq. 21), a number or [k_y, k_z]; default u_d / 10",
    )
    alpha: gain(100.0, "-", f"joint-reference shape parameter (eq. 22); default {_GAINS.alpha:g}")
    k_p: gain(1.0e3, "-", f"pointing-error gain (eq. 23); default {_GAINS.k_p:g}")
    k_d: gain(1.0e4, "s", "angular-velocity-error gain (eq. 23); default 19 or 12 by case")
    k_qp: gain(1.0e6, "N m/rad", f"joint proportional gain (eq. 24); default {_GAINS.k_qp:g}")
    k_qd: gain(
        1.0e6, "N m s/rad", f"joint derivative gain (eq. 24); default {_GAINS.k_qd:g}", zero=True
    )
    k_1p: gain(
        1.0e6, "N s/m", f"surge proportional gain (eq. 25); default {_GAINS.k_1p:g}", zero=True
    )
    k_1i: gain(1.0e6, "N/m", f"surge integral gain (eq. 25); default {_GAINS.k_1i:g}", zero=True)
    q_max: gain(
        math.pi, "rad", f"saturation of the base angles (eq. 22); default {_GAINS.q_max:.4g}"
    )
    feedforward: key(
        Literal[FEEDFORWARD_OPTIONS], "-", "feedforward of eq. (23): exact or as printed"
    )
    turn_feedforward: key(
        bool,
        "-",
        "beyond the paper: feed the reference turn rate (path curvature) forward through the "
        "identified turn dynamics",
    )
    turn_curvature_gain: gain(
        1.0e3, "1/(m rad)", "turn model: steady path curvature per radian of base angle"
    )
    turn_time_constant: gain(1.0e4, "s", "turn model: time constant of the turn rate", zero=True)
    current_compensation: key(
        Literal[CURRENT_COMPENSATION_OPTIONS],
        "-",
        "none (the paper's LOS) or integral_los (integral LOS against currents)",
    )
    los_integral_gain: gain(1.0e3, "-", "integral gain sigma of the integral LOS")
    hydrostatic_compensation: key(
        bool, "-", "beyond the paper: base angles balance the vehicle's restoring moment"
    )
    turn_moment_gain: gain(
        1.0e6, "N m/rad", "effective hydrodynamic moment per radian of base angle"
    )
    thrusts: key(
        Annotated[list[FiniteThrust], Field(min_length=1)],
        "N",
        'type = "constant": one thrust per thruster, in the vehicle\'s order (saturated to '
        "max_thrust)",
    )


class GaitTable(BaseModel):
    """``[gait]``: the serpentine gait of ``controller.type = "gait"``
    (:class:`aiauv_pin.controllers.gait_controller.Gait`; Kelasidi et al., IEEE T-RO 33(3), 2017).
    Joint servo gains are ``controller.k_qp``, ``controller.k_qd``; the combined mode's speed and
    surge gains ``controller.u_d``, ``k_1p``, ``k_1i``."""

    model_config = strict_config("gait")
    kind: key(
        Literal[tuple(GAIT_KINDS)],
        "-",
        "envelope g(i): lateral_undulation (1) or eel_like ((n - i) / (n + 1))",
    )
    amplitude: key(number(0.0, math.pi), "rad", "amplitude alpha of the joint references")
    omega: key(number(0.0, 100.0, low_open=True), "rad/s", "angular frequency of the gait (> 0)")
    delta: key(number(-2.0 * math.pi, 2.0 * math.pi), "rad", "phase offset between joints")
    k_theta: key(number(0.0, 100.0), "-", "heading gain: phi_0 = k_theta (theta - theta_ref)")
    max_offset: key(number(0.0, math.pi), "rad", "saturation of the gait offset phi_0")
    lookahead: key(Size, "m", "LOS lookahead distance Delta (default: twice the length)")
    integral_los: key(bool, "-", "integral LOS (against currents) instead of LOS")
    los_integral_gain: key(
        number(0.0, 1.0e3, low_open=True), "-", "integral gain sigma of the integral LOS"
    )
    thrust: key(
        Literal[THRUST_MODES],
        "-",
        "none (thrusters idle) or surge (combined: X thrusters hold controller.u_d)",
    )
    depth: key(
        Literal[tuple(DEPTH_MODES)],
        "-",
        "depth keeping: none, joints (pitch joints; controller.alpha, q_max) or thrusters (z)",
    )
    depth_gain: gain(100.0, "-", "pitch PD: base angle per rad of elevation error", zero=True)
    depth_damping: gain(100.0, "s", "pitch PD: derivative time", zero=True)
    depth_lookahead: key(Size, "m", "vertical LOS lookahead (default: the gait's lookahead)")
    depth_kp: gain(1.0e5, "N/m", "depth PI of the vertical thrusters: proportional", zero=True)
    depth_ki: gain(1.0e5, "N/(m s)", "depth PI of the vertical thrusters: integral", zero=True)


class TorpedoTable(BaseModel):
    """``[torpedo]``: a torpedo AUV's path following by its fins, ``controller.type = "torpedo"``
    (:class:`aiauv_pin.controllers.torpedo_controller.Torpedo`; docs/source/torpedo.md)."""

    model_config = strict_config("torpedo")
    speed: gain(MAX_SPEED, "m/s", "desired speed, held by the propeller's PI (default 2)")
    thrust: gain(1.0e5, "N", "constant thrust per propeller instead of the speed PI")
    speed_kp: gain(1.0e5, "N s/m", "speed PI: proportional", zero=True)
    speed_ki: gain(1.0e5, "N/m", "speed PI: integral", zero=True)
    lookahead: key(Size, "m", "LOS lookahead distance Delta")
    integral_los: key(bool, "-", "integral LOS (crab angles, currents) instead of LOS")
    los_integral_gain: key(
        number(0.0, 1.0e3, low_open=True), "-", "integral gain sigma of the integral LOS"
    )
    yaw_kp: gain(100.0, "rad/rad", "heading PID: rudder angle per heading error")
    yaw_kd: gain(100.0, "s", "heading PID: derivative", zero=True)
    yaw_ki: gain(100.0, "1/s", "heading PID: integral", zero=True)
    pitch_kp: gain(100.0, "rad/rad", "pitch PID: stern-plane angle per pitch error")
    pitch_kd: gain(100.0, "s", "pitch PID: derivative", zero=True)
    pitch_ki: gain(100.0, "1/s", "pitch PID: integral", zero=True)
    max_deflection: key(
        number(0.0, math.pi, low_open=True), "rad", "rudder/stern saturation (default: fin limit)"
    )


AxisName = Literal["surge", "sway", "heave", "roll", "pitch", "yaw"]
FrameName = Annotated[str, Field(min_length=1, max_length=200)]


class StationTable(BaseModel):
    """``[station]``: station keeping of ``controller.type = "station"``
    (:class:`aiauv_pin.wholebody.station_controller.StationKeeping`)."""

    model_config = strict_config("station")
    frame: key(FrameName, "-", "frame held: a link or frame name (default: the base)")
    position: key(Position, "m", "target position of the frame, world axes (default: its start)")
    rpy: key(vector(-math.pi, math.pi), "rad", "target roll, pitch, yaw (zyx; default: its start)")
    omega: key(number(0.0, 100.0, low_open=True), "rad/s", "natural frequency of every axis")
    zeta: key(number(0.0, 10.0, low_open=True), "-", "damping ratio of every axis")
    integral_pole: key(number(0.0, 100.0), "1/s", "integral root -a (default omega / 4)")
    axes: key(list[AxisName], "-", "axes held (default all six); the others are left free")
    known_current: key(bool, "-", "the model is told of the scenario's current (default true)")


class VelocityTable(BaseModel):
    """``[velocity]``: velocity control of ``controller.type = "velocity"``
    (:class:`aiauv_pin.wholebody.velocity_controller.VelocityControl`)."""

    model_config = strict_config("velocity")
    frame: key(FrameName, "-", "frame controlled: a link or frame name (default: the base)")
    twist: key(
        vector(-MAX_SPEED, MAX_SPEED, 6),
        "m/s, rad/s",
        "commanded (u, v, w, p, q, r), frame axes",
        ...,
    )
    bandwidth: key(number(0.0, 100.0, low_open=True), "rad/s", "velocity-loop root -bandwidth")
    integral_pole: key(number(0.0, 100.0), "1/s", "integral root -a (default bandwidth / 4)")
    axes: key(list[AxisName], "-", "axes controlled (default all six); the others are left free")
    known_current: key(bool, "-", "the model is told of the scenario's current (default true)")


class WavesTable(BaseModel):
    """``[waves]``: linear waves (:class:`aiauv_hydro.waves.sea_state.Waves`), added to a constant
    ``[current]`` (docs/source/waves.md)."""

    model_config = strict_config("waves")
    type: key(
        Literal[SEA_KINDS],
        "-",
        "regular (Airy), fenton (stream function, raschii), jonswap or pierson_moskowitz",
        "regular",
    )
    height: key(
        number(0.0, 30.0), "m", "wave height H (regular) or significant height H_s (irregular)", ...
    )
    period: key(
        number(0.0, 100.0, low_open=True), "s", "period T (regular) or peak period T_p", ...
    )
    heading: key(
        Angle, "rad", "direction the waves travel to, from world x about z (pi: head seas on +x)"
    )
    depth: key(
        number(0.0, 1.2e4, low_open=True), "m", "water depth h below surface_z (default: deep)"
    )
    surface_z: key(Distance, "m", "world z of the still-water level (default 0)")
    phase: key(Angle, "rad", "phase of a regular wave (0: a crest at the origin at t = 0)")
    peak_enhancement: key(
        number(1.0, 7.0), "-", "JONSWAP gamma (default: DNV-RP-C205's rule from T_p / sqrt(H_s))"
    )
    spreading: key(Literal[SPREADINGS], "-", "none (long-crested), cos_n or cos_2s (short-crested)")
    spreading_exponent: key(
        number(0.0, 100.0, low_open=True), "-", "n of cos_n or s of cos_2s (default 2)"
    )
    components: key(
        number(1.0, MAX_COMPONENTS), "-", "number of components of an irregular sea (default 100)"
    )
    seed: key(number(0.0, 2.0**53), "-", "seed of the phases and directions (default 0)")
    order: key(number(1.0, 50.0), "-", "Fourier harmonics of a fenton wave (default 10)")


Axis = Literal["x", "y", "z", "rx", "ry", "rz"]


class InterventionTable(BaseModel):
    """``[intervention]``: hold the end-effector's pose with thrusters and joints
    (``controller.type = "intervention"`` or ``"transit_intervene"``;
    :class:`aiauv_pin.wholebody.intervention_transit.InterventionSettings`)."""

    model_config = strict_config("intervention")
    frame: key(
        Annotated[str, Field(min_length=1, max_length=200)], "-", "the frame held (end_effector)"
    )
    target_position: key(Position, "m", "target of the frame, world (default: where it starts)")
    target_rpy: key(vector(-10.0, 10.0), "rad", "target roll, pitch, yaw, world axes")
    move_time: key(number(0.0, MAX_DURATION), "s", "minimum-jerk move to the target (0: a step)")
    posture: key(
        Annotated[list[Angle], Field(min_length=1, max_length=1000)],
        "rad",
        "joint angles of the null-space posture (and the start of an intervention run)",
    )
    shared_joints: key(bool, "-", "joint motors share the task (false: joints locked)")
    axes: key(
        Annotated[list[Axis], Field(min_length=1, max_length=6)],
        "-",
        "task axes among x, y, z, rx, ry, rz (world; default all six)",
    )
    current_known: key(bool, "-", "the model knows the current (false: integral action)")
    thrust_limit: key(number(0.0, 1.0e6, low_open=True), "N", "largest thrust of each thruster")
    joint_torque_limit: key(
        number(0.0, 1.0e6, low_open=True), "N m", "largest torque of each joint motor"
    )
    stiffness: gain(1.0e4, "1/s^2", "pose error gain K_p")
    damping: gain(1.0e4, "1/s", "twist error gain K_d")
    integral: gain(1.0e4, "1/s^3", "pose error integral gain K_i", zero=True)
    integral_limit: gain(1.0e4, "m s", "anti-windup limit of the integral", zero=True)
    posture_stiffness: gain(1.0e4, "1/s^2", "posture joint PD stiffness", zero=True)
    posture_damping: gain(1.0e4, "1/s", "posture joint PD damping", zero=True)
    thrust_weight: gain(1.0e4, "1/N", "effort weight of each thruster")
    joint_weight: gain(1.0e4, "1/(N m)", "effort weight of each joint motor")
    posture_weight: gain(1.0e4, "s^2/rad", "weight of the posture task", zero=True)
    base_weight: gain(1.0e4, "s^2/m", "weight of the base damping task", zero=True)
    site: key(Position, "m", "work site of transit_intervene, world")
    switch_distance: key(Size, "m", "end-effector distance to the site that ends the transit")


class OutputTable(BaseModel):
    """``[output]``: what a run writes."""

    model_config = strict_config("output")
    csv_period: key(
        number(1.0e-6, MAX_DURATION), "s", "time between rows of timeseries.csv (<= duration)"
    )


class ScenarioFile(BaseModel):
    """A scenario file (every key optional; a key not given keeps the paper scenario's value)."""

    model_config = strict_config("scenario")
    case: key(Literal[CASES], "-", "paper case: the bundled vehicle and its k_d (default uniform)")
    vehicle: key(
        Annotated[str, Field(min_length=1, max_length=4096)],
        "-",
        "URDF or xacro of the vehicle, relative to the file naming it",
    )
    duration: key(number(0.0, MAX_DURATION, low_open=True), "s", "simulated time (default 300)")
    # a step of more than 10 s says nothing about the vehicle (it may still diverge, which a run
    # reports); the lower bound keeps duration / dt countable
    dt: key(number(1.0e-6, 10.0), "s", "integration step (<= duration; default 0.004)")
    method: key(Literal[METHODS], "-", "integrator (default euler)")
    control_period: key(
        number(1.0e-6, 100.0),
        "s",
        "sampling period of the guidance, base-angle and surge loops, a whole multiple of dt "
        "(default: every step)",
    )
    continuous_joints: key(
        bool, "-", "joint PD (eq. 24) as a continuous servo (true) or sampled with the controller"
    )
    added_mass: key(
        Literal[ADDED_MASS_SCHEMES],
        "-",
        "exact (in the mass matrix) or lagged (UUV Simulator's and gz-sim's scheme; Python "
        "controller)",
    )
    lagged_filter: key(
        number(0.0, 1.0, low_open=True),
        "-",
        "filter coefficient alpha of the lagged scheme: 0.3 UUV Simulator, 1 gz-sim",
    )
    fixed_base: key(
        bool,
        "-",
        "the vehicle's root link fixed to the world (default false; a massless 'world' root link "
        "fixes it anyway)",
    )
    package_path: key(
        Annotated[list[Annotated[str, Field(min_length=1, max_length=4096)]], Field(max_length=64)],
        "-",
        "folders searched first for ROS packages ($(find pkg), package://), relative to the file",
    )
    lenient: key(
        bool,
        "-",
        "repair what published vehicle files are known to trip, each repair a warning (default "
        "false)",
    )
    start: key(StartTable, "-", "the start")
    path: key(
        _tagged_union(PATH_TABLES, None), "-", "the path to follow (default: the world x-axis)"
    )
    current: key(
        _tagged_union(CURRENT_TABLES, "constant"), "-", "the water current (default: none)"
    )
    controller: key(ControllerTable, "-", "the controller and its gains")
    gait: key(GaitTable, "-", "the serpentine gait (controller.type = gait)")
    station: key(StationTable, "-", "station keeping (controller.type = station)")
    velocity: key(VelocityTable, "-", "velocity control (controller.type = velocity)")
    torpedo: key(TorpedoTable, "-", "a torpedo AUV's path following (controller.type = torpedo)")
    waves: key(WavesTable, "-", "linear waves on the current (default: none)")
    intervention: key(InterventionTable, "-", "the intervention (controller.type = intervention)")
    output: key(OutputTable, "-", "outputs")
