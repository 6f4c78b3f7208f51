"""Reduced-attitude tracking with two torques (paper, Section 2) on a simulated rigid body.

The body has a full 2x2 ``J_22`` (nonzero product of inertia), gyroscopic moments and a known
disturbance; the reference precesses on a cone with a wobbling rate (analytic derivatives).
"""

from __future__ import annotations

import numpy as np
import pytest
from rigid_body_attitude import (
    ConeReference,
    ConstantReference,
    RigidBody,
    quaternion_from_axis_angle,
    quaternion_to_rotation,
)
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from aiauv_control.reduced_attitude import (
    E1,
    H,
    ReducedAttitudeLaw,
    error_angle,
    error_axis_angle,
    lyapunov_function,
    minimal_rotation,
    minimal_rotation_rate_correction,
    reduced_attitude_errors,
    reduced_attitude_torque,
    reference_angular_acceleration,
    reference_angular_velocity,
    skew,
)

J = np.array([[1.2, 0.0, 0.0], [0.0, 2.0, 0.4], [0.0, 0.4, 1.5]])  # block-diagonal, full J_22
J22 = J[1:, 1:]
K_P, K_D = 2.0, 3.0
DT, T_END = 0.02, 20.0


def disturbance(t: float) -> np.ndarray:
    return np.array([0.0, 0.3 * np.sin(t), -0.2 + 0.1 * np.cos(0.5 * t)])


BODY = RigidBody(J, disturbance)
CONE = ConeReference()
STATE0 = np.concatenate([quaternion_from_axis_angle([0.0, 0.0, 1.0], 0.0), [0.8, 0.2, -0.1]])


