"""Compiled rigid-body kernels: kinematics, articulated-body dynamics with general inertias, RK4 on SE(3).

These kernels are the compiled counterpart of Pinocchio's algorithms for the models the toolkit
simulates (a free-flyer root with 1-DOF revolute or prismatic joints), tested against Pinocchio
(tests/kernels/test_fast.py). Every fluid term comes from :mod:`aiauv_hydro.laws.fluid_terms`, the
same functions the Pinocchio path calls; nothing here re-implements a fluid law.

The model is a :class:`Model` record (:class:`RigidBodies`, :class:`aiauv_hydro.laws.fluid_terms.FluidModel`,
:class:`Thrusters`), built by :meth:`aiauv_pin.Vehicle.packed_model`. Spatial vectors are
``(linear, angular)`` as in Pinocchio. The articulated-body algorithm is Featherstone's (2008,
Table 7.1) with the rigid inertia replaced by the full 6x6 ``I = I_RB + M_A`` of each body, so the
added-mass inertia enters exactly (never lagged) and the added-mass Coriolis terms enter through
the body bias (Kirchhoff: ``M nu_dot + nu x* (M nu)``, Fossen 2021, eq. (6.43)); with a current the
added mass acts on the relative twist (Fossen 2021, eq. (10.5)).

The environment (:class:`Environment`) holds two compiled functions, called at every integrator
stage with the stage's own time:

* ``current(t, x, y, z, parameters) -> (V_x, V_y, V_z)``: the water velocity [m/s] at a world
  point [m] (:mod:`aiauv_hydro.currents` has the built-in ones), sampled at each body's probe point
  (:attr:`aiauv_hydro.laws.fluid_terms.FluidModel.current_probe`), with the water's acceleration
  ``DV/Dt`` [m/s^2] at the same point (:func:`aiauv_hydro.currents.current_acceleration`): the
  forces use the relative velocity (Fossen 2021, eq. (10.5)) and the water's acceleration adds
  the Froude-Krylov force and the added mass's reaction
  (:mod:`aiauv_hydro.laws.unsteady_flow`), unless the environment holds the quasi-steady model
  (``current_unsteady`` false: the acceleration neglected);
* ``disturbance(t, q, v, parameters, tau)``: adds a generalised force [N, N m] to ``tau`` (nv,).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_control.laws.paper_laws import joint_pd_implicit_terms, joint_pd_torque
from aiauv_hydro.currents import CONSTANT, current_acceleration, current_velocity
from aiauv_hydro.laws.actuators import actuator_response
from aiauv_hydro.laws.fluid_terms import (
    add_body_fluid_bias,
    coriolis_of_momentum,
    hydrostatic_wrench,
    stacked_row_dot,
)
from aiauv_hydro.laws.lift import add_fin_wrenches
from aiauv_hydro.laws.unsteady_flow import add_flow_acceleration_bias
from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE, compiled
from aiauv_hydro.numerics.spatial import cross3, motion_cross, motion_to_child
from aiauv_pin.kernels.disturbances import apply_disturbance
from aiauv_pin.kernels.records import FREE_FLYER, LOCKED_ROOT, REVOLUTE, Workspace
from aiauv_pin.kernels.rotations import quaternion_rotation

#: Integration methods understood by :func:`step` and :func:`run_steps`.
RK4, EULER, MIDPOINT = 0, 1, 2


# ---------------------------------------------------------------------- small linear algebra
@compiled(fastmath=True)
def _dot6(m, b, i, x, c):
    """``m[b, i] . x[c]`` for 6-vectors, indexing the stacked arrays directly (no views)."""
    return (
        m[b, i, 0] * x[c, 0]
        + m[b, i, 1] * x[c, 1]
        + m[b, i, 2] * x[c, 2]
        + m[b, i, 3] * x[c, 3]
        + m[b, i, 4] * x[c, 4]
        + m[b, i, 5] * x[c, 5]
    )


@compiled(fastmath=True)
def _dot_rows(a, i, x, j):
    """``a[i] . x[j]`` for rows of 6 (no views)."""
    return (
        a[i, 0] * x[j, 0]
        + a[i, 1] * x[j, 1]
        + a[i, 2] * x[j, 2]
        + a[i, 3] * x[j, 3]
        + a[i, 4] * x[j, 4]
        + a[i, 5] * x[j, 5]
    )


@compiled(fastmath=True)
def _matvec6(m, x, out):
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += m[i, j] * x[j]
        out[i] = s


@compiled(fastmath=True, borrows_only=True)
def _xT_add(xl, f, dst):
    """``dst += X^T f``: a child-frame force vector in the parent frame, ``(R f, p x R f + R n)``."""
    p0, p1, p2 = xl[3, 0], xl[3, 1], xl[3, 2]
    f0 = xl[0, 0] * f[0] + xl[0, 1] * f[1] + xl[0, 2] * f[2]
    f1 = xl[1, 0] * f[0] + xl[1, 1] * f[1] + xl[1, 2] * f[2]
    f2 = xl[2, 0] * f[0] + xl[2, 1] * f[1] + xl[2, 2] * f[2]
    c0, c1, c2 = cross3(p0, p1, p2, f0, f1, f2)
    dst[0] += f0
    dst[1] += f1
    dst[2] += f2
    dst[3] += xl[0, 0] * f[3] + xl[0, 1] * f[4] + xl[0, 2] * f[5] + c0
    dst[4] += xl[1, 0] * f[3] + xl[1, 1] * f[4] + xl[1, 2] * f[5] + c1
    dst[5] += xl[2, 0] * f[3] + xl[2, 1] * f[4] + xl[2, 2] * f[5] + c2


@compiled(fastmath=True, borrows_only=True)
def _solve_spd6(a, b, out):
    """Solve ``a x = b`` for a symmetric positive-definite 6x6 ``a`` (Cholesky ``a = L L^T``),
    reading ``a``'s upper triangle only; written out in scalars (no work arrays), so that the
    factor stays in registers."""
    a00, a01, a02, a03, a04, a05 = a[0, 0], a[0, 1], a[0, 2], a[0, 3], a[0, 4], a[0, 5]
    a11, a12, a13, a14, a15 = a[1, 1], a[1, 2], a[1, 3], a[1, 4], a[1, 5]
    a22, a23, a24, a25 = a[2, 2], a[2, 3], a[2, 4], a[2, 5]
    a33, a34, a35 = a[3, 3], a[3, 4], a[3, 5]
    a44, a45 = a[4, 4], a[4, 5]
    a55 = a[5, 5]
    s = a00
    l00 = math.sqrt(s) if s > 0.0 else math.nan
    i0 = 1.0 / l00
    l10 = a01 * i0
    l20 = a02 * i0
    l30 = a03 * i0
    l40 = a04 * i0
    l50 = a05 * i0
    s = a11 - l10 * l10
    l11 = math.sqrt(s) if s > 0.0 else math.nan
    i1 = 1.0 / l11
    l21 = (a12 - l20 * l10) * i1
    l31 = (a13 - l30 * l10) * i1
    l41 = (a14 - l40 * l10) * i1
    l51 = (a15 - l50 * l10) * i1
    s = a22 - l20 * l20 - l21 * l21
    l22 = math.sqrt(s) if s > 0.0 else math.nan
    i2 = 1.0 / l22
    l32 = (a23 - l30 * l20 - l31 * l21) * i2
    l42 = (a24 - l40 * l20 - l41 * l21) * i2
    l52 = (a25 - l50 * l20 - l51 * l21) * i2
    s = a33 - l30 * l30 - l31 * l31 - l32 * l32
    l33 = math.sqrt(s) if s > 0.0 else math.nan
    i3 = 1.0 / l33
    l43 = (a34 - l40 * l30 - l41 * l31 - l42 * l32) * i3
    l53 = (a35 - l50 * l30 - l51 * l31 - l52 * l32) * i3
    s = a44 - l40 * l40 - l41 * l41 - l42 * l42 - l43 * l43
    l44 = math.sqrt(s) if s > 0.0 else math.nan
    i4 = 1.0 / l44
    l54 = (a45 - l50 * l40 - l51 * l41 - l52 * l42 - l53 * l43) * i4
    s = a55 - l50 * l50 - l51 * l51 - l52 * l52 - l53 * l53 - l54 * l54
    l55 = math.sqrt(s) if s > 0.0 else math.nan
    i5 = 1.0 / l55
    y0 = b[0] * i0
    y1 = (b[1] - l10 * y0) * i1
    y2 = (b[2] - l20 * y0 - l21 * y1) * i2
    y3 = (b[3] - l30 * y0 - l31 * y1 - l32 * y2) * i3
    y4 = (b[4] - l40 * y0 - l41 * y1 - l42 * y2 - l43 * y3) * i4
    y5 = (b[5] - l50 * y0 - l51 * y1 - l52 * y2 - l53 * y3 - l54 * y4) * i5
    x5 = y5 * i5
    x4 = (y4 - l54 * x5) * i4
    x3 = (y3 - l43 * x4 - l53 * x5) * i3
    x2 = (y2 - l32 * x3 - l42 * x4 - l52 * x5) * i2
    x1 = (y1 - l21 * x2 - l31 * x3 - l41 * x4 - l51 * x5) * i1
    x0 = (y0 - l10 * x1 - l20 * x2 - l30 * x3 - l40 * x4 - l50 * x5) * i0
    out[0] = x0
    out[1] = x1
    out[2] = x2
    out[3] = x3
    out[4] = x4
    out[5] = x5


# ---------------------------------------------------------------------- kinematics
@compiled(fastmath=True, borrows_only=True, inline=True)
def kinematics(bodies, q, v, W):
    """Body poses in the world, placements in the parent, twists and ``v x S qd`` into ``W``
    (:func:`kinematics_into` on the arrays of ``bodies`` and ``W`` it uses: inlined, so that a
    compiled caller passes those few arrays rather than every array of both records)."""
    kinematics_into(
        bodies.parent,
        bodies.kind,
        bodies.q_index,
        bodies.v_index,
        bodies.placement,
        bodies.axis,
        q,
        v,
        W.rotation,
        W.position,
        W.placement,
        W.twist,
        W.bias_acceleration,
    )


@compiled(fastmath=True, borrows_only=True)
def kinematics_into(
    parents, kinds, q_index, v_index, place, axis, q, v, rot_w, pos_w, xform, twist, bias_acc
):
    """:func:`kinematics` on arrays: body poses ``rot_w``, ``pos_w``, placements in the parent
    ``xform``, twists ``twist`` and ``v x S qd`` ``bias_acc`` of the tree ``parents, kinds,
    q_index, v_index, place, axis`` (the fields of :class:`aiauv_pin.kernels.records.RigidBodies`).

    Written body by body with scalar locals (no helper writes into array views), so the compiler
    keeps a body's rotation, position and twist in registers; each body's results are stored once.
    The joints' sines and cosines are taken first, in a loop of their own (parked in the rows
    ``xform[b, 3]`` that the body's translation overwrites later): a call to the math library
    inside the main loop would spill every live float of the body at hand.
    """
    for b in range(parents.shape[0]):
        if kinds[b] == REVOLUTE:
            qj = q[q_index[b]]
            xform[b, 3, 0] = math.sin(qj)
            xform[b, 3, 1] = 1.0 - math.cos(qj)
    for b in range(parents.shape[0]):
        parent, kind, iq, iv = parents[b], kinds[b], q_index[b], v_index[b]
        if kind == FREE_FLYER or kind == LOCKED_ROOT:
            rows = quaternion_rotation(q[iq + 3], q[iq + 4], q[iq + 5], q[iq + 6])
            for i in range(3):
                pos_w[b, i] = q[iq + i]
                for j in range(3):
                    rot_w[b, i, j] = rows[i][j]
                    xform[b, i, j] = 1.0 if i == j else 0.0
                xform[b, 3, i] = 0.0
            for i in range(6):
                # a locked root (fixed base) does not move, whatever v's base entries hold
                twist[b, i] = v[iv + i] if kind == FREE_FLYER else 0.0
                bias_acc[b, i] = 0.0
            continue
        qj, qd = q[iq], v[iv]
        s0, s1, s2, s3, s4, s5 = (
            axis[b, 0],
            axis[b, 1],
            axis[b, 2],
            axis[b, 3],
            axis[b, 4],
            axis[b, 5],
        )
        p00, p01, p02 = place[b, 0, 0], place[b, 0, 1], place[b, 0, 2]
        p10, p11, p12 = place[b, 1, 0], place[b, 1, 1], place[b, 1, 2]
        p20, p21, p22 = place[b, 2, 0], place[b, 2, 1], place[b, 2, 2]
        l0, l1, l2 = place[b, 3, 0], place[b, 3, 1], place[b, 3, 2]
        if kind == REVOLUTE:
            # R_l = R_placement exp(q [a]) (Rodrigues about the unit axis a = (s3, s4, s5))
            sn = xform[b, 3, 0]  # sin q
            c1 = xform[b, 3, 1]  # 1 - cos q
            j00 = 1.0 - c1 * (s4 * s4 + s5 * s5)
            j11 = 1.0 - c1 * (s3 * s3 + s5 * s5)
            j22 = 1.0 - c1 * (s3 * s3 + s4 * s4)
            j01 = -sn * s5 + c1 * s3 * s4
            j10 = sn * s5 + c1 * s3 * s4
            j02 = sn * s4 + c1 * s3 * s5
            j20 = -sn * s4 + c1 * s3 * s5
            j12 = -sn * s3 + c1 * s4 * s5
            j21 = sn * s3 + c1 * s4 * s5
            if (
                p00 == 1.0
                and p11 == 1.0
                and p22 == 1.0
                and p01 == 0.0
                and p02 == 0.0
                and p10 == 0.0
                and p12 == 0.0
                and p20 == 0.0
                and p21 == 0.0
            ):
                # a joint frame aligned with its parent's (the usual case): R_l = exp(q [a])
                r00, r01, r02, r10, r11, r12, r20, r21, r22 = (
                    j00,
                    j01,
                    j02,
                    j10,
                    j11,
                    j12,
                    j20,
                    j21,
                    j22,
                )
            else:
                r00 = p00 * j00 + p01 * j10 + p02 * j20
                r01 = p00 * j01 + p01 * j11 + p02 * j21
                r02 = p00 * j02 + p01 * j12 + p02 * j22
                r10 = p10 * j00 + p11 * j10 + p12 * j20
                r11 = p10 * j01 + p11 * j11 + p12 * j21
                r12 = p10 * j02 + p11 * j12 + p12 * j22
                r20 = p20 * j00 + p21 * j10 + p22 * j20
                r21 = p20 * j01 + p21 * j11 + p22 * j21
                r22 = p20 * j02 + p21 * j12 + p22 * j22
        else:
            r00, r01, r02, r10, r11, r12, r20, r21, r22 = (
                p00,
                p01,
                p02,
                p10,
                p11,
                p12,
                p20,
                p21,
                p22,
            )
            l0 += qj * (p00 * s0 + p01 * s1 + p02 * s2)
            l1 += qj * (p10 * s0 + p11 * s1 + p12 * s2)
            l2 += qj * (p20 * s0 + p21 * s1 + p22 * s2)
        xform[b, 0, 0], xform[b, 0, 1], xform[b, 0, 2] = r00, r01, r02
        xform[b, 1, 0], xform[b, 1, 1], xform[b, 1, 2] = r10, r11, r12
        xform[b, 2, 0], xform[b, 2, 1], xform[b, 2, 2] = r20, r21, r22
        xform[b, 3, 0], xform[b, 3, 1], xform[b, 3, 2] = l0, l1, l2
        if parent < 0:
            rot_w[b, 0, 0], rot_w[b, 0, 1], rot_w[b, 0, 2] = r00, r01, r02
            rot_w[b, 1, 0], rot_w[b, 1, 1], rot_w[b, 1, 2] = r10, r11, r12
            rot_w[b, 2, 0], rot_w[b, 2, 1], rot_w[b, 2, 2] = r20, r21, r22
            pos_w[b, 0], pos_w[b, 1], pos_w[b, 2] = l0, l1, l2
            v0, v1, v2, w0, w1, w2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        else:
            a00, a01, a02 = rot_w[parent, 0, 0], rot_w[parent, 0, 1], rot_w[parent, 0, 2]
            a10, a11, a12 = rot_w[parent, 1, 0], rot_w[parent, 1, 1], rot_w[parent, 1, 2]
            a20, a21, a22 = rot_w[parent, 2, 0], rot_w[parent, 2, 1], rot_w[parent, 2, 2]
            pos_w[b, 0] = pos_w[parent, 0] + a00 * l0 + a01 * l1 + a02 * l2
            pos_w[b, 1] = pos_w[parent, 1] + a10 * l0 + a11 * l1 + a12 * l2
            pos_w[b, 2] = pos_w[parent, 2] + a20 * l0 + a21 * l1 + a22 * l2
            rot_w[b, 0, 0] = a00 * r00 + a01 * r10 + a02 * r20
            rot_w[b, 0, 1] = a00 * r01 + a01 * r11 + a02 * r21
            rot_w[b, 0, 2] = a00 * r02 + a01 * r12 + a02 * r22
            rot_w[b, 1, 0] = a10 * r00 + a11 * r10 + a12 * r20
            rot_w[b, 1, 1] = a10 * r01 + a11 * r11 + a12 * r21
            rot_w[b, 1, 2] = a10 * r02 + a11 * r12 + a12 * r22
            rot_w[b, 2, 0] = a20 * r00 + a21 * r10 + a22 * r20
            rot_w[b, 2, 1] = a20 * r01 + a21 * r11 + a22 * r21
            rot_w[b, 2, 2] = a20 * r02 + a21 * r12 + a22 * r22
            # X nu_parent = (R^T (v - l x w), R^T w)  (Featherstone 2008, eq. (2.24))
            v0, v1, v2, w0, w1, w2 = motion_to_child(
                xform[b],
                twist[parent, 0],
                twist[parent, 1],
                twist[parent, 2],
                twist[parent, 3],
                twist[parent, 4],
                twist[parent, 5],
            )
        # joint motion S qd, the body twist, and the bias acceleration nu x (S qd)
        m0, m1, m2, m3, m4, m5 = s0 * qd, s1 * qd, s2 * qd, s3 * qd, s4 * qd, s5 * qd
        v0 += m0
        v1 += m1
        v2 += m2
        w0 += m3
        w1 += m4
        w2 += m5
        twist[b, 0], twist[b, 1], twist[b, 2], twist[b, 3], twist[b, 4], twist[b, 5] = (
            v0,
            v1,
            v2,
            w0,
            w1,
            w2,
        )
        (
            bias_acc[b, 0],
            bias_acc[b, 1],
            bias_acc[b, 2],
            bias_acc[b, 3],
            bias_acc[b, 4],
            bias_acc[b, 5],
        ) = motion_cross(v0, v1, v2, w0, w1, w2, m0, m1, m2, m3, m4, m5)


@compiled(fastmath=True)
def point_in_world(rotation, position, b, x, y, z):
    """World coordinates [m] of the point ``(x, y, z)`` [m] of body ``b``'s frame, ``p_b + R_b r``,
    from the kinematics in ``rotation`` (nb, 3, 3) and ``position`` (nb, 3)."""
    return (
        position[b, 0] + rotation[b, 0, 0] * x + rotation[b, 0, 1] * y + rotation[b, 0, 2] * z,
        position[b, 1] + rotation[b, 1, 0] * x + rotation[b, 1, 1] * y + rotation[b, 1, 2] * z,
        position[b, 2] + rotation[b, 2, 0] * x + rotation[b, 2, 1] * y + rotation[b, 2, 2] * z,
    )


@compiled(fastmath=True, borrows_only=True, inline=True)
def sample_current(model, env, t, W):
    """Water velocity at every body's probe point at time ``t`` into ``W.current`` (after kinematics).

    A built-in constant current is the same everywhere: copied to every probe, without the
    probes' positions."""
    if env.current_function is None and env.current_kind == CONSTANT:
        water, velocity = W.current, env.current_parameters
        for b in range(water.shape[0]):
            water[b, 0], water[b, 1], water[b, 2] = velocity[0], velocity[1], velocity[2]
        return
    current_at_probes(
        env.current_function,
        env.current_kind,
        env.current_parameters,
        t,
        model.fluid.current_probe,
        W.rotation,
        W.position,
        W.current,
    )


