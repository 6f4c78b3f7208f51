"""Station keeping of any vehicle: hold the pose of a frame (the base or a named frame) with the
thrusters, computed torque on the vehicle's model, thrust allocation with each thruster's limits.

The laws are :mod:`aiauv_control.laws.station_laws` (computed torque ``tau = M a_d + n`` with a
PID outer loop, and why); the allocation is :mod:`aiauv_control.allocation` (weighted least
squares with limits, the compiled active-set allocator). Here they get their measurements and
actuators:

* the frame's pose and twist (frame axes), from ``q`` and ``v`` (the base) or the vehicle's
  kinematics (a named frame, e.g. ``end_effector`` or ``camera``);
* ``M(q)`` and the bias ``n(q, v)`` from :meth:`aiauv_pin.Vehicle.fluid_forces` (rigid and added
  mass with every coupling, Coriolis, damping, restoring; with the current the controller is told
  of, or still water: then the integral rejects the current);
* joints (an articulated vehicle) are held at their references by the joint servo (the paper's
  eq. 24, :class:`aiauv_pin.dynamics.joint_servo.JointServo`), so the base and the frame move as
  one rigid body: the frame's twist is ``X nu_b`` with ``X`` the base columns of the frame's
  Jacobian, constant while the joints hold, and the base acceleration is ``X^-1 a_d``;
* the base wrench ``M_bb X^-1 a_d + n_b`` goes to the thrusters (the base rows of ``B(q)``); what
  they cannot produce is the residual, logged, and while a thruster is at a limit the integral is
  frozen (conditional integration);
* thrusters with a first-order lag or a rate limit (UUV Simulator's ``FirstOrder`` thruster
  dynamics, RexROV's 0.05 s) follow the allocated command through
  :func:`aiauv_hydro.laws.actuators.actuator_response`, the law the compiled loop applies
  (:func:`aiauv_pin.kernels.articulated_body.actuators_into`), over ``actuator_period`` (the
  interval each command is held: the scenario's control period), the thrust reached held over
  that interval (logged as ``thrust_produced``; ``thrust`` is the command).

Runs as a Python controller (``controller(t, q, v) -> (tau, info)``, either backend) calling the
compiled allocator; nothing is compiled per run.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from aiauv_control.allocation import (
    AllocationParameters,
    allocate_compiled,
    workspace,
)
from aiauv_control.laws.station_laws import (
    AXIS_NAMES,
    PidGains,
    computed_wrench,
    integrate_error,
    pid_gains,
    pose_error,
    station_acceleration,
    unproducible_axes,
)
from aiauv_hydro.laws.actuators import actuator_response
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle

#: Default natural frequency of station keeping [rad/s]: stiff enough against the destabilising
#: Munk moment of an ROV in a current the model is not told of (docs/source/station_keeping.md).
DEFAULT_OMEGA = 2.0
#: Default joint servo gains (the paper's eq. 24 defaults) [N m/rad], [N m s/rad].
DEFAULT_JOINT_STIFFNESS = 30.0
DEFAULT_JOINT_DAMPING = 50.0
#: Force weight of an axis that is not held (relative to 1 on the held axes) [-].
FREE_AXIS_WEIGHT = 1e-3


def held_axes(axes) -> np.ndarray:
    """The mask (6,) of the named axes (:data:`~aiauv_control.laws.station_laws.AXIS_NAMES`)."""
    if isinstance(axes, str) or not all(isinstance(a, str) for a in axes):
        raise ArgumentError(f"axes: expected a list of names from {AXIS_NAMES}, got {axes!r:.80}")
    unknown = [a for a in axes if a not in AXIS_NAMES]
    if unknown or not axes:
        raise ArgumentError(
            f"axes: expected one or more of {', '.join(AXIS_NAMES)}, got {list(axes)!r:.80}"
        )
    return np.array([name in axes for name in AXIS_NAMES])


def checked_gains(gains: PidGains, what: str, *, proportional: bool) -> PidGains:
    """``gains`` as (6,) float arrays; non-positive (or non-finite) gains refused in one line."""
    out = {}
    for name in ("k_p", "k_d", "k_i"):
        value = np.broadcast_to(np.asarray(getattr(gains, name), dtype=float), (6,)).copy()
        if not np.all(np.isfinite(value)):
            raise ArgumentError(f"{what}: {name} must be finite, got {value.tolist()}")
        must_be_positive = name == "k_d" or (name == "k_p" and proportional)
        if must_be_positive and not np.all(value > 0):
            raise ArgumentError(f"{what}: {name} must be positive, got {value.tolist()}")
        if not np.all(value >= 0):
            raise ArgumentError(f"{what}: {name} must be >= 0, got {value.tolist()}")
        out[name] = value
    return PidGains(**out)


class ModelBasedBody:
    """What station keeping and velocity control share: the frame, the model's wrench, the
    allocation, the joint servo and the info row (see the module docstring).

    Args:
        vehicle: The vehicle (either backend).
        frame: A link or frame name whose pose/twist is controlled; ``None``: the base.
        axes: The axes held (names of :data:`AXIS_NAMES`); the others are left free.
        thrust_limits: Per-thruster limit [N] (m,), positive; ``None``: the vehicle's.
        current: The current the model is told of (``None``: still water assumed).
        joint_references: Joint angles the servo holds (n,) [rad]; ``None``: zero.
        joint_stiffness, joint_damping: Servo gains (eq. 24) [N m/rad], [N m s/rad].
        what: The controller's name in messages.
        q_check: Configuration at which the actuators are checked against the held axes.
        actuator_period: Interval each thrust command is held [s] (the control period): needed
            when the vehicle's thrusters have a lag or a rate limit, ignored otherwise.
    """

    continuous_joints = True
    #: The simulation loop may run this Python controller on a vehicle whose thrusters have
    #: dynamics (it carries their state; fins stay at zero angle, as for any Python controller).
    handles_thruster_dynamics = True

    def __init__(
        self,
        vehicle: Vehicle,
        *,
        frame: str | None,
        axes,
        thrust_limits,
        current,
        joint_references,
        joint_stiffness: float,
        joint_damping: float,
        what: str,
        q_check=None,
        actuator_period: float | None = None,
    ) -> None:
        self.vehicle = vehicle
        self.what = what
        self.held = held_axes(tuple(axes))
        if frame is None:
            self.frame_name, self.frame = None, None
        else:
            if not isinstance(frame, str) or not vehicle.model.existFrame(frame):
                names = sorted({f.name for f in vehicle.model.frames} - {"universe", "root_joint"})
                raise ArgumentError(
                    f"{what}: unknown frame {frame!r:.60} (frames: {', '.join(names)[:200]})"
                )
            self.frame_name, self.frame = frame, vehicle.model.getFrameId(frame)
        m = len(vehicle.hydro.thrusters)
        if m == 0:
            raise ArgumentError(f"{what}: the vehicle has no thrusters")
        limits = vehicle.max_thrust if thrust_limits is None else thrust_limits
        limits = np.asarray(limits, dtype=float).reshape(-1)
        if limits.shape != (m,) or not np.all(np.isfinite(limits)) or not np.all(limits > 0):
            raise ArgumentError(
                f"{what}: thrust limits must be {m} positive numbers [N], got {limits.tolist()}"
            )
        self.thrust_limits = limits
        thrusters = vehicle.hydro.thrusters
        self.dynamic = any(t.time_constant > 0.0 or t.max_rate != np.inf for t in thrusters)
        if self.dynamic and not (
            actuator_period is not None and np.isfinite(actuator_period) and actuator_period > 0
        ):
            raise ArgumentError(
                f"{what}: the thrusters have a lag or a rate limit: give actuator_period, the "
                f"interval each command is held [s], got {actuator_period!r:.40}"
            )
        self.actuator_period = actuator_period
        self.thrust_produced = np.zeros(m)
        n = vehicle.nv - 6
        references = np.zeros(n) if joint_references is None else joint_references
        references = np.asarray(references, dtype=float).reshape(-1)
        if references.shape != (n,) or not np.all(np.isfinite(references)):
            raise ArgumentError(f"{what}: joint_references must be {n} finite angles [rad]")
        for name, value in (("joint_stiffness", joint_stiffness), ("joint_damping", joint_damping)):
            if not (np.isfinite(value) and value > 0):
                raise ArgumentError(f"{what}: {name} must be positive, got {value!r}")
        self.joint_servo = JointServo.uniform(n, joint_stiffness, joint_damping) if n else None
        if self.joint_servo is not None:
            self.joint_servo.references[:] = references
        self.current = current
        q = vehicle.neutral_configuration() if q_check is None else np.asarray(q_check, float)
        if n:
            q = q.copy()
            q[7:] = references
        B = vehicle.thrust_matrix(q)[:6] @ np.diag(limits)
        # the thrusters' wrench at the frame, frame axes: w_f = X^-T w_b (X^T w_f = w_b)
        missing = unproducible_axes(np.linalg.solve(self._to_frame(q).T, B), self.held)
        if missing:
            rank = int(np.linalg.matrix_rank(B, tol=1e-9 * max(np.abs(B).max(), 1e-300)))
            kept = [a for a, h in zip(AXIS_NAMES, self.held, strict=True) if h]
            kept = [a for a in kept if a not in missing]
            raise ArgumentError(
                f"{what}: the thrusters cannot produce {', '.join(missing)} (thrust matrix rank "
                f"{rank} of 6); hold fewer axes, e.g. axes = {kept}"
            )
        weights = np.where(self.held, 1.0, FREE_AXIS_WEIGHT)
        self.allocation = AllocationParameters(
            thrust_min=tuple(-limits), thrust_max=tuple(limits), force_weights=tuple(weights)
        )
        self._work = workspace(m)
        self.integral = np.zeros(6)
        self._last_t: float | None = None

    # ------------------------------------------------------------------ measurement
    def _to_frame(self, q) -> np.ndarray:
        """``X`` (6, 6): the frame's twist (frame axes) per base twist, joints held."""
        if self.frame is None:
            return np.eye(6)
        model, data = self.vehicle.model, self.vehicle.data
        jac = pin.computeFrameJacobian(model, data, np.asarray(q, float), self.frame, pin.LOCAL)
        return jac[:, :6].copy()

    def measure(self, q, v):
        """``(R, p, twist, X)``: the frame's rotation to world, position [m], twist in its axes
        (v, omega) [m/s, rad/s] and ``X`` (:meth:`_to_frame`)."""
        if self.frame is None:
            x, y, z, w = q[3:7]
            rotation = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
            return rotation, np.array(q[:3], dtype=float), np.array(v[:6], dtype=float), np.eye(6)
        rotation, position, twist = self.vehicle.frame_motion(q, v, self.frame)
        return rotation, position, twist, self._to_frame(q)

    # ------------------------------------------------------------------ action
    def act(self, t: float, q, v, frame_acceleration, error):
        """The base wrench for the frame acceleration ``a_d`` (frame axes), its allocation, the
        integral advanced by ``error``; returns ``(tau (nv,), wrench (6,), result)``."""
        q = np.asarray(q, dtype=float)
        v = np.asarray(v, dtype=float)
        _, _, _, X = self.measure(q, v)
        forces = self.vehicle.fluid_forces(q, v, self.current, t=t)
        base_acceleration = np.linalg.solve(X, frame_acceleration)
        wrench = computed_wrench(forces.mass_matrix[:6, :6], base_acceleration, forces.bias[:6])
        B = self.vehicle.thrust_matrix(q)
        result = allocate_compiled(B[:6], wrench, self.allocation, self._work)
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        frozen = bool(result.saturated.any())
        self.integral = integrate_error(self.integral, error, dt, frozen, self.held)
        if self.dynamic:
            for k, thruster in enumerate(self.vehicle.hydro.thrusters):
                self.thrust_produced[k] = actuator_response(
                    self.thrust_produced[k],
                    result.thrusts[k],
                    thruster.max_thrust,
                    thruster.time_constant,
                    thruster.max_rate,
                    self.actuator_period,
                )
            tau = B @ self.thrust_produced
        else:
            tau = B @ result.thrusts
        return tau, wrench, result

    def reset(self) -> None:
        """Clear the integral (before a new run)."""
        self.integral = np.zeros(6)
        self._last_t = None
        self.thrust_produced[:] = 0.0

    def info_row(self, error, twist, wrench, result) -> dict:
        """The logged diagnostics (keys of :meth:`info_shapes`)."""
        residual = np.where(self.held, result.residual, 0.0)
        row = {
            "error": np.asarray(error, dtype=float),
            "twist": np.asarray(twist, dtype=float),
            "wrench": wrench,
            "residual": residual,
            "thrust": result.thrusts,
            "saturated": float(np.count_nonzero(result.saturated)),
        }
        if self.dynamic:
            row["thrust_produced"] = self.thrust_produced.copy()
        return row

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics."""
        m = len(self.vehicle.hydro.thrusters)
        return {
            "error": (6,),
            "twist": (6,),
            "wrench": (6,),
            "residual": (6,),
            "thrust": (m,),
            "saturated": (),
            **({"thrust_produced": (m,)} if self.dynamic else {}),
        }


class StationKeeping(ModelBasedBody):
    """Controller for :func:`aiauv_pin.simulate`: hold a frame at a pose (module docstring).

    Args:
        vehicle: The vehicle.
        target_position: The frame's target position in the world (3,) [m]; ``None``: where it
            is at the first sample.
        target_rotation: Its target rotation to world (3, 3); ``None``: as at the first sample.
        frame: The frame held (``None``: the base).
        gains: Per-axis gains on accelerations; ``None``: :func:`pid_gains` of ``omega``.
        omega: Natural frequency of the default gains [rad/s].
        axes: The axes held (default all six); the others are left free.
        thrust_limits: Per-thruster limits [N] (default the vehicle's ``max_thrust``).
        current: The current the model is told of (``None``: still water; the integral rejects
            the actual one).
        joint_references, joint_stiffness, joint_damping: The joint servo of an articulated vehicle.
        actuator_period: Interval each thrust command is held [s] (thrusters with dynamics).

    Raises:
        ArgumentError: An unknown frame, gains or limits that are not positive, or held axes the
            thrusters cannot produce (one line naming them).
    """

    def __init__(
        self,
        vehicle: Vehicle,
        target_position=None,
        target_rotation=None,
        *,
        frame: str | None = None,
        gains: PidGains | None = None,
        omega: float = DEFAULT_OMEGA,
        axes=AXIS_NAMES,
        thrust_limits=None,
        current=None,
        joint_references=None,
        joint_stiffness: float = DEFAULT_JOINT_STIFFNESS,
        joint_damping: float = DEFAULT_JOINT_DAMPING,
        q_check=None,
        actuator_period: float | None = None,
    ) -> None:
        what = "station keeping"
        if gains is None:
            try:
                gains = pid_gains(float(omega))
            except (TypeError, ValueError) as exc:
                raise ArgumentError(f"{what}: {exc}") from None
        self.gains = checked_gains(gains, what, proportional=True)
        super().__init__(
            vehicle,
            frame=frame,
            axes=axes,
            thrust_limits=thrust_limits,
            current=current,
            joint_references=joint_references,
            joint_stiffness=joint_stiffness,
            joint_damping=joint_damping,
            what=what,
            q_check=q_check,
            actuator_period=actuator_period,
        )
        self.target_position = None
        self.target_rotation = None
        if target_position is not None:
            p = np.asarray(target_position, dtype=float).reshape(-1)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise ArgumentError(f"{what}: target_position must be 3 finite numbers [m]")
            self.target_position = p
        if target_rotation is not None:
            R = np.asarray(target_rotation, dtype=float)
            if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-9):
                raise ArgumentError(f"{what}: target_rotation must be a 3x3 rotation matrix")
            self.target_rotation = R
        self._first = (self.target_position, self.target_rotation)

    def reset(self) -> None:
        """Clear the integral and any target taken from a first sample."""
        super().reset()
        self.target_position, self.target_rotation = self._first

    def __call__(self, t: float, q, v):
        """``(tau, info)`` at ``(t, q, v)``."""
        rotation, position, twist, _ = self.measure(np.asarray(q, float), np.asarray(v, float))
        if self.target_position is None:
            self.target_position = position.copy()
        if self.target_rotation is None:
            self.target_rotation = rotation.copy()
        error = np.where(
            self.held,
            pose_error(rotation, position, self.target_rotation, self.target_position),
            0.0,
        )
        acceleration = station_acceleration(error, twist, self.integral, self.gains, self.held)
        tau, wrench, result = self.act(t, q, v, acceleration, error)
        info = self.info_row(error, twist, wrench, result)
        info["frame_position"] = position
        return tau, info

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics."""
        return {**super().info_shapes(), "frame_position": (3,)}
