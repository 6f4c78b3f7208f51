"""The constant-thrust controller (``[controller] type = "constant"``): records, saturation, and the
compiled run against the interpreted loop with ``tau = B(q) thrusts``."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.errors import ArgumentError
from aiauv_pin.scenario.definition import Scenario
from aiauv_pin.scenario.toml_file import scenario_from_mapping

EXAMPLES = Path(__file__).parents[2] / "examples" / "gz"


@pytest.fixture(scope="module")
def tethys():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return aiauv_pin.load_vehicle(
            EXAMPLES / "auv_controls.sdf", model_path=[EXAMPLES / "models"]
        )


def test_one_thrust_per_thruster_saturated(tethys):
    controller = CompiledController.constant(tethys, [-2500.0])
    np.testing.assert_array_equal(controller.parameters.thrusts, [-1000.0])  # max_thrust
    assert dict(controller.info_shapes) == {"thrust": (1,), "thruster_power": (1,)}
    with pytest.raises(ArgumentError, match="expected 1 finite numbers"):
        CompiledController.constant(tethys, [1.0, 2.0])
    with pytest.raises(ArgumentError, match="expected 1 finite numbers"):
        CompiledController.constant(tethys, [np.nan])


def test_scenario_needs_thrusts_with_constant_only():
    with pytest.raises(ValueError, match="thrusts go with controller 'constant'"):
        Scenario(controller="constant")
    with pytest.raises(ValueError, match="thrusts go with controller 'constant'"):
        Scenario(controller="none", thrusts=(1.0,))
    scenario = scenario_from_mapping({"controller": {"type": "constant", "thrusts": [-3, 4.5]}})
    assert scenario.thrusts == (-3.0, 4.5)


def test_compiled_run_is_the_interpreted_b_of_q_thrusts(tethys):
    if tethys.fast is None:
        pytest.skip("compiled backend unavailable")
    thrusts = np.array([-20.0])
    q0 = tethys.neutral_configuration()
    v0 = np.zeros(tethys.nv)
    compiled = aiauv_pin.simulate(
        tethys, q0, v0, 5.0, 0.01, CompiledController.constant(tethys, thrusts), method="rk4"
    )
    interpreted = aiauv_pin.simulate(
        tethys, q0, v0, 5.0, 0.01, lambda t, q, v: tethys.thrust_matrix(q) @ thrusts, method="rk4"
    )
    np.testing.assert_allclose(compiled.q[-1], interpreted.q[-1], rtol=0.0, atol=1e-9)
    np.testing.assert_allclose(compiled.v[-1], interpreted.v[-1], rtol=0.0, atol=1e-9)
    assert compiled.v[-1][0] < -0.5  # pushed along -x
    power = np.asarray(compiled.info["thruster_power"])[-1, 0]
    assert np.isclose(power, thrusts[0] * compiled.v[-1][0], rtol=1e-2)
