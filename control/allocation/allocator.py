"""Thrust allocation: the actuator forces that best produce a desired generalised force.

The objective (Fossen 2021, Ch. 11, constrained allocation by weighted least squares; Johansen &
Fossen 2013, linear allocation as a quadratic programme, the "least squares with a penalty on the
control effort" form)::

    minimise  J(u) = |W_f (B u - tau_d)|^2 + |W_u u|^2   subject to   u_min <= u <= u_max

with ``B`` the actuator matrix (the thrust matrix ``B(q)``, nv x m, and an identity column for each
joint motor sharing the task), ``W_f = diag(force_weights)``, ``W_u = diag(actuator weights)``. One
strictly convex QP rather than the two-stage "exact where feasible" form (first minimise the
residual, then the effort among the minimisers): its answer is unique and continuous in ``tau_d``
and ``q`` (no jump between minimisers of a rank-deficient ``B`` from one step to the next), it is
one solve per call, and the compiled allocator solves the very same problem, so the two can be
compared exactly. The price is a small deliberate residual: with no limit active the answer is the
damped weighted pseudo-inverse ``u = W_u^-2 B^T (B W_u^-2 B^T + W_f^-2)^-1 tau_d``, which tends to
Fossen's weighted pseudo-inverse ``W^-1 B^T (B W^-1 B^T)^-1 tau_d`` (Ch. 11, the generalised
inverse, ``W = W_u^2``) as ``W_u / W_f -> 0``; the default ``W_u = 1e-3`` [1/N] against
``W_f = 1`` leaves a relative residual of order 1e-6 on a fully actuated vehicle of unit gains.

:func:`allocate` solves it with the closed form when no limit is active (exact) and with the QP
solver ProxQP (Bambade et al. 2022, "PROX-QP: Yet another Quadratic Programming Solver for
Robotics and beyond", RSS 2022; the ``proxsuite`` package) otherwise; :func:`allocate_compiled` with
the compiled active-set kernel (:mod:`aiauv_control.allocation.kernels`). Both report what
cannot be produced: the residual ``tau_d - B u``, the axes no actuator acts on and the rank of
``B``.
"""

from __future__ import annotations

import numpy as np

from aiauv_control.allocation import kernels
from aiauv_control.allocation.problem import (
    AllocationParameters,
    AllocationResult,
    actuator_matrix,
    check_request,
    result_of,
)

_STATUS = {kernels.OPTIMAL: "optimal", kernels.BUDGET: "budget"}


def normal_equations(matrix, tau, force_weights, actuator_weights):
    """``(H, g)`` of :mod:`aiauv_control.allocation.kernels` (its compiled law)."""
    m = matrix.shape[1]
    hessian, linear = np.empty((m, m)), np.empty(m)
    kernels.normal_equations_into(matrix, tau, force_weights, actuator_weights, hessian, linear)
    return hessian, linear


def allocate(thrust_matrix, tau_d, parameters: AllocationParameters) -> AllocationResult:
    """The allocation of ``tau_d`` (module docstring), solved in Python with ProxQP.

    Args:
        thrust_matrix: ``B(q)`` (nv, m) [N/N, N m/N] (:meth:`aiauv_pin.Vehicle.thrust_matrix`).
        tau_d: The desired generalised force (nv,) [N, N m].
        parameters: Limits and weights.

    Raises:
        AllocationError: a shape, value or limit that does not fit (one line).
    """
    import proxsuite  # a heavy import, only where the Python allocator runs

    B, tau = check_request(thrust_matrix, tau_d, parameters)
    matrix = actuator_matrix(B, parameters.joint_dofs)
    lower, upper = parameters.lower(), parameters.upper()
    hessian, linear = normal_equations(
        matrix, tau, parameters.force_weights_for(B.shape[0]), parameters.actuator_weights()
    )
    u = np.linalg.solve(hessian, linear)  # the closed form: optimal if no limit binds
    if np.all(u > lower) and np.all(u < upper):
        return result_of(matrix, tau, parameters, u, "unconstrained", 0)
    scale = max(1.0, float(np.abs(linear).max()))
    solution = proxsuite.proxqp.dense.solve(
        hessian,
        -linear,
        l_box=lower,
        u_box=upper,
        eps_abs=parameters.tolerance * scale,
        eps_rel=0.0,
        max_iter=10_000,
    )
    solved = solution.info.status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
    u, exact = polish(
        hessian,
        linear,
        lower,
        upper,
        np.clip(solution.x, lower, upper),
        solution.z,
        parameters.tolerance * scale,
    )
    status = "optimal" if solved or exact else "not converged"
    return result_of(matrix, tau, parameters, u, status, solution.info.iter)


