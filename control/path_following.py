"""Straight-path following for articulated intervention AUVs (paper, Section 3).

:class:`PathFollowingController` composes

1. LOS guidance (eq. 21, :mod:`aiauv_control.guidance`): reference pointing direction ``x_ref`` from the
   end-effector position and its derivatives;
2. base angles (eq. 23, :mod:`aiauv_control.joint_references`): the reduced-attitude law applied to the
   end-effector frame;
3. joint references (eq. 22) and joint PD with hydrostatic compensation (eq. 24,
   :mod:`aiauv_control.joint_control`);
4. surge PI on the longitudinal thrusters (eq. 25, :mod:`aiauv_control.surge`); all other thrusters stay
   0.

It knows nothing about how the vehicle is simulated: every measured quantity comes in a
:class:`PathFollowingMeasurement`.

Saturation ``q_max`` of the base angles (eq. 22) is not given in the paper. The default, 30 deg,
keeps the first (largest) joint reference at less than half of the +-65 deg joint limits of the
vehicle lineage, leaving margin for PD overshoot and for the hydrostatic and hydrodynamic loads on
the joints; with ``alpha = 0.7`` the references of one axis then sum to at most ``1.87 q_max``
(about 56 deg of total body bend per plane for four joints), enough for a turn without letting the
body coil.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from aiauv_control.guidance import X_AXIS, cross_track_gains
from aiauv_control.joint_references import check_joint_axes, joint_reference_pattern
from aiauv_control.laws import paper_laws as laws
from aiauv_control.paths import Path
from aiauv_control.reduced_attitude import check_feedforward, check_rotation
from aiauv_control.surge import SurgePIController

#: Options of :attr:`PathFollowingGains.current_compensation`.
CURRENT_COMPENSATION_OPTIONS = ("none", "integral_los")

#: Turn model of the paper's vehicle, identified from open-loop step responses of the base angles
#: (joint references of eq. 22 held, surge PI at u_d = 0.5 m/s; ``benchmarks/beyond_paper.py``,
#: figures in ``benchmarks/beyond_paper.json``): a step of 0.1 rad in ``q_y0`` or ``q_z0`` settles
#: at an end-effector turn rate of 0.057 rad/s at u = 0.497 m/s, i.e. a steady path curvature of
#: 1.14 1/m per radian of base angle [1/(m rad)].
PAPER_TURN_CURVATURE_GAIN = 1.14
#: Time constant of the turn rate's response, fitted first-order to the same steps (about 10 s), is
#: NOT the default: fed forward through the measured (finite-difference) acceleration it
#: destabilises the helix run (the head's lateral acceleration answers the bend at once). 0 keeps
#: the steady part (the reference turn rate) only [s].
PAPER_TURN_TIME_CONSTANT = 0.0
#: Effective hydrodynamic moment per radian of base angle [N m/rad] of the roll-stabilised vehicle
#: in closed loop, calibrated by a sweep on the paper's scenario (``benchmarks/beyond_paper.py``:
#: 5 over-cancels the restoring moment and overshoots, 6 settles fastest, 7-9 settle slower). The
#: margin to over-cancelling is thin: do not lower it without measuring.
PAPER_TURN_MOMENT_GAIN = 6.0
#: Integral gain ``sigma`` of the integral LOS guidance [-] (with ``k_e = u_d / 10``).
DEFAULT_LOS_INTEGRAL_GAIN = 0.5

CASES = ("uniform", "stabilised")
"""Vehicle cases of the paper's Section 4.2 (they differ in the attitude gain ``k_d``)."""

_CASE_K_D = {"uniform": 19.0, "stabilised": 12.0}


