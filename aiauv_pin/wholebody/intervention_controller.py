"""Intervention mode: hold (or move) a frame's 6-DOF pose, thrusters and joint motors sharing the work.

A whole-body computed torque in the actuator space with strict task priority
(:mod:`aiauv_control.laws.intervention_laws` holds the laws and their sources):

1. the frame's task: ``J a + J_dot v = a*``, ``a*`` a PID on the pose error plus the reference's
   acceleration (a minimum-jerk move to the target);
2. in the task's null space: low actuator effort (``W_u``) and a body posture (joint PD and base
   damping, ``W_p``).

The accelerations of the free coordinates ``F`` (the base and the joints whose motors share the
task) answer the actuator forces ``w`` (thrusts, then joint torques) through the model:
``a_F = M_FF^-1 (A_F w - b_F) = H w - h``, with ``M`` the mass matrix with the added mass and
``b`` the bias (Coriolis, damping on the velocity relative to the water as the controller believes
it, restoring forces; :meth:`aiauv_pin.model.vehicle.Vehicle.fluid_forces`). Joints that do not
share the task are held by a stiff joint servo (:attr:`InterventionControl.joint_servo`) and taken
as locked (``a = 0``). The task then reads ``G w = r`` with ``G = J_F H`` and
``r = a* - J_dot v + J_F h``; the actuators' limits enter as in
:func:`aiauv_control.laws.intervention_laws.prioritised_actuation_limited`.

Why this and not differential IK (pink) plus a torque loop: the vehicle floats, so the frame's
pose is reached through forces on an underactuated base (the thrusters) and the joints at once;
the computed torque uses the exact model (added mass included) that the simulator integrates, keeps
the priority exact at the level where the actuators act, and handles their limits in the same
solve. An integral term on the pose error takes out what the model does not know (a current).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from aiauv_control.laws.intervention_laws import (
    TASK_AXES,
    minimum_jerk,
    pose_error,
    prioritised_actuation_limited,
    rotation_log,
    secondary_objective,
    task_acceleration,
    unproducible_axes,
)
from aiauv_control.laws.paper_laws import thruster_power as _thruster_power
from aiauv_hydro.currents import as_current
from aiauv_hydro.numerics.jit import interpreted
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
#: The thrusters' mechanical power law, run interpreted (:mod:`aiauv_control.laws.paper_laws`).
thruster_power = interpreted(_thruster_power)


@dataclass(frozen=True)
class InterventionGains:
    """Gains and weights of :class:`InterventionControl` (per axis the same value).

    Attributes:
        stiffness: ``K_p`` of the pose error [1/s^2].
        damping: ``K_d`` of the twist error [1/s].
        integral: ``K_i`` of the pose error's integral [1/s^3] (0: none).
        integral_limit: Largest magnitude of each axis's integral [m s, rad s] (anti-windup).
        posture_stiffness: Joint PD stiffness of the posture in the null space [1/s^2].
        posture_damping: Joint PD damping of the posture [1/s]; the base's velocity is damped
            with the same value.
        thrust_weight: ``W_u`` of each thruster [1/N] (low thrust in the null space).
        joint_weight: ``W_u`` of each joint motor [1/(N m)].
        posture_weight: ``W_p`` of each joint acceleration [s^2/rad].
        base_weight: ``W_p`` of each base acceleration [s^2/m, s^2/rad].
    """

    stiffness: float = 9.0
    damping: float = 6.0
    integral: float = 6.0
    integral_limit: float = 1.0
    posture_stiffness: float = 1.0
    posture_damping: float = 2.0
    thrust_weight: float = 0.02
    joint_weight: float = 0.05
    posture_weight: float = 10.0
    base_weight: float = 1.0

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ArgumentError(f"intervention gain {name} must be a number, got {value!r:.40}")
            if not math.isfinite(value) or value < 0.0:
                raise ArgumentError(
                    f"intervention gain {name} must be finite and >= 0, got {value}"
                )
        for name in ("stiffness", "damping", "thrust_weight", "joint_weight"):
            if not getattr(self, name) > 0.0:
                raise ArgumentError(f"intervention gain {name} must be positive, got 0")


def _limits(values, n: int, name: str) -> np.ndarray:
    array = np.asarray(values, dtype=float).reshape(-1)
    if array.size == 1:
        array = np.full(n, float(array[0]))
    if array.shape != (n,):
        raise ArgumentError(f"{name}: expected {n} limits, got {array.size}")
    bad = np.flatnonzero(~(np.isfinite(array) & (array > 0.0)))
    if bad.size:
        raise ArgumentError(
            f"{name} must be positive and finite, got {array[bad[0]]!r} (entry {bad[0]})"
        )
    return array


def rotation_from_rpy(rpy) -> np.ndarray:
    """``R = R_z(yaw) R_y(pitch) R_x(roll)`` of world-axis roll, pitch, yaw [rad] (URDF's ``rpy``)."""
    return pin.rpy.rpyToMatrix(*np.asarray(rpy, dtype=float))


class InterventionControl:
    """Controller callback for :func:`aiauv_pin.simulate`: hold or move a frame's pose (module
    docstring).

    Args:
        vehicle: The vehicle.
        target_position: Where the frame goes, world [m] (``None``: where it is at the first call).
        target_rotation: Its orientation, a rotation matrix to world (``None``: as at the first call).
        frame: The frame held (a link or frame of the vehicle; ``end_effector`` by default).
        gains: :class:`InterventionGains`.
        posture: Joint angles [rad] of the posture held in the null space (``None``: the angles at
            the first call).
        shared_joints: Whether the joint motors share the task (``False``: the joints are locked
            by :attr:`joint_servo` at ``posture``, thrusters alone hold the frame).
        axes: The task axes (names of :data:`aiauv_control.laws.intervention_laws.TASK_AXES`); the
            others are left free.
        move_time: Duration [s] of the minimum-jerk move from the frame's pose at the first call to
            the target (0: a step).
        current: The water velocity the model assumes (world, [m/s]; ``None``: still water, the
            integral term then takes out a current).
        thrust_limit: Largest thrust magnitude of each thruster [N] (default: the vehicle's).
        joint_torque_limit: Largest torque magnitude of each joint motor [N m] (default: the URDF's
            effort limits).
        servo_stiffness: Locked joints' PD stiffness [N m/rad] (``shared_joints=False``).
        servo_damping: Locked joints' PD damping [N m s/rad].

    Raises:
        ArgumentError: An unknown frame or axis, a non-positive limit, a bad gain (one line).
    """

    def __init__(
        self,
        vehicle: Vehicle,
        target_position=None,
        target_rotation=None,
        *,
        frame: str = "end_effector",
        gains: InterventionGains | None = None,
        posture=None,
        shared_joints: bool = True,
        axes=TASK_AXES,
        move_time: float = 0.0,
        current=None,
        thrust_limit=None,
        joint_torque_limit=None,
        servo_stiffness: float = 2000.0,
        servo_damping: float = 400.0,
    ) -> None:
        self.vehicle = vehicle
        model = vehicle.model
        if not isinstance(frame, str) or not model.existFrame(frame):
            raise ArgumentError(
                f"intervention: frame {frame!r:.80} does not exist in vehicle '{vehicle.name}'"
            )
        self.frame = frame
        self._frame_id = model.getFrameId(frame)
        self.gains = InterventionGains() if gains is None else gains
        if not isinstance(self.gains, InterventionGains):
            raise ArgumentError("intervention: gains must be an InterventionGains")
        axes = tuple(axes)
        unknown = [a for a in axes if a not in TASK_AXES]
        if unknown or not axes or len(set(axes)) != len(axes):
            raise ArgumentError(
                f"intervention: axes must be distinct names among {', '.join(TASK_AXES)}, "
                f"got {axes!r:.80}"
            )
        self.axes = tuple(a for a in TASK_AXES if a in axes)
        self._rows = np.array([TASK_AXES.index(a) for a in self.axes])
        self.target_position = None if target_position is None else self._vector(target_position)
        self.target_rotation = None
        if target_rotation is not None:
            R = np.asarray(target_rotation, dtype=float)
            if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6):
                raise ArgumentError("intervention: target_rotation must be a 3x3 rotation matrix")
            self.target_rotation = R
        self.move_time = float(move_time)
        if not (math.isfinite(self.move_time) and self.move_time >= 0.0):
            raise ArgumentError(f"intervention: move_time must be >= 0 s, got {move_time!r}")
        n_joints = vehicle.nv - 6
        self.posture = None
        if posture is not None:
            self.posture = np.asarray(posture, dtype=float).reshape(-1)
            if self.posture.shape != (n_joints,) or not np.all(np.isfinite(self.posture)):
                raise ArgumentError(f"intervention: posture must be {n_joints} finite joint angles")
        self.shared_joints = bool(shared_joints)
        self.current = as_current(current)
        m = len(vehicle.hydro.thrusters)
        self.thrust_limit = _limits(
            vehicle.max_thrust if thrust_limit is None else thrust_limit, m, "thrust_limit"
        )
        self.joint_dofs = tuple(range(6, vehicle.nv)) if self.shared_joints else ()
        self.joint_torque_limit = _limits(
            # a URDF without effort limits: Pinocchio's "none" (the largest float) as 1e9 N m
            np.minimum(model.effortLimit[6:], 1e9)
            if joint_torque_limit is None
            else joint_torque_limit,
            n_joints,
            "joint_torque_limit",
        )
        self.free = np.array((*range(6), *self.joint_dofs), dtype=int)
        self.joint_servo = None
        if not self.shared_joints:
            self.joint_servo = JointServo.uniform(n_joints, servo_stiffness, servo_damping)
        self.lower = -np.concatenate(
            [self.thrust_limit, self.joint_torque_limit[: len(self.joint_dofs)]]
        )
        self.upper = -self.lower
        self._data = model.createData()
        self.reset()

    @staticmethod
    def _vector(value) -> np.ndarray:
        array = np.asarray(value, dtype=float).reshape(-1)
        if array.shape != (3,) or not np.all(np.isfinite(array)):
            raise ArgumentError("intervention: target_position must be 3 finite numbers [m]")
        return array

    def reset(self) -> None:
        """Forget the start (the first call sets it again) and the integral."""
        self._start = None
        self._integral = np.zeros(6)
        self._last_t = None

    def retarget(self, t: float, position, rotation, move_time: float | None = None) -> None:
        """Move to a new target from the reference's pose at ``t`` (a new minimum-jerk move)."""
        p, R, _, _ = self.reference(t) if self._start is not None else (None, None, None, None)
        self.target_position = self._vector(position)
        self.target_rotation = np.asarray(rotation, dtype=float)
        if move_time is not None:
            self.move_time = float(move_time)
        if p is not None:
            self._start = (t, p, R)

    def _kinematics(self, q, v):
        model, data = self.vehicle.model, self._data
        pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        pose = data.oMf[self._frame_id]
        jacobian = pin.getFrameJacobian(model, data, self._frame_id, _LWA)
        drift = pin.getFrameClassicalAcceleration(model, data, self._frame_id, _LWA).vector
        return pose.rotation.copy(), pose.translation.copy(), jacobian, drift

    def _start_at(self, t: float, q: np.ndarray) -> None:
        rotation, position, _, _ = self._kinematics(q, np.zeros(self.vehicle.nv))
        if self.target_position is None:
            self.target_position = position.copy()
        if self.target_rotation is None:
            self.target_rotation = rotation.copy()
        if self.posture is None:
            self.posture = np.asarray(q[7:], dtype=float).copy()
        if self.joint_servo is not None:
            self.joint_servo.references[:] = self.posture
        self._start = (float(t), position, rotation)

    def reference(self, t: float):
        """``(p_ref, R_ref, twist_ref, acceleration_ref)`` of the move at ``t`` (world axes)."""
        t0, p0, R0 = self._start
        rotation_step = R0.T @ self.target_rotation
        axis_angle = R0 @ rotation_log(rotation_step)  # world axes
        if self.move_time > 0.0:
            s, ds, dds = minimum_jerk((t - t0) / self.move_time)
            ds, dds = ds / self.move_time, dds / self.move_time**2
        else:
            s, ds, dds = 1.0, 0.0, 0.0
        delta = self.target_position - p0
        position = p0 + s * delta
        rotation = pin.exp3(s * axis_angle) @ R0
        twist = np.concatenate([ds * delta, ds * axis_angle])
        acceleration = np.concatenate([dds * delta, dds * axis_angle])
        return position, rotation, twist, acceleration

    def task_matrices(self, q, v, t: float = 0.0):
        """``(G, r_offset, H, h, J, drift, pose)`` of the model at ``(q, v)`` (module docstring):
        the task's actuator matrix over the task axes, ``- J_dot v + J_F h`` on them, the
        free-coordinate response ``H`` and offset ``h``, the full Jacobian and ``J_dot v``."""
        vehicle = self.vehicle
        forces = vehicle.fluid_forces(q, v, self.current, t=t)
        mass, bias = forces.mass_matrix, forces.bias
        B = vehicle.thrust_matrix(q)
        n = vehicle.nv
        actuators = np.zeros((n, B.shape[1] + len(self.joint_dofs)))
        actuators[:, : B.shape[1]] = B
        for c, d in enumerate(self.joint_dofs):
            actuators[d, B.shape[1] + c] = 1.0
        F = self.free
        mass_ff = mass[np.ix_(F, F)]
        response = np.linalg.solve(mass_ff, actuators[F])
        offset = np.linalg.solve(mass_ff, bias[F])
        rotation, position, jacobian, drift = self._kinematics(q, v)
        j_task = jacobian[self._rows][:, F]
        G = j_task @ response
        r_offset = -drift[self._rows] + j_task @ offset
        return G, r_offset, response, offset, jacobian, drift, (rotation, position)

    def check(self, q: np.ndarray) -> None:
        """Raise if the actuators cannot produce some task axis at ``q`` (one line naming them)."""
        q = np.asarray(q, dtype=float)
        G = self.task_matrices(q, np.zeros(self.vehicle.nv))[0]
        missing = [self.axes[i] for i in unproducible_axes(G)]
        if missing:
            who = "thrusters and joints" if self.shared_joints else "thrusters (joints locked)"
            raise ArgumentError(
                f"intervention: the {who} of '{self.vehicle.name}' cannot move frame "
                f"'{self.frame}' along {', '.join(missing)} in this configuration; bend the body "
                f"(posture) or leave {'it' if len(missing) == 1 else 'them'} out of the task axes"
            )

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray):
        if self._start is None:
            self.check(q)
            self._start_at(t, q)
        gains = self.gains
        G, r_offset, H, h, jacobian, _, (rotation, position) = self.task_matrices(q, v, t)
        p_ref, R_ref, twist_ref, accel_ref = self.reference(t)
        error = pose_error(rotation, position, R_ref, p_ref)
        twist = jacobian @ v
        dt = 0.0 if self._last_t is None else max(0.0, float(t) - self._last_t)
        self._last_t = float(t)
        limit = gains.integral_limit
        self._integral = np.clip(self._integral + dt * error, -limit, limit)
        desired = task_acceleration(
            error,
            twist_ref - twist,
            self._integral,
            accel_ref,
            gains.stiffness,
            gains.damping,
            gains.integral,
        )
        # posture in the null space: joint PD towards the posture, base damped
        vf = v[self.free]
        posture_acc = -gains.posture_damping * vf
        n_shared = len(self.joint_dofs)
        if n_shared:
            posture_acc[6:] += gains.posture_stiffness * (self.posture - q[7:])
        m = len(self.thrust_limit)
        actuator_weights = np.concatenate(
            [np.full(m, gains.thrust_weight), np.full(n_shared, gains.joint_weight)]
        )
        posture_weights = np.concatenate(
            [np.full(6, gains.base_weight), np.full(n_shared, gains.posture_weight)]
        )
        hessian, linear = secondary_objective(H, h, posture_acc, actuator_weights, posture_weights)
        w, limited = prioritised_actuation_limited(
            G, desired[self._rows] + r_offset, hessian, linear, self.lower, self.upper
        )
        thrusts = w[:m]
        thrust_matrix = self.vehicle.thrust_matrix(q)
        tau = thrust_matrix @ thrusts  # A w on every coordinate
        for c, d in enumerate(self.joint_dofs):
            tau[d] += w[m + c]
        span = self.upper - self.lower
        saturated = (w <= self.lower + 1e-6 * span) | (w >= self.upper - 1e-6 * span)
        info = {
            "p": position,
            "pose_error": error,
            "position_error": float(np.linalg.norm(error[:3])),
            "attitude_error": float(np.linalg.norm(error[3:])),
            "thrust": thrusts.copy(),
            # mechanical power of each thruster (the paper controller's definition)
            "thruster_power": thruster_power(v @ thrust_matrix, thrusts),
            "saturated": float(np.count_nonzero(saturated)),
            "limited": float(limited),
        }
        if n_shared:
            info["joint_torque"] = w[m:].copy()
        return tau, info
