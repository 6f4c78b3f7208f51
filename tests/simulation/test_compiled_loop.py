"""The compiled simulation loop and the paper's controller in it, against the Python loop.

The laws themselves are written once (:mod:`aiauv_control.laws.paper_laws`, tested in
tests/hydro/test_laws.py); here the
vehicle side is checked: the compiled controller's measurement and action against the Python
adapter (:class:`aiauv_pin.controllers.paper_controller.VehiclePathFollowing`) on the same state,
whole compiled
runs against Python-controller runs and against the Pinocchio reference, logging, divergence, and
the reproduction of the runs recorded before the laws were moved (to 1e-9).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

import aiauv_pin
from aiauv_control.path_following import PathFollowingGains
from aiauv_pin.controllers.paper_controller import (
    VehiclePathFollowing,
    compiled_path_following_reason,
)
from aiauv_pin.errors import SimulationDiverged
from aiauv_pin.scenario.definition import PaperScenario, run_paper_scenario

TIGHT = dict(rtol=1e-12, atol=1e-12)
REFERENCE = Path(__file__).parents[1] / "data" / "paper_reference_60s.npz"


# ---------------------------------------------------------------- whole runs
@pytest.fixture(scope="module")
def numba_vehicle():
    vehicle = aiauv_pin.load_vehicle()
    vehicle.backend = "numba"
    return vehicle


def test_measurement_and_output_match_the_python_adapter(numba_vehicle, rng):
    from conftest import random_state

    for continuous in (True, False):
        adapter = VehiclePathFollowing(
            numba_vehicle, PathFollowingGains.stabilised(), continuous_joints=continuous
        )
        compiled = adapter.compiled()
        fast = numba_vehicle.fast
        for k in range(4):  # successive calls: the finite-difference acceleration enters
            q, v = random_state(numba_vehicle.model, rng, speed=0.4)
            tau_expected, info_expected = adapter(0.01 * k, q, v)
            tau = np.zeros(numba_vehicle.nv)
            row = np.zeros(compiled.info_width)
            compiled.function(
                0.01 * k,
                q,
                v,
                fast.model,
                fast.workspace,
                compiled.parameters,
                compiled.state,
                tau,
                row,
            )
            info = compiled.unpack(row)
            np.testing.assert_allclose(tau, tau_expected, **TIGHT)
            assert info.keys() == info_expected.keys()
            for key, value in info_expected.items():
                np.testing.assert_allclose(info[key], value, err_msg=key, **TIGHT)


@pytest.mark.parametrize("case", ["uniform", "stabilised"])
@pytest.mark.parametrize("feedforward", ["exact", "paper"])
def test_paper_runs_unchanged_by_the_move_of_the_laws(case, feedforward):
    """60 s of the paper scenario, sampled every 0.5 s, as recorded before the laws moved (with
    RK4 at 0.01 s, the default then)."""
    reference = np.load(REFERENCE)
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
    gains = PathFollowingGains.for_case(case, feedforward=feedforward)
    scenario = PaperScenario(case=case, duration=60.0, gains=gains, method="rk4", dt=0.01)
    result = run_paper_scenario(vehicle, scenario)
    trajectory = result.trajectory
    rows = np.arange(0, len(trajectory.t), 50)
    key = f"{case}_{feedforward}"
    np.testing.assert_array_equal(trajectory.t[rows], reference[f"{key}_t"])
    for name, got in (
        ("q", trajectory.q[rows]),
        ("v", trajectory.v[rows]),
        ("p", trajectory.info["p"][rows]),
        ("phi", trajectory.info["phi_tilde"][rows]),
        ("thrust", trajectory.info["thrust"][rows]),
    ):
        np.testing.assert_allclose(got, reference[f"{key}_{name}"], rtol=0, atol=1e-9, err_msg=name)


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
        dict(
            case="stabilised",
            control_period=0.03,
            current=(0.1, -0.05, 0.02),
            method="rk4",
            dt=0.01,
        ),
        dict(case="uniform", continuous_joints=False, method="euler", dt=0.005),
        dict(case="uniform", method="midpoint", dt=0.02),
        dict(
            case="stabilised",
            continuous_joints=False,
            current=(0.1, -0.05, 0.02),
            method="midpoint",
            dt=0.0025,  # the sampled joint PD oscillates at 0.005 s with this method
        ),
    ],
    ids=[
        "paper",
        "held_with_current_rk4",
        "sampled_joints_euler",
        "midpoint",
        "midpoint_sampled_joints_current",
    ],
)
def test_compiled_scenario_matches_python_controller(numba_vehicle, options):
    scenario = PaperScenario(duration=2.0, **options)
    compiled = run_paper_scenario(numba_vehicle, scenario)
    python = run_paper_scenario(numba_vehicle, scenario, compiled=False)
    assert compiled.extra["compiled_controller"] and not python.extra["compiled_controller"]
    # same kernels for the dynamics: only the controller's rounding differs
    _same_trajectory(compiled.trajectory, python.trajectory, dict(rtol=1e-9, atol=1e-11))


@pytest.mark.parametrize("method", ["euler", "midpoint"])
def test_compiled_scenario_matches_pinocchio_reference(method):
    reference = aiauv_pin.load_vehicle()
    reference.backend = "pinocchio"
    fast = aiauv_pin.load_vehicle()
    fast.backend = "numba"
    scenario = PaperScenario(duration=1.5, method=method)
    expected = run_paper_scenario(reference, scenario)
    assert not expected.extra["compiled_controller"]
    got = run_paper_scenario(fast, scenario)
    _same_trajectory(got.trajectory, expected.trajectory, dict(rtol=1e-9, atol=1e-9))


def test_after_first_chunk_runs_once_and_changes_nothing(numba_vehicle):
    """The CLI's background work starts after the first 10 s; the rest then runs in one call."""
    scenario = PaperScenario(duration=25.0)
    calls = []
    with_callback = run_paper_scenario(
        numba_vehicle, scenario, after_first_chunk=lambda: calls.append(1)
    )
    plain = run_paper_scenario(numba_vehicle, scenario)
    assert calls == [1]
    _same_trajectory(with_callback.trajectory, plain.trajectory, dict(rtol=0, atol=0))