@compiled(fastmath=True)
def acceleration_at_probes(
    acceleration, function, kind, parameters, t, probe, rotation, position, water
):
    """``water[b]``: the water's acceleration ``DV/Dt`` at body ``b``'s probe point at time ``t``
    [m/s^2], world axes (:func:`aiauv_hydro.currents.current_acceleration`).

    Reference-counted, as :func:`current_at_probes`: it may call a user's functions.
    """
    for b in range(water.shape[0]):
        x, y, z = point_in_world(rotation, position, b, probe[b, 0], probe[b, 1], probe[b, 2])
        a = current_acceleration(acceleration, function, kind, t, x, y, z, parameters)
        water[b, 0] = a[0]
        water[b, 1] = a[1]
        water[b, 2] = a[2]


@compiled(fastmath=True)
def current_at_probes(function, kind, parameters, t, probe, rotation, position, water):
    """``water[b]``: the current at body ``b``'s probe point ``p_b + R_b c_b`` at time ``t`` [m/s].

    Reference-counted (unlike the kernels around it) because it calls a user's current function,
    which may return an array of its own.
    """
    for b in range(water.shape[0]):
        x, y, z = point_in_world(rotation, position, b, probe[b, 0], probe[b, 1], probe[b, 2])
        c = current_velocity(function, kind, t, x, y, z, parameters)
        water[b, 0] = c[0]
        water[b, 1] = c[1]
        water[b, 2] = c[2]


