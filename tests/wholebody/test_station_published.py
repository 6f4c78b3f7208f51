"""Station keeping of UUV Simulator's RexROV as published (issue 32), with and without the Oberon7
arm, from the scenario files ``examples/station_rexrov.toml`` and
``station_rexrov_oberon7.toml``; the station controller carries RexROV's thruster dynamics.

Tolerances stated in advance, as for rov8 (docs/source/station_keeping.md): within 1 cm and 1
degree after 30 s in a 0.2 m/s current the model is not told of, thrusts within UUV Simulator's
2000 N, everything asked produced once settled.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_hydro.laws.actuators import actuator_response
from aiauv_pin.errors import ArgumentError
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import load_scenario
from aiauv_pin.wholebody.station_controller import StationKeeping

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _load(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the lenient repairs (tests/model/test_lenient.py)
        return aiauv_pin.load_vehicle(
            scenario.vehicle, lenient=scenario.lenient, package_path=scenario.package_path
        )


@pytest.fixture(scope="module")
def rexrov():
    return _load(load_scenario(EXAMPLES / "station_rexrov.toml"))


def _run(name):
    scenario = load_scenario(EXAMPLES / name)
    return run_scenario(_load(scenario), scenario).trajectory


@pytest.mark.parametrize(
    ("name", "joints"), [("station_rexrov.toml", 0), ("station_rexrov_oberon7.toml", 8)]
)
def test_rexrov_holds_within_1_cm_and_1_degree_after_30_s(name, joints):
    trajectory = _run(name)
    t = np.asarray(trajectory.t)
    late = t >= 30.0
    error = trajectory.info["error"]
    assert np.linalg.norm(error[late, :3], axis=1).max() < 0.01  # [m]
    assert np.degrees(np.linalg.norm(error[late, 3:], axis=1).max()) < 1.0  # [deg]
    assert np.linalg.norm(error[0, :3]) > 0.25  # it did start away from the target
    produced = trajectory.info["thrust_produced"]
    assert np.abs(produced).max() <= 2000.0 and np.abs(produced[late]).max() < 500.0  # [N]
    assert np.abs(trajectory.info["residual"][late]).max() < 1e-3  # [N, N m]: all produced
    assert trajectory.q.shape[1] == 7 + joints
    if joints:  # the arm held by the joint servo near its reference
        assert np.abs(trajectory.q[late, 7:]).max() < 0.1  # [rad]


def test_thrust_follows_the_command_through_the_thruster_dynamics(rexrov):
    """The produced thrust is the compiled loop's actuator law (first order, 0.05 s) applied to
    the allocated command over the control period; without that period the controller refuses."""
    with pytest.raises(ArgumentError, match="actuator_period") as caught:
        StationKeeping(rexrov, np.zeros(3), np.eye(3))
    assert "\n" not in str(caught.value)
    period = 0.05
    controller = StationKeeping(rexrov, [0.3, -0.2, 0.1], np.eye(3), actuator_period=period)
    q, v = rexrov.neutral_configuration(), np.zeros(6)
    produced = np.zeros(8)
    for k in range(3):
        tau, info = controller(k * period, q, v)
        produced = [
            actuator_response(p, c, 2000.0, 0.05, np.inf, period)
            for p, c in zip(produced, info["thrust"], strict=True)
        ]
        np.testing.assert_allclose(info["thrust_produced"], produced, rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(
            tau, rexrov.thrust_matrix(q) @ info["thrust_produced"], rtol=1e-12, atol=1e-9
        )
    assert np.abs(info["thrust"] - info["thrust_produced"]).max() > 1.0  # a lag, not a copy
    controller.reset()
    np.testing.assert_array_equal(controller.thrust_produced, np.zeros(8))


def test_a_scenario_gives_package_folders_relative_to_itself():
    scenario = load_scenario(EXAMPLES / "station_rexrov.toml")
    (folder,) = scenario.package_path
    assert Path(folder).resolve() == EXAMPLES.parent / "tests" / "data" / "uuv_simulator_packages"
    assert scenario.lenient and Path(scenario.vehicle).is_file()
