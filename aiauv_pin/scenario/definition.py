"""Scenarios: a vehicle, a path, a start, a current and a controller, run for a duration.

:class:`Scenario` describes one run (scenario files build it: :mod:`aiauv_pin.scenario.toml_file`);
:func:`run_scenario` runs it and :func:`summary` computes its figures of merit. Its defaults are
the paper's scenario (Sec. 4): straight-path following from an offset start. Choices the paper
leaves open, documented here and in the README:

* the path is the world x-axis; the vehicle starts straight, at rest, parallel to the path, with its
  end-effector at ``(0, 2, 2)`` m (a few metres off in y and z, PAPER_DATA "Start");
* 300 s of simulated time (the lineage code's duration); the guidance, base-angle and surge loops
  are sampled every step (zero-order hold; ``control_period`` samples them more slowly, with states
  logged at the controller's rate) and the joint PD (eq. 24) runs as a continuous servo evaluated at
  every integrator stage (see :class:`aiauv_pin.controllers.paper_controller.VehiclePathFollowing`);
* semi-implicit Euler with ``dt = 0.004`` s (:mod:`aiauv_pin.scenario.defaults`), chosen by
  the rule of accuracy per cost with one condition of ours: the cheapest setting whose
  end-effector path stays within 2 mm
  of a converged reference (Richardson's extrapolation of RK4 at 0.5 and 1 ms) over the whole
  300 s run, and whose sampled attitude loop still converges with the paper's ``k_p, k_d`` doubled
  (a gain margin of 2, :data:`aiauv_pin.tools.run_benchmarks.MARGIN_TARGET`). It is 1.996 mm off on the
  uniform vehicle (the paper's scenario) and 2.0002 mm on the stabilised one (2.74 and 2.04 mm in
  a 0.1/0.1 m/s current), with a margin of 3 or more; RK4 at 0.01 s (the default before) is
  2.53-2.59 mm off. Euler at 0.004 s costs 0.83x RK4 at 0.01 s (``aiauv bench``): 2.5 times as
  many steps, each one evaluation and one controller sample against RK4's four evaluations.
  Holding the controller from the start of each step makes the error first order in ``dt`` for
  both. The midpoint method at 0.02 s is 0.21-0.36 mm off for 0.33x and would win on accuracy
  alone, but its loop oscillates at every sample with the paper's gains times 1.25 (uniform) or 2
  (stabilised): its stage, predicted with the previous output, halves the sampled loop's stable
  range (:mod:`aiauv_pin.simulation.step_stability`); it also rings at the start of the run and
  its joints' work is 63 % too large. Euler's joint servo is implicit, so a larger step only costs
  accuracy (5.0 mm at 0.01 s, 2 cm at 0.04 s). Measured by ``benchmarks/default_step.py``
  (``benchmarks/default_step.json``); ``aiauv bench --only accuracy-per-cost`` says whether the
  default is still the cheapest within 2 mm, with and without the margin;
* ``timeseries.csv`` holds one row every ``csv_period = 0.04`` s (every tenth step, 25 per second
  like the playback's frames); the summary's integrals and settling times use every step;
* the base-angle saturation ``q_max`` is :class:`aiauv_control.path_following.PathFollowingGains`' default.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import Any

import numpy as np

from aiauv_control.guidance import X_AXIS
from aiauv_control.path_following import PathFollowingGains
from aiauv_control.paths import LinePath, Path
from aiauv_hydro.currents import Current, as_current
from aiauv_hydro.laws.fluid_terms import UUV_SIMULATOR_FILTER
from aiauv_hydro.waves.sea_state import Waves
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.controllers.gait_controller import Gait, VehicleGait
from aiauv_pin.controllers.paper_controller import (
    END_EFFECTOR,
    VehiclePathFollowing,
    compiled_path_following_reason,
)
from aiauv_pin.controllers.torpedo_controller import Torpedo, VehicleTorpedo
from aiauv_pin.dynamics.lagged_added_mass import check_filter, check_scheme
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.scenario.defaults import DEFAULT_CSV_PERIOD, DEFAULT_DT, DEFAULT_METHOD
from aiauv_pin.simulation.energy import energy_summary, exact_column_sums
from aiauv_pin.simulation.fixed_step import Trajectory, simulate
from aiauv_pin.simulation.step_stability import warn_if_oscillating
from aiauv_pin.wholebody.intervention_transit import InterventionSettings, TransitThenIntervene

CASES = ("uniform", "stabilised")
#: Controllers a scenario can name: the paper's path following (turning with the body), none
#: (passive run), the thruster-turning baseline (:mod:`aiauv_pin.controllers.turning_controller`),
#: a serpentine gait (:mod:`aiauv_pin.controllers.gait_controller`), station keeping or velocity
#: control (:mod:`aiauv_pin.wholebody`), intervention (hold the end-effector's pose,
#: :mod:`aiauv_pin.wholebody.intervention_controller`), transit then intervention
#: (:mod:`aiauv_pin.wholebody.intervention_transit`), constant thrusts (an open-loop command,
#: :meth:`CompiledController.constant`), or a torpedo AUV's path following by its fins
#: (:mod:`aiauv_pin.controllers.torpedo_controller`).
CONTROLLERS = (
    "paper",
    "none",
    "thruster_turning",
    "gait",
    "station",
    "velocity",
    "intervention",
    "transit_intervene",
    "constant",
    "torpedo",
)
#: Controllers that follow no path (their runs have no path errors).
OPEN_LOOP_CONTROLLERS = ("none", "constant", "station", "velocity", "intervention")


@dataclass(frozen=True)
class Scenario:
    """Parameters of one run (defaults: the paper's scenario).

    Attributes:
        case: ``"uniform"`` or ``"stabilised"`` (selects the paper's ``k_D`` and the bundled
            vehicle when ``vehicle`` is not given).
        duration: Simulated time [s].
        dt: Integration step [s].
        initial_offset: End-effector start ``(p_y, p_z)`` [m] with ``p_x = 0``, used when
            ``start_position`` is not given.
        initial_surge: Initial forward speed of the straight vehicle [m/s].
        method: Integrator, ``"rk4"``, ``"euler"`` or ``"midpoint"`` (:func:`aiauv_pin.simulate`).
        current: Water velocity: a constant world velocity (3) [m/s] or a
            :class:`aiauv_hydro.currents.Current`.
        gains: Controller gains; ``None`` means the paper's for the case.
        continuous_joints: Joint PD as a continuous servo (True) or sampled with the controller.
        control_period: Sampling period of the guidance, base-angle and surge loops [s], a whole
            multiple of ``dt``; ``None`` samples them every step.
        csv_period: Time between rows of ``timeseries.csv`` [s], rounded to a whole number of
            logged samples (at least one); ``None`` writes every logged sample. The run is still
            logged at every sample and ``summary.json`` uses them all.
        path: The path to follow (:mod:`aiauv_control.paths`); ``None`` is the world x-axis.
        start_position: End-effector start in the world [m] (default ``(0, *initial_offset)``).
        heading: Direction the straight vehicle points at the start (default: the path's tangent
            at the point closest to the start).
        controller: ``"paper"`` (path following), ``"none"`` (passive), ``"thruster_turning"``
            (straight body steered by the tunnel thrusters, compiled backend only), ``"gait"``
            (a serpentine gait, :attr:`gait`, compiled backend only) or ``"torpedo"`` (a torpedo
            AUV steered by its fins, :attr:`torpedo`, compiled backend only).
        gait: The gait of ``controller = "gait"``
            (:class:`aiauv_pin.controllers.gait_controller.Gait`; ``None``: its defaults).
        intervention: The settings of ``controller = "intervention"`` or ``"transit_intervene"``
            (:class:`aiauv_pin.wholebody.intervention_transit.InterventionSettings`; ``None``:
            its defaults).
        thrusts: The thrusts [N] of ``controller = "constant"``, one per thruster in the vehicle's
            order (saturated to their ``max_thrust``).
        torpedo: The options of ``controller = "torpedo"``
            (:class:`aiauv_pin.controllers.torpedo_controller.Torpedo`; ``None``: its defaults).
        vehicle: URDF (or SDF, MJCF) file of the vehicle (``None``: the bundled vehicle of ``case``).
        fixed_base, lenient, package_path: Load options of the vehicle
            (:func:`aiauv_pin.load_vehicle`).
        added_mass: ``"exact"`` or ``"lagged"`` (UUV Simulator's and gz-sim's scheme,
            :mod:`aiauv_pin.dynamics.lagged_added_mass`; runs the Python controller, not the compiled loop).
        lagged_filter: The lagged scheme's filter coefficient in ``(0, 1]`` (0.3: UUV Simulator,
            1: gz-sim).
        wholebody: The ``[station]`` or ``[velocity]`` table of ``controller = "station"`` or
            ``"velocity"`` (:func:`aiauv_pin.wholebody.station_options.controller_from_options`).
        waves: Linear waves (:class:`aiauv_hydro.waves.sea_state.Waves`) on the current, which
            must then be constant: the two velocities add (:meth:`Current.waves`); ``None``: none.
    """

    case: str = "uniform"
    duration: float = 300.0
    dt: float = DEFAULT_DT
    initial_offset: tuple[float, float] = (2.0, 2.0)
    initial_surge: float = 0.0
    method: str = DEFAULT_METHOD
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gains: PathFollowingGains | None = None
    continuous_joints: bool = True
    control_period: float | None = None
    csv_period: float | None = DEFAULT_CSV_PERIOD
    path: Path | None = None
    start_position: tuple[float, float, float] | None = None
    heading: tuple[float, float, float] | None = None
    controller: str = "paper"
    vehicle: str | None = None
    fixed_base: bool = False
    lenient: bool = False
    package_path: tuple[str, ...] = ()
    added_mass: str = "exact"
    lagged_filter: float = UUV_SIMULATOR_FILTER
    gait: Gait | None = None
    wholebody: Mapping[str, Any] | None = None
    waves: Waves | None = None
    intervention: InterventionSettings | None = None
    thrusts: tuple[float, ...] | None = None
    torpedo: Torpedo | None = None

    def __post_init__(self) -> None:
        check_scheme(self.added_mass)
        object.__setattr__(self, "lagged_filter", check_filter(self.lagged_filter))
        if self.controller not in CONTROLLERS:
            raise ValueError(
                f"unknown controller '{self.controller}' (expected {' or '.join(CONTROLLERS)})"
            )
        if self.thrusts is not None:
            thrusts = tuple(float(x) for x in self.thrusts)
            if not all(map(math.isfinite, thrusts)):
                raise ValueError("thrusts must be finite numbers [N]")
            object.__setattr__(self, "thrusts", thrusts)
        if (self.controller == "constant") != (self.thrusts is not None):
            raise ValueError("thrusts go with controller 'constant', and it needs them")
        if self.gait is not None and not isinstance(self.gait, Gait):
            raise ValueError(
                f"gait must be a aiauv_pin.controllers.gait_controller.Gait, got "
                f"{type(self.gait).__name__:.40}"
            )
        if self.intervention is not None and not isinstance(
            self.intervention, InterventionSettings
        ):
            raise ValueError(
                "intervention must be an aiauv_pin.wholebody.intervention_transit."
                f"InterventionSettings, got {type(self.intervention).__name__:.40}"
            )
        if self.torpedo is not None and not isinstance(self.torpedo, Torpedo):
            raise ValueError(
                f"torpedo must be a aiauv_pin.controllers.torpedo_controller.Torpedo, got "
                f"{type(self.torpedo).__name__:.40}"
            )
        if self.path is not None and not isinstance(self.path, Path):
            raise ValueError(
                f"path must be a aiauv_control.paths.Path, got {type(self.path).__name__}"
            )
        for name in ("start_position", "heading"):
            value = getattr(self, name)
            if value is not None:
                value = tuple(float(x) for x in value)
                if len(value) != 3 or not all(map(math.isfinite, value)):
                    raise ValueError(f"{name} must be three finite numbers")
                object.__setattr__(self, name, value)
        if self.heading is not None and math.hypot(*self.heading) == 0.0:
            raise ValueError("heading must not be the zero vector")
        if self.case not in CASES:
            raise ValueError(f"unknown case '{self.case}' (expected uniform or stabilised)")
        for name in ("duration", "dt"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
        if self.control_period is not None:
            period = self.control_period
            ratio = period / self.dt if isinstance(period, (int, float)) else math.nan
            if not (
                math.isfinite(ratio) and period > 0 and abs(ratio - round(ratio)) < 1e-9 * ratio
            ):
                raise ValueError(
                    f"control_period must be a positive whole multiple of dt = {self.dt:g} s, "
                    f"got {period!r}"
                )
        if self.csv_period is not None and not (
            isinstance(self.csv_period, (int, float))
            and math.isfinite(self.csv_period)
            and self.csv_period > 0
        ):
            raise ValueError(
                f"csv_period must be a positive number of seconds or None, got {self.csv_period!r}"
            )
        if self.dt > self.duration:
            raise ValueError(
                f"dt ({self.dt:g} s) must not exceed the duration ({self.duration:g} s)"
            )
        if len(self.initial_offset) != 2 or not all(map(math.isfinite, self.initial_offset)):
            raise ValueError("initial_offset must be two finite numbers (p_y, p_z) [m]")
        if not math.isfinite(self.initial_surge):
            raise ValueError("initial_surge must be finite")
        if not isinstance(self.current, Current) and (
            len(self.current) != 3 or not all(map(math.isfinite, self.current))
        ):
            raise ValueError("current must be three finite numbers [m/s] or a Current")
        if self.waves is not None:
            if not isinstance(self.waves, Waves):
                raise ValueError(
                    f"waves must be a aiauv_hydro.waves.Waves, got {type(self.waves).__name__:.40}"
                )
            if as_current(self.current).kind != "constant":
                raise ValueError(
                    "waves: add to a constant current only, got a "
                    f"{as_current(self.current).kind} current"
                )
            self.waves.check_point(float(self.start[2]), "the start (end-effector)")
            self._check_path_in_the_water()

    def _check_path_in_the_water(self) -> None:
        """Refuse a followed path that leaves the water (below the sea floor or above the
        still-water level) within the run's reach: from its point closest to the start, ahead
        by the desired speed times the duration (64 points; one line). A user's own path is not
        sampled (its arc length may be costly to invert)."""
        path = followed_path(self)
        if path is None or path.kind_code < 0:
            return
        first = path.closest(self.start).s
        reach = self.controller_gains.u_d * self.duration
        for s, z in zip(
            np.linspace(0.0, reach, 64),
            path.points_at(np.linspace(first, first + reach, 64))[:, 2],
            strict=True,
        ):
            self.waves.check_point(float(z), f"the path {s:.3g} m ahead of the start")

    @property
    def steps_per_control(self) -> int:
        """Integration steps per controller call."""
        if self.control_period is None:
            return 1
        return max(1, round(self.control_period / self.dt))

    @property
    def path_to_follow(self) -> Path:
        """The path in force (the world x-axis by default)."""
        return X_AXIS if self.path is None else self.path

    @property
    def start(self) -> np.ndarray:
        """End-effector start position in the world [m]."""
        if self.start_position is not None:
            return np.array(self.start_position)
        return np.array([0.0, *self.initial_offset])

    @property
    def water(self) -> Current:
        """The water's motion as a :class:`aiauv_hydro.currents.Current`: the current, with the
        waves on it when there are waves (the current's ``unsteady`` choice kept)."""
        current = as_current(self.current)
        if self.waves is None:
            return current
        return Current.waves(self.waves, velocity=current.parameters[:3], unsteady=current.unsteady)

    @property
    def on_x_axis(self) -> bool:
        """Whether the path is the paper's (the world x-axis), for which p_y, p_z are reported."""
        path = self.path_to_follow
        return isinstance(path, LinePath) and path.describe() == X_AXIS.describe()

    @property
    def controller_gains(self) -> PathFollowingGains:
        """The gains in force: the given ones or the paper's for the case."""
        return self.gains if self.gains is not None else PathFollowingGains.for_case(self.case)


def _heading_rotation(heading: np.ndarray) -> np.ndarray:
    """Rotation taking the vehicle's x-axis to ``heading`` by yaw then pitch (no roll)."""
    h = heading / np.linalg.norm(heading)
    yaw = math.atan2(h[1], h[0])
    pitch = -math.asin(max(-1.0, min(1.0, h[2])))
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    return rz @ ry


def tip_frame(vehicle: Vehicle) -> str:
    """The frame whose position is the "end-effector" of a run: ``end_effector`` if the vehicle has
    one, else the link of its last body (the tip of a chain, e.g. an arm's last link)."""
    if vehicle.model.existFrame(END_EFFECTOR):
        return END_EFFECTOR
    import pinocchio as pin

    last_joint = vehicle.model.njoints - 1
    for frame in reversed(vehicle.model.frames):
        if frame.parentJoint == last_joint and frame.type == pin.FrameType.BODY:
            return frame.name
    return vehicle.model.frames[-1].name


def initial_state(vehicle: Vehicle, scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Straight vehicle at rest (or at ``initial_surge``), end-effector at the start, pointing along
    ``heading`` (default: the path's tangent at the point closest to the start).

    A fixed-base vehicle without a ``[start]`` of its own stays where its URDF puts it (the base at
    the world origin: a ``world`` root link is the world), at rest.
    """
    import pinocchio as pin

    if vehicle.fixed_base and scenario.start_position is None and scenario.heading is None:
        return vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    start = scenario.start
    heading = (
        np.array(scenario.heading)
        if scenario.heading is not None
        else np.array(scenario.path_to_follow.closest(start).tangent)
    )
    q = vehicle.neutral_configuration()
    tip = vehicle.frame_placement(q, tip_frame(vehicle)).translation  # base frame, q neutral
    rotation = _heading_rotation(heading)
    if np.allclose(rotation, np.eye(3), rtol=0.0, atol=0.0):
        q[:3] = start - tip
    else:
        q[:3] = start - rotation @ tip
        q[3:7] = pin.Quaternion(rotation).coeffs()
    settings = scenario.intervention
    if scenario.controller == "intervention" and settings is not None and settings.posture:
        # the body in its posture, the end-effector still at the start
        if len(settings.posture) != vehicle.nv - 6:
            raise ArgumentError(
                f"intervention.posture: expected {vehicle.nv - 6} joint angles, "
                f"got {len(settings.posture)}"
            )
        q[7:] = settings.posture
        q[:3] += start - vehicle.frame_placement(q, tip_frame(vehicle)).translation
    v = np.zeros(vehicle.nv)
    v[0] = scenario.initial_surge
    return q, v


@dataclass
class ScenarioResult:
    """A finished (or diverged) path-following run.

    Attributes:
        scenario: What was run.
        trajectory: Logged states and controller diagnostics.
        wall_time: Wall-clock time of the simulation loop [s].
        joint_names: Names of the actuated joints.
        thruster_names: Names of the thrusters.
        extra: Backend facts (``backend``, ``compiled_controller``).
        joint_units: Unit of each joint's position, ``"rad"`` (revolute) or ``"m"``
            (prismatic), in the order of ``joint_names`` (:func:`joint_position_units`); empty means
            every joint is revolute.
    """

    scenario: PaperScenario
    trajectory: Trajectory
    wall_time: float
    joint_names: list[str]
    thruster_names: list[str]
    extra: dict = field(default_factory=dict)
    joint_units: list[str] = field(default_factory=list)

    @property
    def followed_path(self) -> Path | None:
        """The path the run followed (:func:`followed_path`), ``None`` for a passive run."""
        return followed_path(self.scenario)

    @property
    def position_units(self) -> list[str]:
        """:attr:`joint_units`, or ``"rad"`` for every joint when it was not recorded."""
        return list(self.joint_units) or ["rad"] * len(self.joint_names)


def followed_path(scenario: Scenario) -> Path | None:
    """The path a run of ``scenario`` follows: its path in force with a path-following controller
    (``"paper"``, ``"thruster_turning"``), ``None`` for a passive run (``controller = "none"``),
    which follows nothing and so has no path errors."""
    return None if scenario.controller in OPEN_LOOP_CONTROLLERS else scenario.path_to_follow


#: Position unit of each one-degree-of-freedom joint type of Pinocchio that moves along an axis
#: (the others, revolute, turn: "rad").
_PRISMATIC_TYPES = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")


def joint_position_units(vehicle: Vehicle) -> list[str]:
    """Unit of each actuated joint's position (``q[7:]``): ``"m"`` for a prismatic joint, else
    ``"rad"``; its rate is that unit per second, its effort [N] or [N m]."""
    return [
        "m" if joint.shortname() in _PRISMATIC_TYPES else "rad"
        for joint in vehicle.model.joints[2:]
    ]


@dataclass(frozen=True)
class RunPlan:
    """A scenario made ready to run on a vehicle (:func:`plan_run`): the controller built once and
    every argument of :func:`aiauv_pin.simulate`, for the warm-up and the run alike.

    ``simulate(*plan.arguments, **plan.options)`` runs it; :func:`finish_run` turns the trajectory
    into a :class:`ScenarioResult`.

    Attributes:
        vehicle: The vehicle.
        scenario: The scenario.
        arguments: ``(vehicle, q0, v0, duration [s], dt [s], controller)``, the positional
            arguments of :func:`aiauv_pin.simulate`.
        options: Its keyword arguments (method, current, servo, control period, log period, ...).
        compiled: The compiled loop runs the controller (``after_first_chunk`` applies).
        passive: A passive run (``controller = "none"``).
    """

    vehicle: Vehicle
    scenario: Scenario
    arguments: tuple
    options: Mapping[str, Any]
    compiled: bool
    passive: bool


def plan_run(
    vehicle: Vehicle,
    scenario: Scenario,
    *,
    controller: VehiclePathFollowing | None = None,
    compiled: bool | None = None,
) -> RunPlan:
    """Build ``scenario``'s controller for ``vehicle`` and the arguments of its run (a
    :class:`RunPlan`), without simulating: :func:`run_scenario`'s first half.

    Args:
        vehicle: The vehicle.
        scenario: What to run.
        controller: The controller callback; ``None`` builds the one ``scenario`` names.
        compiled: ``True`` requires the compiled path, ``False`` forbids it, ``None`` (default)
            uses it when :func:`compiled_path_following_reason` allows.

    Raises:
        ValueError: ``compiled=True`` but the compiled path cannot run this controller, or a task
            the actuators cannot produce (one line, before the run).
    """
    q0, v0 = initial_state(vehicle, scenario)
    options = dict(
        method=scenario.method,
        current=scenario.water,
        control_period=scenario.control_period,
        log_every=scenario.steps_per_control,
    )
    lagged = scenario.added_mass == "lagged"
    if lagged:
        if compiled:
            raise ValueError(
                "added_mass = 'lagged' runs the Python controller, not the compiled loop"
            )
        options.update(added_mass="lagged", lagged_filter=scenario.lagged_filter)
        compiled = False
    passive = scenario.controller == "none" and controller is None
    if passive:
        use_compiled = vehicle.fast is not None and compiled is not False
        if compiled and not use_compiled:
            raise ValueError(
                f"compiled run unavailable: the vehicle runs on {vehicle.active_backend}"
            )
        law = CompiledController.passive() if use_compiled else None
        servo = None
    elif scenario.controller == "constant" and controller is None:
        if vehicle.fast is None or compiled is False:
            raise ValueError("constant thrusts run in the compiled loop only")
        law, servo, use_compiled = (
            CompiledController.constant(vehicle, scenario.thrusts),
            None,
            True,
        )
    elif scenario.controller == "gait" and controller is None:
        if compiled is False:
            raise ValueError(
                "gaits run in the compiled loop only"
                + (" (not with added_mass = 'lagged')" if lagged else "")
            )
        gait = VehicleGait(
            vehicle, scenario.gait, scenario.controller_gains, path=scenario.path_to_follow
        )
        law, servo, use_compiled = gait.compiled(), gait.joint_servo, True
    elif scenario.controller == "torpedo" and controller is None:
        if compiled is False:
            raise ValueError(
                "the torpedo controller runs in the compiled loop only"
                + (" (not with added_mass = 'lagged')" if lagged else "")
            )
        torpedo = VehicleTorpedo(vehicle, scenario.torpedo, path=scenario.path_to_follow)
        law, servo, use_compiled = torpedo.compiled(), None, True
    elif scenario.controller in ("station", "velocity") and controller is None:
        from aiauv_pin.wholebody.station_options import controller_from_options

        if compiled:
            raise ValueError(f"{scenario.controller} runs as a Python controller")
        controller = controller_from_options(
            vehicle,
            scenario.controller,
            scenario.wholebody or {},
            scenario.water,
            q0,
            actuator_period=scenario.dt * scenario.steps_per_control,
        )
        law, servo, use_compiled = controller, controller.joint_servo, False
    elif scenario.controller in ("intervention", "transit_intervene") and controller is None:
        if compiled:
            raise ValueError(
                f"{scenario.controller} runs the Python controller, not the compiled loop"
            )
        settings = scenario.intervention or InterventionSettings()
        if scenario.controller == "intervention":
            law = settings.controller(vehicle, scenario.water)
            law.check(q0)  # a task the actuators cannot produce: one line before the run
        else:
            law = TransitThenIntervene(
                vehicle,
                settings,
                scenario.controller_gains,
                path=scenario.path_to_follow,
                current=scenario.water,
            )
        servo = law.joint_servo
        use_compiled = False
    elif scenario.controller == "thruster_turning" and controller is None:
        from aiauv_pin.controllers.turning_controller import VehicleThrusterTurning

        if compiled is False:
            raise ValueError(
                "thruster turning runs in the compiled loop only"
                + (" (not with added_mass = 'lagged')" if lagged else "")
            )
        turning = VehicleThrusterTurning(
            vehicle, scenario.controller_gains, path=scenario.path_to_follow
        )
        law, servo, use_compiled = turning.compiled(), turning.joint_servo, True
    else:
        if controller is None:
            controller = VehiclePathFollowing(
                vehicle,
                scenario.controller_gains,
                continuous_joints=scenario.continuous_joints,
                path=scenario.path_to_follow,
            )
        reason = compiled_path_following_reason(controller)
        if compiled and reason is not None:
            raise ArgumentError(f"compiled path following unavailable: {reason}")
        use_compiled = reason is None and compiled is not False
        law = controller.compiled() if use_compiled else controller
        servo = controller.joint_servo if controller.continuous_joints else None
    return RunPlan(
        vehicle,
        scenario,
        (vehicle, q0, v0, scenario.duration, scenario.dt, law),
        {**options, "servo": servo},
        use_compiled,
        passive,
    )


def finish_run(plan: RunPlan, trajectory: Trajectory, wall_time: float) -> ScenarioResult:
    """The :class:`ScenarioResult` of ``plan``'s run: ``trajectory`` with its path errors, after a
    check for oscillating joints; :func:`run_scenario`'s second half.

    Args:
        plan: The run's :class:`RunPlan`.
        trajectory: What :func:`aiauv_pin.simulate` returned for it.
        wall_time: The simulation's wall time [s].
    """
    vehicle, scenario = plan.vehicle, plan.scenario
    complete_diagnostics(vehicle, scenario, trajectory)
    if not plan.passive and scenario.controller != "constant":  # rows logged once per sample
        warn_if_oscillating(
            np.asarray(trajectory.v)[:, 6:],
            scenario.method,
            scenario.dt,
            scenario.dt * scenario.steps_per_control,
        )
    return result_of(plan, trajectory, wall_time)


def result_of(plan: RunPlan, trajectory: Trajectory, wall_time: float) -> ScenarioResult:
    """The :class:`ScenarioResult` of ``plan``'s run holding ``trajectory`` as it is (no
    diagnostics added, no check): the vehicle's joint and thruster names and units, and its
    backend. ``wall_time``: the simulation's wall time [s]."""
    vehicle = plan.vehicle
    return ScenarioResult(
        scenario=plan.scenario,
        trajectory=trajectory,
        wall_time=wall_time,
        joint_names=vehicle.joint_names,
        thruster_names=vehicle.thruster_names,
        extra={"backend": vehicle.active_backend, "compiled_controller": plan.compiled},
        joint_units=joint_position_units(vehicle),
    )


def run_scenario(
    vehicle: Vehicle,
    scenario: Scenario,
    *,
    progress: bool = False,
    on_log=None,
    controller: VehiclePathFollowing | None = None,
    compiled: bool | None = None,
    after_first_chunk: Callable[[], None] | None = None,
    compile_only: bool = False,
) -> ScenarioResult | None:
    """Simulate a scenario on a vehicle: :func:`plan_run`, :func:`aiauv_pin.simulate`,
    :func:`finish_run`.

    ``on_log(t, q, info)`` is called at every logged sample (see :func:`aiauv_pin.simulate`).

    With the numba backend and the paper's controller the whole run (dynamics, controller every
    step, logging) executes in compiled code (:func:`aiauv_pin.simulation.compiled_loop.run_chunk`), in chunks
    of simulated time between which the progress bar and ``on_log`` run; otherwise (Pinocchio
    backend, a subclass of :class:`VehiclePathFollowing` or of its controller) the Python controller
    is called every step. A passive run (``controller="none"``) is compiled too. Both give the same trajectory
    and the same logged keys.

    Args:
        vehicle: The vehicle.
        scenario: What to run.
        progress: Show a progress bar.
        on_log: Callback at every logged sample.
        after_first_chunk: Called once the compiled loop's first chunk has run, for work that can
            overlap the rest in a background thread (the loop releases the GIL), e.g.
            :func:`aiauv_pin.results.outputs.preload_plotting`.
        controller: The controller callback; ``None`` builds the paper's for ``scenario``.
        compiled: ``True`` requires the compiled path, ``False`` forbids it, ``None`` (default)
            uses it when :func:`compiled_path_following_reason` allows.
        compile_only: Build the controller and load (or compile) the compiled loop for the run,
            then return ``None`` without simulating (:func:`aiauv_pin.simulate`'s
            ``compile_only``; :func:`warm_up`).

    Raises:
        SimulationDiverged: With the partial trajectory, if the state became non-finite.
        ValueError: ``compiled=True`` but the compiled path cannot run this controller.
    """
    plan = plan_run(vehicle, scenario, controller=controller, compiled=compiled)
    if compile_only:
        simulate(*plan.arguments, **plan.options, compile_only=True)
        return None
    start = time.perf_counter()
    trajectory = simulate(
        *plan.arguments,
        **plan.options,
        progress=progress,
        on_log=on_log,
        after_first_chunk=after_first_chunk if plan.compiled else None,
    )
    return finish_run(plan, trajectory, time.perf_counter() - start)


def complete_diagnostics(vehicle: Vehicle, scenario: Scenario, trajectory: Trajectory) -> None:
    """The diagnostics :func:`finish_run` adds to a run's log: the path errors of
    :func:`add_path_errors`, for a transit and intervention run from ``p`` over both phases."""
    if scenario.controller == "transit_intervene":
        for key in ("cross_track", "path_s"):
            trajectory.info.pop(key, None)
    add_path_errors(vehicle, scenario, trajectory)


def add_path_errors(vehicle: Vehicle, scenario: Scenario, trajectory: Trajectory) -> None:
    """Log the end-effector position ``p`` and, when a path is followed (:func:`followed_path`),
    the cross-track errors ``cross_track`` [m] and path parameter ``path_s`` [m], when the
    controller did not.

    A user's controller logs no path quantities; they are computed here from the logged
    configurations (:meth:`Vehicle.frame_placement`, :meth:`aiauv_control.paths.Path.closest`). So are
    they for the midpoint method, whose rows hold the controller's measurement at the middle of
    their step (:func:`aiauv_pin.simulate`): the files then show the rows' own. A passive run
    follows no path: it gets ``p`` only.
    """
    from aiauv_control.laws.paper_laws import path_errors_of_positions
    from aiauv_pin.reference.integrators import SAMPLES_INSIDE_STEP

    info = trajectory.info
    n = len(trajectory.t)
    if scenario.method in SAMPLES_INSIDE_STEP:
        for key in ("p", "cross_track", "path_s"):
            info.pop(key, None)
    if "p" not in info:
        frame = vehicle.frame_id(tip_frame(vehicle))
        if vehicle.fast is not None:
            info["p"] = vehicle.fast.frame_positions(np.asarray(trajectory.q), frame)
        else:
            zero = np.zeros(vehicle.nv)
            info["p"] = np.array([vehicle.frame_motion(q, zero, frame)[1] for q in trajectory.q])
    path = followed_path(scenario)
    if path is None:
        for key in ("cross_track", "path_s"):
            info.pop(key, None)
    elif "cross_track" not in info:
        s, errors = np.empty(n), np.empty((n, 2))
        path_errors_of_positions(
            path.user_function,
            path.kind_code,
            path.params,
            np.ascontiguousarray(info["p"], dtype=float).reshape(n, 3),
            s,
            errors,
        )
        info["cross_track"], info["path_s"] = errors, s


def run_paper_scenario(vehicle: Vehicle, scenario: Scenario, **options) -> ScenarioResult:
    """:func:`run_scenario` (kept for the paper's scripts and notebooks)."""
    return run_scenario(vehicle, scenario, **options)


#: The paper's scenario is a :class:`Scenario` with its defaults.
PaperScenario = Scenario


def settling_time(t: np.ndarray, error: np.ndarray, band: float) -> float | None:
    """First time after which ``|error|`` stays within ``band`` (``None`` if it never does)."""
    outside = np.flatnonzero(np.abs(error) > band)
    if outside.size == 0:
        return float(t[0])
    if outside[-1] == len(t) - 1:
        return None
    return float(t[outside[-1] + 1])


def _parameters(scenario: Scenario) -> dict:
    """The scenario's parameters as JSON-friendly values (path and current described)."""
    out = {}
    for f in fields(scenario):
        value = getattr(scenario, f.name)
        if f.name == "gains":
            continue
        if f.name in ("gait", "intervention", "torpedo"):
            value = asdict(value) if value is not None else None
        if f.name == "path":
            value = scenario.path_to_follow.describe()
        elif f.name == "current":
            value = as_current(scenario.current).describe()
        elif f.name == "waves":
            value = value.describe() if value is not None else None
        elif isinstance(value, tuple):
            value = list(value)
        out[f.name] = value
    out["gains"] = asdict(scenario.controller_gains)
    return out


#: Largest vertical component of a normal counted as horizontal in :func:`cross_track_axes` [-].
HORIZONTAL_TOLERANCE = 1e-9


def cross_track_axes(scenario: Scenario, s_range: tuple[float, float]) -> tuple[str, str]:
    """Names of the cross-track errors ``(e_1, e_2)`` of a run of ``scenario``: the components of
    the end-effector's offset from its closest path point along the path frame's normals
    ``(N1, N2)`` (:mod:`aiauv_control.paths`), named by what those normals are over ``s_range`` [m]:

    * ``("p_y", "p_z")`` on the paper's path, the world x-axis (``N1, N2`` are world ``y, z``);
    * ``("horizontal", "vertical")`` where ``N1`` is horizontal and ``N2`` points up at every
      sampled point (a line that is not vertical, waypoints in one horizontal plane, a circle about
      an upward axis): ``e_1`` is the horizontal error, positive to the left of the direction of
      travel (``N1 = N2 x T``), ``e_2`` the error in the vertical plane through the tangent,
      positive upwards;
    * ``("N1", "N2")`` elsewhere (a helix with a pitch, a climbing waypoint path, a vertical line, a
      user's path): the rotation-minimising frame's normals, which turn along the path.

    The frame is read with :meth:`aiauv_control.paths.Path.closest` at 33 points of the path evenly
    spaced over ``s_range``.
    """
    if scenario.on_x_axis:
        return ("p_y", "p_z")
    path = scenario.path_to_follow
    low, high = (float(x) for x in s_range)
    s = np.linspace(low, high, 33) if high > low else np.array([low])
    for point in path.points_at(s):
        frame = path.closest(point)
        if abs(frame.normal1[2]) > HORIZONTAL_TOLERANCE or frame.normal2[2] <= HORIZONTAL_TOLERANCE:
            return ("N1", "N2")
    return ("horizontal", "vertical")


def summary(result: ScenarioResult, energy: Callable[[], dict | None] | None = None) -> dict:
    """Figures of merit of a run (all SI units).

    ``energy``: gives the ``energy`` block
    (:func:`aiauv_pin.simulation.energy.energy_summary` of ``result``), e.g. computed in a thread
    meanwhile (:func:`aiauv_pin.results.outputs.write_results`); by default computed here.

    Every run: ``final.position`` (the end-effector's world position [m]), ``final.base_position``
    [m], ``final.base_displacement`` (from the start, world frame [m]), ``final.base_distance``
    (its length [m]) and ``final.base_speed`` (speed of the base origin [m/s]).

    A run that follows a path (:func:`followed_path`; not a passive run) also has
    ``final.cross_track_error`` (distance from the end-effector to the path [m]),
    ``final.cross_track`` (its components ``e_1, e_2`` [m], named by ``cross_track_axes``,
    :func:`cross_track_axes`), ``final.along_track`` (arc length of the closest path point [m]) and
    ``settling_time.cross_track_5cm``; on the paper's x-axis also ``p_y``, ``p_z`` (the same
    errors, in world axes). The paper controller's quantities (surge, pointing error, work) are
    reported when it ran.
    """
    scenario = result.scenario
    tr = result.trajectory
    t, info = tr.t, tr.info
    p = info["p"]
    q, v = np.asarray(tr.q), np.asarray(tr.v)
    last30 = t >= t[-1] - 30.0
    dt_log = np.diff(t)
    displacement = q[-1, :3] - q[0, :3]
    final: dict = {
        "position": [float(x) for x in p[-1]],
        "base_position": [float(x) for x in q[-1, :3]],
        "base_displacement": [float(x) for x in displacement],
        "base_distance": float(np.linalg.norm(displacement)),
        # the body-frame linear velocity's length is the world speed of the base origin
        "base_speed": float(np.linalg.norm(v[-1, :3])),
    }
    settling: dict = {}
    axes = None
    if result.followed_path is not None:
        cross = info["cross_track"]
        path_s = info["path_s"]
        distance = np.hypot(cross[:, 0], cross[:, 1])
        axes = cross_track_axes(scenario, (float(np.min(path_s)), float(np.max(path_s))))
        final.update(
            {
                "cross_track_error": float(distance[-1]),
                "cross_track": [float(x) for x in cross[-1]],
                "along_track": float(path_s[-1]),
                "max_cross_track_error_last_30s": float(distance[last30].max()),
            }
        )
        settling["cross_track_5cm"] = settling_time(t, distance, 0.05)
        if scenario.on_x_axis:
            final["p_y"], final["p_z"] = float(p[-1, 1]), float(p[-1, 2])
            settling["p_y_5cm"] = settling_time(t, p[:, 1], 0.05)
            settling["p_z_5cm"] = settling_time(t, p[:, 2], 0.05)
    content = {
        "case": scenario.case,
        "controller": scenario.controller,
        "status": tr.status,
        "message": tr.message,
        "parameters": _parameters(scenario),
        "path": None if result.followed_path is None else result.followed_path.describe(),
        "dt": scenario.dt,
        "method": scenario.method,
        "steps": len(t) - 1,
        "simulated_time": float(t[-1]),
        "wall_time": result.wall_time,
        "real_time_factor": float(t[-1] / result.wall_time) if result.wall_time > 0 else None,
        "backend": result.extra.get("backend"),
        "compiled_controller": result.extra.get("compiled_controller"),
        "final": final,
        "settling_time": settling,
    }
    if axes is not None:
        content["cross_track_axes"] = list(axes)
    if "u" in info and np.all(np.isfinite(info["u"])):  # (not a transit's intervention rows)
        gains = scenario.controller_gains
        u = info["u"]
        final.update(
            {
                "u": float(u[-1]),
                "phi_tilde": float(info["phi_tilde"][-1]),
                "omega_tilde": [float(x) for x in info["omega_tilde"][-1]],
                "max_abs_u_error_last_30s": float(np.abs(u[last30] - gains.u_d).max()),
                "max_phi_tilde_last_30s": float(np.abs(info["phi_tilde"][last30]).max()),
            }
        )
        settling["u_1cm_s"] = settling_time(t, u - gains.u_d, 0.01)
        settling["phi_tilde_0.02rad"] = settling_time(t, info["phi_tilde"], 0.02)
    if "thruster_power" in info and "joint_torque" in info:
        thruster_power = np.abs(info["thruster_power"][:-1])
        joint_power = np.abs(info["joint_torque"][:-1] * tr.v[:-1, 6:])
        thruster_work, total_thruster_work = exact_column_sums(thruster_power * dt_log[:, None])
        joint_work, total_joint_work = exact_column_sums(joint_power * dt_log[:, None])
        content["thruster_work"] = dict(zip(result.thruster_names, thruster_work, strict=True))
        content["joint_work"] = dict(zip(result.joint_names, joint_work, strict=True))
        content["total_thruster_work"] = total_thruster_work
        content["total_joint_work"] = total_joint_work
    if "pose_error" in info:  # intervention mode: errors to the reference, its rows only
        error = np.asarray(info["pose_error"]).reshape(len(t), 6)
        error = error[np.all(np.isfinite(error), axis=1)]
        position, attitude = (np.linalg.norm(error[:, s], axis=1) for s in (slice(3), slice(3, 6)))
        content["intervention"] = {
            "final_position_error": float(position[-1]),
            "final_attitude_error": float(attitude[-1]),
            "max_position_error": float(position.max()),
            "max_attitude_error": float(attitude.max()),
        }
    block = energy_summary(result) if energy is None else energy()
    if block is not None:
        content["energy"] = block
    return content


def warm_up(vehicle, scenario) -> None:
    """Load (or compile) the compiled loop of ``scenario``'s run on ``vehicle`` without simulating.

    The controller is built and the arguments checked as for the run, and the loop is called with
    no step to take (:func:`run_scenario` with ``compile_only``), so numba loads or compiles the
    loop's specialisation for exactly the run's argument types and no physics runs. Does nothing
    on the Pinocchio backend (nothing to compile).

    Args:
        vehicle: The :class:`~aiauv_pin.Vehicle` of the run.
        scenario: The :class:`~aiauv_pin.scenario.definition.Scenario` about to run.

    Raises:
        ValueError: A scenario the run would refuse (the same one line, before the run).
    """
    if vehicle.active_backend != "numba":
        return
    run_scenario(vehicle, scenario, compile_only=True)
