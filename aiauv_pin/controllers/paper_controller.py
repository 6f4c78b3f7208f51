"""The paper's path-following controller (``control``) wired to a vehicle (measurement and action).

:class:`VehiclePathFollowing` measures what :class:`aiauv_control.path_following.PathFollowingController`
needs from the simulator state ``(q, v)`` (end-effector pose and velocity, joint states, the joints'
hydrostatic forces ``g_q``) and maps its command back to generalised forces with the paper's eq. (20):
``tau = B(q) tau_thr + [0; tau_q]``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from aiauv_control.laws.paper_laws import (
    finite_difference_acceleration,
    new_command_buffers,
    new_guidance_state,
    new_surge_state,
    restoring_moment_in_frame,
    thruster_power,
)
from aiauv_control.path_following import (
    PathFollowingController,
    PathFollowingGains,
    PathFollowingMeasurement,
)
from aiauv_control.paths import Path
from aiauv_control.surge import SurgePIController
from aiauv_hydro.numerics.jit import interpreted
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.controllers.info_rows import info_offsets
from aiauv_pin.controllers.paper_compiled import (
    PaperInfo,
    PaperParameters,
    PaperState,
    new_frame_measurement,
    paper_info_shapes,
    paper_path_following,
)
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle

END_EFFECTOR = "end_effector"

#: The compiled controller's measurement and power laws, run interpreted on the Python side (one
#: implementation of each, :mod:`aiauv_control.laws.paper_laws`).
_finite_difference_acceleration = interpreted(finite_difference_acceleration)
_thruster_power = interpreted(thruster_power)

_AXIS_OF_JOINT_TYPE = {"JointModelRX": "+x", "JointModelRY": "+y", "JointModelRZ": "+z"}


def joint_axis_labels(vehicle: Vehicle) -> tuple[str, ...]:
    """Signed axis label (``"+x"``, ``"-y"``, ``"+z"``, ...) of every actuated joint, in model
    order (:func:`aiauv_control.joint_references.check_joint_axes`).

    Raises:
        ValueError: A joint that is not revolute about a link axis (up to sign).
    """
    labels = []
    for joint in vehicle.model.joints[2:]:
        name = joint.shortname()
        if name in _AXIS_OF_JOINT_TYPE:
            labels.append(_AXIS_OF_JOINT_TYPE[name])
            continue
        axis = getattr(joint, "axis", None)
        if axis is not None:
            axis = np.asarray(axis, dtype=float)
            k = int(np.argmax(np.abs(axis)))
            if abs(abs(axis[k]) - 1.0) < 1e-9:
                labels.append(("+" if axis[k] > 0.0 else "-") + "xyz"[k])
                continue
        raise ValueError(
            f"joint '{vehicle.model.names[joint.id]}' is not revolute about a link axis"
        )
    return tuple(labels)


def surge_thruster_indices(vehicle: Vehicle) -> list[int]:
    """Indices of the thrusters that push along their link's x-axis (the paper's "X" thrusters)."""
    return [k for k, t in enumerate(vehicle.hydro.thrusters) if abs(t.direction[0]) > 0.999]


def compiled_path_following_reason(adapter) -> str | None:
    """Why ``adapter`` cannot run in compiled code (``None`` if it can).

    The compiled loop runs the same law (:func:`aiauv_control.laws.paper_laws.path_following_command`) through
    :func:`aiauv_pin.controllers.paper_compiled.paper_path_following`; it needs a plain
    :class:`VehiclePathFollowing` around a plain
    :class:`aiauv_control.path_following.PathFollowingController` (a subclass may change the law in
    Python) on a vehicle with the numba backend.
    """
    if type(adapter) is not VehiclePathFollowing:
        return f"the controller is a {type(adapter).__name__}, not VehiclePathFollowing"
    if type(adapter.controller) is not PathFollowingController:
        return f"the controller law is a {type(adapter.controller).__name__}"
    if type(adapter.controller._surge) is not SurgePIController:
        return "the surge controller is not aiauv_control.surge.SurgePIController"
    if adapter.vehicle.fast is None:
        return f"the vehicle runs on the {adapter.vehicle.active_backend} backend"
    if adapter.controller.n_joints != adapter.vehicle.nv - 6:
        return "the controller's joints are not the vehicle's"
    return None


class VehiclePathFollowing:
    """Controller callback for :func:`aiauv_pin.simulate` running the paper's path following.

    The end-effector acceleration that the guidance law's second derivative needs is the finite
    difference of the end-effector velocity between consecutive calls (zero at the first call), so the
    callback costs no extra dynamics evaluation.

    Joint loop: with ``continuous_joints=True`` (default) the joint PD with hydrostatic compensation
    (eq. 24) runs as a continuous-time servo, :meth:`servo`, evaluated by the integrator at every stage
    with the latest references, the way joint motor controllers run far faster than the guidance
    loop; the callback's own output then holds only the thrusts. :attr:`joint_servo` is that servo as
    data (a :class:`aiauv_pin.dynamics.joint_servo.JointServo` whose references the callback
    updates), which the
    compiled backend evaluates inside its integration kernel. With ``False`` eq. (24) is sampled
    with the rest of the controller and held over the step; the paper's gains then need
    ``dt <~ 0.01 s`` (the fastest joint mode has ``k_qD / I ~ 190 1/s``).

    Args:
        vehicle: The vehicle; it must have a frame named ``end_effector`` and X thrusters.
        gains: Controller gains (paper defaults).
        end_effector: Name of the end-effector frame.
        continuous_joints: Run eq. (24) as a continuous servo (see above).
        path: The path to follow (default: the world x-axis, the paper's).
    """

    def __init__(
        self,
        vehicle: Vehicle,
        gains: PathFollowingGains | None = None,
        *,
        end_effector: str = END_EFFECTOR,
        continuous_joints: bool = True,
        path: Path | None = None,
    ) -> None:
        self.vehicle = vehicle
        self.continuous_joints = bool(continuous_joints)
        self.gains = gains if gains is not None else PathFollowingGains()
        if isinstance(end_effector, str) and not vehicle.model.existFrame(end_effector):
            raise ArgumentError(
                f"the paper's path-following controller steers a frame named {end_effector!r:.80}, "
                "which this vehicle lacks: add it to the URDF (a fixed joint to the head link) or "
                "use --controller none"
            )
        self.frame = vehicle.frame_id(end_effector)
        surge = surge_thruster_indices(vehicle)
        if not surge:
            raise ValueError("the vehicle has no thruster along a link x-axis for surge control")
        self.controller = PathFollowingController(
            joint_axes=joint_axis_labels(vehicle),
            surge_thrusters=surge,
            n_thrusters=len(vehicle.hydro.thrusters),
            max_thrust=vehicle.max_thrust,
            gains=self.gains,
            path=path,
        )
        self.path = self.controller.path
        self.joint_servo = JointServo.uniform(vehicle.nv - 6, self.gains.k_qp, self.gains.k_qd)
        self.reset()

    def reset(self) -> None:
        """Clear the surge integrator and the velocity history."""
        self.controller.reset()
        # the previous sample of the measured acceleration (finite_difference_acceleration)
        self._history = np.zeros(5)
        self.joint_servo.references[:] = 0.0

    def servo(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Joint PD with hydrostatic compensation (eq. 24) at the latest references, as ``tau`` (nv,)."""
        return self.joint_servo.torque(self.vehicle, q, v)

    def measure(self, t: float, q: np.ndarray, v: np.ndarray) -> PathFollowingMeasurement:
        """What the controller needs, from the simulator state."""
        rotation, position, twist = self.vehicle.frame_motion(q, v, self.frame)
        velocity_in_world = rotation @ twist[:3]
        acceleration = np.empty(3)
        _finite_difference_acceleration(float(t), velocity_in_world, self._history, acceleration)
        restoring = self.vehicle.restoring_forces(q)
        base_rotation = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        return PathFollowingMeasurement(
            position_in_world=position,
            velocity_in_world=velocity_in_world,
            acceleration_in_world=acceleration,
            rotation_to_world=rotation,
            angular_velocity_in_ee=twist[3:].copy(),
            joint_positions=q[7:].copy(),
            joint_velocities=v[6:].copy(),
            joint_hydrostatic_forces=restoring[6:],
            surge_velocity=float(twist[0]),
            restoring_moment_in_ee=np.array(
                restoring_moment_in_frame(base_rotation, q[:3], rotation, position, restoring[:6])
            ),
        )

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray):
        measurement = self.measure(t, q, v)
        command = self.controller.command(t, measurement)
        self.joint_servo.references[:] = command.joint_references
        thrust_matrix = self.vehicle.thrust_matrix(q)
        tau = thrust_matrix @ command.thrusts
        if not self.continuous_joints:
            tau[6:] += command.joint_torques
        info = {
            "p": measurement.position_in_world,
            "u": measurement.surge_velocity,
            "phi_tilde": command.phi_tilde,
            "omega_tilde": command.omega_tilde,
            "base_angles": command.base_angles,
            "joint_references": command.joint_references,
            "x_ref": command.x_ref,
            "pointing": command.pointing_direction,
            "thrust": command.thrusts,
            # mechanical power of each thruster: thrust times the speed of its point along its axis
            "thruster_power": _thruster_power(v @ thrust_matrix, command.thrusts),
            "joint_torque": command.joint_torques,
            "cross_track": command.cross_track_error,
            "path_s": command.path_parameter,
        }
        return tau, info

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics (both the Python and the compiled loop)."""
        return paper_info_shapes(self.controller.n_joints, self.controller.n_thrusters)

    def compiled(self) -> CompiledController:
        """This controller for the compiled loop (a fresh state; the same law and parameters).

        Raises:
            ArgumentError: It cannot run compiled (see :func:`compiled_path_following_reason`).
        """
        reason = compiled_path_following_reason(self)
        if reason is not None:
            raise ArgumentError(f"compiled path following unavailable: {reason}")
        controller = self.controller
        body, rotation, translation = self.vehicle.fast.frame(self.frame)
        parameters = PaperParameters(
            gains=controller.gain_record,
            path_function=controller.path.user_function,
            path_kind=controller.path.kind_code,
            path_parameters=controller.path.params,
            axis_index=np.ascontiguousarray(controller.axis_index, dtype=np.int64),
            reference_scale=np.ascontiguousarray(controller.reference_scale, dtype=float),
            surge_mask=controller.surge_mask,
            frame_body=body,
            frame_rotation=rotation,
            frame_translation=translation,
            continuous_joints=self.continuous_joints,
            servo_references=self.joint_servo.references,
            info=info_offsets(self.info_shapes(), PaperInfo),
        )
        state = PaperState(
            surge=new_surge_state(),
            measurement=new_frame_measurement(),
            command=new_command_buffers(controller.n_joints, controller.n_thrusters),
            guidance=new_guidance_state(),
        )

        def reset() -> None:
            for array in (*state.surge, *state.guidance, *state.measurement):
                array[:] = 0.0
            self.joint_servo.references[:] = 0.0

        return CompiledController(
            paper_path_following,
            parameters,
            state,
            self.info_shapes(),
            self.joint_servo if self.continuous_joints else None,
            reset,
        )
