"""The thruster-turning baseline (:mod:`aiauv_control.laws.turning_laws`) wired to a vehicle.

:class:`VehicleThrusterTurning` holds the body straight with the joint servo (eq. 24 at zero
references), steers the straight vehicle with its tunnel thrusters and pushes it with its X
thrusters (see :mod:`aiauv_control.laws.turning_laws` for the law and its sources). It computes once, from
the vehicle in its straight configuration, what the law needs: the vehicle's centre (centre of
mass), its pitch/yaw inertia about that centre (rigid and added mass, locked joints), and each
tunnel thruster's side force and moment about the centre per newton.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from aiauv_control.guidance import X_AXIS, cross_track_gains
from aiauv_control.laws.paper_laws import new_surge_state
from aiauv_control.laws.turning_laws import (
    NOT_TUNNEL,
    PITCH_PLANE,
    YAW_PLANE,
    TurningGains,
    new_turning_buffers,
    thruster_turning_command,
)
from aiauv_control.path_following import PathFollowingGains
from aiauv_control.paths import Path
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.controllers.info_rows import info_offsets
from aiauv_pin.controllers.paper_compiled import new_frame_measurement
from aiauv_pin.controllers.paper_controller import END_EFFECTOR, surge_thruster_indices
from aiauv_pin.controllers.turning_compiled import (
    TurningInfo,
    TurningParameters,
    TurningState,
    thruster_turning,
    turning_info_shapes,
)
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.model.vehicle import Vehicle

#: Default pointing gains of the baseline: stiffness [N m/rad] and damping [N m s/rad]. With the
#: paper vehicle's pitch/yaw inertia about its centre (about 150 kg m^2 with added mass) they give
#: a natural frequency near 0.6 rad/s, about the bandwidth of the paper's body-curving loop.
DEFAULT_POINTING_STIFFNESS = 300.0
DEFAULT_POINTING_DAMPING = 400.0


def straight_vehicle_geometry(vehicle: Vehicle):
    """Centre (base frame) [m], inertia about it in base axes (3, 3) [kg m^2], and per-thruster
    plane codes, side force per newton [-] and moment about the centre per newton [m], all for the
    straight vehicle (neutral configuration)."""
    q = vehicle.neutral_configuration()
    centre = pin.centerOfMass(
        vehicle.model, vehicle.data, q
    ).copy()  # base at the origin, unrotated
    mass = vehicle.mass_matrix(q)[:6, :6]  # locked joints: (v, omega) at the base origin
    shift = np.eye(6)
    shift[:3, 3:] = pin.skew(centre)  # v_o = v_c + c x omega
    inertia = (shift.T @ mass @ shift)[3:, 3:]
    inertia = 0.5 * (inertia + inertia.T)
    B = vehicle.thrust_matrix(q)[:6]
    m = B.shape[1]
    plane = np.zeros(m, dtype=np.int64)
    force = np.zeros(m)
    moment = np.zeros(m)
    for k in range(m):
        direction = B[:3, k]
        about_centre = B[3:, k] - np.cross(centre, direction)
        if abs(direction[1]) > 0.999:
            plane[k], force[k], moment[k] = YAW_PLANE, direction[1], about_centre[2]
        elif abs(direction[2]) > 0.999:
            plane[k], force[k], moment[k] = PITCH_PLANE, direction[2], about_centre[1]
        else:
            plane[k] = NOT_TUNNEL
    return centre, inertia, plane, force, moment


class VehicleThrusterTurning:
    """Controller for :func:`aiauv_pin.simulate`: the thruster-turning baseline (compiled).

    Args:
        vehicle: The vehicle: an ``end_effector`` frame, X thrusters and tunnel thrusters in both
            planes; the numba backend.
        gains: Guidance, surge and joint-servo gains (``u_d``, ``k_e``, ``k_1p``, ``k_1i``, ``k_qp``,
            ``k_qd``, ``feedforward``) shared with the paper's controller.
        k_p, k_d: Pointing stiffness [N m/rad] and damping [N m s/rad] of eq. (9).
        path: The path (default: the world x-axis).
        sideslip_compensation: Steer the end-effector's velocity direction along the LOS
            direction (see :mod:`aiauv_control.laws.turning_laws`); ``False`` steers its pointing.
    """

    continuous_joints = True

    def __init__(
        self,
        vehicle: Vehicle,
        gains: PathFollowingGains | None = None,
        *,
        k_p: float = DEFAULT_POINTING_STIFFNESS,
        k_d: float = DEFAULT_POINTING_DAMPING,
        path: Path | None = None,
        end_effector: str = END_EFFECTOR,
        sideslip_compensation: bool = True,
    ) -> None:
        if vehicle.fast is None:
            raise ValueError(
                f"thruster turning runs compiled only; the vehicle runs on {vehicle.active_backend}"
            )
        if not (np.isfinite(k_p) and k_p > 0 and np.isfinite(k_d) and k_d > 0):
            raise ValueError(f"thruster turning: k_p and k_d must be > 0, got {k_p!r}, {k_d!r}")
        self.vehicle = vehicle
        self.gains = gains if gains is not None else PathFollowingGains()
        self.path = path if path is not None else X_AXIS
        self.frame = vehicle.frame_id(end_effector)
        surge = surge_thruster_indices(vehicle)
        if not surge:
            raise ValueError("the vehicle has no thruster along a link x-axis for surge control")
        self.surge_mask = np.zeros(len(vehicle.hydro.thrusters))
        self.surge_mask[surge] = 1.0
        centre, inertia, plane, force, moment = straight_vehicle_geometry(vehicle)
        for p, name in ((YAW_PLANE, "Y"), (PITCH_PLANE, "Z")):
            if not np.any(plane == p):
                raise ValueError(f"thruster turning needs {name} (tunnel) thrusters")
        self.centre, self.inertia = centre, inertia
        self.plane, self.force_coeff, self.moment_coeff = plane, force, moment
        k_y, k_z = cross_track_gains(self.gains.k_e)[1:]
        self.turning_gains = TurningGains(
            u_d=self.gains.u_d,
            k_y=float(k_y),
            k_z=float(k_z),
            k_p=float(k_p),
            k_d=float(k_d),
            k_1p=self.gains.k_1p,
            k_1i=self.gains.k_1i,
            max_thrust=float(np.min(vehicle.max_thrust)),
            exact=self.gains.feedforward == "exact",
            sideslip_compensation=bool(sideslip_compensation),
        )
        n = vehicle.nv - 6
        self.joint_servo = JointServo.uniform(n, self.gains.k_qp, self.gains.k_qd)
        self.law = thruster_turning_command  # the law, for readers: aiauv_control.laws.turning_laws

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics."""
        return turning_info_shapes(self.vehicle.nv - 6, len(self.vehicle.hydro.thrusters))

    def compiled(self) -> CompiledController:
        """This controller for the compiled loop (a fresh state)."""
        body, rotation, translation = self.vehicle.fast.frame(self.frame)
        # inertia in end-effector axes: the straight vehicle's base and end-effector axes coincide
        # up to the frame's fixed rotation in its body
        to_ee = rotation.T if body == 0 else np.eye(3)
        parameters = TurningParameters(
            gains=self.turning_gains,
            inertia=np.ascontiguousarray(to_ee @ self.inertia @ to_ee.T),
            centre_in_base=np.ascontiguousarray(self.centre, dtype=float),
            path_function=self.path.user_function,
            path_kind=self.path.kind_code,
            path_parameters=self.path.params,
            plane=self.plane,
            force_coeff=self.force_coeff,
            moment_coeff=self.moment_coeff,
            surge_mask=self.surge_mask,
            frame_body=body,
            frame_rotation=rotation,
            frame_translation=translation,
            joint_stiffness=self.joint_servo.stiffness,
            joint_damping=self.joint_servo.damping,
            info=info_offsets(self.info_shapes(), TurningInfo),
        )
        state = TurningState(
            surge=new_surge_state(),
            measurement=new_frame_measurement(),
            command=new_turning_buffers(len(self.vehicle.hydro.thrusters)),
        )

        def reset() -> None:
            for array in (*state.surge, *state.measurement):
                array[:] = 0.0
            self.joint_servo.references[:] = 0.0

        return CompiledController(
            thruster_turning, parameters, state, self.info_shapes(), self.joint_servo, reset
        )
