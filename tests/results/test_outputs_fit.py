"""Outputs that fit the run (issue 28, item 8).

Path quantities only for a run that follows a path, named in the path's frame; ``timeseries.csv``
with units and the whole state, read back exactly (a run rebuilt and replayed from it alone);
every figure's axes labelled with units; titles that name the output folder.
"""

from __future__ import annotations

import json
import re

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import aiauv_pin
from aiauv_control.paths import HelixPath, LinePath, WaypointPath
from aiauv_pin.app import cli
from aiauv_pin.results import figures, outputs, playback
from aiauv_pin.scenario.definition import Scenario, cross_track_axes, run_scenario, summary

#: A unit in brackets at the end of an axis label, e.g. "[m]", "[rad/s]", "[-]".
UNIT = re.compile(r"\[[^\]]+\]$")


@pytest.fixture(scope="module")
def vehicle():
    return aiauv_pin.load_vehicle()


@pytest.fixture(scope="module")
def paper_run(vehicle):
    """1 s of the paper's scenario (every diagnostic of its controller)."""
    return run_scenario(vehicle, Scenario(duration=1.0))


@pytest.fixture(scope="module")
def passive_run(vehicle):
    """1 s of a passive vehicle in a 0.2 m/s cross current: no path followed."""
    return run_scenario(vehicle, Scenario(duration=1.0, controller="none", current=(0, 0.2, 0)))


# --------------------------------------------------------------------- path quantities


def test_a_passive_run_records_its_motion_and_no_path_errors(passive_run, tmp_path):
    content = summary(passive_run)
    final = content["final"]
    for key in ("cross_track_error", "cross_track", "along_track", "p_y", "p_z"):
        assert key not in final, key
    assert content["settling_time"] == {} and content["path"] is None
    assert "cross_track_axes" not in content
    q, v = passive_run.trajectory.q, passive_run.trajectory.v
    assert final["base_position"] == q[-1, :3].tolist()
    np.testing.assert_array_equal(final["base_displacement"], q[-1, :3] - q[0, :3])
    assert final["base_distance"] == pytest.approx(np.linalg.norm(q[-1, :3] - q[0, :3]))
    assert final["base_speed"] == pytest.approx(np.linalg.norm(v[-1, :3]))
    assert 0.0 < final["base_speed"] < 0.2  # carried by the current, not yet at its speed
    assert {"cross_track", "path_s"}.isdisjoint(passive_run.trajectory.info)
    assert outputs.figures_of(passive_run) == outputs.MOTION_FIGURES
    assert outputs.default_path_points(passive_run) is None
    line = outputs.final_line(content)
    assert line.startswith("final base position = (") and "p_y" not in line
    assert "cross-track" not in line and "m from its start" in line
    columns = outputs.timeseries_columns(passive_run)
    assert {"e_1", "e_2", "s", "u"}.isdisjoint(columns) and {"p_x", "p_y", "p_z"} <= set(columns)


def test_a_run_that_follows_a_path_names_its_errors_in_the_path_frame(paper_run):
    content = summary(paper_run)
    final = content["final"]
    assert content["cross_track_axes"] == ["p_y", "p_z"]  # the paper's x-axis
    assert final["cross_track"] == [final["p_y"], final["p_z"]]
    assert final["along_track"] == paper_run.trajectory.info["path_s"][-1]
    assert outputs.final_line(content).startswith("final p_y = ")
    # another path: the distance and its components named by the frame, and the arc length
    content = dict(content, cross_track_axes=["horizontal", "vertical"])
    content["final"] = {k: v for k, v in final.items() if k not in ("p_y", "p_z")}
    line = outputs.final_line(content)
    assert line.startswith("final cross-track error = ") and "horizontal" in line
    assert "vertical" in line and "along-track s = " in line


def _frame_names(path, start, s_range=(0.0, 20.0)):
    return cross_track_axes(Scenario(path=path, start_position=start), s_range)


