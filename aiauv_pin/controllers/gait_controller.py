"""Serpentine gaits (:mod:`aiauv_control.laws.gait_laws`) wired to a vehicle.

:class:`Gait` holds a gait's parameters (checked on their own); :class:`VehicleGait` checks them
against a vehicle (the joint limits) and builds the compiled controller
(:func:`aiauv_pin.controllers.gait_compiled.serpentine_gait`). The yaw joints (about a link's z axis)
undulate; the pitch joints are held straight by the joint servo, or keep the depth
(``depth = "joints"``: vertical LOS and a saturated PD spread over them by eq. 22); thrusters stay
idle, or in the combined mode (``thrust = "surge"``) the X thrusters push with the paper's surge PI
(eq. 25), and with ``depth = "thrusters"`` the vertical thrusters keep the depth by a PI (see
:mod:`aiauv_control.laws.gait_laws`).

A run in Python::

    import numpy as np, aiauv_pin
    from aiauv_pin.controllers.gait_controller import Gait, VehicleGait
    from aiauv_control.path_following import PathFollowingGains

    vehicle = aiauv_pin.load_vehicle()
    gait = VehicleGait(vehicle, Gait("lateral_undulation", amplitude=0.5, omega=1.5, delta=0.7),
                       PathFollowingGains(k_qp=400.0, k_qd=40.0))
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    trajectory = aiauv_pin.simulate(vehicle, q0, v0, 60.0, 0.01, gait.compiled(),
                                    servo=gait.joint_servo)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aiauv_control.guidance import X_AXIS
from aiauv_control.joint_references import joint_reference_pattern
from aiauv_control.laws.gait_laws import (
    DEPTH_MODES,
    GAIT_KINDS,
    STRAIGHT_JOINT,
    GaitGains,
    gait_envelope,
    new_gait_buffers,
)
from aiauv_control.laws.paper_laws import new_guidance_state, new_surge_state
from aiauv_control.path_following import DEFAULT_LOS_INTEGRAL_GAIN, PathFollowingGains
from aiauv_control.paths import Path
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.controllers.gait_compiled import (
    GaitInfo,
    GaitParameters,
    GaitState,
    gait_info_shapes,
    serpentine_gait,
)
from aiauv_pin.controllers.info_rows import info_offsets
from aiauv_pin.controllers.paper_controller import joint_axis_labels, surge_thruster_indices
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle

#: How the thrusters take part: idle, or the X thrusters push with the surge PI (combined mode).
THRUST_MODES = ("none", "surge")


def _positive(name: str, value, *, zero: bool = False) -> float:
    value = float(value)
    if not (math.isfinite(value) and (value >= 0.0 if zero else value > 0.0)):
        relation = ">= 0" if zero else "> 0"
        raise ArgumentError(f"gait.{name} must be a finite number {relation}, got {value!r}")
    return value


@dataclass(frozen=True)
class Gait:
    """A serpentine gait and its steering (Kelasidi 2017; see :mod:`aiauv_control.laws.gait_laws`).

    Attributes:
        kind: ``"lateral_undulation"`` (``g(i) = 1``) or ``"eel_like"``
            (``g(i) = (n - i) / (n + 1)``): the head-to-tail amplitude envelope.
        amplitude: ``alpha`` [rad].
        omega: Angular frequency of the gait [rad/s] (> 0).
        delta: Phase offset between neighbouring undulating joints [rad].
        k_theta: Gain of the heading controller ``phi_0 = k_theta (theta_bar - theta_ref)`` [-].
        max_offset: Saturation of ``phi_0`` [rad].
        lookahead: LOS lookahead distance ``Delta`` [m]; ``None``: twice the vehicle's length.
        integral_los: Integral LOS (against currents) instead of LOS.
        los_integral_gain: ``sigma`` of the integral LOS [-].
        thrust: ``"none"`` (thrusters idle) or ``"surge"`` (combined mode: the X thrusters hold the
            speed ``u_d`` of the controller gains with the surge PI).
        depth: Depth keeping: ``"none"``, ``"joints"`` (the pitch joints; their pattern's
            ``alpha`` and saturation ``q_max`` are the controller gains') or ``"thrusters"`` (the
            vertical thrusters).
        depth_gain: ``k_v`` of the pitch PD, base angle per rad of elevation error [-].
        depth_damping: Its derivative time ``T_v`` [s].
        depth_lookahead: Vertical LOS lookahead ``Delta_v`` [m]; ``None``: the gait's lookahead.
        depth_kp: Proportional gain of the thrusters' depth PI [N/m].
        depth_ki: Its integral gain [N/(m s)].
    """

    kind: str = "lateral_undulation"
    amplitude: float = math.radians(30.0)
    omega: float = 1.0
    delta: float = math.radians(40.0)
    k_theta: float = 0.5
    max_offset: float = math.radians(20.0)
    lookahead: float | None = None
    integral_los: bool = False
    los_integral_gain: float = DEFAULT_LOS_INTEGRAL_GAIN
    thrust: str = "none"
    depth: str = "none"
    depth_gain: float = 2.0
    depth_damping: float = 0.0
    depth_lookahead: float | None = None
    depth_kp: float = 5.0
    depth_ki: float = 0.1

    def __post_init__(self) -> None:
        if self.kind not in GAIT_KINDS:
            raise ArgumentError(
                f"gait.kind must be one of {', '.join(GAIT_KINDS)}, got {self.kind!r:.40}"
            )
        if self.thrust not in THRUST_MODES:
            raise ArgumentError(
                f"gait.thrust must be one of {', '.join(THRUST_MODES)}, got {self.thrust!r:.40}"
            )
        object.__setattr__(self, "amplitude", _positive("amplitude", self.amplitude, zero=True))
        object.__setattr__(self, "omega", _positive("omega", self.omega))
        delta = float(self.delta)
        if not math.isfinite(delta):
            raise ArgumentError(f"gait.delta must be finite, got {delta!r}")
        object.__setattr__(self, "delta", delta)
        object.__setattr__(self, "k_theta", _positive("k_theta", self.k_theta, zero=True))
        object.__setattr__(self, "max_offset", _positive("max_offset", self.max_offset, zero=True))
        if self.lookahead is not None:
            object.__setattr__(self, "lookahead", _positive("lookahead", self.lookahead))
        object.__setattr__(
            self, "los_integral_gain", _positive("los_integral_gain", self.los_integral_gain)
        )
        if self.depth not in DEPTH_MODES:
            raise ArgumentError(
                f"gait.depth must be one of {', '.join(DEPTH_MODES)}, got {self.depth!r:.40}"
            )
        for name in ("depth_gain", "depth_damping", "depth_kp", "depth_ki"):
            object.__setattr__(self, name, _positive(name, getattr(self, name), zero=True))
        if self.depth_lookahead is not None:
            object.__setattr__(
                self, "depth_lookahead", _positive("depth_lookahead", self.depth_lookahead)
            )


def pitch_joint_scale(vehicle: Vehicle, alpha: float) -> np.ndarray:
    """Per joint: eq. (22)'s signed scale ``sign exp(-alpha (j - 1))`` for the pitch (y-axis)
    joints, ``j`` counted from the tail among them, and 0 for the others
    (:func:`aiauv_control.joint_references.joint_reference_pattern`)."""
    labels = joint_axis_labels(vehicle)
    _, scale = joint_reference_pattern(labels, alpha)
    return np.array([s if label[1] == "y" else 0.0 for s, label in zip(scale, labels, strict=True)])


def heave_thruster_signs(vehicle: Vehicle) -> np.ndarray:
    """Per thruster: the sign of its axis if it pushes along its link's z-axis, else 0."""
    return np.array(
        [
            math.copysign(1.0, t.direction[2]) if abs(t.direction[2]) > 0.999 else 0.0
            for t in vehicle.hydro.thrusters
        ]
    )


