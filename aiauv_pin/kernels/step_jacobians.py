"""Exact transition Jacobians of one integrator step (RK4 Munthe-Kaas and semi-implicit Euler), compiled.

The state is ``x = (q, v)`` with ``q`` perturbed in its tangent space (``q (+) dq``, as
``pinocchio.integrate``) and the input ``u = (thrusts, joint torques)``. As in the simulator, the
generalised force of a step is computed once at its start and held over the step,
``tau_k = tau_0 + B(q_k) thrusts + S joint_torques``, so ``d tau_k = G dq_k + B(q_k) d thrusts + S d
joint_torques`` with ``G = d(B(q) thrusts)/dq`` (:func:`thrust_force_derivative`).

The step is differentiated in forward mode, stage by stage, with matrices of tangents (one column
per component of ``(dq, dv, du)``): each stage's acceleration by
:func:`aiauv_pin.kernels.tangent_rnea.acceleration_derivatives_into`, each stage configuration
``q_s = q (+) xi_s`` by the derivatives of ``integrate`` (``d q_s = Ad(exp(-xi_s)) dq + J_r(xi_s)
d xi_s`` on the free flyer, Barfoot 2017, eq. (7.86); identity on the joints), and each stage rate
``k_s = J_r(xi_s)^-1 v_s`` (:func:`aiauv_pin.kernels.articulated_body.tangent_rate`) by its own forward-mode
derivative :func:`tangent_rate_tangent`.
"""

from __future__ import annotations

import math

import numpy as np

from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import cross3, motion_transform_into
from aiauv_pin.kernels.articulated_body import EULER, integrate, tangent_rate
from aiauv_pin.kernels.rotations import quaternion_rotation
from aiauv_pin.kernels.tangent_rnea import (
    _add_cross_force,
    _apply_transpose_add,
    acceleration_derivatives_into,
    thrust_matrix_at,
)


# ---------------------------------------------------------------------- 3-vectors as tuples
@compiled(fastmath=True, borrows_only=True)
def _cr(a, b):
    """``a x b`` for indexable 3-vectors (:func:`aiauv_hydro.numerics.spatial.cross3`)."""
    return cross3(a[0], a[1], a[2], b[0], b[1], b[2])


@compiled(fastmath=True, borrows_only=True)
def _dcr(a, da, b, db):
    """Tangent of ``a x b``."""
    x = _cr(da, b)
    y = _cr(a, db)
    return (x[0] + y[0], x[1] + y[1], x[2] + y[2])


@compiled(fastmath=True, borrows_only=True)
def _comb(s0, a, s1, b, s2, c):
    return (
        s0 * a[0] + s1 * b[0] + s2 * c[0],
        s0 * a[1] + s1 * b[1] + s2 * c[1],
        s0 * a[2] + s1 * b[2] + s2 * c[2],
    )


@compiled(fastmath=True, borrows_only=True)
def _coefficients(t2):
    """``(c1, c2, c3, d)`` of :func:`aiauv_pin.kernels.articulated_body.tangent_rate` and their ``d/d t2``."""
    if math.sqrt(t2) < 0.1:
        c1 = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0
        c2 = 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0 - t2 * t2 * t2 / 3628800.0
        c3 = 1.0 / 120.0 - t2 / 2520.0 + t2 * t2 / 120960.0 - t2 * t2 * t2 / 9979200.0
        d = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
        e1 = -1.0 / 120.0 + 2.0 * t2 / 5040.0 - 3.0 * t2 * t2 / 362880.0
        e2 = -1.0 / 720.0 + 2.0 * t2 / 40320.0 - 3.0 * t2 * t2 / 3628800.0
        e3 = -1.0 / 2520.0 + 2.0 * t2 / 120960.0 - 3.0 * t2 * t2 / 9979200.0
        ed = 1.0 / 720.0 + 2.0 * t2 / 30240.0 + 3.0 * t2 * t2 / 1209600.0
        return c1, c2, c3, d, e1, e2, e3, ed
    t = math.sqrt(t2)
    s, c = math.sin(t), math.cos(t)
    t4 = t2 * t2
    c1 = (t - s) / (t2 * t)
    c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t4)
    c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t4 * t)
    d = 1.0 / t2 - (1.0 + c) / (2.0 * t * s)
    # d/dt, then d/dt2 = (d/dt) / (2 t)
    g1 = (1.0 - c) / (t2 * t) - 3.0 * (t - s) / t4
    g2 = (2.0 * t - 2.0 * s) / (2.0 * t4) - 4.0 * (t2 + 2.0 * c - 2.0) / (2.0 * t4 * t)
    g3 = (2.0 - 2.0 * c - t * s) / (2.0 * t4 * t) - 5.0 * (2.0 * t - 3.0 * s + t * c) / (
        2.0 * t4 * t2
    )
    gd = -2.0 / (t2 * t) + (2.0 * t * s * s + (1.0 + c) * (2.0 * s + 2.0 * t * c)) / (
        4.0 * t2 * s * s
    )
    return c1, c2, c3, d, g1 / (2.0 * t), g2 / (2.0 * t), g3 / (2.0 * t), gd / (2.0 * t)


