"""The control laws of the paper, written once for every backend (Wrzos-Kaminska et al. 2019).

Each function here is the only implementation of its law in the project. They are compiled by
:func:`aiauv_hydro.numerics.jit.compiled` and called from the compiled simulation loop
(:mod:`aiauv_pin.controllers.paper_compiled`), from the Python API (:mod:`aiauv_control.guidance`,
:mod:`aiauv_control.reduced_attitude`, :mod:`aiauv_control.joint_references`,
:mod:`aiauv_control.joint_control`,
:mod:`aiauv_control.surge`, :mod:`aiauv_control.path_following`, which validate their inputs and
call these), and
interpreted when numba is missing.

* :func:`los_guidance` - path-parametrised line-of-sight guidance (eq. 21 on any path) with exact
  first and second time derivatives of the reference direction; :func:`biased_los_guidance` and
  :func:`integral_los_bias` - its integral form against currents (Borhaug et al. 2008), with the
  integrator turning with the curvature direction on a twisted path
  (:func:`normal_plane_turn_rate`); :func:`restoring_moment_in_frame` - the restoring moment used by
  the hydrostatic compensation; :func:`finite_difference_acceleration` - the measured acceleration
  of the end-effector; :func:`thruster_power` - a thruster's mechanical power (a diagnostic);
* :func:`reduced_attitude_law` - the reduced-attitude law of eq. (9) (and eq. 23 for ``J = I``,
  ``m = 0``) with the ``"paper"`` or ``"exact"`` feedforward (findings 1 and 2 of PAPER_DATA.md);
* :func:`joint_reference` - eq. (22); :func:`joint_pd_torque` - eq. (24) (and
  :func:`joint_pd_implicit_terms`, its implicit Euler step);
* :func:`surge_pi` - eq. (25) with conditional-integration anti-windup;
* :func:`path_following_command` - the composition of all of them (paper, Section 3).

No fast-math here: saturations, the anti-windup and the antipodal branch must take the same
decisions compiled and interpreted.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_control.paths import path_point_of
from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import cross3

#: ``|x_ref^b x e1|`` (with ``e1 . x_ref^b < 0``) at or below which ``phi_tilde = pi`` [-].
ANTIPODAL_TOLERANCE = 1e-12


# ---------------------------------------------------------------------- LOS guidance (eq. 21)
@compiled(borrows_only=True)
def los_guidance(path_point, p, p_dot, p_ddot, u_d, k_y, k_z):
    """Reference pointing direction ``x_ref = mu / |mu|`` and its exact time derivatives (eq. 21).

    :func:`biased_los_guidance` without bias; see there.
    """
    return biased_los_guidance(path_point, p, p_dot, p_ddot, u_d, k_y, k_z, _NO_BIAS)


_NO_BIAS = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@compiled(borrows_only=True)
def biased_los_guidance(path_point, p, p_dot, p_ddot, u_d, k_y, k_z, bias):
    """Reference pointing direction ``x_ref = mu / |mu|`` and its exact time derivatives.

    Path-parametrised vector LOS (the paper's eq. 21 on any path): with the closest path point, its
    rotation-minimising frame ``(T, N1, N2)`` and curvatures ``k1, k2`` (:mod:`aiauv_control.paths`), the
    cross-track errors ``e_i = (p - c) . N_i`` give

        mu = u_d T - k_y e_1 N1 - k_z e_2 N2.

    On the world x-axis this is eq. (21), ``mu = u_d e1 - K (0, p_y, p_z)``. Time derivatives
    (``D = 1 - k1 e1 - k2 e2``, dots are d/dt, primes d/ds):

        s_dot = T . p_dot / D,   e_i_dot = N_i . p_dot,   e_i_ddot = N_i . p_ddot - k_i s_dot (T . p_dot),
        T_dot = (k1 N1 + k2 N2) s_dot,   N_i_dot = -k_i T s_dot,

    and ``x_ref_dot = P mu_dot / r``, ``x_ref_ddot = (P mu_ddot - x (x_dot . mu_dot)
    - 2 x_dot (x . mu_dot)) / r`` with ``r = |mu|``, ``P = I - x x^T``.

    With a ``bias`` ``b_i`` the guidance acts on ``e_i + b_i`` instead of ``e_i`` (integral LOS,
    :func:`integral_los_bias`): ``mu = u_d T - k_y (e_1 + b_1) N1 - k_z (e_2 + b_2) N2``; the
    bias's own time derivatives enter ``mu_dot`` and ``mu_ddot``. A zero bias gives exactly the
    unbiased numbers.

    Args:
        path_point: The :class:`aiauv_control.paths.PathPoint` closest to ``p``.
        p, p_dot, p_ddot: End-effector position [m], velocity [m/s] and acceleration [m/s^2] (3,).
        u_d: Desired speed along the path [m/s] (> 0).
        k_y, k_z: Cross-track gains along ``N1`` and ``N2`` [1/s].
        bias: ``(b_1, b_2, b_1_dot, b_2_dot, b_1_ddot, b_2_ddot)`` [m], [m/s], [m/s^2].

    Returns:
        ``(x_ref, x_ref_dot, x_ref_ddot)``, each a 3-tuple (world frame; [-], [1/s], [1/s^2]).
    """
    c = path_point.point
    t0, t1, t2 = path_point.tangent
    a0, a1, a2 = path_point.normal1
    b0, b1, b2 = path_point.normal2
    k1, k2 = path_point.curvature1, path_point.curvature2
    dk1, dk2 = path_point.curvature1_rate, path_point.curvature2_rate
    d0, d1, d2 = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    e1 = a0 * d0 + a1 * d1 + a2 * d2
    e2 = b0 * d0 + b1 * d1 + b2 * d2
    tv = t0 * p_dot[0] + t1 * p_dot[1] + t2 * p_dot[2]
    e1_dot = a0 * p_dot[0] + a1 * p_dot[1] + a2 * p_dot[2]
    e2_dot = b0 * p_dot[0] + b1 * p_dot[1] + b2 * p_dot[2]
    ta = t0 * p_ddot[0] + t1 * p_ddot[1] + t2 * p_ddot[2]
    # the errors the guidance acts on: e_i + b_i (b = 0 without integral LOS)
    g1, g2 = e1 + bias[0], e2 + bias[1]
    g1_dot, g2_dot = e1_dot + bias[2], e2_dot + bias[3]
    # mu and its derivatives; on a straight path (k = 0) only the cross-track terms remain
    m0 = u_d * t0 - k_y * g1 * a0 - k_z * g2 * b0
    m1 = u_d * t1 - k_y * g1 * a1 - k_z * g2 * b1
    m2 = u_d * t2 - k_y * g1 * a2 - k_z * g2 * b2
    e1_ddot = a0 * p_ddot[0] + a1 * p_ddot[1] + a2 * p_ddot[2]
    e2_ddot = b0 * p_ddot[0] + b1 * p_ddot[1] + b2 * p_ddot[2]
    v0 = -k_y * g1_dot * a0 - k_z * g2_dot * b0
    v1 = -k_y * g1_dot * a1 - k_z * g2_dot * b1
    v2 = -k_y * g1_dot * a2 - k_z * g2_dot * b2
    w0 = -k_y * (e1_ddot + bias[4]) * a0 - k_z * (e2_ddot + bias[5]) * b0
    w1 = -k_y * (e1_ddot + bias[4]) * a1 - k_z * (e2_ddot + bias[5]) * b1
    w2 = -k_y * (e1_ddot + bias[4]) * a2 - k_z * (e2_ddot + bias[5]) * b2
    if k1 != 0.0 or k2 != 0.0 or dk1 != 0.0 or dk2 != 0.0:
        big_d = 1.0 - k1 * e1 - k2 * e2
        s_dot = tv / big_d
        # curvature vector kappa = k1 N1 + k2 N2 and its parts
        kv0, kv1, kv2 = k1 * a0 + k2 * b0, k1 * a1 + k2 * b1, k1 * a2 + k2 * b2
        kp = kv0 * p_dot[0] + kv1 * p_dot[1] + kv2 * p_dot[2]
        d_dot = -(dk1 * s_dot * e1 + k1 * e1_dot + dk2 * s_dot * e2 + k2 * e2_dot)
        s_ddot = (kp * s_dot + ta) / big_d - tv * d_dot / (big_d * big_d)
        e1_ddot -= k1 * s_dot * tv
        e2_ddot -= k2 * s_dot * tv
        e1_ddot += bias[4]
        e2_ddot += bias[5]
        e1, e2, e1_dot, e2_dot = g1, g2, g1_dot, g2_dot
        # T_dot = kappa s_dot;  N_i_dot = -k_i T s_dot
        # T_ddot = (k1' N1 + k2' N2) s_dot^2 - (k1^2 + k2^2) T s_dot^2 + kappa s_ddot
        # N_i_ddot = -k_i' s_dot^2 T - k_i kappa s_dot^2 - k_i T s_ddot
        s2 = s_dot * s_dot
        kk = k1 * k1 + k2 * k2
        td0, td1, td2 = kv0 * s_dot, kv1 * s_dot, kv2 * s_dot
        tdd0 = (dk1 * a0 + dk2 * b0) * s2 - kk * t0 * s2 + kv0 * s_ddot
        tdd1 = (dk1 * a1 + dk2 * b1) * s2 - kk * t1 * s2 + kv1 * s_ddot
        tdd2 = (dk1 * a2 + dk2 * b2) * s2 - kk * t2 * s2 + kv2 * s_ddot
        n1d = -k1 * s_dot
        n2d = -k2 * s_dot
        n1dd0 = -dk1 * s2 * t0 - k1 * kv0 * s2 - k1 * t0 * s_ddot
        n1dd1 = -dk1 * s2 * t1 - k1 * kv1 * s2 - k1 * t1 * s_ddot
        n1dd2 = -dk1 * s2 * t2 - k1 * kv2 * s2 - k1 * t2 * s_ddot
        n2dd0 = -dk2 * s2 * t0 - k2 * kv0 * s2 - k2 * t0 * s_ddot
        n2dd1 = -dk2 * s2 * t1 - k2 * kv1 * s2 - k2 * t1 * s_ddot
        n2dd2 = -dk2 * s2 * t2 - k2 * kv2 * s2 - k2 * t2 * s_ddot
        # mu_dot = u_d T_dot - k_y (e1_dot N1 + e1 N1_dot) - k_z (e2_dot N2 + e2 N2_dot)
        v0 += u_d * td0 - k_y * e1 * n1d * t0 - k_z * e2 * n2d * t0
        v1 += u_d * td1 - k_y * e1 * n1d * t1 - k_z * e2 * n2d * t1
        v2 += u_d * td2 - k_y * e1 * n1d * t2 - k_z * e2 * n2d * t2
        # mu_ddot = u_d T_ddot - k_y (e1_ddot N1 + 2 e1_dot N1_dot + e1 N1_ddot) - k_z (...)
        w0 = (
            u_d * tdd0
            - k_y * (e1_ddot * a0 + 2.0 * e1_dot * n1d * t0 + e1 * n1dd0)
            - k_z * (e2_ddot * b0 + 2.0 * e2_dot * n2d * t0 + e2 * n2dd0)
        )
        w1 = (
            u_d * tdd1
            - k_y * (e1_ddot * a1 + 2.0 * e1_dot * n1d * t1 + e1 * n1dd1)
            - k_z * (e2_ddot * b1 + 2.0 * e2_dot * n2d * t1 + e2 * n2dd1)
        )
        w2 = (
            u_d * tdd2
            - k_y * (e1_ddot * a2 + 2.0 * e1_dot * n1d * t2 + e1 * n1dd2)
            - k_z * (e2_ddot * b2 + 2.0 * e2_dot * n2d * t2 + e2 * n2dd2)
        )
    r = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    x0, x1, x2 = m0 / r, m1 / r, m2 / r
    x_mud = x0 * v0 + x1 * v1 + x2 * v2
    xd0 = (v0 - x0 * x_mud) / r  # P mu_dot / r
    xd1 = (v1 - x1 * x_mud) / r
    xd2 = (v2 - x2 * x_mud) / r
    x_mudd = x0 * w0 + x1 * w1 + x2 * w2
    xd_mud = xd0 * v0 + xd1 * v1 + xd2 * v2
    # d/dt of P mu_dot / r
    xdd0 = (w0 - x0 * x_mudd - x0 * xd_mud - 2.0 * xd0 * x_mud) / r
    xdd1 = (w1 - x1 * x_mudd - x1 * xd_mud - 2.0 * xd1 * x_mud) / r
    xdd2 = (w2 - x2 * x_mudd - x2 * xd_mud - 2.0 * xd2 * x_mud) / r
    return (x0, x1, x2), (xd0, xd1, xd2), (xdd0, xdd1, xdd2)


# ---------------------------------------------------------------------- integral LOS
class GuidanceState(NamedTuple):
    """State of :func:`integral_los_bias`, each field an array updated in place.

    Attributes:
        integral: ILOS integrator ``z_i`` per normal ``N1``, ``N2`` (2,) [m].
        has_previous: 1 once a sample has been taken (1,).
        time: Time of the previous sample (1,) [s].
        rate: ``z_i_dot`` at the previous sample (2,) [m/s].
    """

    integral: np.ndarray
    has_previous: np.ndarray
    time: np.ndarray
    rate: np.ndarray


def new_guidance_state() -> GuidanceState:
    """A cleared :class:`GuidanceState`."""
    return GuidanceState(np.zeros(2), np.zeros(1), np.zeros(1), np.zeros(2))


@compiled(borrows_only=True)
def cross_track_errors(path_point, p, p_dot):
    """``(e_1, e_2, e_1_dot, e_2_dot)``: offsets from the closest path point along ``N1``, ``N2``
    [m] and their rates ``N_i . p_dot`` [m/s] (exact on a line; on a curve the normals' own turning
    is left out, which only the ILOS feedforward uses)."""
    c = path_point.point
    n1, n2 = path_point.normal1, path_point.normal2
    d0, d1, d2 = p[0] - c[0], p[1] - c[1], p[2] - c[2]
    return (
        n1[0] * d0 + n1[1] * d1 + n1[2] * d2,
        n2[0] * d0 + n2[1] * d1 + n2[2] * d2,
        n1[0] * p_dot[0] + n1[1] * p_dot[1] + n1[2] * p_dot[2],
        n2[0] * p_dot[0] + n2[1] * p_dot[1] + n2[2] * p_dot[2],
    )


@compiled
def path_errors_of_positions(user, kind, params, positions, s_out, errors_out):
    """Closest-point parameter ``s`` [m] and cross-track errors ``(e_1, e_2)`` [m] of many positions.

    For a run whose controller logged no path quantities (a passive run, a user's controller):
    :func:`cross_track_errors` at each of ``positions`` (n, 3) [m] (world), in one compiled call.

    Args:
        user, kind, params: The path, as :data:`aiauv_control.paths.path_point_of` takes it.
        positions: End-effector positions (n, 3) [m].
        s_out: Output (n,) [m].
        errors_out: Output (n, 2) [m].
    """
    still = (0.0, 0.0, 0.0)
    for k in range(positions.shape[0]):
        p = positions[k]
        point = path_point_of(user, kind, p, params)
        e = cross_track_errors(point, p, still)
        s_out[k] = point.s
        errors_out[k, 0] = e[0]
        errors_out[k, 1] = e[1]


@compiled
def _ilos_rate(e, z, lookahead, sigma):
    """``z_dot = Delta e / ((e + sigma z)^2 + Delta^2)`` [m/s] (Borhaug et al. 2008, eq. 9)."""
    g = e + sigma * z
    return lookahead * e / (g * g + lookahead * lookahead)


@compiled(borrows_only=True)
def normal_plane_turn_rate(path_point, p_dot, e1, e2):
    """Rate at which the path's curvature direction turns about ``T`` in ``(N1, N2)`` [rad/s].

    With ``kappa = k1 N1 + k2 N2`` in the rotation-minimising frame, its angle
    ``phi = atan2(k2, k1)`` advances at ``phi' = (k1 k2' - k2 k1') / (k1^2 + k2^2)`` per metre,
    which is the path's torsion (the rotation-minimising frame does not turn about ``T``, the Frenet
    frame turns at the torsion; Bishop 1975, "There is more than one way to frame a curve", Amer.
    Math. Monthly 82(3)); times ``s_dot = T . p_dot / (1 - k1 e1 - k2 e2)`` (see
    :func:`biased_los_guidance`). Zero on straight segments and on plane curves; ``0.0975 1/m``
    curvature and ``0.0155 1/m`` torsion on the 10 m, 10 m-per-turn helix.
    """
    k1, k2 = path_point.curvature1, path_point.curvature2
    kk = k1 * k1 + k2 * k2
    if kk == 0.0:
        return 0.0
    torsion = (k1 * path_point.curvature2_rate - k2 * path_point.curvature1_rate) / kk
    if torsion == 0.0:
        return 0.0
    t = path_point.tangent
    s_dot = (t[0] * p_dot[0] + t[1] * p_dot[1] + t[2] * p_dot[2]) / (1.0 - k1 * e1 - k2 * e2)
    return torsion * s_dot


@compiled(borrows_only=True)
def integral_los_bias(state, t, errors, u_d, k_y, k_z, sigma, frame_rate=0.0):
    """Integral LOS bias ``b_i = sigma z_i`` and its time derivatives at time ``t``; advances ``state``.

    Integral line-of-sight guidance of Borhaug, Pavlov and Pettersen (2008, "Integral LOS control for
    path following of underactuated marine surface vessels in the presence of constant ocean
    currents", IEEE CDC, eqs. 8-9), applied on each normal of the path as in the 3-D ILOS of
    Caharija et al. (2016, IEEE TCST 24(5), and their 3-D AUV version, Caharija et al. 2012, IEEE CDC).
    In the vector form of eq. (21) the lookahead distance is ``Delta_i = u_d / k_i`` and

        mu = u_d T - k_i (e_i + sigma z_i) N_i,    z_i_dot = Delta_i e_i / ((e_i + sigma z_i)^2 + Delta_i^2),

    so that at a steady state with a constant current ``e_i = 0`` and ``sigma z_i`` holds the offset
    the current needs (the crab angle); the denominator slows the integration far from the path
    (anti-windup by construction). ``z`` advances by its previous rate held over the elapsed time
    (zero-order hold, like :func:`surge_pi`).

    On a path with torsion (a helix) the offset the vehicle needs in a steady turn (the head's
    sideslip and angle of attack, set by the curvature) is steady in the Frenet frame, which turns
    about ``T`` at ``frame_rate`` (:func:`normal_plane_turn_rate`) relative to ``(N1, N2)``. An
    integrator fixed in ``(N1, N2)`` can follow that turning bias only with a steady error
    ``e = |b| frame_rate Delta / sigma`` (2.3 cm on the helix at ``sigma = 1``, ``Delta = 5 m``). So
    ``z`` turns with the curvature direction:

        z_dot = (Delta_1 e_1 / (...), Delta_2 e_2 / (...)) + frame_rate (-z_2, z_1),

    exact for a constant bias in the Frenet frame; on straight segments and plane curves
    ``frame_rate = 0`` and this is Borhaug's law. In ``b_ddot`` the frame rate is held constant.

    Args:
        state: :class:`GuidanceState` (advanced).
        t: Time [s].
        errors: ``(e_1, e_2, e_1_dot, e_2_dot)`` of :func:`cross_track_errors`.
        u_d: Desired speed [m/s]; k_y, k_z: cross-track gains [1/s]; sigma: integral gain [-] (> 0).
        frame_rate: Turn rate of the curvature direction about ``T`` [rad/s]
            (:func:`normal_plane_turn_rate`; 0 on a line).

    Returns:
        ``(b_1, b_2, b_1_dot, b_2_dot, b_1_ddot, b_2_ddot)`` [m], [m/s], [m/s^2] for
        :func:`biased_los_guidance`.
    """
    if state.has_previous[0] != 0.0 and t > state.time[0]:
        h = t - state.time[0]
        state.integral[0] += state.rate[0] * h
        state.integral[1] += state.rate[1] * h
    # turning of the integrator with the curvature direction: frame_rate (-z_2, z_1)
    turn_1, turn_2 = -frame_rate * state.integral[1], frame_rate * state.integral[0]
    b_1, b_1_dot, b_1_ddot = _ilos_axis(state, 0, errors[0], errors[2], u_d / k_y, sigma, turn_1)
    b_2, b_2_dot, b_2_ddot = _ilos_axis(state, 1, errors[1], errors[3], u_d / k_z, sigma, turn_2)
    if frame_rate != 0.0:
        # d/dt of frame_rate (-z_2, z_1) with frame_rate held: frame_rate (-z_2_dot, z_1_dot)
        b_1_ddot -= frame_rate * b_2_dot
        b_2_ddot += frame_rate * b_1_dot
    state.has_previous[0] = 1.0
    state.time[0] = t
    return b_1, b_2, b_1_dot, b_2_dot, b_1_ddot, b_2_ddot


@compiled(borrows_only=True)
def _ilos_axis(state, i, e, e_dot, lookahead, sigma, turn):
    """One normal ``i`` of :func:`integral_los_bias`: stores ``z_i_dot`` in ``state.rate[i]`` and
    returns ``(sigma z_i, sigma z_i_dot, sigma z_i_ddot)`` [m], [m/s], [m/s^2]."""
    z = state.integral[i]
    z_dot = _ilos_rate(e, z, lookahead, sigma) + turn
    g = e + sigma * z
    den = g * g + lookahead * lookahead
    # d/dt [Delta e / den] = Delta (e_dot den - e 2 g (e_dot + sigma z_dot)) / den^2
    z_ddot = lookahead * (e_dot * den - 2.0 * e * g * (e_dot + sigma * z_dot)) / (den * den)
    state.rate[i] = z_dot
    return sigma * z, sigma * z_dot, sigma * z_ddot


@compiled(borrows_only=True)
def finite_difference_acceleration(t, velocity, history, acceleration):
    """The measured acceleration of a frame [m/s^2] into ``acceleration`` (3,): the difference of its
    world velocity ``velocity`` (3,) [m/s] with the previous sample's over the elapsed time, zero
    at the first sample or when ``t`` [s] does not advance (the paper's controller needs ``p_ddot``
    for the feed-forward of eq. 9; the simulator gives it no acceleration sensor).

    ``history`` (5,) holds the previous sample (has one (1.0) or not (0.0), its time [s], its
    velocity (3) [m/s]) and is updated to this one.
    """
    for i in range(3):
        acceleration[i] = 0.0
    if history[0] != 0.0 and t > history[1]:
        h = t - history[1]
        for i in range(3):
            acceleration[i] = (velocity[i] - history[2 + i]) / h
    history[0] = 1.0
    history[1] = t
    for i in range(3):
        history[2 + i] = velocity[i]


@compiled
def thruster_power(axis_speed, thrust):
    """Mechanical power of a thruster [W]: its thrust [N] times the speed [m/s] of its point along
    its axis (the thruster's entry of ``v^T B(q)``, eq. 20's thrust matrix). Works on scalars
    (compiled) and, interpreted, on arrays of thrusters."""
    return axis_speed * thrust


@compiled(borrows_only=True)
def restoring_moment_in_frame(base_rotation, base_position, rotation, position, base_wrench):
    """Moment of the restoring wrench about a frame's origin, in its axes [N m].

    ``base_wrench`` is the free-flyer part ``g[0:6]`` of the restoring generalised force (left-hand
    side of eq. 19: weight minus buoyancy), a spatial force ``(f, n)`` in the base frame about the
    base origin; the frame has rotation ``R_e`` and position ``p_e`` in the world, the base ``R_b``,
    ``p_b``. Moved to the frame origin: ``n_e = R_e^T (R_b n - (p_e - p_b) x R_b f)`` (for a neutrally
    buoyant vehicle ``f = 0`` and the moment is the same about every point). ``position`` may be any
    indexable of three floats (array or tuple).

    Returns:
        ``(n_e,x, n_e,y, n_e,z)``, a tuple of three floats (no array is allocated) [N m].
    """
    w0, w1, w2 = base_wrench[0], base_wrench[1], base_wrench[2]
    w3, w4, w5 = base_wrench[3], base_wrench[4], base_wrench[5]
    f0 = base_rotation[0, 0] * w0 + base_rotation[0, 1] * w1 + base_rotation[0, 2] * w2
    f1 = base_rotation[1, 0] * w0 + base_rotation[1, 1] * w1 + base_rotation[1, 2] * w2
    f2 = base_rotation[2, 0] * w0 + base_rotation[2, 1] * w1 + base_rotation[2, 2] * w2
    n0 = base_rotation[0, 0] * w3 + base_rotation[0, 1] * w4 + base_rotation[0, 2] * w5
    n1 = base_rotation[1, 0] * w3 + base_rotation[1, 1] * w4 + base_rotation[1, 2] * w5
    n2 = base_rotation[2, 0] * w3 + base_rotation[2, 1] * w4 + base_rotation[2, 2] * w5
    r0 = position[0] - base_position[0]
    r1 = position[1] - base_position[1]
    r2 = position[2] - base_position[2]
    c0, c1, c2 = cross3(r0, r1, r2, f0, f1, f2)
    n0 -= c0
    n1 -= c1
    n2 -= c2
    return (
        rotation[0, 0] * n0 + rotation[1, 0] * n1 + rotation[2, 0] * n2,
        rotation[0, 1] * n0 + rotation[1, 1] * n1 + rotation[2, 1] * n2,
        rotation[0, 2] * n0 + rotation[1, 2] * n1 + rotation[2, 2] * n2,
    )


# ---------------------------------------------------------------------- reduced attitude (eq. 9)
@compiled
def one_plus_cos(y0, y1, y2):
    """``1 + e1 . y`` for a unit ``y``; as ``|y x e1|^2 / (1 - e1 . y)`` when ``e1 . y < 0``."""
    if y0 >= 0.0:
        return 1.0 + y0
    return (y1 * y1 + y2 * y2) / (1.0 - y0)


@compiled
def is_antipodal(y0, y1, y2):
    """True if ``y`` is within :data:`ANTIPODAL_TOLERANCE` of ``-e1`` (``phi_tilde = pi``)."""
    return y0 < 0.0 and math.hypot(y1, y2) <= ANTIPODAL_TOLERANCE


@compiled
def error_angle(y0, y1, y2):
    """Pointing error ``phi_tilde = atan2(|y x e1|, e1 . y)`` in ``[0, pi]`` [rad] (eq. 4)."""
    return math.atan2(math.hypot(y1, y2), y0)


@compiled
def error_axis_angle(y0, y1, y2):
    """``phi_tilde n = (phi_tilde / sin phi_tilde) (y x e1)`` (eq. 9); 0 at 0 and (by convention) at pi."""
    sin_phi = math.hypot(y1, y2)
    if sin_phi == 0.0 or is_antipodal(y0, y1, y2):
        return 0.0, 0.0, 0.0
    scale = error_angle(y0, y1, y2) / sin_phi
    return 0.0, scale * y2, scale * -y1


@compiled
def minimal_rotation(y0, y1, y2):
    """``R_tilde = I + S(k) + S(k)^2 / (1 + e1 . y)``, ``k = y x e1`` (eq. 5), as three row tuples.

    ``R_tilde y = e1``; the identity at the antipodal point (paper, after eq. 9).
    """
    if is_antipodal(y0, y1, y2):
        return (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    k1, k2 = y2, -y1
    # S(k) = [[0, -k2, k1], [k2, 0, 0], [-k1, 0, 0]];
    # S(k)^2 = [[-(k1^2 + k2^2), 0, 0], [0, -k2^2, k1 k2], [0, k1 k2, -k1^2]]
    opc = one_plus_cos(y0, y1, y2)
    return (
        (1.0 + (-(k1 * k1 + k2 * k2)) / opc, -k2, k1),
        (k2, 1.0 + (-(k2 * k2)) / opc, (k1 * k2) / opc),
        (-k1, (k2 * k1) / opc, 1.0 + (-(k1 * k1)) / opc),
    )


@compiled
def rate_correction(delta0, delta1, delta2, y0, y1, y2):
    """Finding 2: ``mu = -(e1 . delta + y . delta) / (1 + e1 . y)`` [rad/s]; 0 at the antipode."""
    if is_antipodal(y0, y1, y2):
        return 0.0
    return -delta0 - (y1 * delta1 + y2 * delta2) / one_plus_cos(y0, y1, y2)


@compiled
def reference_rate_in_body(R, r0, r1, r2, x_derivative):
    """``R^T (x_ref x x_ref^(k))``: the reference's angular rate seen from the body, 3 floats.

    With the first derivative ``x_ref_dot`` it is ``omega_ref^b``, the reference angular velocity
    [rad/s] (eq. 3); with the second, ``x_ref_ddot``, the reference angular acceleration
    [rad/s^2] of the feed-forward of eqs. (9) and (10) (finding 1:
    ``d/dt (x_ref x x_ref_dot) = x_ref x x_ref_ddot``).

    Args:
        R: Body-to-world rotation (3, 3).
        r0, r1, r2: The unit reference direction ``x_ref``, world axes.
        x_derivative: Its first or second time derivative, world axes (3-indexable) [1/s], [1/s^2].
    """
    c0, c1, c2 = cross3(r0, r1, r2, x_derivative[0], x_derivative[1], x_derivative[2])
    return (
        R[0, 0] * c0 + R[1, 0] * c1 + R[2, 0] * c2,
        R[0, 1] * c0 + R[1, 1] * c1 + R[2, 1] * c2,
        R[0, 2] * c0 + R[1, 2] * c1 + R[2, 2] * c2,
    )


class AttitudeCommand(NamedTuple):
    """Output of :func:`reduced_attitude_law`."""

    u_y: float
    """Control about the body y-axis (eq. 9) [N m], or base angle ``q_y0`` (eq. 23) [rad]."""
    u_z: float
    """Control about the body z-axis [N m], or ``q_z0`` [rad]."""
    phi_tilde: float
    """Pointing error [rad] (eq. 4)."""
    omega_tilde_y: float
    """Angular velocity error about y [rad/s] (eq. 8)."""
    omega_tilde_z: float
    """Angular velocity error about z [rad/s] (eq. 8)."""
    rate_ref_y: float = 0.0
    """Reference angular velocity ``H^T R_tilde omega_ref^b`` about y [rad/s] (eq. 8)."""
    rate_ref_z: float = 0.0
    """The same about z [rad/s]."""
    accel_ref_y: float = 0.0
    """Reference angular acceleration of the feedforward of eq. (9) (finding 2 included when
    exact), ``H^T R_tilde R^T (x_ref x x_ref_ddot)`` about y [rad/s^2]."""
    accel_ref_z: float = 0.0
    """The same about z [rad/s^2]."""


@compiled(borrows_only=True)
def reduced_attitude_law(R, omega, x_ref, x_dot, x_ddot, J, m_y, m_z, k_p, k_d, exact):
    """The reduced-attitude tracking law of eq. (9), findings 1 and 2 applied.

    ``u = -k_P phi_tilde H^T n - k_D omega_tilde + H^T (J R_tilde R^T (x_ref x x_ref_ddot) - m)``,
    plus ``mu H^T J R_tilde (y x omega_ref^b)`` when ``exact`` (finding 2), with
    ``y = R^T x_ref``, ``omega_ref^b = R^T (x_ref x x_ref_dot)`` (eq. 3) and
    ``omega_tilde = H^T (omega - R_tilde omega_ref^b)`` (eq. 8). Eq. (23), the base angles, is this law
    on the end-effector frame with ``J = I`` and ``m = 0``.

    Args:
        R: Body-to-world rotation (3, 3).
        omega: Body angular velocity, body axes (3,) [rad/s].
        x_ref: Reference direction, world (3-sequence; renormalised here).
        x_dot, x_ddot: Its first and second time derivatives [1/s], [1/s^2].
        J: Inertia (3, 3) [kg m^2], block-diagonal (Assumption 1): only ``J[1:, 1:]`` enters.
        m_y, m_z: Known moments about the body y- and z-axes [N m] (eq. 1).
        k_p: Proportional gain [N m/rad]; k_d: derivative gain [N m s/rad].
        exact: Add the finding-2 term.
    """
    norm = math.sqrt(x_ref[0] * x_ref[0] + x_ref[1] * x_ref[1] + x_ref[2] * x_ref[2])
    r0, r1, r2 = x_ref[0] / norm, x_ref[1] / norm, x_ref[2] / norm
    y0 = R[0, 0] * r0 + R[1, 0] * r1 + R[2, 0] * r2  # y = R^T x_ref
    y1 = R[0, 1] * r0 + R[1, 1] * r1 + R[2, 1] * r2
    y2 = R[0, 2] * r0 + R[1, 2] * r1 + R[2, 2] * r2
    _, row1, row2 = minimal_rotation(y0, y1, y2)
    w0, w1, w2 = reference_rate_in_body(R, r0, r1, r2, x_dot)  # omega_ref^b   (eq. 3)
    # omega_tilde = H^T (omega - R_tilde omega_ref^b)   (eq. 8)
    ot_y = omega[1] - (row1[0] * w0 + row1[1] * w1 + row1[2] * w2)
    ot_z = omega[2] - (row2[0] * w0 + row2[1] * w1 + row2[2] * w2)
    # R_tilde R^T (x_ref x x_ref_ddot)   (eq. 9 with finding 1)
    b0, b1, b2 = reference_rate_in_body(R, r0, r1, r2, x_ddot)
    acc1 = row1[0] * b0 + row1[1] * b1 + row1[2] * b2
    acc2 = row2[0] * b0 + row2[1] * b1 + row2[2] * b2
    if exact:
        # + mu R_tilde (y x omega_ref^b)   (finding 2)
        mu = rate_correction(omega[0] - w0, omega[1] - w1, omega[2] - w2, y0, y1, y2)
        s0, s1, s2 = cross3(y0, y1, y2, w0, w1, w2)
        acc1 = acc1 + mu * (row1[0] * s0 + row1[1] * s1 + row1[2] * s2)
        acc2 = acc2 + mu * (row2[0] * s0 + row2[1] * s1 + row2[2] * s2)
    _, n1, n2 = error_axis_angle(y0, y1, y2)
    feedforward_y = J[1, 1] * acc1 + J[1, 2] * acc2 - m_y
    feedforward_z = J[2, 1] * acc1 + J[2, 2] * acc2 - m_z
    return AttitudeCommand(
        -k_p * n1 - k_d * ot_y + feedforward_y,  # eq. (9)
        -k_p * n2 - k_d * ot_z + feedforward_z,
        error_angle(y0, y1, y2),
        ot_y,
        ot_z,
        row1[0] * w0 + row1[1] * w1 + row1[2] * w2,
        row2[0] * w0 + row2[1] * w1 + row2[2] * w2,
        acc1,
        acc2,
    )


# ---------------------------------------------------------------------- joints (eqs. 22, 24)
@compiled
def joint_reference(base_angle, scale, q_max):
    """``q*_{a,j} = exp(-alpha (j - 1)) sat(q_{a,0})`` (eq. 22), ``scale = exp(-alpha (j - 1))`` [rad]."""
    return scale * min(max(base_angle, -q_max), q_max)


@compiled
def joint_pd_torque(q, q_dot, q_ref, g_q, k_qp, k_qd):
    """Joint PD with hydrostatic compensation, ``-k_qP (q - q*) - k_qD q_dot + g_q`` (eq. 24) [N m]."""
    return -k_qp * (q - q_ref) - k_qd * q_dot + g_q


@compiled
def joint_pd_implicit_terms(h, q_dot, k_qp, k_qd):
    """What one linearly implicit Euler step of ``h`` [s] adds for the PD of eq. (24) on a joint.

    Semi-implicit Euler evaluates the PD at the step's end, ``(q + h q_dot', q_dot')``, instead of
    its start; the PD being linear, ``M (q_dot' - q_dot) / h = f(q, q_dot) - (k_qD + h k_qP)
    (q_dot' - q_dot) - h k_qP q_dot`` gives ``(M + A) (q_dot' - q_dot) / h = f - h k_qP q_dot``:
    the joint's inertia gains the armature ``A = h k_qD + h^2 k_qP`` and its torque
    ``-h k_qP q_dot`` (implicit Euler on the servo, stable for every ``h > 0``: Hairer and Wanner
    1996, "Solving ordinary differential equations II", Sec. IV.3). MuJoCo's Euler makes joint
    damping implicit the same way ("Computation: numerical integration" in its documentation), and
    its 3.13 changelog names ``M + h D + h^2 K`` as the effective metric of damping and stiffness.

    Returns:
        ``(armature [kg m^2], torque [N m])``.
    """
    return h * k_qd + h * h * k_qp, -h * k_qp * q_dot


# ---------------------------------------------------------------------- surge PI (eq. 25)
class SurgeState(NamedTuple):
    """State of :func:`surge_pi`, each field a 1-element array (updated in place).

    Attributes:
        integral: ``integral (u - u_d) dt`` [m].
        has_previous: 1 once a sample has been taken.
        time: Time of the previous sample [s].
        error: Error ``u - u_d`` of the previous sample [m/s].
        saturation: +1 / -1 if the previous output was clipped at +/- the limit, else 0.
    """

    integral: np.ndarray
    has_previous: np.ndarray
    time: np.ndarray
    error: np.ndarray
    saturation: np.ndarray


def new_surge_state() -> SurgeState:
    """A cleared :class:`SurgeState`."""
    return SurgeState(*(np.zeros(1) for _ in SurgeState._fields))


@compiled(borrows_only=True)
def surge_pi(state, t, u, k_p, k_i, u_d, max_thrust):
    """Thrust of eq. (25) at time ``t`` [N]; advances ``state``.

    ``T = sat(-k_1P (u - u_d) - k_1I integral (u - u_d) dt)``. The integral advances by the previous
    error held over the elapsed time (zero-order hold); it is frozen while the previous output was
    saturated with an error pushing further into the limit (conditional-integration anti-windup).
    """
    error = u - u_d
    if state.has_previous[0] != 0.0:
        winding_up = state.saturation[0] * state.error[0] < 0.0
        if not winding_up:
            state.integral[0] += state.error[0] * (t - state.time[0])
    demand = -k_p * error - k_i * state.integral[0]  # eq. (25)
    thrust = min(max(demand, -max_thrust), max_thrust)
    saturation = 0.0
    if thrust != demand:
        saturation = 1.0 if demand > 0.0 else (-1.0 if demand < 0.0 else 0.0)
    state.saturation[0] = saturation
    state.has_previous[0] = 1.0
    state.time[0] = t
    state.error[0] = error
    return thrust


# ---------------------------------------------------------------------- composition (Section 3)
class PaperGains(NamedTuple):
    """The gains of :func:`path_following_command` as plain floats (see
    :class:`aiauv_control.path_following.PathFollowingGains`, which builds it).

    The fields after ``exact`` switch on the extensions beyond the paper (all off by default, so
    that the paper's law is unchanged): ``turn_feedforward`` with the identified turn model
    ``turn_rate_gain`` ``G`` [1/s per rad of base angle] and ``turn_time_constant`` ``T`` [s];
    ``integral_los`` with ``los_integral_gain`` ``sigma`` [-]; ``hydrostatic_compensation`` with
    ``turn_moment_gain`` ``K_m`` [N m per rad of base angle] (see :func:`path_following_command`).
    """

    u_d: float
    k_y: float
    k_z: float
    k_p: float
    k_d: float
    k_qp: float
    k_qd: float
    k_1p: float
    k_1i: float
    max_thrust: float
    q_max: float
    exact: bool
    turn_feedforward: bool = False
    turn_rate_gain: float = 0.0
    turn_time_constant: float = 0.0
    integral_los: bool = False
    los_integral_gain: float = 0.0
    hydrostatic_compensation: bool = False
    turn_moment_gain: float = 0.0


class CommandBuffers(NamedTuple):
    """Outputs of :func:`path_following_command`, written in place."""

    joint_references: np.ndarray  # (n,) [rad] (eq. 22)
    joint_torques: np.ndarray  # (n,) [N m] (eq. 24)
    thrusts: np.ndarray  # (m,) [N] (eq. 25)
    base_angles: np.ndarray  # (2,) [rad] (eq. 23)
    omega_tilde: np.ndarray  # (2,) [rad/s] (eq. 8)
    x_ref: np.ndarray  # (3,) (eq. 21)
    x_ref_dot: np.ndarray  # (3,) [1/s]
    x_ref_ddot: np.ndarray  # (3,) [1/s^2]
    cross_track: np.ndarray  # (2,) [m] along N1, N2
    phi_tilde: np.ndarray  # (1,) [rad] (eq. 4)
    path_s: np.ndarray  # (1,) path parameter s [m]


def new_command_buffers(n_joints: int, n_thrusters: int) -> CommandBuffers:
    """Zeroed :class:`CommandBuffers`."""
    return CommandBuffers(
        np.zeros(n_joints),
        np.zeros(n_joints),
        np.zeros(n_thrusters),
        np.zeros(2),
        np.zeros(2),
        np.zeros(3),
        np.zeros(3),
        np.zeros(3),
        np.zeros(2),
        np.zeros(1),
        np.zeros(1),
    )


_IDENTITY = np.eye(3)


@compiled(borrows_only=True, inline=True)
def path_following_command(
    gains,
    path_function,
    path_kind,
    path_parameters,
    axis_index,
    reference_scale,
    surge_mask,
    surge_state,
    guidance_state,
    t,
    rotation,
    position,
    velocity,
    acceleration,
    omega,
    surge_velocity,
    joint_positions,
    joint_velocities,
    joint_hydrostatic_forces,
    restoring_moment,
    out,
):
    """One evaluation of the paper's path-following controller (Section 3) into ``out``.

    LOS guidance on the path (eq. 21, :func:`los_guidance`); base angles by the reduced-attitude
    law on the end-effector frame (eq. 23 = eq. 9 with ``J = I``, ``m = 0``); joint references
    (eq. 22) and joint PD with hydrostatic compensation (eq. 24); the surge PI (eq. 25) on the
    thrusters flagged in ``surge_mask``, all others at zero.

    Beyond the paper, switched on in ``gains`` (all off: the paper's law, to the last bit):

    * ``integral_los``: the guidance acts on ``e_i + sigma z_i`` (:func:`integral_los_bias`), which
      removes the steady cross-track offset of a constant current; on a path with torsion ``z``
      turns with the curvature direction (:func:`normal_plane_turn_rate`).
    * ``turn_feedforward``: the base angles hold the reference turn rate through the identified
      turn dynamics of the body, ``T d(omega)/dt + omega = G q_0`` per axis (end-effector angular
      velocity ``omega`` about its y and z axes, base angle ``q_0``; identified by step responses,
      see ``benchmarks/beyond_paper.py``). Its inverse replaces the ``J = I`` feedforward of eq. (23):
      ``q_0 = -k_P phi_tilde H^T n - k_D omega_tilde + (omega_ref + T omega_ref_dot) / G`` with
      ``omega_ref = H^T R_tilde omega_ref^b`` (eq. 8) and ``omega_ref_dot`` the reference angular
      acceleration of eq. (9). On a helix ``omega_ref`` is the path's curvature times the speed, so
      the body holds the curvature of the path without a steady pointing error: the curvature
      feedforward of path-parametrised guidance (Breivik and Fossen 2004, "Path following for
      marine surface vessels", OCEANS; Lekkas and Fossen 2014, "Integral LOS path following for
      curved paths based on a monotone cubic Hermite spline parametrization", IEEE TCST 22(6)).
    * ``hydrostatic_compensation``: ``+ H^T g_e / K_m``, the base angle whose hydrodynamic turning
      moment ``K_m q_0`` (an effective gain, calibrated on the paper's scenario:
      :data:`aiauv_control.path_following.PAPER_TURN_MOMENT_GAIN`) balances the restoring moment
      ``g_e`` about the
      end-effector (``restoring_moment``, left-hand side of eq. 19, end-effector axes; the paper's
      Conclusions name this as future work).

    Args:
        gains: :class:`PaperGains`.
        path_function, path_kind, path_parameters: The path (:mod:`aiauv_control.paths`): a user's
            compiled function, or ``None`` and the built-in path's ``kind_code``.
        axis_index: Base angle (0: y, 1: z) driving each joint (n,).
        reference_scale: ``exp(-alpha (j - 1))`` per joint (n,).
        surge_mask: 1 for the surge thrusters (m,).
        surge_state: :class:`SurgeState` (advanced).
        guidance_state: :class:`GuidanceState` (advanced when ``gains.integral_los``).
        t: Time [s].
        rotation: End-effector-to-world rotation (3, 3).
        position, velocity, acceleration: End-effector position [m], velocity [m/s] and
            acceleration [m/s^2], world (3,).
        omega: End-effector angular velocity in its own axes (3,) [rad/s].
        surge_velocity: ``u`` [m/s], end-effector velocity along its own x-axis.
        joint_positions, joint_velocities, joint_hydrostatic_forces: (n,) [rad], [rad/s], [N m].
        restoring_moment: Restoring moment of the whole vehicle about the end-effector, its axes,
            left-hand side of eq. (19), three floats (array or tuple) [N m]
            (:func:`restoring_moment_in_frame`; used only with ``gains.hydrostatic_compensation``).
        out: :class:`CommandBuffers`.
    """
    point = path_point_of(path_function, path_kind, position, path_parameters)
    errors = cross_track_errors(point, position, velocity)
    bias = _NO_BIAS
    if gains.integral_los:
        bias = integral_los_bias(  # Borhaug et al. (2008), in 3-D
            guidance_state,
            t,
            errors,
            gains.u_d,
            gains.k_y,
            gains.k_z,
            gains.los_integral_gain,
            normal_plane_turn_rate(point, velocity, errors[0], errors[1]),
        )
    x_ref, x_dot, x_ddot = biased_los_guidance(  # eq. (21)
        point, position, velocity, acceleration, gains.u_d, gains.k_y, gains.k_z, bias
    )
    command = reduced_attitude_law(  # eqs. (23), (4), (8)
        rotation,
        omega,
        x_ref,
        x_dot,
        x_ddot,
        _IDENTITY,
        0.0,
        0.0,
        gains.k_p,
        gains.k_d,
        gains.exact,
    )
    out.base_angles[0] = command.u_y
    out.base_angles[1] = command.u_z
    if gains.turn_feedforward:
        # the inverse turn dynamics replace the J = I feedforward of eq. (23)
        scale = 1.0 / gains.turn_rate_gain
        tc = gains.turn_time_constant
        out.base_angles[0] += (
            scale * (command.rate_ref_y + tc * command.accel_ref_y) - command.accel_ref_y
        )
        out.base_angles[1] += (
            scale * (command.rate_ref_z + tc * command.accel_ref_z) - command.accel_ref_z
        )
    if gains.hydrostatic_compensation:
        out.base_angles[0] += restoring_moment[1] / gains.turn_moment_gain
        out.base_angles[1] += restoring_moment[2] / gains.turn_moment_gain
    out.omega_tilde[0] = command.omega_tilde_y
    out.omega_tilde[1] = command.omega_tilde_z
    for j in range(joint_positions.shape[0]):
        ref = joint_reference(out.base_angles[axis_index[j]], reference_scale[j], gains.q_max)
        out.joint_references[j] = ref  # eq. (22)
        out.joint_torques[j] = joint_pd_torque(  # eq. (24)
            joint_positions[j],
            joint_velocities[j],
            ref,
            joint_hydrostatic_forces[j],
            gains.k_qp,
            gains.k_qd,
        )
    thrust = surge_pi(  # eq. (25)
        surge_state, t, surge_velocity, gains.k_1p, gains.k_1i, gains.u_d, gains.max_thrust
    )
    for k in range(surge_mask.shape[0]):
        out.thrusts[k] = thrust if surge_mask[k] != 0 else 0.0
    for i in range(3):
        out.x_ref[i] = x_ref[i]
        out.x_ref_dot[i] = x_dot[i]
        out.x_ref_ddot[i] = x_ddot[i]
    out.cross_track[0] = errors[0]
    out.cross_track[1] = errors[1]
    out.phi_tilde[0] = command.phi_tilde
    out.path_s[0] = point.s
