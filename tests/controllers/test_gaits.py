"""Serpentine gaits: the laws, their checks, swimming physics and path following.

The swimming checks reproduce the qualitative results of Kelasidi et al.'s study of the gait
parameters' effect on the forward velocity (Kelasidi, Liljeback, Pettersen, Gravdahl, "Experimental
investigation of efficient locomotion of underwater snake robots for lateral undulation and eel-like
motion patterns", Robotics and Biomimetics 2:8, 2015; IEEE Robotics & Automation Magazine, March
2016): the average forward speed rises with the gait frequency, rises with the amplitude up to a
limit beyond which it falls, and eel-like motion is slower than lateral undulation at equal
parameters (checked at 30 and 50 deg: beyond lateral undulation's best amplitude, 60 deg and more
on this snake, the eel-like gait is the faster). On the Mamba-like snake of
``urdf/mamba_like.toml`` (assumed dimensions, the project's slender-cylinder fluid coefficients):
no published number is compared here (see docs/source/swimming.md).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_control.laws.gait_laws import (
    EEL_LIKE,
    LATERAL_UNDULATION,
    gait_envelope,
    heading_offset,
    pitch_base_angle,
    serpenoid_reference,
    vertical_los_elevation,
    wrap_angle,
)
from aiauv_control.path_following import PathFollowingGains
from aiauv_pin.controllers.gait_controller import Gait, VehicleGait
from aiauv_pin.errors import ArgumentError
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario, scenario_from_mapping

ROOT = Path(__file__).resolve().parents[2]
SERVO = PathFollowingGains(k_qp=10.0, k_qd=0.3)
BASE = dict(amplitude=math.radians(30.0), omega=2.0, delta=math.radians(40.0))


@pytest.fixture(scope="module")
def mamba():
    return aiauv_pin.load_vehicle(str(ROOT / "urdf" / "mamba_like.urdf"))


def test_envelope_and_reference_are_kelasidis():
    n = 10
    assert gait_envelope(LATERAL_UNDULATION, 3, n) == 1.0
    assert gait_envelope(EEL_LIKE, 1, n) == pytest.approx(9 / 11)  # (n - i) / (n + 1)
    assert gait_envelope(EEL_LIKE, 9, n) == pytest.approx(1 / 11)
    t, alpha, omega, delta, offset, g, i = 1.3, 0.4, 2.0, 0.7, 0.05, 0.5, 4
    expected = alpha * g * math.sin(omega * t + (i - 1) * delta) + offset
    assert serpenoid_reference(t, alpha, omega, delta, offset, g, i) == pytest.approx(expected)


def test_heading_offset_saturates_and_wraps():
    assert heading_offset(0.1, 0.0, 0.5, 1.0) == pytest.approx(0.05)
    assert heading_offset(2.0, 0.0, 1.0, 0.3) == 0.3
    assert heading_offset(-2.0, 0.0, 1.0, 0.3) == -0.3
    # across +-pi the error is the short way round
    assert heading_offset(3.1, -3.1, 1.0, 1.0) == pytest.approx(wrap_angle(6.2))
    assert heading_offset(3.1, -3.1, 1.0, 1.0) < 0.0


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (dict(omega=0.0), "gait.omega must be a finite number > 0"),
        (dict(omega=-1.0), "gait.omega must be a finite number > 0"),
        (dict(kind="crawl"), "gait.kind must be one of"),
        (dict(amplitude=float("nan")), "gait.amplitude"),
        (dict(thrust="jet"), "gait.thrust must be one of"),
    ],
)
def test_bad_gait_parameters_give_one_line(options, message):
    with pytest.raises(ArgumentError, match=message) as caught:
        Gait(**options)
    assert "\n" not in str(caught.value)


def test_amplitude_beyond_the_joint_limit_is_refused(mamba):
    limit = float(mamba.model.upperPositionLimit[7])
    with pytest.raises(ArgumentError, match="exceeds the limit") as caught:
        VehicleGait(mamba, Gait(amplitude=limit, max_offset=0.1))
    assert "\n" not in str(caught.value)
    VehicleGait(mamba, Gait("eel_like", amplitude=limit, max_offset=0.1))  # g(1) = 9/11


def test_scenario_file_gait_errors_are_one_line():
    table = {"vehicle": "urdf/mamba_like.urdf", "controller": {"type": "gait"}}
    with pytest.raises(ScenarioFileError) as caught:
        scenario_from_mapping({**table, "gait": {"omega": 0.0}}, ROOT)
    assert "gait.omega" in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(ScenarioFileError, match=r"gait\.wings"):
        scenario_from_mapping({**table, "gait": {"wings": 2}}, ROOT)
    scenario = scenario_from_mapping({**table, "gait": {"kind": "eel_like", "omega": 1.5}}, ROOT)
    assert scenario.gait == Gait("eel_like", omega=1.5)


def _speed(vehicle, kind="lateral_undulation", duration=40.0, **gait):
    """Average speed of the centre of mass over the whole periods of the run's second half."""
    options = {**BASE, **gait}
    law = VehicleGait(vehicle, Gait(kind, k_theta=0.0, max_offset=0.0, **options), SERVO)
    trajectory = aiauv_pin.simulate(
        vehicle,
        vehicle.neutral_configuration(),
        np.zeros(vehicle.nv),
        duration,
        0.01,
        law.compiled(),
        servo=law.joint_servo,
        method="euler",
    )
    t, centre = np.asarray(trajectory.t), trajectory.info["centre"]
    period = 2.0 * math.pi / options["omega"]
    k0 = int(np.searchsorted(t, t[-1] - (duration / 2 // period) * period - 1e-9))
    return float(np.linalg.norm(centre[-1, :2] - centre[k0, :2]) / (t[-1] - t[k0]))


def test_swimming_speed_follows_kelasidis_qualitative_results(mamba):
    """Speed rises with frequency; with amplitude up to a limit; eel-like slower than lateral."""
    by_omega = [_speed(mamba, omega=w) for w in (1.0, 2.0, 3.0)]
    assert by_omega[0] > 0.0
    assert np.all(np.diff(by_omega) > 0.0), by_omega
    amplitudes = [math.radians(a) for a in (10, 30, 50, 70, 85)]
    by_amplitude = np.array([_speed(mamba, amplitude=a) for a in amplitudes])
    best = int(np.argmax(by_amplitude))
    assert 0 < best < len(amplitudes) - 1, by_amplitude  # an interior maximum: "up to a limit"
    assert np.all(np.diff(by_amplitude[: best + 1]) > 0.0), by_amplitude
    assert np.all(np.diff(by_amplitude[best:]) < 0.0), by_amplitude
    for a in (math.radians(30.0), math.radians(50.0)):
        assert _speed(mamba, "eel_like", amplitude=a) < _speed(mamba, amplitude=a)


def test_gait_swims_head_first_and_pitch_joints_stay_straight():
    """On the paper vehicle (yaw and pitch joints) the pitch joints are held at zero and the
    vehicle swims forward (towards its head) at constant depth."""
    vehicle = aiauv_pin.load_vehicle()
    law = VehicleGait(
        vehicle,
        Gait(amplitude=0.6, omega=1.0, delta=0.7, k_theta=0.0, max_offset=0.0),
        PathFollowingGains(k_qp=300.0, k_qd=60.0),
    )
    trajectory = aiauv_pin.simulate(
        vehicle,
        vehicle.neutral_configuration(),
        np.zeros(vehicle.nv),
        30.0,
        0.01,
        law.compiled(),
        servo=law.joint_servo,
        method="euler",
    )
    refs = trajectory.info["joint_references"]
    assert np.all(refs[:, 1::2] == 0.0)  # joints 2, 4, 6, 8 turn about y
    assert np.abs(refs[:, 0::2]).max() == pytest.approx(0.6, abs=1e-3)
    centre = trajectory.info["centre"]
    assert centre[-1, 0] - centre[0, 0] > 1.0
    assert abs(centre[-1, 2] - centre[0, 2]) < 1e-6
    assert np.all(trajectory.info["thrust"] == 0.0)


@pytest.mark.parametrize(
    ("name", "final", "last"),
    [("gait_line", 0.05, 0.05), ("gait_waypoints", 0.1, 0.15), ("gait_circle", 0.05, 0.05)],
)
def test_gait_follows_the_example_paths(name, final, last):
    scenario = load_scenario(ROOT / "examples" / f"{name}.toml")
    result = run_scenario(aiauv_pin.load_vehicle(scenario.vehicle), scenario)
    t = result.trajectory.t
    error = np.hypot(*result.trajectory.info["cross_track"].T)
    assert error[0] > 0.25
    assert error[-1] < final
    assert error[t >= t[-1] - 30.0].max() < last
    centre = result.trajectory.info["centre"]
    assert np.sum(np.linalg.norm(np.diff(centre[::100, :2], axis=0), axis=1)) > 8.0  # swims on


def test_the_measured_centre_of_mass_is_pinocchios():
    """The gait steers the centre of mass: its position and speed along the mean heading, measured
    in the compiled controller, agree with Pinocchio's ``centerOfMass`` to 1e-9."""
    import pinocchio as pin

    vehicle = aiauv_pin.load_vehicle()
    law = VehicleGait(vehicle, Gait(amplitude=0.6, omega=1.0), PathFollowingGains(k_qp=300.0))
    trajectory = aiauv_pin.simulate(
        vehicle,
        vehicle.neutral_configuration(),
        np.zeros(vehicle.nv),
        5.0,
        0.01,
        law.compiled(),
        servo=law.joint_servo,
        method="euler",
    )
    q, v = np.asarray(trajectory.q)[-1], np.asarray(trajectory.v)[-1]
    data = vehicle.model.createData()
    centre = pin.centerOfMass(vehicle.model, data, q, v)
    np.testing.assert_allclose(trajectory.info["centre"][-1], centre, rtol=0.0, atol=1e-9)
    heading = trajectory.info["heading"][-1]
    along = data.vcom[0][0] * math.cos(heading) + data.vcom[0][1] * math.sin(heading)
    assert trajectory.info["speed"][-1] == pytest.approx(along, abs=1e-9)


def test_a_sweep_over_gait_keys_gives_distinct_runs():
    """The gait keys are sweep parameters: they enter the resolved parameters (and the run ids)
    and come back out of them."""
    from aiauv_pin.scenario.sweep_spec import (
        run_id,
        scenario_from_parameters,
        scenario_parameters,
    )

    base = load_scenario(ROOT / "examples" / "gait_waypoints.toml")
    resolved = scenario_parameters(base)
    assert resolved["gait.kind"] == "eel_like" and resolved["gait.integral_los"] is True
    rebuilt = scenario_from_parameters(resolved)
    assert rebuilt.gait == base.gait
    faster = dict(resolved, **{"gait.omega": 3.0})
    assert run_id(faster) != run_id(resolved)
    assert scenario_from_parameters(faster).gait.omega == 3.0


def test_a_gait_built_for_another_vehicle_is_refused(mamba):
    """The compiled loop checks the gait's records against the vehicle it runs (one line)."""
    from aiauv_pin.dynamics.joint_servo import JointServo
    from aiauv_pin.errors import RecordSizeError

    law = VehicleGait(mamba, Gait(), SERVO)
    paper = aiauv_pin.load_vehicle()
    servo = JointServo.uniform(paper.nv - 6, 10.0, 0.3)  # the right size: the records are not
    with pytest.raises(RecordSizeError) as caught:
        aiauv_pin.simulate(
            paper,
            paper.neutral_configuration(),
            np.zeros(paper.nv),
            0.1,
            0.01,
            law.compiled(),
            servo=servo,
            method="euler",
        )
    assert "\n" not in str(caught.value)


# ---------------------------------------------------------------- depth keeping
def test_vertical_los_and_pitch_pd():
    """``gamma_d = atan2(-e_v, Delta_v)``; ``q_y0 = sat(k_v (gamma - gamma_d) + k_v T_v
    gamma_dot, q_max)``: above the path the body is asked to point down, and a body pointing up
    more than asked gets a positive (nose-down for a ``+y`` joint) base angle."""
    assert vertical_los_elevation(1.0, 3.0) == pytest.approx(math.atan2(-1.0, 3.0))
    assert vertical_los_elevation(-1.0, 3.0) > 0.0
    assert pitch_base_angle(0.1, 0.0, -0.1, 2.0, 0.0, 1.0) == pytest.approx(0.4)
    assert pitch_base_angle(0.0, 0.2, 0.0, 2.0, 0.5, 1.0) == pytest.approx(0.2)
    assert pitch_base_angle(1.0, 0.0, -1.0, 2.0, 0.0, 0.5) == 0.5
    assert pitch_base_angle(-1.0, 0.0, 1.0, 2.0, 0.0, 0.5) == -0.5


def _depth_run(gait_options, z=-1.0):
    """The paper vehicle undulating along the x-axis 1 m beside its start and ``z`` [m] below it
    (the table of examples/gait_depth.toml with other depth options), 120 s."""
    table = {
        "case": "uniform",
        "duration": 120.0,
        "dt": 0.01,
        "method": "euler",
        "start": {"position": [0.0, 1.0, 0.0], "heading": [1.0, 0.0, 0.0]},
        "path": {"type": "line", "point": [0.0, 0.0, z], "direction": [1.0, 0.0, 0.0]},
        "controller": {"type": "gait", "k_qp": 300.0, "k_qd": 60.0},
        "gait": {
            "amplitude": 0.6,
            "omega": 1.0,
            "delta": 0.7,
            "k_theta": 0.5,
            "max_offset": 0.2,
            **gait_options,
        },
    }
    scenario = scenario_from_mapping(table, ROOT)
    return run_scenario(aiauv_pin.load_vehicle(scenario.vehicle), scenario).trajectory


@pytest.mark.parametrize("z", [-1.0, 1.0])
def test_pitch_joints_keep_the_depth(z):
    """A line 1 m below (above) the start: the depth error of the centre of mass falls from 1 m to
    below 1 cm in 120 s (measured 0.001 m) while the horizontal cross-track converges as without
    depth keeping (0.034 m, measured 0.031 m without); with the gain at zero the depth error stays
    1 m (the law does the work)."""
    trajectory = _depth_run({"depth": "joints", "depth_gain": 2.0, "depth_lookahead": 3.0}, z)
    depth = trajectory.info["depth"][:, 0]
    assert depth[0] == pytest.approx(-z)
    assert abs(depth[-1]) < 0.01
    assert abs(trajectory.info["cross_track"][-1, 0]) < 0.05
    refs = trajectory.info["joint_references"]
    assert np.abs(refs[:, 1::2]).max() > 0.1  # the pitch joints did bend
    # eq. (22) over the pitch joints: each one exp(-alpha) of the one behind it
    np.testing.assert_allclose(refs[0, 3::2], refs[0, 1:-2:2] * math.exp(-0.7), rtol=1e-12)
    idle = _depth_run({"depth": "joints", "depth_gain": 0.0}, z)
    assert np.all(idle.info["joint_references"][:, 1::2] == 0.0)
    assert abs(idle.info["depth"][-1, 0]) > 0.99
    assert abs(idle.info["cross_track"][-1, 0]) < 0.05


def test_vertical_thrusters_keep_the_depth():
    """By the vertical thrusters (PI, defaults 5 N/m and 0.1 N/(m s)) with the pitch joints
    straight: the depth error falls from 1 m to 0.004 m in 120 s; the horizontal cross-track still
    converges (0.14 m at 120 s: the thrusters' moments disturb the steering)."""
    trajectory = _depth_run({"depth": "thrusters"}, 1.0)
    depth = trajectory.info["depth"][:, 0]
    assert depth[0] == pytest.approx(-1.0)
    assert abs(depth[-1]) < 0.01
    assert abs(trajectory.info["cross_track"][-1, 0]) < 0.2
    assert np.all(trajectory.info["joint_references"][:, 1::2] == 0.0)
    thrust = trajectory.info["thrust"]
    assert np.abs(thrust).max() <= 50.0
    assert np.all(thrust[:, [1, 2, 3, 5]] == 0.0)  # only the z thrusters (0, 4, 6) push


def test_the_measured_elevation_rate_is_the_elevations_derivative():
    """``mean_elevation``'s rate agrees with a central difference of its elevation along a
    motion (to 1e-6 rad/s)."""
    import pinocchio as pin

    from aiauv_pin.controllers.gait_compiled import mean_elevation
    from aiauv_pin.kernels.articulated_body import kinematics

    vehicle = aiauv_pin.load_vehicle()
    rng = np.random.default_rng(3)
    q = pin.integrate(
        vehicle.model, vehicle.neutral_configuration(), 0.3 * rng.normal(size=vehicle.nv)
    )
    v = rng.normal(size=vehicle.nv)
    fast = vehicle.fast
    masses = np.array([inertia.mass for inertia in list(vehicle.model.inertias)[1:]])

    def elevation(qq):
        kinematics(fast.model.bodies, qq, v, fast.workspace)
        return mean_elevation(fast.workspace, masses)

    h = 1e-6
    _, rate = elevation(q)
    ahead = elevation(pin.integrate(vehicle.model, q, h * v))[0]
    behind = elevation(pin.integrate(vehicle.model, q, -h * v))[0]
    assert rate == pytest.approx((ahead - behind) / (2.0 * h), abs=1e-6)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (dict(depth="fins"), "gait.depth must be one of"),
        (dict(depth_gain=-1.0), "gait.depth_gain must be a finite number >= 0"),
        (dict(depth_damping=float("inf")), "gait.depth_damping"),
        (dict(depth_lookahead=0.0), "gait.depth_lookahead must be a finite number > 0"),
        (dict(depth_kp=float("nan")), "gait.depth_kp"),
    ],
)
def test_bad_depth_parameters_give_one_line(options, message):
    with pytest.raises(ArgumentError, match=message) as caught:
        Gait(**options)
    assert "\n" not in str(caught.value)


def test_depth_keeping_needs_its_actuators(mamba):
    """The Mamba-like snake has neither pitch joints nor thrusters: one line each."""
    for depth, message in (("joints", "needs pitch"), ("thrusters", "needs thrusters")):
        with pytest.raises(ArgumentError, match=message) as caught:
            VehicleGait(mamba, Gait(depth=depth), SERVO)
        assert "\n" not in str(caught.value)
    table = {"vehicle": "urdf/mamba_like.urdf", "controller": {"type": "gait"}}
    with pytest.raises(ScenarioFileError) as caught:
        scenario_from_mapping({**table, "gait": {"depth_gain": -1.0}}, ROOT)
    assert "gait.depth_gain" in str(caught.value) and "\n" not in str(caught.value)


def test_the_depth_example_converges():
    """examples/gait_depth.toml: depth error 1 m -> below 1 cm, cross-track 1 m -> below 5 cm."""
    scenario = load_scenario(ROOT / "examples" / "gait_depth.toml")
    trajectory = run_scenario(aiauv_pin.load_vehicle(scenario.vehicle), scenario).trajectory
    errors = trajectory.info["cross_track"]
    depth = trajectory.info["depth"][:, 0]
    assert depth[0] == pytest.approx(1.0) and abs(depth[-1]) < 0.01
    assert abs(errors[0, 0]) > 0.9 and abs(errors[-1, 0]) < 0.05