@compiled(fastmath=True, borrows_only=True)
def tangent_rate_tangent(xi, dxi, vel, dvel, out):
    """Directional derivative of :func:`aiauv_pin.kernels.articulated_body.tangent_rate` (free-flyer part).

    The same sequence of operations as ``tangent_rate`` on (value, tangent) pairs (forward-mode
    differentiation by hand): ``out[:6] = d/d(xi, vel) [J_r(xi)^-1 vel] . (dxi, dvel)``.
    """
    r = (-xi[0], -xi[1], -xi[2])
    dr = (-dxi[0], -dxi[1], -dxi[2])
    p = (-xi[3], -xi[4], -xi[5])
    dp = (-dxi[3], -dxi[4], -dxi[5])
    t2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    dt2 = 2.0 * (p[0] * dp[0] + p[1] * dp[1] + p[2] * dp[2])
    c1, c2, c3, d, e1, e2, e3, ed = _coefficients(t2)
    dc1, dc2, dc3, dd = e1 * dt2, e2 * dt2, e3 * dt2, ed * dt2
    w = (vel[3], vel[4], vel[5])
    dw = (dvel[3], dvel[4], dvel[5])
    x = _cr(p, w)
    dx = _dcr(p, dp, w, dw)
    y = _cr(p, x)
    dy = _dcr(p, dp, x, dx)
    a = _comb(1.0, w, -0.5, x, d, y)
    da = _comb(1.0, dw, -0.5, dx, d, dy)
    da = _comb(1.0, da, dd, y, 0.0, y)
    pa, dpa = _cr(p, a), _dcr(p, dp, a, da)
    ra, dra = _cr(r, a), _dcr(r, dr, a, da)
    pra, dpra = _cr(p, ra), _dcr(p, dp, ra, dra)
    rpa, drpa = _cr(r, pa), _dcr(r, dr, pa, dpa)
    prpa, dprpa = _cr(p, rpa), _dcr(p, dp, rpa, drpa)
    ppra, dppra = _cr(p, pra), _dcr(p, dp, pra, dpra)
    ppa, dppa = _cr(p, pa), _dcr(p, dp, pa, dpa)
    rppa, drppa = _cr(r, ppa), _dcr(r, dr, ppa, dppa)
    prppa, dprppa = _cr(p, rppa), _dcr(p, dp, rppa, drppa)
    pprpa, dpprpa = _cr(p, prpa), _dcr(p, dp, prpa, dprpa)
    values = (pra, rpa, prpa, ppra, rppa, prppa, pprpa)
    tangents = (dpra, drpa, dprpa, dppra, drppa, dprppa, dpprpa)
    dq = (
        _q_row_tangent(0, dra, c1, c2, c3, dc1, dc2, dc3, values, tangents),
        _q_row_tangent(1, dra, c1, c2, c3, dc1, dc2, dc3, values, tangents),
        _q_row_tangent(2, dra, c1, c2, c3, dc1, dc2, dc3, values, tangents),
    )
    q0 = tangent_rate_q(r, p, a, c1, c2, c3)
    l = (vel[0] - q0[0], vel[1] - q0[1], vel[2] - q0[2])
    dl = (dvel[0] - dq[0], dvel[1] - dq[1], dvel[2] - dq[2])
    x = _cr(p, l)
    dx = _dcr(p, dp, l, dl)
    y = _cr(p, x)
    dy = _dcr(p, dp, x, dx)
    for i in range(3):
        out[i] = dl[i] - 0.5 * dx[i] + dd * y[i] + d * dy[i]
        out[3 + i] = da[i]