@compiled(fastmath=True)
def add_disturbance(function, kind, t, q, v, parameters, tau):
    """:func:`aiauv_pin.kernels.disturbances.apply_disturbance` (reference-counted: it may call a user's
    function)."""
    apply_disturbance(function, kind, t, q, v, parameters, tau)


@compiled(fastmath=True, borrows_only=True)
def body_bias(model, W):
    """Velocity- and state-dependent part of each body's equation ``f = I a + p`` (left-hand side).

    Not inlined into :func:`acceleration_into`: it does not depend on the current's function, so
    it is compiled once and loaded alike in every process (inlined, a run with a user's current
    got other last bits in a second process: tests/simulation/test_user_cache.py).

    ``p = nu x* (I_RB nu)`` (rigid Coriolis, Featherstone 2008, eq. (2.67)) plus every fluid term of
    :func:`aiauv_hydro.laws.fluid_terms.add_body_fluid_bias`, and the fins' lift and drag at the
    angles ``W.fin_angle`` (:func:`aiauv_hydro.laws.lift.add_fin_wrenches`); after
    :func:`kinematics` and :func:`sample_current`. The water's acceleration is added by
    :func:`flow_acceleration_bias`.
    """
    rigid, twist, bias = model.bodies.rigid_inertia, W.twist, W.bias
    for b in range(bias.shape[0]):
        v0, v1, v2 = twist[b, 0], twist[b, 1], twist[b, 2]
        w0, w1, w2 = twist[b, 3], twist[b, 4], twist[b, 5]
        w = coriolis_of_momentum(
            v0,
            v1,
            v2,
            w0,
            w1,
            w2,
            stacked_row_dot(rigid, b, 0, v0, v1, v2, w0, w1, w2),
            stacked_row_dot(rigid, b, 1, v0, v1, v2, w0, w1, w2),
            stacked_row_dot(rigid, b, 2, v0, v1, v2, w0, w1, w2),
            stacked_row_dot(rigid, b, 3, v0, v1, v2, w0, w1, w2),
            stacked_row_dot(rigid, b, 4, v0, v1, v2, w0, w1, w2),
            stacked_row_dot(rigid, b, 5, v0, v1, v2, w0, w1, w2),
        )
        for i in range(6):
            bias[b, i] = w[i]
    add_body_fluid_bias(
        model.fluid, W.rotation, W.twist, W.current, W.bias, W.relative, W.fluid_scratch
    )
    add_fin_wrenches(model.fins, W.fin_angle, W.rotation, W.twist, W.current, W.bias)


@compiled(fastmath=True, borrows_only=True, inline=True)
def flow_acceleration_bias(model, env, t, W):
    """The water's acceleration ``DV/Dt`` at every body's probe point at time ``t`` into
    ``W.flow_acceleration`` and its wrench in each body's bias
    (:func:`aiauv_hydro.laws.unsteady_flow.add_flow_acceleration_bias`), after :func:`body_bias`,
    when ``env.current_unsteady``; nothing at all otherwise (a constant current, the quasi-steady
    model: ``W.flow_acceleration`` is then left as it was), so those runs execute the code they
    did before the term existed."""
    if env.current_unsteady:
        acceleration_at_probes(
            env.current_acceleration_function,
            env.current_function,
            env.current_kind,
            env.current_parameters,
            t,
            model.fluid.current_probe,
            W.rotation,
            W.position,
            W.flow_acceleration,
        )
        add_flow_acceleration_bias(model.fluid, W.rotation, W.flow_acceleration, W.bias)


# ---------------------------------------------------------------------- articulated-body algorithm
@compiled(fastmath=True)
def _rotate_symmetric(r00, r01, r02, r10, r11, r12, r20, r21, r22, a00, a01, a02, a11, a12, a22):
    """Upper triangle ``(00, 01, 02, 11, 12, 22)`` of ``R A R^T`` for a symmetric 3x3 ``A``."""
    h00 = a00 * r00 + a01 * r01 + a02 * r02  # h = A R^T
    h01 = a00 * r10 + a01 * r11 + a02 * r12
    h02 = a00 * r20 + a01 * r21 + a02 * r22
    h10 = a01 * r00 + a11 * r01 + a12 * r02
    h11 = a01 * r10 + a11 * r11 + a12 * r12
    h12 = a01 * r20 + a11 * r21 + a12 * r22
    h20 = a02 * r00 + a12 * r01 + a22 * r02
    h21 = a02 * r10 + a12 * r11 + a22 * r12
    h22 = a02 * r20 + a12 * r21 + a22 * r22
    return (
        r00 * h00 + r01 * h10 + r02 * h20,
        r00 * h01 + r01 * h11 + r02 * h21,
        r00 * h02 + r01 * h12 + r02 * h22,
        r10 * h01 + r11 * h11 + r12 * h21,
        r10 * h02 + r11 * h12 + r12 * h22,
        r20 * h02 + r21 * h12 + r22 * h22,
    )