def test_cross_track_errors_are_named_by_what_the_path_normals_are():
    assert _frame_names(None, (0.0, 2.0, 2.0)) == ("p_y", "p_z")
    inclined = LinePath(point=(0.0, 0.0, 0.0), direction=(1.0, 1.0, 0.3))
    assert _frame_names(inclined, (0.0, 1.0, 0.0)) == ("horizontal", "vertical")
    # horizontal: an offset to the left of the direction of travel, in the horizontal plane,
    # is all e_1 (positive); an offset up in the vertical plane through the path is all e_2
    tangent = np.array(inclined.direction)
    left = np.cross([0.0, 0.0, 1.0], tangent)
    left /= np.linalg.norm(left)
    up = np.cross(tangent, left)
    point = 5.0 * tangent
    np.testing.assert_allclose(
        inclined.cross_track_error(point + 0.3 * left), [0.3, 0.0], atol=1e-12
    )
    np.testing.assert_allclose(inclined.cross_track_error(point + 0.2 * up), [0.0, 0.2], atol=1e-12)
    vertical = LinePath(point=(0.0, 0.0, 0.0), direction=(0.0, 0.0, 1.0))
    assert _frame_names(vertical, (1.0, 0.0, 0.0)) == ("N1", "N2")
    circle = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=0.0)
    assert _frame_names(circle, (10.0, 0.0, 0.0)) == ("horizontal", "vertical")
    upside_down = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, -1.0), radius=10.0, pitch=0.0)
    assert _frame_names(upside_down, (10.0, 0.0, 0.0)) == ("N1", "N2")  # N2 points down
    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=10.0)
    assert _frame_names(helix, (10.0, 0.0, 0.0)) == ("N1", "N2")
    flat = WaypointPath(points=[(0, 0, -5), (30, 0, -5), (50, 20, -5)], corner_radius=5.0)
    assert _frame_names(flat, (0.0, 1.0, -5.0), (0.0, 60.0)) == ("horizontal", "vertical")
    climbing = WaypointPath(points=[(0, 0, 0), (30, 0, 0), (50, 20, -5)], corner_radius=5.0)
    assert _frame_names(climbing, (0.0, 1.0, 0.0), (0.0, 60.0)) == ("N1", "N2")


# --------------------------------------------------------------------- timeseries.csv


def test_the_csv_header_carries_units_and_the_values_read_back_exactly(paper_run, tmp_path):
    path = outputs.write_timeseries(paper_run, tmp_path / "timeseries.csv")
    header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert all(UNIT.search(cell) for cell in header), header
    series = outputs.read_timeseries(path)
    units = series.units
    expected = {
        "t": "s",
        "p_x": "m",
        "e_1": "m",
        "s": "m",
        "u": "m/s",
        "phi_tilde": "rad",
        "omega_tilde_y": "rad/s",
        "x_ref_x": "-",
        "q_joint1": "rad",
        "qref_joint1": "rad",
        "tau_joint1": "N m",
        "v_joint1": "rad/s",
        "base_x": "m",
        "base_quat_w": "-",
        "base_u": "m/s",
        "base_r": "rad/s",
    }
    assert {name: units[name] for name in expected} == expected
    thrusters = [name for name in units if name.startswith("thrust_")]
    assert len(thrusters) == len(paper_run.thruster_names)
    assert {units[name] for name in thrusters} == {"N"}
    rows = outputs.csv_rows(paper_run)
    table = outputs.timeseries_table(paper_run)
    assert list(series.columns) == [column.name for column in table]
    for column in table:  # bit for bit
        np.testing.assert_array_equal(series[column.name], column.values[rows], column.name)