@compiled(fastmath=True, borrows_only=True)
def tangent_rate_q(r, p, a, c1, c2, c3):
    """``Q a`` of :func:`aiauv_pin.kernels.articulated_body.tangent_rate` (value only)."""
    pa = _cr(p, a)
    ra = _cr(r, a)
    pra = _cr(p, ra)
    rpa = _cr(r, pa)
    prpa = _cr(p, rpa)
    ppra = _cr(p, pra)
    ppa = _cr(p, pa)
    rppa = _cr(r, ppa)
    prppa = _cr(p, rppa)
    pprpa = _cr(p, prpa)
    values = (pra, rpa, prpa, ppra, rppa, prppa, pprpa)
    return (
        _q_row(0, ra, c1, c2, c3, values),
        _q_row(1, ra, c1, c2, c3, values),
        _q_row(2, ra, c1, c2, c3, values),
    )


@compiled(fastmath=True)
def _q_row(i, ra, c1, c2, c3, values):
    """Row ``i`` of :func:`tangent_rate_q` from the cross products
    ``values = (p(ra), r(pa), p(r(pa)), p(p(ra)), r(p(pa)), p(r(p(pa))), p(p(r(pa))))``."""
    pra, rpa, prpa, ppra, rppa, prppa, pprpa = values
    return (
        0.5 * ra[i]
        + c1 * (pra[i] + rpa[i] + prpa[i])
        + c2 * (ppra[i] + rppa[i] - 3.0 * prpa[i])
        + c3 * (prppa[i] + pprpa[i])
    )


@compiled(fastmath=True)
def _q_row_tangent(i, dra, c1, c2, c3, dc1, dc2, dc3, values, tangents):
    """Row ``i`` of the tangent of :func:`tangent_rate_q` (``values`` as in :func:`_q_row`,
    ``tangents`` their tangents)."""
    pra, rpa, prpa, ppra, rppa, prppa, pprpa = values
    dpra, drpa, dprpa, dppra, drppa, dprppa, dpprpa = tangents
    s1 = pra[i] + rpa[i] + prpa[i]
    s2 = ppra[i] + rppa[i] - 3.0 * prpa[i]
    s3 = prppa[i] + pprpa[i]
    ds1 = dpra[i] + drpa[i] + dprpa[i]
    ds2 = dppra[i] + drppa[i] - 3.0 * dprpa[i]
    ds3 = dprppa[i] + dpprpa[i]
    return 0.5 * dra[i] + dc1 * s1 + c1 * ds1 + dc2 * s2 + c2 * ds2 + dc3 * s3 + c3 * ds3