def test_a_compiled_runs_trajectory_is_read_from_its_log_without_a_copy(numba_vehicle):
    """``t, q, v, tau`` of a compiled loop's run are columns of its log's rows (one row stride, at
    least a whole row's), with the values the Python controller's run holds in arrays of their
    own."""
    scenario = PaperScenario(duration=0.5)
    compiled = run_paper_scenario(numba_vehicle, scenario).trajectory
    assert numba_vehicle.fallback_reason is None
    arrays = (compiled.t, compiled.q, compiled.v, compiled.tau)
    row_bytes = 8 * (1 + numba_vehicle.nq + 2 * numba_vehicle.nv)
    assert len({a.strides[0] for a in arrays}) == 1 and arrays[0].strides[0] > row_bytes
    assert not compiled.q.flags.c_contiguous
    python = run_paper_scenario(numba_vehicle, scenario, compiled=False).trajectory
    assert python.q.flags.c_contiguous
    for got, expected in zip(arrays, (python.t, python.q, python.v, python.tau), strict=True):
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9)


def test_a_run_logs_into_the_memory_it_is_given_and_refuses_memory_that_does_not_fit(
    numba_vehicle,
):
    from aiauv_pin.errors import ArgumentError
    from aiauv_pin.scenario.definition import plan_run
    from aiauv_pin.simulation.fixed_step import simulate

    plan = plan_run(numba_vehicle, PaperScenario(duration=0.5))
    given = []

    def memory(shape):
        given.append(np.zeros(shape))
        return given[-1]

    trajectory = simulate(*plan.arguments, **plan.options, log_memory=memory)
    assert len(given) == 1 and np.shares_memory(trajectory.q, given[0])
    plain = simulate(*plan.arguments, **plan.options)
    _same_trajectory(trajectory, plain, dict(rtol=0, atol=0))
    refused = {
        "shape": lambda shape: np.zeros((shape[0] + 1, shape[1])),
        "float64": lambda shape: np.zeros(shape, dtype=np.float32),
        "C-ordered": lambda shape: np.zeros(shape, order="F"),
    }
    for word, bad in refused.items():
        with pytest.raises(ArgumentError, match=word) as error:
            simulate(*plan.arguments, **plan.options, log_memory=bad)
        assert "\n" not in str(error.value)


