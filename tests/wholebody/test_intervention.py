"""Intervention mode on the paper's vehicle: the issue's targets (tolerances fixed before measuring),
bad requests in one line, scenario files.

Targets (issue 31, part 3): hold the end-effector within 1 cm and 1 degree in a 0.2 m/s current
(the controller does not know it: integral action), over the whole run from rest; a commanded move
of 0.5 m and 30 degrees settles within 2 cm / 2 degrees in under 20 s, no actuator saturated for
longer than 1 s in a row.
"""

from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_control.laws.intervention_laws import pose_error
from aiauv_pin.errors import ArgumentError
from aiauv_pin.results.outputs import figures_of, timeseries_table
from aiauv_pin.scenario.definition import Scenario, run_scenario, summary
from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario, scenario_from_mapping
from aiauv_pin.wholebody.intervention_controller import (
    InterventionControl,
    InterventionGains,
    rotation_from_rpy,
)
from aiauv_pin.wholebody.intervention_transit import InterventionSettings, TransitThenIntervene

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
CURRENT = np.array([0.2, 0.0, 0.0])
POSTURE = 0.3 * np.array([1, 1, -1, -1, 1, 1, -1, -1])


@pytest.fixture(scope="module")
def vehicle():
    return aiauv_pin.load_vehicle()


def _bent(vehicle):
    q = vehicle.neutral_configuration()
    q[7:] = POSTURE
    return q


def _longest_run(flags: np.ndarray, dt: float) -> float:
    longest = run = 0
    for flag in flags:
        run = run + 1 if flag else 0
        longest = max(longest, run)
    return longest * dt


@pytest.mark.parametrize("axis", [0, 1, 2], ids=["along", "across", "vertical"])
def test_hold_in_a_current_within_1cm_and_1deg(vehicle, axis):
    controller = InterventionControl(vehicle)  # target: the pose at the start
    current = np.roll(CURRENT, axis)
    run = aiauv_pin.simulate(
        vehicle, _bent(vehicle), np.zeros(vehicle.nv), 40.0, 0.01, controller, current=current
    )
    error = run.info["pose_error"]
    assert np.linalg.norm(error[:, :3], axis=1).max() < 0.01
    assert np.degrees(np.linalg.norm(error[:, 3:], axis=1)).max() < 1.0
    assert run.info["saturated"].max() == 0


@pytest.mark.parametrize(
    ("direction", "rpy"),
    [([0.0, 0.6, 0.8], [0.0, 0.0, 30.0]), ([0.6, 0.0, 0.8], [0.0, 30.0, 0.0])],
    ids=["yaw", "pitch"],
)
def test_move_half_a_metre_and_30_degrees_settles_in_20_s(vehicle, direction, rpy):
    q0 = _bent(vehicle)
    start = vehicle.frame_placement(q0, "end_effector")
    target_p = start.translation + 0.5 * np.array(direction)
    target_R = rotation_from_rpy(np.radians(rpy)) @ start.rotation
    controller = InterventionControl(vehicle, target_p, target_R, move_time=8.0)
    dt = 0.01
    run = aiauv_pin.simulate(
        vehicle, q0, np.zeros(vehicle.nv), 25.0, dt, controller, current=CURRENT
    )
    frame = vehicle.frame_id("end_effector")
    errors = np.array(
        [
            pose_error(*vehicle.frame_motion(q, v, frame)[:2], target_R, target_p)
            for q, v in zip(run.q, run.v, strict=True)
        ]
    )
    outside = (np.linalg.norm(errors[:, :3], axis=1) > 0.02) | (
        np.degrees(np.linalg.norm(errors[:, 3:], axis=1)) > 2.0
    )
    settle = run.t[np.flatnonzero(outside)[-1] + 1]
    assert settle < 20.0
    assert _longest_run(run.info["saturated"] > 0, dt) <= 1.0


def test_locked_straight_body_holds_with_thrusters_alone(vehicle):
    """The comparison of the issue: joints locked straight by a stiff servo, thrusters alone, the
    roll left out (no thruster of the straight body makes a roll moment)."""
    controller = InterventionControl(vehicle, shared_joints=False, axes=("x", "y", "z", "ry", "rz"))
    run = aiauv_pin.simulate(
        vehicle,
        vehicle.neutral_configuration(),
        np.zeros(vehicle.nv),
        20.0,
        0.01,
        controller,
        current=CURRENT,
        method="euler",  # the stiff servo is implicit in it
        servo=controller.joint_servo,
    )
    error = run.info["pose_error"]
    assert np.linalg.norm(error[:, :3], axis=1).max() < 0.01
    assert "joint_torque" not in run.info
    assert np.abs(run.q[:, 7:]).max() < 1e-3