def test_a_run_is_rebuilt_from_its_csv_alone(paper_run, passive_run, vehicle, tmp_path):
    for name, result in (("paper", paper_run), ("passive", passive_run)):
        path = outputs.write_timeseries(result, tmp_path / f"{name}.csv")
        rebuilt = outputs.timeseries_trajectory(path)
        rows = outputs.csv_rows(result)
        live = result.trajectory
        np.testing.assert_array_equal(rebuilt.t, live.t[rows])
        np.testing.assert_array_equal(rebuilt.q, live.q[rows])  # base pose, quaternion, joints
        np.testing.assert_array_equal(rebuilt.v, live.v[rows])  # base twist, joint rates
        for key, values in rebuilt.info.items():
            np.testing.assert_array_equal(values, np.asarray(live.info[key])[rows], key)
        assert np.isnan(rebuilt.tau).all()  # not in the file
    # the playback replayed from the file is the playback of the live run's rows
    rebuilt = outputs.timeseries_trajectory(tmp_path / "paper.csv")
    assert {"p", "thrust", "x_ref"} <= set(rebuilt.info)  # what the playback draws
    rows = outputs.csv_rows(paper_run)
    live = paper_run.trajectory
    sampled = aiauv_pin.simulation.fixed_step.Trajectory(
        live.t[rows],
        live.q[rows],
        live.v[rows],
        live.tau[rows],
        {key: np.asarray(value)[rows] for key, value in live.info.items()},
    )
    points = outputs.default_path_points(paper_run)
    replayed = playback.playback_commands(vehicle, rebuilt, path_points=points)
    original = playback.playback_commands(vehicle, sampled, path_points=points)
    assert _without_uuids(replayed) == _without_uuids(original)


def _without_uuids(commands) -> str:
    """The commands as JSON, their random three.js uuids numbered in order of appearance."""
    text = json.dumps(commands)
    numbers: dict[str, str] = {}
    pattern = r"[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}"
    return re.sub(pattern, lambda m: numbers.setdefault(m.group(), f"#{len(numbers)}"), text)


def test_a_csv_that_is_not_a_run_is_refused_in_one_line(tmp_path):
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("t [s],base_x [m]\n0.0,1.0\n0.1\n", encoding="utf-8")
    with pytest.raises(ValueError, match="row 3 has 1 cells, the header 2") as error:
        outputs.read_timeseries(ragged)
    assert "\n" not in str(error.value)
    words = tmp_path / "words.csv"
    words.write_text("t [s]\nnoon\n", encoding="utf-8")
    with pytest.raises(ValueError, match="row 2 holds a cell that is not a number"):
        outputs.read_timeseries(words)
    stateless = tmp_path / "stateless.csv"
    stateless.write_text("t [s],p_x [m]\n0.0,1.0\n", encoding="utf-8")
    with pytest.raises(ValueError, match="no column 'base_x'"):
        outputs.timeseries_trajectory(stateless)


# --------------------------------------------------------------------- figures


def _labelled(axes) -> list[str]:
    """Axis labels without a unit in brackets (shared x axes: on one of the axes sharing it)."""
    missing = []
    for ax in axes:
        labels = {"y": ax.get_ylabel()}
        if hasattr(ax, "get_zlabel"):
            labels["z"] = ax.get_zlabel()
        siblings = ax.get_shared_x_axes().get_siblings(ax)
        labels["x"] = next((s.get_xlabel() for s in siblings if s.get_xlabel()), "")
        missing += [
            f"{ax.get_title()!r} {k}: {v!r}" for k, v in labels.items() if not UNIT.search(v)
        ]
    return missing


def test_every_figure_has_labelled_axes_with_units(paper_run, passive_run):
    drawn = [(name, paper_run) for name in outputs.FIGURES]
    drawn += [(name, passive_run) for name in outputs.MOTION_FIGURES]
    for name, result in drawn:
        fig = figures._draw(name, outputs.figure_data(result, vehicle_name="run_folder"))
        assert _labelled(fig.axes) == [], name
        assert any("(run_folder)" in ax.get_title() for ax in fig.axes), name


def test_titles_name_the_output_folder(tmp_path, monkeypatch, capsys):
    seen = {}
    write_results = outputs.write_results

    def spy(*args, **kwargs):
        seen.update(kwargs)
        return write_results(*args, **kwargs)

    monkeypatch.setattr(outputs, "write_results", spy)
    out = tmp_path / "my_run"
    argv = ["simulate", "--duration", "0.2", "--controller", "none", "--no-html", "--quiet"]
    assert cli.main([*argv, "--out", str(out)]) == 0
    assert seen["vehicle_name"] == "my_run"  # not the bundled vehicle's paper_uniform
    printed = capsys.readouterr().out
    assert "final base position = (" in printed and "p_y" not in printed
    content = json.loads((out / "summary.json").read_text())
    assert "cross_track_error" not in content["final"]
    assert sorted(p.name for p in (out / "figures").iterdir()) == sorted(outputs.MOTION_FIGURES)
