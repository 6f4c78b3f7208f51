"""Compiled rigid-body kernels: kinematics, articulated-body dynamics with general inertias, RK4 on SE(3).

These kernels are the compiled counterpart of Pinocchio's algorithms for the models the toolkit
simulates (a free-flyer root with 1-DOF revolute or prismatic joints), tested against Pinocchio
(tests/test_fast.py). Every fluid term comes from :mod:`hydro.laws`, the same functions the
Pinocchio path calls; nothing here re-implements a fluid law.

The model is a :class:`Model` record (:class:`RigidBodies`, :class:`hydro.laws.FluidModel`,
:class:`Thrusters`), built by :meth:`aiauv_pin.Vehicle.packed_model`. Spatial vectors are
``(linear, angular)`` as in Pinocchio. The articulated-body algorithm is Featherstone's (2008,
Table 7.1) with the rigid inertia replaced by the full 6x6 ``I = I_RB + M_A`` of each body, so the
added-mass inertia enters exactly (never lagged) and the added-mass Coriolis terms enter through
the body bias (Kirchhoff: ``M nu_dot + nu x* (M nu)``, Fossen 2021, eq. (6.43)); with a current the
added mass acts on the relative twist (Fossen 2021, eq. (10.5)).

The environment (:class:`Environment`) holds two compiled functions, called at every integrator
stage with the stage's own time:

* ``current(t, x, y, z, parameters) -> (V_x, V_y, V_z)``: the water velocity [m/s] at a world
  point [m] (:mod:`hydro.currents` has the built-in ones), sampled at each body's probe point
  (:attr:`hydro.laws.FluidModel.current_probe`). A time- or space-varying current is applied
  quasi-steadily: the relative-velocity form of Fossen 2021, eq. (10.5), which is exact for a
  uniform steady current, with the current's own local acceleration (Froude-Krylov and its
  added-mass reaction) neglected;
* ``disturbance(t, q, v, parameters, tau)``: adds a generalised force [N, N m] to ``tau`` (nv,).
"""

from __future__ import annotations

import math

import numpy as np

from control.laws import joint_pd_torque
from hydro.currents import current_velocity
from hydro.jit import compiled
from hydro.laws import add_body_fluid_bias, coriolis_wrench, hydrostatic_wrench

from ..disturbances import apply_disturbance
from .records import FREE_FLYER, REVOLUTE, Workspace
from .rotations import quaternion_rotation

#: Integration methods understood by :func:`step` and :func:`run_steps`.
RK4, EULER = 0, 1


# ---------------------------------------------------------------------- small linear algebra
@compiled(fastmath=True)
def _quat_to_rot(x, y, z, w, out):
    """Rotation matrix of a unit quaternion ``(x, y, z, w)`` into ``out``."""
    rows = quaternion_rotation(x, y, z, w)
    for i in range(3):
        for j in range(3):
            out[i, j] = rows[i][j]


@compiled(fastmath=True)
def _axis_rot(ax, ay, az, angle, out):
    """Rodrigues: rotation by ``angle`` about the unit axis ``a``."""
    s = math.sin(angle)
    c1 = 1.0 - math.cos(angle)
    out[0, 0] = 1.0 - c1 * (ay * ay + az * az)
    out[1, 1] = 1.0 - c1 * (ax * ax + az * az)
    out[2, 2] = 1.0 - c1 * (ax * ax + ay * ay)
    out[0, 1] = -s * az + c1 * ax * ay
    out[1, 0] = s * az + c1 * ax * ay
    out[0, 2] = s * ay + c1 * ax * az
    out[2, 0] = -s * ay + c1 * ax * az
    out[1, 2] = -s * ax + c1 * ay * az
    out[2, 1] = s * ax + c1 * ay * az


@compiled(fastmath=True)
def _motion_cross(a, b, out):
    """``a x b`` for motion vectors (Featherstone's ``crm``): ``(w x v' + v x w', w x w')``."""
    v0, v1, v2, w0, w1, w2 = a[0], a[1], a[2], a[3], a[4], a[5]
    out[0] = w1 * b[2] - w2 * b[1] + v1 * b[5] - v2 * b[4]
    out[1] = w2 * b[0] - w0 * b[2] + v2 * b[3] - v0 * b[5]
    out[2] = w0 * b[1] - w1 * b[0] + v0 * b[4] - v1 * b[3]
    out[3] = w1 * b[5] - w2 * b[4]
    out[4] = w2 * b[3] - w0 * b[5]
    out[5] = w0 * b[4] - w1 * b[3]


