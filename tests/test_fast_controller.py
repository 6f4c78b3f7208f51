"""The compiled path-following controller (aiauv_pin.fast.path_following) against ``control``.

The numpy implementation in ``control/`` is the reference. The compiled controller must give the
same command (joint references and torques, thrusts, errors, base angles, LOS reference and its
derivatives, surge integral) to 1e-12 for random measurements and gains, with both feedforward
options, at the singular points of the pointing error, and through saturation and anti-windup of
the surge PI; and a whole compiled scenario must follow the Python-controller run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("numba")

import aiauv_pin
from aiauv_pin.errors import SimulationDiverged
from aiauv_pin.fast.path_following import CompiledController, CompiledPathFollowing
from aiauv_pin.path_following import VehiclePathFollowing, compiled_path_following_reason
from aiauv_pin.scenario import PaperScenario, run_paper_scenario
from control.path_following import (
    PathFollowingController,
    PathFollowingGains,
    PathFollowingMeasurement,
)

TIGHT = dict(rtol=1e-12, atol=1e-12)
LAYOUT = ("z", "y", "z", "y", "z", "y")
FIELDS = (
    "joint_torques",
    "thrusts",
    "phi_tilde",
    "omega_tilde",
    "base_angles",
    "joint_references",
    "x_ref",
    "x_ref_dot",
    "pointing_direction",
    "surge_integral",
)


def _rotation(rng) -> np.ndarray:
    quaternion = rng.normal(size=4)
    x, y, z, w = quaternion / np.linalg.norm(quaternion)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _measurement(rng, n: int, rotation=None, position=None, surge=None) -> PathFollowingMeasurement:
    return PathFollowingMeasurement(
        position_in_world=rng.uniform(-3, 3, 3) if position is None else position,
        velocity_in_world=rng.normal(size=3),
        acceleration_in_world=rng.normal(size=3),
        rotation_to_world=_rotation(rng) if rotation is None else rotation,
        angular_velocity_in_ee=rng.normal(size=3),
        joint_positions=rng.uniform(-1, 1, n),
        joint_velocities=rng.normal(size=n),
        joint_hydrostatic_forces=rng.normal(size=n),
        surge_velocity=rng.uniform(-1, 2) if surge is None else surge,
    )


def _random_gains(rng, feedforward: str) -> PathFollowingGains:
    k_e = float(rng.uniform(0.01, 1.0)) if rng.random() < 0.5 else tuple(rng.uniform(0.01, 1, 2))
    return PathFollowingGains(
        u_d=float(rng.uniform(0.1, 2.0)),
        k_e=k_e,
        alpha=float(rng.uniform(0.1, 2.0)),
        k_p=float(rng.uniform(0.1, 5.0)),
        k_d=float(rng.uniform(0.1, 30.0)),
        k_qp=float(rng.uniform(1, 50)),
        k_qd=float(rng.uniform(0, 60)),
        k_1p=float(rng.uniform(0, 200)),
        k_1i=float(rng.uniform(0, 20)),
        q_max=float(rng.uniform(0.05, 1.0)),  # small limits: many references saturate
        feedforward=feedforward,
    )


def _pair(gains: PathFollowingGains, max_thrust=50.0):
    reference = PathFollowingController(LAYOUT, [0, 2], 4, max_thrust, gains)
    return reference, CompiledController(reference)


def _assert_same(got: dict, expected, x_ref_ddot=None) -> None:
    for name in FIELDS:
        np.testing.assert_allclose(got[name], getattr(expected, name), err_msg=name, **TIGHT)
    if x_ref_ddot is not None:
        np.testing.assert_allclose(got["x_ref_ddot"], x_ref_ddot, **TIGHT)


@pytest.mark.parametrize("feedforward", ["exact", "paper"])
def test_command_matches_control_for_random_measurements_and_gains(feedforward, rng):
    from control.guidance import los_reference

    saturated = 0
    for _ in range(60):
        gains = _random_gains(rng, feedforward)
        reference, compiled = _pair(gains)
        t = 0.0
        for _ in range(5):  # a sequence: the surge integral advances between calls
            t += float(rng.uniform(0.0, 0.3))
            measurement = _measurement(rng, len(LAYOUT))
            expected = reference.command(t, measurement)
            got = compiled.command(t, measurement)
            x_ddot = los_reference(
                measurement.position_in_world,
                measurement.velocity_in_world,
                measurement.acceleration_in_world,
                gains.u_d,
                gains.k_e,
            )[2]
            _assert_same(got, expected, x_ddot)
            saturated += int(np.any(np.abs(expected.base_angles) > gains.q_max))
    assert saturated > 50  # the saturation of eq. (22) was exercised


@pytest.mark.parametrize("feedforward", ["exact", "paper"])
def test_surge_saturation_and_anti_windup_match(feedforward, rng):
    gains = PathFollowingGains(u_d=0.5, k_1p=100.0, k_1i=5.0, feedforward=feedforward)
    reference, compiled = _pair(gains, max_thrust=np.array([4.0, 9.0, 6.0, 9.0]))
    t = 0.0
    states = []
    # too slow (saturated at +max, integral frozen), then too fast (leaves the limit, integrates)
    for surge in [0.0] * 6 + [0.45] * 3 + [1.5] * 6 + [0.5] * 3:
        t += 0.1
        measurement = _measurement(rng, len(LAYOUT), surge=surge)
        expected = reference.command(t, measurement)
        got = compiled.command(t, measurement)
        _assert_same(got, expected)
        states.append((abs(expected.thrusts[0]) == 4.0, expected.surge_integral))
        assert expected.thrusts[2] == expected.thrusts[0] and expected.thrusts[1] == 0.0
    # windup was prevented while saturated: the integral stayed put over saturated intervals
    assert states[0][0] and states[1][0] and states[2][1] == states[1][1]
    assert any(not saturated for saturated, _ in states)


@pytest.mark.parametrize("feedforward", ["exact", "paper"])
@pytest.mark.parametrize("case", ["aligned", "antipodal", "near_antipodal"])
def test_singular_pointing_errors_match(feedforward, case, rng):
    gains = PathFollowingGains(feedforward=feedforward)
    reference, compiled = _pair(gains)
    # at p = 0 the LOS reference is e1; rotate the end-effector about z by 0, pi or pi - 1e-9
    angle = {"aligned": 0.0, "antipodal": math.pi, "near_antipodal": math.pi - 1e-9}[case]
    c, s = math.cos(angle), math.sin(angle)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    measurement = _measurement(rng, len(LAYOUT), rotation=rotation, position=np.zeros(3))
    expected = reference.command(1.0, measurement)
    _assert_same(compiled.command(1.0, measurement), expected)
    assert math.isfinite(expected.phi_tilde)


# ---------------------------------------------------------------- whole runs
@pytest.fixture(scope="module")
def numba_vehicle():
    vehicle = aiauv_pin.load_vehicle()
    vehicle.backend = "numba"
    return vehicle


def test_measurement_and_output_match_the_python_adapter(numba_vehicle, rng):
    from conftest import random_state

    adapter = VehiclePathFollowing(numba_vehicle, PathFollowingGains.stabilised())
    compiled = CompiledPathFollowing(adapter)
    for k in range(4):  # successive calls: the finite-difference acceleration enters
        q, v = random_state(numba_vehicle.model, rng, speed=0.4)
        tau_expected, info_expected = adapter(0.01 * k, q, v)
        tau, info = compiled(0.01 * k, q, v)
        np.testing.assert_allclose(tau, tau_expected, **TIGHT)
        assert info.keys() == info_expected.keys()
        for key, value in info_expected.items():
            np.testing.assert_allclose(info[key], value, err_msg=key, **TIGHT)


def _same_trajectory(got, expected, tol) -> None:
    np.testing.assert_array_equal(got.t, expected.t)
    for name in ("q", "v", "tau"):
        np.testing.assert_allclose(getattr(got, name), getattr(expected, name), err_msg=name, **tol)
    assert got.info.keys() == expected.info.keys()
    for key, value in expected.info.items():
        assert got.info[key].shape == value.shape, key
        np.testing.assert_allclose(got.info[key], value, err_msg=key, **tol)


@pytest.mark.parametrize(
    "options",
    [
        dict(case="uniform"),
        dict(case="stabilised", control_period=0.03, current=(0.1, -0.05, 0.02)),
        dict(case="uniform", continuous_joints=False, method="euler", dt=0.005),
    ],
    ids=["paper", "held_with_current", "sampled_joints_euler"],
)
def test_compiled_scenario_matches_python_controller(numba_vehicle, options):
    scenario = PaperScenario(duration=2.0, **options)
    compiled = run_paper_scenario(numba_vehicle, scenario)
    python = run_paper_scenario(numba_vehicle, scenario, compiled=False)
    assert compiled.extra["compiled_controller"] and not python.extra["compiled_controller"]
    # same kernels for the dynamics: only the controller's rounding differs
    _same_trajectory(compiled.trajectory, python.trajectory, dict(rtol=1e-9, atol=1e-11))


def test_compiled_scenario_matches_pinocchio_reference():
    reference = aiauv_pin.load_vehicle()
    reference.backend = "pinocchio"
    fast = aiauv_pin.load_vehicle()
    fast.backend = "numba"
    scenario = PaperScenario(duration=1.5)
    expected = run_paper_scenario(reference, scenario)
    assert not expected.extra["compiled_controller"]
    got = run_paper_scenario(fast, scenario)
    _same_trajectory(got.trajectory, expected.trajectory, dict(rtol=1e-9, atol=1e-9))


def test_on_log_sees_every_logged_sample(numba_vehicle):
    scenario = PaperScenario(duration=2.5, control_period=0.02)
    seen = {True: [], False: []}
    for compiled in (True, False):
        run_paper_scenario(
            numba_vehicle,
            scenario,
            compiled=compiled,
            on_log=lambda t, q, info, c=compiled: seen[c].append((t, q[0], info["p"][1])),
        )
    assert len(seen[True]) == 126
    np.testing.assert_allclose(np.array(seen[True]), np.array(seen[False]), rtol=1e-9, atol=1e-12)


def test_divergence_reports_the_same_time_and_partial_trajectory(numba_vehicle):
    scenario = PaperScenario(duration=20.0, dt=0.5)
    errors = []
    for compiled in (True, False):
        with pytest.raises(SimulationDiverged) as error:
            run_paper_scenario(numba_vehicle, scenario, compiled=compiled)
        errors.append(error.value)
    got, expected = errors
    assert str(got) == str(expected) and "t = 1 s" in str(got)
    assert got.trajectory.status == "diverged"
    _same_trajectory(got.trajectory, expected.trajectory, dict(rtol=1e-9, atol=1e-11))


def test_custom_controllers_fall_back_to_python(numba_vehicle, paper_vehicle):
    class Quieter(VehiclePathFollowing):
        def __call__(self, t, q, v):
            tau, info = super().__call__(t, q, v)
            return 0.5 * tau, info

    custom = Quieter(numba_vehicle)
    assert "Quieter" in compiled_path_following_reason(custom)
    scenario = PaperScenario(duration=0.2)
    result = run_paper_scenario(numba_vehicle, scenario, controller=custom)
    assert not result.extra["compiled_controller"]
    plain = run_paper_scenario(numba_vehicle, scenario)
    # the subclass's halved thrust was applied: the run differs from the paper controller's
    assert not np.allclose(result.trajectory.tau[1:, :6], 0.5 * plain.trajectory.tau[1:, :6])
    with pytest.raises(ValueError, match="compiled path following unavailable") as error:
        run_paper_scenario(numba_vehicle, scenario, controller=custom, compiled=True)
    assert "\n" not in str(error.value)
    pinocchio_vehicle = aiauv_pin.load_vehicle()
    pinocchio_vehicle.backend = "pinocchio"
    assert "pinocchio" in compiled_path_following_reason(VehiclePathFollowing(pinocchio_vehicle))


# ---------------------------------------------------------------- result files (speed-ups)
def test_csv_text_is_that_of_numpy_savetxt(rng):
    import io

    from aiauv_pin.outputs import format_table

    table = rng.normal(size=(7, 5)) * np.logspace(-12, 12, 5)
    table[0, 0] = 0.0
    buffer = io.StringIO()
    np.savetxt(buffer, table, delimiter=",", header="a,b,c,d,e", comments="", fmt="%.9g")
    assert format_table(list("abcde"), table) == buffer.getvalue()


def test_csv_keeps_every_csv_period_and_the_summary_every_step(numba_vehicle, tmp_path):
    import json

    from aiauv_pin.outputs import write_results

    result = run_paper_scenario(numba_vehicle, PaperScenario(duration=1.03))
    write_results(result, tmp_path)
    rows = (tmp_path / "timeseries.csv").read_text().splitlines()[1:]
    times = [float(row.split(",")[0]) for row in rows]
    np.testing.assert_allclose(times, [*np.arange(0.0, 1.0001, 0.05), 1.03], atol=1e-12)
    content = json.loads((tmp_path / "summary.json").read_text())
    assert content["steps"] == 103  # integrals and settling times see every step


def test_plot_envelope_keeps_each_buckets_extremes_in_time_order(rng):
    from aiauv_pin.outputs import envelope

    t = np.arange(10_001) * 0.01
    y = np.cumsum(rng.normal(size=t.size)) + 5.0 * (rng.random(t.size) < 0.001)
    t_kept, y_kept = envelope(t, y, buckets=100)
    assert len(t_kept) <= 2 * 100 + 2 and np.all(np.diff(t_kept) > 0)
    assert (t_kept[0], t_kept[-1]) == (t[0], t[-1])
    size = -(-t.size // 100)
    for start in range(0, t.size, size):
        inside = (t_kept >= t[start]) & (t_kept <= t[min(start + size, t.size) - 1])
        assert y_kept[inside].max() == y[start : start + size].max()
        assert y_kept[inside].min() == y[start : start + size].min()
    _, short_y = envelope(t[:150], y[:150], buckets=100)
    assert np.array_equal(short_y, y[:150])
