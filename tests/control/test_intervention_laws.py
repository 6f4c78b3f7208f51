"""The intervention laws against closed forms: the null-space projector's properties, Khatib's law
as the full-actuation case, exact task tracking, strict priority under limits, the rotation log."""

import math

import numpy as np
import pytest

from aiauv_control.laws.intervention_laws import (
    dynamically_consistent_inverse,
    minimum_jerk,
    null_space_projector,
    pose_error,
    prioritised_actuation,
    prioritised_actuation_limited,
    rotation_log,
    secondary_objective,
    unproducible_axes,
    weighted_pseudo_inverse,
)


def _system(seed: int, n: int = 9, k: int = 6):
    rng = np.random.default_rng(seed)
    root = rng.normal(size=(n, n))
    mass = root @ root.T + n * np.eye(n)
    jacobian = rng.normal(size=(k, n))
    return rng, mass, jacobian


def _rotation(vector) -> np.ndarray:
    """Rodrigues' formula, written independently of the laws."""
    vector = np.asarray(vector, dtype=float)
    theta = np.linalg.norm(vector)
    if theta == 0.0:
        return np.eye(3)
    k = vector / theta
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(theta) * K + (1 - math.cos(theta)) * K @ K


@pytest.mark.parametrize("seed", range(5))
def test_null_space_projector_properties(seed):
    _, mass, jacobian = _system(seed)
    N = null_space_projector(mass, jacobian)
    np.testing.assert_allclose(jacobian @ N, 0.0, atol=1e-12)  # no task acceleration
    np.testing.assert_allclose(N @ N, N, atol=1e-12)  # a projector
    np.testing.assert_allclose(mass @ N, N.T @ mass, atol=1e-10)  # dynamically consistent
    j_bar, inertia = dynamically_consistent_inverse(mass, jacobian)
    np.testing.assert_allclose(jacobian @ j_bar, np.eye(6), atol=1e-12)
    np.testing.assert_allclose(
        inertia, np.linalg.inv(jacobian @ np.linalg.solve(mass, jacobian.T)), rtol=1e-12
    )
    # a null-space torque N^T tau_0 gives no task acceleration
    tau_0 = np.arange(9.0)
    np.testing.assert_allclose(jacobian @ np.linalg.solve(mass, N.T @ tau_0), 0.0, atol=1e-11)