@compiled(fastmath=True)
def _add_force_cross(twist, wrench, out):
    """``out += twist x* wrench`` (Featherstone's ``crf``): ``(w x f, v x f + w x n)``."""
    v0, v1, v2, w0, w1, w2 = twist[0], twist[1], twist[2], twist[3], twist[4], twist[5]
    f0, f1, f2, n0, n1, n2 = wrench[0], wrench[1], wrench[2], wrench[3], wrench[4], wrench[5]
    out[0] += w1 * f2 - w2 * f1
    out[1] += w2 * f0 - w0 * f2
    out[2] += w0 * f1 - w1 * f0
    out[3] += v1 * f2 - v2 * f1 + w1 * n2 - w2 * n1
    out[4] += v2 * f0 - v0 * f2 + w2 * n0 - w0 * n2
    out[5] += v0 * f1 - v1 * f0 + w0 * n1 - w1 * n0


@compiled(fastmath=True)
def _matvec6(m, x, out):
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += m[i, j] * x[j]
        out[i] = s


@compiled(fastmath=True)
def _matTvec6(m, x, out):
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += m[j, i] * x[j]
        out[i] = s


@compiled(fastmath=True)
def _motion_transform(rot, trans, out):
    """``X``: parent twists to the child frame at ``(R, p)`` (Featherstone 2008, eq. (2.24))."""
    px, py, pz = trans[0], trans[1], trans[2]
    for i in range(3):
        r0, r1, r2 = rot[0, i], rot[1, i], rot[2, i]  # row i of R^T
        out[i, 0] = r0
        out[i, 1] = r1
        out[i, 2] = r2
        out[i + 3, 3] = r0
        out[i + 3, 4] = r1
        out[i + 3, 5] = r2
        out[i + 3, 0] = 0.0
        out[i + 3, 1] = 0.0
        out[i + 3, 2] = 0.0
        # -R^T [p]: row i of R^T times [p]
        out[i, 3] = -(r1 * pz - r2 * py)
        out[i, 4] = -(r2 * px - r0 * pz)
        out[i, 5] = -(r0 * py - r1 * px)


@compiled(fastmath=True)
def _x_apply(xl, m, out):
    """``out = X m``: a parent-frame motion vector in the child frame.

    ``xl`` is the child's placement in its parent (rows 0-2 ``R``, row 3 ``p``), so
    ``X = [[R^T, -R^T [p]], [0, R^T]]`` (Featherstone 2008, eq. (2.24)) and
    ``X m = (R^T (v - p x w), R^T w)``.
    """
    p0, p1, p2 = xl[3, 0], xl[3, 1], xl[3, 2]
    w0, w1, w2 = m[3], m[4], m[5]
    a0 = m[0] - (p1 * w2 - p2 * w1)
    a1 = m[1] - (p2 * w0 - p0 * w2)
    a2 = m[2] - (p0 * w1 - p1 * w0)
    for i in range(3):
        r0, r1, r2 = xl[0, i], xl[1, i], xl[2, i]
        out[i] = r0 * a0 + r1 * a1 + r2 * a2
        out[3 + i] = r0 * w0 + r1 * w1 + r2 * w2


@compiled(fastmath=True)
def _xT_add(xl, f, dst):
    """``dst += X^T f``: a child-frame force vector in the parent frame, ``(R f, p x R f + R n)``."""
    p0, p1, p2 = xl[3, 0], xl[3, 1], xl[3, 2]
    f0 = xl[0, 0] * f[0] + xl[0, 1] * f[1] + xl[0, 2] * f[2]
    f1 = xl[1, 0] * f[0] + xl[1, 1] * f[1] + xl[1, 2] * f[2]
    f2 = xl[2, 0] * f[0] + xl[2, 1] * f[1] + xl[2, 2] * f[2]
    dst[0] += f0
    dst[1] += f1
    dst[2] += f2
    dst[3] += xl[0, 0] * f[3] + xl[0, 1] * f[4] + xl[0, 2] * f[5] + p1 * f2 - p2 * f1
    dst[4] += xl[1, 0] * f[3] + xl[1, 1] * f[4] + xl[1, 2] * f[5] + p2 * f0 - p0 * f2
    dst[5] += xl[2, 0] * f[3] + xl[2, 1] * f[4] + xl[2, 2] * f[5] + p0 * f1 - p1 * f0


