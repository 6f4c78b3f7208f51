"""The paper's path-following law on joint layouts other than the paper's (issue 31, part 1).

Eq. (22) is applied per axis: each axis's joints get the exponential pattern counted from the tail,
whatever their number and order. Checked on the two example vehicles (three yaw and two pitch
joints, not alternating; a planar snake with six yaw joints and tail thrusters) following a line
from scenario files, and on a vehicle whose joints cannot steer.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_control.joint_references import JointLayoutWarning
from aiauv_pin.app.cli import main
from aiauv_pin.builders.urdf_builder import build_urdf
from aiauv_pin.builders.vehicle_spec import load_spec, spec_from_dict
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import load_scenario

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("name", ["yaw3_pitch2", "planar_snake"])
def test_example_vehicles_are_built_from_their_specs(name):
    """The shipped URDFs are what `aiauv build` makes of the specs beside them (no drift)."""
    folder = EXAMPLES / "vehicles"
    built = build_urdf(load_spec(folder / f"{name}.toml"))
    assert built == (folder / f"{name}.urdf").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("scenario_file", "warns"),
    [("line_yaw3_pitch2.toml", False), ("line_planar_snake.toml", True)],
)
def test_unequal_and_one_axis_layouts_follow_a_line(scenario_file, warns):
    scenario = load_scenario(EXAMPLES / scenario_file)
    vehicle = aiauv_pin.load_vehicle(scenario.vehicle)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run_scenario(vehicle, scenario)
    layout_warnings = [w for w in caught if issubclass(w.category, JointLayoutWarning)]
    assert bool(layout_warnings) == warns
    trajectory = result.trajectory
    assert trajectory.status == "complete"
    p, u, t = trajectory.info["p"], trajectory.info["u"], trajectory.t
    cross_track = np.hypot(p[:, 1], p[:, 2])
    late = t >= t[-1] - 10.0
    # from 1.41 m (1 m for the planar snake) to within 0.25 m of the line after 90 s, still closing
    assert cross_track[late].max() < 0.25 * cross_track[0]
    assert cross_track[-1] < cross_track[np.searchsorted(t, 45.0)]
    assert abs(u[late].mean() - 0.5) < 0.02  # the paper's u_d [m/s]
    if warns:  # no pitch joint: the path is in the snake's plane and it stays there
        assert np.max(np.abs(p[:, 2])) < 1e-6


def test_a_vehicle_whose_joints_cannot_steer_gets_one_line(tmp_path, capsys):
    modules = [
        {"name": "tail", "length": 0.45, "mass": 10.0, "joint": "x"},
        {
            "name": "head",
            "length": 0.45,
            "mass": 10.0,
            "thruster": [
                {"name": "x_port", "x": 0.2, "y": 0.1, "direction": "x"},
                {"name": "x_starboard", "x": 0.2, "y": -0.1, "direction": "x"},
            ],
        },
    ]
    urdf = tmp_path / "roll_only.urdf"
    urdf.write_text(
        build_urdf(spec_from_dict({"name": "roll_only", "radius": 0.085, "module": modules})),
        encoding="utf-8",
    )
    status = main(
        [
            "simulate",
            "--vehicle",
            str(urdf),
            "--duration",
            "1",
            "--out",
            str(tmp_path / "out"),
            "--no-html",
            "--quiet",
        ]
    )
    error = capsys.readouterr().err.strip().splitlines()
    assert status != 0
    assert error[-1].startswith("aiauv: error: ")
    assert "cannot be curved to steer" in error[-1] and "body axis x" in error[-1]
    assert not any("Traceback" in line for line in error)
