"""The torpedo AUV's laws against closed forms: LOS angles for known geometries, the autopilot's
PID and its anti-windup, the fin shares of cruciform and X tails, the signs of the deflections."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_control.laws.paper_laws import new_guidance_state, new_surge_state
from aiauv_control.laws.torpedo_laws import (
    PITCH,
    YAW,
    TorpedoGains,
    direction_angles,
    fin_share,
    new_autopilot_state,
    new_torpedo_buffers,
    pid_autopilot,
    torpedo_command,
)
from aiauv_control.paths import HelixPath, LinePath

X_AXIS = LinePath(point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0))
CRUCIFORM_RUDDER = np.array([1.0, 1.0, 0.0, 0.0])
CRUCIFORM_STERN = np.array([0.0, 0.0, 1.0, 1.0])


def _gains(**changes) -> TorpedoGains:
    base = dict(
        lookahead=8.0,
        integral=False,
        sigma=1.0,
        speed_control=True,
        u_d=2.0,
        thrust=0.0,
        k_1p=40.0,
        k_1i=10.0,
        max_thrust=100.0,
        yaw_kp=1.0,
        yaw_kd=0.5,
        yaw_ki=0.0,
        pitch_kp=2.0,
        pitch_kd=0.5,
        pitch_ki=0.0,
        max_deflection=0.5,
    )
    base.update(changes)
    return TorpedoGains(**base)


def _command(gains, position, velocity, axis, axis_rate, path=X_AXIS, u=2.0):
    out = new_torpedo_buffers(1, 4)
    torpedo_command(
        gains,
        path.user_function,
        path.kind_code,
        path.params,
        np.array([1.0]),
        CRUCIFORM_RUDDER,
        CRUCIFORM_STERN,
        np.full(4, 0.5),
        new_surge_state(),
        new_guidance_state(),
        new_autopilot_state(),
        0.0,
        np.asarray(position, float),
        np.asarray(velocity, float),
        np.asarray(axis, float),
        np.asarray(axis_rate, float),
        u,
        out,
    )
    return out


def test_direction_angles_and_rates():
    psi, theta = math.radians(30.0), math.radians(-10.0)

    def x_of(psi, theta):
        return np.array(
            [math.cos(theta) * math.cos(psi), math.cos(theta) * math.sin(psi), math.sin(theta)]
        )

    psi_dot, theta_dot = 0.2, -0.05
    x = x_of(psi, theta)
    h = 1e-6
    x_dot = (
        x_of(psi + psi_dot * h, theta + theta_dot * h)
        - x_of(psi - psi_dot * h, theta - theta_dot * h)
    ) / (2 * h)
    angles = direction_angles(*x, *x_dot)
    np.testing.assert_allclose(angles, [psi, psi_dot, theta, theta_dot], rtol=1e-8, atol=1e-9)
    # a vertical direction: heading 0, no heading rate
    assert direction_angles(0.0, 0.0, 1.0, 0.1, 0.0, 0.0)[:3] == (0.0, 0.0, math.pi / 2)


def test_los_angles_on_the_x_axis_are_breivik_fossens():
    """On the x-axis, ``chi_d = -atan(y / Delta)`` and ``theta_d = atan(-z / Delta)`` (lateral and
    vertical offsets taken one at a time: the vector LOS normalises their sum)."""
    delta = 8.0
    gains = _gains(lookahead=delta)
    out = _command(gains, (3.0, 2.0, 0.0), (2.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert out.angles[1] == pytest.approx(-math.atan(2.0 / delta), abs=1e-14)
    assert out.angles[3] == pytest.approx(0.0, abs=1e-14)
    out = _command(gains, (3.0, 0.0, -1.5), (2.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert out.angles[3] == pytest.approx(math.atan(1.5 / delta), abs=1e-14)
    assert out.angles[1] == pytest.approx(0.0, abs=1e-14)
    np.testing.assert_allclose(out.cross_track, [0.0, -1.5], atol=1e-14)


def test_los_on_a_helix_points_along_its_tangent_on_the_path():
    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=20.0, pitch=15.0)
    point = helix.closest(np.array([20.0, 0.0, 0.0]))
    tangent = np.asarray(point.tangent)
    out = _command(_gains(), point.point, 2.0 * tangent, tangent, (0.0, 0.0, 0.0), path=helix)
    psi_t = math.atan2(tangent[1], tangent[0])
    theta_t = math.atan2(tangent[2], math.hypot(tangent[0], tangent[1]))
    assert out.angles[1] == pytest.approx(psi_t, abs=1e-12)
    assert out.angles[3] == pytest.approx(theta_t, abs=1e-12)
    assert theta_t == pytest.approx(math.atan(15.0 / (2 * math.pi * 20.0)), abs=1e-12)


def test_pid_autopilot_closed_form_and_anti_windup():
    state = new_autopilot_state()
    k_p, k_d, k_i, limit = 1.5, 0.4, 0.2, 0.5
    e, r = 0.1, -0.05
    outputs = [pid_autopilot(state, YAW, t, e, r, k_p, k_d, k_i, limit) for t in (0.0, 1.0, 2.5)]
    # zero-order hold: the integral at t holds e * t
    expected = [k_p * e + k_d * r + k_i * e * t for t in (0.0, 1.0, 2.5)]
    np.testing.assert_allclose(outputs, expected, rtol=1e-15)
    assert state.integral[PITCH] == 0.0  # the other axis is untouched
    # saturated with the error pushing further: the integral is frozen
    state = new_autopilot_state()
    big = 1.0
    assert pid_autopilot(state, PITCH, 0.0, big, 0.0, k_p, k_d, k_i, limit) == limit
    pid_autopilot(state, PITCH, 3.0, big, 0.0, k_p, k_d, k_i, limit)
    assert state.integral[PITCH] == 0.0
    # the error reversed: integration resumes (from the previous sample's error, held)
    out = pid_autopilot(state, PITCH, 4.0, -big, 0.0, k_p, k_d, k_i, limit)
    assert out == -limit
    assert state.integral[PITCH] == 0.0  # the previous error pushed into the limit: held
    pid_autopilot(state, PITCH, 5.0, -0.01, 0.0, k_p, k_d, k_i, limit)
    assert state.integral[PITCH] == 0.0  # saturated low with a negative error: frozen
    pid_autopilot(state, PITCH, 6.0, 0.01, 0.0, k_p, k_d, k_i, limit)
    assert state.integral[PITCH] == pytest.approx(-0.01)


def test_autopilot_signs_and_allocation():
    """Turned to port of the reference (psi > psi_d): a positive rudder (a starboard turn); nose
    above the reference (theta > theta_d): a negative stern plane (nose down). Both rudders get
    delta_r, both stern planes delta_s."""
    gains = _gains(yaw_kd=0.0, pitch_kd=0.0)
    c, s = math.cos(0.2), math.sin(0.2)
    out = _command(gains, (0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (c, s, 0.0), (0.0, 0.0, 0.0))
    assert out.deflection[0] == pytest.approx(gains.yaw_kp * 0.2)
    assert out.deflection[1] == 0.0
    np.testing.assert_allclose(out.fins, [0.2, 0.2, 0.0, 0.0], rtol=1e-14)
    out = _command(gains, (0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (c, 0.0, s), (0.0, 0.0, 0.0))
    assert out.deflection[1] == pytest.approx(-gains.pitch_kp * 0.2)
    np.testing.assert_allclose(out.fins, [0.0, 0.0, -0.4, -0.4], rtol=1e-14)
    # saturated at max_deflection, then at each fin's limit
    out = _command(gains, (0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 0.0))
    assert out.deflection[0] == gains.max_deflection


def test_speed_pi_and_constant_thrust():
    out = _command(_gains(u_d=2.0, k_1p=40.0), (0, 0, 0), (1.5, 0, 0), (1, 0, 0), (0, 0, 0), u=1.5)
    assert out.thrusts[0] == pytest.approx(40.0 * 0.5)  # eq. (25) at the first sample
    out = _command(
        _gains(speed_control=False, thrust=33.0), (0, 0, 0), (1, 0, 0), (1, 0, 0), (0, 0, 0)
    )
    assert out.thrusts[0] == 33.0


def test_fin_shares_cruciform_and_x_tail():
    # torpedo.urdf's fins: rudders (axis z) above and below, stern planes (axis y) to the sides;
    # moment r x (a x e_x) with r = (-0.71, 0, +-0.17) or (-0.71, +-0.17, 0)
    moments = []
    for r, a in (
        ((-0.71, 0.0, 0.17), (0, 0, 1)),
        ((-0.71, 0.0, -0.17), (0, 0, 1)),
        ((-0.71, 0.17, 0.0), (0, 1, 0)),
        ((-0.71, -0.17, 0.0), (0, 1, 0)),
    ):
        moments.append(np.cross(r, np.cross(a, (1.0, 0.0, 0.0))))
    rudder, stern = fin_share(moments)
    np.testing.assert_array_equal(rudder, CRUCIFORM_RUDDER)
    np.testing.assert_array_equal(stern, CRUCIFORM_STERN)
    # an X tail (fins at 45 degrees): each fin shares both, 1/sqrt(2) each
    k = 1.0 / math.sqrt(2.0)
    a = np.array([0.0, k, k])
    rudder, stern = fin_share([np.cross((-0.7, -0.12, 0.12), np.cross(a, (1.0, 0.0, 0.0)))])
    assert abs(rudder[0]) == pytest.approx(k) and abs(stern[0]) == pytest.approx(k)
    # a fin that only rolls the vehicle: no share
    np.testing.assert_array_equal(fin_share([(0.3, 0.0, 0.0)]), ([0.0], [0.0]))
