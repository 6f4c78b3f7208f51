"""Waves in scenario files, the Python API and sweeps (``[waves]``; docs/source/waves.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from aiauv_hydro.currents import WAVES, Current
from aiauv_hydro.waves import Waves, wave_velocity
from aiauv_pin.scenario.definition import Scenario
from aiauv_pin.scenario.parameters import SCHEMA, TABLES
from aiauv_pin.scenario.sweep_spec import (
    load_sweep_spec,
    scenario_from_parameters,
    scenario_parameters,
)
from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario, scenario_from_mapping

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
WAVE_FILES = sorted(EXAMPLES.glob("waves_*.toml"))


def test_the_wave_examples_load():
    assert len(WAVE_FILES) == 8
    for path in WAVE_FILES:
        scenario = load_scenario(path)
        assert isinstance(scenario.waves, Waves)
        water = scenario.water
        assert water.kind_code == WAVES
        depth = 5.0 if path.stem.endswith("_5m") else 20.0
        assert scenario.waves.surface_z == depth and scenario.start[2] == 0.0
        heading = math.pi if "_head_" in path.stem else math.pi / 2
        assert scenario.waves.heading == pytest.approx(heading, abs=1e-15)


def test_waves_add_to_a_constant_current():
    table = {
        "start": {"position": [0.0, 0.0, -3.0]},
        "current": {"velocity": [0.1, 0.2, 0.0]},
        "waves": {"height": 1.0, "period": 6.0, "heading": 0.5, "depth": 40.0},
    }
    scenario = scenario_from_mapping(table)
    sea = Waves(height=1.0, period=6.0, heading=0.5, depth=40.0)
    assert scenario.waves == sea
    expected = np.add(wave_velocity(2.0, 1.0, 1.0, -3.0, sea.parameters()), (0.1, 0.2, 0.0))
    np.testing.assert_allclose(scenario.water.velocity(2.0, (1.0, 1.0, -3.0)), expected, atol=1e-15)
    # the Python API: the same water
    api = Scenario(start_position=(0.0, 0.0, -3.0), current=(0.1, 0.2, 0.0), waves=sea)
    np.testing.assert_array_equal(api.water.parameters, scenario.water.parameters)
    direct = Current.waves(sea, velocity=(0.1, 0.2, 0.0))
    np.testing.assert_array_equal(direct.parameters, scenario.water.parameters)


def test_quasi_steady_waves_from_the_current_table():
    """``[current] unsteady = false`` reaches the waves' water (the quasi-steady model)."""
    table = {
        "start": {"position": [0.0, 0.0, 0.0]},
        "waves": {"height": 1.0, "period": 6.0, "surface_z": 5.0},
    }
    assert scenario_from_mapping(table).water.unsteady
    quasi = scenario_from_mapping({**table, "current": {"unsteady": False}})
    assert not quasi.water.unsteady and quasi.water.kind_code == WAVES
    assert not quasi.water.water_acceleration(1.0, (0.0, 0.0, 0.0)).any()
    sea = quasi.waves
    assert not Current.waves(sea, unsteady=False).unsteady
    assert Current.waves(sea).water_acceleration(1.0, (0.0, 0.0, 0.0)).any()
    rebuilt = scenario_from_parameters(scenario_parameters(quasi))
    assert not rebuilt.water.unsteady


@pytest.mark.parametrize(
    ("waves", "extra", "message"),
    [
        ({"height": 1.0, "period": 6.0}, {}, r"^waves\.surface_z: the start .* above the still"),
        ({"height": 1.0, "period": 6.0, "surface_z": 5.0, "depth": 2.5}, {}, "sea floor"),
        ({"height": 1.0, "period": 6.0, "surface_z": 5.0, "wave_length": 3.0}, {}, "wave_length"),
        ({"height": -1.0, "period": 6.0, "surface_z": 5.0}, {}, r"^waves\.height: expected"),
        (
            {"type": "jonswap", "height": 4.0, "period": 6.0, "surface_z": 5.0},
            {},
            r"^waves\.period: T_p = 6 s is below",
        ),
        (
            {"height": 1.0, "period": 6.0, "surface_z": 5.0, "depth": 20.0},
            {"path": {"type": "line", "point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, -0.2]}},
            r"^waves\.depth: the sea floor \(z = -15 m\) is above the path 78\.6 m ahead of",
        ),
        (
            {"height": 1.0, "period": 6.0, "surface_z": 5.0},
            {"path": {"type": "line", "point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.1]}},
            r"^waves\.surface_z: the path 52\.4 m ahead of the start .* above the still-water",
        ),
        (
            {"height": 1.0, "period": 6.0, "surface_z": 5.0},
            {"current": {"type": "shear", "gradient": [0.01, 0.0, 0.0]}},
            r"^waves: add to a constant current only, got a shear current$",
        ),
    ],
)
def test_bad_wave_tables_get_one_line(waves, extra, message):
    with pytest.raises(ScenarioFileError, match=message) as caught:
        scenario_from_mapping({"waves": waves, **extra})
    assert "\n" not in str(caught.value)


def test_wave_keys_are_scenario_and_sweep_keys():
    assert TABLES["waves"][:3] == ("type", "height", "period")
    for key in ("waves.height", "waves.period", "waves.heading", "waves.seed"):
        assert SCHEMA[key].sweepable
    assert SCHEMA["waves.height"].unit == "m" and SCHEMA["waves.period"].unit == "s"


def test_wave_parameters_round_trip_and_sweep(tmp_path):
    scenario = load_scenario(EXAMPLES / "waves_irregular_beam_20m.toml")
    parameters = scenario_parameters(scenario)
    assert parameters["waves.height"] == 1.5 and parameters["waves.type"] == "jonswap"
    assert parameters["current.type"] == "constant"
    rebuilt = scenario_from_parameters(parameters)
    assert rebuilt.waves == scenario.waves
    np.testing.assert_array_equal(rebuilt.water.parameters, scenario.water.parameters)
    assert "waves.height" not in scenario_parameters(Scenario())
    spec = tmp_path / "spec.toml"
    base = (EXAMPLES / "waves_regular_head_5m.toml").read_text()
    (tmp_path / "base.toml").write_text(base)
    spec.write_text(
        'base = "base.toml"\nduration = 2.0\n[grid]\n'
        '"waves.height" = [0.5, 1.0]\n"waves.period" = [5.0, 8.0]\n'
    )
    points = load_sweep_spec(spec).points()
    assert len(points) == 4
    seas = {(p.parameters["waves.height"], p.parameters["waves.period"]) for p in points}
    assert seas == {(0.5, 5.0), (0.5, 8.0), (1.0, 5.0), (1.0, 8.0)}
    for point in points:
        sea = scenario_from_parameters(point.parameters).waves
        assert (sea.height, sea.period) == (
            point.parameters["waves.height"],
            point.parameters["waves.period"],
        )
        assert sea.surface_z == 5.0


def test_a_fenton_wave_from_a_file():
    pytest.importorskip("raschii")
    table = {
        "start": {"position": [0.0, 0.0, -5.0]},
        "waves": {"type": "fenton", "height": 2.0, "period": 8.0, "depth": 15.0, "order": 8},
    }
    scenario = scenario_from_mapping(table)
    assert scenario.waves.order == 8 and scenario.water.parameters.size == 6 + 7 * 8
    rebuilt = scenario_from_parameters(scenario_parameters(scenario))
    assert rebuilt.waves == scenario.waves