@compiled(fastmath=True)
def _rotate_full(
    r00, r01, r02, r10, r11, r12, r20, r21, r22, b00, b01, b02, b10, b11, b12, b20, b21, b22
):
    """``R B R^T`` for a 3x3 ``B``, row by row (9 floats)."""
    h00 = b00 * r00 + b01 * r01 + b02 * r02  # h = B R^T
    h01 = b00 * r10 + b01 * r11 + b02 * r12
    h02 = b00 * r20 + b01 * r21 + b02 * r22
    h10 = b10 * r00 + b11 * r01 + b12 * r02
    h11 = b10 * r10 + b11 * r11 + b12 * r12
    h12 = b10 * r20 + b11 * r21 + b12 * r22
    h20 = b20 * r00 + b21 * r01 + b22 * r02
    h21 = b20 * r10 + b21 * r11 + b22 * r12
    h22 = b20 * r20 + b21 * r21 + b22 * r22
    return (
        r00 * h00 + r01 * h10 + r02 * h20,
        r00 * h01 + r01 * h11 + r02 * h21,
        r00 * h02 + r01 * h12 + r02 * h22,
        r10 * h00 + r11 * h10 + r12 * h20,
        r10 * h01 + r11 * h11 + r12 * h21,
        r10 * h02 + r11 * h12 + r12 * h22,
        r20 * h00 + r21 * h10 + r22 * h20,
        r20 * h01 + r21 * h11 + r22 * h21,
        r20 * h02 + r21 * h12 + r22 * h22,
    )


@compiled(fastmath=True, borrows_only=True, inline=True)
def _add_child_inertia(
    xform,
    child,
    art,
    parent,
    a00,
    a01,
    a02,
    a11,
    a12,
    a22,
    b00,
    b01,
    b02,
    b10,
    b11,
    b12,
    b20,
    b21,
    b22,
    c00,
    c01,
    c02,
    c11,
    c12,
    c22,
):
    """``art[parent] += X^T I^a X`` (upper triangle) for the child's symmetric ``I^a = [[A, B],
    [B^T, C]]`` given in scalars (the upper triangles of ``A`` and ``C``, all of ``B``).

    With ``A' = R A R^T``, ``B' = R B R^T``, ``C' = R C R^T`` and ``P = [p]`` (``xform[child]``: rows 0-2
    ``R``, row 3 ``p``): ``X^T I X = [[A', B' - A' P], [sym., C' + P B' + (P B')^T - P A' P]]``, the inertia
    transform of Featherstone 2008, eq. (2.66), written for ``X`` of the kinematics; the two
    symmetric blocks are computed on their upper triangles only (``P A' P`` is symmetric), and
    only the parent's upper triangle is updated (:func:`articulated_into` keeps no other).
    """
    r00, r01, r02 = xform[child, 0, 0], xform[child, 0, 1], xform[child, 0, 2]
    r10, r11, r12 = xform[child, 1, 0], xform[child, 1, 1], xform[child, 1, 2]
    r20, r21, r22 = xform[child, 2, 0], xform[child, 2, 1], xform[child, 2, 2]
    p0, p1, p2 = xform[child, 3, 0], xform[child, 3, 1], xform[child, 3, 2]
    a00, a01, a02, a11, a12, a22 = _rotate_symmetric(
        r00, r01, r02, r10, r11, r12, r20, r21, r22, a00, a01, a02, a11, a12, a22
    )
    c00, c01, c02, c11, c12, c22 = _rotate_symmetric(
        r00, r01, r02, r10, r11, r12, r20, r21, r22, c00, c01, c02, c11, c12, c22
    )
    b00, b01, b02, b10, b11, b12, b20, b21, b22 = _rotate_full(
        r00, r01, r02, r10, r11, r12, r20, r21, r22, b00, b01, b02, b10, b11, b12, b20, b21, b22
    )
    # T = A' P, row i = a'_i x p
    t00 = a01 * p2 - a02 * p1
    t01 = a02 * p0 - a00 * p2
    t02 = a00 * p1 - a01 * p0
    t10 = a11 * p2 - a12 * p1
    t11 = a12 * p0 - a01 * p2
    t12 = a01 * p1 - a11 * p0
    t20 = a12 * p2 - a22 * p1
    t21 = a22 * p0 - a02 * p2
    t22 = a02 * p1 - a12 * p0
    # Q = P B', column j = p x b'_j
    q00 = p1 * b20 - p2 * b10
    q10 = p2 * b00 - p0 * b20
    q20 = p0 * b10 - p1 * b00
    q01 = p1 * b21 - p2 * b11
    q11 = p2 * b01 - p0 * b21
    q21 = p0 * b11 - p1 * b01
    q02 = p1 * b22 - p2 * b12
    q12 = p2 * b02 - p0 * b22
    q22 = p0 * b12 - p1 * b02
    # P T, column j = p x t_j (symmetric: upper triangle)
    s00 = p1 * t20 - p2 * t10
    s01 = p1 * t21 - p2 * t11
    s11 = p2 * t01 - p0 * t21
    s02 = p1 * t22 - p2 * t12
    s12 = p2 * t02 - p0 * t22
    s22 = p0 * t12 - p1 * t02
    art[parent, 0, 0] += a00
    art[parent, 0, 1] += a01
    art[parent, 0, 2] += a02
    art[parent, 1, 1] += a11
    art[parent, 1, 2] += a12
    art[parent, 2, 2] += a22
    art[parent, 0, 3] += b00 - t00
    art[parent, 0, 4] += b01 - t01
    art[parent, 0, 5] += b02 - t02
    art[parent, 1, 3] += b10 - t10
    art[parent, 1, 4] += b11 - t11
    art[parent, 1, 5] += b12 - t12
    art[parent, 2, 3] += b20 - t20
    art[parent, 2, 4] += b21 - t21
    art[parent, 2, 5] += b22 - t22
    art[parent, 3, 3] += c00 + 2.0 * q00 - s00
    art[parent, 3, 4] += c01 + q01 + q10 - s01
    art[parent, 3, 5] += c02 + q02 + q20 - s02
    art[parent, 4, 4] += c11 + 2.0 * q11 - s11
    art[parent, 4, 5] += c12 + q12 + q21 - s12
    art[parent, 5, 5] += c22 + 2.0 * q22 - s22