@compiled(fastmath=True)
def _add_transformed_inertia(xl, inertia, dst, half, rotated):
    """``dst += X^T I X`` for a symmetric 6x6 ``I`` given in the child frame, in 3x3 blocks.

    With ``I = [[A, B], [B^T, C]]`` rotated into the parent axes (``A' = R A R^T`` etc.) and
    ``P = [p]``: ``X^T I X = [[A', B' - A' P], [sym., C' + P B' + (P B')^T - P A' P]]``, the
    inertia transform of Featherstone 2008, eq. (2.66), written out for ``X`` of :func:`_x_apply`
    (about half the work of two 6x6 products).
    """
    # half = I blockdiag(R, R)^T, rotated = blockdiag(R, R) half
    for i in range(6):
        for c in range(0, 6, 3):
            a0, a1, a2 = inertia[i, c], inertia[i, c + 1], inertia[i, c + 2]
            for j in range(3):
                half[i, c + j] = a0 * xl[j, 0] + a1 * xl[j, 1] + a2 * xl[j, 2]
    for r in range(0, 6, 3):
        for col in range(6):
            y0, y1, y2 = half[r, col], half[r + 1, col], half[r + 2, col]
            for i in range(3):
                rotated[r + i, col] = xl[i, 0] * y0 + xl[i, 1] * y1 + xl[i, 2] * y2
    p0, p1, p2 = xl[3, 0], xl[3, 1], xl[3, 2]
    # T = A' P (row i: a_i x p) stored in half[0:3, 0:3]; new B = B' - T
    for i in range(3):
        a0, a1, a2 = rotated[i, 0], rotated[i, 1], rotated[i, 2]
        t0 = a1 * p2 - a2 * p1
        t1 = a2 * p0 - a0 * p2
        t2 = a0 * p1 - a1 * p0
        half[i, 0] = t0
        half[i, 1] = t1
        half[i, 2] = t2
        for j in range(3):
            dst[i, j] += rotated[i, j]
        b0 = rotated[i, 3] - t0
        b1 = rotated[i, 4] - t1
        b2 = rotated[i, 5] - t2
        dst[i, 3] += b0
        dst[i, 4] += b1
        dst[i, 5] += b2
        dst[3, i] += b0
        dst[4, i] += b1
        dst[5, i] += b2
    # Q = P B' (column j: p x b'_j) in half[0:3, 3:6]; P T (column j: p x t_j) in half[3:6, 0:3]
    for j in range(3):
        b0, b1, b2 = rotated[0, 3 + j], rotated[1, 3 + j], rotated[2, 3 + j]
        half[0, 3 + j] = p1 * b2 - p2 * b1
        half[1, 3 + j] = p2 * b0 - p0 * b2
        half[2, 3 + j] = p0 * b1 - p1 * b0
        t0, t1, t2 = half[0, j], half[1, j], half[2, j]
        half[3, j] = p1 * t2 - p2 * t1
        half[4, j] = p2 * t0 - p0 * t2
        half[5, j] = p0 * t1 - p1 * t0
    for i in range(3):
        for j in range(3):
            dst[3 + i, 3 + j] += (
                rotated[3 + i, 3 + j] + half[i, 3 + j] + half[j, 3 + i] - half[3 + i, j]
            )


@compiled(fastmath=True)
def _solve_spd6(a, b, out, low, y):
    """Solve ``a x = b`` for a symmetric positive-definite 6x6 ``a`` (Cholesky)."""
    for j in range(6):
        s = a[j, j]
        for k in range(j):
            s -= low[j, k] * low[j, k]
        d = math.sqrt(s) if s > 0.0 else math.nan
        low[j, j] = d
        for i in range(j + 1, 6):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s / d
    for i in range(6):
        s = b[i]
        for k in range(i):
            s -= low[i, k] * y[k]
        y[i] = s / low[i, i]
    for i in range(5, -1, -1):
        s = y[i]
        for k in range(i + 1, 6):
            s -= low[k, i] * out[k]
        out[i] = s / low[i, i]


# ---------------------------------------------------------------------- kinematics
@compiled(fastmath=True)
def kinematics(bodies, q, v, W):
    """Body poses in the world, placements in the parent, twists and ``v x S qd`` into ``W``."""
    rot_w, pos_w, xform, twist, bias_acc = (
        W.rotation,
        W.position,
        W.placement,
        W.twist,
        W.bias_acceleration,
    )
    rot_l = W.m33[0]
    rot_j = W.m33[1]
    pos_l = W.v6[0, :3]
    tmp = W.v6[1]
    place, axis = bodies.placement, bodies.axis
    for b in range(bodies.parent.shape[0]):
        parent, kind, iq, iv = (
            bodies.parent[b],
            bodies.kind[b],
            bodies.q_index[b],
            bodies.v_index[b],
        )
        if kind == FREE_FLYER:
            _quat_to_rot(q[iq + 3], q[iq + 4], q[iq + 5], q[iq + 6], rot_w[b])
            for i in range(3):
                pos_w[b, i] = q[iq + i]
            for i in range(6):
                twist[b, i] = v[iv + i]
                bias_acc[b, i] = 0.0
            for i in range(4):
                for j in range(3):
                    xform[b, i, j] = 1.0 if i == j else 0.0
            continue
        qj = q[iq]
        s = axis[b]
        if kind == REVOLUTE:
            _axis_rot(s[3], s[4], s[5], qj, rot_j)
            for i in range(3):
                for j in range(3):
                    rot_l[i, j] = (
                        place[b, i, 0] * rot_j[0, j]
                        + place[b, i, 1] * rot_j[1, j]
                        + place[b, i, 2] * rot_j[2, j]
                    )
                pos_l[i] = place[b, 3, i]
        else:
            for i in range(3):
                for j in range(3):
                    rot_l[i, j] = place[b, i, j]
                pos_l[i] = place[b, 3, i] + qj * (
                    place[b, i, 0] * s[0] + place[b, i, 1] * s[1] + place[b, i, 2] * s[2]
                )
        if parent < 0:
            for i in range(3):
                pos_w[b, i] = pos_l[i]
                for j in range(3):
                    rot_w[b, i, j] = rot_l[i, j]
        else:
            for i in range(3):
                acc = pos_w[parent, i]
                for k in range(3):
                    acc += rot_w[parent, i, k] * pos_l[k]
                pos_w[b, i] = acc
                for j in range(3):
                    rot_w[b, i, j] = (
                        rot_w[parent, i, 0] * rot_l[0, j]
                        + rot_w[parent, i, 1] * rot_l[1, j]
                        + rot_w[parent, i, 2] * rot_l[2, j]
                    )
        xl = xform[b]
        for i in range(3):
            for j in range(3):
                xl[i, j] = rot_l[i, j]
            xl[3, i] = pos_l[i]
        qd = v[iv]
        if parent < 0:
            for i in range(6):
                twist[b, i] = s[i] * qd
        else:
            _x_apply(xl, twist[parent], twist[b])
            for i in range(6):
                twist[b, i] += s[i] * qd
        for i in range(6):
            tmp[i] = s[i] * qd
        _motion_cross(twist[b], tmp, bias_acc[b])


