"""Actuators in the compiled loop: fin angles and thrusts follow their commands with the exact
first-order response and the rate limits, and the torpedo example turns and climbs on its fins."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin

numba = pytest.importorskip("numba")

from aiauv_pin.controllers.compiled_controller import CompiledController  # noqa: E402
from aiauv_pin.errors import ArgumentError  # noqa: E402
from aiauv_pin.kernels.articulated_body import kinematics, thrust_into  # noqa: E402

TORPEDO = Path(__file__).resolve().parents[2] / "examples" / "vehicles" / "torpedo.urdf"
DT = 0.01


@numba.njit
def fin_steps(t, q, v, model, workspace, parameters, state, tau, info):
    """Thrust parameters[0] from t = 0; from t = parameters[3] the rudders at parameters[1] and
    the stern planes at parameters[2]; logs the four fin angles and the produced thrust."""
    kinematics(model.bodies, q, v, workspace)
    thrust_into(model, workspace, parameters[:1], tau)
    on = t >= parameters[3] - 1e-9
    rudder = parameters[1] if on else 0.0
    stern = parameters[2] if on else 0.0
    workspace.fin_command[0] = rudder
    workspace.fin_command[1] = rudder
    workspace.fin_command[2] = stern
    workspace.fin_command[3] = stern
    for k in range(4):
        info[k] = workspace.fin_angle[k]
    info[4] = workspace.thrust[0]


def run(path, thrust, rudder, stern, t_step, duration):
    vehicle = aiauv_pin.load_vehicle(path)
    controller = CompiledController(
        fin_steps,
        np.array([thrust, rudder, stern, t_step]),
        info_shapes={"fins": (4,), "thrust": ()},
    )
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    return aiauv_pin.simulate(vehicle, q0, v0, duration, DT, controller)


def variant(tmp_path, old: str, new: str) -> Path:
    path = tmp_path / "torpedo_variant.urdf"
    text = TORPEDO.read_text()
    assert old in text
    path.write_text(text.replace(old, new))
    return path


def yaw_rate_and_pitch(trajectory):
    """Yaw rate about the world up axis [rad/s] and nose elevation [rad] of the last row."""
    q, v = trajectory.q[-1], trajectory.v[-1]
    x, y, z, w = q[3:7]
    rotation = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    return (rotation @ v[3:6])[2], math.asin(rotation[2, 0])


def test_lags_follow_the_exact_first_order_response_and_the_rudder_turns_to_starboard():
    trajectory = run(TORPEDO, 40.0, 0.2, 0.0, 10.0, 30.0)
    t = trajectory.t
    # the propeller: time constant 1 s from rest, command 40 N at t = 0
    np.testing.assert_allclose(
        trajectory.info["thrust"], 40.0 * (1.0 - np.exp(-t / 1.0)), rtol=0.0, atol=1e-12
    )
    # the rudders: time constant 1 s from t = 10 s; the stern planes stay at zero
    expected = np.where(t >= 10.0 - 1e-9, 0.2 * (1.0 - np.exp(-(t - 10.0) / 1.0)), 0.0)
    fins = trajectory.info["fins"]
    np.testing.assert_allclose(fins[:, 0], expected, rtol=0.0, atol=1e-12)
    np.testing.assert_array_equal(fins[:, 0], fins[:, 1])
    assert np.all(fins[:, 2:] == 0.0)
    # straight and level before the rudder moves; a positive rudder turns to starboard
    before = np.searchsorted(t, 10.0)
    assert abs(trajectory.q[before, 1]) < 1e-6 and trajectory.v[before, 0] > 2.5
    yaw_rate, _ = yaw_rate_and_pitch(trajectory)
    assert yaw_rate < -0.2
    assert trajectory.q[-1, 1] < -1.0  # it has gone to starboard (-y)


def test_stern_planes_pitch_the_nose_up():
    trajectory = run(TORPEDO, 40.0, 0.0, 0.1, 5.0, 12.0)
    _, pitch_up = yaw_rate_and_pitch(trajectory)
    assert pitch_up > 0.05
    assert trajectory.q[-1, 2] > 0.3  # climbing


def test_rate_limits_and_instant_actuators(tmp_path):
    path = variant(
        tmp_path,
        'max_thrust="116" time_constant="1"',
        'max_thrust="116" max_rate="20"',
    )
    text = path.read_text().replace('time_constant="1"/>', 'max_rate="0.5"/>')
    path.write_text(text)
    trajectory = run(path, 40.0, 0.3, -0.7, 2.0, 5.0)
    t = trajectory.t
    np.testing.assert_allclose(
        trajectory.info["thrust"], np.minimum(20.0 * t, 40.0), rtol=0.0, atol=1e-12
    )
    rudder = np.clip(0.5 * (t - 2.0), 0.0, 0.3)
    np.testing.assert_allclose(trajectory.info["fins"][:, 0], rudder, rtol=0.0, atol=1e-12)
    # the stern planes' command -0.7 is clipped to the 30 degree limit
    stern = -np.clip(0.5 * (t - 2.0), 0.0, math.radians(30.0))
    np.testing.assert_allclose(trajectory.info["fins"][:, 2], stern, rtol=0.0, atol=1e-12)
    # without dynamics the command acts at once (the angle logged at a sample is the state
    # reached over the step before it: the command from the sample after the step)
    instant = variant(tmp_path, 'max_thrust="116" time_constant="1"', 'max_thrust="116"')
    instant.write_text(instant.read_text().replace(' time_constant="1"/>', "/>"))
    trajectory = run(instant, 40.0, 0.3, 0.0, 2.0, 3.0)
    fins = trajectory.info["fins"][:, 0]
    t = trajectory.t
    np.testing.assert_array_equal(fins, np.where(t > 2.0 + 1e-9, 0.3, 0.0))
    assert np.all(np.isnan(trajectory.info["thrust"]) | (trajectory.info["thrust"] == 0.0))


def test_a_python_controller_holds_the_fins_at_zero_and_refuses_thruster_lag(tmp_path):
    """Under a Python controller (a generalised force, which cannot command a fin) the fins are
    fixed surfaces at zero angle: the run equals the compiled loop's with every fin commanded to
    zero. A thruster with a lag has state only the compiled loop carries: one line."""
    instant = variant(tmp_path, 'max_thrust="116" time_constant="1"', 'max_thrust="116"')
    instant.write_text(instant.read_text().replace(' time_constant="1"/>', "/>"))
    vehicle = aiauv_pin.load_vehicle(instant)
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    compiled = run(instant, 40.0, 0.0, 0.0, 0.0, 2.0)
    thrust = np.array([40.0])
    python = aiauv_pin.simulate(
        vehicle, q0, v0, 2.0, DT, lambda t, q, v: vehicle.thrust_matrix(q) @ thrust
    )
    np.testing.assert_allclose(python.q[-1], compiled.q[-1], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(python.v[-1], compiled.v[-1], rtol=0.0, atol=1e-9)
    lagged = aiauv_pin.load_vehicle(TORPEDO)
    assert any(t.time_constant > 0.0 for t in lagged.hydro.thrusters)
    with pytest.raises(ArgumentError, match="thrusters with a lag") as caught:
        aiauv_pin.simulate(lagged, q0, v0, 1.0, DT, lambda t, q, v: np.zeros(lagged.nv))
    assert "\n" not in str(caught.value)
