"""The per-step API: ``Vehicle.step`` with thrusts and joint torques as controls."""

from __future__ import annotations

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.errors import ArgumentError


@pytest.fixture(scope="module")
def vehicles():
    return aiauv_pin.load_vehicle(), aiauv_pin.load_vehicle(backend="pinocchio")


def _state(vehicle, rng):
    q = vehicle.neutral_configuration()
    q[7:] = rng.uniform(-0.5, 0.5, vehicle.nv - 6)
    v = 0.3 * rng.normal(size=vehicle.nv)
    controls = np.concatenate(
        (rng.uniform(-50.0, 50.0, len(vehicle.thruster_names)), rng.uniform(-5, 5, vehicle.nv - 6))
    )
    return q, v, controls


def test_controls_enter_through_the_thrust_matrix(vehicles, rng):
    fast, _ = vehicles
    q, _, controls = _state(fast, rng)
    m = len(fast.thruster_names)
    expected = fast.thrust_matrix(q) @ controls[:m]
    expected[6:] += controls[m:]
    assert np.array_equal(fast.controls_to_forces(q, controls), expected)
    assert fast.n_controls == m + fast.nv - 6


@pytest.mark.parametrize("method", ["rk4", "euler", "midpoint"])
def test_step_is_the_compiled_step_of_those_forces(vehicles, rng, method):
    fast, _ = vehicles
    q, v, controls = _state(fast, rng)
    tau = fast.controls_to_forces(q, controls)
    q1, v1 = fast.step(q, v, controls, 0.01, method=method, current=[0.1, 0.0, 0.0], t=0.5)
    q2, v2 = fast.fast.step(q, v, tau, 0.01, method=method, current=[0.1, 0.0, 0.0], t=0.5)
    assert np.array_equal(q1, q2) and np.array_equal(v1, v2)


def test_step_matches_rk4_on_pinocchio(vehicles, rng):
    fast, reference = vehicles
    q, v, controls = _state(fast, rng)
    tau = reference.controls_to_forces(q, controls)
    q1, v1 = fast.step(q, v, controls, 0.01)
    q2, v2 = aiauv_pin.rk4_step(
        reference.model, lambda qq, vv: reference.acceleration(qq, vv, tau), q, v, 0.01
    )
    assert np.allclose(q1, q2, atol=1e-9) and np.allclose(v1, v2, atol=1e-9)


@pytest.mark.parametrize(
    "change",
    [
        {"controls": np.zeros(3)},
        {"controls": np.full(15, np.nan)},
        {"controls": "thrust"},
        {"dt": 0.0},
        {"dt": -1.0},
        {"method": "leapfrog"},
        {"q": np.zeros(4)},
    ],
)
def test_bad_arguments_give_one_line(vehicles, change):
    fast, _ = vehicles
    arguments = {
        "q": fast.neutral_configuration(),
        "v": np.zeros(fast.nv),
        "controls": np.zeros(fast.n_controls),
        "dt": 0.01,
        "method": "rk4",
    }
    arguments.update(change)
    method = arguments.pop("method")
    with pytest.raises(ArgumentError) as error:
        fast.step(*arguments.values(), method=method)
    assert "\n" not in str(error.value)


def test_the_pinocchio_backend_is_refused_in_one_line(vehicles):
    _, reference = vehicles
    with pytest.raises(ArgumentError, match="compiled backend") as error:
        reference.step(reference.neutral_configuration(), np.zeros(14), np.zeros(15), 0.01)
    assert "\n" not in str(error.value)
