"""Sweeps on a base scenario file: one schema for scenario files and sweep specs, older names as
aliases, run ids that follow the base file, one-line errors, and a short sweep on a yawed line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from aiauv_pin.model.loading import bundled_urdf, load_vehicle
from aiauv_pin.scenario.definition import run_scenario, summary
from aiauv_pin.scenario.parameters import ALIASES, SCHEMA, scalar_parameters
from aiauv_pin.scenario.sweep_runner import flatten_summary, read_table, run_sweep
from aiauv_pin.scenario.sweep_spec import (
    PARAMETERS,
    SweepSpecError,
    load_sweep_spec,
    scenario_from_parameters,
    scenario_parameters,
    sweep_spec_from_toml,
)
from aiauv_pin.scenario.toml_file import TABLES as FILE_TABLES
from aiauv_pin.scenario.toml_file import TOP_LEVEL as FILE_TOP_LEVEL
from aiauv_pin.scenario.toml_file import load_scenario

# a line at 45 deg in the horizontal plane, a lateral current, one gain changed from the paper's
YAWED_LINE = """
case = "uniform"
duration = 3.0
dt = 0.01
method = "rk4"
[start]
position = [0.0, 1.0, 0.5]
[path]
type = "line"
point = [0.0, 0.0, 0.0]
direction = [1.0, 1.0, 0.0]
[current]
velocity = [0.0, 0.05, 0.0]
[controller]
k_p = 2.5
"""

HELIX = """
duration = 2.0
[start]
position = [11.0, 0.0, -1.0]
[path]
type = "helix"
centre = [0.0, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
radius = 10.0
pitch = 10.0
"""

# a new name ("path.direction.z") and an old one ("k_e") in the grid
SPEC = """
base = "base.toml"
[grid]
"path.direction.z" = [0.0, 0.5]
k_e = [0.05, 0.1]
"""


def _write(folder: Path, spec: str = SPEC, base: str = YAWED_LINE) -> Path:
    (folder / "base.toml").write_text(base, encoding="utf-8")
    path = folder / "spec.toml"
    path.write_text(spec, encoding="utf-8")
    return path


def _ids(folder: Path, spec: str = SPEC) -> list[str]:
    return [p.run_id for p in sweep_spec_from_toml(spec, folder).points()]


# --- one schema ----------------------------------------------------------------------------------


def test_scenario_files_and_sweep_specs_share_one_table_of_names():
    assert FILE_TOP_LEVEL == tuple(name for name in SCHEMA if "." not in name)
    assert FILE_TABLES["start"] == ("position", "heading", "surge")
    for name, (parameter, component) in scalar_parameters().items():
        assert name in PARAMETERS
        assert parameter.unit  # every quantity documented with its unit
        assert name == (parameter.name if component is None else f"{parameter.name}.{component}")
    for new in (
        "path.radius",
        "path.pitch",
        "path.corner_radius",
        "path.direction.x",
        "current.velocity.y",
        "current.period",
        "start.surge",
        "controller.k_d",
    ):
        assert new in PARAMETERS
    for old, new in ALIASES.items():
        if isinstance(new, str):
            assert PARAMETERS[old][0] == PARAMETERS[new][0]


def test_resolved_values_combine_the_base_and_the_grid(tmp_path):
    _write(tmp_path)
    spec = load_sweep_spec(tmp_path / "spec.toml")
    points = spec.points()
    assert len(points) == 4
    directions = set()
    for point in points:
        p = point.parameters
        assert p["path.type"] == "line" and p["path.point.x"] == 0.0
        directions.add(tuple(p[f"path.direction.{a}"] for a in "xyz"))
        assert (p["start.position.x"], p["start.position.y"], p["start.position.z"]) == (
            0.0,
            1.0,
            0.5,
        )
        assert p["current.type"] == "constant" and p["current.velocity.y"] == 0.05
        assert p["controller.type"] == "paper"
        assert p["controller.k_p"] == 2.5  # from the base
        assert p["controller.k_d"] == 19.0  # the uniform case's default
        assert p["controller.k_e.y"] == p["controller.k_e.z"]
        assert p["duration"] == 3.0 and p["dt"] == 0.01
        # the resolved parameters rebuild the same scenario
        # (a unit direction normalised again may move by one rounding)
        rebuilt = scenario_parameters(scenario_from_parameters(p))
        assert rebuilt.keys() == p.keys() - {"vehicle_sha256"}
        for key, value in rebuilt.items():
            if key.startswith("path.direction."):
                assert math.isclose(value, p[key], rel_tol=4e-16, abs_tol=0.0), key
            else:
                assert value == p[key], key
    assert {p.parameters["controller.k_e.y"] for p in points} == {0.05, 0.1}
    # the direction as the line reader normalises it: (1, 1, z) / |(1, 1, z)|
    expected = set()
    for z in (0.0, 0.5):
        norm = math.sqrt(2.0 + z * z)
        expected.add((1.0 / norm, 1.0 / norm, z / norm))
    assert len(directions) == 2
    for got in directions:
        assert any(
            all(
                math.isclose(g, e, rel_tol=1e-15, abs_tol=0) for g, e in zip(got, want, strict=True)
            )
            for want in expected
        )


def test_spec_parameters_override_the_base_under_either_name(tmp_path):
    _write(tmp_path)
    old = sweep_spec_from_toml(
        'base = "base.toml"\nduration = 2.0\n"initial_offset.y" = 3.0\nk_d = 15.0', tmp_path
    ).points()[0]
    new = sweep_spec_from_toml(
        'base = "base.toml"\nduration = 2.0\n[start]\nposition.y = 3.0\n[controller]\nk_d = 15.0',
        tmp_path,
    ).points()[0]
    assert old.run_id == new.run_id
    p = old.parameters
    assert p["duration"] == 2.0  # the spec wins over the base
    assert (p["start.position.x"], p["start.position.y"], p["start.position.z"]) == (0.0, 3.0, 0.5)
    assert p["controller.k_d"] == 15.0 and p["controller.k_p"] == 2.5
    # a whole vector under its old name, and a case change moving k_d with it
    current = sweep_spec_from_toml(
        'base = "base.toml"\ncurrent = [0.1, 0.0, 0.0]\ncase = "stabilised"', tmp_path
    ).points()[0]
    assert [current.parameters[f"current.velocity.{a}"] for a in "xyz"] == [0.1, 0.0, 0.0]
    assert current.parameters["controller.k_d"] == 12.0
    assert current.vehicle == bundled_urdf("stabilised")
    heading = sweep_spec_from_toml(
        'base = "base.toml"\n"start.heading" = [0.0, 2.0, 0.0]', tmp_path
    ).points()[0]
    assert [heading.parameters[f"start.heading.{a}"] for a in "xyz"] == [0.0, 2.0, 0.0]
    assert points_heading_default(tmp_path) == [None, None, None]


def points_heading_default(folder: Path) -> list:
    point = sweep_spec_from_toml('base = "base.toml"', folder).points()[0]
    return [point.parameters[f"start.heading.{a}"] for a in "xyz"]


def test_a_helix_base_with_a_grid_over_its_radius(tmp_path):
    spec = 'base = "base.toml"\n[grid]\n"path.radius" = [8.0, 12.0]\n"initial_surge" = [0.0, 0.3]'
    _write(tmp_path, spec, HELIX)
    points = sweep_spec_from_toml(spec, tmp_path).points()
    assert len(points) == 4
    assert {p.parameters["path.radius"] for p in points} == {8.0, 12.0}
    assert {p.parameters["start.surge"] for p in points} == {0.0, 0.3}
    assert all(p.parameters["path.pitch"] == 10.0 for p in points)
    assert all("path.direction.x" not in p.parameters for p in points)


def test_run_ids_follow_the_resolved_base_scenario(tmp_path):
    _write(tmp_path)
    ids = _ids(tmp_path)
    assert len(set(ids)) == 4
    (tmp_path / "base.toml").write_text("# a comment\n" + YAWED_LINE, encoding="utf-8")
    assert _ids(tmp_path) == ids  # the same scenario
    for old, new in (
        ("point = [0.0, 0.0, 0.0]", "point = [0.0, 0.5, 0.0]"),  # path
        ("velocity = [0.0, 0.05, 0.0]", "velocity = [0.0, 0.0, 0.0]"),  # current
        ("k_p = 2.5", 'type = "none"\nk_p = 2.5'),  # controller type
        ("position = [0.0, 1.0, 0.5]", "position = [0.0, 1.0, 0.6]"),  # start
        ("dt = 0.01", "dt = 0.005"),  # run settings
    ):
        assert old in YAWED_LINE
        (tmp_path / "base.toml").write_text(YAWED_LINE.replace(old, new), encoding="utf-8")
        changed = _ids(tmp_path)
        assert not set(changed) & set(ids), new
    # a base-file vehicle enters through its content
    (tmp_path / "copy.urdf").write_bytes(bundled_urdf("uniform").read_bytes())
    (tmp_path / "base.toml").write_text('vehicle = "copy.urdf"\n' + YAWED_LINE, encoding="utf-8")
    assert _ids(tmp_path) == ids
    (tmp_path / "copy.urdf").write_text(
        bundled_urdf("uniform").read_text(encoding="utf-8") + "<!-- changed -->\n",
        encoding="utf-8",
    )
    assert not set(_ids(tmp_path)) & set(ids)


@pytest.mark.parametrize(
    ("spec", "base", "expected"),
    [
        ('[grid]\n"start.positon.y" = [1.0]', None, "grid.start.positon.y: unknown key"),
        ('k_p = 1.0\n"controller.k_p" = 2.0', None, "both 'k_p' and 'controller.k_p' are given"),
        (
            'k_p = 1.0\n[grid]\n"controller.k_p" = [1.0, 2.0]',
            None,
            "[grid]: 'controller.k_p' is also set in fixed parameters (as 'k_p')",
        ),
        (
            '"current.y" = 0.1\n[current]\nvelocity = [0.0, 0.2, 0.0]',
            None,
            "both 'current.y' and 'current.velocity' are given",
        ),
        ('[grid]\nk_e = [0.1]\n"controller.k_e.z" = [0.2]', None, "both 'k_e' and"),
        ('[path]\ntype = "helix"', None, "path.type: set in the base scenario file"),
        ("base = 3", None, "base: expected a non-empty string, got 3"),
        ('base = "missing.toml"', None, "base: scenario file"),
        ('base = "base.toml"', "[path\n", "base base.toml: not valid TOML"),
        ('base = "base.toml"', "durattion = 3.0", "base base.toml: durattion: unknown key"),
        (
            'base = "base.toml"',
            '[path]\ntype = "line"\npoint = [0, 0, 0]\ndirection = [0, 0, 0]',
            "base base.toml: path.line.direction",
        ),
        ('base = "base.toml"\n"path.radius" = 3.0', YAWED_LINE, "path.line.radius: unknown key"),
        ('base = "base.toml"\n"start.heading.x" = 1.0', YAWED_LINE, "give the whole vector"),
        ('[grid]\n"path.pitch" = [1.0, 2.0]', None, "path.line.pitch: unknown key"),
    ],
)
def test_bad_specs_and_bases_get_one_line(tmp_path, spec, base, expected):
    if base is not None:
        (tmp_path / "base.toml").write_text(base, encoding="utf-8")
    with pytest.raises(SweepSpecError) as error:
        sweep_spec_from_toml(spec, tmp_path).points()
    message = str(error.value)
    assert "\n" not in message
    assert expected in message, message


# --- a short sweep on Dask -----------------------------------------------------------------------

E2E_SPEC = """
base = "base.toml"
duration = 2.0
initial_surge = 0.2               # an older name, fixed
[grid]
"path.direction.z" = [0.0, 0.2]   # a scenario-file name
"controller.type" = ["paper", "none"]
"""


def test_a_sweep_on_a_base_scenario_writes_the_path_metrics(tmp_path):
    pytest.importorskip("distributed")
    spec_path = _write(tmp_path, E2E_SPEC)
    out = tmp_path / "out"
    report = run_sweep(spec_path, out, workers=1, progress=False, plots=False)
    assert report.counts["complete"] == 4 and report.executed == 4
    rows = read_table(out / "results.csv")
    columns = set(rows[0])
    assert {"final.cross_track_error", "settling_time.cross_track_5cm", "final.u"} <= columns
    assert {"path.direction.z", "controller.type", "start.surge", "controller.k_p"} <= columns
    assert "final.p_y" not in columns and "settling_time.p_y_5cm" not in columns  # not the x-axis
    points = load_sweep_spec(spec_path).points()
    assert [row["run_id"] for row in rows] == [p.run_id for p in points]
    vehicle = load_vehicle(bundled_urdf("uniform"))
    for row, point in zip(rows, points, strict=True):
        assert row["status"] == "complete"
        assert float(row["start.surge"]) == 0.2 and float(row["duration"]) == 2.0
        assert (row["final.u"] == "") == (row["controller.type"] == "none")
        # the worker ran exactly the scenario of the resolved parameters
        scenario = scenario_from_parameters(point.parameters)
        expected = flatten_summary(summary(run_scenario(vehicle, scenario)))
        for key in ("final.cross_track_error", "final.position.0", "total_thruster_work"):
            if key in expected:
                assert math.isclose(float(row[key]), expected[key], rel_tol=1e-12), key
    # run again: nothing to do
    again = run_sweep(spec_path, out, workers=1, progress=False, plots=False)
    assert again.executed == 0 and again.skipped == 4


def test_example_base_scenarios_load():
    examples = Path(__file__).resolve().parents[2] / "examples"
    for name in ("line_diagonal.toml", "helix.toml"):
        spec = sweep_spec_from_toml(f'base = "{name}"\nduration = 1.0', examples)
        (point,) = spec.points()
        assert (
            scenario_parameters(load_scenario(examples / name))["path.type"]
            == point.parameters["path.type"]
        )
