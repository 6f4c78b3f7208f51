"""``aiauv simulate SCENARIO.toml [flags]`` with the scenario file exactly as issue 12 writes it.

The file's text (comments included) is the issue's; the flags ``--current VX VY VZ``,
``--duration``, ``--dt``, ``--method`` and ``--controller none|paper`` override it; a short run
writes what fits it into ``summary.json`` (path errors only when a path is followed) and the
end-effector position into ``timeseries.csv``.
"""

from __future__ import annotations

import json
import shutil

import pytest

import aiauv_pin
from aiauv_pin._internal.argument_types import EXIT_FAILED
from aiauv_pin.app.cli import build_parser, main, scenario_for_args

#: The scenario file of issue 12, word for word.
ISSUE_TOML = """\
case = "uniform"             # bundled vehicle; or vehicle = "my.urdf" (relative to this file)
duration = 120.0             # [s]
dt = 0.01                    # [s]
method = "rk4"               # or "euler"
[start]
position = [0.0, 2.0, 2.0]   # end-effector [m], world; vehicle straight, at rest
heading = [1.0, 0.0, 0.0]    # direction the vehicle points at the start (default: along the path)
[path]
type = "line"                # line: point, direction | helix: centre, axis, radius, pitch | waypoints: points
point = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
[current]
velocity = [0.0, 0.0, 0.0]   # [m/s], world
[controller]
type = "paper"               # or "none" (passive, thrusters and joints idle); gains as in sweep specs
"""


def _scenario(argv):
    return scenario_for_args(build_parser().parse_args(["simulate", *map(str, argv)]))


def test_issue_file_as_written_and_every_flag_overrides_it(tmp_path):
    path = tmp_path / "issue.toml"
    path.write_text(ISSUE_TOML)
    scenario = _scenario([path])
    assert (scenario.case, scenario.duration, scenario.dt, scenario.method) == (
        "uniform",
        120.0,
        0.01,
        "rk4",
    )
    assert scenario.controller == "paper" and scenario.on_x_axis and scenario.water.is_zero
    assert scenario.start.tolist() == [0.0, 2.0, 2.0]
    flags = ["--current", 0.1, -0.2, 0.05, "--duration", 3, "--dt", 0.02, "--method", "euler"]
    changed = _scenario([path, *flags, "--controller", "none"])
    assert (changed.duration, changed.dt, changed.method, changed.controller) == (
        3.0,
        0.02,
        "euler",
        "none",
    )
    assert changed.water.velocity(0.0, (0.0, 0.0, 0.0)).tolist() == [0.1, -0.2, 0.05]
    assert _scenario([path, "--controller", "paper"]).controller == "paper"


def test_lagged_added_mass_flags(tmp_path, capfd):
    assert _scenario([]).added_mass == "exact"
    lagged = _scenario(["--added-mass", "lagged"])
    assert (lagged.added_mass, lagged.lagged_filter) == ("lagged", 0.3)  # UUV Simulator's
    assert _scenario(["--added-mass", "lagged", "--lagged-filter", "1"]).lagged_filter == 1.0
    path = tmp_path / "lagged.toml"
    path.write_text('added_mass = "lagged"\n' + ISSUE_TOML)
    assert _scenario([path, "--lagged-filter", "0.5"]).lagged_filter == 0.5  # the file's scheme
    assert _scenario([path, "--added-mass", "exact"]).added_mass == "exact"
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["simulate", "--lagged-filter", "0"])
    assert exit_.value.code == 2 and "must be in (0, 1], got '0'" in capfd.readouterr().err
    out = tmp_path / "run"
    argv = ["simulate", "--lagged-filter", "0.5", "--duration", "0.1", "--out", str(out)]
    assert main(argv) == EXIT_FAILED
    err = capfd.readouterr().err.strip()
    assert (
        err
        == "aiauv: error: --lagged-filter applies to lagged added mass only: add --added-mass lagged"
    )
    assert not out.exists()