@dataclass(frozen=True)
class PathFollowingGains:
    """Parameters of the path-following controller; defaults are the paper's (Sec. 4.2).

    Attributes:
        u_d: Desired surge speed [m/s] (eq. 21, 25).
        k_e: Cross-track gain [1/s] (eq. 21): a scalar or ``(k_y, k_z)``; ``None`` (default)
            means ``u_d / 10`` as in the paper.
        alpha: Shape parameter of the joint references [-] (eq. 22).
        k_p: Pointing-error gain of the base angles [-] (eq. 23).
        k_d: Angular-velocity-error gain of the base angles [s] (eq. 23); 19 (uniform density) or 12
            (passively roll-stabilised) in the paper.
        k_qp: Joint proportional gain [N m/rad] (eq. 24).
        k_qd: Joint derivative gain [N m s/rad] (eq. 24).
        k_1p: Surge proportional gain [N s/m] (eq. 25).
        k_1i: Surge integral gain [N/m] (eq. 25).
        q_max: Saturation of the base angles [rad] (eq. 22; project choice, see the module
            docstring).
        feedforward: ``"exact"`` (default) or ``"paper"`` feedforward in eq. (23).
        turn_feedforward: Beyond the paper: feed the reference turn rate (on a curved path, the
            path's curvature times the speed) forward through the identified turn dynamics
            (:func:`aiauv_control.laws.paper_laws.path_following_command`). Off by default (the paper's law).
        turn_curvature_gain: Steady end-effector path curvature per radian of base angle
            [1/(m rad)]; the turn model's gain is ``G = turn_curvature_gain * u_d`` [1/s].
        turn_time_constant: Time constant ``T`` of the turn model [s] (0: steady model only).
        current_compensation: ``"none"`` (the paper's LOS) or ``"integral_los"`` (integral LOS,
            Borhaug et al. 2008, in 3-D).
        los_integral_gain: Integral gain ``sigma`` of the integral LOS [-].
        hydrostatic_compensation: Beyond the paper: add to the base angles the angle whose
            hydrodynamic moment balances the vehicle's restoring moment (its Conclusions' future
            work). Off by default.
        turn_moment_gain: Hydrodynamic moment per radian of base angle [N m/rad] (identified).
    """

    u_d: float = 0.5
    k_e: float | tuple[float, float] | None = None
    alpha: float = 0.7
    k_p: float = 2.0
    k_d: float = 19.0
    k_qp: float = 30.0
    k_qd: float = 50.0
    k_1p: float = 100.0
    k_1i: float = 5.0
    q_max: float = float(np.deg2rad(30.0))
    feedforward: str = "exact"
    turn_feedforward: bool = False
    turn_curvature_gain: float = PAPER_TURN_CURVATURE_GAIN
    turn_time_constant: float = PAPER_TURN_TIME_CONSTANT
    current_compensation: str = "none"
    los_integral_gain: float = DEFAULT_LOS_INTEGRAL_GAIN
    hydrostatic_compensation: bool = False
    turn_moment_gain: float = PAPER_TURN_MOMENT_GAIN

    def __post_init__(self) -> None:
        positive = (
            "u_d",
            "alpha",
            "k_p",
            "k_d",
            "k_qp",
            "q_max",
            "turn_curvature_gain",
            "los_integral_gain",
            "turn_moment_gain",
        )
        non_negative = ("k_qd", "k_1p", "k_1i", "turn_time_constant")
        for name in ("turn_feedforward", "hydrostatic_compensation"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be true or false, got {getattr(self, name)!r}")
        if self.current_compensation not in CURRENT_COMPENSATION_OPTIONS:
            raise ValueError(
                f"current_compensation must be one of {', '.join(CURRENT_COMPENSATION_OPTIONS)}, "
                f"got {self.current_compensation!r}"
            )
        for name in positive + non_negative:
            value = getattr(self, name)
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise ValueError(f"gain {name} must be a number, got {value!r}") from None
            if not np.isfinite(number) or number < 0.0 or (name in positive and number == 0.0):
                bound = "> 0" if name in positive else ">= 0"
                raise ValueError(f"gain {name} must be finite and {bound}, got {value}")
            object.__setattr__(self, name, number)
        if self.q_max > np.pi:
            raise ValueError(f"gain q_max must be at most pi rad, got {self.q_max}")
        if self.k_e is None:
            object.__setattr__(self, "k_e", self.u_d / 10.0)  # paper, Sec. 4.2: k_e = u_d / 10
        gains = cross_track_gains(self.k_e)[1:]
        if np.any(gains == 0.0):
            raise ValueError(
                f"gain k_e must be > 0 (no convergence to the path otherwise), got {self.k_e}"
            )
        object.__setattr__(
            self,
            "k_e",
            float(gains[0]) if gains[0] == gains[1] else (float(gains[0]), float(gains[1])),
        )
        check_feedforward(self.feedforward)

    @classmethod
    def for_case(cls, case: str, **overrides) -> PathFollowingGains:
        """The paper's gains for ``case`` in :data:`CASES` (``k_d`` 19 or 12), with overrides."""
        if case not in _CASE_K_D:
            raise ValueError(f"unknown vehicle case {case!r}, expected one of {CASES}")
        return cls(**{"k_d": _CASE_K_D[case], **overrides})

    @classmethod
    def uniform(cls, **overrides) -> PathFollowingGains:
        """The paper's gains for the uniform-density vehicle (``k_d = 19``)."""
        return cls.for_case("uniform", **overrides)

    @classmethod
    def stabilised(cls, **overrides) -> PathFollowingGains:
        """The paper's gains for the passively roll-stabilised vehicle (``k_d = 12``)."""
        return cls.for_case("stabilised", **overrides)

    def with_changes(self, **changes) -> PathFollowingGains:
        """A copy with some fields replaced (validated again).

        ``k_e`` keeps its resolved value when only ``u_d`` changes; pass ``k_e=None`` to re-derive
        ``u_d / 10``.
        """
        return replace(self, **changes)


def _frozen(value, shape: tuple[int, ...] | None, name: str) -> np.ndarray:
    array = np.array(value, dtype=float)
    if shape is None:
        if array.ndim != 1:
            raise ValueError(f"{name}: expected a 1-D array, got shape {array.shape}")
    elif array.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class PathFollowingMeasurement:
    """What the controller needs to know about the vehicle at one instant.

    Attributes:
        position_in_world: End-effector position ``p_e`` (3,) [m].
        velocity_in_world: End-effector linear velocity (3,) [m/s].
        acceleration_in_world: End-effector linear acceleration (3,) [m/s^2] (latest available
            value).
        rotation_to_world: End-effector orientation ``R_e`` (end-effector frame to world, 3x3).
        angular_velocity_in_ee: End-effector angular velocity in its own frame (3,) [rad/s].
        joint_positions: ``q`` (n,) [rad], model order.
        joint_velocities: ``q_dot`` (n,) [rad/s].
        joint_hydrostatic_forces: ``g_q`` (n,) [N m], left-hand-side convention of eq. (19)
            (see :mod:`aiauv_control.joint_control`).
        surge_velocity: ``u`` [m/s], x-component of the end-effector velocity in its own frame.
        restoring_moment_in_ee: Restoring moment of the whole vehicle about the end-effector, its
            axes, left-hand side of eq. (19) (3,) [N m]; needed only for the hydrostatic
            compensation (default zero).
    """

    position_in_world: np.ndarray
    velocity_in_world: np.ndarray
    acceleration_in_world: np.ndarray
    rotation_to_world: np.ndarray
    angular_velocity_in_ee: np.ndarray
    joint_positions: np.ndarray
    joint_velocities: np.ndarray
    joint_hydrostatic_forces: np.ndarray
    surge_velocity: float
    restoring_moment_in_ee: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        for name, shape in (
            ("position_in_world", (3,)),
            ("restoring_moment_in_ee", (3,)),
            ("velocity_in_world", (3,)),
            ("acceleration_in_world", (3,)),
            ("rotation_to_world", (3, 3)),
            ("angular_velocity_in_ee", (3,)),
            ("joint_positions", None),
        ):
            object.__setattr__(self, name, _frozen(getattr(self, name), shape, name))
        n = self.joint_positions.shape
        for name in ("joint_velocities", "joint_hydrostatic_forces"):
            object.__setattr__(self, name, _frozen(getattr(self, name), n, name))
        surge = float(self.surge_velocity)
        if not np.isfinite(surge):
            raise ValueError(f"surge_velocity must be finite, got {self.surge_velocity}")
        object.__setattr__(self, "surge_velocity", surge)


@dataclass(frozen=True)
class PathFollowingCommand:
    """Controller output and diagnostics at one instant.

    Attributes:
        joint_torques: ``tau_q`` (n,) [N m] (eq. 24).
        thrusts: ``tau_thr`` (n_thrusters,) [N] (eq. 25); nonzero only for the surge thrusters.
        phi_tilde: Pointing error of the end-effector [rad] (eq. 4).
        omega_tilde: Angular velocity error ``omega_tilde^e`` (2,) [rad/s] (eq. 8).
        base_angles: ``q0 = (q_y0, q_z0)`` [rad] before saturation (eq. 23).
        joint_references: ``q*`` (n,) [rad] (eq. 22).
        x_ref: Reference pointing direction, world frame (3,) (eq. 21).
        x_ref_dot: Its time derivative (3,) [1/s].
        pointing_direction: End-effector x-axis in the world frame (3,).
        surge_integral: ``integral (u - u_d) dt`` of the surge PI [m].
        x_ref_ddot: Second time derivative of ``x_ref`` (3,) [1/s^2].
        cross_track_error: End-effector offset from the path along ``N1``, ``N2`` (2,) [m].
        path_parameter: Arc length of the closest path point [m].
    """

    joint_torques: np.ndarray
    thrusts: np.ndarray
    phi_tilde: float
    omega_tilde: np.ndarray
    base_angles: np.ndarray
    joint_references: np.ndarray
    x_ref: np.ndarray
    x_ref_dot: np.ndarray
    pointing_direction: np.ndarray
    surge_integral: float
    x_ref_ddot: np.ndarray
    cross_track_error: np.ndarray
    path_parameter: float


class PathFollowingController:
    """Path following by curving the body (paper, Section 3), on any path of :mod:`aiauv_control.paths`.

    Args:
        joint_axes: Axis label (``"y"``/``"z"``/``"x"``, optionally signed: ``"-z"``) of each
            actuated joint, model order, tail to head; any numbers in any order
            (:func:`aiauv_control.joint_references.check_joint_axes`).
        surge_thrusters: Indices (into the thrust vector) of the longitudinal thrusters.
        n_thrusters: Length of the thrust vector.
        max_thrust: Thrust limit [N], one value or one per thruster. All surge thrusters receive the
            same thrust, limited by the smallest of their limits, so that a symmetric pair produces
            no turning moment.
        gains: Controller parameters.
        path: The path to follow (default: the world x-axis, as in the paper).
    """

    def __init__(
        self,
        joint_axes: Sequence[str],
        surge_thrusters: Sequence[int],
        n_thrusters: int,
        max_thrust: float | Sequence[float],
        gains: PathFollowingGains | None = None,
        path: Path | None = None,
    ) -> None:
        self.gains = PathFollowingGains() if gains is None else gains
        if not isinstance(self.gains, PathFollowingGains):
            raise ValueError(f"gains: expected PathFollowingGains, got {type(self.gains).__name__}")
        self.joint_axes = check_joint_axes(joint_axes)
        self._axis_index, self._reference_scale = joint_reference_pattern(
            self.joint_axes, self.gains.alpha
        )
        if isinstance(n_thrusters, bool) or int(n_thrusters) != n_thrusters or n_thrusters < 1:
            raise ValueError(f"n_thrusters must be a positive integer, got {n_thrusters}")
        self.n_thrusters = int(n_thrusters)
        self.surge_thrusters = self._check_surge_thrusters(surge_thrusters)
        limits = np.asarray(max_thrust, dtype=float)
        if limits.ndim == 0:
            limits = np.full(self.n_thrusters, float(limits))
        if limits.shape != (self.n_thrusters,):
            raise ValueError(
                f"max_thrust: expected one value or {self.n_thrusters}, got shape {limits.shape}"
            )
        if not np.all(np.isfinite(limits)) or np.any(limits <= 0.0):
            raise ValueError(
                f"max_thrust: limits must be positive and finite, got {limits.tolist()}"
            )
        self.max_thrust = limits.copy()
        self.path = X_AXIS if path is None else path
        if not isinstance(self.path, Path):
            raise ValueError(
                f"path: expected a aiauv_control.paths.Path, got {type(self.path).__name__}"
            )
        self._surge = SurgePIController(
            self.gains.k_1p,
            self.gains.k_1i,
            self.gains.u_d,
            float(np.min(self.max_thrust[list(self.surge_thrusters)])),
        )
        self.surge_mask = np.zeros(self.n_thrusters, dtype=np.int64)
        self.surge_mask[list(self.surge_thrusters)] = 1
        self._guidance = laws.new_guidance_state()

    @property
    def gain_record(self) -> laws.PaperGains:
        """The gains as the :class:`aiauv_control.laws.paper_laws.PaperGains` record the compiled
        law takes."""
        g = self.gains
        k_y, k_z = cross_track_gains(g.k_e)[1:]
        return laws.PaperGains(
            u_d=g.u_d,
            k_y=float(k_y),
            k_z=float(k_z),
            k_p=g.k_p,
            k_d=g.k_d,
            k_qp=g.k_qp,
            k_qd=g.k_qd,
            k_1p=g.k_1p,
            k_1i=g.k_1i,
            max_thrust=self._surge.max_thrust,
            q_max=g.q_max,
            exact=g.feedforward == "exact",
            turn_feedforward=g.turn_feedforward,
            turn_rate_gain=g.turn_curvature_gain * g.u_d,
            turn_time_constant=g.turn_time_constant,
            integral_los=g.current_compensation == "integral_los",
            los_integral_gain=g.los_integral_gain,
            hydrostatic_compensation=g.hydrostatic_compensation,
            turn_moment_gain=g.turn_moment_gain,
        )

    @property
    def axis_index(self) -> np.ndarray:
        """Base angle (0: ``q_y0``, 1: ``q_z0``) driving each joint (eq. 22)."""
        return self._axis_index

    @property
    def reference_scale(self) -> np.ndarray:
        """``exp(-alpha (j - 1))`` per joint (eq. 22)."""
        return self._reference_scale

    @property
    def surge_state(self) -> laws.SurgeState:
        """The surge PI's state record (shared with the compiled loop when it runs this controller)."""
        return self._surge.state

    def _check_surge_thrusters(self, surge_thrusters: Sequence[int]) -> tuple[int, ...]:
        indices = tuple(surge_thrusters)
        if (
            not indices
            or any(isinstance(i, bool) or int(i) != i for i in indices)
            or len(set(indices)) != len(indices)
        ):
            raise ValueError(
                f"surge_thrusters: expected distinct integer indices, got {list(indices)}"
            )
        if min(indices) < 0 or max(indices) >= self.n_thrusters:
            raise ValueError(
                f"surge_thrusters: indices must lie in [0, {self.n_thrusters}), got {list(indices)}"
            )
        return tuple(int(i) for i in indices)

    @property
    def n_joints(self) -> int:
        """Number of actuated joints."""
        return len(self.joint_axes)

    def reset(self) -> None:
        """Clear the surge and integral-LOS integrators (and their sampling history)."""
        self._surge.reset()
        for array in self._guidance:
            array[:] = 0.0

    def command(self, t: float, measurement: PathFollowingMeasurement) -> PathFollowingCommand:
        """Joint torques and thrusts at time ``t`` [s] (non-decreasing between calls).

        Raises:
            ValueError: measurement with the wrong number of joints, invalid rotation, time going
                backwards.
        """
        if not isinstance(measurement, PathFollowingMeasurement):
            raise ValueError(
                f"measurement: expected PathFollowingMeasurement, got {type(measurement).__name__}"
            )
        if measurement.joint_positions.shape != (self.n_joints,):
            raise ValueError(
                f"measurement: {measurement.joint_positions.size} joints, "
                f"controller has {self.n_joints}"
            )
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"t must be finite, got {t}")
        if self._surge.state.has_previous[0] and t < self._surge.state.time[0]:
            if True:
                raise ValueError(
                    f"time went backwards: t = {t} < previous {self._surge.state.time[0]}"
                )
        out = laws.new_command_buffers(self.n_joints, self.n_thrusters)
        R_e = check_rotation(measurement.rotation_to_world, "rotation_to_world")
        laws.path_following_command(  # eqs. (21)-(25): aiauv_control.laws.paper_laws.path_following_command
            self.gain_record,
            self.path.user_function,
            self.path.kind_code,
            self.path.params,
            self._axis_index,
            self._reference_scale,
            self.surge_mask,
            self._surge.state,
            self._guidance,
            float(t),
            R_e,
            measurement.position_in_world,
            measurement.velocity_in_world,
            measurement.acceleration_in_world,
            measurement.angular_velocity_in_ee,
            measurement.surge_velocity,
            measurement.joint_positions,
            measurement.joint_velocities,
            measurement.joint_hydrostatic_forces,
            measurement.restoring_moment_in_ee,
            out,
        )
        return PathFollowingCommand(
            joint_torques=out.joint_torques,
            thrusts=out.thrusts,
            phi_tilde=float(out.phi_tilde[0]),
            omega_tilde=out.omega_tilde,
            base_angles=out.base_angles,
            joint_references=out.joint_references,
            x_ref=out.x_ref,
            x_ref_dot=out.x_ref_dot,
            pointing_direction=R_e[:, 0].copy(),
            surge_integral=self._surge.integral,
            x_ref_ddot=out.x_ref_ddot,
            cross_track_error=out.cross_track,
            path_parameter=float(out.path_s[0]),
        )