def polish(hessian, linear, lower, upper, u, multipliers, tolerance):
    """The QP's answer made exact on its active set (Stellato et al. 2020, "OSQP: an operator
    splitting solver for quadratic programs", *Math. Prog. Comp.* 12, "solution polishing").

    ProxQP stops on residuals of size ``tolerance``; in the directions of the null space of ``B``
    only ``W_u^2`` holds ``u``, so the answer is off by ``tolerance / min(W_u)^2``, e.g. 1e-8 N next
    to a limit it should sit on. The limits with a multiplier of ProxQP (``z < 0``: minimum,
    ``z > 0``: maximum) are held, ``H_FF u_F = g_F - H_FA u_A`` is solved for the others, and the
    result is kept if it is feasible and the held limits' multipliers have the right sign (the KKT
    conditions, to the absolute ``tolerance`` in the units of ``g``); otherwise ``u`` is returned
    unchanged.

    Returns:
        ``(u, exact)``: the polished answer and True, or ``u`` and False.
    """
    at_min = multipliers < -tolerance
    at_max = multipliers > tolerance
    held = at_min | at_max
    polished = np.where(at_min, lower, np.where(at_max, upper, u))
    free = ~held
    if free.any():
        rhs = linear[free] - hessian[np.ix_(free, held)] @ polished[held]
        polished[free] = np.linalg.solve(hessian[np.ix_(free, free)], rhs)
    gradient = hessian @ polished - linear
    feasible = np.all(polished >= lower) and np.all(polished <= upper)
    signs = np.all(gradient[at_min] >= -tolerance) and np.all(gradient[at_max] <= tolerance)
    exact = bool(feasible and signs)
    return (polished, True) if exact else (u, False)


def allocate_compiled(
    thrust_matrix, tau_d, parameters: AllocationParameters, work: kernels.Workspace | None = None
) -> AllocationResult:
    """The allocation of ``tau_d`` by the compiled active-set kernel (:func:`allocate`'s problem).

    Compiled controllers call :func:`aiauv_control.allocation.kernels.allocate_into` directly on
    their own buffers; this is its checked Python entry (``work`` from
    :func:`~aiauv_control.allocation.kernels.workspace`, or a new one).
    """
    B, tau = check_request(thrust_matrix, tau_d, parameters)
    matrix = np.empty((B.shape[0], parameters.n_actuators))
    kernels.actuator_matrix_into(B, np.array(parameters.joint_dofs, dtype=np.int64), matrix)
    if work is None:
        work = kernels.workspace(parameters.n_actuators)
    u = np.empty(parameters.n_actuators)
    status, iterations = kernels.allocate_into(
        matrix,
        tau,
        parameters.force_weights_for(B.shape[0]),
        parameters.actuator_weights(),
        parameters.lower(),
        parameters.upper(),
        parameters.max_iterations,
        parameters.tolerance,
        work,
        u,
    )
    if status == kernels.NOT_POSITIVE_DEFINITE:  # weights are checked positive: not reachable
        raise ArithmeticError("allocation: H not positive definite (weights too small for B)")
    name = _STATUS[status]
    if status == kernels.OPTIMAL and iterations == 0:
        name = "unconstrained" if not np.any(work.state) else "optimal"
    return result_of(matrix, tau, parameters, u, name, iterations)
