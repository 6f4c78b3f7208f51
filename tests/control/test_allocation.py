"""Thrust allocation (aiauv_control.allocation): closed forms, KKT conditions, residual, bad requests.

The problem: minimise |W_f (B u - tau_d)|^2 + |W_u u|^2 subject to u_min <= u <= u_max.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import aiauv_pin
from aiauv_control.allocation import (
    AllocationError,
    AllocationParameters,
    allocate,
    allocate_compiled,
    kernels,
)
from aiauv_control.allocation.allocator import normal_equations
from aiauv_control.allocation.problem import actuator_matrix
from aiauv_hydro.numerics.jit import interpreted

N_RANDOM = 200  # random saturated problems of the compiled-vs-QP comparison


def _random_problem(rng, nv=6, m=8, limit=10.0):
    B = rng.normal(size=(nv, m)) * rng.uniform(0.2, 2.0, size=m)
    parameters = AllocationParameters(
        thrust_min=-limit * rng.uniform(0.0, 1.0, size=m),  # some thrusters one-way
        thrust_max=limit * rng.uniform(0.3, 1.0, size=m),
        thrust_weights=rng.uniform(1e-3, 1e-1, size=m),
        force_weights=rng.uniform(0.5, 2.0, size=nv),
    )
    return B, parameters


def _damped_weighted_pseudo_inverse(B, tau, wf, wu):
    """u = W_u^-2 B^T (B W_u^-2 B^T + W_f^-2)^-1 tau: the unconstrained minimiser (push-through form)."""
    winv = np.diag(1.0 / wu**2)
    return winv @ B.T @ np.linalg.solve(B @ winv @ B.T + np.diag(1.0 / wf**2), tau)


def _kkt_violation(B, tau, parameters, u):
    """Largest violation of the box-constrained problem's KKT conditions, relative to max(1, |g|).

    Stationarity H u - g + mu_max - mu_min = 0 with mu >= 0 and mu_i (limit_i - u_i) = 0:
    the gradient vanishes on free actuators, is >= 0 at a minimum, <= 0 at a maximum.
    """
    matrix = actuator_matrix(B, parameters.joint_dofs)
    H, g = normal_equations(
        matrix, tau, parameters.force_weights_for(B.shape[0]), parameters.actuator_weights()
    )
    gradient = H @ u - g
    lower, upper = parameters.lower(), parameters.upper()
    assert np.all(u >= lower) and np.all(u <= upper)  # primal feasibility, exact
    span = upper - lower
    at_min = u <= lower + 1e-9 * span
    at_max = u >= upper - 1e-9 * span
    free = ~(at_min | at_max)
    violation = np.concatenate(
        [np.abs(gradient[free]), np.maximum(-gradient[at_min], 0), np.maximum(gradient[at_max], 0)]
    )
    return float(violation.max(initial=0.0)) / max(1.0, float(np.abs(g).max()))


# ---------------------------------------------------------------- full actuation, no active limit
def test_no_active_limit_is_the_closed_form_weighted_pseudo_inverse(rng):
    for _ in range(20):
        B, parameters = _random_problem(rng)
        expected_unit = _damped_weighted_pseudo_inverse(
            B, np.ones(6), np.array(parameters.force_weights), np.array(parameters.thrust_weights)
        )
        tau = rng.normal(size=6)
        tau *= 0.5 * min(parameters.thrust_max) / np.abs(expected_unit).sum() / np.abs(tau).max()
        expected = _damped_weighted_pseudo_inverse(
            B, tau, np.array(parameters.force_weights), np.array(parameters.thrust_weights)
        )
        for result in (allocate(B, tau, parameters), allocate_compiled(B, tau, parameters)):
            if not np.all((expected > parameters.lower()) & (expected < parameters.upper())):
                continue  # a one-way thruster's minimum of 0 binds: not this test's case
            assert result.status == "unconstrained" and result.iterations == 0
            assert not result.saturated.any()
            np.testing.assert_allclose(result.thrusts, expected, rtol=0, atol=1e-12)
            np.testing.assert_allclose(result.residual, tau - B @ expected, rtol=0, atol=1e-12)
            assert result.rank == 6 and result.unactuated_axes == ()


def test_weighted_pseudo_inverse_of_fossen_is_the_limit_of_small_effort_weights():
    # Fossen 2021, eq. 11.39: u = W^-1 B^T (B W^-1 B^T)^-1 tau with W = W_u^2, B full row rank
    rng = np.random.default_rng(3)
    B = rng.normal(size=(6, 8))
    tau = rng.normal(size=6)
    wu = rng.uniform(0.5, 2.0, size=8)
    winv = np.diag(1.0 / wu**2)
    fossen = winv @ B.T @ np.linalg.solve(B @ winv @ B.T, tau)
    # W_u = 1e-3 wu against W_f = 1: the damping shifts u by O(1e-6) relative
    parameters = AllocationParameters([-1e3] * 8, [1e3] * 8, thrust_weights=1e-3 * wu)
    for solve in (allocate, allocate_compiled):
        result = solve(B, tau, parameters)
        assert result.status == "unconstrained"
        np.testing.assert_allclose(result.thrusts, fossen, rtol=0, atol=1e-5 * np.abs(fossen).max())
        assert np.abs(result.residual).max() < 1e-5 * np.abs(tau).max()


# ---------------------------------------------------------------- saturation: KKT, compiled vs QP
def test_saturated_allocations_satisfy_kkt_and_compiled_agrees_with_proxsuite():
    # measured on these 200 problems (141 with a limit active): KKT violation 2.4e-15 (both),
    # compiled vs polished ProxQP 6.1e-12, compiled vs ProxQP's raw answer 4.1e-7 (relative to
    # max(1, max|u|)); raw ProxQP is only as exact as its residuals over min(W_u)^2 allow
    import proxsuite

    rng = np.random.default_rng(20261127)
    worst_polished = worst_raw = 0.0
    saturated_problems = 0
    for _ in range(N_RANDOM):
        B, parameters = _random_problem(rng, nv=int(rng.integers(3, 9)), m=int(rng.integers(2, 11)))
        tau = rng.normal(size=B.shape[0]) * rng.choice([1.0, 20.0, 200.0])
        qp = allocate(B, tau, parameters)
        fast = allocate_compiled(B, tau, parameters)
        assert qp.status in ("unconstrained", "optimal")
        assert fast.status in ("unconstrained", "optimal")
        assert _kkt_violation(B, tau, parameters, qp.thrusts) <= 1e-12
        assert _kkt_violation(B, tau, parameters, fast.thrusts) <= 1e-12
        np.testing.assert_array_equal(qp.saturated, fast.saturated)
        H, g = normal_equations(
            B, tau, np.array(parameters.force_weights), parameters.actuator_weights()
        )
        raw = proxsuite.proxqp.dense.solve(
            H,
            -g,
            l_box=parameters.lower(),
            u_box=parameters.upper(),
            eps_abs=parameters.tolerance * max(1.0, float(np.abs(g).max())),
            eps_rel=0.0,
            max_iter=10_000,
        )
        scale = max(1.0, float(np.abs(fast.thrusts).max()))
        worst_polished = max(worst_polished, np.abs(qp.thrusts - fast.thrusts).max() / scale)
        raw_u = np.clip(raw.x, parameters.lower(), parameters.upper())
        worst_raw = max(worst_raw, np.abs(raw_u - fast.thrusts).max() / scale)
        saturated_problems += bool(fast.saturated.any())
    assert saturated_problems >= N_RANDOM // 2
    assert worst_polished <= 1e-10, worst_polished
    assert worst_raw <= 1e-6, worst_raw


def test_compiled_and_interpreted_kernels_agree(rng):
    B, parameters = _random_problem(rng)
    tau = 50.0 * rng.normal(size=6)
    matrix = actuator_matrix(B, ())
    answers = []
    for function in (kernels.allocate_into, interpreted(kernels.allocate_into)):
        u = np.empty(8)
        status, _ = function(
            matrix,
            tau,
            np.array(parameters.force_weights),
            parameters.actuator_weights(),
            parameters.lower(),
            parameters.upper(),
            100,
            1e-12,
            kernels.workspace(8),
            u,
        )
        assert status == kernels.OPTIMAL
        answers.append(u)
    np.testing.assert_allclose(answers[0], answers[1], rtol=0, atol=1e-12)


def test_an_exhausted_iteration_budget_is_reported_and_feasible():
    rng = np.random.default_rng(5)
    B, parameters = _random_problem(rng)
    parameters = AllocationParameters(
        parameters.thrust_min, parameters.thrust_max, parameters.thrust_weights, max_iterations=1
    )
    tau = 500.0 * rng.normal(size=6)
    result = allocate_compiled(B, tau, parameters)
    assert result.status == "budget" and result.iterations == 1
    assert np.all(result.thrusts >= parameters.lower()) and np.all(
        result.thrusts <= parameters.upper()
    )


# ---------------------------------------------------------------- joints sharing the task
def test_joint_motors_share_the_task_as_identity_columns():
    # one thruster pushing along axis 0 and a joint axis 2 no thruster reaches: the joint motor
    # produces axis 2 exactly where its limit allows and saturates beyond it
    B = np.array([[1.0], [0.0], [0.0]])
    parameters = AllocationParameters(
        [-5.0],
        [5.0],
        thrust_weights=[1e-4],
        joint_dofs=(2,),
        joint_torque_min=[-1.0],
        joint_torque_max=[2.0],
        joint_weights=[1e-4],
    )
    for solve in (allocate, allocate_compiled):
        result = solve(B, np.array([3.0, 0.7, 1.5]), parameters)
        np.testing.assert_allclose(result.thrusts, [3.0], atol=1e-7)
        np.testing.assert_allclose(result.joint_torques, [1.5], atol=1e-7)
        assert result.unactuated_axes == (1,) and result.rank == 2
        np.testing.assert_allclose(result.residual[1], 0.7, rtol=0, atol=0)
        result = solve(B, np.array([3.0, 0.0, 4.0]), parameters)
        np.testing.assert_allclose(result.joint_torques, [2.0], rtol=0, atol=0)
        assert result.saturated.tolist() == [False, True]
        np.testing.assert_allclose(result.residual[2], 2.0, atol=1e-12)


# ---------------------------------------------------------------- under-actuation: the paper vehicle
def test_paper_vehicle_at_neutral_reports_the_axes_it_cannot_produce():
    vehicle = aiauv_pin.load_vehicle()
    B = vehicle.thrust_matrix(pin.neutral(vehicle.model))
    zero_rows = tuple(int(r) for r in np.flatnonzero(np.all(B == 0.0, axis=1)))
    assert 3 in zero_rows  # no thruster rolls the base in the straight posture
    m = B.shape[1]
    parameters = AllocationParameters([-20.0] * m, [20.0] * m)
    tau = np.arange(1.0, B.shape[0] + 1.0)
    for solve in (allocate, allocate_compiled):
        result = solve(B, tau, parameters)
        assert result.unactuated_axes == zero_rows
        assert result.rank == np.linalg.matrix_rank(B) < B.shape[0]
        np.testing.assert_array_equal(result.residual[list(zero_rows)], tau[list(zero_rows)])
        np.testing.assert_allclose(result.residual, tau - B @ result.thrusts, rtol=0, atol=1e-12)
        assert _kkt_violation(B, tau, parameters, result.thrusts) <= 1e-9


# ---------------------------------------------------------------- bad requests: one line
@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (dict(thrust_min=[1.0], thrust_max=[2.0]), "must include zero"),
        (dict(thrust_min=[0.0], thrust_max=[0.0]), "must be below maximum"),
        (dict(thrust_min=[0.0], thrust_max=[-1.0]), "must be below maximum"),
        (dict(thrust_min=[-1.0, -1.0], thrust_max=[1.0]), "2 minima but 1 maxima"),
        (dict(thrust_min=[-1.0], thrust_max=[np.nan]), "NaN or infinite"),
        (dict(thrust_min=[-1.0], thrust_max=[1.0], thrust_weights=[0.0]), "must be positive"),
        (dict(thrust_min=[-1.0], thrust_max=[1.0], force_weights=[1.0, -1.0]), "must be positive"),
        (dict(thrust_min=[], thrust_max=[]), "no actuators"),
        (dict(thrust_min=[-1.0], thrust_max=[1.0], joint_dofs=(6,)), "joint torque limits"),
        (dict(thrust_min=[-1.0], thrust_max=[1.0], joint_dofs=(-1,)), "indices >= 0"),
        (dict(thrust_min=[-1.0], thrust_max=[1.0], max_iterations=0), "must be positive"),
    ],
)
def test_bad_parameters_get_one_line(arguments, message):
    with pytest.raises(AllocationError, match=message) as error:
        AllocationParameters(**arguments)
    assert "\n" not in str(error.value)
    assert isinstance(error.value, ValueError)


@pytest.mark.parametrize("solve", [allocate, allocate_compiled])
@pytest.mark.parametrize(
    ("B", "tau", "message"),
    [
        (np.ones((6, 3)), np.ones(6), r"expected shape \(nv, 2\)"),
        (np.ones((6, 2)), np.ones(5), r"expected shape \(6,\)"),
        (np.full((6, 2), np.inf), np.ones(6), "thrust matrix: contains NaN"),
        (np.ones((6, 2)), np.full(6, np.nan), "tau_d: contains NaN"),
    ],
)
def test_bad_requests_get_one_line(solve, B, tau, message):
    parameters = AllocationParameters([-1.0, -1.0], [1.0, 1.0])
    with pytest.raises(AllocationError, match=message) as error:
        solve(B, tau, parameters)
    assert "\n" not in str(error.value)


def test_a_joint_beyond_the_generalised_forces_and_wrong_force_weights_get_one_line():
    B = np.ones((3, 1))
    with pytest.raises(AllocationError, match="index 5 out of range for nv = 3"):
        allocate(
            B,
            np.ones(3),
            AllocationParameters(
                [-1.0], [1.0], joint_dofs=(5,), joint_torque_min=[-1.0], joint_torque_max=[1.0]
            ),
        )
    with pytest.raises(AllocationError, match="expected 3 weights"):
        allocate(B, np.ones(3), AllocationParameters([-1.0], [1.0], force_weights=[1.0, 1.0]))