# ---------------------------------------------------------------------- integrate's derivatives
@compiled(fastmath=True, borrows_only=True)
def integrate_jacobians(xi, d_configuration, d_increment, scratch, scratch_matrix):
    """Free-flyer blocks (6, 6) of ``d(q (+) xi)/d q`` (= ``Ad(exp(-xi))``) and ``d/d xi`` (= ``J_r(xi)``).

    ``Ad(exp(-xi))`` is the motion transform ``[[R^T, -R^T [p]], [0, R^T]]`` of ``exp(xi) = (R, p)``;
    ``J_r(xi)`` is the inverse of the matrix of :func:`aiauv_pin.kernels.articulated_body.tangent_rate`, block
    upper triangular, so inverted by its 3x3 diagonal block. ``scratch`` (>= 5, 7) and
    ``scratch_matrix`` (2, 6, 6) are work arrays.
    """
    identity, moved, base = scratch[0], scratch[1], scratch[2]
    unit, column = scratch[3, :6], scratch[4, :6]
    inverse, inv = scratch_matrix[0], scratch_matrix[1]
    for i in range(7):
        identity[i] = 0.0
    identity[6] = 1.0
    for i in range(6):
        base[i] = xi[i]
    integrate(identity, base[:6], moved)
    rows = quaternion_rotation(moved[3], moved[4], moved[5], moved[6])
    motion_transform_into(rows, moved[0], moved[1], moved[2], d_configuration)
    for i in range(6):
        unit[i] = 0.0
    for j in range(6):
        unit[j] = 1.0
        tangent_rate(base[:6], unit, column)
        unit[j] = 0.0
        for i in range(6):
            inverse[i, j] = column[i]
    # J_r^-1 = [[Ai, Bi], [0, Ai]] (block upper triangular) => J_r = [[A, -A Bi A], [0, A]], A = Ai^-1
    a00, a01, a02 = inverse[0, 0], inverse[0, 1], inverse[0, 2]
    a10, a11, a12 = inverse[1, 0], inverse[1, 1], inverse[1, 2]
    a20, a21, a22 = inverse[2, 0], inverse[2, 1], inverse[2, 2]
    c00 = a11 * a22 - a12 * a21
    c01 = a02 * a21 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a10 * c01 + a20 * c02
    inv[0, 0], inv[0, 1], inv[0, 2] = c00 / det, c01 / det, c02 / det
    inv[1, 0] = (a12 * a20 - a10 * a22) / det
    inv[1, 1] = (a00 * a22 - a02 * a20) / det
    inv[1, 2] = (a02 * a10 - a00 * a12) / det
    inv[2, 0] = (a10 * a21 - a11 * a20) / det
    inv[2, 1] = (a01 * a20 - a00 * a21) / det
    inv[2, 2] = (a00 * a11 - a01 * a10) / det
    for i in range(6):
        for j in range(6):
            d_increment[i, j] = 0.0
    for i in range(3):
        for j in range(3):
            d_increment[i, j] = inv[i, j]
            d_increment[3 + i, 3 + j] = inv[i, j]
    for i in range(3):  # upper-right: -A Bi A
        for j in range(3):
            s = 0.0
            for k in range(3):
                t = 0.0
                for m in range(3):
                    t += inverse[k, 3 + m] * inv[m, j]
                s += inv[i, k] * t
            d_increment[i, 3 + j] = -s


@compiled(fastmath=True, borrows_only=True)
def rate_jacobians(xi, vel, d_increment, d_velocity, scratch):
    """Free-flyer blocks (6, 6) of ``k = J_r(xi)^-1 vel``: ``dk/dxi`` and ``dk/dvel = J_r(xi)^-1``.

    ``scratch`` (>= 7, 7) is a work array.
    """
    base, unit, column = scratch[2, :6], scratch[3, :6], scratch[4, :6]
    zero, velocity = scratch[5, :6], scratch[6, :6]
    for i in range(6):
        base[i] = xi[i]
        velocity[i] = vel[i]
        unit[i] = 0.0
        zero[i] = 0.0
    for j in range(6):
        unit[j] = 1.0
        tangent_rate_tangent(base, unit, velocity, zero, column)
        for i in range(6):
            d_increment[i, j] = column[i]
        tangent_rate(base, unit, column)
        for i in range(6):
            d_velocity[i, j] = column[i]
        unit[j] = 0.0


@compiled(fastmath=True, borrows_only=True)
def thrust_force_derivative(model, D, thrusts, out):
    """``G = d(B(q) thrusts)/dq`` (nv, nv), tangent space, after a derivative evaluation at ``q``.

    A thruster's wrench is fixed in its body; turning joint ``j`` by ``dq`` changes the force its
    subtree sends to the parent by ``X_j^T (S_j dq x* F_j)`` (``F_j``: the subtree's thrust wrench
    in body ``j``'s axes), which then reaches every ancestor. The base pose does not change
    generalised forces given in body axes.
    """
    bodies = model.bodies
    nb = bodies.parent.shape[0]
    nv = out.shape[0]
    force = D.subtree_thrust
    for b in range(nb):
        for i in range(6):
            force[b, i] = 0.0
    for k in range(thrusts.shape[0]):
        b = model.thrusters.body[k]
        for i in range(6):
            force[b, i] += model.thrusters.unit_wrench[k, i] * thrusts[k]
    for b in range(nb - 1, 0, -1):
        parent = bodies.parent[b]
        _apply_transpose_add(D.xform[b], force[b], force[parent])
    for i in range(nv):
        for j in range(nv):
            out[i, j] = 0.0
    wrench, up = D.transition_scratch[3, :6], D.transition_scratch[4, :6]
    for b in range(1, nb):
        col = bodies.v_index[b]
        s_axis = bodies.axis[b]
        # S x* F; S^T (S x* F) = 0, so body b's own entry is 0
        for i in range(6):
            wrench[i] = 0.0
        _add_cross_force(s_axis, force[b], wrench)
        c = b
        while c > 0:
            for i in range(6):
                up[i] = 0.0
            _apply_transpose_add(D.xform[c], wrench, up)
            for i in range(6):
                wrench[i] = up[i]
            c = bodies.parent[c]
            if c == 0:
                for i in range(6):
                    out[bodies.v_index[0] + i, col] = wrench[i]
            else:
                s = 0.0
                for i in range(6):
                    s += bodies.axis[c, i] * wrench[i]
                out[bodies.v_index[c], col] = s