@compiled(fastmath=True)
def sample_current(model, env, t, W):
    """Water velocity at every body's probe point at time ``t`` into ``W.current`` (after kinematics)."""
    probe = model.fluid.current_probe
    for b in range(W.current.shape[0]):
        rot = W.rotation[b]
        x = (
            W.position[b, 0]
            + rot[0, 0] * probe[b, 0]
            + rot[0, 1] * probe[b, 1]
            + rot[0, 2] * probe[b, 2]
        )
        y = (
            W.position[b, 1]
            + rot[1, 0] * probe[b, 0]
            + rot[1, 1] * probe[b, 1]
            + rot[1, 2] * probe[b, 2]
        )
        z = (
            W.position[b, 2]
            + rot[2, 0] * probe[b, 0]
            + rot[2, 1] * probe[b, 1]
            + rot[2, 2] * probe[b, 2]
        )
        c = current_velocity(
            env.current_function, env.current_kind, t, x, y, z, env.current_parameters
        )
        W.current[b, 0] = c[0]
        W.current[b, 1] = c[1]
        W.current[b, 2] = c[2]


@compiled(fastmath=True)
def body_bias(model, W):
    """Velocity- and state-dependent part of each body's equation ``f = I a + p`` (left-hand side).

    ``p = nu x* (I_RB nu)`` (rigid Coriolis, Featherstone 2008, eq. (2.67)) plus every fluid term of
    :func:`hydro.laws.add_body_fluid_bias`; after :func:`kinematics` and :func:`sample_current`.
    """
    rigid = model.bodies.rigid_inertia
    for b in range(W.bias.shape[0]):
        w = coriolis_wrench(rigid[b], W.twist[b])
        for i in range(6):
            W.bias[b, i] = w[i]
    add_body_fluid_bias(
        model.fluid, W.rotation, W.twist, W.current, W.bias, W.relative, W.fluid_scratch
    )


# ---------------------------------------------------------------------- articulated-body algorithm
@compiled(fastmath=True)
def _articulated(bodies, tau, W, out):
    """ABA passes 2 and 3 (Featherstone 2008, Table 7.1) with general 6x6 body inertias."""
    nb = bodies.parent.shape[0]
    xform, bias_acc, bias = W.placement, W.bias_acceleration, W.bias
    art, pa, u_vec, d_inv, u_sc, acc = (
        W.articulated_inertia,
        W.articulated_bias,
        W.u_vector,
        W.d_inverse,
        W.u_scalar,
        W.acceleration,
    )
    ia = W.m66[0]
    p_loc = W.v6[0]
    tmp = W.v6[1]
    for b in range(nb):
        for i in range(6):
            pa[b, i] = bias[b, i]
            for j in range(6):
                art[b, i, j] = bodies.inertia[b, i, j]
    for b in range(nb - 1, 0, -1):
        parent = bodies.parent[b]
        s = bodies.axis[b]
        _matvec6(art[b], s, u_vec[b])
        d = 0.0
        sp = 0.0
        for i in range(6):
            d += s[i] * u_vec[b, i]
            sp += s[i] * pa[b, i]
        d_inv[b] = 1.0 / d
        u_sc[b] = tau[bodies.v_index[b]] - sp
        if parent < 0:
            continue
        for i in range(6):
            for j in range(6):
                ia[i, j] = art[b, i, j] - u_vec[b, i] * u_vec[b, j] * d_inv[b]
        # p^a = p^A + I^a c + U u / D
        _matvec6(ia, bias_acc[b], p_loc)
        for i in range(6):
            p_loc[i] += pa[b, i] + u_vec[b, i] * u_sc[b] * d_inv[b]
        # parent += X^T I^a X, X^T p^a
        _add_transformed_inertia(xform[b], ia, art[parent], W.m66[1], W.m66[2])
        _xT_add(xform[b], p_loc, pa[parent])
    # root: free flyer (6 DOF, S = identity)
    iv0 = bodies.v_index[0]
    for i in range(6):
        tmp[i] = tau[iv0 + i] - pa[0, i]
    _solve_spd6(art[0], tmp, acc[0], W.m66[2], W.v6[2])
    for i in range(6):
        out[iv0 + i] = acc[0, i]
    for b in range(1, nb):
        parent = bodies.parent[b]
        s = bodies.axis[b]
        if parent < 0:
            for i in range(6):
                tmp[i] = bias_acc[b, i]
        else:
            _x_apply(xform[b], acc[parent], tmp)
            for i in range(6):
                tmp[i] += bias_acc[b, i]
        ua = 0.0
        for i in range(6):
            ua += u_vec[b, i] * tmp[i]
        qdd = (u_sc[b] - ua) * d_inv[b]
        out[bodies.v_index[b]] = qdd
        for i in range(6):
            acc[b, i] = tmp[i] + s[i] * qdd


