"""Vehicle side of the thruster-turning baseline for the compiled loop.

Measurement as :func:`aiauv_pin.controllers.paper_compiled.paper_path_following` (end-effector pose, twist,
finite-difference acceleration, surge speed) plus the hydrostatic moment about the vehicle's centre;
the law is :func:`aiauv_control.laws.turning_laws.thruster_turning_command`; the action ``tau = B(q) thrusts``
(eq. 20). The joints are held straight by the continuous joint servo at zero references.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aiauv_control.laws.paper_laws import SurgeState, joint_pd_torque, restoring_moment_in_frame
from aiauv_control.laws.turning_laws import TurningBuffers, TurningGains, thruster_turning_command
from aiauv_hydro.numerics.jit import compiled
from aiauv_pin.controllers.paper_compiled import (
    FrameMeasurement,
    measure_end_effector,
    thrusts_and_power_into,
)
from aiauv_pin.kernels.articulated_body import thrust_into


class TurningInfo(NamedTuple):
    """Offsets of the fields of :func:`turning_info_shapes` in the info row of
    :func:`thruster_turning` (:func:`aiauv_pin.controllers.info_rows.info_offsets`)."""

    p: int
    u: int
    phi_tilde: int
    omega_tilde: int
    base_angles: int
    joint_references: int
    x_ref: int
    pointing: int
    turning_moment: int
    saturation_scale: int
    thrust: int
    thruster_power: int
    joint_torque: int
    cross_track: int
    path_s: int


class TurningParameters(NamedTuple):
    """What :func:`thruster_turning` needs besides the state (built in Python once)."""

    gains: TurningGains
    inertia: np.ndarray  # (3, 3) straight vehicle about its centre, end-effector axes [kg m^2]
    centre_in_base: np.ndarray  # (3,) the vehicle's centre in the base frame, straight [m]
    path_function: object  # None for a built-in path (then path_kind chooses it)
    path_kind: int
    path_parameters: np.ndarray
    plane: np.ndarray  # (m,) int64 plane codes
    force_coeff: np.ndarray  # (m,) side force per newton [-]
    moment_coeff: np.ndarray  # (m,) moment about the centre per newton [m]
    surge_mask: np.ndarray  # (m,)
    frame_body: int
    frame_rotation: np.ndarray  # (3, 3)
    frame_translation: np.ndarray  # (3,) [m]
    joint_stiffness: np.ndarray  # (n,) servo gains, for logging its torque [N m/rad]
    joint_damping: np.ndarray  # (n,) [N m s/rad]
    info: TurningInfo  # where the info row's fields start


class TurningState(NamedTuple):
    """State of :func:`thruster_turning` (arrays updated in place)."""

    surge: SurgeState
    measurement: FrameMeasurement  # the end-effector at the sample (its history kept)
    command: TurningBuffers


def turning_info_shapes(n_joints: int, n_thrusters: int) -> dict[str, tuple[int, ...]]:
    """Keys and shapes of the info row of :func:`thruster_turning`."""
    return {
        "p": (3,),
        "u": (),
        "phi_tilde": (),
        "omega_tilde": (2,),
        "base_angles": (2,),  # zero: the body is held straight
        "joint_references": (n_joints,),  # zero
        "x_ref": (3,),
        "pointing": (3,),
        "turning_moment": (2,),
        "saturation_scale": (),
        "thrust": (n_thrusters,),
        "thruster_power": (n_thrusters,),
        "joint_torque": (n_joints,),
        "cross_track": (2,),
        "path_s": (),
    }


@compiled(borrows_only=True, inline=True)
def thruster_turning(t, q, v, model, workspace, parameters, state, tau, info):
    """The thruster-turning baseline on the vehicle: measure, law, ``tau = B(q) thrusts``.

    The known moment of eq. (1) is the hydrostatic one: the base part of ``-g(q)`` (a wrench at the
    base origin, base axes) moved to the vehicle's centre ``p_b + R_b c`` and turned into
    end-effector axes, by :func:`aiauv_control.laws.paper_laws.restoring_moment_in_frame` (which
    gives the moment of
    ``g``, the left-hand side: hence the sign). The logged joint torque is the servo's eq. (24) at
    this sample.
    """
    W = workspace
    P = parameters
    meas = state.measurement
    measure_end_effector(
        t, q, v, model, W, P.frame_body, P.frame_rotation, P.frame_translation, meas
    )
    R, p, twist = meas.rotation, meas.position, meas.twist
    g = W.restoring
    # the law gives the moment of g (left-hand side) about the centre, in end-effector axes; the
    # acting moment is its negative. Only the lever p_c - p_b = R_b c enters, so positions are
    # taken from the base origin (no rounding from large world coordinates).
    Rb, c = W.rotation[0], P.centre_in_base
    lever = (
        Rb[0, 0] * c[0] + Rb[0, 1] * c[1] + Rb[0, 2] * c[2],
        Rb[1, 0] * c[0] + Rb[1, 1] * c[1] + Rb[1, 2] * c[2],
        Rb[2, 0] * c[0] + Rb[2, 1] * c[1] + Rb[2, 2] * c[2],
    )
    moment = restoring_moment_in_frame(Rb, (0.0, 0.0, 0.0), R, lever, g)
    m_y, m_z = -moment[1], -moment[2]
    out = state.command
    thruster_turning_command(
        P.gains,
        P.inertia,
        P.path_function,
        P.path_kind,
        P.path_parameters,
        P.plane,
        P.force_coeff,
        P.moment_coeff,
        P.surge_mask,
        state.surge,
        t,
        R,
        p,
        meas.velocity,
        meas.acceleration,
        meas.omega,
        twist[0],
        m_y,
        m_z,
        out,
    )
    thrust_into(model, W, out.thrusts, tau)  # eq. (20)
    n = q.shape[0] - 7
    # the info row, at the offsets of turning_info_shapes (the body is held straight: zero
    # base angles and joint references)
    L = P.info
    for i in range(3):
        info[L.p + i] = p[i]
        info[L.x_ref + i] = out.x_ref[i]
        info[L.pointing + i] = R[i, 0]
    info[L.u] = twist[0]
    info[L.phi_tilde] = out.phi_tilde[0]
    for i in range(2):
        info[L.omega_tilde + i] = out.omega_tilde[i]
        info[L.base_angles + i] = 0.0
        info[L.turning_moment + i] = out.moments[i]
        info[L.cross_track + i] = out.cross_track[i]
    info[L.saturation_scale] = out.saturation_scale[0]
    thrusts_and_power_into(model, W, out.thrusts, info, L.thrust, L.thruster_power)
    for j in range(n):
        info[L.joint_references + j] = 0.0
        info[L.joint_torque + j] = joint_pd_torque(
            q[7 + j], v[6 + j], 0.0, g[6 + j], P.joint_stiffness[j], P.joint_damping[j]
        )
    info[L.path_s] = out.path_s[0]