# ---------------------------------------------------------------------- the step
@compiled(fastmath=True, borrows_only=True)
def _configuration_tangent(xi, d_xi, nv, out, d_conf, d_inc, scratch, scratch_matrix):
    """``out = d(q (+) xi)`` for tangents ``[I 0 0]`` of ``q`` and ``d_xi`` (nv, nz)."""
    integrate_jacobians(xi, d_conf, d_inc, scratch, scratch_matrix)
    nz = out.shape[1]
    for i in range(6):
        for c in range(nz):
            s = d_conf[i, c] if c < 6 else 0.0
            for j in range(6):
                s += d_inc[i, j] * d_xi[j, c]
            out[i, c] = s
    for i in range(6, nv):
        for c in range(nz):
            out[i, c] = d_xi[i, c] + (1.0 if c == i else 0.0)


@compiled(fastmath=True, borrows_only=True)
def _acceleration_tangent(
    model, env, t, q, v, tau, W, D, dq_s, dv_s, input_force, out, dv_out, scratch, first
):
    """Stage acceleration (into ``dv_out``) and its tangents ``A_q dq_s + A_v dv_s + M^-1 d tau``.

    ``input_force`` is the tangent of the held generalised force, ``[G, 0, B, S]`` by column blocks
    (``dq``, ``dv``, thrusts, joint torques); only its ``G`` and ``B`` blocks are read, the zero
    block and the joint selection ``S`` (``M^-1 S`` = the joint columns of ``M^-1``) are used by
    structure. ``first``: the stage at the start of the step, where ``dq_s = [I 0 0]`` and ``dv_s =
    [0 I 0]`` (then not read), so ``out = [A_q + M^-1 G, A_v, M^-1 B, M^-1 S]``.
    ``scratch`` (>= 3, nv, nv) holds ``A_q, A_v, M^-1``.
    """
    nv = v.shape[0]
    nz = out.shape[1]
    first_torque = nz - (nv - 6)
    da_dq, da_dv, minv = scratch[0], scratch[1], scratch[2]
    no_current = scratch[2][:, 0:0]  # (nv, 0): the current's directions are not needed
    no_thrust = dv_out[0:0]
    acceleration_derivatives_into(
        model,
        env,
        t,
        q,
        v,
        tau,
        no_thrust,
        W,
        D,
        dv_out,
        da_dq,
        da_dv,
        minv,
        no_current,
        no_current,
    )
    for i in range(nv):
        row = out[i]
        if first:
            for c in range(nv):
                row[c] = da_dq[i, c]
                row[nv + c] = da_dv[i, c]
            for c in range(2 * nv, nz):
                row[c] = 0.0
        else:
            for c in range(nz):
                row[c] = 0.0
            for j in range(nv):
                a_q = da_dq[i, j]
                a_v = da_dv[i, j]
                dq_j = dq_s[j]
                dv_j = dv_s[j]
                for c in range(nz):
                    row[c] += a_q * dq_j[c] + a_v * dv_j[c]
        for j in range(nv):
            m_ij = minv[i, j]
            force_j = input_force[j]
            for c in range(nv):
                row[c] += m_ij * force_j[c]
            for c in range(2 * nv, first_torque):
                row[c] += m_ij * force_j[c]
        for c in range(first_torque, nz):
            row[c] += minv[i, 6 + c - first_torque]