@compiled(fastmath=True)
def generalized_force(bodies, xform, body_wrench, out, tmp):
    """Generalised force ``sum_b J_b^T w_b`` of body wrenches (body frames); consumes them."""
    for b in range(bodies.parent.shape[0] - 1, -1, -1):
        iv = bodies.v_index[b]
        if bodies.kind[b] == FREE_FLYER:
            for i in range(6):
                out[iv + i] = body_wrench[b, i]
        else:
            s = 0.0
            for i in range(6):
                s += bodies.axis[b, i] * body_wrench[b, i]
            out[iv] = s
        parent = bodies.parent[b]
        if parent >= 0:
            _xT_add(xform[b], body_wrench[b], body_wrench[parent])


@compiled(fastmath=True)
def restoring_into(model, W, out):
    """``g(q)`` (left-hand side: weight minus buoyancy, generalised) after :func:`kinematics`.

    Built from :func:`hydro.laws.hydrostatic_wrench` through the same per-body data the dynamics use.
    """
    wrench = W.relative
    h = model.fluid.hydrostatics
    for b in range(wrench.shape[0]):
        rot = W.rotation[b]
        w = hydrostatic_wrench(h[b, 0], h[b, 1], h[b, 2], h[b, 3], rot[2, 0], rot[2, 1], rot[2, 2])
        for i in range(6):
            wrench[b, i] = -w[i]
    generalized_force(model.bodies, W.placement, wrench, out, W.v6[0])


@compiled(fastmath=True)
def thrust_into(model, W, thrusts, out):
    """``out = B(q) thrusts`` (the paper's eq. (20)) after :func:`kinematics` [N, N m]."""
    wrench = W.relative
    wrench[:, :] = 0.0
    th = model.thrusters
    for k in range(th.body.shape[0]):
        b = th.body[k]
        for i in range(6):
            wrench[b, i] += th.unit_wrench[k, i] * thrusts[k]
    generalized_force(model.bodies, W.placement, wrench, out, W.v6[0])


# ---------------------------------------------------------------------- workspace
@compiled
def workspace(nb, nq, nv):
    """Scratch arrays of one evaluation (allocate once, reuse in every step)."""
    return Workspace(
        np.empty((nb, 3, 3)),
        np.empty((nb, 3)),
        np.empty((nb, 4, 3)),
        np.empty((nb, 6)),
        np.empty((nb, 6)),
        np.empty((nb, 6)),
        np.empty((nb, 6)),
        np.zeros((nb, 3)),
        np.empty((nb, 6, 6)),
        np.empty((nb, 6)),
        np.empty((nb, 6)),
        np.empty(nb),
        np.empty(nb),
        np.empty((nb, 6)),
        np.empty((3, 6)),
        np.empty((3, 6, 6)),
        np.empty((8, 6)),
        np.empty((2, 3, 3)),
        np.empty(nv),
        np.empty(nv),
        np.zeros(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nv),
        np.empty(nq),
        np.empty(nq),
    )


def new_workspace(model, nq: int, nv: int) -> Workspace:
    """A :class:`Workspace` for ``model`` (from Python)."""
    return workspace(model.bodies.parent.shape[0], nq, nv)


