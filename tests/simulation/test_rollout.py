"""Batch rollouts (:func:`aiauv_pin.rollout`): each run is bit-identical to
:func:`aiauv_pin.simulate`,
whatever the number of threads; bad shapes get one-line errors before anything runs."""

from __future__ import annotations

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
from aiauv_pin.errors import ArgumentError
from aiauv_pin.scenario.definition import PaperScenario, initial_state

DURATION, DT = 1.0, 0.01


@pytest.fixture(scope="module")
def vehicle():
    vehicle = aiauv_pin.load_vehicle()
    if vehicle.fast is None:
        pytest.skip("needs the compiled backend")
    return vehicle


def _starts(vehicle, offsets):
    states = [initial_state(vehicle, PaperScenario(initial_offset=o)) for o in offsets]
    return np.stack([q for q, _ in states]), np.stack([v for _, v in states])


def _controller(vehicle, k_e):
    gains = PaperScenario().controller_gains
    from dataclasses import replace

    return VehiclePathFollowing(vehicle, replace(gains, k_e=(k_e, k_e))).compiled()


@pytest.mark.parametrize("method", ["rk4", "midpoint"])
def test_every_run_equals_simulate_bit_for_bit_with_any_thread_count(vehicle, method):
    offsets = [(2.0, 2.0), (1.0, -0.5), (-1.5, 0.3)]
    gains = [0.05, 0.08, 0.1]
    q0, v0 = _starts(vehicle, offsets)
    laws = [_controller(vehicle, k) for k in gains]
    batches = [
        aiauv_pin.rollout(vehicle, q0, v0, DURATION, DT, laws, method=method, threads=threads)
        for threads in (1, 3)
    ]
    for i, k_e in enumerate(gains):
        law = _controller(vehicle, k_e)
        single = aiauv_pin.simulate(
            vehicle, q0[i], v0[i], DURATION, DT, law, method=method, servo=law.servo
        )
        for batch in batches:
            assert batch.status[i] == "complete" and batch.steps[i] == 100
            np.testing.assert_array_equal(batch.t, single.t)
            np.testing.assert_array_equal(batch.q[i], single.q)
            np.testing.assert_array_equal(batch.v[i], single.v)
            np.testing.assert_array_equal(batch.tau[i], single.tau)
            for key, value in single.info.items():
                np.testing.assert_array_equal(batch.info[key][i], value)
    # the runs differ (each got its own gains and start)
    assert not np.array_equal(batches[0].q[0], batches[0].q[1])


def test_one_controller_shared_by_many_starts_gets_a_private_state_per_run(vehicle):
    q0, v0 = _starts(vehicle, [(2.0, 2.0), (2.0, 2.0)])
    law = _controller(vehicle, 0.05)
    batch = aiauv_pin.rollout(vehicle, q0, v0, DURATION, DT, law, log_every=10, threads=2)
    assert batch.q.shape == (2, 11, vehicle.nq) and batch.t.shape == (11,)
    np.testing.assert_array_equal(batch.q[0], batch.q[1])  # same start, same law: same run


def test_a_diverging_run_stops_alone(vehicle):
    q0 = np.stack([vehicle.neutral_configuration()] * 2)
    v0 = np.zeros((2, vehicle.nv))
    v0[1, 0] = 1e200  # overflows at once
    batch = aiauv_pin.rollout(vehicle, q0, v0, 0.1, DT)
    assert list(batch.status) == ["complete", "diverged"]
    assert batch.steps[0] == 10 and batch.steps[1] < 10
    assert np.isnan(batch.q[1, -1]).all()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"q0": np.zeros((2, 5))}, r"q0 must have shape \(15,\) or \(N, 15\), got \(2, 5\)"),
        ({"v0": np.zeros((3, 14))}, "disagree on the run count"),
        ({"current": np.zeros((2, 2))}, r"current must have shape \(3,\) or \(N, 3\)"),
        ({"controller": "paper"}, "controller must be a CompiledController"),
        ({"q0": [[1.0, "x"]]}, "q0 must be an array of numbers"),
        ({"current": "still"}, "current must be a velocity"),
        ({"threads": 0}, "threads must be a whole number >= 1"),
        ({"dt": -1.0}, "dt"),
        ({"method": "rk5"}, "unknown method"),
        (
            {"method": "midpoint", "control_period": 2 * DT},
            "samples the controller inside every step: control_period must equal dt",
        ),
        ({"duration": 1e8}, r"GiB .*log less often"),  # 2 logs of 1e10 samples, before allocating
    ],
)
def test_bad_arguments_get_one_line_errors(vehicle, change, message):
    arguments = {
        "q0": np.stack([vehicle.neutral_configuration()] * 2),
        "v0": np.zeros((2, vehicle.nv)),
        "duration": 0.05,
        "dt": DT,
    }
    arguments.update(change)
    with pytest.raises(ArgumentError, match=message) as error:
        aiauv_pin.rollout(vehicle, **arguments)
    assert "\n" not in str(error.value)


def test_controllers_logging_different_diagnostics_are_refused(vehicle):
    from aiauv_pin.controllers.compiled_controller import CompiledController

    laws = [CompiledController.passive(), _controller(vehicle, 0.05)]
    with pytest.raises(ArgumentError, match="must log the same diagnostics"):
        aiauv_pin.rollout(
            vehicle, vehicle.neutral_configuration(), np.zeros(vehicle.nv), 0.1, DT, laws
        )