def test_a_lagged_run_records_its_scheme(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["simulate", "--added-mass", "lagged", "--lagged-filter", "0.5", "--duration", "0.5"]
    argv += ["--dt", "0.01", "--no-html", "--quiet", "--out", str(out)]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["added_mass"] == "lagged"
    assert summary["parameters"]["lagged_filter"] == 0.5
    assert summary["compiled_controller"] is False  # the lagged scheme runs the Python controller
    capsys.readouterr()


def test_vehicle_is_taken_relative_to_the_file(tmp_path):
    folder = tmp_path / "runs"
    folder.mkdir()
    shutil.copy(aiauv_pin.bundled_urdf("stabilised"), folder / "my.urdf")
    path = folder / "mine.toml"
    path.write_text(ISSUE_TOML.replace('case = "uniform"', 'vehicle = "my.urdf"'))
    assert _scenario([path]).vehicle == str(folder / "my.urdf")


@pytest.mark.parametrize(
    "line, message",
    [
        ("duration = -1.0", "duration: expected a number in (0, 1e5], got -1.0"),
        ("method = 4", "method: expected"),
        ("speed = 1.0", "speed: unknown key"),
        ("dt = true", "dt: expected a number in [1e-6, 10] (a bool is not a number), got True"),
        ("duration = '300'", "duration: expected a number in (0, 1e5], got '300'"),
    ],
)
def test_bad_issue_file_names_the_key(tmp_path, capfd, line, message):
    path = tmp_path / "bad.toml"
    path.write_text(line + "\n" + ISSUE_TOML.split("\n", 4)[4])
    assert main(["simulate", str(path), "--out", str(tmp_path / "out")]) == EXIT_FAILED
    err = capfd.readouterr().err.strip()
    assert err.startswith("aiauv: error:") and message in err and "\n" not in err


def test_short_runs_write_what_fits_them(tmp_path, capsys):
    """Passive in a current: the motion, no path errors; the paper's controller: the path errors
    on the paper's x-axis (``p_y``, ``p_z``); both: the end-effector position with its unit."""
    from aiauv_pin.results.outputs import MOTION_FIGURES, read_timeseries

    path = tmp_path / "issue.toml"
    path.write_text(ISSUE_TOML)
    argv = ["simulate", str(path), "--duration", "0.5", "--no-html", "--quiet"]
    passive = tmp_path / "passive"
    current = ["--current", "0", "0.2", "0", "--dt", "0.05", "--method", "euler"]
    assert main([*argv, *current, "--controller", "none", "--out", str(passive)]) == 0
    summary = json.loads((passive / "summary.json").read_text())
    assert "cross_track_error" not in summary["final"] and "p_y" not in summary["final"]
    assert summary["settling_time"] == {} and summary["path"] is None
    assert summary["final"]["base_distance"] > 0.0  # carried by the current
    assert sorted(p.name for p in (passive / "figures").iterdir()) == sorted(MOTION_FIGURES)
    assert "final base position" in capsys.readouterr().out
    following = tmp_path / "paper"
    assert main([*argv, "--out", str(following)]) == 0
    summary = json.loads((following / "summary.json").read_text())
    assert summary["final"]["cross_track_error"] > 2.0  # still ~2.8 m off the x-axis
    assert "cross_track_5cm" in summary["settling_time"]  # null: never within 5 cm
    assert "p_y" in summary["final"] and "p_z" in summary["final"]  # the paper's x-axis
    assert summary["cross_track_axes"] == ["p_y", "p_z"]
    assert "final p_y = " in capsys.readouterr().out
    for out in (passive, following):
        units = read_timeseries(out / "timeseries.csv").units
        assert {name: units[name] for name in ("p_x", "p_y", "p_z")} == dict.fromkeys(
            ("p_x", "p_y", "p_z"), "m"
        )


def test_no_figures_writes_the_data_files_and_no_figure(tmp_path, capsys):
    """``--no-figures``: ``summary.json`` and ``timeseries.csv`` as with figures, no ``figures/``,
    and the data files' numbers equal to a run that draws them."""
    path = tmp_path / "issue.toml"
    path.write_text(ISSUE_TOML)
    argv = ["simulate", str(path), "--duration", "0.3", "--no-html", "--quiet"]
    bare, drawn = tmp_path / "bare", tmp_path / "drawn"
    assert main([*argv, "--no-figures", "--out", str(bare)]) == 0
    assert main([*argv, "--out", str(drawn)]) == 0
    assert sorted(p.name for p in bare.iterdir()) == [
        ".aiauv-run.json",
        "summary.json",
        "timeseries.csv",
    ]
    assert (drawn / "figures").is_dir()
    assert (bare / "timeseries.csv").read_bytes() == (drawn / "timeseries.csv").read_bytes()
    final = [json.loads((out / "summary.json").read_text())["final"] for out in (bare, drawn)]
    assert final[0] == final[1]


def test_a_refused_output_folder_costs_no_warm_up(tmp_path, monkeypatch, capsys):
    """The output folder and the playback's shapes are checked before the kernels are compiled or
    loaded: a refused ``--out`` is one line, at once (the campaign of issue 29 saw it come after
    the warm-up, which compiles in a new installation)."""
    import aiauv_pin.scenario.definition as definition

    calls = []
    monkeypatch.setattr(definition, "warm_up", lambda *a, **k: calls.append(a))
    foreign = tmp_path / "thesis"
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("not ours", encoding="utf-8")
    status = main(["simulate", "--duration", "0.1", "--no-html", "--quiet", "--out", str(foreign)])
    error = capsys.readouterr().err.strip().splitlines()
    assert status != 0 and len(error) == 1 and error[0].startswith("aiauv: error: refusing")
    assert calls == []
    assert (foreign / "thesis.tex").read_text(encoding="utf-8") == "not ours"
