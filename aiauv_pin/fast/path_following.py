"""The paper's path-following controller compiled with numba, and the scenario loop around it.

:mod:`control` stays the plain-numpy reference; this module re-implements, for speed, exactly what
:class:`control.path_following.PathFollowingController` computes from what
:meth:`aiauv_pin.path_following.VehiclePathFollowing.measure` measures:

* the measurement: end-effector pose and twist (the frame fixed to its body), its world velocity,
  the finite difference of that velocity between two samples as its acceleration (zero at the first
  sample or when the time does not advance), the joints' hydrostatic forces ``g_q`` (left-hand
  side) and the surge speed ``u`` (x-component of the end-effector velocity in its own axes);
* LOS guidance ``x_ref = mu / |mu|`` with its first two derivatives (paper, eq. 21;
  :func:`control.guidance.los_reference`);
* the base angles (eq. 23 = eq. 9 with ``J = I``, ``m = 0``) with the ``"paper"`` or ``"exact"``
  feedforward, the pointing error ``phi_tilde`` (eq. 4) and ``omega_tilde`` (eq. 8), with the same
  antipodal conventions (:mod:`control.reduced_attitude`);
* joint references with saturation (eq. 22), joint PD with hydrostatic compensation (eq. 24);
* the surge PI (eq. 25) with conditional-integration anti-windup and zero-order-hold integral
  (:class:`control.surge.SurgePIController`);
* the generalised force ``tau = B(q) tau_thr (+ [0; tau_q])`` (eq. 20) and the thrusters'
  mechanical power.

tests/test_fast_controller.py checks every output against :mod:`control` to 1e-12 and a whole
compiled run against the Python-controller run.

:func:`run_path_following` runs a whole scenario (dynamics steps, the controller every control
period and the logging into preallocated arrays) in compiled code, one chunk of about a second of
simulated time per call, so that a progress bar and ``on_log`` callbacks still run between chunks.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping

import numpy as np
from numba import njit

from . import kernels

# No fast-math here: the controller's branches (saturation, anti-windup, antipodal point) must take
# the same decisions as the numpy reference.
_OPTS = dict(cache=True, nogil=True, error_model="numpy")

ANTIPODAL_TOLERANCE = 1e-12  # as control.reduced_attitude.ANTIPODAL_TOLERANCE

# layout of the float parameter vector ``P``
(
    P_U_D,
    P_K_Y,
    P_K_Z,
    P_K_P,
    P_K_D,
    P_K_QP,
    P_K_QD,
    P_K_1P,
    P_K_1I,
    P_MAX_THRUST,
    P_Q_MAX,
    P_EXACT,
    P_CONTINUOUS,
) = range(13)
N_PARAMETERS = 13

# layout of the controller state vector ``S``
(
    S_INTEGRAL,
    S_SURGE_HAS_PREVIOUS,
    S_SURGE_TIME,
    S_SURGE_ERROR,
    S_SURGE_SATURATION,
    S_VEL_HAS_PREVIOUS,
    S_VEL_TIME,
    S_VEL_X,
    S_VEL_Y,
    S_VEL_Z,
) = range(10)
N_STATE = 10


def info_layout(n_joints: int, n_thrusters: int) -> dict[str, tuple[int, tuple[int, ...]]]:
    """Offset and shape of each logged diagnostic inside one row of the info block.

    The keys and shapes are those of :meth:`aiauv_pin.path_following.VehiclePathFollowing.__call__`.
    """
    shapes = {
        "p": (3,),
        "u": (),
        "phi_tilde": (),
        "omega_tilde": (2,),
        "base_angles": (2,),
        "joint_references": (n_joints,),
        "x_ref": (3,),
        "pointing": (3,),
        "thrust": (n_thrusters,),
        "thruster_power": (n_thrusters,),
        "joint_torque": (n_joints,),
    }
    layout = {}
    offset = 0
    for key, shape in shapes.items():
        layout[key] = (offset, shape)
        offset += int(np.prod(shape, dtype=int))
    return layout


def info_width(n_joints: int, n_thrusters: int) -> int:
    """Number of floats in one row of the info block."""
    return 3 + 1 + 1 + 2 + 2 + n_joints + 3 + 3 + 2 * n_thrusters + n_joints


# ---------------------------------------------------------------------- control laws
@njit(**_OPTS)
def los_reference(p, p_dot, p_ddot, u_d, k_y, k_z, x, x_dot, x_ddot):
    """``x_ref``, ``x_ref_dot``, ``x_ref_ddot`` of eq. (21) (as :func:`control.guidance.los_reference`)."""
    # eq. (21): mu = u_d e1 - K (0, p_y, p_z); the gain on p_x is 0
    m0 = u_d - 0.0 * p[0]
    m1 = 0.0 - k_y * p[1]
    m2 = 0.0 - k_z * p[2]
    d0, d1, d2 = -0.0 * p_dot[0], -k_y * p_dot[1], -k_z * p_dot[2]
    a0, a1, a2 = -0.0 * p_ddot[0], -k_y * p_ddot[1], -k_z * p_ddot[2]
    r = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
    x[0], x[1], x[2] = m0 / r, m1 / r, m2 / r
    x_mud = x[0] * d0 + x[1] * d1 + x[2] * d2
    x_dot[0] = (d0 - x[0] * x_mud) / r  # P mu_dot / r
    x_dot[1] = (d1 - x[1] * x_mud) / r
    x_dot[2] = (d2 - x[2] * x_mud) / r
    x_mudd = x[0] * a0 + x[1] * a1 + x[2] * a2
    xd_mud = x_dot[0] * d0 + x_dot[1] * d1 + x_dot[2] * d2
    # d/dt of P mu_dot / r
    x_ddot[0] = (a0 - x[0] * x_mudd - x[0] * xd_mud - 2.0 * x_dot[0] * x_mud) / r
    x_ddot[1] = (a1 - x[1] * x_mudd - x[1] * xd_mud - 2.0 * x_dot[1] * x_mud) / r
    x_ddot[2] = (a2 - x[2] * x_mudd - x[2] * xd_mud - 2.0 * x_dot[2] * x_mud) / r


@njit(**_OPTS)
def _one_plus_cos(y0, y1, y2):
    """``1 + e1 . y``; as ``|y x e1|^2 / (1 - e1 . y)`` when ``e1 . y < 0``."""
    if y0 >= 0.0:
        return 1.0 + y0
    return (y1 * y1 + y2 * y2) / (1.0 - y0)


@njit(**_OPTS)
def pointing_law(R, omega, x_ref_in, x_dot, x_ddot, k_p, k_d, exact, q0, omega_tilde):
    """Base angles ``q0`` (eq. 23) into ``q0``, ``omega_tilde`` (eq. 8); returns ``phi_tilde``.

    As :func:`control.joint_references.pointing_law` (eq. 9 with ``J = I``, ``m = 0``), findings 1
    and 2 of :mod:`control.reduced_attitude` included (``exact`` != 0 adds the finding-2 term).
    """
    # the reference renormalises x_ref (control.reduced_attitude._unit_vector)
    norm = math.sqrt(x_ref_in[0] ** 2 + x_ref_in[1] ** 2 + x_ref_in[2] ** 2)
    r0, r1, r2 = x_ref_in[0] / norm, x_ref_in[1] / norm, x_ref_in[2] / norm
    # y = R^T x_ref
    y0 = R[0, 0] * r0 + R[1, 0] * r1 + R[2, 0] * r2
    y1 = R[0, 1] * r0 + R[1, 1] * r1 + R[2, 1] * r2
    y2 = R[0, 2] * r0 + R[1, 2] * r1 + R[2, 2] * r2
    sin_phi = math.hypot(y1, y2)
    antipodal = y0 < 0.0 and sin_phi <= ANTIPODAL_TOLERANCE
    phi = math.atan2(sin_phi, y0)  # eq. (4)
    # rows 2 and 3 of R_tilde = I + S(k) + S(k)^2 / (1 + e1 . y), k = y x e1 = (0, y2, -y1)   (eq. 5)
    if antipodal:
        t10, t11, t12 = 0.0, 1.0, 0.0
        t20, t21, t22 = 0.0, 0.0, 1.0
    else:
        k1, k2 = y2, -y1
        # S(k) = [[0, -k2, k1], [k2, 0, 0], [-k1, 0, 0]];
        # S(k)^2 = [[-(k1^2 + k2^2), 0, 0], [0, -k2^2, k1 k2], [0, k1 k2, -k1^2]]
        opc = _one_plus_cos(y0, y1, y2)
        t10 = k2
        t11 = 1.0 + (-(k2 * k2)) / opc
        t12 = (k1 * k2) / opc
        t20 = -k1
        t21 = (k2 * k1) / opc
        t22 = 1.0 + (-(k1 * k1)) / opc
    # omega_ref^b = R^T (x_ref x x_ref_dot)   (eq. 3)
    c0 = r1 * x_dot[2] - r2 * x_dot[1]
    c1 = r2 * x_dot[0] - r0 * x_dot[2]
    c2 = r0 * x_dot[1] - r1 * x_dot[0]
    w0 = R[0, 0] * c0 + R[1, 0] * c1 + R[2, 0] * c2
    w1 = R[0, 1] * c0 + R[1, 1] * c1 + R[2, 1] * c2
    w2 = R[0, 2] * c0 + R[1, 2] * c1 + R[2, 2] * c2
    # omega_tilde = H^T (omega - R_tilde omega_ref^b)   (eq. 8)
    omega_tilde[0] = omega[1] - (t10 * w0 + t11 * w1 + t12 * w2)
    omega_tilde[1] = omega[2] - (t20 * w0 + t21 * w1 + t22 * w2)
    # R_tilde R^T (x_ref x x_ref_ddot)   (eq. 9, finding 1)
    c0 = r1 * x_ddot[2] - r2 * x_ddot[1]
    c1 = r2 * x_ddot[0] - r0 * x_ddot[2]
    c2 = r0 * x_ddot[1] - r1 * x_ddot[0]
    b0 = R[0, 0] * c0 + R[1, 0] * c1 + R[2, 0] * c2
    b1 = R[0, 1] * c0 + R[1, 1] * c1 + R[2, 1] * c2
    b2 = R[0, 2] * c0 + R[1, 2] * c1 + R[2, 2] * c2
    acc1 = t10 * b0 + t11 * b1 + t12 * b2
    acc2 = t20 * b0 + t21 * b1 + t22 * b2
    if exact != 0.0:
        # finding 2: mu = -(e1 . delta + y . delta) / (1 + e1 . y), delta = omega - omega_ref^b
        mu = 0.0
        if not antipodal:
            e0, e1, e2 = omega[0] - w0, omega[1] - w1, omega[2] - w2
            mu = -e0 - (y1 * e1 + y2 * e2) / _one_plus_cos(y0, y1, y2)
        # + mu R_tilde (y x omega_ref^b)
        s0 = y1 * w2 - y2 * w1
        s1 = y2 * w0 - y0 * w2
        s2 = y0 * w1 - y1 * w0
        acc1 = acc1 + mu * (t10 * s0 + t11 * s1 + t12 * s2)
        acc2 = acc2 + mu * (t20 * s0 + t21 * s1 + t22 * s2)
    # phi_tilde n = (phi / sin phi) (y x e1); 0 at phi = 0 and (by convention) at phi = pi
    n1 = 0.0
    n2 = 0.0
    if sin_phi != 0.0 and not antipodal:
        scale = phi / sin_phi
        n1 = scale * y2
        n2 = scale * -y1
    q0[0] = -k_p * n1 - k_d * omega_tilde[0] + acc1  # eq. (23) = eq. (9), J = I
    q0[1] = -k_p * n2 - k_d * omega_tilde[1] + acc2
    return phi


@njit(**_OPTS)
def surge_update(S, t, surge_velocity, k_p, k_i, u_d, max_thrust):
    """Thrust of eq. (25) at time ``t``, advancing the PI state ``S`` (as ``SurgePIController``)."""
    error = surge_velocity - u_d
    if S[S_SURGE_HAS_PREVIOUS] != 0.0:
        dt = t - S[S_SURGE_TIME]
        winding_up = S[S_SURGE_SATURATION] * S[S_SURGE_ERROR] < 0.0
        if not winding_up:
            S[S_INTEGRAL] += S[S_SURGE_ERROR] * dt  # zero-order hold of the error
    demand = -k_p * error - k_i * S[S_INTEGRAL]  # eq. (25)
    thrust = min(max(demand, -max_thrust), max_thrust)
    saturation = 0.0
    if thrust != demand:
        saturation = 1.0 if demand > 0.0 else (-1.0 if demand < 0.0 else 0.0)
    S[S_SURGE_SATURATION] = saturation
    S[S_SURGE_HAS_PREVIOUS] = 1.0
    S[S_SURGE_TIME] = t
    S[S_SURGE_ERROR] = error
    return thrust


@njit(**_OPTS)
def finite_difference(S, t, vel_w, acc):
    """End-effector acceleration: velocity difference with the previous sample over the time step.

    Zero at the first sample or when ``t`` does not advance (as
    :meth:`aiauv_pin.path_following.VehiclePathFollowing.measure`); stores the sample in ``S``.
    """
    if S[S_VEL_HAS_PREVIOUS] == 0.0 or t <= S[S_VEL_TIME]:
        acc[0] = 0.0
        acc[1] = 0.0
        acc[2] = 0.0
    else:
        h = t - S[S_VEL_TIME]
        acc[0] = (vel_w[0] - S[S_VEL_X]) / h
        acc[1] = (vel_w[1] - S[S_VEL_Y]) / h
        acc[2] = (vel_w[2] - S[S_VEL_Z]) / h
    S[S_VEL_HAS_PREVIOUS] = 1.0
    S[S_VEL_TIME] = t
    S[S_VEL_X] = vel_w[0]
    S[S_VEL_Y] = vel_w[1]
    S[S_VEL_Z] = vel_w[2]


@njit(**_OPTS)
def command(
    P,
    axis_index,
    ref_scale,
    surge_mask,
    S,
    t,
    R,
    p,
    vel_w,
    acc,
    omega_e,
    surge_velocity,
    q_joint,
    qd_joint,
    g_q,
    info,
    q_ref,
    joint_torque,
    thrusts,
    x_ref,
    x_dot,
    x_ddot,
):
    """One call of the paper's controller on a measurement (as ``PathFollowingController.command``).

    Writes the info row (layout of :func:`info_layout`, thruster power excepted), ``q_ref``,
    ``joint_torque`` (eq. 24), ``thrusts`` (eq. 25) and ``x_ref`` with its derivatives; advances
    the surge state in ``S``.
    """
    n = q_joint.shape[0]
    m = thrusts.shape[0]
    los_reference(p, vel_w, acc, P[P_U_D], P[P_K_Y], P[P_K_Z], x_ref, x_dot, x_ddot)  # eq. (21)
    q0 = np.empty(2)
    omega_tilde = np.empty(2)
    phi = pointing_law(  # eqs. (23), (4), (8)
        R, omega_e, x_ref, x_dot, x_ddot, P[P_K_P], P[P_K_D], P[P_EXACT], q0, omega_tilde
    )
    q_max = P[P_Q_MAX]
    for j in range(n):
        base = q0[axis_index[j]]
        q_ref[j] = ref_scale[j] * min(max(base, -q_max), q_max)  # eq. (22)
        joint_torque[j] = (
            -P[P_K_QP] * (q_joint[j] - q_ref[j]) - P[P_K_QD] * qd_joint[j] + g_q[j]
        )  # eq. (24)
    thrust = surge_update(  # eq. (25)
        S, t, surge_velocity, P[P_K_1P], P[P_K_1I], P[P_U_D], P[P_MAX_THRUST]
    )
    for k in range(m):
        thrusts[k] = thrust if surge_mask[k] != 0 else 0.0
    # info row, in the order of info_layout
    o = 0
    for i in range(3):
        info[o + i] = p[i]
    o += 3
    info[o] = surge_velocity
    info[o + 1] = phi
    info[o + 2] = omega_tilde[0]
    info[o + 3] = omega_tilde[1]
    info[o + 4] = q0[0]
    info[o + 5] = q0[1]
    o += 6
    for j in range(n):
        info[o + j] = q_ref[j]
    o += n
    for i in range(3):
        info[o + i] = x_ref[i]
        info[o + 3 + i] = R[i, 0]
    o += 6
    for k in range(m):
        info[o + k] = thrusts[k]
    o += 2 * m  # thruster power: filled by the caller, which knows B(q)
    for j in range(n):
        info[o + j] = joint_torque[j]


# ---------------------------------------------------------------------- vehicle side
@njit(**_OPTS)
def _measure_and_command(M, F, P, axis_index, ref_scale, surge_mask, S, t, q, v, W, C, tau, info):
    """Measure at ``(q, v)``, run the controller, write ``tau`` (nv,) and the info row.

    ``F`` = (frame body, frame rotation (3x3), frame translation (3,)); ``C`` holds scratch arrays.
    """
    body, frame_rot, frame_pos = F
    nv = v.shape[0]
    n = nv - 6
    thrust_table = M[9]
    m = thrust_table.shape[0]
    kernels._kinematics_ws(M, q, v, W)
    rot_w, pos_w, twist = W[0], W[1], W[3]
    R = C[0]
    p = C[1][0]
    vel_w = C[1][1]
    omega_e = C[1][2]
    frame_twist = C[2][0]
    x_ref, x_dot, x_ddot = C[1][3], C[1][4], C[1][5]
    acc_w = C[2][1, :3]
    # end-effector pose and twist in its own axes
    for i in range(3):
        acc = pos_w[body, i]
        for k in range(3):
            acc += rot_w[body, i, k] * frame_pos[k]
        p[i] = acc
        for j in range(3):
            R[i, j] = (
                rot_w[body, i, 0] * frame_rot[0, j]
                + rot_w[body, i, 1] * frame_rot[1, j]
                + rot_w[body, i, 2] * frame_rot[2, j]
            )
    x6 = W[12][0]
    kernels._motion_transform(frame_rot, frame_pos, x6)
    kernels._matvec6(x6, twist[body], frame_twist)
    for i in range(3):
        vel_w[i] = R[i, 0] * frame_twist[0] + R[i, 1] * frame_twist[1] + R[i, 2] * frame_twist[2]
        omega_e[i] = frame_twist[3 + i]
    # g_q (left-hand side)
    g = W[15][1]
    kernels._restoring_ws(M, W, g)
    q_ref = C[3][0]
    joint_torque = C[3][1]
    g_q = C[3][2]
    for j in range(n):
        g_q[j] = g[6 + j]
    thrusts = C[4][0]
    finite_difference(S, t, vel_w, acc_w)
    command(
        P,
        axis_index,
        ref_scale,
        surge_mask,
        S,
        t,
        R,
        p,
        vel_w,
        acc_w,
        omega_e,
        frame_twist[0],
        q[7:],
        v[6:],
        g_q,
        info,
        q_ref,
        joint_torque,
        thrusts,
        x_ref,
        x_dot,
        x_ddot,
    )
    # tau = B(q) tau_thr (eq. 20): one backward pass of the thrust wrenches; the power of thruster
    # k is its thrust times the speed of its point along its axis, twist_b . w_k (= (v^T B)_k)
    wrench = W[6]
    for b in range(wrench.shape[0]):
        for i in range(6):
            wrench[b, i] = 0.0
    power_offset = info.shape[0] - n - m
    for k in range(m):
        b = int(thrust_table[k, 0])
        speed = 0.0
        for i in range(6):
            wrench[b, i] += thrust_table[k, 1 + i] * thrusts[k]
            speed += twist[b, i] * thrust_table[k, 1 + i]
        info[power_offset + k] = speed * thrusts[k]
    kernels._backward_generalized(M[0], M[2], W[2], wrench, tau, W[13][0])
    if P[P_CONTINUOUS] == 0.0:
        for j in range(n):
            tau[6 + j] += joint_torque[j]


@njit(**_OPTS)
def scratch(nv, n_thrusters):
    """Scratch arrays of :func:`_measure_and_command`."""
    n = nv - 6
    return (
        np.empty((3, 3)),
        np.empty((6, 3)),
        np.empty((2, 6)),
        np.empty((3, n)),
        np.empty((1, n_thrusters)),
    )


@njit(**_OPTS)
def measure_and_command(M, F, P, axis_index, ref_scale, surge_mask, S, t, q, v, tau, info):
    """One controller call from Python (tests): writes ``tau`` and the info row."""
    W = kernels.workspace(M[0].shape[0], q.shape[0], v.shape[0])
    C = scratch(v.shape[0], M[9].shape[0])
    _measure_and_command(M, F, P, axis_index, ref_scale, surge_mask, S, t, q, v, W, C, tau, info)


@njit(**_OPTS)
def run_chunk(
    M,
    F,
    P,
    axis_index,
    ref_scale,
    surge_mask,
    S,
    servo,
    current,
    q,
    v,
    tau,
    info,
    dt,
    method,
    k_start,
    k_stop,
    n_total,
    steps_per_control,
    log_every,
    log,
    log_index,
):
    """Steps ``k_start .. k_stop - 1`` (controller, logging, integration), plus the final sample.

    ``log`` rows are ``(t, q, v, tau, info)``; ``tau`` and ``info`` hold the last controller output
    between calls (zero-order hold). The servo's references (``servo[2]``) follow the controller's
    joint references. Returns ``(next log index, steps completed)``; fewer steps than asked means
    the state became non-finite (``q, v`` then hold the last finite state).
    """
    nq = q.shape[0]
    nv = v.shape[0]
    n = nv - 6
    W = kernels.workspace(M[0].shape[0], nq, nv)
    C = scratch(nv, M[9].shape[0])
    q_new = W[17][1]
    v_new = W[16][9]
    width = info.shape[0]
    use_servo = servo.shape[1] > 0
    k = k_start
    while True:
        if k == k_stop and k != n_total:
            return log_index, k - k_start
        if k % steps_per_control == 0:
            _measure_and_command(
                M, F, P, axis_index, ref_scale, surge_mask, S, k * dt, q, v, W, C, tau, info
            )
            if use_servo:
                for j in range(n):
                    servo[2, j] = C[3][0][j]
        if k % log_every == 0 or k == n_total:
            row = log[log_index]
            row[0] = k * dt
            for i in range(nq):
                row[1 + i] = q[i]
            for i in range(nv):
                row[1 + nq + i] = v[i]
                row[1 + nq + nv + i] = tau[i]
            base = 1 + nq + 2 * nv
            for i in range(width):
                row[base + i] = info[i]
            log_index += 1
        if k == n_total:
            return log_index, k - k_start
        if method == 0:
            kernels._rk4_ws(M, q, v, tau, current, servo, dt, W, q_new, v_new)
        else:
            kernels._euler_ws(M, q, v, tau, current, servo, dt, W, q_new, v_new)
        for i in range(nq):
            if not math.isfinite(q_new[i]):
                return log_index, k - k_start
        for i in range(nv):
            if not math.isfinite(v_new[i]):
                return log_index, k - k_start
        q[:] = q_new
        v[:] = v_new
        k += 1


# ---------------------------------------------------------------------- Python side
def controller_arrays(controller, continuous_joints: bool = True):
    """``(P, axis_index, reference_scale, surge_mask)`` of a ``PathFollowingController``."""
    gains = controller.gains
    k_e = gains.k_e
    k_y, k_z = (k_e, k_e) if np.ndim(k_e) == 0 else (k_e[0], k_e[1])
    P = np.zeros(N_PARAMETERS)
    P[P_U_D] = gains.u_d
    P[P_K_Y], P[P_K_Z] = float(k_y), float(k_z)
    P[P_K_P], P[P_K_D] = gains.k_p, gains.k_d
    P[P_K_QP], P[P_K_QD] = gains.k_qp, gains.k_qd
    P[P_K_1P], P[P_K_1I] = gains.k_1p, gains.k_1i
    P[P_MAX_THRUST] = controller._surge.max_thrust
    P[P_Q_MAX] = gains.q_max
    P[P_EXACT] = 1.0 if gains.feedforward == "exact" else 0.0
    P[P_CONTINUOUS] = 1.0 if continuous_joints else 0.0
    axis_index = np.ascontiguousarray(controller._axis_index, dtype=np.int64)
    scale = np.ascontiguousarray(controller._reference_scale, dtype=float)
    mask = np.zeros(controller.n_thrusters, dtype=np.int64)
    mask[list(controller.surge_thrusters)] = 1
    return P, axis_index, scale, mask


class CompiledController:
    """:class:`control.path_following.PathFollowingController` evaluated by :func:`command`.

    Holds its own surge state (starting cleared); for tests and for callers that measure
    themselves.

    Args:
        controller: The reference controller (its gains, joint layout and thrusters are copied).
    """

    def __init__(self, controller) -> None:
        self.parameters, self.axis_index, self.reference_scale, self.surge_mask = controller_arrays(
            controller
        )
        self.n_joints = controller.n_joints
        self.n_thrusters = controller.n_thrusters
        self.state = np.zeros(N_STATE)
        self.layout = info_layout(self.n_joints, self.n_thrusters)

    @property
    def surge_integral(self) -> float:
        """``integral (u - u_d) dt`` of the surge PI [m]."""
        return float(self.state[S_INTEGRAL])

    def command(self, t: float, measurement) -> dict[str, np.ndarray | float]:
        """The fields of ``PathFollowingCommand`` (``x_ref_ddot`` too) for a measurement."""
        n, m = self.n_joints, self.n_thrusters
        info = np.zeros(info_width(n, m))
        out = {
            "joint_references": np.empty(n),
            "joint_torques": np.empty(n),
            "thrusts": np.empty(m),
            "x_ref": np.empty(3),
            "x_ref_dot": np.empty(3),
            "x_ref_ddot": np.empty(3),
        }
        command(
            self.parameters,
            self.axis_index,
            self.reference_scale,
            self.surge_mask,
            self.state,
            float(t),
            np.ascontiguousarray(measurement.rotation_to_world),
            np.ascontiguousarray(measurement.position_in_world),
            np.ascontiguousarray(measurement.velocity_in_world),
            np.ascontiguousarray(measurement.acceleration_in_world),
            np.ascontiguousarray(measurement.angular_velocity_in_ee),
            float(measurement.surge_velocity),
            np.ascontiguousarray(measurement.joint_positions),
            np.ascontiguousarray(measurement.joint_velocities),
            np.ascontiguousarray(measurement.joint_hydrostatic_forces),
            info,
            out["joint_references"],
            out["joint_torques"],
            out["thrusts"],
            out["x_ref"],
            out["x_ref_dot"],
            out["x_ref_ddot"],
        )
        for key in ("phi_tilde", "omega_tilde", "base_angles", "pointing"):
            offset, shape = self.layout[key]
            size = int(np.prod(shape, dtype=int))
            value = info[offset : offset + size]
            out[key] = float(value[0]) if shape == () else value.copy()
        out["pointing_direction"] = out.pop("pointing")
        out["surge_integral"] = self.surge_integral
        return out


class CompiledPathFollowing:
    """The arrays of a :class:`aiauv_pin.path_following.VehiclePathFollowing` for the kernels.

    Args:
        adapter: The controller callback (paper's controller on a vehicle with the numba backend).

    Raises:
        ValueError: The vehicle has no compiled backend.
    """

    def __init__(self, adapter) -> None:
        vehicle = adapter.vehicle
        fast = vehicle.fast
        if fast is None:
            raise ValueError("compiled path following needs the numba backend")
        controller = adapter.controller
        self.fast = fast
        self.n_joints = controller.n_joints
        self.n_thrusters = controller.n_thrusters
        self.parameters, self.axis_index, self.reference_scale, self.surge_mask = controller_arrays(
            controller, adapter.continuous_joints
        )
        frame = vehicle.model.frames[adapter.frame]
        self.frame = (
            int(frame.parentJoint) - 1,
            np.ascontiguousarray(frame.placement.rotation, dtype=float),
            np.ascontiguousarray(frame.placement.translation, dtype=float),
        )
        self.state = np.zeros(N_STATE)
        self.layout = info_layout(self.n_joints, self.n_thrusters)
        self.width = info_width(self.n_joints, self.n_thrusters)

    def reset(self) -> None:
        """Clear the surge integrator and the velocity history."""
        self.state[:] = 0.0

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray):
        """Same output as :meth:`VehiclePathFollowing.__call__` (``(tau, info)``), compiled."""
        tau = np.zeros(self.fast.nv)
        info = np.empty(self.width)
        measure_and_command(
            self.fast.arrays,
            self.frame,
            self.parameters,
            self.axis_index,
            self.reference_scale,
            self.surge_mask,
            self.state,
            float(t),
            np.ascontiguousarray(q, dtype=float),
            np.ascontiguousarray(v, dtype=float),
            tau,
            info,
        )
        return tau, self.unpack(info)

    def unpack(self, block: np.ndarray) -> dict[str, np.ndarray]:
        """Split info rows (``(..., width)``) into the logged keys (copies)."""
        out = {}
        for key, (offset, shape) in self.layout.items():
            size = int(np.prod(shape, dtype=int))
            part = block[..., offset : offset + size]
            out[key] = np.array(part.reshape(block.shape[:-1] + shape))
        return out


def run_path_following(
    adapter,
    q0: np.ndarray,
    v0: np.ndarray,
    duration: float,
    dt: float,
    *,
    method: str = "rk4",
    current: np.ndarray | None = None,
    control_period: float | None = None,
    log_every: int = 1,
    progress: bool = False,
    on_log: Callable[[float, np.ndarray, Mapping[str, object]], None] | None = None,
    chunk_seconds: float | None = None,
    after_first_chunk: Callable[[], None] | None = None,
):
    """:func:`aiauv_pin.simulate` with the paper's controller, entirely in compiled code.

    Same arguments, sampling, logging and divergence behaviour as
    ``simulate(vehicle, q0, v0, duration, dt, adapter, servo=adapter.joint_servo, ...)`` (the servo
    only with ``adapter.continuous_joints``); the run advances in chunks of ``chunk_seconds`` of
    simulated time (default: 1 s with ``on_log``, for a smooth live view, else 10 s), between which
    the progress bar and ``on_log`` run. ``after_first_chunk()`` is called once the first chunk
    has returned (the compiled code is then loaded; later chunks release the GIL, so background
    threads started there overlap them).

    Returns:
        The :class:`aiauv_pin.simulation.Trajectory`.

    Raises:
        SimulationDiverged: As :func:`aiauv_pin.simulate`.
    """
    from ..simulation import Trajectory, check_run_arguments, diverged

    n_steps, steps_per_control = check_run_arguments(
        duration, dt, method, log_every, control_period
    )
    compiled = CompiledPathFollowing(adapter)
    fast = compiled.fast
    nq, nv = fast.nq, fast.nv
    q = np.array(q0, dtype=float)
    v = np.array(v0, dtype=float)
    if q.shape != (nq,) or v.shape != (nv,):
        raise ValueError(f"q0 must have {nq} and v0 {nv} entries")
    from .model import METHOD_CODES

    method_code = METHOD_CODES[method]
    current = fast._current(None if current is None else np.asarray(current, dtype=float))
    servo = adapter.joint_servo.packed() if adapter.continuous_joints else fast.no_servo
    n_logs = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    width = 1 + nq + 2 * nv + compiled.width
    log = np.empty((n_logs, width))
    tau = np.zeros(nv)
    info = np.full(compiled.width, np.nan)
    if chunk_seconds is None:
        chunk_seconds = 1.0 if on_log is not None else 10.0
    chunk = max(1, round(chunk_seconds / dt))
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_steps, unit="step", desc=f"simulate {duration:g} s", leave=False)
    logged = 0
    k = 0
    diverged_at = None
    try:
        while True:
            stop = min(k + chunk, n_steps)
            start_log = logged
            logged, done = run_chunk(
                fast.arrays,
                compiled.frame,
                compiled.parameters,
                compiled.axis_index,
                compiled.reference_scale,
                compiled.surge_mask,
                compiled.state,
                servo,
                current,
                q,
                v,
                tau,
                info,
                float(dt),
                method_code,
                k,
                stop,
                n_steps,
                steps_per_control,
                int(log_every),
                log,
                logged,
            )
            if on_log is not None:
                for row in log[start_log:logged]:
                    on_log(
                        float(row[0]),
                        row[1 : 1 + nq].copy(),
                        compiled.unpack(row[1 + nq + 2 * nv :]),
                    )
            if bar is not None:
                bar.update(done)
            if k == 0 and after_first_chunk is not None:
                after_first_chunk()
            if k + done < stop:
                diverged_at = k + done
                break
            k = stop
            if k == n_steps:
                break
            time.sleep(0)  # let other threads (a viewer) run between chunks
    finally:
        if bar is not None:
            bar.close()
    rows = log[:logged]
    trajectory = Trajectory(
        t=rows[:, 0].copy(),
        q=rows[:, 1 : 1 + nq].copy(),
        v=rows[:, 1 + nq : 1 + nq + nv].copy(),
        tau=rows[:, 1 + nq + nv : 1 + nq + 2 * nv].copy(),
        info=compiled.unpack(rows[:, 1 + nq + 2 * nv :]),
    )
    if diverged_at is not None:
        raise diverged(trajectory, diverged_at + 1, dt)
    return trajectory