@compiled(fastmath=True, borrows_only=True, inline=True)
def articulated_into(model, servo, q, v, tau, W, out, implicit_step):
    """ABA passes 2 and 3 (Featherstone 2008, Table 7.1) with general 6x6 body inertias.

    After :func:`kinematics` and :func:`body_bias`. The joint servo of the paper, eq. (24)
    (``tau_q += -k_p (q - q*) - k_d qd + g_q(q)``), is applied inside the inward pass: ``g_q`` is the
    joint's share of the hydrostatic wrenches of its subtree, carried inward alongside the
    articulated bias (what :func:`restoring_into` computes in a separate pass).

    With ``implicit_step`` ``h > 0`` [s] it returns instead the servo-implicit acceleration of one
    semi-implicit Euler step, ``(M + A) dv = tau + servo - bias - h k_p qd``
    (:func:`aiauv_control.laws.paper_laws.joint_pd_implicit_terms`): the armature ``A`` enters each
    servoed joint's
    ``D = S^T I^A S`` (the joint-space diagonal the ABA inverts).

    The articulated inertias are symmetric: only their upper triangles are formed and kept
    (``W.articulated_inertia[b, i, j]`` for ``i <= j``), and a body's own ``I^a`` stays in scalars
    from its ``I^A`` to its parent's.
    """
    bodies = model.bodies
    nb = bodies.parent.shape[0]
    xform, bias_acc = W.placement, W.bias_acceleration
    art, pa, u_vec, d_inv, u_sc, acc = (
        W.articulated_inertia,
        W.articulated_bias,
        W.u_vector,
        W.d_inverse,
        W.u_scalar,
        W.acceleration,
    )
    n_joint = servo.references.shape[0]
    use_servo = servo.enabled and n_joint > 0
    carry_restoring = use_servo and servo.compensate_restoring
    restoring = W.subtree_restoring
    h = model.fluid.hydrostatics
    parents, v_index, axis_index, axis = (
        bodies.parent,
        bodies.v_index,
        bodies.axis_index,
        bodies.axis,
    )
    inertia, bias, rot = bodies.inertia, W.bias, W.rotation
    references, stiffness, damping = servo.references, servo.stiffness, servo.damping
    for b in range(nb):
        for i in range(6):
            pa[b, i] = bias[b, i]
            for j in range(i, 6):
                art[b, i, j] = inertia[b, i, j]
        if carry_restoring:
            w = hydrostatic_wrench(
                h[b, 0], h[b, 1], h[b, 2], h[b, 3], rot[b, 2, 0], rot[b, 2, 1], rot[b, 2, 2]
            )
            for i in range(6):
                restoring[b, i] = -w[i]
    for b in range(nb - 1, 0, -1):
        parent = parents[b]
        iv = v_index[b]
        k = axis_index[b]
        # I^A (upper triangle) in scalars
        a00, a01, a02, a03, a04, a05 = (
            art[b, 0, 0],
            art[b, 0, 1],
            art[b, 0, 2],
            art[b, 0, 3],
            art[b, 0, 4],
            art[b, 0, 5],
        )
        a11, a12, a13, a14, a15 = (
            art[b, 1, 1],
            art[b, 1, 2],
            art[b, 1, 3],
            art[b, 1, 4],
            art[b, 1, 5],
        )
        a22, a23, a24, a25 = art[b, 2, 2], art[b, 2, 3], art[b, 2, 4], art[b, 2, 5]
        a33, a34, a35 = art[b, 3, 3], art[b, 3, 4], art[b, 3, 5]
        a44, a45, a55 = art[b, 4, 4], art[b, 4, 5], art[b, 5, 5]
        if k >= 0:
            # U = I^A e_k: column k, read from the upper triangle
            u0 = art[b, 0, k]
            u1 = art[b, min(1, k), max(1, k)]
            u2 = art[b, min(2, k), max(2, k)]
            u3 = art[b, min(3, k), max(3, k)]
            u4 = art[b, min(4, k), max(4, k)]
            u5 = art[b, k, 5]
            d = art[b, k, k]
            sp = pa[b, k]
            g = restoring[b, k] if carry_restoring else 0.0
        else:
            s0, s1, s2 = axis[b, 0], axis[b, 1], axis[b, 2]
            s3, s4, s5 = axis[b, 3], axis[b, 4], axis[b, 5]
            u0 = a00 * s0 + a01 * s1 + a02 * s2 + a03 * s3 + a04 * s4 + a05 * s5
            u1 = a01 * s0 + a11 * s1 + a12 * s2 + a13 * s3 + a14 * s4 + a15 * s5
            u2 = a02 * s0 + a12 * s1 + a22 * s2 + a23 * s3 + a24 * s4 + a25 * s5
            u3 = a03 * s0 + a13 * s1 + a23 * s2 + a33 * s3 + a34 * s4 + a35 * s5
            u4 = a04 * s0 + a14 * s1 + a24 * s2 + a34 * s3 + a44 * s4 + a45 * s5
            u5 = a05 * s0 + a15 * s1 + a25 * s2 + a35 * s3 + a45 * s4 + a55 * s5
            d = u0 * s0 + u1 * s1 + u2 * s2 + u3 * s3 + u4 * s4 + u5 * s5
            sp = _dot_rows(pa, b, axis, b)
            g = 0.0
            if carry_restoring:
                g = _dot_rows(restoring, b, axis, b)
        tau_b = tau[iv]
        joint = iv - 6
        if use_servo and 0 <= joint < n_joint:
            # joint servo, paper eq. (24): -k_p (q - q*) - k_d qd + g_q(q)
            tau_b += joint_pd_torque(
                q[7 + joint],
                v[6 + joint],
                references[joint],
                g,
                stiffness[joint],
                damping[joint],
            )
            if implicit_step > 0.0:
                armature, correction = joint_pd_implicit_terms(
                    implicit_step, v[6 + joint], stiffness[joint], damping[joint]
                )
                d += armature
                tau_b += correction
        di = 1.0 / d
        us = tau_b - sp
        u_vec[b, 0], u_vec[b, 1], u_vec[b, 2] = u0, u1, u2
        u_vec[b, 3], u_vec[b, 4], u_vec[b, 5] = u3, u4, u5
        d_inv[b] = di
        u_sc[b] = us
        if parent < 0:
            continue
        # I^a = I^A - U U^T / D (upper triangle)
        w0, w1, w2, w3, w4, w5 = u0 * di, u1 * di, u2 * di, u3 * di, u4 * di, u5 * di
        a00 -= w0 * u0
        a01 -= w0 * u1
        a02 -= w0 * u2
        a03 -= w0 * u3
        a04 -= w0 * u4
        a05 -= w0 * u5
        a11 -= w1 * u1
        a12 -= w1 * u2
        a13 -= w1 * u3
        a14 -= w1 * u4
        a15 -= w1 * u5
        a22 -= w2 * u2
        a23 -= w2 * u3
        a24 -= w2 * u4
        a25 -= w2 * u5
        a33 -= w3 * u3
        a34 -= w3 * u4
        a35 -= w3 * u5
        a44 -= w4 * u4
        a45 -= w4 * u5
        a55 -= w5 * u5
        # p^a = p^A + I^a c + U u / D, then the parent's X^T p^a
        c0, c1, c2 = bias_acc[b, 0], bias_acc[b, 1], bias_acc[b, 2]
        c3, c4, c5 = bias_acc[b, 3], bias_acc[b, 4], bias_acc[b, 5]
        f = us * di
        x0 = pa[b, 0] + a00 * c0 + a01 * c1 + a02 * c2 + a03 * c3 + a04 * c4 + a05 * c5 + u0 * f
        x1 = pa[b, 1] + a01 * c0 + a11 * c1 + a12 * c2 + a13 * c3 + a14 * c4 + a15 * c5 + u1 * f
        x2 = pa[b, 2] + a02 * c0 + a12 * c1 + a22 * c2 + a23 * c3 + a24 * c4 + a25 * c5 + u2 * f
        x3 = pa[b, 3] + a03 * c0 + a13 * c1 + a23 * c2 + a33 * c3 + a34 * c4 + a35 * c5 + u3 * f
        x4 = pa[b, 4] + a04 * c0 + a14 * c1 + a24 * c2 + a34 * c3 + a44 * c4 + a45 * c5 + u4 * f
        x5 = pa[b, 5] + a05 * c0 + a15 * c1 + a25 * c2 + a35 * c3 + a45 * c4 + a55 * c5 + u5 * f
        _add_child_force(xform, b, x0, x1, x2, x3, x4, x5, pa, parent)
        _add_child_inertia(
            xform,
            b,
            art,
            parent,
            a00,
            a01,
            a02,
            a11,
            a12,
            a22,
            a03,
            a04,
            a05,
            a13,
            a14,
            a15,
            a23,
            a24,
            a25,
            a33,
            a34,
            a35,
            a44,
            a45,
            a55,
        )
        if carry_restoring:
            _add_child_force(
                xform,
                b,
                restoring[b, 0],
                restoring[b, 1],
                restoring[b, 2],
                restoring[b, 3],
                restoring[b, 4],
                restoring[b, 5],
                restoring,
                parent,
            )
    # root: free flyer (6 DOF, S = identity); a locked root (fixed base) has a = 0, no solve
    # (Featherstone 2008, Table 7.1: a fixed base's a_0 is the gravity term, here in the bias)
    iv0 = v_index[0]
    if bodies.kind[0] == LOCKED_ROOT:
        for i in range(6):
            acc[0, i] = 0.0
            out[iv0 + i] = 0.0
    else:
        tmp = W.v6[1]
        for i in range(6):
            tmp[i] = tau[iv0 + i] - pa[0, i]
        _solve_spd6(art[0], tmp, acc[0])
        for i in range(6):
            out[iv0 + i] = acc[0, i]
    for b in range(1, nb):
        parent = parents[b]
        if parent < 0:
            a0, a1, a2 = bias_acc[b, 0], bias_acc[b, 1], bias_acc[b, 2]
            a3, a4, a5 = bias_acc[b, 3], bias_acc[b, 4], bias_acc[b, 5]
        else:
            a0, a1, a2, a3, a4, a5 = motion_to_child(
                xform[b],
                acc[parent, 0],
                acc[parent, 1],
                acc[parent, 2],
                acc[parent, 3],
                acc[parent, 4],
                acc[parent, 5],
            )
            a0 += bias_acc[b, 0]
            a1 += bias_acc[b, 1]
            a2 += bias_acc[b, 2]
            a3 += bias_acc[b, 3]
            a4 += bias_acc[b, 4]
            a5 += bias_acc[b, 5]
        ua = (
            u_vec[b, 0] * a0
            + u_vec[b, 1] * a1
            + u_vec[b, 2] * a2
            + u_vec[b, 3] * a3
            + u_vec[b, 4] * a4
            + u_vec[b, 5] * a5
        )
        qdd = (u_sc[b] - ua) * d_inv[b]
        out[v_index[b]] = qdd
        s = axis
        acc[b, 0] = a0 + s[b, 0] * qdd
        acc[b, 1] = a1 + s[b, 1] * qdd
        acc[b, 2] = a2 + s[b, 2] * qdd
        acc[b, 3] = a3 + s[b, 3] * qdd
        acc[b, 4] = a4 + s[b, 4] * qdd
        acc[b, 5] = a5 + s[b, 5] * qdd


