"""The compiled thrust allocator: a box-constrained weighted least-squares problem solved by a
primal active-set method on preallocated buffers (compiled controllers call it in their loop).

The problem (the same as :func:`aiauv_control.allocation.allocator.allocate`, see there)::

    minimise  J(u) = |W_f (B u - tau_d)|^2 + |W_u u|^2   subject to   u_min <= u <= u_max,

with ``W_f = diag(force_weights)``, ``W_u = diag(actuator_weights)`` (all positive). Up to a
constant, ``J / 2 = u^T H u / 2 - g^T u`` with the normal equations (Fossen 2021, Ch. 11,
the weighted least-squares allocation with ``W_f`` added; Johansen & Fossen 2013)::

    H = B^T W_f^2 B + W_u^2   (positive definite),      g = B^T W_f^2 tau_d.

Algorithm: the primal active-set method for convex QPs (Nocedal & Wright 2006, *Numerical
Optimization*, 2nd ed., Algorithm 16.3) specialised to bounds, as used for control allocation by
Harkegard 2002 ("Efficient active set algorithms for solving constrained least squares problems
in aircraft control allocation", Proc. 41st IEEE CDC, pp. 1295-1300). The working set is the set of
actuators held at a limit; each iteration solves the equality-constrained subproblem on the free
actuators (Cholesky of ``H_FF``), then either steps to its minimiser (blocked by the first limit met,
which joins the working set) or, at the subspace minimiser, releases the actuator whose multiplier
has the wrong sign. It starts from the unconstrained minimiser clipped to the limits, so an
allocation with no active limit takes no iteration at all. Every iteration adds or releases one
actuator; the fixed budget ``max_iterations`` bounds the time (the answer is feasible at every
iteration; status :data:`BUDGET` says it may not be optimal).

Nothing here allocates: all arrays are the caller's (:func:`workspace`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aiauv_hydro.numerics.jit import compiled

#: Status codes of :func:`box_least_squares_into` and :func:`allocate_into`.
OPTIMAL = 0  #: the KKT conditions hold (to ``tolerance``)
BUDGET = 1  #: the iteration budget ran out; the answer is feasible but maybe not optimal
NOT_POSITIVE_DEFINITE = 2  #: a pivot of ``H_FF`` was not positive (weights not positive)

#: The active-set states of an actuator.
FREE, AT_MIN, AT_MAX = 0, -1, 1


class Workspace(NamedTuple):
    """Scratch arrays of :func:`allocate_into` for ``nv`` generalised forces and ``m`` actuators."""

    hessian: np.ndarray  #: (m, m) ``H``
    linear: np.ndarray  #: (m,) ``g``
    factor: np.ndarray  #: (m, m) Cholesky factor of ``H_FF``
    rhs: np.ndarray  #: (m,) right-hand side, then solution, of the subproblem
    step: np.ndarray  #: (m,) the step ``p``
    state: np.ndarray  #: (m,) int64, :data:`FREE`, :data:`AT_MIN` or :data:`AT_MAX`
    free: np.ndarray  #: (m,) int64, the free actuators' indices


def workspace(m: int) -> Workspace:
    """The scratch arrays for ``m`` actuators (allocate once, reuse in every step)."""
    return Workspace(
        np.empty((m, m)),
        np.empty(m),
        np.empty((m, m)),
        np.empty(m),
        np.empty(m),
        np.zeros(m, dtype=np.int64),
        np.zeros(m, dtype=np.int64),
    )


@compiled(borrows_only=True)
def normal_equations_into(matrix, tau_d, force_weights, actuator_weights, hessian, linear):
    """``H = B^T W_f^2 B + W_u^2`` and ``g = B^T W_f^2 tau_d`` into ``hessian``, ``linear``."""
    nv, m = matrix.shape
    for i in range(m):
        s = 0.0
        for r in range(nv):
            s += matrix[r, i] * force_weights[r] * force_weights[r] * tau_d[r]
        linear[i] = s
        for j in range(i, m):
            s = 0.0
            for r in range(nv):
                s += matrix[r, i] * force_weights[r] * force_weights[r] * matrix[r, j]
            if i == j:
                s += actuator_weights[i] * actuator_weights[i]
            hessian[i, j] = s
            hessian[j, i] = s


@compiled(borrows_only=True)
def _solve_free(hessian, linear, u, state, free, factor, rhs):
    """Minimiser of ``J`` over the free actuators with the others held: ``rhs[:nf]`` (ordered as
    ``free[:nf]``); returns ``nf``, or ``-1`` if ``H_FF`` is not positive definite."""
    m = u.shape[0]
    nf = 0
    for i in range(m):
        if state[i] == FREE:
            free[nf] = i
            nf += 1
    for a in range(nf):
        i = free[a]
        s = linear[i]
        for j in range(m):
            if state[j] != FREE:
                s -= hessian[i, j] * u[j]
        rhs[a] = s
    # Cholesky H_FF = L L^T (lower triangle of factor), then L y = rhs, L^T x = y
    for a in range(nf):
        for b in range(a + 1):
            s = hessian[free[a], free[b]]
            for c in range(b):
                s -= factor[a, c] * factor[b, c]
            if a == b:
                if not s > 0.0:
                    return -1
                factor[a, a] = np.sqrt(s)
            else:
                factor[a, b] = s / factor[b, b]
    for a in range(nf):
        s = rhs[a]
        for c in range(a):
            s -= factor[a, c] * rhs[c]
        rhs[a] = s / factor[a, a]
    for a in range(nf - 1, -1, -1):
        s = rhs[a]
        for c in range(a + 1, nf):
            s -= factor[c, a] * rhs[c]
        rhs[a] = s / factor[a, a]
    return nf


@compiled(borrows_only=True)
def box_least_squares_into(hessian, linear, lower, upper, max_iterations, tolerance, work, u):
    """Minimise ``u^T H u / 2 - g^T u`` subject to ``lower <= u <= upper`` (module docstring).

    Args:
        hessian: ``H`` (m, m), symmetric positive definite.
        linear: ``g`` (m,).
        lower, upper: The limits (m,), ``lower <= upper``.
        max_iterations: The budget of active-set iterations (each adds or releases one limit).
        tolerance: A multiplier counts as of the wrong sign below ``-tolerance * scale``, with
            ``scale = max(1, max|g|)`` (same units as ``g``).
        work: A :class:`Workspace` for ``m`` actuators (its ``state`` is overwritten).
        u: The answer (m,), written.

    Returns:
        ``(status, iterations)``: :data:`OPTIMAL`, :data:`BUDGET` or :data:`NOT_POSITIVE_DEFINITE`.
    """
    m = u.shape[0]
    state, free, factor, rhs, step = work.state, work.free, work.factor, work.rhs, work.step
    scale = 1.0
    for i in range(m):
        scale = max(scale, abs(linear[i]))
        state[i] = FREE
    # the unconstrained minimiser, clipped: the start (feasible; the clipped ones form the working set)
    nf = _solve_free(hessian, linear, u, state, free, factor, rhs)
    if nf < 0:
        return NOT_POSITIVE_DEFINITE, 0
    for i in range(m):
        x = rhs[i]
        if x <= lower[i]:
            u[i] = lower[i]
            state[i] = AT_MIN
        elif x >= upper[i]:
            u[i] = upper[i]
            state[i] = AT_MAX
        else:
            u[i] = x
    at_subspace_minimum = True
    for i in range(m):
        if state[i] != FREE:
            at_subspace_minimum = False
    iterations = 0
    while iterations < max_iterations:
        if at_subspace_minimum:
            # multipliers of the held limits: lambda = +(H u - g)_i at u_min, -(H u - g)_i at u_max
            worst = -tolerance * scale
            release = -1
            for i in range(m):
                if state[i] == FREE:
                    continue
                gradient = -linear[i]
                for j in range(m):
                    gradient += hessian[i, j] * u[j]
                multiplier = gradient if state[i] == AT_MIN else -gradient
                if multiplier < worst:
                    worst = multiplier
                    release = i
            if release < 0:
                return OPTIMAL, iterations
            state[release] = FREE
            at_subspace_minimum = False
            iterations += 1
            continue
        nf = _solve_free(hessian, linear, u, state, free, factor, rhs)
        if nf < 0:
            return NOT_POSITIVE_DEFINITE, iterations
        alpha = 1.0
        blocking = -1
        side = FREE
        for a in range(nf):
            i = free[a]
            p = rhs[a] - u[i]
            step[i] = p
            if p < 0.0 and lower[i] - u[i] > alpha * p:
                alpha = (lower[i] - u[i]) / p
                blocking, side = i, AT_MIN
            elif p > 0.0 and upper[i] - u[i] < alpha * p:
                alpha = (upper[i] - u[i]) / p
                blocking, side = i, AT_MAX
        for a in range(nf):
            i = free[a]
            u[i] = min(max(u[i] + alpha * step[i], lower[i]), upper[i])
        if blocking >= 0:
            u[blocking] = lower[blocking] if side == AT_MIN else upper[blocking]
            state[blocking] = side
        else:
            at_subspace_minimum = True
        iterations += 1
    return BUDGET, iterations


@compiled(borrows_only=True)
def allocate_into(
    matrix,
    tau_d,
    force_weights,
    actuator_weights,
    lower,
    upper,
    max_iterations,
    tolerance,
    work,
    u,
):
    """The allocation ``u`` (m,) of ``tau_d`` (nv,) on the actuator matrix ``matrix`` (nv, m):
    :func:`normal_equations_into`, then :func:`box_least_squares_into`; returns its
    ``(status, iterations)``. Units: those of ``tau_d`` [N, N m] and ``u`` [N, N m]."""
    normal_equations_into(matrix, tau_d, force_weights, actuator_weights, work.hessian, work.linear)
    return box_least_squares_into(
        work.hessian, work.linear, lower, upper, max_iterations, tolerance, work, u
    )


@compiled(borrows_only=True)
def actuator_matrix_into(thrust_matrix, joint_dofs, out):
    """``[B | E]`` into ``out`` (nv, m + k): the thrust matrix ``B`` (nv, m) and one unit column per
    joint actuator, ``E[:, c] = e_{joint_dofs[c]}`` (a joint torque is its generalised force)."""
    nv, m = thrust_matrix.shape
    for r in range(nv):
        for c in range(m):
            out[r, c] = thrust_matrix[r, c]
        for c in range(joint_dofs.shape[0]):
            out[r, m + c] = 1.0 if joint_dofs[c] == r else 0.0