# ---------------------------------------------------------------------- forward dynamics
@compiled(fastmath=True)
def acceleration_into(model, env, servo, t, q, v, tau, W, out):
    """Forward dynamics ``dv`` of ``M(q) dv + bias(q, v) = tau + servo + disturbance`` into ``out``."""
    kinematics(model.bodies, q, v, W)
    sample_current(model, env, t, W)
    body_bias(model, W)
    tau_all = W.tau_total
    for i in range(tau.shape[0]):
        tau_all[i] = tau[i]
    apply_disturbance(
        env.disturbance_function, env.disturbance_kind, t, q, v, env.disturbance_parameters, tau_all
    )
    n_joint = servo.references.shape[0]
    if servo.enabled and n_joint > 0:
        # joint servo, paper eq. (24): -k_p (q - q*) - k_d qd + g_q(q)
        g = W.restoring
        if servo.compensate_restoring:
            restoring_into(model, W, g)
        else:
            g[:] = 0.0
        for k in range(n_joint):
            tau_all[6 + k] += joint_pd_torque(
                q[7 + k],
                v[6 + k],
                servo.references[k],
                g[6 + k],
                servo.stiffness[k],
                servo.damping[k],
            )
    _articulated(model.bodies, tau_all, W, out)


# ------------------------------------------------------------------ SE(3) x R^n group operations
@compiled(fastmath=True)
def integrate(q, xi, out):
    """``out = q * exp(xi)``: free flyer by the exact SE(3) exponential, joints by addition.

    ``exp(v, w) = (exp3(w), V(w) v)`` with ``V = I + (1 - cos t)/t^2 [w] + (t - sin t)/t^3 [w]^2``
    (Barfoot 2017, eq. (7.85)); the quaternion is ``q_0 (x) (sin(t/2) w/t, cos(t/2))``, renormalised
    and kept in ``q_0``'s hemisphere.
    """
    w0, w1, w2 = xi[3], xi[4], xi[5]
    t2 = w0 * w0 + w1 * w1 + w2 * w2
    t = math.sqrt(t2)
    if t < 0.1:
        a = 0.5 - t2 / 24.0 + t2 * t2 / 720.0 - t2 * t2 * t2 / 40320.0  # (1 - cos t)/t^2
        c = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0  # (t - sin t)/t^3
        h = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0 - t2 * t2 * t2 / 645120.0  # sin(t/2)/t
    else:
        a = (1.0 - math.cos(t)) / t2
        c = (t - math.sin(t)) / (t2 * t)
        h = math.sin(0.5 * t) / t
    v0, v1, v2 = xi[0], xi[1], xi[2]
    # V v = v + a w x v + c w x (w x v)
    c0 = w1 * v2 - w2 * v1
    c1 = w2 * v0 - w0 * v2
    c2 = w0 * v1 - w1 * v0
    d0 = w1 * c2 - w2 * c1
    d1 = w2 * c0 - w0 * c2
    d2 = w0 * c1 - w1 * c0
    p0 = v0 + a * c0 + c * d0
    p1 = v1 + a * c1 + c * d1
    p2 = v2 + a * c2 + c * d2
    x, y, z, w = q[3], q[4], q[5], q[6]
    # R(q0) p
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = quaternion_rotation(x, y, z, w)
    out[0] = q[0] + r00 * p0 + r01 * p1 + r02 * p2
    out[1] = q[1] + r10 * p0 + r11 * p1 + r12 * p2
    out[2] = q[2] + r20 * p0 + r21 * p1 + r22 * p2
    ex, ey, ez, ew = h * w0, h * w1, h * w2, math.cos(0.5 * t)
    nx = w * ex + x * ew + y * ez - z * ey
    ny = w * ey - x * ez + y * ew + z * ex
    nz = w * ez + x * ey - y * ex + z * ew
    nw = w * ew - x * ex - y * ey - z * ez
    norm = math.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    if x * nx + y * ny + z * nz + w * nw < 0.0:
        norm = -norm
    out[3] = nx / norm
    out[4] = ny / norm
    out[5] = nz / norm
    out[6] = nw / norm
    for i in range(7, q.shape[0]):
        out[i] = q[i] + xi[i - 1]