@compiled(fastmath=True, borrows_only=True)
def _add_child_force(xform, child, f0, f1, f2, n0, n1, n2, dst, parent):
    """``dst[parent] += X^T (f, n)``: a child-frame force in the parent frame, ``(R f, p x R f + R n)``."""
    p0, p1, p2 = xform[child, 3, 0], xform[child, 3, 1], xform[child, 3, 2]
    g0 = xform[child, 0, 0] * f0 + xform[child, 0, 1] * f1 + xform[child, 0, 2] * f2
    g1 = xform[child, 1, 0] * f0 + xform[child, 1, 1] * f1 + xform[child, 1, 2] * f2
    g2 = xform[child, 2, 0] * f0 + xform[child, 2, 1] * f1 + xform[child, 2, 2] * f2
    dst[parent, 0] += g0
    dst[parent, 1] += g1
    dst[parent, 2] += g2
    dst[parent, 3] += (
        xform[child, 0, 0] * n0
        + xform[child, 0, 1] * n1
        + xform[child, 0, 2] * n2
        + p1 * g2
        - p2 * g1
    )
    dst[parent, 4] += (
        xform[child, 1, 0] * n0
        + xform[child, 1, 1] * n1
        + xform[child, 1, 2] * n2
        + p2 * g0
        - p0 * g2
    )
    dst[parent, 5] += (
        xform[child, 2, 0] * n0
        + xform[child, 2, 1] * n1
        + xform[child, 2, 2] * n2
        + p0 * g1
        - p1 * g0
    )


@compiled(fastmath=True, borrows_only=True)
def generalized_force(bodies, xform, body_wrench, out, tmp):
    """Generalised force ``sum_b J_b^T w_b`` of body wrenches (body frames); consumes them."""
    for b in range(bodies.parent.shape[0] - 1, -1, -1):
        iv = bodies.v_index[b]
        if bodies.kind[b] == FREE_FLYER or bodies.kind[b] == LOCKED_ROOT:
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


@compiled(fastmath=True, borrows_only=True)
def restoring_into(model, W, out):
    """``g(q)`` (left-hand side: weight minus buoyancy, generalised) after :func:`kinematics`.

    Built from :func:`aiauv_hydro.laws.fluid_terms.hydrostatic_wrench` through the same per-body
    data the dynamics use.
    """
    wrench = W.relative
    h = model.fluid.hydrostatics
    for b in range(wrench.shape[0]):
        rot = W.rotation[b]
        w = hydrostatic_wrench(h[b, 0], h[b, 1], h[b, 2], h[b, 3], rot[2, 0], rot[2, 1], rot[2, 2])
        for i in range(6):
            wrench[b, i] = -w[i]
    generalized_force(model.bodies, W.placement, wrench, out, W.v6[0])


@compiled(fastmath=True, borrows_only=True)
def thrust_forces_into(model, W, thrusts, out):
    """``out = B(q) thrusts`` (the paper's eq. (20)) after :func:`kinematics` [N, N m]."""
    wrench = W.relative
    wrench[:, :] = 0.0
    th = model.thrusters
    for k in range(th.body.shape[0]):
        b = th.body[k]
        for i in range(6):
            wrench[b, i] += th.unit_wrench[k, i] * thrusts[k]
    generalized_force(model.bodies, W.placement, wrench, out, W.v6[0])


@compiled(fastmath=True, borrows_only=True)
def thrust_into(model, W, thrusts, out):
    """``out = B(q) thrusts`` (the paper's eq. (20)) after :func:`kinematics` [N, N m]; the
    thrusts are recorded as the command ``W.thrust_command`` (the thrusters' actuator dynamics,
    :func:`actuators_into`, follow it)."""
    command = W.thrust_command
    for k in range(command.shape[0]):
        command[k] = thrusts[k]
    thrust_forces_into(model, W, thrusts, out)


@compiled(fastmath=True, borrows_only=True)
def actuators_into(model, W, q, v, tau, dt):
    """Advance the actuators over one step of the compiled loop; whether the step takes
    ``W.tau_actuated`` instead of ``tau``.

    Where a command reaches the plant: each fin angle ``W.fin_angle`` follows the command
    ``W.fin_command`` (a compiled controller writes it) and, for thrusters with a lag or a rate
    limit, each produced thrust ``W.thrust`` follows ``W.thrust_command`` (written by
    :func:`thrust_into`), both by :func:`aiauv_hydro.laws.actuators.actuator_response` over ``dt``
    (exact first-order response, then the rate limit, the command clipped to its limit); the value
    reached is held over the step. The controller's ``tau`` holds ``B(q_s) T_cmd`` from its sample;
    the step then takes ``tau + B(q) (T - T_cmd)`` at the step's ``q``.
    Without fins or dynamic thrusters nothing changes and ``tau`` is taken as it is.
    """
    fins = model.fins
    angle, command = W.fin_angle, W.fin_command
    for k in range(angle.shape[0]):
        angle[k] = actuator_response(
            angle[k], command[k], fins.max_angle[k], fins.time_constant[k], fins.max_rate[k], dt
        )
    th = model.thrusters
    if not th.dynamic:
        return False
    thrust, thrust_command, delta = W.thrust, W.thrust_command, W.thrust_delta
    for k in range(thrust.shape[0]):
        thrust[k] = actuator_response(
            thrust[k],
            thrust_command[k],
            th.max_thrust[k],
            th.time_constant[k],
            th.max_rate[k],
            dt,
        )
        delta[k] = thrust[k] - thrust_command[k]
    kinematics(model.bodies, q, v, W)
    out = W.tau_actuated
    thrust_forces_into(model, W, delta, out)
    for i in range(out.shape[0]):
        out[i] += tau[i]
    return True


def reset_actuators(W) -> None:
    """Fins at zero angle and thrusters at rest, commands zero: the actuators' state at the start
    of a run (from Python)."""
    for name in ("fin_angle", "fin_command", "thrust", "thrust_command", "thrust_delta"):
        getattr(W, name)[:] = 0.0


# ---------------------------------------------------------------------- workspace
def workspace(nb: int, nq: int, nv: int, nf: int = 0, m: int = 0) -> Workspace:
    """Scratch arrays of one evaluation for ``nb`` bodies, ``nf`` fins and ``m`` thrusters
    (allocate once, reuse in every step); the actuators start at rest (zero).

    Built in Python: it is only called from Python, and compiling its 34 array allocations would
    lengthen every first run.
    """
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
        np.empty((nb, 6)),
        np.zeros(nf),
        np.zeros(nf),
        np.zeros(m),
        np.zeros(m),
        np.zeros(m),
        np.zeros(nv),
        np.zeros((nb, 3)),
    )


def new_workspace(model, nq: int, nv: int) -> Workspace:
    """A :class:`Workspace` for ``model`` (from Python)."""
    return workspace(
        model.bodies.parent.shape[0],
        nq,
        nv,
        model.fins.body.shape[0],
        model.thrusters.body.shape[0],
    )


# ---------------------------------------------------------------------- forward dynamics
@compiled(fastmath=True, borrows_only=True)
def acceleration_into(model, env, servo, t, q, v, tau, W, out, implicit_step):
    """Forward dynamics ``dv`` of ``M(q) dv + bias(q, v) = tau + servo + disturbance`` into ``out``.

    ``implicit_step``: 0 for the dynamics; ``h > 0`` [s] for the servo-implicit acceleration of
    a semi-implicit Euler step of that size (:func:`articulated_into`).
    """
    kinematics(model.bodies, q, v, W)
    sample_current(model, env, t, W)
    body_bias(model, W)
    flow_acceleration_bias(model, env, t, W)
    tau_all = W.tau_total
    for i in range(tau.shape[0]):
        tau_all[i] = tau[i]
    add_disturbance(
        env.disturbance_function, env.disturbance_kind, t, q, v, env.disturbance_parameters, tau_all
    )
    articulated_into(model, servo, q, v, tau_all, W, out, implicit_step)


# ------------------------------------------------------------------ SE(3) x R^n group operations
@compiled(fastmath=True, borrows_only=True)
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
    c0, c1, c2 = cross3(w0, w1, w2, v0, v1, v2)
    d0, d1, d2 = cross3(w0, w1, w2, c0, c1, c2)
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


