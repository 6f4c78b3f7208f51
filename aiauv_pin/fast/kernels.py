"""Numba kernels: kinematics, articulated-body dynamics with general inertias, hydro, RK4 on SE(3).

Everything here works on the flat arrays of :class:`aiauv_pin.fast.model.FastModel` (a tuple ``M``):

* ``ints`` (nb, 4) int64: parent body (-1 for the base), joint type (0 free flyer, 1 revolute,
  2 prismatic), index in ``q``, index in ``v``;
* ``place`` (nb, 4, 3): joint placement in the parent body (rows 0-2 rotation, row 3 translation);
* ``axis`` (nb, 6): motion subspace ``S`` of the 1-DOF joint in the child frame;
* ``inertia`` (nb, 3, 6, 6): ``[0]`` rigid + added inertia, ``[1]`` added mass ``M_A``,
  ``[2]`` rigid inertia, all about the body origin in body axes;
* ``restore`` (nb, 4): ``(B - W, B c_B - W c_W)`` per body (weight ``W`` at ``c_W``, buoyancy
  ``B`` at ``c_B``) so that the hydrostatic wrench on the body is
  ``((B - W) e, (B c_B - W c_W) x e)`` with ``e`` the world's up axis in body axes
  (Fossen 2021, eq. (4.6));
* ``link_i`` (nl, 5) int64: body of the link, 1 if it has crossflow drag, 1 if the link frame is
  the body frame, 1 if the cylinder frame is the link frame, 1 if ``D_Q`` is diagonal (these
  three only skip multiplications by 0 and 1);
* ``link_m`` (nl, 4, 6, 6): link-from-body motion transform, ``D_L``, ``D_Q``, cylinder-from-link
  motion transform;
* ``link_f`` (nl, 2): cylinder length [m], strip coefficient ``rho r C_dC`` [kg/m^2];
* ``gauss`` (2, n): Gauss-Legendre nodes and weights on ``[0, 1]``;
* ``thrust`` (m, 7): body index, unit-thrust wrench in the body frame (6).

Spatial vectors are ``(linear, angular)`` as in Pinocchio. The articulated-body algorithm is
Featherstone's (2008, Table 7.1) with the rigid inertia replaced by the full 6x6
``I = I_RB + M_A`` of each body, so that the added-mass inertia and Coriolis terms enter exactly as
in :meth:`aiauv_pin.Vehicle.acceleration` (Kirchhoff: ``M nu_dot + nu x* (M nu)``, Fossen 2021,
eq. (6.43)); with a current the added mass acts on the relative twist (Fossen 2021, eq. (10.5)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_OPTS = dict(
    cache=True,
    nogil=True,
    # reassociation and FMA contraction only: NaN and infinity semantics are kept (divergence
    # checks)
    fastmath={"reassoc", "contract", "arcp", "nsz"},
    error_model="numpy",
)

FREE_FLYER, REVOLUTE, PRISMATIC = 0, 1, 2


# ---------------------------------------------------------------------- small linear algebra
@njit(**_OPTS)
def _quat_to_rot(x, y, z, w, out):
    """Rotation matrix of a unit quaternion ``(x, y, z, w)``."""
    out[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[0, 1] = 2.0 * (x * y - z * w)
    out[0, 2] = 2.0 * (x * z + y * w)
    out[1, 0] = 2.0 * (x * y + z * w)
    out[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[1, 2] = 2.0 * (y * z - x * w)
    out[2, 0] = 2.0 * (x * z - y * w)
    out[2, 1] = 2.0 * (y * z + x * w)
    out[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(**_OPTS)
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


@njit(**_OPTS)
def _motion_cross(a, b, out):
    """``a x b`` for motion vectors (Featherstone's ``crm``): ``(w x v' + v x w', w x w')``."""
    v0, v1, v2, w0, w1, w2 = a[0], a[1], a[2], a[3], a[4], a[5]
    out[0] = w1 * b[2] - w2 * b[1] + v1 * b[5] - v2 * b[4]
    out[1] = w2 * b[0] - w0 * b[2] + v2 * b[3] - v0 * b[5]
    out[2] = w0 * b[1] - w1 * b[0] + v0 * b[4] - v1 * b[3]
    out[3] = w1 * b[5] - w2 * b[4]
    out[4] = w2 * b[3] - w0 * b[5]
    out[5] = w0 * b[4] - w1 * b[3]


@njit(**_OPTS)
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


@njit(**_OPTS)
def _matvec6(m, x, out):
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += m[i, j] * x[j]
        out[i] = s


@njit(**_OPTS)
def _matTvec6(m, x, out):
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += m[j, i] * x[j]
        out[i] = s


@njit(**_OPTS)
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


@njit(**_OPTS)
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


@njit(**_OPTS)
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


@njit(**_OPTS)
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


@njit(**_OPTS)
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
@njit(**_OPTS)
def kinematics(ints, place, axis, q, v, rot_w, pos_w, xform, twist, bias_acc, m33, v6):
    """Body poses in the world, placements in the parent (``xform``), twists and ``v x S qd``."""
    nb = ints.shape[0]
    rot_l = m33[0]
    rot_j = m33[1]
    pos_l = v6[0, :3]
    tmp = v6[1]
    for b in range(nb):
        parent, kind, iq, iv = ints[b, 0], ints[b, 1], ints[b, 2], ints[b, 3]
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


# ---------------------------------------------------------------------- hydrodynamics
@njit(**_OPTS)
def _crossflow(vel, length, coefficient, gauss, out):
    """Crossflow wrench about the cylinder origin (as :func:`hydro.crossflow.crossflow_wrench`).

    ``f(x) = -k |v_n| v_n`` with ``v_n(x) = (v + r x, w - q x)`` integrated over ``[0, L]`` with
    Gauss-Legendre on each side of the point where ``|v_n|`` is smallest (Fossen 2021, Sec. 6.4.3).
    """
    a_y, a_z = vel[1], vel[2]
    b_y, b_z = vel[5], -vel[4]
    slope2 = b_y * b_y + b_z * b_z
    split = 0.0
    if slope2 > 0.0:
        split = -(a_y * b_y + a_z * b_z) / slope2
    if split < 0.0:
        split = 0.0
    elif split > length:
        split = length
    fy = 0.0
    fz = 0.0
    my = 0.0
    mz = 0.0
    n = gauss.shape[1]
    for part in range(2):
        start = 0.0 if part == 0 else split
        width = split if part == 0 else length - split
        for k in range(n):
            x = start + width * gauss[0, k]
            w = width * gauss[1, k]
            ny = a_y + b_y * x
            nz = a_z + b_z * x
            speed = math.sqrt(ny * ny + nz * nz)
            ly = -speed * ny
            lz = -speed * nz
            fy += w * ly
            fz += w * lz
            my -= w * x * lz
            mz += w * x * ly
    out[0] = 0.0
    out[1] = coefficient * fy
    out[2] = coefficient * fz
    out[3] = 0.0
    out[4] = coefficient * my
    out[5] = coefficient * mz


@njit(**_OPTS)
def body_bias(M, rot_w, twist, current, bias, relative, v6):
    """Velocity- and state-dependent part of each body's equation ``f = I a + p`` (left-hand side).

    ``p = nu x* (I_RB nu) + nu_r x* (M_A nu_r) + M_A (w x v_c, 0) - tau_D(nu_r) - g_wrench``.
    """
    ints, inertia, restore, link_i, link_m, link_f, gauss = M[0], M[3], M[4], M[5], M[6], M[7], M[8]
    nb = ints.shape[0]
    mom = v6[0]
    tmp = v6[1]
    tmp2 = v6[2]
    wrench = v6[3]
    cyl = v6[4]
    cyl_w = v6[5]
    cur_x, cur_y, cur_z = current[0], current[1], current[2]
    has_current = cur_x != 0.0 or cur_y != 0.0 or cur_z != 0.0
    for b in range(nb):
        rot = rot_w[b]
        nu = twist[b]
        for i in range(6):
            bias[b, i] = 0.0
            relative[b, i] = nu[i]
        if not has_current:
            # nu x* (I_RB nu) + nu x* (M_A nu) = nu x* ((I_RB + M_A) nu): one product
            # (Featherstone 2008, eq. (2.67); Fossen 2021, eq. (6.46))
            _matvec6(inertia[b, 0], nu, mom)
            _add_force_cross(nu, mom, bias[b])
        else:
            # rigid Coriolis-centripetal: nu x* (I_RB nu)   (Featherstone 2008, eq. (2.67))
            _matvec6(inertia[b, 2], nu, mom)
            _add_force_cross(nu, mom, bias[b])
            # current in body axes, v_c = R^T V_c; nu_r = nu - (v_c, 0)   (Fossen 2021, eq. (10.4))
            vc0 = rot[0, 0] * cur_x + rot[1, 0] * cur_y + rot[2, 0] * cur_z
            vc1 = rot[0, 1] * cur_x + rot[1, 1] * cur_y + rot[2, 1] * cur_z
            vc2 = rot[0, 2] * cur_x + rot[1, 2] * cur_y + rot[2, 2] * cur_z
            relative[b, 0] -= vc0
            relative[b, 1] -= vc1
            relative[b, 2] -= vc2
            # M_A (w x v_c, 0): d/dt of the current seen from the rotating body
            # (Fossen 2021, eq. (10.5))
            tmp[0] = nu[4] * vc2 - nu[5] * vc1
            tmp[1] = nu[5] * vc0 - nu[3] * vc2
            tmp[2] = nu[3] * vc1 - nu[4] * vc0
            tmp[3] = 0.0
            tmp[4] = 0.0
            tmp[5] = 0.0
            _matvec6(inertia[b, 1], tmp, tmp2)
            for i in range(6):
                bias[b, i] += tmp2[i]
            # added-mass Coriolis: nu_r x* (M_A nu_r)   (Fossen 2021, eq. (6.46))
            _matvec6(inertia[b, 1], relative[b], mom)
            _add_force_cross(relative[b], mom, bias[b])
        # hydrostatics: ((B - W) e, (B c_B - W c_W) x e), e = R^T z   (Fossen 2021, eq. (4.6))
        e0, e1, e2 = rot[2, 0], rot[2, 1], rot[2, 2]
        sf, sx, sy, sz = restore[b, 0], restore[b, 1], restore[b, 2], restore[b, 3]
        bias[b, 0] -= sf * e0
        bias[b, 1] -= sf * e1
        bias[b, 2] -= sf * e2
        bias[b, 3] -= sy * e2 - sz * e1
        bias[b, 4] -= sz * e0 - sx * e2
        bias[b, 5] -= sx * e1 - sy * e0
    # damping per link: -D_L nu_r - D_Q |nu_r| nu_r (+ crossflow)   (Fossen 2021, eq. (6.60)-(6.62))
    for k in range(link_i.shape[0]):
        b = link_i[k, 0]
        x_link = link_m[k, 0]
        same_frame = link_i[k, 2] != 0
        if same_frame:
            for i in range(6):
                tmp[i] = relative[b, i]
        else:
            _matvec6(x_link, relative[b], tmp)
        d_lin = link_m[k, 1]
        d_quad = link_m[k, 2]
        if link_i[k, 4] != 0:
            for i in range(6):
                s = 0.0
                for j in range(6):
                    s += d_lin[i, j] * tmp[j]
                wrench[i] = -s - d_quad[i, i] * abs(tmp[i]) * tmp[i]
        else:
            for i in range(6):
                tmp2[i] = abs(tmp[i]) * tmp[i]
            for i in range(6):
                s = 0.0
                for j in range(6):
                    s += d_lin[i, j] * tmp[j] + d_quad[i, j] * tmp2[j]
                wrench[i] = -s
        if link_i[k, 1]:
            x_cyl = link_m[k, 3]
            if link_i[k, 3] != 0:
                _crossflow(tmp, link_f[k, 0], link_f[k, 1], gauss, cyl_w)
                for i in range(6):
                    wrench[i] += cyl_w[i]
            else:
                _matvec6(x_cyl, tmp, cyl)
                _crossflow(cyl, link_f[k, 0], link_f[k, 1], gauss, cyl_w)
                _matTvec6(x_cyl, cyl_w, tmp2)
                for i in range(6):
                    wrench[i] += tmp2[i]
        if same_frame:
            for i in range(6):
                bias[b, i] -= wrench[i]
        else:
            _matTvec6(x_link, wrench, tmp2)
            for i in range(6):
                bias[b, i] -= tmp2[i]


# ---------------------------------------------------------------------- articulated-body algorithm
@njit(**_OPTS)
def _articulated(M, tau, xform, bias_acc, bias, out, art, pa, u_vec, scal, acc, m66, v6):
    """ABA passes 2 and 3 (Featherstone 2008, Table 7.1) with general 6x6 body inertias."""
    ints, axis, inertia = M[0], M[2], M[3]
    nb = ints.shape[0]
    d_inv = scal[0]
    u_sc = scal[1]
    ia = m66[0]
    t66 = m66[1]
    p_loc = v6[0]
    tmp = v6[1]
    for b in range(nb):
        for i in range(6):
            pa[b, i] = bias[b, i]
            for j in range(6):
                art[b, i, j] = inertia[b, 0, i, j]
    for b in range(nb - 1, 0, -1):
        parent = ints[b, 0]
        s = axis[b]
        _matvec6(art[b], s, u_vec[b])
        d = 0.0
        sp = 0.0
        for i in range(6):
            d += s[i] * u_vec[b, i]
            sp += s[i] * pa[b, i]
        d_inv[b] = 1.0 / d
        u_sc[b] = tau[ints[b, 3]] - sp
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
        _add_transformed_inertia(xform[b], ia, art[parent], t66, m66[2])
        _xT_add(xform[b], p_loc, pa[parent])
    # root: free flyer (6 DOF, S = identity)
    iv0 = ints[0, 3]
    for i in range(6):
        tmp[i] = tau[iv0 + i] - pa[0, i]
    _solve_spd6(art[0], tmp, acc[0], m66[2], v6[2])
    for i in range(6):
        out[iv0 + i] = acc[0, i]
    for b in range(1, nb):
        parent = ints[b, 0]
        s = axis[b]
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
        out[ints[b, 3]] = qdd
        for i in range(6):
            acc[b, i] = tmp[i] + s[i] * qdd


@njit(**_OPTS)
def _backward_generalized(ints, axis, xform, body_wrench, out, tmp):
    """Generalised force ``sum_b J_b^T w_b`` of body wrenches (body frames); consumes them."""
    nb = ints.shape[0]
    for b in range(nb - 1, -1, -1):
        iv = ints[b, 3]
        if ints[b, 1] == FREE_FLYER:
            for i in range(6):
                out[iv + i] = body_wrench[b, i]
        else:
            s = 0.0
            for i in range(6):
                s += axis[b, i] * body_wrench[b, i]
            out[iv] = s
        parent = ints[b, 0]
        if parent >= 0:
            _xT_add(xform[b], body_wrench[b], body_wrench[parent])


@njit(**_OPTS)
def _restoring_wrenches(restore, rot_w, out):
    """Hydrostatic wrench acting on each body, in body axes (Fossen 2021, eq. (4.6))."""
    for b in range(restore.shape[0]):
        e0, e1, e2 = rot_w[b, 2, 0], rot_w[b, 2, 1], rot_w[b, 2, 2]
        sf, sx, sy, sz = restore[b, 0], restore[b, 1], restore[b, 2], restore[b, 3]
        out[b, 0] = sf * e0
        out[b, 1] = sf * e1
        out[b, 2] = sf * e2
        out[b, 3] = sy * e2 - sz * e1
        out[b, 4] = sz * e0 - sx * e2
        out[b, 5] = sx * e1 - sy * e0


# ---------------------------------------------------------------------- workspace
@njit(**_OPTS)
def workspace(nb, nq, nv):
    """Scratch arrays reused by every evaluation (no allocation inside the step loop)."""
    return (
        np.empty((nb, 3, 3)),  # 0 rot_w
        np.empty((nb, 3)),  # 1 pos_w
        np.empty((nb, 4, 3)),  # 2 placements in the parent (rows 0-2 R, row 3 p)
        np.empty((nb, 6)),  # 3 twist
        np.empty((nb, 6)),  # 4 bias_acc
        np.empty((nb, 6)),  # 5 bias
        np.empty((nb, 6)),  # 6 relative twist / wrenches
        np.empty((nb, 6, 6)),  # 7 articulated inertia
        np.empty((nb, 6)),  # 8 articulated bias
        np.empty((nb, 6)),  # 9 U
        np.empty((2, nb)),  # 10 1/D, u
        np.empty((nb, 6)),  # 11 accelerations
        np.empty((3, 6, 6)),  # 12 6x6 scratch
        np.empty((8, 6)),  # 13 6-vector scratch
        np.empty((2, 3, 3)),  # 14 3x3 scratch
        np.empty((3, nv)),  # 15 generalised scratch: tau + servo, g(q), zero velocity
        np.empty((10, nv)),  # 16 integrator stages
        np.empty((3, nq)),  # 17 stage / next configurations
    )


@njit(**_OPTS)
def _kinematics_ws(M, q, v, W):
    kinematics(M[0], M[1], M[2], q, v, W[0], W[1], W[2], W[3], W[4], W[14], W[13])


@njit(**_OPTS)
def _restoring_ws(M, W, out):
    """``g(q)`` after :func:`_kinematics_ws` (left-hand side: minus the force on the system)."""
    wrench = W[6]
    _restoring_wrenches(M[4], W[0], wrench)
    _backward_generalized(M[0], M[2], W[2], wrench, out, W[13][0])
    for i in range(out.shape[0]):
        out[i] = -out[i]


@njit(**_OPTS)
def restoring_forces(M, q):
    """``g(q)``: hydrostatic generalised force on the left-hand side (weight minus buoyancy)."""
    nv = M[10][1]
    W = workspace(M[0].shape[0], q.shape[0], nv)
    zero = W[15][2]
    zero[:] = 0.0
    _kinematics_ws(M, q, zero, W)
    out = np.empty(nv)
    _restoring_ws(M, W, out)
    return out


@njit(**_OPTS)
def thrust_matrix(M, q):
    """``B(q)`` (nv x m): generalised forces of unit thrusts (the paper's eq. (20))."""
    ints, axis, thrust = M[0], M[2], M[9]
    nv = M[10][1]
    W = workspace(ints.shape[0], q.shape[0], nv)
    zero = W[15][2]
    zero[:] = 0.0
    _kinematics_ws(M, q, zero, W)
    m = thrust.shape[0]
    out = np.empty((nv, m))
    wrench = W[6]
    column = W[15][0]
    for k in range(m):
        wrench[:, :] = 0.0
        b = int(thrust[k, 0])
        for i in range(6):
            wrench[b, i] = thrust[k, 1 + i]
        _backward_generalized(ints, axis, W[2], wrench, column, W[13][0])
        out[:, k] = column
    return out


# ---------------------------------------------------------------------- forward dynamics
@njit(**_OPTS)
def _acceleration_ws(M, q, v, tau, current, servo, W, out):
    """Forward dynamics into ``out`` using the workspace ``W``."""
    _kinematics_ws(M, q, v, W)
    body_bias(M, W[0], W[3], current, W[5], W[6], W[13])
    tau_all = W[15][0]
    for i in range(tau.shape[0]):
        tau_all[i] = tau[i]
    n_joint = servo.shape[1]
    if n_joint > 0 and servo[3, 0] != 0.0:
        # joint servo, paper eq. (24): -k_p (q - q*) - k_d qd + g_q(q)
        g = W[15][1]
        if servo[4, 0] != 0.0:
            _restoring_ws(M, W, g)
        else:
            g[:] = 0.0
        for k in range(n_joint):
            tau_all[6 + k] += (
                -servo[0, k] * (q[7 + k] - servo[2, k]) - servo[1, k] * v[6 + k] + g[6 + k]
            )
    _articulated(M, tau_all, W[2], W[4], W[5], out, W[7], W[8], W[9], W[10], W[11], W[12], W[13])


@njit(**_OPTS)
def acceleration(M, q, v, tau, current, servo, out):
    """Forward dynamics ``dv`` for ``M(q) dv + bias(q, v) = tau (+ servo)``; writes ``out`` (nv,).

    ``servo`` (5, n): rows ``k_p``, ``k_d``, ``q*``, then ``[enabled, compensate g_q]`` in column 0
    (shape (5, 0): no servo).
    """
    W = workspace(M[0].shape[0], q.shape[0], v.shape[0])
    _acceleration_ws(M, q, v, tau, current, servo, W, out)


# ------------------------------------------------------------------ SE(3) x R^n group operations
@njit(**_OPTS)
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
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r01 = 2.0 * (x * y - z * w)
    r02 = 2.0 * (x * z + y * w)
    r10 = 2.0 * (x * y + z * w)
    r11 = 1.0 - 2.0 * (x * x + z * z)
    r12 = 2.0 * (y * z - x * w)
    r20 = 2.0 * (x * z - y * w)
    r21 = 2.0 * (y * z + x * w)
    r22 = 1.0 - 2.0 * (x * x + y * y)
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


@njit(**_OPTS)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(**_OPTS)
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
@njit(**_OPTS)
def _rk4_ws(M, q, v, tau, current, servo, dt, W, q_out, v_out):
    """One Runge-Kutta-Munthe-Kaas step of order 4 (as :func:`aiauv_pin.integrators.rk4_step`)."""
    nv = v.shape[0]
    half = 0.5 * dt
    st = W[16]
    a1, a2, a3, a4, k2, k3, k4, xi, vs = (
        st[0],
        st[1],
        st[2],
        st[3],
        st[4],
        st[5],
        st[6],
        st[7],
        st[8],
    )
    qs = W[17][0]
    _acceleration_ws(M, q, v, tau, current, servo, W, a1)
    for i in range(nv):
        xi[i] = half * v[i]  # k1 = v: the Jacobian at xi = 0 is the identity
        vs[i] = v[i] + half * a1[i]
    integrate(q, xi, qs)
    _acceleration_ws(M, qs, vs, tau, current, servo, W, a2)
    tangent_rate(xi, vs, k2)
    for i in range(nv):
        xi[i] = half * k2[i]
        vs[i] = v[i] + half * a2[i]
    integrate(q, xi, qs)
    _acceleration_ws(M, qs, vs, tau, current, servo, W, a3)
    tangent_rate(xi, vs, k3)
    for i in range(nv):
        xi[i] = dt * k3[i]
        vs[i] = v[i] + dt * a3[i]
    integrate(q, xi, qs)
    _acceleration_ws(M, qs, vs, tau, current, servo, W, a4)
    tangent_rate(xi, vs, k4)
    sixth = dt / 6.0
    for i in range(nv):
        xi[i] = sixth * (v[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        v_out[i] = v[i] + sixth * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
    integrate(q, xi, q_out)


@njit(**_OPTS)
def _euler_ws(M, q, v, tau, current, servo, dt, W, q_out, v_out):
    """Semi-implicit Euler: ``v += dt f(q, v)``, then ``q = q * exp(dt v)``."""
    a = W[16][0]
    xi = W[16][1]
    _acceleration_ws(M, q, v, tau, current, servo, W, a)
    for i in range(v.shape[0]):
        v_out[i] = v[i] + dt * a[i]
        xi[i] = dt * v_out[i]
    integrate(q, xi, q_out)


@njit(**_OPTS)
def step(M, q, v, tau, current, servo, dt, method, q_out, v_out):
    """One step (method 0 = RK4, 1 = semi-implicit Euler) into ``q_out, v_out``."""
    W = workspace(M[0].shape[0], q.shape[0], v.shape[0])
    if method == 0:
        _rk4_ws(M, q, v, tau, current, servo, dt, W, q_out, v_out)
    else:
        _euler_ws(M, q, v, tau, current, servo, dt, W, q_out, v_out)


@njit(**_OPTS)
def run_steps(M, q, v, tau, current, servo, dt, n_steps, method):
    """Advance ``(q, v)`` in place by ``n_steps`` steps (method 0 = RK4, 1 = Euler).

    Returns:
        The number of steps completed; fewer than ``n_steps`` if the state became non-finite (then
        ``q, v`` hold the last finite state).
    """
    W = workspace(M[0].shape[0], q.shape[0], v.shape[0])
    q_new = W[17][1]
    v_new = W[16][9]
    for k in range(n_steps):
        if method == 0:
            _rk4_ws(M, q, v, tau, current, servo, dt, W, q_new, v_new)
        else:
            _euler_ws(M, q, v, tau, current, servo, dt, W, q_new, v_new)
        for i in range(q.shape[0]):
            if not math.isfinite(q_new[i]):
                return k
        for i in range(v.shape[0]):
            if not math.isfinite(v_new[i]):
                return k
        q[:] = q_new
        v[:] = v_new
    return n_steps


@njit(**_OPTS)
def time_accelerations(M, q, v, tau, current, servo, repeats):
    """Evaluate the dynamics ``repeats`` times in compiled code (benchmarking); returns the last."""
    W = workspace(M[0].shape[0], q.shape[0], v.shape[0])
    out = np.empty(v.shape[0])
    for _ in range(repeats):
        _acceleration_ws(M, q, v, tau, current, servo, W, out)
    return out


@njit(**_OPTS)
def frame_kinematics(M, q, v, body, rotation, translation):
    """World pose and body-frame twist of a frame fixed to ``body`` at ``(rotation, translation)``.

    Returns:
        ``(R (3x3), p (3,), twist (6,))`` with the twist ``(v, w)`` in the frame's axes.
    """
    W = workspace(M[0].shape[0], q.shape[0], v.shape[0])
    _kinematics_ws(M, q, v, W)
    rot_w, pos_w = W[0], W[1]
    rot = rot_w[body] @ rotation
    pos = pos_w[body] + rot_w[body] @ translation
    x = W[12][0]
    _motion_transform(rotation, translation, x)
    frame_twist = np.empty(6)
    _matvec6(x, W[3][body], frame_twist)
    return rot, pos, frame_twist