def random_unit_vectors(count: int, seed: int) -> np.ndarray:
    vectors = np.random.default_rng(seed).normal(size=(count, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def tracking_controller(reference, feedforward: str):
    law = ReducedAttitudeLaw(J, K_P, K_D, feedforward)

    def controller(R, omega, t):
        x, x_dot, x_ddot = reference(t)
        return law(R, omega, x, x_dot, x_ddot, BODY.moments(omega, t)).torque

    return controller


def error_history(times, states, reference):
    phi, omega_tilde, V = [], [], []
    for t, state in zip(times, states, strict=True):
        x, x_dot, _ = reference(t)
        p, w = reduced_attitude_errors(quaternion_to_rotation(state[:4]), state[4:], x, x_dot)
        phi.append(p)
        omega_tilde.append(w)
        V.append(lyapunov_function(p, w, J22, K_P))
    return np.array(phi), np.array(omega_tilde), np.array(V)


@pytest.fixture(scope="module")
def cone_runs():
    """Closed-loop runs with the precessing reference, for both feedforward options."""
    runs = {}
    for feedforward in ("exact", "paper"):
        times, states = BODY.simulate(STATE0, T_END, DT, tracking_controller(CONE, feedforward))
        runs[feedforward] = (times, states, *error_history(times, states, CONE))
    return runs


# --------------------------------------------------------------------------------------------------
# geometry
# --------------------------------------------------------------------------------------------------
def test_minimal_rotation_matches_axis_angle_rotation():
    """R_tilde (eq. 5) is the rotation by phi_tilde about y x e1, taking y to e1."""
    for y in random_unit_vectors(50, seed=1):
        phi = np.arccos(y[0])
        axis = np.cross(y, E1) / np.linalg.norm(np.cross(y, E1))
        expected = Rotation.from_rotvec(phi * axis).as_matrix()
        R_tilde = minimal_rotation(y)
        np.testing.assert_allclose(R_tilde, expected, atol=1e-12)
        np.testing.assert_allclose(R_tilde @ y, E1, atol=1e-12)
        assert error_angle(y) == pytest.approx(phi, abs=1e-12)
        np.testing.assert_allclose(error_axis_angle(y), phi * axis, atol=1e-12)


def test_minimal_rotation_and_error_vector_are_smooth_at_zero_error():
    """Near phi_tilde = 0: R_tilde -> I and phi_tilde n -> y x e1 with no 0/0 blow-up."""
    np.testing.assert_array_equal(minimal_rotation(E1), np.eye(3))
    np.testing.assert_array_equal(error_axis_angle(E1), np.zeros(3))
    for eps in (1e-4, 1e-8, 1e-12):
        y = np.array([1.0, eps, -0.5 * eps])
        y /= np.linalg.norm(y)
        k = np.cross(y, E1)
        np.testing.assert_allclose(minimal_rotation(y), np.eye(3) + skew(k), atol=2 * eps**2)
        np.testing.assert_allclose(error_axis_angle(y), k, rtol=eps**2, atol=1e-300)


def test_antipodal_reference_uses_the_paper_convention():
    """At phi_tilde = pi: phi n := 0, R_tilde := I, mu := 0; the torque is finite and equals
    -k_D H^T (omega - omega_ref^b) + H^T (J R^T (x_ref x x_ref_ddot) - m) for both options."""
    R = Rotation.from_rotvec([0.0, 0.0, np.pi]).as_matrix()  # body x-axis along -x_world
    x_ref = E1.copy()
    x_ref_dot = np.array([0.0, 0.3, -0.2])
    x_ref_ddot = np.array([-0.13, 0.1, 0.4])
    omega = np.array([0.4, -0.3, 0.7])
    m = np.array([0.2, -0.5, 0.1])
    y = R.T @ x_ref
    assert error_angle(y) == pytest.approx(np.pi, abs=1e-12)
    np.testing.assert_array_equal(error_axis_angle(y), np.zeros(3))
    np.testing.assert_array_equal(minimal_rotation(y), np.eye(3))
    omega_ref_b = reference_angular_velocity(R, x_ref, x_ref_dot)
    assert minimal_rotation_rate_correction(omega, omega_ref_b, y) == 0.0

    phi, omega_tilde = reduced_attitude_errors(R, omega, x_ref, x_ref_dot)
    assert phi == pytest.approx(np.pi, abs=1e-12)
    np.testing.assert_allclose(omega_tilde, (omega - omega_ref_b)[1:], atol=1e-15)
    expected = -K_D * (omega - omega_ref_b)[1:] + H.T @ (
        J @ reference_angular_acceleration(R, x_ref, x_ref_ddot) - m
    )
    for feedforward in ("exact", "paper"):
        u = reduced_attitude_torque(
            R, omega, x_ref, x_ref_dot, x_ref_ddot, J, m, K_P, K_D, feedforward=feedforward
        )
        assert np.all(np.isfinite(u))
        np.testing.assert_allclose(u, expected, atol=1e-14)


def test_near_the_antipode_rotation_stays_accurate_and_torque_finite():
    """Just off phi_tilde = pi, R_tilde is still an accurate rotation taking y to e1, |phi n| = phi,
    mu grows no faster than 1 / (pi - phi_tilde) and the torque is finite; within
    ANTIPODAL_TOLERANCE the antipodal convention takes over."""
    delta = np.array([0.1, 0.2, 0.3])
    for eps in (1e-3, 1e-7, 1e-11):
        y = np.array([-1.0, eps, eps])
        y /= np.linalg.norm(y)
        R_tilde = minimal_rotation(y)
        np.testing.assert_allclose(R_tilde @ y, E1, atol=1e-12)
        np.testing.assert_allclose(R_tilde.T @ R_tilde, np.eye(3), atol=1e-12)
        assert np.linalg.norm(error_axis_angle(y)) == pytest.approx(error_angle(y), rel=1e-12)
        mu = minimal_rotation_rate_correction(delta, np.zeros(3), y)
        assert abs(mu) * (np.pi - error_angle(y)) < 2.0 * np.linalg.norm(delta)
        u = reduced_attitude_torque(
            np.eye(3), delta, y, [0.0, 0.1, 0.0], [0.0, 0.0, 0.1], J, np.zeros(3), K_P, K_D
        )
        assert np.all(np.isfinite(u))
    y = np.array([-1.0, 1e-13, 0.0])
    np.testing.assert_array_equal(minimal_rotation(y / np.linalg.norm(y)), np.eye(3))


# --------------------------------------------------------------------------------------------------
# kinematics of the errors (finite differences)
# --------------------------------------------------------------------------------------------------
R0 = quaternion_to_rotation(quaternion_from_axis_angle([0.3, -1.0, 0.5], 1.1))
OMEGA0 = np.array([0.8, -0.3, 0.5])  # constant body rate: R(t) = R0 expm(S(omega0) t)


def body_frame_reference(t: float) -> np.ndarray:
    R = R0 @ expm(skew(OMEGA0) * t)
    return R.T @ CONE(t)[0]


@pytest.mark.parametrize("t", [0.4, 1.3, 2.9])
def test_error_angle_rate_matches_eq7(t):
    """d/dt phi_tilde = (omega - omega_ref^b) . (y x e1) / sin(phi_tilde) (eq. 7)."""
    h = 1e-5
    R = R0 @ expm(skew(OMEGA0) * t)
    x, x_dot, _ = CONE(t)
    y = R.T @ x
    delta = OMEGA0 - reference_angular_velocity(R, x, x_dot)
    rate = delta @ np.cross(y, E1) / np.sin(error_angle(y))  # eq. (7)
    numeric = (
        error_angle(body_frame_reference(t + h)) - error_angle(body_frame_reference(t - h))
    ) / (2 * h)
    assert numeric == pytest.approx(rate, rel=1e-7)


@pytest.mark.parametrize("t", [0.4, 1.3, 2.9])
def test_minimal_rotation_rate_finding_2(t):
    """d/dt R_tilde = R_tilde S(delta + mu y), not R_tilde S(delta), for a moving reference."""
    h = 1e-5
    R = R0 @ expm(skew(OMEGA0) * t)
    x, x_dot, _ = CONE(t)
    y = R.T @ x
    omega_ref_b = reference_angular_velocity(R, x, x_dot)
    delta = OMEGA0 - omega_ref_b
    mu = minimal_rotation_rate_correction(OMEGA0, omega_ref_b, y)
    R_tilde = minimal_rotation(y)
    numeric = (
        minimal_rotation(body_frame_reference(t + h))
        - minimal_rotation(body_frame_reference(t - h))
    ) / (2 * h)
    np.testing.assert_allclose(numeric, R_tilde @ skew(delta + mu * y), atol=1e-8)
    assert abs(mu) > 0.1
    assert np.max(np.abs(numeric - R_tilde @ skew(delta))) > 0.1


def test_rate_correction_closed_forms():
    """mu = 0 for a pure tilt about y x e1 (R_tilde then turns at delta itself), and mu = -s for a
    spin s about e1 (R_tilde does not follow the body's spin about its own axis)."""
    y = np.array([np.cos(0.7), np.sin(0.7), 0.0])
    tilt = np.array([0.0, 0.0, 0.9])  # delta . e1 = delta . y = 0
    assert minimal_rotation_rate_correction(tilt, np.zeros(3), y) == 0.0
    spin = 0.6 * E1
    assert minimal_rotation_rate_correction(spin, np.zeros(3), y) == pytest.approx(-0.6)


# --------------------------------------------------------------------------------------------------
# closed loop
# --------------------------------------------------------------------------------------------------
def closed_loop_rates(state: np.ndarray, t: float, feedforward: str, reference=CONE):
    """Central differences of V and omega_tilde along the closed-loop flow (RK4, +-h)."""
    h = 2e-5
    controller = tracking_controller(reference, feedforward)

    def errors(s, time):
        x, x_dot, _ = reference(time)
        return reduced_attitude_errors(quaternion_to_rotation(s[:4]), s[4:], x, x_dot)

    forward = errors(BODY.step(state, t, h, controller), t + h)
    backward = errors(BODY.step(state, t, -h, controller), t - h)
    phi, omega_tilde = errors(state, t)
    V_dot = (lyapunov_function(*forward, J22, K_P) - lyapunov_function(*backward, J22, K_P)) / (
        2 * h
    )
    omega_tilde_dot = (forward[1] - backward[1]) / (2 * h)
    return phi, omega_tilde, V_dot, omega_tilde_dot


def random_states(count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    states = []
    for _ in range(count):
        q = rng.normal(size=4)
        states.append(np.concatenate([q / np.linalg.norm(q), rng.normal(scale=0.7, size=3)]))
    return states


def test_exact_law_gives_the_closed_loop_of_eq12_and_V_dot_of_eq16():
    """With the exact feedforward, omega_tilde_dot = J22^-1 (-k_P H^T phi n - k_D omega_tilde)
    (eq. 12) and V_dot = -k_D |omega_tilde|^2 (eq. 16) hold pointwise for a moving reference."""
    for k, state in enumerate(random_states(6, seed=7)):
        t = 0.8 * k
        _, omega_tilde, V_dot, omega_tilde_dot = closed_loop_rates(state, t, "exact")
        R = quaternion_to_rotation(state[:4])
        y = R.T @ CONE(t)[0]
        expected = np.linalg.solve(J22, -K_P * error_axis_angle(y)[1:] - K_D * omega_tilde)
        np.testing.assert_allclose(omega_tilde_dot, expected, atol=1e-7)
        assert V_dot == pytest.approx(-K_D * omega_tilde @ omega_tilde, abs=1e-7)


def test_paper_law_misses_eq16_for_a_moving_reference():
    """Without the finding-2 term, V_dot differs from -k_D |omega_tilde|^2 by order 0.1 W."""
    mismatches = []
    for k, state in enumerate(random_states(6, seed=7)):
        _, omega_tilde, V_dot, _ = closed_loop_rates(state, 0.8 * k, "paper")
        mismatches.append(abs(V_dot + K_D * omega_tilde @ omega_tilde))
    assert max(mismatches) > 0.05


def test_exact_law_V_never_increases_and_errors_vanish(cone_runs):
    """Theorem 1 with the exact feedforward: V (eq. 14) is non-increasing along the RK4 solution
    and (phi_tilde, omega_tilde) -> 0 for the precessing reference."""
    _, _, phi, omega_tilde, V = cone_runs["exact"]
    assert np.pi**2 > phi[0] ** 2 + omega_tilde[0] @ J22 @ omega_tilde[0] / K_P  # eq. (13)
    assert np.max(np.diff(V)) < 1e-8 * V[0]
    assert V[-1] < 1e-8 * V[0]
    assert phi[-1] < 1e-4
    assert np.linalg.norm(omega_tilde[-1]) < 1e-4


def test_paper_law_stalls_at_a_nonzero_error(cone_runs):
    """With the printed feedforward (finding 1 fixed) the error stalls: phi_tilde over the last
    quarter stays above 0.05 rad, more than 100x the exact law's final error, and V increases at
    times."""
    times, _, phi_paper, _, V_paper = cone_runs["paper"]
    phi_exact = cone_runs["exact"][2]
    last_quarter = times >= 0.75 * T_END
    assert np.min(phi_paper[last_quarter]) > 0.05
    assert np.max(phi_paper[last_quarter]) < 0.5  # bounded, not diverging
    assert phi_paper[-1] > 100 * phi_exact[-1]
    assert np.max(np.diff(V_paper)) > 1e-4 * V_paper[0]


def test_constant_reference_both_options_agree_and_converge():
    """For a constant reference omega_ref = 0, the finding-2 term vanishes: identical torques and
    trajectories, V non-increasing, errors -> 0 from phi_tilde(0) = pi/2."""
    reference = ConstantReference()
    for state in random_states(5, seed=3):
        R, omega = quaternion_to_rotation(state[:4]), state[4:]
        x, x_dot, x_ddot = reference(0.0)
        m = BODY.moments(omega, 0.0)
        u = [
            reduced_attitude_torque(R, omega, x, x_dot, x_ddot, J, m, K_P, K_D, feedforward=ff)
            for ff in ("exact", "paper")
        ]
        np.testing.assert_array_equal(u[0], u[1])
    runs = [
        BODY.simulate(STATE0, 20.0, 0.04, tracking_controller(reference, feedforward))[1]
        for feedforward in ("exact", "paper")
    ]
    np.testing.assert_array_equal(runs[0], runs[1])
    times = np.arange(len(runs[0])) * 0.04
    phi, omega_tilde, V = error_history(times, runs[0], reference)
    assert phi[0] == pytest.approx(np.pi / 2)
    assert np.max(np.diff(V)) < 1e-8 * V[0]
    assert phi[-1] < 1e-3
    assert np.linalg.norm(omega_tilde[-1]) < 1e-3


def test_law_object_matches_the_functions():
    """ReducedAttitudeLaw returns the torque of reduced_attitude_torque and the errors of
    reduced_attitude_errors; m = None means no known moments."""
    for k, state in enumerate(random_states(4, seed=5)):
        R, omega = quaternion_to_rotation(state[:4]), state[4:]
        x, x_dot, x_ddot = CONE(0.7 * k)
        m = BODY.moments(omega, 0.7 * k)
        for feedforward in ("exact", "paper"):
            out = ReducedAttitudeLaw(J, K_P, K_D, feedforward)(R, omega, x, x_dot, x_ddot, m)
            u = reduced_attitude_torque(
                R, omega, x, x_dot, x_ddot, J, m, K_P, K_D, feedforward=feedforward
            )
            np.testing.assert_array_equal(out.torque, u)
            phi, omega_tilde = reduced_attitude_errors(R, omega, x, x_dot)
            assert out.phi_tilde == phi
            np.testing.assert_array_equal(out.omega_tilde, omega_tilde)
            no_m = ReducedAttitudeLaw(J, K_P, K_D, feedforward)(R, omega, x, x_dot, x_ddot)
            np.testing.assert_allclose(no_m.torque, u + m[1:], atol=1e-14)


# --------------------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------------------
GOOD = dict(
    R=np.eye(3),
    omega=np.zeros(3),
    x_ref=np.array([0.6, 0.8, 0.0]),
    x_ref_dot=np.zeros(3),
    x_ref_ddot=np.zeros(3),
    J=J,
    m=np.zeros(3),
    k_p=K_P,
    k_d=K_D,
)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"J": np.array([[1.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 3.0]])}, "block"),
        ({"J": np.array([[1.0, 0, 0], [0, 1.0, 0.2], [0, 0.3, 1.0]])}, "symmetric"),
        ({"J": np.diag([1.0, -1.0, 1.0])}, "positive definite"),
        ({"J": np.eye(2)}, "3x3"),
        ({"x_ref": np.array([1.0, 1.0, 0.0])}, "unit"),
        ({"R": 2.0 * np.eye(3)}, "rotation"),
        ({"R": np.diag([1.0, 1.0, -1.0])}, "rotation"),
        ({"omega": np.array([0.0, np.nan, 0.0])}, "NaN"),
        ({"m": np.zeros(2)}, "shape"),
        ({"k_p": 0.0}, "k_p"),
        ({"k_d": -1.0}, "k_d"),
    ],
)
def test_bad_inputs_raise_one_line_errors(change, message):
    with pytest.raises(ValueError, match=message) as error:
        reduced_attitude_torque(**{**GOOD, **change})
    assert "\n" not in str(error.value)


def test_unknown_feedforward_raises():
    with pytest.raises(ValueError, match="feedforward") as error:
        reduced_attitude_torque(**GOOD, feedforward="printed")
    assert "\n" not in str(error.value)