@pytest.mark.parametrize("seed", range(5))
def test_full_actuation_is_khatibs_operational_space_law(seed):
    """A = I (every coordinate actuated) and the weight Q = M^-1 on the torques: the actuator-space
    law is tau = J^T Lambda (a* - J_dot v + J M^-1 b) + N^T tau_0 (Khatib 1987)."""
    rng, mass, jacobian = _system(seed)
    bias, drift, desired = rng.normal(size=9), rng.normal(size=6), rng.normal(size=6)
    tau_0 = rng.normal(size=9)
    G = jacobian @ np.linalg.inv(mass)  # J M^-1 A with A = I
    r = desired - drift + jacobian @ np.linalg.solve(mass, bias)
    weight = np.linalg.inv(mass)
    tau = prioritised_actuation(G, r, weight, weight @ tau_0)  # secondary: |tau - tau_0|^2_{M^-1}
    _, inertia = dynamically_consistent_inverse(mass, jacobian)
    N = null_space_projector(mass, jacobian)
    khatib = jacobian.T @ inertia @ r + N.T @ tau_0
    np.testing.assert_allclose(tau, khatib, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(weighted_pseudo_inverse(G, weight), jacobian.T @ inertia, rtol=1e-9)
    # exact tracking: the acceleration the torque produces meets the task
    acceleration = np.linalg.solve(mass, tau - bias)
    np.testing.assert_allclose(jacobian @ acceleration + drift, desired, atol=1e-10)


def test_secondary_task_is_optimal_in_the_null_space():
    """Among the solutions of G w = r the law minimises the secondary objective: every feasible
    direction (the null space of G) raises it, and the KKT gradient lies in G's row space."""
    rng = np.random.default_rng(7)
    n, n_a = 9, 12
    H, h, a_0 = rng.normal(size=(n, n_a)), rng.normal(size=n), rng.normal(size=n)
    G = rng.normal(size=(6, n)) @ H
    r = rng.normal(size=6)
    Q, c = secondary_objective(H, h, a_0, np.full(n_a, 0.1), np.full(n, 2.0))
    w = prioritised_actuation(G, r, Q, c)
    np.testing.assert_allclose(G @ w, r, atol=1e-10)
    gradient = Q @ w - c
    _, _, vt = np.linalg.svd(G)
    null = vt[6:].T
    np.testing.assert_allclose(null.T @ gradient, 0.0, atol=1e-9)
    # the objective as defined: |W_u w|^2 + |W_p (H w - h - a_0)|^2 = w^T Q w - 2 c^T w + const
    w_test = rng.normal(size=n_a)
    direct = np.sum((0.1 * w_test) ** 2) + np.sum((2.0 * (H @ w_test - h - a_0)) ** 2)
    constant = np.sum((2.0 * (h + a_0)) ** 2)
    np.testing.assert_allclose(w_test @ Q @ w_test - 2 * c @ w_test + constant, direct)


def test_limits_keep_the_task_first():
    """With a limit binding, the task is met first (exactly where the limits allow it) and the
    secondary objective is minimised on what is left (Kanoun et al. 2011)."""
    rng = np.random.default_rng(3)
    n_a = 8
    G = rng.normal(size=(3, n_a))
    Q, c = np.eye(n_a), rng.normal(size=n_a) * 5.0
    r = rng.normal(size=3)
    free, limited = prioritised_actuation_limited(G, r, Q, c, -np.full(n_a, 50), np.full(n_a, 50))
    assert not limited
    np.testing.assert_allclose(free, prioritised_actuation(G, r, Q, c))
    lower, upper = -np.full(n_a, 0.6), np.full(n_a, 0.6)
    w, limited = prioritised_actuation_limited(G, r, Q, c, lower, upper)
    assert limited
    assert np.all(w >= lower - 1e-9) and np.all(w <= upper + 1e-9)
    np.testing.assert_allclose(G @ w, r, atol=1e-6)  # still producible within the limits
    # the secondary is worse than unconstrained but no feasible point on G w = r does better:
    # a random feasible perturbation in the null space of G within the limits costs more
    _, _, vt = np.linalg.svd(G)
    null = vt[3:].T
    cost = 0.5 * w @ Q @ w - c @ w
    for _ in range(200):
        trial = w + null @ rng.normal(size=n_a - 3) * 0.05
        if np.all(trial >= lower) and np.all(trial <= upper):
            assert 0.5 * trial @ Q @ trial - c @ trial >= cost - 1e-7


def test_an_axis_no_actuator_reaches_is_named():
    G = np.array([[1.0, 0.0, 2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert unproducible_axes(G) == (1,)
    assert unproducible_axes(np.zeros((2, 3))) == (0, 1)
    assert unproducible_axes(np.eye(3)) == ()


@pytest.mark.parametrize(
    "vector",
    [[0.0, 0.0, 0.0], [1e-8, 0, 0], [0.3, -0.2, 0.5], [0, math.pi - 1e-6, 0], [0, 0, math.pi]],
)
def test_rotation_log_inverts_rodrigues(vector):
    vector = np.array(vector, dtype=float)
    back = rotation_log(_rotation(vector))
    if np.linalg.norm(vector) > math.pi - 1e-5:  # at pi, +k and -k are the same rotation
        np.testing.assert_allclose(_rotation(back), _rotation(vector), atol=1e-9)
    else:
        np.testing.assert_allclose(back, vector, atol=1e-9)


def test_pose_error_is_world_position_and_rotation_vector():
    R = _rotation([0.1, 0.2, -0.3])
    R_d = _rotation([0.0, 0.0, 0.4]) @ R
    error = pose_error(R, [1.0, 2.0, 3.0], R_d, [1.5, 2.0, 2.0])
    np.testing.assert_allclose(error, [0.5, 0.0, -1.0, 0.0, 0.0, 0.4], atol=1e-12)


def test_minimum_jerk_profile():
    assert minimum_jerk(0.0) == (0.0, 0.0, 0.0)
    assert minimum_jerk(1.0) == (1.0, 0.0, 0.0)
    s, ds, dds = minimum_jerk(0.5)
    assert s == pytest.approx(0.5) and ds == pytest.approx(1.875) and dds == pytest.approx(0.0)
    # derivatives against central differences
    h = 1e-6
    for x in (0.1, 0.37, 0.8):
        assert minimum_jerk(x)[1] == pytest.approx(
            (minimum_jerk(x + h)[0] - minimum_jerk(x - h)[0]) / (2 * h), rel=1e-6
        )
        assert minimum_jerk(x)[2] == pytest.approx(
            (minimum_jerk(x + h)[1] - minimum_jerk(x - h)[1]) / (2 * h), rel=1e-5
        )
