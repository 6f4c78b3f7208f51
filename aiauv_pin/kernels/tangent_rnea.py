"""Exact derivatives of the forward dynamics, compiled: a tangent recursive Newton-Euler pass.

The forward dynamics ``dv = M(q)^-1 (tau - h(q, v, V_c))`` of :mod:`aiauv_pin.kernels.articulated_body` (rigid
plus added inertia per body, every fluid term of :mod:`aiauv_hydro.laws.fluid_terms`) is
differentiated through its
inverse dynamics rather than through the articulated-body algorithm:
``ID(q, v, a) = M(q) a + h(q, v) = tau``, so at ``a = dv``

    d dv / d tau = M^-1,    d dv / d x = -M^-1 d ID / d x (at fixed a),   x in {q, v, V_c}

(Carpentier and Mansard 2018, "Analytical derivatives of rigid body dynamics algorithms", Sec. III;
their Algorithm for the ABA derivatives uses the same identity). ``d ID / d x`` is computed here in
forward mode, one tangent direction at a time, through the recursive Newton-Euler algorithm
(Featherstone 2008, Table 5.1) in body coordinates:

* a configuration direction of joint ``j`` moves the placement ``X_j`` by
  ``d X_j = -crm(S_j dq) X_j``, so ``d nu_j = nu_j x S_j``, ``d a_j = (a_j - c_j) x S_j + d nu_j x
  S_j qd_j`` and the force sent to the parent gains ``X_j^T (S_j x* F_j)``; the pose tangent of every
  body of the subtree (its rotation ``d theta_b`` in body axes) propagates like a twist;
* a base configuration direction (right perturbation ``q (+) dq``, as ``pinocchio.integrate``) only
  rotates and moves the whole vehicle: body twists and accelerations in body axes do not change, the
  up axis ``e = R^T z`` and the current in body axes ``v_c = R^T V_c`` turn by ``d theta``;
* a velocity direction changes twists and the velocity-product accelerations ``c_b = nu_b x S qd``;
* a current direction changes each body's ``v_c`` by ``R^T dV_c``.

The water's acceleration ``a`` (a tidal current's ``dV/dt``) enters each body's force as
``-(M_F + M_A)[:, :3] R^T a`` (:mod:`aiauv_hydro.laws.unsteady_flow`): uniform in space and
independent of ``V_c``'s value, it changes only with the body's rotation, like ``v_c``
(:func:`aiauv_hydro.laws.unsteady_flow.add_flow_acceleration_rotation_jacobian`).

Each body's force ``f_b = I_b a_b + p_b(nu_b, v_c, e)`` then changes by
``I_b d a_b + dp/dnu d nu_b + (dp/de [e] + dp/dv_c [v_c]) d theta_b (+ dp/dv_c R^T dV_c)``, with the
fluid parts of ``dp/d*`` from :func:`aiauv_hydro.laws.fluid_terms.body_fluid_bias_jacobians` (the
derivative of each
fluid law sits next to the law) and the rigid Coriolis part from
:func:`aiauv_hydro.laws.fluid_terms.coriolis_wrench_jacobian`. These per-body 6x6 and 6x3 matrices
are formed once
per evaluation, so each direction costs a few 6x6 products per body of its subtree.

The current must be spatially uniform (constant or tidal; its value at time ``t`` is used): the
derivative with respect to a body's position would need the current's spatial gradient.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_hydro.laws.fluid_terms import (
    body_fluid_bias_jacobians,
    coriolis_of_momentum,
    coriolis_wrench_jacobian,
)
from aiauv_hydro.laws.unsteady_flow import add_flow_acceleration_rotation_jacobian
from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import (
    cross3,
    motion_cross,
    motion_to_child,
    motion_transform_into,
)
from aiauv_pin.kernels.articulated_body import (
    _matvec6,
    _xT_add,
    body_bias,
    flow_acceleration_bias,
    kinematics,
    sample_current,
)

#: Kinds of tangent direction.
CONFIGURATION, VELOCITY, CURRENT = 0, 1, 2


class DerivativeWorkspace(NamedTuple):
    """Scratch arrays of one derivative evaluation (allocated once per vehicle)."""

    xform: np.ndarray  # (nb, 6, 6) motion transforms parent -> body
    placement: np.ndarray  # (nb, 4, 3) the same as (R, p): rows 0-2 R, row 3 p
    d_twist: np.ndarray  # (nb, 6, 6) d p_b / d nu_b
    d_current: np.ndarray  # (nb, 6, 3) d p_b / d v_c (body axes)
    d_up: np.ndarray  # (nb, 6, 3) d p_b / d e (body axes)
    d_rotation: np.ndarray  # (nb, 6, 3) d p_b / d theta_b
    fluid_scratch: np.ndarray  # (5, 6, 6)
    composite: np.ndarray  # (nb, 6, 6) composite inertias
    body_acceleration: np.ndarray  # (nb, 6)
    force: np.ndarray  # (nb, 6) body forces, accumulated to the root
    mass: np.ndarray  # (nv, nv)
    cholesky: np.ndarray  # (nv, nv)
    mass_inverse: np.ndarray  # (nv, nv)
    bias: np.ndarray  # (nv,) h(q, v)
    d_twist_t: np.ndarray  # (nb, 6) tangent of the twists
    d_acceleration_t: np.ndarray  # (nb, 6)
    d_rotation_t: np.ndarray  # (nb, 3)
    d_force_t: np.ndarray  # (nb, 6)
    vec: np.ndarray  # (4, 6)
    subtree: np.ndarray  # (nb, nb) subtree[b, j] = 1 if b is j or below it
    body_of_dof: np.ndarray  # (nv,) body of each velocity index
    d_id_dq: np.ndarray  # (nv, nv)
    d_id_dv: np.ndarray  # (nv, nv)
    d_id_dcurrent: np.ndarray  # (nv, 3)
    external: np.ndarray  # (nb, 6) thruster wrenches on each body, body axes
    thrust_matrix: np.ndarray  # (nv, m) B(q)
    # scratch of aiauv_pin.kernels.step_jacobians.transition_into, nz = 2 nv + m + nv - 6 tangent columns
    step_tangents: np.ndarray  # (11, nv, nz) d_acc (4), d_rate (3), d tau, d xi, dq_s, dv_s
    step_vectors: np.ndarray  # (9, nv) stage accelerations (4), rates (3), tau, xi
    step_matrices: np.ndarray  # (5, nv, nv) da_dq, da_dv, M^-1, G, spare
    step_blocks: np.ndarray  # (4, 6, 6) free-flyer blocks of integrate and of the tangent rate
    transition_scratch: np.ndarray  # (8, 7) work vectors of the transition's free-flyer blocks
    transition_matrices: np.ndarray  # (2, 6, 6) work matrices of the same
    subtree_thrust: np.ndarray  # (nb, 6) thrust wrench of each subtree, body axes
    q_stage: np.ndarray  # (nq,) a stage's configuration
    v_stage: np.ndarray  # (nv,) a stage's velocity


def new_derivative_workspace(model, nv: int) -> DerivativeWorkspace:
    """A :class:`DerivativeWorkspace` for ``model`` (a :class:`aiauv_pin.kernels.records.Model`)."""
    bodies = model.bodies
    nb = bodies.parent.shape[0]
    subtree = np.zeros((nb, nb), dtype=np.int64)
    for b in range(nb):
        c = b
        while c >= 0:
            subtree[b, c] = 1
            c = int(bodies.parent[c])
    body_of_dof = np.zeros(nv, dtype=np.int64)
    for b in range(nb):
        width = 6 if b == 0 else 1
        body_of_dof[bodies.v_index[b] : bodies.v_index[b] + width] = b
    return DerivativeWorkspace(
        np.zeros((nb, 6, 6)),
        np.zeros((nb, 4, 3)),
        np.zeros((nb, 6, 6)),
        np.zeros((nb, 6, 3)),
        np.zeros((nb, 6, 3)),
        np.zeros((nb, 6, 3)),
        np.zeros((5, 6, 6)),
        np.zeros((nb, 6, 6)),
        np.zeros((nb, 6)),
        np.zeros((nb, 6)),
        np.zeros((nv, nv)),
        np.zeros((nv, nv)),
        np.zeros((nv, nv)),
        np.zeros(nv),
        np.zeros((nb, 6)),
        np.zeros((nb, 6)),
        np.zeros((nb, 3)),
        np.zeros((nb, 6)),
        np.zeros((4, 6)),
        subtree,
        body_of_dof,
        np.zeros((nv, nv)),
        np.zeros((nv, nv)),
        np.zeros((nv, 3)),
        np.zeros((nb, 6)),
        np.zeros((nv, model.thrusters.body.shape[0])),
        np.zeros((11, nv, 2 * nv + model.thrusters.body.shape[0] + nv - 6)),
        np.zeros((9, nv)),
        np.zeros((5, nv, nv)),
        np.zeros((4, 6, 6)),
        np.zeros((8, 7)),
        np.zeros((2, 6, 6)),
        np.zeros((nb, 6)),
        np.zeros(nv + 1),
        np.zeros(nv),
    )


# ---------------------------------------------------------------------- spatial helpers
@compiled(fastmath=True, borrows_only=True)
def _cross_motion(a, b, out):
    """``out = a x b`` for motion vectors (:func:`aiauv_hydro.numerics.spatial.motion_cross`)."""
    out[0], out[1], out[2], out[3], out[4], out[5] = motion_cross(
        a[0], a[1], a[2], a[3], a[4], a[5], b[0], b[1], b[2], b[3], b[4], b[5]
    )


@compiled(fastmath=True, borrows_only=True)
def _add_cross_force(a, f, out):
    """``out += a x* f`` for a motion ``a`` and a force ``f`` (Featherstone 2008, eq. (2.32)); the
    product is :func:`aiauv_hydro.laws.fluid_terms.coriolis_of_momentum`."""
    w = coriolis_of_momentum(a[0], a[1], a[2], a[3], a[4], a[5], f[0], f[1], f[2], f[3], f[4], f[5])
    for i in range(6):
        out[i] += w[i]


@compiled(fastmath=True, borrows_only=True)
def _apply_transpose_add(x, f, out):
    """``out += X^T f``."""
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += x[j, i] * f[j]
        out[i] += s


@compiled(fastmath=True, borrows_only=True)
def _to_child(xl, m, out):
    """``out = X m = (R^T (v - p x w), R^T w)`` for the placement ``xl`` (rows 0-2 ``R``, row 3 ``p``;
    :func:`aiauv_hydro.numerics.spatial.motion_to_child`)."""
    out[0], out[1], out[2], out[3], out[4], out[5] = motion_to_child(
        xl, m[0], m[1], m[2], m[3], m[4], m[5]
    )


@compiled(fastmath=True, borrows_only=True)
def _times_skew(g, a0, a1, a2, out, add):
    """``out (+)= G [a]`` for a (6, 3) ``G`` (``[a] b = a x b``)."""
    for i in range(6):
        c0, c1, c2 = cross3(g[i, 0], g[i, 1], g[i, 2], a0, a1, a2)  # row i of G [a]
        if add:
            out[i, 0] += c0
            out[i, 1] += c1
            out[i, 2] += c2
        else:
            out[i, 0] = c0
            out[i, 1] = c1
            out[i, 2] = c2


# ---------------------------------------------------------------------- mass matrix
@compiled(fastmath=True, borrows_only=True)
def _mass_matrix(bodies, D):
    """``M(q)`` by the composite-rigid-body algorithm (Featherstone 2008, Table 6.2), 6x6 inertias."""
    nb = bodies.parent.shape[0]
    comp = D.composite
    mass = D.mass
    tmp = D.fluid_scratch[0]
    force = D.vec[0]
    up = D.vec[1]
    for b in range(nb):
        for i in range(6):
            for j in range(6):
                comp[b, i, j] = bodies.inertia[b, i, j]
    for b in range(nb - 1, 0, -1):
        x = D.xform[b]
        parent = bodies.parent[b]
        for i in range(6):  # tmp = I X
            for j in range(6):
                s = 0.0
                for k in range(6):
                    s += comp[b, i, k] * x[k, j]
                tmp[i, j] = s
        for i in range(6):  # parent += X^T tmp
            for j in range(6):
                s = 0.0
                for k in range(6):
                    s += x[k, i] * tmp[k, j]
                comp[parent, i, j] += s
    for i in range(6):
        for j in range(6):
            mass[i, j] = comp[0, i, j]
    for b in range(1, nb):
        col = bodies.v_index[b]
        s_axis = bodies.axis[b]
        _matvec6(comp[b], s_axis, force)
        s = 0.0
        for i in range(6):
            s += s_axis[i] * force[i]
        mass[col, col] = s
        c = b
        while bodies.parent[c] >= 0:
            for i in range(6):
                up[i] = 0.0
            _apply_transpose_add(D.xform[c], force, up)
            for i in range(6):
                force[i] = up[i]
            c = bodies.parent[c]
            if c == 0:
                for i in range(6):
                    mass[bodies.v_index[0] + i, col] = force[i]
                    mass[col, bodies.v_index[0] + i] = force[i]
            else:
                row = bodies.v_index[c]
                s = 0.0
                for i in range(6):
                    s += bodies.axis[c, i] * force[i]
                mass[row, col] = s
                mass[col, row] = s


@compiled(fastmath=True, borrows_only=True)
def _invert_spd(a, low, out):
    """``out = a^-1`` for a symmetric positive-definite ``a``: ``a = L L^T``, ``a^-1 = L^-T L^-1``.

    ``low`` ends holding ``L^-1`` in its lower triangle (inverted in place, columns right to left
    as LAPACK's ``dtrtri``: ``L^-1[j+1:, j] = -L^-1[j+1:, j+1:] L[j+1:, j] / L[j, j]``); only the
    upper triangle of ``a^-1`` is summed, then mirrored (about n^3/2 products in all).
    """
    n = a.shape[0]
    for j in range(n):
        s = a[j, j]
        for k in range(j):
            s -= low[j, k] * low[j, k]
        d = math.sqrt(s) if s > 0.0 else math.nan
        low[j, j] = d
        r = 1.0 / d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= low[i, k] * low[j, k]
            low[i, j] = s * r
    for j in range(n - 1, -1, -1):
        r = 1.0 / low[j, j]
        low[j, j] = r
        for i in range(n - 1, j, -1):  # rows below j still hold L in column j above row i
            s = 0.0
            for k in range(j + 1, i + 1):
                s += low[i, k] * low[k, j]
            low[i, j] = -s * r
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for k in range(j, n):
                s += low[k, i] * low[k, j]
            out[i, j] = s
            out[j, i] = s


@compiled(fastmath=True, borrows_only=True)
def _thrust_matrix(model, D):
    """``B(q)`` (nv, m): each thruster's unit wrench sent up the tree (``sum_b J_b^T w``)."""
    bodies = model.bodies
    wrench = D.vec[2]
    up = D.vec[3]
    out = D.thrust_matrix
    for k in range(model.thrusters.body.shape[0]):
        for i in range(out.shape[0]):
            out[i, k] = 0.0
        for i in range(6):
            wrench[i] = model.thrusters.unit_wrench[k, i]
        c = model.thrusters.body[k]
        while c >= 0:
            iv = bodies.v_index[c]
            if c == 0:
                for i in range(6):
                    out[iv + i, k] = wrench[i]
                break
            s = 0.0
            for i in range(6):
                s += bodies.axis[c, i] * wrench[i]
            out[iv, k] = s
            for i in range(6):
                up[i] = 0.0
            _apply_transpose_add(D.xform[c], wrench, up)
            for i in range(6):
                wrench[i] = up[i]
            c = bodies.parent[c]


@compiled(fastmath=True, borrows_only=True)
def thrust_matrix_at(model, q, W, D):
    """``B(q)`` into ``D.thrust_matrix`` and the placements into ``D.xform`` (kinematics at ``q``)."""
    kinematics(model.bodies, q, W.zero_velocity, W)
    for b in range(model.bodies.parent.shape[0]):
        xl = W.placement[b]
        motion_transform_into(xl[:3], xl[3, 0], xl[3, 1], xl[3, 2], D.xform[b])
    _thrust_matrix(model, D)


# ---------------------------------------------------------------------- passes
@compiled(fastmath=True, borrows_only=True)
def _forces(bodies, W, D, qdd):
    """Body accelerations and forces ``F_b`` of the RNEA at ``qdd``, accumulated to the root.

    Fills ``D.body_acceleration`` and ``D.force``, and writes ``ID(q, v, qdd)`` into ``D.bias``.
    """
    nb = bodies.parent.shape[0]
    acc = D.body_acceleration
    force = D.force
    for b in range(nb):
        parent = bodies.parent[b]
        iv = bodies.v_index[b]
        if parent < 0:
            for i in range(6):
                acc[b, i] = qdd[iv + i]
        else:
            _to_child(D.placement[b], acc[parent], acc[b])
            for i in range(6):
                acc[b, i] += bodies.axis[b, i] * qdd[iv] + W.bias_acceleration[b, i]
        _matvec6(bodies.inertia[b], acc[b], force[b])
        for i in range(6):
            force[b, i] += W.bias[b, i] - D.external[b, i]
    for b in range(nb - 1, -1, -1):
        iv = bodies.v_index[b]
        if b == 0:
            for i in range(6):
                D.bias[iv + i] = force[b, i]
        else:
            s = 0.0
            for i in range(6):
                s += bodies.axis[b, i] * force[b, i]
            D.bias[iv] = s
            _xT_add(D.placement[b], force[b], force[bodies.parent[b]])


@compiled(fastmath=True, borrows_only=True)
def _tangent(bodies, W, D, kind, root, component, v, out_col):
    """``d ID / d x`` along one direction into ``out_col`` (nv,); see the module docstring.

    Args:
        kind: :data:`CONFIGURATION`, :data:`VELOCITY` or :data:`CURRENT`.
        root: Body whose coordinate is perturbed (ignored for the current).
        component: Coordinate of the free flyer (0-5) when ``root`` is 0; the current axis (0-2).
    """
    nb = bodies.parent.shape[0]
    dnu, dacc, dth, dforce = D.d_twist_t, D.d_acceleration_t, D.d_rotation_t, D.d_force_t
    tmp = D.vec[0]
    tmp2 = D.vec[1]
    everything = kind == CURRENT or root == 0
    for b in range(nb):
        if kind == CURRENT:
            rot = W.rotation[b]
            for i in range(6):
                dforce[b, i] = (
                    D.d_current[b, i, 0] * rot[component, 0]
                    + D.d_current[b, i, 1] * rot[component, 1]
                    + D.d_current[b, i, 2] * rot[component, 2]
                )
            continue
        if D.subtree[b, root] == 0:
            for i in range(6):
                dforce[b, i] = 0.0
            continue
        s_axis = bodies.axis[b]
        iv = bodies.v_index[b]
        moving = True  # whether d nu, d a are non-zero
        if b == root:
            if kind == CONFIGURATION:
                if b == 0:
                    for i in range(3):
                        dth[b, i] = 1.0 if i + 3 == component else 0.0
                    moving = False
                else:
                    for i in range(3):
                        dth[b, i] = s_axis[3 + i]
                    _cross_motion(W.twist[b], s_axis, dnu[b])
                    for i in range(6):
                        tmp[i] = D.body_acceleration[b, i] - W.bias_acceleration[b, i]
                    _cross_motion(tmp, s_axis, dacc[b])
                    for i in range(6):
                        tmp[i] = s_axis[i] * v[iv]
                    _cross_motion(dnu[b], tmp, tmp2)
                    for i in range(6):
                        dacc[b, i] += tmp2[i]
            else:
                for i in range(3):
                    dth[b, i] = 0.0
                if b == 0:
                    for i in range(6):
                        dnu[b, i] = 1.0 if i == component else 0.0
                        dacc[b, i] = 0.0
                else:
                    for i in range(6):
                        dnu[b, i] = s_axis[i]
                    _cross_motion(W.twist[b], s_axis, dacc[b])
        else:
            parent = bodies.parent[b]
            x = D.xform[b]
            for i in range(3):
                dth[b, i] = (
                    x[3 + i, 3] * dth[parent, 0]
                    + x[3 + i, 4] * dth[parent, 1]
                    + (x[3 + i, 5] * dth[parent, 2])
                )
            if kind == CONFIGURATION and root == 0:
                moving = False
            else:
                _to_child(D.placement[b], dnu[parent], dnu[b])
                _to_child(D.placement[b], dacc[parent], dacc[b])
                for i in range(6):
                    tmp[i] = s_axis[i] * v[iv]
                _cross_motion(dnu[b], tmp, tmp2)
                for i in range(6):
                    dacc[b, i] += tmp2[i]
        g_rot = D.d_rotation[b]
        t0, t1, t2 = dth[b, 0], dth[b, 1], dth[b, 2]
        if moving:
            inertia = bodies.inertia[b]
            g_nu = D.d_twist[b]
            for i in range(6):
                s = g_rot[i, 0] * t0 + g_rot[i, 1] * t1 + g_rot[i, 2] * t2
                for j in range(6):
                    s += inertia[i, j] * dacc[b, j] + g_nu[i, j] * dnu[b, j]
                dforce[b, i] = s
        else:
            for i in range(6):
                dforce[b, i] = g_rot[i, 0] * t0 + g_rot[i, 1] * t1 + g_rot[i, 2] * t2
    for b in range(nb - 1, -1, -1):
        iv = bodies.v_index[b]
        related = everything or D.subtree[b, root] == 1 or D.subtree[root, b] == 1
        if b == 0:
            for i in range(6):
                out_col[iv + i] = dforce[b, i] if related else 0.0
            continue
        if not related:
            out_col[iv] = 0.0
            continue
        s = 0.0
        for i in range(6):
            s += bodies.axis[b, i] * dforce[b, i]
        out_col[iv] = s
        if b == root and kind == CONFIGURATION:
            _add_cross_force(bodies.axis[b], D.force[b], dforce[b])
        _xT_add(D.placement[b], dforce[b], dforce[bodies.parent[b]])


@compiled(fastmath=True, borrows_only=True)
def acceleration_derivatives_into(
    model, env, t, q, v, tau, thrusts, W, D, dv, da_dq, da_dv, da_dtau, da_dcurrent, da_dthrust
):
    """``dv`` and its exact derivatives with respect to ``q`` (tangent), ``v``, ``tau``, ``V_c``, thrusts.

    The generalised force is ``tau + B(q) thrusts``; the thrusters' wrenches are fixed in their
    bodies, so their change with ``q`` enters ``da_dq`` through the force each body sends to its
    parent (the ``X^T (S x* F)`` term).

    Args:
        model, env: As for :func:`aiauv_pin.kernels.articulated_body.acceleration_into` (no servo, no
            disturbance); the current must be uniform in space.
        t: Time [s] at which the current is sampled.
        q, v, tau: State (nq,), (nv,) and generalised force (nv,).
        thrusts: Thruster forces (m,) [N].
        W: Kernel workspace; D: :class:`DerivativeWorkspace`.
        dv: Output (nv,) [m/s^2, rad/s^2].
        da_dq: Output (nv, nv): with respect to ``dq`` in ``q (+) dq`` [1/s^2].
        da_dv: Output (nv, nv) [1/s].
        da_dtau: Output (nv, nv): ``M^-1``.
        da_dcurrent: Output (nv, 3): with respect to the uniform current, world axes [1/s]; an
            (nv, 0) array skips the current's directions.
        da_dthrust: Output (nv, m): ``M^-1 B(q)``; an (nv, 0) array skips ``B(q)`` (then
            ``D.thrust_matrix`` is left as it was).
    """
    bodies = model.bodies
    nb = bodies.parent.shape[0]
    nv = v.shape[0]
    kinematics(bodies, q, v, W)
    sample_current(model, env, t, W)
    body_bias(model, W)
    flow_acceleration_bias(model, env, t, W)
    for b in range(nb):
        xl = W.placement[b]
        motion_transform_into(xl[:3], xl[3, 0], xl[3, 1], xl[3, 2], D.xform[b])
        for i in range(4):
            for j in range(3):
                D.placement[b, i, j] = W.placement[b, i, j]
        coriolis_wrench_jacobian(bodies.rigid_inertia[b], W.twist[b], D.d_twist[b])
        for i in range(6):
            for j in range(3):
                D.d_current[b, i, j] = 0.0
                D.d_up[b, i, j] = 0.0
    body_fluid_bias_jacobians(
        model.fluid, W.rotation, W.twist, W.current, D.d_twist, D.d_current, D.d_up, D.fluid_scratch
    )
    for b in range(nb):
        rot = W.rotation[b]
        c0, c1, c2 = W.current[b, 0], W.current[b, 1], W.current[b, 2]
        vc0 = rot[0, 0] * c0 + rot[1, 0] * c1 + rot[2, 0] * c2
        vc1 = rot[0, 1] * c0 + rot[1, 1] * c1 + rot[2, 1] * c2
        vc2 = rot[0, 2] * c0 + rot[1, 2] * c1 + rot[2, 2] * c2
        # d e = [e] d theta and d v_c = [v_c] d theta (e = R^T z turns by -d theta)
        _times_skew(D.d_up[b], rot[2, 0], rot[2, 1], rot[2, 2], D.d_rotation[b], False)
        _times_skew(D.d_current[b], vc0, vc1, vc2, D.d_rotation[b], True)
    # the water's acceleration in body axes turns like the current
    if env.current_unsteady:
        add_flow_acceleration_rotation_jacobian(
            model.fluid, W.rotation, W.flow_acceleration, D.d_rotation
        )
    _mass_matrix(bodies, D)
    _invert_spd(D.mass, D.cholesky, D.mass_inverse)
    if da_dthrust.shape[1] > 0:
        _thrust_matrix(model, D)
    for b in range(nb):
        for i in range(6):
            D.external[b, i] = 0.0
    for k in range(thrusts.shape[0]):
        b = model.thrusters.body[k]
        for i in range(6):
            D.external[b, i] += model.thrusters.unit_wrench[k, i] * thrusts[k]
    for i in range(nv):
        dv[i] = 0.0
    _forces(bodies, W, D, dv)  # D.bias = h(q, v) - B(q) thrusts
    minv = D.mass_inverse
    for i in range(nv):
        s = 0.0
        for j in range(nv):
            s += minv[i, j] * (tau[j] - D.bias[j])
        dv[i] = s
    _forces(bodies, W, D, dv)
    for k in range(nv):
        b = D.body_of_dof[k]
        component = k - bodies.v_index[b]
        if b == 0 and component < 3:
            for i in range(nv):  # a translation of the base: no effect in a uniform current
                D.d_id_dq[i, k] = 0.0
        else:
            _tangent(bodies, W, D, CONFIGURATION, b, component, v, D.d_id_dq[:, k])
        _tangent(bodies, W, D, VELOCITY, b, component, v, D.d_id_dv[:, k])
    n_current = da_dcurrent.shape[1]  # 3, or 0 to skip the current's directions
    for k in range(n_current):
        _tangent(bodies, W, D, CURRENT, 0, k, v, D.d_id_dcurrent[:, k])
    for i in range(nv):
        # row i of -M^-1 dID/dq and -M^-1 dID/dv, rows of dID accumulated (contiguous inner loop)
        for j in range(nv):
            da_dtau[i, j] = minv[i, j]
            da_dq[i, j] = 0.0
            da_dv[i, j] = 0.0
        for k in range(nv):
            m_ik = -minv[i, k]
            for j in range(nv):
                da_dq[i, j] += m_ik * D.d_id_dq[k, j]
                da_dv[i, j] += m_ik * D.d_id_dv[k, j]
        for j in range(n_current):
            s = 0.0
            for k in range(nv):
                s += minv[i, k] * D.d_id_dcurrent[k, j]
            da_dcurrent[i, j] = -s
        for j in range(da_dthrust.shape[1]):
            s = 0.0
            for k in range(nv):
                s += minv[i, k] * D.thrust_matrix[k, j]
            da_dthrust[i, j] = s
