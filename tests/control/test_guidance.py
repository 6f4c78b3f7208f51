"""LOS vector guidance (paper, eq. 21): geometry and exact derivatives of x_ref."""

from __future__ import annotations

import numpy as np
import pytest

from aiauv_control.guidance import cross_track_gains, los_direction, los_reference

U_D = 0.5


def trajectory(t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A smooth end-effector path (position, velocity, acceleration), analytic."""
    p = np.array(
        [0.5 * t + 0.1 * np.sin(t), 3.0 * np.cos(0.3 * t) - 1.0, 2.0 * np.sin(0.4 * t) + 0.5 * t]
    )
    v = np.array([0.5 + 0.1 * np.cos(t), -0.9 * np.sin(0.3 * t), 0.8 * np.cos(0.4 * t) + 0.5])
    a = np.array([-0.1 * np.sin(t), -0.27 * np.cos(0.3 * t), -0.32 * np.sin(0.4 * t)])
    return p, v, a


@pytest.mark.parametrize("k_e", [0.05, (0.05, 0.2), (7.0, 0.1, 0.03)])
@pytest.mark.parametrize("t", [0.0, 2.3, 7.1])
def test_derivatives_match_finite_differences(k_e, t):
    h = 1e-4

    def direction(time):
        p, v, a = trajectory(time)
        return los_reference(p, v, a, U_D, k_e)

    x, x_dot, x_ddot = direction(t)
    x_plus, x_dot_plus, _ = direction(t + h)
    x_minus, x_dot_minus, _ = direction(t - h)
    np.testing.assert_allclose(x_dot, (x_plus - x_minus) / (2 * h), atol=1e-9)
    np.testing.assert_allclose(x_ddot, (x_dot_plus - x_dot_minus) / (2 * h), atol=1e-9)
    np.testing.assert_allclose(x_ddot, (x_plus - 2 * x + x_minus) / h**2, atol=1e-6)
    assert np.linalg.norm(x) == pytest.approx(1.0, abs=1e-15)
    assert x @ x_dot == pytest.approx(0.0, abs=1e-15)
    assert x @ x_ddot == pytest.approx(-(x_dot @ x_dot), abs=1e-15)  # d^2/dt^2 |x|^2 = 0


def test_direction_closed_form_and_steering_sign():
    """x_ref = (u_d, -k_y p_y, -k_z p_z) / norm: points back towards the path (eq. 21)."""
    p = np.array([12.0, 3.0, -2.0])
    x, x_dot, x_ddot = los_reference(p, [U_D, 0.0, 0.0], np.zeros(3), U_D, (0.05, 0.1))
    expected = np.array([U_D, -0.15, 0.2])
    np.testing.assert_allclose(x, expected / np.linalg.norm(expected), atol=1e-15)
    np.testing.assert_allclose(los_direction(p, U_D, (0.05, 0.1)), expected, atol=1e-15)
    # Moving parallel to the path: the direction does not change.
    np.testing.assert_array_equal(x_dot, np.zeros(3))
    np.testing.assert_array_equal(x_ddot, np.zeros(3))
    # On the path: straight along it, independent of the along-path position.
    on_path = los_reference([5.0, 0.0, 0.0], [U_D, 0.0, 0.0], np.zeros(3), U_D, 0.05)[0]
    np.testing.assert_array_equal(on_path, [1.0, 0.0, 0.0])


def test_cross_track_angle_is_atan_of_scaled_error():
    """In the horizontal plane the LOS angle is atan(k_e p_y / u_d)."""
    for p_y in (-4.0, 0.5, 10.0):
        x = los_reference([0.0, p_y, 0.0], np.zeros(3), np.zeros(3), U_D, 0.05)[0]
        assert np.arctan2(-x[1], x[0]) == pytest.approx(np.arctan(0.05 * p_y / U_D), abs=1e-14)


def test_gain_forms_are_equivalent():
    np.testing.assert_array_equal(cross_track_gains(0.05), [0.0, 0.05, 0.05])
    np.testing.assert_array_equal(cross_track_gains((0.05, 0.2)), [0.0, 0.05, 0.2])
    np.testing.assert_array_equal(cross_track_gains([9.0, 0.05, 0.2]), [0.0, 0.05, 0.2])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"u_d": 0.0}, "u_d"),
        ({"u_d": -0.5}, "u_d"),
        ({"k_e": -0.1}, "k_e"),
        ({"k_e": (0.1, 0.2, 0.3, 0.4)}, "k_e"),
        ({"k_e": np.eye(2)}, "k_e"),
        ({"position_in_world": [0.0, np.inf, 0.0]}, "position_in_world"),
        ({"velocity_in_world": [0.0, 0.0]}, "velocity_in_world"),
    ],
)
def test_bad_inputs_raise_one_line_errors(kwargs, message):
    arguments = {
        "position_in_world": np.zeros(3),
        "velocity_in_world": np.zeros(3),
        "acceleration_in_world": np.zeros(3),
        "u_d": U_D,
        "k_e": 0.05,
        **kwargs,
    }
    with pytest.raises(ValueError, match=message) as error:
        los_reference(**arguments)
    assert "\n" not in str(error.value)
