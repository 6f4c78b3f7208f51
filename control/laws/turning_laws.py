"""Thruster-turning baseline: the straight vehicle steered by its tunnel thrusters (written once).

The prior work on AIAUV control that Wrzos-Kaminska et al. (2019) cite (Sverdrup-Thygeson,
Kelasidi, Pettersen and Gravdahl, e.g. "The underwater swimming manipulator - a bioinspired solution
for subsea operations", IEEE J. Oceanic Eng. 43(2), 2018; Kelasidi et al., IFAC CAMS 2016) moves the
vehicle like a conventional rigid AUV: the joints hold the shape and the thrusters produce the
forces and moments. This module is that baseline on the paper's guidance:

* the body is held straight by the joint servo at zero references (eq. 24 with ``q* = 0``);
* the pointing direction of the end-effector (= the whole straight vehicle) tracks the same
  path-parametrised LOS reference (eq. 21, :func:`aiauv_control.laws.paper_laws.los_guidance`) with
  the paper's own
  reduced-attitude law written for torques (eq. 9,
  :func:`aiauv_control.laws.paper_laws.reduced_attitude_law` with the
  straight vehicle's pitch/yaw inertia ``J`` about its centre and its known hydrostatic moment);
* the demanded yaw and pitch moments go to the tunnel (Y, Z) thrusters by the unconstrained
  minimum-norm allocation with zero net side force (Fossen 2021, Sec. 11.2.2, generalised inverse
  ``f = T^T (T T^T)^{-1} tau``, one 2 x n problem per plane), scaled down together to the thrust limit
  when one thruster would exceed it (keeping the direction of the demanded moment);
* surge by the longitudinal (X) thrusters with the same surge PI (eq. 25,
  :func:`aiauv_control.laws.paper_laws.surge_pi`);
* optionally (default in :class:`aiauv_pin.controllers.turning_controller.VehicleThrusterTurning`) sideslip
  compensation, as for any AUV steered by LOS (Fossen 2021, Sec. 12.4: ``psi_d = chi_d - beta``): the
  LOS direction is taken as the desired direction of the end-effector's *velocity* (its course), and
  the pointing reference is it turned by the measured rotation from the velocity direction to the
  pointing direction (:func:`sideslip_compensated`). Without it the straight vehicle turning on a
  helix points its head along the LOS direction while the head, 1.6 m ahead of the centre of
  rotation, slips sideways by about 9 degrees, and LOS settles about 1.6 m off the path.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_control.laws.paper_laws import (
    cross_track_errors,
    los_guidance,
    reduced_attitude_law,
    surge_pi,
)
from aiauv_control.paths import path_point_of
from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import cross3

#: Plane codes of :func:`tunnel_allocation`: not a tunnel thruster, yaw (side force along body y,
#: moment about body z), pitch (force along body z, moment about body y).
NOT_TUNNEL, YAW_PLANE, PITCH_PLANE = 0, 1, 2


class TurningGains(NamedTuple):
    """Gains of :func:`thruster_turning_command` as plain floats."""

    u_d: float  # desired speed [m/s]
    k_y: float  # LOS cross-track gain along N1 [1/s]
    k_z: float  # LOS cross-track gain along N2 [1/s]
    k_p: float  # pointing stiffness [N m/rad]
    k_d: float  # pointing damping [N m s/rad]
    k_1p: float  # surge PI [N s/m]
    k_1i: float  # surge PI [N/m]
    max_thrust: float  # per thruster [N]
    exact: bool  # the exact feedforward (finding 2) or the paper's
    sideslip_compensation: bool  # steer the velocity direction (course), not the pointing


class TurningBuffers(NamedTuple):
    """Outputs of :func:`thruster_turning_command`, written in place."""

    thrusts: np.ndarray  # (m,) [N]
    moments: np.ndarray  # (2,) demanded moment about body y, z [N m] (eq. 9), before saturation
    omega_tilde: np.ndarray  # (2,) [rad/s] (eq. 8)
    x_ref: np.ndarray  # (3,) reference direction (eq. 21)
    cross_track: np.ndarray  # (2,) [m] along N1, N2
    phi_tilde: np.ndarray  # (1,) [rad] (eq. 4)
    path_s: np.ndarray  # (1,) path parameter s [m]
    saturation_scale: np.ndarray  # (1,) scale of the tunnel thrusts [-]


def new_turning_buffers(n_thrusters: int) -> TurningBuffers:
    """Zeroed :class:`TurningBuffers`."""
    return TurningBuffers(
        np.zeros(n_thrusters),
        np.zeros(2),
        np.zeros(2),
        np.zeros(3),
        np.zeros(2),
        np.zeros(1),
        np.zeros(1),
        np.zeros(1),
    )


@compiled(borrows_only=True)
def tunnel_allocation(moment_y, moment_z, plane, force_coeff, moment_coeff, max_thrust, thrusts):
    """Tunnel thrusts for a pitch moment ``moment_y`` and a yaw moment ``moment_z`` [N m].

    For each plane, with ``f_k`` the side force and ``m_k`` the moment (about the vehicle's centre) of
    thruster ``k`` per newton of thrust, the minimum-norm solution of ``sum f_k F_k = 0``,
    ``sum m_k F_k = M`` (Fossen 2021, eq. 11.31 with ``W = I``) is ``F_k = f_k l_0 + m_k l_1`` with
    ``(l_0, l_1) = (A A^T)^{-1} (0, M)``, ``A = [f; m]``. If the plane's thrusters cannot cancel
    their side force (one thruster, or all at one point) it is the minimum-norm moment alone,
    ``F_k = m_k M / sum m^2``. All tunnel thrusts are then scaled by one factor so that none exceeds
    ``max_thrust`` [N]. Writes ``thrusts`` at the tunnel thrusters only (``plane != 0``).

    Returns:
        The scale factor applied (1 when no thruster saturates) [-].
    """
    largest = 0.0
    for p in (YAW_PLANE, PITCH_PLANE):
        demand = moment_z if p == YAW_PLANE else moment_y
        sff = 0.0
        sfm = 0.0
        smm = 0.0
        for k in range(plane.shape[0]):
            if plane[k] == p:
                sff += force_coeff[k] * force_coeff[k]
                sfm += force_coeff[k] * moment_coeff[k]
                smm += moment_coeff[k] * moment_coeff[k]
        det = sff * smm - sfm * sfm
        l0 = 0.0
        l1 = 0.0
        if det > 1e-9 * (sff * smm + 1e-300):
            l0 = -sfm * demand / det
            l1 = sff * demand / det
        elif smm > 0.0:
            l1 = demand / smm
        for k in range(plane.shape[0]):
            if plane[k] == p:
                thrust = force_coeff[k] * l0 + moment_coeff[k] * l1
                thrusts[k] = thrust
                largest = max(largest, abs(thrust))
    scale = 1.0
    if largest > max_thrust:
        scale = max_thrust / largest
        for k in range(plane.shape[0]):
            if plane[k] != NOT_TUNNEL:  # clipped too: the product may round past the limit
                thrusts[k] = min(max(thrusts[k] * scale, -max_thrust), max_thrust)
    return scale


@compiled
def _rodrigues(k0, k1, k2, c, f, y):
    """``c y + k x y + (k . y) k f`` for a 3-sequence ``y`` (see :func:`sideslip_compensated`)."""
    ky = k0 * y[0] + k1 * y[1] + k2 * y[2]
    x0, x1, x2 = cross3(k0, k1, k2, y[0], y[1], y[2])
    return (
        c * y[0] + x0 + ky * k0 * f,
        c * y[1] + x1 + ky * k1 * f,
        c * y[2] + x2 + ky * k2 * f,
    )


@compiled(borrows_only=True)
def sideslip_compensated(velocity, rotation, x_ref, x_dot, x_ddot):
    """``x_ref`` and its derivatives turned by the rotation taking the velocity direction ``w`` to the
    pointing direction ``b`` (the x-axis of ``rotation``), held constant over the sample.

    Rodrigues' formula with ``k = w x b``, ``c = w . b``: ``Q y = c y + k x y + (k . y) k / (1 + c)``.
    Returned unchanged below 1 cm/s or when ``c <= 0`` (moving backwards or sideways).
    """
    speed = math.sqrt(velocity[0] ** 2 + velocity[1] ** 2 + velocity[2] ** 2)
    b0, b1, b2 = rotation[0, 0], rotation[1, 0], rotation[2, 0]
    if speed < 0.01:
        return x_ref, x_dot, x_ddot
    w0, w1, w2 = velocity[0] / speed, velocity[1] / speed, velocity[2] / speed
    c = w0 * b0 + w1 * b1 + w2 * b2
    if c <= 0.0:
        return x_ref, x_dot, x_ddot
    k0, k1, k2 = cross3(w0, w1, w2, b0, b1, b2)
    f = 1.0 / (1.0 + c)
    return (
        _rodrigues(k0, k1, k2, c, f, x_ref),
        _rodrigues(k0, k1, k2, c, f, x_dot),
        _rodrigues(k0, k1, k2, c, f, x_ddot),
    )


@compiled(borrows_only=True)
def thruster_turning_command(
    gains,
    inertia,
    path_function,
    path_kind,
    path_parameters,
    plane,
    force_coeff,
    moment_coeff,
    surge_mask,
    surge_state,
    t,
    rotation,
    position,
    velocity,
    acceleration,
    omega,
    surge_velocity,
    moment_y,
    moment_z,
    out,
):
    """One evaluation of the thruster-turning baseline into ``out`` (see the module docstring).

    Args:
        gains: :class:`TurningGains`.
        inertia: (3, 3) inertia of the straight vehicle about its centre, end-effector axes
            [kg m^2] (rigid and added; only the y-z block enters eq. 9).
        path_function, path_kind, path_parameters: The path (:mod:`aiauv_control.paths`): a user's
            compiled function, or ``None`` and the built-in path's ``kind_code``.
        plane, force_coeff, moment_coeff: Per thruster (m,): plane code and side force [-] and moment
            [m] per newton (:func:`tunnel_allocation`).
        surge_mask: 1 for the surge (X) thrusters (m,).
        surge_state: :class:`aiauv_control.laws.paper_laws.SurgeState` (advanced).
        t: Time [s].
        rotation: End-effector-to-world rotation (3, 3).
        position, velocity, acceleration: End-effector position [m], velocity [m/s] and
            acceleration [m/s^2], world (3,).
        omega: End-effector angular velocity in its own axes (3,) [rad/s].
        surge_velocity: ``u`` [m/s].
        moment_y, moment_z: Known external (hydrostatic) moment on the vehicle about its centre,
            end-effector axes [N m] (eq. 1's ``m``).
        out: :class:`TurningBuffers`.
    """
    point = path_point_of(path_function, path_kind, position, path_parameters)
    x_ref, x_dot, x_ddot = los_guidance(  # eq. (21)
        point, position, velocity, acceleration, gains.u_d, gains.k_y, gains.k_z
    )
    if gains.sideslip_compensation:
        x_ref, x_dot, x_ddot = sideslip_compensated(velocity, rotation, x_ref, x_dot, x_ddot)
    command = reduced_attitude_law(  # eq. (9): torques on the rigid straight vehicle
        rotation,
        omega,
        x_ref,
        x_dot,
        x_ddot,
        inertia,
        moment_y,
        moment_z,
        gains.k_p,
        gains.k_d,
        gains.exact,
    )
    out.moments[0] = command.u_y
    out.moments[1] = command.u_z
    out.omega_tilde[0] = command.omega_tilde_y
    out.omega_tilde[1] = command.omega_tilde_z
    thrust = surge_pi(  # eq. (25)
        surge_state, t, surge_velocity, gains.k_1p, gains.k_1i, gains.u_d, gains.max_thrust
    )
    for k in range(surge_mask.shape[0]):
        out.thrusts[k] = thrust if surge_mask[k] != 0 else 0.0
    scale = tunnel_allocation(
        command.u_y, command.u_z, plane, force_coeff, moment_coeff, gains.max_thrust, out.thrusts
    )
    for i in range(3):
        out.x_ref[i] = x_ref[i]
    errors = cross_track_errors(point, position, velocity)
    out.cross_track[0] = errors[0]
    out.cross_track[1] = errors[1]
    out.phi_tilde[0] = command.phi_tilde
    out.path_s[0] = point.s
    out.saturation_scale[0] = scale
