"""The schemas of scenario files, sweep specs and vehicle specs (aiauv_pin.scenario.file_schemas and others).

Strict types (a bool or a string is not a number), unknown keys at every level, plausible ranges
and exact lengths, each refused in one line naming the key path and what is expected; the JSON
Schema that ``aiauv schema`` prints accepts every example and bundled spec; random tables never
raise anything but the project's error.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import tracemalloc
from pathlib import Path

import jsonschema
import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from aiauv_control.path_following import PathFollowingGains
from aiauv_control.paths import PATH_TYPES
from aiauv_hydro.currents import CURRENT_KEYS
from aiauv_pin._internal.schema_validation import json_schema
from aiauv_pin.app import cli
from aiauv_pin.builders.urdf_builder import bundled_spec_path
from aiauv_pin.builders.vehicle_spec import SpecError, load_spec, spec_from_dict
from aiauv_pin.builders.vehicle_spec_schema import VehicleSpecFile
from aiauv_pin.errors import AiauvError
from aiauv_pin.scenario.file_schemas import (
    CURRENT_TABLES,
    PATH_TABLES,
    ControllerTable,
    ScenarioFile,
)
from aiauv_pin.scenario.sweep_spec import SweepSpecError, load_sweep_spec, sweep_spec_from_dict
from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario, scenario_from_mapping

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
SWEEPS = sorted(EXAMPLES.glob("sweep_*.toml"))
SCENARIOS = sorted(set(EXAMPLES.glob("*.toml")) - set(SWEEPS))
VEHICLES = sorted((ROOT / "urdf").glob("*.toml"))
HELIX = {"type": "helix", "centre": [0, 0, 0], "axis": [0, 0, 1], "radius": 5.0, "pitch": 1.0}


def _one_line(error_type, reader, table) -> str:
    with pytest.raises(error_type) as error:
        reader(table)
    message = str(error.value)
    assert "\n" not in message, message
    return message


def _scenario(table) -> str:
    return _one_line(ScenarioFileError, scenario_from_mapping, table)


def _sweep(table) -> str:
    return _one_line(SweepSpecError, lambda t: sweep_spec_from_dict(t).points(), table)


def _vehicle(table) -> str:
    return _one_line(SpecError, spec_from_dict, table)


def _paper_spec() -> dict:
    return tomllib.loads(bundled_spec_path("uniform").read_text(encoding="utf-8"))


# --- one declaration -----------------------------------------------------------------------------


def test_the_tables_have_the_keys_of_the_classes_they_build():
    for name, cls in PATH_TYPES.items():
        keys = {f.name for f in dataclasses.fields(cls) if f.init}
        assert set(PATH_TABLES[name].model_fields) == keys | {"type"}, name
    for name, keys in CURRENT_KEYS.items():
        assert set(CURRENT_TABLES[name].model_fields) == set(keys), name
    gains = {f.name for f in dataclasses.fields(PathFollowingGains)}
    # "thrusts": the constant controller's (Scenario.thrusts), not a gain
    assert set(ControllerTable.model_fields) == gains | {"type", "thrusts"}


@pytest.mark.parametrize("model", [ScenarioFile, VehicleSpecFile])
def test_every_key_documents_its_unit_and_every_number_its_range(model):
    def walk(schema: dict, path: str):
        for name, node in schema.get("properties", {}).items():
            node = node if "$ref" not in node else root["$defs"][node["$ref"].rsplit("/", 1)[1]]
            if "properties" in node:
                walk(node, f"{path}{name}.")
                continue
            text = json.dumps(node)
            assert "[" in node.get("description", ""), f"{path}{name}: no unit"
            if '"number"' in text:
                assert "Minimum" in text or "minimum" in text, f"{path}{name}: no range"
                assert "aximum" in text, f"{path}{name}: no range"

    root = json_schema(model)
    walk(root, "")
    for definition in root["$defs"].values():
        walk(definition, f"{definition['title']}.")


# --- one line naming the key ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        # a bool or a string is not a number (both were coerced to 1.0 and 19.0 before)
        (
            {"controller": {"k_d": True}},
            "controller.k_d: expected a number in (0, 1e4] (a bool is not a number), got True",
        ),
        ({"controller": {"k_d": "19"}}, "controller.k_d: expected a number in (0, 1e4], got '19'"),
        ({"duration": False}, "duration: expected a number in (0, 1e5] (a bool is not a number)"),
        ({"start": {"surge": "1"}}, "start.surge: expected a number in [-10, 10], got '1'"),
        ({"continuous_joints": 1}, "continuous_joints: expected true or false, got 1"),
        ({"path": {**HELIX, "radius": "5"}}, "path.helix.radius: expected a number"),
        # unknown keys at every level
        ({"durations": 3.0}, "durations: unknown key (expected case, vehicle, duration"),
        ({"start": {"speed": 1.0}}, "start.speed: unknown key (expected position, heading, surge)"),
        ({"path": {**HELIX, "k": 1}}, "path.helix.k: unknown key"),
        (
            {"path": {"type": "line", "point": [0] * 3, "direction": [1, 0, 0], "radius": 1}},
            "path.line.radius: unknown key",
        ),
        (
            {"path": {"type": "waypoints", "points": [[0] * 3, [1] * 3], "x": 1}},
            "path.waypoints.x: unknown key",
        ),
        ({"current": {"period": 3.0}}, "current.constant.period: unknown key"),
        (
            {"current": {"type": "shear", "gradient": [0] * 3, "phase": 0}},
            "current.shear.phase: unknown",
        ),
        ({"controller": {"kd": 1.0}}, "controller.kd: unknown key (expected type, u_d, k_e"),
        ({"output": {"csv": 1.0}}, "output.csv: unknown key (expected csv_period)"),
        # plausible ranges
        (
            {"current": {"velocity": [1e6, 0, 0]}},
            "current.constant.velocity[0]: expected a number in [-10, 10]",
        ),
        (
            {"current": {"type": "tidal", "amplitude": [0, 0.1, 0], "period": 1e-300}},
            "current.tidal.period: expected a number in [1, 1e7], got 1e-300",
        ),
        (
            {"controller": {"k_d": 1e308}},
            "controller.k_d: expected a number in (0, 1e4], got 1e+308",
        ),
        ({"output": {"csv_period": 1e308}}, "output.csv_period: expected a number in [1e-6, 1e5]"),
        (
            {"duration": 10.0, "output": {"csv_period": 20.0}},
            "output.csv_period: must not exceed the duration (10 s)",
        ),
        ({"duration": 100.0, "dt": 20.0}, "dt: expected a number in [1e-6, 10], got 20.0"),
        ({"duration": 0.5, "dt": 0.8}, "dt: must not exceed the duration (0.5 s)"),
        ({"dt": 0.0}, "dt: expected a number in [1e-6, 10], got 0.0"),
        ({"controller": {"u_d": 100.0}}, "controller.u_d: expected a number in (0, 10]"),
        ({"controller": {"q_max": 4.0}}, "controller.q_max: expected a number in (0, pi]"),
        ({"start": {"position": [0, math.inf, 0]}}, "start.position[1]: expected a number"),
        # lengths
        (
            {"controller": {"k_e": [1, 2, 3]}},
            "controller.k_e: expected a number in (0, 100] or a list of 2 numbers, each in (0, 100]",
        ),
        ({"start": {"position": [0, 1]}}, "start.position: expected a list of 3 numbers, each in"),
        (
            {"path": {"type": "waypoints", "points": [[0, 0, 0]]}},
            "path.waypoints.points: expected a list of 2 to 10000",
        ),
        (
            {"path": {"type": "spiral"}},
            "path.type: expected one of line, helix, waypoints, got 'spiral'",
        ),
        (
            {"path": {"point": [0, 0, 0]}},
            "path.type: expected one of line, helix, waypoints, missing",
        ),
    ],
)
def test_bad_scenarios_are_one_line_naming_the_key(table, expected):
    message = _scenario(table)
    assert message.startswith(expected.split(":")[0] + ":"), message
    assert expected in message, message


def test_a_file_with_several_problems_names_the_first_and_counts_the_rest():
    message = _scenario({"duration": "x", "dt": True, "controller": {"k_p": -1.0}})
    assert message.startswith("duration: expected a number"), message
    assert message.endswith("(and 2 more problems)"), message
    # a misspelt key is named first: it often explains the rest
    message = _scenario({"path": {"type": "line", "piont": [0, 0, 0], "direction": [1, 0, 0]}})
    assert message.startswith("path.line.piont: unknown key"), message


def test_k_e_is_a_number_or_a_pair():
    assert scenario_from_mapping({"controller": {"k_e": 0.2}}).controller_gains.k_e == 0.2
    gains = scenario_from_mapping({"controller": {"k_e": [0.1, 0.2]}}).controller_gains
    assert gains.k_e == (0.1, 0.2)
    message = _sweep({"controller": {"k_e": [1.0, 2.0, 3.0]}})
    assert message.startswith("controller.k_e: expected a number in (0, 100] or a list of 2")
    assert _sweep({"k_e": [0.1, 0.2, 0.3]}).startswith("k_e: expected a number")


@pytest.mark.parametrize(
    ("table", "expected"),
    [
        ({"k_d": True}, "k_d: expected a number in (0, 1e4] (a bool is not a number)"),
        ({"controller": {"k_d": "19"}}, "controller.k_d: expected a number in (0, 1e4], got '19'"),
        (
            {"grid": {"start": {"position": {"y": [1.0, "a"]}}}},
            "grid.start.position.y[1]: expected a number",
        ),
        ({"colour": 1}, "colour: unknown key"),
        ({"grid": {"controller": {"kd": [1.0]}}}, "grid.controller.kd: unknown key"),
        ({"random": {"samples": 2, "k_p": {"gauss": [1, 2]}}}, "random.k_p: expected a table"),
        (
            {"random": {"samples": 2.0, "k_p": {"normal": [1, 2]}}},
            "random.samples: expected a whole number",
        ),
        (
            {"random": {"samples": True, "k_p": {"normal": [1, 2]}}},
            "random.samples: expected a whole number",
        ),
        (
            {"grid": {"current.velocity.x": [20.0]}},
            "grid.current.velocity.x[0]: expected a number in [-10, 10]",
        ),
        (
            {"grid": {"k_p": {"linspace": [1.0, 2.0, 1e9]}}},
            "grid.k_p: count must be a whole number",
        ),
        ({"grid": "k_p"}, "grid: expected a table, got 'k_p'"),
        (
            {"path": {"points": [[0, 0, 0], [1, 0, 0]]}},
            "path.points: set in the base scenario file",
        ),
    ],
)
def test_bad_sweep_specs_are_one_line_naming_the_key(table, expected):
    message = _sweep(table)
    assert expected in message, message


@pytest.mark.parametrize(
    ("path", "value", "expected"),
    [
        (("gravity",), True, "gravity: expected a number in [0, 100] (a bool is not a number)"),
        (("radius",), "0.085", "radius: expected a number in (0, 10], got '0.085'"),
        (("module", 0, "length"), 1e308, "module 'link1'.length: expected a number in (0, 100]"),
        (("module", 0, "colour"), 1, "module 'link1'.colour: unknown key"),
        (
            ("module", 2, "thruster", 0, "colour"),
            1,
            "module 'link3'.thruster 'link3_z'.colour: unknown",
        ),
        (
            ("module", 2, "thruster", 0, "max_thrust"),
            1e30,
            ".max_thrust: expected a number in (0, 1e7]",
        ),
        (
            ("module", 2, "cg_offset"),
            [0, 0, 0, 0],
            "module 'link3'.cg_offset: expected a list of 3",
        ),
        (("module", 0, "joint"), True, "module 'link1'.joint: expected one of x, y, z, got True"),
        (("colour",), "red", "colour: unknown key"),
    ],
)
def test_bad_vehicle_specs_are_one_line_naming_the_key(path, value, expected):
    table = copy.deepcopy(_paper_spec())
    target = table
    for part in path[:-1]:
        target = target[part]
    target[path[-1]] = value
    message = _vehicle(table)
    assert expected in message, message


def test_a_linspace_count_is_refused_before_anything_is_allocated():
    tracemalloc.start()
    try:
        for count in (1e9, 10**9, 400 * 400):
            spec = {"grid": {"k_p": {"linspace": [1.0, 2.0, count]}}, "k_d": 12.0}
            with pytest.raises(SweepSpecError):
                sweep_spec_from_dict(spec)
        spec = {"grid": {"k_p": {"linspace": [1.0, 2.0, 1000]}, "k_d": {"geomspace": [1, 2, 1000]}}}
        with pytest.raises(SweepSpecError, match="expands to 1000000 runs, more than 100000"):
            sweep_spec_from_dict(spec)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 64 * 2**20  # 1e9 floats would be 7.45 GiB


# --- aiauv schema and the examples ---------------------------------------------------------------


def _printed_schema(kind: str, capsys) -> dict:
    assert cli.main(["schema", kind]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema)
    return schema


def test_every_example_and_bundled_spec_passes_the_printed_schema_and_its_reader(capsys):
    validators = {
        kind: jsonschema.Draft202012Validator(_printed_schema(kind, capsys))
        for kind in ("scenario", "sweep", "vehicle")
    }
    assert SCENARIOS and SWEEPS and VEHICLES
    for kind, files, reader in (
        ("scenario", SCENARIOS, load_scenario),
        ("sweep", SWEEPS, load_sweep_spec),
        ("vehicle", VEHICLES, load_spec),
    ):
        for path in files:
            table = tomllib.loads(path.read_text(encoding="utf-8"))
            errors = [e.message for e in validators[kind].iter_errors(table)]
            assert not errors, (path.name, errors)
            reader(path)  # and the reader accepts it
    # the printed schema refuses what the reader refuses
    scenario = validators["scenario"]
    for bad in (
        {"controller": {"k_d": True}},
        {"durations": 1.0},
        {"controller": {"k_e": [1, 2, 3]}},
    ):
        assert not scenario.is_valid(bad), bad
    assert not validators["sweep"].is_valid({"grid": {"k_p": [True]}})
    assert not validators["vehicle"].is_valid({**_paper_spec(), "gravity": "9.81"})


def test_schema_needs_a_known_kind(capsys):
    with pytest.raises(SystemExit):
        cli.main(["schema", "robot"])
    assert "invalid choice" in capsys.readouterr().err


# --- property: nothing but the project's error escapes -------------------------------------------

_KEYS = [
    *ScenarioFile.model_fields,
    *ControllerTable.model_fields,
    "position", "heading", "surge", "point", "direction", "centre", "axis", "radius", "pitch",
    "points", "velocity", "amplitude", "period", "phase", "gradient", "reference_z", "csv_period",
    "line", "helix", "waypoints", "tidal", "shear", "constant", "euler", "x",
]  # fmt: skip
_SCALARS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**30), 10**30),
    st.booleans(),
    st.sampled_from(_KEYS),
    st.text(max_size=5),
)
_VALUES = st.recursive(
    _SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(_KEYS), inner, max_size=4)
    ),
    max_leaves=12,
)


@seed(20240601)
@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(st.dictionaries(st.sampled_from(_KEYS), _VALUES, max_size=6))
def test_random_scenario_tables_raise_only_the_projects_error(table):
    try:
        scenario_from_mapping(table)
    except ScenarioFileError as error:
        assert "\n" not in str(error)
    except AiauvError as error:  # pragma: no cover - any other project error is a finding
        pytest.fail(f"{type(error).__name__} instead of ScenarioFileError: {error}")
