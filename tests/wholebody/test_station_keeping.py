"""Station keeping and velocity control (aiauv_pin.wholebody): the rov8 targets from the scenario
files, allocation exactness, a named frame, the paper vehicle's five axes, saturation, bad input.

Tolerances stated in advance (issue 31; docs/source/station_keeping.md): station keeping of rov8
in a 0.2 m/s current within 1 cm and 1 degree after 30 s; velocity tracking within 1 mm/s and
1 mrad/s after 10 s, with no thruster at its limit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_control.allocation import AllocationParameters, allocate_compiled
from aiauv_pin.errors import ArgumentError
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario, scenario_from_mapping
from aiauv_pin.wholebody.station_controller import StationKeeping
from aiauv_pin.wholebody.velocity_controller import VelocityControl

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
ROV8 = EXAMPLES / "vehicles" / "rov8.urdf"


@pytest.fixture(scope="module")
def rov8():
    return aiauv_pin.load_vehicle(str(ROV8))


def _run(name):
    scenario = load_scenario(EXAMPLES / name)
    vehicle = aiauv_pin.load_vehicle(scenario.vehicle)
    return run_scenario(vehicle, scenario).trajectory


def test_rov8_is_fully_actuated_with_coupled_added_mass(rov8):
    q = rov8.neutral_configuration()
    B = rov8.thrust_matrix(q)
    assert B.shape == (6, 8) and np.linalg.matrix_rank(B) == 6
    M = rov8.mass_matrix(q)
    assert M[0, 4] == pytest.approx(0.0636) and M[1, 3] == pytest.approx(-0.0712)
    assert rov8.restoring_forces(q)[2] < 0.0  # slightly positive buoyancy: g(q) points down


def test_allocation_is_exact_under_full_actuation(rov8):
    """No limit active: the allocation is the damped weighted pseudo-inverse (closed form) and
    the residual is its known deliberate part ``(I + B W_u^-2 B^T)^-1 tau`` (W_f = 1)."""
    B = rov8.thrust_matrix(rov8.neutral_configuration())
    tau = np.array([5.0, -3.0, 8.0, 0.4, -0.3, 0.6])
    params = AllocationParameters(thrust_min=(-40.0,) * 8, thrust_max=(40.0,) * 8)
    result = allocate_compiled(B, tau, params)
    w2 = 1e-3**2
    expected = B.T @ np.linalg.solve(B @ B.T + w2 * np.eye(6), tau)
    # H = B^T B + W_u^2 has a condition number near 4e6 (singular values of B 0.24 to 2, W_u 1e-3):
    # the normal equations lose that factor of the unit roundoff, about 1e-9 N on thrusts of 4 N
    np.testing.assert_allclose(result.thrusts, expected, rtol=0.0, atol=1e-8)
    np.testing.assert_allclose(
        result.residual, w2 * np.linalg.solve(w2 * np.eye(6) + B @ B.T, tau), atol=1e-12
    )
    assert np.abs(result.residual).max() < 1e-5 and not result.saturated.any()


def test_station_rov8_holds_within_1_cm_and_1_degree_after_30_s():
    trajectory = _run("station_rov8.toml")
    t = np.asarray(trajectory.t)
    late = t >= 30.0
    error = trajectory.info["error"]
    assert np.abs(error[late, :3]).max() < 0.01  # [m]
    assert np.degrees(np.abs(error[late, 3:]).max()) < 1.0  # [deg]
    assert np.abs(error[0, :3]).max() > 0.1  # it did start away from the target
    assert np.abs(trajectory.info["thrust"]).max() < 40.0  # no thruster at its limit
    assert np.abs(trajectory.info["residual"]).max() < 1e-3  # [N, N m]: all produced


def test_velocity_rov8_tracks_the_twist():
    trajectory = _run("velocity_rov8.toml")
    t = np.asarray(trajectory.t)
    error = trajectory.info["error"][t >= 10.0]
    assert np.abs(error[:, :3]).max() < 1e-3  # [m/s]
    assert np.abs(error[:, 3:]).max() < 1e-3  # [rad/s]
    assert not trajectory.info["saturated"].any()


def test_a_named_frame_is_held(rov8):
    """The camera frame, 0.25 m ahead of the CG, held at a pose turned 20 degrees in yaw."""
    from aiauv_control.laws.station_laws import rotation_from_rpy

    target = rotation_from_rpy(0.0, 0.0, np.radians(20.0))
    controller = StationKeeping(rov8, [0.5, 0.2, -0.1], target, frame="camera")
    q0 = rov8.neutral_configuration()
    trajectory = aiauv_pin.simulate(
        rov8, q0, np.zeros(6), 20.0, 0.01, controller, control_period=0.05
    )
    _, position, _ = rov8.frame_motion(trajectory.q[-1], np.zeros(6), rov8.frame_id("camera"))
    np.testing.assert_allclose(position, [0.5, 0.2, -0.1], atol=1e-3)
    assert np.degrees(np.linalg.norm(np.asarray(trajectory.info["error"][-1, 3:]))) < 0.1


def test_the_paper_vehicle_cannot_hold_roll_and_holds_the_other_five_axes():
    vehicle = aiauv_pin.load_vehicle()
    with pytest.raises(ArgumentError, match=r"cannot produce roll \(thrust matrix rank 5 of 6\)"):
        StationKeeping(vehicle, [0.0, 0.0, 0.0], np.eye(3))
    axes = ("surge", "sway", "heave", "pitch", "yaw")
    controller = StationKeeping(vehicle, [0.0, 0.0, 0.0], np.eye(3), axes=axes)
    q0 = vehicle.neutral_configuration()
    q0[:3] = [0.2, 0.1, -0.1]
    trajectory = aiauv_pin.simulate(
        vehicle,
        q0,
        np.zeros(vehicle.nv),
        40.0,
        0.01,
        controller,
        servo=controller.joint_servo,
        current=[0.0, 0.2, 0.0],
        control_period=0.05,
    )
    late = np.asarray(trajectory.t) >= 30.0
    error = trajectory.info["error"][late]
    assert np.abs(error[:, :3]).max() < 0.01
    assert np.degrees(np.abs(error[:, 3:]).max()) < 1.0
    assert not error[:, 3].any()  # roll is not held: no error is reported on it


def test_saturation_is_reported_and_the_integral_frozen(rov8):
    """Thrust limits of 1 N cannot hold rov8 in the current: thrusters at their limits, the
    residual reported, the integral frozen (it stays bounded)."""
    controller = StationKeeping(
        rov8, [0.0, 0.0, 0.0], np.eye(3), thrust_limits=np.full(8, 1.0), current=[0.0, 0.2, 0.0]
    )
    trajectory = aiauv_pin.simulate(
        rov8,
        rov8.neutral_configuration(),
        np.zeros(6),
        5.0,
        0.01,
        controller,
        current=[0.0, 0.2, 0.0],
        control_period=0.05,
    )
    assert np.abs(trajectory.info["thrust"]).max() <= 1.0 + 1e-12
    assert trajectory.info["saturated"].max() > 0
    assert np.abs(trajectory.info["residual"]).max() > 1.0  # [N]: what could not be produced
    assert np.abs(controller.integral).max() < 1.0


def test_bad_requests_get_one_line(rov8):
    cases = [
        (lambda: StationKeeping(rov8, frame="gripper"), "unknown frame 'gripper'"),
        (
            lambda: StationKeeping(rov8, thrust_limits=[40.0] * 7 + [0.0]),
            "thrust limits must be 8 positive",
        ),
        (lambda: StationKeeping(rov8, omega=-1.0), "omega and zeta must be positive"),
        (lambda: StationKeeping(rov8, axes=("surge", "twist")), "axes: expected one or more"),
        (lambda: VelocityControl(rov8, [0.1, 0.0]), "twist must be 6 finite numbers"),
        (lambda: VelocityControl(rov8, np.zeros(6), bandwidth=0.0), "bandwidth must be positive"),
    ]
    for build, message in cases:
        with pytest.raises(ArgumentError, match=message) as caught:
            build()
        assert "\n" not in str(caught.value)


def test_scenario_tables_are_checked():
    base = {"vehicle": str(ROV8), "controller": {"type": "station"}}
    with pytest.raises(ScenarioFileError, match=r"station\.omega"):
        scenario_from_mapping({**base, "station": {"omega": 0.0}})
    with pytest.raises(ScenarioFileError, match=r"controller\.type is not 'station'"):
        scenario_from_mapping({"controller": {"type": "paper"}, "station": {"omega": 1.0}})
    with pytest.raises(ScenarioFileError, match=r"velocity\.twist"):
        scenario_from_mapping(
            {**base, "controller": {"type": "velocity"}, "velocity": {"twist": [1.0]}}
        )
    scenario = scenario_from_mapping({**base, "station": {"frame": "camera", "axes": ["yaw"]}})
    assert scenario.wholebody == {"frame": "camera", "axes": ["yaw"]}


def test_options_of_a_scenario_build_the_controllers(rov8):
    from aiauv_pin.wholebody.station_options import controller_from_options

    built = controller_from_options(rov8, "station", {"frame": "camera", "axes": ["yaw"]}, None)
    assert isinstance(built, StationKeeping) and built.held.tolist() == [0, 0, 0, 0, 0, 1]
    with pytest.raises(ArgumentError, match=r"^velocity: needs a \[velocity\] table"):
        controller_from_options(rov8, "velocity", {}, None)
    paper = aiauv_pin.load_vehicle()
    with pytest.raises(ArgumentError, match=r"^station keeping: the thrusters cannot produce roll"):
        controller_from_options(paper, "station", {}, None)


def test_linearised_closed_loop_on_rov8_has_the_designed_roots(rov8):
    """The closed loop (vehicle + computed torque + allocation), linearised at the target in still
    water by central differences over (pose (tangent), twist, integral): its 18 eigenvalues are the
    designed roots of ``s^3 + k_d s^2 + k_p s + k_i``, six times each, up to the allocation's
    deliberate residual (relative 1e-6) and the differences' error."""
    import pinocchio as pin

    from aiauv_control.laws.station_laws import closed_loop_roots, pid_gains

    gains = pid_gains(2.0, 0.7, 0.5)
    controller = StationKeeping(rov8, [0.0, 0.0, 0.0], np.eye(3), gains=gains)
    q_target = rov8.neutral_configuration()

    def rate(x):
        q = pin.integrate(rov8.model, q_target, x[:6])
        v = x[6:12]
        controller.integral, controller._last_t = x[12:].copy(), None
        tau, info = controller(0.0, q, v)
        dv = rov8.acceleration(q, v, tau)
        # d/dt of the tangent coordinates: v through the inverse right Jacobian of SE(3)
        jr = pin.Jexp6(x[:6])
        return np.concatenate((np.linalg.solve(jr, v), dv, info["error"]))

    h = 1e-6
    A = np.empty((18, 18))
    for k in range(18):
        step = np.zeros(18)
        step[k] = h
        A[:, k] = (rate(step) - rate(-step)) / (2 * h)
    found = np.linalg.eigvals(A)
    roots = closed_loop_roots(gains.k_p[0], gains.k_d[0], gains.k_i[0])
    assert len(set(np.round(roots, 6))) == 3  # three distinct roots, -0.5 and -1.4 +- 1.43 i
    for root in roots:
        assert np.count_nonzero(np.abs(found - root) < 1e-4) == 6, (root, found)


