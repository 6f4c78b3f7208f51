"""Station-keeping and velocity laws (aiauv_control.laws.station_laws): closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_control.laws.station_laws import (
    AXIS_NAMES,
    closed_loop_roots,
    computed_wrench,
    integrate_error,
    pid_gains,
    pose_error,
    rotation_from_rpy,
    rotation_log,
    station_acceleration,
    unproducible_axes,
    velocity_gains,
)


def _axis_angle(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K  # Rodrigues


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-4, 0.3, 2.0, math.pi - 1e-8, math.pi])
def test_rotation_log_inverts_rodrigues(angle):
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    log = rotation_log(_axis_angle(axis, angle))
    np.testing.assert_allclose(log, angle * axis, atol=1e-7)


def test_pose_error_in_frame_axes():
    R = rotation_from_rpy(0.0, 0.0, math.pi / 2)  # yawed 90 degrees
    e = pose_error(R, [1.0, 2.0, 3.0], np.eye(3), [1.0, 0.0, 3.0])
    np.testing.assert_allclose(e[:3], [2.0, 0.0, 0.0], atol=1e-15)  # world +y is body +x
    np.testing.assert_allclose(e[3:], [0.0, 0.0, math.pi / 2], atol=1e-15)


@pytest.mark.parametrize("omega, zeta, a", [(2.0, 1.0, None), (0.7, 0.5, 0.1), (3.0, 2.0, 0.0)])
def test_pid_gains_place_the_closed_loop_roots(omega, zeta, a):
    gains = pid_gains(omega, zeta, a)
    a = omega / 4 if a is None else a
    expected = np.concatenate(([-a], np.roots([1.0, 2 * zeta * omega, omega**2])))
    for i in range(6):
        roots = closed_loop_roots(gains.k_p[i], gains.k_d[i], gains.k_i[i])
        np.testing.assert_allclose(np.sort_complex(roots), np.sort_complex(expected), atol=1e-6)


def test_velocity_gains_place_the_roots():
    gains = velocity_gains(2.0, 0.5)
    roots = closed_loop_roots(0.0, gains.k_d[0], gains.k_i[0])
    np.testing.assert_allclose(np.sort(roots.real), [-2.0, -0.5], atol=1e-12)


def test_computed_torque_linear_closed_loop_is_the_designed_one():
    """On M dv + n = tau, tau = M a_d + n gives dv = a_d exactly: the linearised loop of one axis
    (e' = nu, nu' = a_d, z' = e) has the designed characteristic polynomial."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6))
    M = A @ A.T + 6 * np.eye(6)  # a full (coupled) mass matrix
    n = rng.normal(size=6)
    gains = pid_gains(1.5, 0.8, 0.3)
    held = np.ones(6, bool)
    e, nu, z = rng.normal(size=6), rng.normal(size=6), rng.normal(size=6)
    tau = computed_wrench(M, station_acceleration(e, nu, z, gains, held), n)
    dv = np.linalg.solve(M, tau - n)
    np.testing.assert_allclose(dv, -gains.k_p * e - gains.k_d * nu - gains.k_i * z, atol=1e-12)
    state_matrix = np.array(
        [[0, 1, 0], [-gains.k_p[0], -gains.k_d[0], -gains.k_i[0]], [1, 0, 0]], dtype=float
    )
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(state_matrix)),
        np.sort_complex(closed_loop_roots(gains.k_p[0], gains.k_d[0], gains.k_i[0])),
        atol=1e-9,
    )


def test_integral_is_frozen_while_saturated_and_zero_on_free_axes():
    held = np.array([True, True, False, True, True, True])
    z = integrate_error(np.zeros(6), np.ones(6), 0.1, False, held)
    np.testing.assert_allclose(z, [0.1, 0.1, 0.0, 0.1, 0.1, 0.1])
    np.testing.assert_array_equal(integrate_error(z, np.ones(6), 0.1, True, held), z)


def test_unproducible_axes_names_the_missing_ones():
    B = np.zeros((6, 3))
    B[0, 0] = B[1, 1] = 1.0
    B[5, 2] = 0.5
    assert unproducible_axes(B, np.ones(6, bool)) == ("heave", "roll", "pitch")
    assert unproducible_axes(B, np.array([1, 1, 0, 0, 0, 1], bool)) == ()
    assert unproducible_axes(np.eye(6), np.ones(6, bool)) == ()
    assert AXIS_NAMES[3] == "roll"


def test_bad_gain_requests():
    with pytest.raises(ValueError, match="positive"):
        pid_gains(0.0)
    with pytest.raises(ValueError, match="integral_pole"):
        velocity_gains(1.0, -1.0)