@compiled(fastmath=True)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@compiled(fastmath=True)
def tangent_rate(xi, vel, out):
    """``out = J_r(xi)^-1 vel``: the rate of ``xi`` for ``integrate(q0, xi)`` moving with ``vel``.

    ``J_r`` is the right Jacobian of ``exp`` (Pinocchio's ``dIntegrate`` w.r.t. its 2nd argument):
    on SE(3), ``J_r(rho, phi) = J_l(-rho, -phi) = [[J3, Q], [0, J3]]`` with ``Q = Q_l(-rho, -phi)``
    (Barfoot 2017, eq. (7.86)); its inverse is ``[[J3^-1, -J3^-1 Q J3^-1], [0, J3^-1]]`` with
    ``J3^-1 = I - [p]/2 + d [p]^2`` at ``p = -phi``, ``d = 1/t^2 - (1 + cos t)/(2 t sin t)``
    (Barfoot 2017, eq. (7.77)). Joints: identity.
    """
    r0, r1, r2 = -xi[0], -xi[1], -xi[2]
    p0, p1, p2 = -xi[3], -xi[4], -xi[5]
    t2 = p0 * p0 + p1 * p1 + p2 * p2
    t = math.sqrt(t2)
    if t < 0.1:
        c1 = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0 - t2 * t2 * t2 / 362880.0
        c2 = 1.0 / 24.0 - t2 / 720.0 + t2 * t2 / 40320.0 - t2 * t2 * t2 / 3628800.0
        c3 = 1.0 / 120.0 - t2 / 2520.0 + t2 * t2 / 120960.0 - t2 * t2 * t2 / 9979200.0
        d = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0 + t2 * t2 * t2 / 1209600.0
    else:
        s, c = math.sin(t), math.cos(t)
        c1 = (t - s) / (t2 * t)
        c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2)
        c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t2 * t2 * t)
        d = 1.0 / t2 - (1.0 + c) / (2.0 * t * s)
    # angular part: J3^-1 w = w - p x w / 2 + d p x (p x w)
    w0, w1, w2 = vel[3], vel[4], vel[5]
    x0, x1, x2 = _cross(p0, p1, p2, w0, w1, w2)
    y0, y1, y2 = _cross(p0, p1, p2, x0, x1, x2)
    a0 = w0 - 0.5 * x0 + d * y0
    a1 = w1 - 0.5 * x1 + d * y1
    a2 = w2 - 0.5 * x2 + d * y2
    # Q a with Q = r/2 + c1 (pr + rp + prp) + c2 (ppr + rpp - 3 prp) + c3 (prpp + pprp)   (products
    # of skew matrices applied right to left)
    pa0, pa1, pa2 = _cross(p0, p1, p2, a0, a1, a2)
    ra0, ra1, ra2 = _cross(r0, r1, r2, a0, a1, a2)
    pra0, pra1, pra2 = _cross(p0, p1, p2, ra0, ra1, ra2)
    rpa0, rpa1, rpa2 = _cross(r0, r1, r2, pa0, pa1, pa2)
    prpa0, prpa1, prpa2 = _cross(p0, p1, p2, rpa0, rpa1, rpa2)
    ppra0, ppra1, ppra2 = _cross(p0, p1, p2, pra0, pra1, pra2)
    ppa0, ppa1, ppa2 = _cross(p0, p1, p2, pa0, pa1, pa2)
    rppa0, rppa1, rppa2 = _cross(r0, r1, r2, ppa0, ppa1, ppa2)
    prppa0, prppa1, prppa2 = _cross(p0, p1, p2, rppa0, rppa1, rppa2)
    pprpa0, pprpa1, pprpa2 = _cross(p0, p1, p2, prpa0, prpa1, prpa2)
    q0 = (
        0.5 * ra0
        + c1 * (pra0 + rpa0 + prpa0)
        + c2 * (ppra0 + rppa0 - 3.0 * prpa0)
        + c3 * (prppa0 + pprpa0)
    )
    q1 = (
        0.5 * ra1
        + c1 * (pra1 + rpa1 + prpa1)
        + c2 * (ppra1 + rppa1 - 3.0 * prpa1)
        + c3 * (prppa1 + pprpa1)
    )
    q2 = (
        0.5 * ra2
        + c1 * (pra2 + rpa2 + prpa2)
        + c2 * (ppra2 + rppa2 - 3.0 * prpa2)
        + c3 * (prppa2 + pprpa2)
    )
    # linear part: J3^-1 (v - Q a)
    l0, l1, l2 = vel[0] - q0, vel[1] - q1, vel[2] - q2
    x0, x1, x2 = _cross(p0, p1, p2, l0, l1, l2)
    y0, y1, y2 = _cross(p0, p1, p2, x0, x1, x2)
    out[0] = l0 - 0.5 * x0 + d * y0
    out[1] = l1 - 0.5 * x1 + d * y1
    out[2] = l2 - 0.5 * x2 + d * y2
    out[3] = a0
    out[4] = a1
    out[5] = a2
    for i in range(6, vel.shape[0]):
        out[i] = vel[i]