def test_straight_body_cannot_roll_the_end_effector(vehicle):
    controller = InterventionControl(vehicle)
    with pytest.raises(
        ArgumentError, match=r"cannot move frame 'end_effector' along rx in"
    ) as info:
        controller.check(vehicle.neutral_configuration())
    assert "\n" not in str(info.value)
    with pytest.raises(ArgumentError, match="along rx"):
        controller(0.0, vehicle.neutral_configuration(), np.zeros(vehicle.nv))


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"frame": "gripper"}, "frame 'gripper' does not exist"),
        ({"thrust_limit": 0.0}, "thrust_limit must be positive"),
        ({"thrust_limit": -5.0}, "thrust_limit must be positive"),
        (
            {"joint_torque_limit": [1.0] * 7 + [0.0]},
            r"joint_torque_limit must be positive.*entry 7",
        ),
        ({"joint_torque_limit": [1.0] * 3}, "expected 8 limits"),
        ({"axes": ("x", "roll")}, "axes must be distinct names"),
        ({"posture": [0.0] * 3}, "posture must be 8"),
        ({"move_time": -1.0}, "move_time must be >= 0"),
        ({"gains": InterventionGains(stiffness=1.0)}, None),
    ],
)
def test_bad_requests_get_one_line(vehicle, options, message):
    if message is None:
        InterventionControl(vehicle, **options)
        return
    with pytest.raises(ArgumentError, match=message) as info:
        InterventionControl(vehicle, **options)
    assert "\n" not in str(info.value)


def test_gains_must_be_positive():
    with pytest.raises(ArgumentError, match="stiffness must be positive"):
        InterventionGains(stiffness=0.0)
    with pytest.raises(ArgumentError, match="integral must be finite and >= 0"):
        InterventionGains(integral=-1.0)


def test_scenario_file_runs_the_intervention(vehicle):
    scenario = load_scenario(EXAMPLES / "intervention_hold.toml")
    assert scenario.controller == "intervention"
    assert scenario.intervention.move_time == 8.0
    result = run_scenario(vehicle, scenario)
    p = result.trajectory.info["p"]
    target = np.array(scenario.intervention.target_position)
    assert np.linalg.norm(p[-1] - target) < 0.02
    assert "cross_track" not in result.trajectory.info  # no path followed
    content = summary(result)["intervention"]
    assert content["max_position_error"] < 0.01 and content["final_attitude_error"] < 1e-3
    columns = {column.name for column in timeseries_table(result)}
    assert {"pose_error_x", "pose_error_rz", "thrust_link3_z", "tau_joint1"} <= columns
    assert "intervention.png" in figures_of(result)


def test_scenario_file_bad_values_are_one_line():
    with pytest.raises(ScenarioFileError, match=r"intervention\.axes") as info:
        scenario_from_mapping(
            {"controller": {"type": "intervention"}, "intervention": {"axes": ["q"]}}
        )
    assert "\n" not in str(info.value)
    with pytest.raises(ScenarioFileError, match=r"intervention\.thrust_limit"):
        scenario_from_mapping({"intervention": {"thrust_limit": 0.0}})


def test_straight_start_of_an_intervention_scenario_is_refused_in_one_line(vehicle):
    scenario = Scenario(controller="intervention", duration=1.0, dt=0.01, method="rk4")
    with pytest.raises(ArgumentError, match="along rx"):
        run_scenario(vehicle, scenario)


def test_transit_switches_once_at_the_site(vehicle):
    settings = InterventionSettings(site=(3.0, 0.0, 0.0), switch_distance=0.5)
    controller = TransitThenIntervene(vehicle, settings)
    q = _bent(vehicle)  # (the intervention needs a bent body)
    tip = vehicle.frame_placement(q, "end_effector").translation
    q[:3] = np.array([3.7, 0.0, 0.0]) - tip  # end-effector 0.7 m from the site
    _, info = controller(0.0, q, np.zeros(vehicle.nv))
    assert info["phase"] == 0.0 and controller.switched_at is None
    assert controller.joint_servo.stiffness.min() > 0.0
    q[0] -= 0.5  # 0.2 m from the site
    _, info = controller(0.01, q, np.zeros(vehicle.nv))
    assert info["phase"] == 1.0 and controller.switched_at == 0.01
    assert not controller.joint_servo.stiffness.any()  # the paper's joint PD is off
    q[0] -= 5.0  # far again: stays in intervention
    _, info = controller(0.02, q, np.zeros(vehicle.nv))
    assert info["phase"] == 1.0 and controller.switched_at == 0.01
    controller.reset()
    assert controller.switched_at is None and controller.joint_servo.stiffness.min() > 0.0
    with pytest.raises(ArgumentError, match=r"intervention\.site"):
        TransitThenIntervene(vehicle, InterventionSettings())


def test_retarget_starts_a_new_move_from_the_reference(vehicle):
    q0 = _bent(vehicle)
    controller = InterventionControl(vehicle, move_time=2.0)
    controller(0.0, q0, np.zeros(vehicle.nv))
    start = vehicle.frame_placement(q0, "end_effector")
    new_position = start.translation + np.array([0.1, 0.0, 0.0])
    controller.retarget(1.0, new_position, start.rotation, move_time=4.0)
    p, _, twist, _ = controller.reference(1.0)
    np.testing.assert_allclose(p, start.translation, atol=1e-12)  # continuous at the retarget
    np.testing.assert_allclose(twist, 0.0, atol=1e-12)
    p, R, _, _ = controller.reference(5.0)
    np.testing.assert_allclose(p, new_position, atol=1e-12)
    np.testing.assert_allclose(R, start.rotation, atol=1e-12)
    p_mid = controller.reference(3.0)[0]
    np.testing.assert_allclose(p_mid, start.translation + np.array([0.05, 0.0, 0.0]), atol=1e-12)