@compiled(fastmath=True, borrows_only=True)
def _rate_tangent(d_rate_xi, d_rate_v, d_xi, d_v, out):
    """``out = d k`` of a stage rate ``k = J_r(xi)^-1 v`` (free flyer) and ``k = v`` (joints)."""
    nv = out.shape[0]
    nz = out.shape[1]
    for i in range(6):
        row = out[i]
        for c in range(nz):
            row[c] = 0.0
        for j in range(6):
            a = d_rate_xi[i, j]
            b = d_rate_v[i, j]
            xi_j = d_xi[j]
            v_j = d_v[j]
            for c in range(nz):
                row[c] += a * xi_j[c] + b * v_j[c]
    for i in range(6, nv):
        for c in range(nz):
            out[i, c] = d_v[i, c]


@compiled(fastmath=True, borrows_only=True)
def transition_into(model, env, t, q, v, tau0, thrusts, dt, method, W, D, x_out, A, B):
    """One step of ``method`` and its transition Jacobians ``A`` (2nv, 2nv) and ``B`` (2nv, m + nj).

    Args:
        model, env: As for the kernels' step (no servo, no disturbance).
        t: Time at the start of the step [s].
        q, v: State at the start of the step.
        tau0: Generalised force held over the step besides the inputs (nv,) [N, N m].
        thrusts: Thruster forces (m,) [N]; joint torques are part of ``tau0`` (their derivative
            is the identity on the joint rows).
        dt: Step [s]; method: :data:`aiauv_pin.kernels.articulated_body.RK4` or ``EULER``.
        W, D: Kernel and derivative workspaces (``D.step_*`` hold the step's tangents).
        x_out: Output: ``(q_next (nq,), v_next (nv,))`` as a tuple of arrays.
        A: Output (2 nv, 2 nv): ``d(dq', dv') / d(dq, dv)``.
        B: Output (2 nv, m + nj): ``d(dq', dv') / d(thrusts, joint torques)``.

    The tangents of the initial state, ``dq = [I 0 0]`` and ``dv = [0 I 0]`` (columns ``dq, dv,
    du``), enter by structure (unit entries added at ``(i, nv + i)``), never as matrices.
    """
    nv = v.shape[0]
    m = thrusts.shape[0]
    nj = nv - 6
    nz = 2 * nv + m + nj
    q_next, v_next = x_out
    tangents = D.step_tangents
    d_acc = tangents[0:4]
    d_rate = tangents[4:7]  # k2, k3, k4
    force_tangent = tangents[7]  # d tau = [G, 0, B, S]
    d_xi = tangents[8]
    d_q_stage = tangents[9]
    d_v_stage = tangents[10]
    vectors = D.step_vectors
    acc = vectors[0:4]
    rate = vectors[4:7]
    tau = vectors[7]
    xi = vectors[8]
    scratch = D.step_matrices
    g = scratch[3]
    d_conf, d_inc, d_rate_xi, d_rate_v = (
        D.step_blocks[0],
        D.step_blocks[1],
        D.step_blocks[2],
        D.step_blocks[3],
    )
    # held generalised force and its tangent
    thrust_matrix_at(model, q, W, D)
    bmat = D.thrust_matrix
    for i in range(nv):
        s = tau0[i]
        for k in range(m):
            s += bmat[i, k] * thrusts[k]
        tau[i] = s
    thrust_force_derivative(model, D, thrusts, g)
    for i in range(nv):
        for j in range(nv):
            force_tangent[i, j] = g[i, j]
            force_tangent[i, nv + j] = 0.0
        for k in range(m):
            force_tangent[i, 2 * nv + k] = bmat[i, k]
        for k in range(nj):
            force_tangent[i, 2 * nv + m + k] = 1.0 if i == 6 + k else 0.0
    q_stage, v_stage = D.q_stage, D.v_stage
    _acceleration_tangent(
        model,
        env,
        t,
        q,
        v,
        tau,
        W,
        D,
        d_q_stage,
        d_v_stage,
        force_tangent,
        d_acc[0],
        acc[0],
        scratch,
        True,
    )
    if method == EULER:
        for i in range(nv):
            v_next[i] = v[i] + dt * acc[0, i]
            xi[i] = dt * v_next[i]
        for i in range(nv):
            for c in range(nz):
                d_v_stage[i, c] = dt * d_acc[0, i, c]
            d_v_stage[i, nv + i] += 1.0
            for c in range(nz):
                d_xi[i, c] = dt * d_v_stage[i, c]
        integrate(q, xi, q_next)
        _configuration_tangent(
            xi, d_xi, nv, d_q_stage, d_conf, d_inc, D.transition_scratch, D.transition_matrices
        )
    else:
        half = 0.5 * dt
        for stage in range(1, 4):
            factor = half if stage < 3 else dt
            stage_time = t + factor
            for i in range(nv):
                if stage == 1:
                    xi[i] = factor * v[i]
                else:
                    xi[i] = factor * rate[stage - 2, i]
                v_stage[i] = v[i] + factor * acc[stage - 1, i]
            for i in range(nv):
                if stage == 1:  # d xi = factor dv
                    for c in range(nz):
                        d_xi[i, c] = 0.0
                    d_xi[i, nv + i] = factor
                else:
                    for c in range(nz):
                        d_xi[i, c] = factor * d_rate[stage - 2, i, c]
                for c in range(nz):
                    d_v_stage[i, c] = factor * d_acc[stage - 1, i, c]
                d_v_stage[i, nv + i] += 1.0
            integrate(q, xi, q_stage)
            _configuration_tangent(
                xi, d_xi, nv, d_q_stage, d_conf, d_inc, D.transition_scratch, D.transition_matrices
            )
            _acceleration_tangent(
                model,
                env,
                stage_time,
                q_stage,
                v_stage,
                tau,
                W,
                D,
                d_q_stage,
                d_v_stage,
                force_tangent,
                d_acc[stage],
                acc[stage],
                scratch,
                False,
            )
            tangent_rate(xi, v_stage, rate[stage - 1])
            rate_jacobians(xi, v_stage, d_rate_xi, d_rate_v, D.transition_scratch)
            _rate_tangent(d_rate_xi, d_rate_v, d_xi, d_v_stage, d_rate[stage - 1])
        sixth = dt / 6.0
        for i in range(nv):
            xi[i] = sixth * (v[i] + 2.0 * rate[0, i] + 2.0 * rate[1, i] + rate[2, i])
            v_next[i] = v[i] + sixth * (acc[0, i] + 2.0 * acc[1, i] + 2.0 * acc[2, i] + acc[3, i])
        for i in range(nv):
            for c in range(nz):
                d_xi[i, c] = sixth * (
                    2.0 * d_rate[0, i, c] + 2.0 * d_rate[1, i, c] + d_rate[2, i, c]
                )
                d_v_stage[i, c] = sixth * (
                    d_acc[0, i, c] + 2.0 * d_acc[1, i, c] + 2.0 * d_acc[2, i, c] + d_acc[3, i, c]
                )
            d_xi[i, nv + i] += sixth
            d_v_stage[i, nv + i] += 1.0
        integrate(q, xi, q_next)
        _configuration_tangent(
            xi, d_xi, nv, d_q_stage, d_conf, d_inc, D.transition_scratch, D.transition_matrices
        )
    for i in range(nv):
        for j in range(2 * nv):
            A[i, j] = d_q_stage[i, j]
            A[nv + i, j] = d_v_stage[i, j]
        for j in range(m + nj):
            B[i, j] = d_q_stage[i, 2 * nv + j]
            B[nv + i, j] = d_v_stage[i, 2 * nv + j]


# ---------------------------------------------------------------------- benchmarking
@compiled(fastmath=True)
def time_acceleration_derivatives(model, env, q, v, tau, repeats, W, D, outputs):
    """Evaluate :func:`acceleration_derivatives_into` ``repeats`` times in compiled code.

    ``outputs`` is ``(dv, da_dq, da_dv, da_dtau, da_dcurrent, da_dthrust)``.
    """
    no_thrust = np.zeros(0)
    dv, da_dq, da_dv, da_dtau, da_dc, da_dthrust = outputs
    for _ in range(repeats):
        acceleration_derivatives_into(
            model,
            env,
            0.0,
            q,
            v,
            tau,
            no_thrust,
            W,
            D,
            dv,
            da_dq,
            da_dv,
            da_dtau,
            da_dc,
            da_dthrust,
        )


@compiled(fastmath=True, borrows_only=True)
def time_transitions(model, env, q, v, tau0, thrusts, dt, method, repeats, W, D, x_out, A, B):
    """Evaluate :func:`transition_into` ``repeats`` times in compiled code."""
    for _ in range(repeats):
        transition_into(model, env, 0.0, q, v, tau0, thrusts, dt, method, W, D, x_out, A, B)