# ---------------------------------------------------------------------- integrators
@compiled(fastmath=True)
def rk4_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """One Runge-Kutta-Munthe-Kaas step of order 4 (as :func:`aiauv_pin.integrators.rk4_step`).

    Stages at ``t``, ``t + dt/2`` (twice) and ``t + dt`` see the current and disturbance at their time.
    """
    nv = v.shape[0]
    half = 0.5 * dt
    a1, a2, a3, a4 = W.acc1, W.acc2, W.acc3, W.acc4
    k2, k3, k4, xi, vs, qs = W.rate2, W.rate3, W.rate4, W.xi, W.v_stage, W.q_stage
    acceleration_into(model, env, servo, t, q, v, tau, W, a1)
    for i in range(nv):
        xi[i] = half * v[i]  # k1 = v: the Jacobian at xi = 0 is the identity
        vs[i] = v[i] + half * a1[i]
    integrate(q, xi, qs)
    acceleration_into(model, env, servo, t + half, qs, vs, tau, W, a2)
    tangent_rate(xi, vs, k2)
    for i in range(nv):
        xi[i] = half * k2[i]
        vs[i] = v[i] + half * a2[i]
    integrate(q, xi, qs)
    acceleration_into(model, env, servo, t + half, qs, vs, tau, W, a3)
    tangent_rate(xi, vs, k3)
    for i in range(nv):
        xi[i] = dt * k3[i]
        vs[i] = v[i] + dt * a3[i]
    integrate(q, xi, qs)
    acceleration_into(model, env, servo, t + dt, qs, vs, tau, W, a4)
    tangent_rate(xi, vs, k4)
    sixth = dt / 6.0
    for i in range(nv):
        xi[i] = sixth * (v[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        v_out[i] = v[i] + sixth * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
    integrate(q, xi, q_out)


@compiled(fastmath=True)
def euler_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """Semi-implicit Euler: ``v += dt f(q, v)``, then ``q = q * exp(dt v)``."""
    a = W.acc1
    xi = W.xi
    acceleration_into(model, env, servo, t, q, v, tau, W, a)
    for i in range(v.shape[0]):
        v_out[i] = v[i] + dt * a[i]
        xi[i] = dt * v_out[i]
    integrate(q, xi, q_out)


@compiled(fastmath=True)
def step_into(model, env, servo, t, q, v, tau, dt, method, W, q_out, v_out):
    """One step of ``method`` (:data:`RK4` or :data:`EULER`) into ``q_out, v_out``."""
    if method == RK4:
        rk4_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)
    else:
        euler_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)


@compiled(fastmath=True)
def is_finite_state(q, v):
    """Whether every entry of ``q`` and ``v`` is finite."""
    for i in range(q.shape[0]):
        if not math.isfinite(q[i]):
            return False
    for i in range(v.shape[0]):
        if not math.isfinite(v[i]):
            return False
    return True


@compiled(fastmath=True)
def run_steps(model, env, servo, t0, q, v, tau, dt, n_steps, method, W):
    """Advance ``(q, v)`` in place by ``n_steps`` steps from time ``t0`` with ``tau`` held.

    Returns:
        The number of steps completed; fewer than ``n_steps`` if the state became non-finite (then
        ``q, v`` hold the last finite state).
    """
    for k in range(n_steps):
        step_into(model, env, servo, t0 + k * dt, q, v, tau, dt, method, W, W.q_next, W.v_next)
        if not is_finite_state(W.q_next, W.v_next):
            return k
        q[:] = W.q_next
        v[:] = W.v_next
    return n_steps


@compiled(fastmath=True)
def time_accelerations(model, env, servo, q, v, tau, repeats, W, out):
    """Evaluate the dynamics ``repeats`` times in compiled code (benchmarking)."""
    for _ in range(repeats):
        acceleration_into(model, env, servo, 0.0, q, v, tau, W, out)


@compiled(fastmath=True)
def frame_kinematics(model, q, v, body, rotation, translation, W):
    """World pose and twist (in its own axes) of a frame fixed to ``body`` at ``(rotation, translation)``.

    Returns:
        ``(R (3x3), p (3,), twist (6,))`` with the twist ``(v, w)`` in the frame's axes.
    """
    kinematics(model.bodies, q, v, W)
    return frame_of_body(W, body, rotation, translation)


@compiled(fastmath=True)
def frame_of_body(W, body, rotation, translation):
    """Pose and own-axes twist of a frame on ``body``, from the kinematics already in ``W``."""
    rot_w, pos_w = W.rotation[body], W.position[body]
    rot = np.empty((3, 3))
    pos = np.empty(3)
    for i in range(3):
        acc = pos_w[i]
        for k in range(3):
            acc += rot_w[i, k] * translation[k]
        pos[i] = acc
        for j in range(3):
            rot[i, j] = (
                rot_w[i, 0] * rotation[0, j]
                + rot_w[i, 1] * rotation[1, j]
                + rot_w[i, 2] * rotation[2, j]
            )
    x = W.m66[0]
    _motion_transform(rotation, translation, x)
    frame_twist = np.empty(6)
    _matvec6(x, W.twist[body], frame_twist)
    return rot, pos, frame_twist


@compiled(fastmath=True)
def restoring_forces(model, q, W, out):
    """``g(q)``: hydrostatic generalised force on the left-hand side (weight minus buoyancy)."""
    kinematics(model.bodies, q, W.zero_velocity, W)
    restoring_into(model, W, out)


@compiled(fastmath=True)
def thrust_matrix(model, q, W, out):
    """``B(q)`` (nv x m): generalised forces of unit thrusts (the paper's eq. (20))."""
    kinematics(model.bodies, q, W.zero_velocity, W)
    m = model.thrusters.body.shape[0]
    unit = np.zeros(m)
    column = W.tau_total
    for k in range(m):
        unit[k] = 1.0
        thrust_into(model, W, unit, column)
        unit[k] = 0.0
        for i in range(column.shape[0]):
            out[i, k] = column[i]
