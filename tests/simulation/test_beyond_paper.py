"""Beyond the paper: integral LOS, turn-rate (curvature) feedforward, hydrostatic compensation.

Closed forms and short runs; the 300 s figures are measured by ``benchmarks/beyond_paper.py``
(``benchmarks/beyond_paper.json``).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import aiauv_pin
from aiauv_control.laws import paper_laws as laws
from aiauv_control.path_following import PathFollowingController, PathFollowingGains
from aiauv_control.paths import HelixPath, LinePath
from aiauv_pin.scenario.definition import Scenario, run_scenario
from aiauv_pin.scenario.toml_file import ScenarioFileError, scenario_from_mapping

EXTENSIONS = ("turn_feedforward", "integral_los", "hydrostatic_compensation")


def _record(gains: PathFollowingGains) -> laws.PaperGains:
    controller = PathFollowingController(("z", "y"), [0], 1, 50.0, gains)
    return controller.gain_record


def test_options_off_by_default_are_the_papers_law():
    record = _record(PathFollowingGains.stabilised())
    assert not any(getattr(record, name) for name in EXTENSIONS)
    scenario = scenario_from_mapping({"case": "stabilised", "controller": {"k_p": 2.0}})
    assert not any(getattr(_record(scenario.controller_gains), n) for n in EXTENSIONS)
    on = _record(
        scenario_from_mapping(
            {
                "controller": {
                    "current_compensation": "integral_los",
                    "turn_feedforward": True,
                    "hydrostatic_compensation": True,
                }
            }
        ).controller_gains
    )
    assert all(getattr(on, name) for name in EXTENSIONS)
    assert on.turn_rate_gain == pytest.approx(on.u_d * PathFollowingGains().turn_curvature_gain)


@pytest.mark.parametrize(
    "controller, message",
    [
        (
            {"current_compensation": "ilos"},
            "current_compensation: expected one of none, integral_los, got 'ilos'",
        ),
        ({"hydrostatic_compensation": 1}, "hydrostatic_compensation: expected true or false"),
        ({"turn_feedforward": "yes"}, "turn_feedforward: expected true or false"),
        ({"turn_moment_gain": 0.0}, "turn_moment_gain: expected a number in (0, 1e6]"),
        ({"los_integral_gain": -1.0}, "los_integral_gain: expected a number in (0, 1000]"),
        ({"turn_time_constant": -1.0}, "turn_time_constant: expected a number in [0, 1e4]"),
        ({"turn_curvature_gain": "x"}, "turn_curvature_gain: expected a number in (0, 1000]"),
    ],
)
def test_bad_values_get_one_line(controller, message):
    # the schema (aiauv_pin.scenario.file_schemas) names the key path: controller.<gain>
    with pytest.raises(ScenarioFileError) as error:
        scenario_from_mapping({"controller": controller})
    text = str(error.value)
    assert text.startswith("controller.") and message in text and "\n" not in text


def test_biased_guidance_on_a_line_is_guidance_at_the_shifted_point(rng):
    # on a straight line, acting on e_i + b_i is the plain law at p + b_1 N1 + b_2 N2
    path = LinePath(point=(1.0, -2.0, 0.5), direction=(1.0, 2.0, -0.5))
    for _ in range(10):
        p, p_dot, p_ddot = rng.normal(size=3) * 3, rng.normal(size=3), rng.normal(size=3)
        b = rng.normal(size=2)
        point = path.closest(p)
        shifted = p + b[0] * np.array(point.normal1) + b[1] * np.array(point.normal2)
        got = laws.biased_los_guidance(
            point, p, p_dot, p_ddot, 0.5, 0.05, 0.08, (b[0], b[1], 0.0, 0.0, 0.0, 0.0)
        )
        expected = laws.los_guidance(path.closest(shifted), shifted, p_dot, p_ddot, 0.5, 0.05, 0.08)
        np.testing.assert_allclose(np.array(got), np.array(expected), rtol=1e-12, atol=1e-13)


def test_biased_guidance_derivatives_match_finite_differences():
    # a biased reference along a smooth motion near a helix: x_ref_dot, x_ref_ddot by differences
    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=10.0)

    def motion(t):
        p = np.array([10.5 * math.cos(0.05 * t), 10.5 * math.sin(0.05 * t), 0.08 * t + 0.3])
        v = np.array([-0.525 * math.sin(0.05 * t), 0.525 * math.cos(0.05 * t), 0.08])
        a = np.array([-0.02625 * math.cos(0.05 * t), -0.02625 * math.sin(0.05 * t), 0.0])
        bias = (0.3 + 0.1 * t, -0.2 + 0.05 * t * t, 0.1, 0.1 * t, 0.0, 0.1)
        return laws.biased_los_guidance(helix.closest(p), p, v, a, 0.5, 0.05, 0.05, bias)

    h, t = 1e-4, 2.0
    x_minus, x0, x_plus = (np.array(motion(t + k * h)) for k in (-1, 0, 1))
    np.testing.assert_allclose(x0[1], (x_plus[0] - x_minus[0]) / (2 * h), atol=1e-7)
    np.testing.assert_allclose(x0[2], (x_plus[1] - x_minus[1]) / (2 * h), atol=1e-7)


def test_integral_los_follows_borhaug_closed_form():
    state = laws.new_guidance_state()
    u_d, k = 0.5, 0.05
    lookahead, sigma = u_d / k, 0.5
    e, e_dot = 0.8, -0.1
    first = laws.integral_los_bias(state, 0.0, (e, 0.0, e_dot, 0.0), u_d, k, k, sigma)
    # z = 0: z_dot = Delta e / (e^2 + Delta^2)
    rate = lookahead * e / (e * e + lookahead * lookahead)
    assert first[0] == 0.0 and first[2] == pytest.approx(sigma * rate, rel=1e-14)
    assert first[1] == first[3] == 0.0  # no error along N2: no bias
    second = laws.integral_los_bias(state, 0.2, (e, 0.0, e_dot, 0.0), u_d, k, k, sigma)
    assert state.integral[0] == pytest.approx(rate * 0.2, rel=1e-14)  # zero-order hold
    assert second[0] == pytest.approx(sigma * rate * 0.2, rel=1e-14)

    # b_ddot: derivative of b_dot along e(t) = e + e_dot t, z(t) integrated finely
    def b_dot(t, z):
        return sigma * laws._ilos_rate(e + e_dot * t, z, lookahead, sigma)

    z, h = 0.3, 1e-6
    state = laws.GuidanceState(np.array([z, 0.0]), np.zeros(1), np.zeros(1), np.zeros(2))
    got = laws.integral_los_bias(state, 0.0, (e, 0.0, e_dot, 0.0), u_d, k, k, sigma)
    z_dot = b_dot(0.0, z) / sigma
    numeric = (b_dot(h, z + z_dot * h) - b_dot(-h, z - z_dot * h)) / (2 * h)
    assert got[4] == pytest.approx(numeric, rel=1e-6)


def test_curvature_direction_turns_at_the_torsion_on_a_helix_and_not_on_plane_paths():
    # Bishop (1975): in a rotation-minimising frame the curvature vector turns at the torsion
    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=10.0)
    p = helix.points_at(np.array([7.0]))[0]
    point = helix.closest(p)
    speed = 0.5
    p_dot = speed * np.array(point.tangent)
    rate = laws.normal_plane_turn_rate(point, p_dot, 0.0, 0.0)
    assert abs(rate) == pytest.approx(helix.torsion * speed, rel=1e-9)
    # and in the sense the (k1, k2) angle advances along the path
    ahead = helix.closest(helix.points_at(np.array([7.0 + 1e-4]))[0])
    turned = math.atan2(ahead.curvature2, ahead.curvature1)
    turned -= math.atan2(point.curvature2, point.curvature1)
    assert rate / speed == pytest.approx(turned / 1e-4, rel=1e-5)
    circle = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=0.0)
    line = LinePath(point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0))
    for path in (circle, line):
        q = np.array([3.0, 9.0, 0.5])
        assert laws.normal_plane_turn_rate(path.closest(q), p_dot, 0.1, 0.2) == 0.0


def test_integral_los_integrator_turns_with_the_frame_rate_on_the_path():
    # on the path (e = 0) Borhaug's rate vanishes and z only turns: z_dot = w (-z_2, z_1)
    z, w, sigma = np.array([0.4, -0.3]), 0.01, 0.8
    state = laws.GuidanceState(z.copy(), np.zeros(1), np.zeros(1), np.zeros(2))
    got = laws.integral_los_bias(state, 0.0, (0.0, 0.0, 0.0, 0.0), 0.5, 0.1, 0.1, sigma, w)
    np.testing.assert_allclose(got[2:4], sigma * w * np.array([-z[1], z[0]]), rtol=1e-14)
    np.testing.assert_allclose(got[4:6], -sigma * w * w * z, rtol=1e-14)
    for k in range(1, 1001):  # 10 s in steps of 10 ms: a turn by w * 10 s = 0.1 rad
        laws.integral_los_bias(state, 0.01 * k, (0.0, 0.0, 0.0, 0.0), 0.5, 0.1, 0.1, sigma, w)
    c, s_ = math.cos(0.1), math.sin(0.1)
    np.testing.assert_allclose(
        state.integral, [c * z[0] - s_ * z[1], s_ * z[0] + c * z[1]], atol=3e-4
    )
    # without a frame rate the integrator stays put (Borhaug's law as before)
    state = laws.GuidanceState(z.copy(), np.zeros(1), np.zeros(1), np.zeros(2))
    for k in range(3):
        laws.integral_los_bias(state, 0.01 * k, (0.0, 0.0, 0.0, 0.0), 0.5, 0.1, 0.1, sigma)
    np.testing.assert_array_equal(state.integral, z)


@pytest.mark.parametrize("case", ["uniform", "stabilised"])
def test_restoring_moment_about_the_end_effector_closed_form(case):
    # straight vehicle pitched nose-up by theta: the CG (h = r/2 below each link's axis in the
    # roll-stabilised case) gives the couple +W h sin(theta) about the end-effector's y-axis (nose
    # down), so the left-hand side g has -W h sin(theta); the uniform vehicle has none (CG = CB)
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
    theta = 0.3
    q = vehicle.neutral_configuration()
    rotation = pin.utils.rpyToMatrix(0.0, -theta, 0.0)  # nose up
    q[3:7] = pin.Quaternion(rotation).coeffs()
    q[:3] = (1.0, -2.0, 3.0)
    placement = vehicle.frame_placement(q, "end_effector")
    g = vehicle.restoring_forces(q)
    moment = laws.restoring_moment_in_frame(
        rotation, q[:3], placement.rotation, placement.translation, g[:6]
    )
    weight_times_offset = 81.3 * 9.81 * 0.085 / 2 if case == "stabilised" else 0.0
    np.testing.assert_allclose(
        moment, [0.0, -weight_times_offset * math.sin(theta), 0.0], atol=1e-9 * 81.3 * 9.81
    )


def test_compiled_and_python_backends_agree_with_every_extension():
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"))
    gains = PathFollowingGains.stabilised(
        turn_feedforward=True,
        turn_time_constant=1.0,
        current_compensation="integral_los",
        hydrostatic_compensation=True,
    )
    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=10.0)
    scenario = Scenario(
        case="stabilised",
        duration=1.5,
        gains=gains,
        path=helix,
        start_position=(11.0, 0.0, -1.0),
        current=(0.05, 0.1, 0.05),
    )
    compiled = run_scenario(vehicle, scenario)
    python = run_scenario(vehicle, scenario, compiled=False)
    assert compiled.extra["compiled_controller"] and not python.extra["compiled_controller"]
    for key in ("base_angles", "joint_references", "x_ref", "cross_track"):
        np.testing.assert_allclose(
            compiled.trajectory.info[key], python.trajectory.info[key], rtol=1e-9, atol=1e-11
        )
    np.testing.assert_allclose(compiled.trajectory.q, python.trajectory.q, rtol=1e-9, atol=1e-11)
    # the extensions acted: the base angles differ from the paper's law's
    paper = run_scenario(vehicle, Scenario(**{**scenario.__dict__, "gains": None}))
    assert (
        np.abs(paper.trajectory.info["base_angles"] - compiled.trajectory.info["base_angles"]).max()
        > 1e-3
    )


def test_integral_los_removes_the_current_offset_short_run():
    # 0.2 m/s across the x-axis: after 120 s the paper's LOS has drifted to its crab offset
    # (Delta V_c / u ~ 4 m, reached at about 3.7 m); the integral LOS holds the vehicle near the path
    vehicle = aiauv_pin.load_vehicle()
    offsets = {}
    for mode in ("none", "integral_los"):
        scenario = Scenario(
            duration=120.0,
            start_position=(0.0, 0.0, 0.0),
            current=(0.0, 0.2, 0.0),
            gains=PathFollowingGains.uniform(current_compensation=mode),
        )
        result = run_scenario(vehicle, scenario)
        offsets[mode] = abs(float(result.trajectory.info["cross_track"][-1, 0]))
    assert offsets["none"] > 2.5
    assert offsets["integral_los"] < 0.1 * offsets["none"]