def test_the_paper_vehicle_holds_its_end_effector_on_five_axes():
    """An articulated vehicle: the joints held by the servo, the end-effector moved 0.3 m, 0.2 m,
    -0.1 m and turned 10 degrees in yaw; within 1 cm and 1 degree after 20 s (omega = 1 rad/s:
    the 50 N thrusters then saturate only briefly)."""
    from aiauv_control.laws.station_laws import rotation_from_rpy

    vehicle = aiauv_pin.load_vehicle()
    q0 = vehicle.neutral_configuration()
    frame = vehicle.frame_id("end_effector")
    rotation, position, _ = vehicle.frame_motion(q0, np.zeros(vehicle.nv), frame)
    target = position + np.array([0.3, 0.2, -0.1])
    controller = StationKeeping(
        vehicle,
        target,
        rotation @ rotation_from_rpy(0.0, 0.0, np.radians(10.0)),
        frame="end_effector",
        omega=1.0,
        axes=("surge", "sway", "heave", "pitch", "yaw"),
    )
    trajectory = aiauv_pin.simulate(
        vehicle,
        q0,
        np.zeros(vehicle.nv),
        30.0,
        0.01,
        controller,
        servo=controller.joint_servo,
        control_period=0.05,
    )
    late = np.asarray(trajectory.t) >= 20.0
    error = trajectory.info["error"][late]
    assert np.abs(error[:, :3]).max() < 0.01
    assert np.degrees(np.abs(error[:, 3:]).max()) < 1.0
    _, final, _ = vehicle.frame_motion(trajectory.q[-1], np.zeros(vehicle.nv), frame)
    np.testing.assert_allclose(final, target, atol=1e-3)


def test_velocity_of_a_named_frame(rov8):
    """The camera frame (0.25 m ahead) driven at 0.2 m/s sideways while yawing at 0.2 rad/s (the
    base then moves on a circle about the camera's path); still water."""
    twist = [0.0, 0.2, 0.0, 0.0, 0.0, 0.2]
    controller = VelocityControl(rov8, twist, frame="camera")
    trajectory = aiauv_pin.simulate(
        rov8, rov8.neutral_configuration(), np.zeros(6), 15.0, 0.01, controller, control_period=0.05
    )
    late = np.asarray(trajectory.t) >= 10.0
    np.testing.assert_allclose(
        trajectory.info["twist"][late], np.tile(twist, (late.sum(), 1)), atol=1e-3
    )
    assert not trajectory.info["saturated"].any()