def undulating_joints(vehicle: Vehicle) -> tuple[np.ndarray, np.ndarray]:
    """Per joint: its index among the yaw (z-axis) joints counted from the tail (1-based; 0 for a
    joint held straight) and the sign of its axis (+1 about +z)."""
    labels = joint_axis_labels(vehicle)
    index = np.full(len(labels), STRAIGHT_JOINT, dtype=np.int64)
    sign = np.ones(len(labels))
    count = 0
    for j, label in enumerate(labels):  # signed: "+z", "-z", ...
        if label[1] != "z":
            continue
        count += 1
        index[j] = count
        if label[0] == "-":
            sign[j] = -1.0
    return index, sign


class VehicleGait:
    """Controller for :func:`aiauv_pin.simulate`: a steered serpentine gait (compiled).

    Args:
        vehicle: The vehicle (numba backend), with at least two yaw joints.
        gait: The gait (:class:`Gait`).
        gains: Joint servo (``k_qp``, ``k_qd``) and, in combined mode, surge (``u_d``, ``k_1p``,
            ``k_1i``) gains.
        path: The path (default: the world x-axis).

    Raises:
        ArgumentError: The vehicle cannot swim this gait: fewer than two yaw joints, a reference
            beyond a joint's limit (``alpha max g(i) + phi_0_max``), combined mode without X
            thrusters, or not on the numba backend.
    """

    continuous_joints = True

    def __init__(
        self,
        vehicle: Vehicle,
        gait: Gait | None = None,
        gains: PathFollowingGains | None = None,
        *,
        path: Path | None = None,
    ) -> None:
        if vehicle.fast is None:
            raise ArgumentError(
                f"gaits run compiled only; the vehicle runs on {vehicle.active_backend}"
            )
        self.vehicle = vehicle
        self.gait = gait if gait is not None else Gait()
        self.gains = gains if gains is not None else PathFollowingGains()
        self.path = path if path is not None else X_AXIS
        self.tail_index, self.joint_sign = undulating_joints(vehicle)
        undulating = int(np.count_nonzero(self.tail_index))
        if undulating < 2:
            raise ArgumentError(
                f"a gait needs at least two yaw (z-axis) joints; the vehicle has {undulating}"
            )
        self.n_links = undulating + 1
        kind = GAIT_KINDS[self.gait.kind]
        upper = np.asarray(vehicle.model.upperPositionLimit)[7:]
        lower = np.asarray(vehicle.model.lowerPositionLimit)[7:]
        for j in np.flatnonzero(self.tail_index):
            g = gait_envelope(kind, int(self.tail_index[j]), self.n_links)
            largest = self.gait.amplitude * g + self.gait.max_offset
            limit = min(upper[j], -lower[j])
            if largest > limit:
                raise ArgumentError(
                    f"gait: amplitude {self.gait.amplitude:.4g} rad x g = {g:.3g} plus max_offset "
                    f"{self.gait.max_offset:.4g} rad = {largest:.4g} rad exceeds the limit "
                    f"{limit:.4g} rad of joint '{vehicle.joint_names[j]}'"
                )
        self.surge_mask = np.zeros(len(vehicle.hydro.thrusters))
        surge = surge_thruster_indices(vehicle)
        if self.gait.thrust == "surge":
            if not surge:
                raise ArgumentError("gait.thrust = 'surge' needs thrusters along a link x-axis")
            self.surge_mask[surge] = 1.0
        if self.gait.lookahead is not None:
            lookahead = self.gait.lookahead
        else:
            lookahead = 2.0 * vehicle_length(vehicle)
        depth = DEPTH_MODES[self.gait.depth]
        self.pitch_scale = np.zeros(len(self.tail_index))
        self.heave_sign = np.zeros(len(vehicle.hydro.thrusters))
        if self.gait.depth == "joints":
            self.pitch_scale = pitch_joint_scale(vehicle, self.gains.alpha)
            if not np.any(self.pitch_scale):
                raise ArgumentError("gait.depth = 'joints' needs pitch (y-axis) joints")
        elif self.gait.depth == "thrusters":
            self.heave_sign = heave_thruster_signs(vehicle)
            if not np.any(self.heave_sign):
                raise ArgumentError("gait.depth = 'thrusters' needs thrusters along a link z-axis")
        depth_lookahead = self.gait.depth_lookahead
        if depth_lookahead is None:
            depth_lookahead = lookahead
        self.gait_gains = GaitGains(
            kind=kind,
            amplitude=self.gait.amplitude,
            omega=self.gait.omega,
            delta=self.gait.delta,
            k_theta=self.gait.k_theta,
            max_offset=self.gait.max_offset,
            lookahead=float(lookahead),
            integral=bool(self.gait.integral_los),
            sigma=self.gait.los_integral_gain,
            surge=self.gait.thrust == "surge",
            u_d=self.gains.u_d,
            k_1p=self.gains.k_1p,
            k_1i=self.gains.k_1i,
            max_thrust=float(np.min(vehicle.max_thrust)) if len(vehicle.max_thrust) else 0.0,
            depth=depth,
            depth_gain=self.gait.depth_gain,
            depth_damping=self.gait.depth_damping,
            depth_lookahead=float(depth_lookahead),
            alpha=float(self.gains.alpha),
            q_max=float(self.gains.q_max),
            depth_kp=self.gait.depth_kp,
            depth_ki=self.gait.depth_ki,
        )
        n = vehicle.nv - 6
        self.joint_servo = JointServo.uniform(n, self.gains.k_qp, self.gains.k_qd)
        masses, centres = [], []
        for inertia in list(vehicle.model.inertias)[1:]:
            masses.append(inertia.mass)
            centres.append(np.asarray(inertia.lever, dtype=float))
        self.link_mass = np.array(masses)
        self.link_centre = np.ascontiguousarray(np.reshape(centres, (-1, 3)))

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics."""
        return gait_info_shapes(self.vehicle.nv - 6, len(self.vehicle.hydro.thrusters))

    def compiled(self) -> CompiledController:
        """This controller for the compiled loop (a fresh state)."""
        parameters = GaitParameters(
            gains=self.gait_gains,
            path_function=self.path.user_function,
            path_kind=self.path.kind_code,
            path_parameters=self.path.params,
            tail_index=self.tail_index,
            joint_sign=self.joint_sign,
            n_links=self.n_links,
            surge_mask=self.surge_mask,
            link_mass=self.link_mass,
            link_centre=self.link_centre,
            servo_references=self.joint_servo.references,
            joint_stiffness=self.joint_servo.stiffness,
            joint_damping=self.joint_servo.damping,
            pitch_scale=self.pitch_scale,
            heave_sign=self.heave_sign,
            info=info_offsets(self.info_shapes(), GaitInfo),
        )
        state = GaitState(
            surge=new_surge_state(),
            guidance=new_guidance_state(),
            command=new_gait_buffers(self.vehicle.nv - 6, len(self.vehicle.hydro.thrusters)),
            depth=new_surge_state(),
        )

        def reset() -> None:
            for array in (*state.surge, *state.guidance, *state.depth):
                array[:] = 0.0
            self.joint_servo.references[:] = 0.0

        return CompiledController(
            serpentine_gait, parameters, state, self.info_shapes(), self.joint_servo, reset
        )


def vehicle_length(vehicle: Vehicle) -> float:
    """Length of the straight vehicle [m]: the extent along the base x-axis of its link origins
    and of its tip frame, in the neutral configuration."""
    import pinocchio as pin

    q = vehicle.neutral_configuration()
    data = vehicle.model.createData()
    pin.framesForwardKinematics(vehicle.model, data, q)
    xs = [float(f.translation[0]) for f in data.oMf]
    return max(xs) - min(xs)