@compiled(fastmath=True, borrows_only=True)
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
    x0, x1, x2 = cross3(p0, p1, p2, w0, w1, w2)
    y0, y1, y2 = cross3(p0, p1, p2, x0, x1, x2)
    a0 = w0 - 0.5 * x0 + d * y0
    a1 = w1 - 0.5 * x1 + d * y1
    a2 = w2 - 0.5 * x2 + d * y2
    # Q a with Q = r/2 + c1 (pr + rp + prp) + c2 (ppr + rpp - 3 prp) + c3 (prpp + pprp)   (products
    # of skew matrices applied right to left)
    pa0, pa1, pa2 = cross3(p0, p1, p2, a0, a1, a2)
    ra0, ra1, ra2 = cross3(r0, r1, r2, a0, a1, a2)
    pra0, pra1, pra2 = cross3(p0, p1, p2, ra0, ra1, ra2)
    rpa0, rpa1, rpa2 = cross3(r0, r1, r2, pa0, pa1, pa2)
    prpa0, prpa1, prpa2 = cross3(p0, p1, p2, rpa0, rpa1, rpa2)
    ppra0, ppra1, ppra2 = cross3(p0, p1, p2, pra0, pra1, pra2)
    ppa0, ppa1, ppa2 = cross3(p0, p1, p2, pa0, pa1, pa2)
    rppa0, rppa1, rppa2 = cross3(r0, r1, r2, ppa0, ppa1, ppa2)
    prppa0, prppa1, prppa2 = cross3(p0, p1, p2, rppa0, rppa1, rppa2)
    pprpa0, pprpa1, pprpa2 = cross3(p0, p1, p2, prpa0, prpa1, prpa2)
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
    x0, x1, x2 = cross3(p0, p1, p2, l0, l1, l2)
    y0, y1, y2 = cross3(p0, p1, p2, x0, x1, x2)
    out[0] = l0 - 0.5 * x0 + d * y0
    out[1] = l1 - 0.5 * x1 + d * y1
    out[2] = l2 - 0.5 * x2 + d * y2
    out[3] = a0
    out[4] = a1
    out[5] = a2
    for i in range(6, vel.shape[0]):
        out[i] = vel[i]


# ---------------------------------------------------------------------- integrators
@compiled(fastmath=True, borrows_only=True)
def rk4_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """One Runge-Kutta-Munthe-Kaas step of order 4 (as :func:`aiauv_pin.reference.integrators.rk4_step`).

    Stages at ``t``, ``t + dt/2`` (twice) and ``t + dt`` see the current and disturbance at their time.
    """
    nv = v.shape[0]
    half = 0.5 * dt
    a1, a2, a3, a4 = W.acc1, W.acc2, W.acc3, W.acc4
    k2, k3, k4, xi, vs, qs = W.rate2, W.rate3, W.rate4, W.xi, W.v_stage, W.q_stage
    acceleration_into(model, env, servo, t, q, v, tau, W, a1, 0.0)
    for i in range(nv):
        xi[i] = half * v[i]  # k1 = v: the Jacobian at xi = 0 is the identity
        vs[i] = v[i] + half * a1[i]
    integrate(q, xi, qs)
    acceleration_into(model, env, servo, t + half, qs, vs, tau, W, a2, 0.0)
    tangent_rate(xi, vs, k2)
    for i in range(nv):
        xi[i] = half * k2[i]
        vs[i] = v[i] + half * a2[i]
    integrate(q, xi, qs)
    acceleration_into(model, env, servo, t + half, qs, vs, tau, W, a3, 0.0)
    tangent_rate(xi, vs, k3)
    for i in range(nv):
        xi[i] = dt * k3[i]
        vs[i] = v[i] + dt * a3[i]
    integrate(q, xi, qs)
    acceleration_into(model, env, servo, t + dt, qs, vs, tau, W, a4, 0.0)
    tangent_rate(xi, vs, k4)
    sixth = dt / 6.0
    for i in range(nv):
        xi[i] = sixth * (v[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        v_out[i] = v[i] + sixth * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i])
    integrate(q, xi, q_out)


@compiled(fastmath=True, borrows_only=True)
def semi_implicit_into(model, env, servo, t, q, v, tau, dt, h, W, q_out, v_out):
    """``v' = v + h a``, then ``q' = q * exp(h v')``, with ``a`` the acceleration at ``(t, q, v)``
    and the joint servo implicit over a step ``dt``
    (:func:`aiauv_control.laws.paper_laws.joint_pd_implicit_terms`):
    semi-implicit Euler with ``h = dt`` (:func:`euler_into`) and the midpoint method's stage with
    ``h = dt/2`` (:func:`midpoint_stage_into`)."""
    a = W.acc1
    xi = W.xi
    acceleration_into(model, env, servo, t, q, v, tau, W, a, dt)
    for i in range(v.shape[0]):
        v_out[i] = v[i] + h * a[i]
        xi[i] = h * v_out[i]
    integrate(q, xi, q_out)


@compiled(fastmath=True, borrows_only=True)
def euler_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """Semi-implicit Euler: ``v += dt f(q, v)``, then ``q = q * exp(dt v)``; the joint servo
    implicit (:func:`aiauv_control.laws.paper_laws.joint_pd_implicit_terms`), so it is stable at any step."""
    semi_implicit_into(model, env, servo, t, q, v, tau, dt, dt, W, q_out, v_out)


@compiled(fastmath=True, borrows_only=True)
def midpoint_stage_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """First stage of the servo-implicit midpoint method: the state at ``t + dt/2``.

    ``v_1 = v + dt/2 a_0``, ``q_1 = q * exp(dt/2 v_1)``, with ``a_0`` the acceleration of
    :func:`euler_into` (the joint servo implicit over the whole step ``dt``): a semi-implicit step
    of ``dt/2`` (:func:`semi_implicit_into`). The compiled loop samples the controller at this
    state (:func:`aiauv_pin.simulation.compiled_loop.sample_inside_step`);
    :func:`midpoint_final_into` completes
    the step.
    """
    semi_implicit_into(model, env, servo, t, q, v, tau, dt, 0.5 * dt, W, q_out, v_out)


@compiled(fastmath=True, borrows_only=True)
def midpoint_final_into(model, env, servo, t, q, v, q_mid, v_mid, tau, dt, W, q_out, v_out):
    """Second stage of the servo-implicit midpoint method, from the stage ``(q_mid, v_mid)`` of
    :func:`midpoint_stage_into`: ``v' = v + dt a_1``, ``q' = q * exp(dt v_1)``.

    ``a_1`` is the acceleration at the stage (time ``t + dt/2``, input ``tau``), the joint servo
    implicit over ``dt`` as in :func:`euler_into`. Without a servo it is the explicit midpoint rule
    (order 2; Hairer, Norsett and Wanner 1993, Sec. II.1) on the group, ``dt v_1`` approximating the
    step's Magnus increment to second order (Iserles et al. 2000, Sec. 4); the servo's implicit
    terms make its error first order with a small constant, and keep a stiff servo stable
    (:func:`aiauv_pin.simulation.step_stability.amplification`).
    """
    a = W.acc2
    xi = W.xi
    acceleration_into(model, env, servo, t + 0.5 * dt, q_mid, v_mid, tau, W, a, dt)
    for i in range(v.shape[0]):
        v_out[i] = v[i] + dt * a[i]
        xi[i] = dt * v_mid[i]
    integrate(q, xi, q_out)


@compiled(fastmath=True, borrows_only=True)
def midpoint_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """One step of the servo-implicit midpoint method with ``tau`` held over it (both stages)."""
    midpoint_stage_into(model, env, servo, t, q, v, tau, dt, W, W.q_stage, W.v_stage)
    midpoint_final_into(model, env, servo, t, q, v, W.q_stage, W.v_stage, tau, dt, W, q_out, v_out)


@compiled(fastmath=True, borrows_only=True)
def step_into(model, env, servo, t, q, v, tau, dt, method, W, q_out, v_out):
    """One step of ``method`` (:data:`RK4`, :data:`EULER` or :data:`MIDPOINT`) into ``q_out, v_out``."""
    if method == RK4:
        rk4_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)
    elif method == MIDPOINT:
        midpoint_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)
    else:
        euler_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)


class EulerMethod(NamedTuple):
    """Semi-implicit Euler for :func:`integrator_step`: chosen when the caller is compiled."""

    code: int = EULER


class RK4Method(NamedTuple):
    """RK4 (Munthe-Kaas) for :func:`integrator_step`: chosen when the caller is compiled."""

    code: int = RK4


class MidpointMethod(NamedTuple):
    """The servo-implicit midpoint method for :func:`integrator_step`: chosen when the caller is
    compiled. The compiled loop samples the controller at its stage (:func:`midpoint_stage_into`)."""

    code: int = MIDPOINT


