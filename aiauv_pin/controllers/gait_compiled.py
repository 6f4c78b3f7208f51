"""Vehicle side of the serpentine gaits for the compiled loop.

Measurement: the vehicle's centre of mass and its world velocity (the point that follows the path,
as in Kelasidi 2017), the mean heading (direction of the mass-weighted mean of the links' x-axes in
the horizontal plane) and the speed along it, and for depth keeping the mean elevation (of the same
mean x-axis, positive towards +z) and its rate. The law is
:func:`aiauv_control.laws.gait_laws.gait_command`; the action: the joint references go to the
continuous joint servo (:class:`aiauv_pin.dynamics.joint_servo.JointServo`, its limits and gains),
and ``tau = B(q) thrusts`` (the paper's eq. 20) in combined mode.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_control.laws.gait_laws import GaitBuffers, GaitGains, gait_command
from aiauv_control.laws.paper_laws import GuidanceState, SurgeState, joint_pd_torque
from aiauv_hydro.numerics.jit import compiled
from aiauv_pin.controllers.paper_compiled import thrusts_and_power_into
from aiauv_pin.kernels.articulated_body import kinematics, restoring_into, thrust_into


class GaitInfo(NamedTuple):
    """Offsets of the fields of :func:`gait_info_shapes` in the info row of
    :func:`serpentine_gait` (:func:`aiauv_pin.controllers.info_rows.info_offsets`)."""

    centre: int
    speed: int
    heading: int
    heading_ref: int
    gait_offset: int
    joint_references: int
    thrust: int
    thruster_power: int
    joint_torque: int
    cross_track: int
    path_s: int
    elevation: int
    depth: int


class GaitParameters(NamedTuple):
    """What :func:`serpentine_gait` needs besides the state (built in Python once)."""

    gains: GaitGains
    path_function: object  # None for a built-in path (then path_kind chooses it)
    path_kind: int
    path_parameters: np.ndarray
    tail_index: (
        np.ndarray
    )  # (n,) int64: index among the undulating joints from the tail, 0: straight
    joint_sign: np.ndarray  # (n,) +-1
    n_links: int
    surge_mask: np.ndarray  # (m,)
    link_mass: np.ndarray  # (nb,) [kg]
    link_centre: np.ndarray  # (nb, 3) centre of mass in the link frame [m]
    servo_references: np.ndarray  # (n,) the servo's references, updated in place
    joint_stiffness: np.ndarray  # (n,) servo gains, for logging its torque [N m/rad]
    joint_damping: np.ndarray  # (n,) [N m s/rad]
    pitch_scale: np.ndarray  # (n,) eq. (22)'s signed scale of the pitch joints, 0 for the others
    heave_sign: np.ndarray  # (m,) sign of the vertical thrusters of the depth PI, 0 for the others
    info: GaitInfo  # where the info row's fields start


class GaitState(NamedTuple):
    """State of :func:`serpentine_gait` (arrays updated in place)."""

    surge: SurgeState
    guidance: GuidanceState
    command: GaitBuffers
    depth: SurgeState  # the depth PI of the vertical thrusters


def gait_info_shapes(n_joints: int, n_thrusters: int) -> dict[str, tuple[int, ...]]:
    """Keys and shapes of the info row of :func:`serpentine_gait`."""
    return {
        "centre": (3,),  # centre of mass [m]
        "speed": (),  # speed of the centre of mass along the mean heading [m/s]
        "heading": (),  # mean heading theta_bar [rad]
        "heading_ref": (),  # LOS heading [rad]
        "gait_offset": (),  # phi_0 [rad], Kelasidi's sign
        "joint_references": (n_joints,),
        "thrust": (n_thrusters,),
        "thruster_power": (n_thrusters,),
        "joint_torque": (n_joints,),
        "cross_track": (2,),  # of the centre of mass [m]
        "path_s": (),
        "elevation": (),  # mean elevation gamma_bar [rad], positive towards +z
        "depth": (3,),  # e_v [m], gamma_d [rad], q_y0 [rad] (joints) or F [N] (thrusters)
    }


@compiled(borrows_only=True)
def centre_and_heading(W, link_mass, link_centre):
    """Centre of mass (3,) [m], its world velocity (3,) [m/s] and the mean heading [rad] from the
    kinematics in ``W``: ``sum m_b (p_b + R_b c_b) / M``, ``sum m_b R_b (v_b + w_b x c_b) / M``
    and ``atan2`` of the horizontal part of ``sum m_b R_b e_x``."""
    total = 0.0
    p0 = p1 = p2 = 0.0
    v0 = v1 = v2 = 0.0
    x0 = x1 = 0.0
    for b in range(link_mass.shape[0]):
        m = link_mass[b]
        R, o, tw = W.rotation[b], W.position[b], W.twist[b]
        c0, c1, c2 = link_centre[b, 0], link_centre[b, 1], link_centre[b, 2]
        # v_b + w_b x c_b in body axes
        a0 = tw[0] + tw[4] * c2 - tw[5] * c1
        a1 = tw[1] + tw[5] * c0 - tw[3] * c2
        a2 = tw[2] + tw[3] * c1 - tw[4] * c0
        p0 += m * (o[0] + R[0, 0] * c0 + R[0, 1] * c1 + R[0, 2] * c2)
        p1 += m * (o[1] + R[1, 0] * c0 + R[1, 1] * c1 + R[1, 2] * c2)
        p2 += m * (o[2] + R[2, 0] * c0 + R[2, 1] * c1 + R[2, 2] * c2)
        v0 += m * (R[0, 0] * a0 + R[0, 1] * a1 + R[0, 2] * a2)
        v1 += m * (R[1, 0] * a0 + R[1, 1] * a1 + R[1, 2] * a2)
        v2 += m * (R[2, 0] * a0 + R[2, 1] * a1 + R[2, 2] * a2)
        x0 += m * R[0, 0]
        x1 += m * R[1, 0]
        total += m
    return (
        (p0 / total, p1 / total, p2 / total),
        (v0 / total, v1 / total, v2 / total),
        math.atan2(x1, x0),
    )


@compiled(borrows_only=True)
def mean_elevation(W, link_mass):
    """Elevation [rad] of ``X = sum m_b R_b e_x`` (positive towards +z) and its rate [rad/s]:
    ``gamma = atan2(X_z, h)``, ``h = |(X_x, X_y)|``, with ``X_dot = sum m_b R_b (w_b x e_x)``."""
    x0 = x1 = x2 = 0.0
    d0 = d1 = d2 = 0.0
    for b in range(link_mass.shape[0]):
        m = link_mass[b]
        R, tw = W.rotation[b], W.twist[b]
        wy, wz = tw[4], tw[5]
        x0 += m * R[0, 0]
        x1 += m * R[1, 0]
        x2 += m * R[2, 0]
        # w x e_x = (0, w_z, -w_y) in body axes
        d0 += m * (R[0, 1] * wz - R[0, 2] * wy)
        d1 += m * (R[1, 1] * wz - R[1, 2] * wy)
        d2 += m * (R[2, 1] * wz - R[2, 2] * wy)
    h = math.sqrt(x0 * x0 + x1 * x1)
    h_dot = (x0 * d0 + x1 * d1) / h if h > 0.0 else 0.0
    norm2 = h * h + x2 * x2
    rate = (h * d2 - x2 * h_dot) / norm2 if norm2 > 0.0 else 0.0
    return math.atan2(x2, h), rate


@compiled(borrows_only=True, inline=True)
def serpentine_gait(t, q, v, model, workspace, parameters, state, tau, info):
    """The steered serpentine gait on the vehicle: measure, :func:`gait_command`, act.

    The joint references go to ``parameters.servo_references`` (the continuous servo tracks them);
    ``tau = B(q) thrusts`` (zero but in combined mode). The logged joint torque is the servo's
    eq. (24) at this sample.
    """
    W = workspace
    P = parameters
    kinematics(model.bodies, q, v, W)
    restoring_into(model, W, W.restoring)
    centre, velocity, heading = centre_and_heading(W, P.link_mass, P.link_centre)
    elevation, elevation_rate = mean_elevation(W, P.link_mass)
    c, s = math.cos(heading), math.sin(heading)
    u = velocity[0] * c + velocity[1] * s
    out = state.command
    gait_command(
        P.gains,
        P.path_function,
        P.path_kind,
        P.path_parameters,
        P.tail_index,
        P.joint_sign,
        P.n_links,
        P.surge_mask,
        state.surge,
        state.guidance,
        t,
        centre,
        velocity,
        heading,
        u,
        out,
        P.pitch_scale,
        P.heave_sign,
        state.depth,
        elevation,
        elevation_rate,
    )
    n = q.shape[0] - 7
    for j in range(n):
        P.servo_references[j] = out.joint_references[j]
    thrust_into(model, W, out.thrusts, tau)  # eq. (20)
    g = W.restoring
    # the info row, at the offsets of gait_info_shapes
    L = P.info
    for i in range(3):
        info[L.centre + i] = centre[i]
        info[L.depth + i] = out.depth[i]
    info[L.speed] = u
    info[L.heading] = heading
    info[L.heading_ref] = out.heading_ref[0]
    info[L.gait_offset] = out.offset[0]
    for j in range(n):
        info[L.joint_references + j] = out.joint_references[j]
        info[L.joint_torque + j] = joint_pd_torque(
            q[7 + j],
            v[6 + j],
            out.joint_references[j],
            g[6 + j],
            P.joint_stiffness[j],
            P.joint_damping[j],
        )
    thrusts_and_power_into(model, W, out.thrusts, info, L.thrust, L.thruster_power)
    info[L.cross_track] = out.cross_track[0]
    info[L.cross_track + 1] = out.cross_track[1]
    info[L.path_s] = out.path_s[0]
    info[L.elevation] = elevation