@pytest.mark.parametrize("method", ["rk4", "midpoint"])
def test_compile_only_loads_the_runs_loop_and_takes_no_step(numba_vehicle, method):
    """The warm-up of ``aiauv simulate`` (:func:`aiauv_pin.scenario.definition.warm_up`): the loop
    is called with no step to take, for exactly the types the run then uses (the run compiles no
    other specialisation), and no controller sample or step runs."""
    from aiauv_pin.scenario.definition import warm_up
    from aiauv_pin.simulation.compiled_loop import run_chunk

    scenario = PaperScenario(duration=1.0, method=method)
    controller = VehiclePathFollowing(numba_vehicle, PathFollowingGains.stabilised())
    law = controller.compiled()
    q0, v0 = numba_vehicle.neutral_configuration(), np.zeros(numba_vehicle.nv)
    v0[0] = 0.3
    before = [array.copy() for record in law.state for array in record]
    assert (
        aiauv_pin.simulate(numba_vehicle, q0, v0, 1.0, 0.01, law, method=method, compile_only=True)
        is None
    )
    after = [array for record in law.state for array in record]
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(before, after, strict=True))
    assert v0[0] == 0.3  # the initial state is copied, and no step took it anywhere
    warm_up(numba_vehicle, scenario)
    signatures = set(run_chunk.signatures)
    run_paper_scenario(numba_vehicle, scenario)
    assert set(run_chunk.signatures) == signatures


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
    scenario = PaperScenario(duration=20.0, dt=0.5, method="rk4")
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


def test_csv_keeps_every_csv_period_and_the_summary_every_step(numba_vehicle, tmp_path):
    import json

    from aiauv_pin.results.outputs import write_results

    scenario = PaperScenario(duration=1.032)  # the default step, 4 ms, and csv_period, 0.04 s
    result = run_paper_scenario(numba_vehicle, scenario)
    write_results(result, tmp_path)
    rows = (tmp_path / "timeseries.csv").read_text().splitlines()[1:]
    times = [float(row.split(",")[0]) for row in rows]
    np.testing.assert_allclose(times, [*np.arange(0.0, 1.0001, 0.04), 1.032], atol=1e-12)
    content = json.loads((tmp_path / "summary.json").read_text())
    assert content["steps"] == 258  # integrals and settling times see every step


def test_plot_envelope_keeps_each_buckets_extremes_in_time_order(rng):
    from aiauv_pin.results.outputs import envelope

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


def test_midpoint_samples_the_controller_at_each_stage_and_the_end(numba_vehicle):
    """The midpoint method samples inside each step at t + dt/2, and at the end, not at t = 0; a
    row at t holds the output applied over [t, t + dt] and the diagnostics of its sample at
    t + dt/2, the last row those of the sample at its own time. Compiled and Python loops alike."""
    dt, n = 0.01, 7
    q0 = numba_vehicle.neutral_configuration()
    stages = [(k + 0.5) * dt for k in range(n)]

    calls = []

    def controller(t, q, v):
        calls.append(t)
        return np.full(numba_vehicle.nv, t), {"sampled_at": t}

    run = aiauv_pin.simulate(
        numba_vehicle, q0, np.zeros(numba_vehicle.nv), n * dt, dt, controller, method="midpoint"
    )
    assert calls == pytest.approx([*stages, n * dt], abs=1e-15)
    np.testing.assert_allclose(run.info["sampled_at"], [*stages, n * dt], atol=1e-15)
    np.testing.assert_allclose(run.tau[:, 0], [*stages, n * dt], atol=1e-15)

    # the compiled loop logs the same way: the row's output is that of the step it starts
    scenario = PaperScenario(duration=n * dt, dt=dt, method="midpoint")
    compiled = run_paper_scenario(numba_vehicle, scenario)
    python = run_paper_scenario(numba_vehicle, scenario, compiled=False)
    _same_trajectory(compiled.trajectory, python.trajectory, dict(rtol=1e-9, atol=1e-11))
    assert np.all(np.isfinite(compiled.trajectory.info["u"]))
    assert np.any(compiled.trajectory.tau[0] != 0.0)