def integrator_step(method, model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
    """One step of ``method`` into ``q_out, v_out``: an :class:`EulerMethod`, :class:`RK4Method` or
    :class:`MidpointMethod` (compiled, the integrator is chosen by its type when the caller is
    compiled, so a loop compiled for one method does not compile the others' code), or
    a code (:data:`RK4`, :data:`EULER`, :data:`MIDPOINT`) chosen at run time by
    :func:`step_into`."""
    code = method if isinstance(method, int) else method.code
    step_into(model, env, servo, t, q, v, tau, dt, code, W, q_out, v_out)


if NUMBA_AVAILABLE:
    from numba import types
    from numba.extending import overload

    @overload(integrator_step)
    def _integrator_step(method, model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
        chosen = getattr(method, "instance_class", None)
        if chosen is EulerMethod:

            def euler(method, model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
                euler_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)

            return euler
        if chosen is RK4Method:

            def rk4(method, model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
                rk4_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)

            return rk4
        if chosen is MidpointMethod:

            def midpoint(method, model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
                midpoint_into(model, env, servo, t, q, v, tau, dt, W, q_out, v_out)

            return midpoint
        if isinstance(method, types.Integer):

            def by_code(method, model, env, servo, t, q, v, tau, dt, W, q_out, v_out):
                step_into(model, env, servo, t, q, v, tau, dt, method, W, q_out, v_out)

            return by_code
        return None


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


@compiled(fastmath=True, borrows_only=True)
def run_steps(model, env, servo, t0, q, v, tau, dt, n_steps, method, W):
    """Advance ``(q, v)`` in place by ``n_steps`` steps from time ``t0`` with ``tau`` held.

    Returns:
        The number of steps completed; fewer than ``n_steps`` if the state became non-finite (then
        ``q, v`` hold the last finite state).
    """
    q_next, v_next = W.q_next, W.v_next
    for k in range(n_steps):
        step_into(model, env, servo, t0 + k * dt, q, v, tau, dt, method, W, q_next, v_next)
        if not is_finite_state(q_next, v_next):
            return k
        for i in range(q.shape[0]):
            q[i] = q_next[i]
        for i in range(v.shape[0]):
            v[i] = v_next[i]
    return n_steps


@compiled(fastmath=True)
def run_rows(
    model,
    env,
    servo,
    rows_q,
    rows_v,
    times,
    controls,
    currents,
    dt,
    n_steps,
    method,
    W,
    tau,
    frame,
    frame_rotation,
    frame_position,
    frame_twist,
    centre,
    done,
    first,
    stop,
):
    """Advance the states ``rows_q[i], rows_v[i]`` of rows ``first <= i < stop`` in place by
    ``n_steps`` steps each (:func:`run_steps`), every row with its own controls and current, then
    evaluate one frame of each: the batched step of :mod:`aiauv_pin.envs`.

    Row ``i`` holds ``tau = B(q_i) u_i + (0, tau_q,i)`` over its steps (the thrusts ``u_i =
    controls[i, :m]`` [N] through ``B(q)`` of the paper's eq. (20) at the row's start, then held, as
    the compiled loop holds a controller's output over its period; joint torques ``tau_q,i =
    controls[i, m:]`` [N m]), runs its ``servo`` (if enabled) towards
    ``controls[i, m + n_joints:]`` [rad], in the constant current ``currents[i]`` (3,) [m/s], world
    axes (``env`` must hold a constant current: its first three parameters are overwritten) from
    time ``times[i]`` [s]. ``env`` and ``servo`` are the calling thread's own (they are written).

    Writes ``done[i]``: the steps completed (fewer than ``n_steps`` if the state became
    non-finite; then the row holds its last finite state), and the world rotation, position [m]
    and own-axes twist of the frame ``frame = (body, rotation, translation)`` at the row's new state
    (:func:`frame_of_body_into`), and the world position of the vehicle's centre of mass
    ``centre[i] = sum_b m_b (p_b + R_b c_b) / sum_b m_b`` [m] (rigid masses only; ``m_b c_b`` read
    from the lower-left block ``m_b [c_b]x`` of each body's rigid inertia, Featherstone 2008,
    eq. (2.63)).
    """
    m = model.thrusters.body.shape[0]
    n_joints = rows_v.shape[1] - 6
    body, rotation, translation = frame
    for i in range(first, stop):
        q, v = rows_q[i], rows_v[i]
        for k in range(3):
            env.current_parameters[k] = currents[i, k]
        if servo.enabled:
            for j in range(n_joints):
                servo.references[j] = controls[i, m + n_joints + j]
        kinematics(model.bodies, q, W.zero_velocity, W)
        thrust_into(model, W, controls[i, :m], tau)
        for j in range(n_joints):
            tau[6 + j] += controls[i, m + j]
        done[i] = run_steps(model, env, servo, times[i], q, v, tau, dt, n_steps, method, W)
        kinematics(model.bodies, q, v, W)
        frame_of_body_into(
            W, body, rotation, translation, frame_rotation[i], frame_position[i], frame_twist[i]
        )
        inertia, mass = model.bodies.rigid_inertia, 0.0
        c0 = c1 = c2 = 0.0
        for b in range(inertia.shape[0]):
            m_b = inertia[b, 0, 0]
            mc0, mc1, mc2 = inertia[b, 5, 1], inertia[b, 3, 2], inertia[b, 4, 0]  # m_b c_b
            r = W.rotation[b]
            p = W.position[b]
            c0 += m_b * p[0] + r[0, 0] * mc0 + r[0, 1] * mc1 + r[0, 2] * mc2
            c1 += m_b * p[1] + r[1, 0] * mc0 + r[1, 1] * mc1 + r[1, 2] * mc2
            c2 += m_b * p[2] + r[2, 0] * mc0 + r[2, 1] * mc1 + r[2, 2] * mc2
            mass += m_b
        centre[i, 0], centre[i, 1], centre[i, 2] = c0 / mass, c1 / mass, c2 / mass


@compiled(fastmath=True, borrows_only=True)
def time_accelerations(model, env, servo, q, v, tau, repeats, W, out):
    """Evaluate the dynamics ``repeats`` times in compiled code (benchmarking)."""
    for _ in range(repeats):
        acceleration_into(model, env, servo, 0.0, q, v, tau, W, out, 0.0)


@compiled(fastmath=True)
def frame_kinematics(model, q, v, body, rotation, translation, W):
    """World pose and twist (in its own axes) of a frame fixed to ``body`` at ``(rotation, translation)``.

    Returns:
        ``(R (3x3), p (3,), twist (6,))`` with the twist ``(v, w)`` in the frame's axes.
    """
    kinematics(model.bodies, q, v, W)
    return frame_of_body(W, body, rotation, translation)


@compiled(fastmath=True, borrows_only=True)
def frame_positions(model, configurations, body, translation, W, out):
    """World position [m] of a point fixed to ``body`` at ``translation`` [m] in each of the
    configurations (n, nq) into ``out`` (n, 3): ``p_b + R_b t`` as :func:`frame_of_body` computes it,
    for a whole logged run in one call."""
    rot_w, pos_w, zero = W.rotation, W.position, W.zero_velocity
    t0, t1, t2 = translation[0], translation[1], translation[2]
    for k in range(configurations.shape[0]):
        kinematics(model.bodies, configurations[k], zero, W)
        out[k, 0], out[k, 1], out[k, 2] = point_in_world(rot_w, pos_w, body, t0, t1, t2)


@compiled(fastmath=True)
def frame_of_body(W, body, rotation, translation):
    """Pose and own-axes twist of a frame on ``body``, from the kinematics already in ``W``.

    Returns:
        New arrays ``(R (3x3), p (3,) [m], twist (6,))`` (:func:`frame_of_body_into` writes them
        into buffers instead).
    """
    rot = np.empty((3, 3))
    pos = np.empty(3)
    frame_twist = np.empty(6)
    frame_of_body_into(W, body, rotation, translation, rot, pos, frame_twist)
    return rot, pos, frame_twist


@compiled(fastmath=True, borrows_only=True)
def frame_of_body_into(W, body, rotation, translation, rot, pos, frame_twist):
    """Pose and own-axes twist of a frame fixed to ``body`` at ``(rotation, translation)``, from the
    kinematics already in ``W``, into ``rot`` (3, 3) (frame to world), ``pos`` (3,) [m] (world) and
    ``frame_twist`` (6,) (``(v, w)`` in the frame's axes [m/s, rad/s]): ``R = R_b R_f``,
    ``p = p_b + R_b t`` and ``twist = X twist_b = (R_f^T (v_b + w_b x t), R_f^T w_b)`` (the motion
    transform of Featherstone 2008, eq. (2.24), applied without forming it)."""
    rot_w = W.rotation[body]
    pos[0], pos[1], pos[2] = point_in_world(
        W.rotation, W.position, body, translation[0], translation[1], translation[2]
    )
    for i in range(3):
        for j in range(3):
            rot[i, j] = (
                rot_w[i, 0] * rotation[0, j]
                + rot_w[i, 1] * rotation[1, j]
                + rot_w[i, 2] * rotation[2, j]
            )
    t0, t1, t2 = translation[0], translation[1], translation[2]
    w0, w1, w2 = W.twist[body, 3], W.twist[body, 4], W.twist[body, 5]
    c0, c1, c2 = cross3(w0, w1, w2, t0, t1, t2)
    v0 = W.twist[body, 0] + c0
    v1 = W.twist[body, 1] + c1
    v2 = W.twist[body, 2] + c2
    for i in range(3):
        r0, r1, r2 = rotation[0, i], rotation[1, i], rotation[2, i]  # row i of R_f^T
        frame_twist[i] = r0 * v0 + r1 * v1 + r2 * v2
        frame_twist[3 + i] = r0 * w0 + r1 * w1 + r2 * w2


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
