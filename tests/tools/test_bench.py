"""``aiauv bench``: what it compares is what it claims to compare (no timing is asserted here)."""

from __future__ import annotations

import pytest

from aiauv_pin.app.cli import main
from aiauv_pin.model import loading
from aiauv_pin.scenario.definition import Scenario
from aiauv_pin.simulation.compiled_loop import loop_for, run_chunk
from aiauv_pin.tools import bench_command as bench


def test_user_controller_runs_the_built_in_law_in_the_uncached_loop():
    """The user's compiled controller (benchmarks/) follows the same trajectory as the built-in one
    (same law through the public API), and runs in the uncached copy of the loop as a user's would."""
    if not loading.load_vehicle().fast:
        pytest.skip("numba backend unavailable")
    results = bench.controller_comparison("uniform", 2.0, repeats=1)
    assert results["steps"] == round(2.0 / Scenario().dt)  # the whole run, at the default step
    assert results["user_loop"].startswith("run_chunk_for_")  # cached by content
    assert results["compilation_excluded"]
    assert results["max_configuration_difference"] <= 1e-12
    assert results["ratio_user_to_built_in_best"] > 0.0
    module = bench.load_user_controller()
    assert loop_for(module.user_path_following) is not run_chunk


def test_mujoco_model_is_the_exported_one_with_the_benchmarked_integrator():
    mujoco = pytest.importorskip("mujoco")
    vehicle = loading.load_vehicle()
    for integrator, code in (
        ("Euler", mujoco.mjtIntegrator.mjINT_EULER),
        ("RK4", mujoco.mjtIntegrator.mjINT_RK4),
    ):
        model = bench.mujoco_model("uniform", integrator, timestep=0.01)
        assert model.opt.integrator == code
        assert model.opt.timestep == 0.01
        assert model.nv == vehicle.nv
        assert model.body_mass.sum() == pytest.approx(
            sum(inertia.mass for inertia in vehicle.model.inertias), rel=1e-14
        )


def test_format_table_prints_the_controller_ratio():
    results = {
        "dynamics": {"numba_acceleration_in_kernel_us": 4.0},
        "mujoco": {"note": "mujoco not installed"},
        "scenario": {
            "case": "uniform",
            "backend": "numba",
            "simulated_time_s": 300.0,
            "simulation_us_per_step": 30.0,
            "real_time_factor": 150.0,
        },
        "controllers": {
            "case": "uniform",
            "duration_s": 300.0,
            "repeats": 7,
            "built_in": {"cpu_s_best": 1.0},
            "user": {"cpu_s_best": 1.1},
            "ratio_user_to_built_in_best": 1.1,
            "ratio_user_to_built_in_median": 1.05,
            "max_configuration_difference": 0.0,
        },
        "accuracy": {"duration_s": 10.0, "rows": []},
    }
    table = bench.format_table(results)
    assert "ratio user / built-in (best of 7 each)" in table
    assert "1.10 x" in table


def test_bench_rejects_a_bad_duration(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["bench", "--duration", "-1"])
    assert exit_info.value.code != 0
    assert "--duration" in capsys.readouterr().err


def test_native_mujoco_loop_calls_mj_forward():
    """The compiled loop that times MuJoCo natively (ctypes on its own library) computes exactly
    what ``mujoco.mj_forward`` computes from Python."""
    mujoco = pytest.importorskip("mujoco")
    pytest.importorskip("numba")
    import numpy as np

    from aiauv_pin.tools import native_benchmarks as bench_native

    model = bench.mujoco_model("uniform", "Euler")
    data, reference = mujoco.MjData(model), mujoco.MjData(model)
    for d in (data, reference):
        d.qvel[:] = 0.1 * np.arange(model.nv)
        d.qpos[7:] = 0.2
    mujoco.mj_forward(model, reference)
    forward_loop, _ = bench_native.native_loops()
    forward_loop(model._address, data._address, 1)
    np.testing.assert_array_equal(data.qacc, reference.qacc)
    assert np.any(data.qacc != 0.0)


def test_scaling_chain_has_the_requested_links_on_both_sides(tmp_path):
    """The scaling figure compares like with like: n links and the same nv in both models."""
    pytest.importorskip("mujoco")
    from aiauv_pin.builders.urdf_builder import build_urdf
    from aiauv_pin.builders.vehicle_spec import spec_from_dict
    from aiauv_pin.tools import native_benchmarks as bench_native

    urdf = tmp_path / "chain.urdf"
    urdf.write_text(build_urdf(spec_from_dict(bench_native.chain_spec(5))))
    vehicle = loading.load_vehicle(urdf)
    assert vehicle.model.njoints - 1 == 5 and vehicle.nv == 10
    assert bench_native.mujoco_model_of(urdf, "RK4").nv == vehicle.nv


def test_pinocchio_path_runs_blas_on_one_thread_for_large_models():
    """Issue 15: the reference path's small matrices lose to BLAS threads; the limit holds only
    during the call and only from SINGLE_THREAD_BLAS_FROM_NV on."""
    from threadpoolctl import threadpool_info

    from aiauv_pin.model.vehicle import SINGLE_THREAD_BLAS_FROM_NV, single_threaded_blas

    before = [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]
    with single_threaded_blas(SINGLE_THREAD_BLAS_FROM_NV):
        inside = [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]
    after = [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]
    assert all(n == 1 for n in inside)
    assert after == before
    with single_threaded_blas(SINGLE_THREAD_BLAS_FROM_NV - 1):
        small = [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]
    assert small == before


def test_derivative_section_measures_ratios_and_prints_them():
    """The derivatives' section of ``aiauv bench`` (issue 16): a short run gives positive times,
    the ratios to one evaluation and the targets, and the table prints them."""
    pytest.importorskip("numba")
    import aiauv_pin
    from aiauv_pin.tools.derivative_benchmarks import TARGETS, derivative_timings, format_rows

    results = derivative_timings(aiauv_pin.load_vehicle(), quick=True, rounds=1)
    assert results["targets"] == TARGETS
    for name in ("all_jacobians", "rk4_transition", "euler_transition"):
        assert results[f"{name}_us"] > 0.0
        ratio = results[f"ratio_{name}_to_evaluation"]
        assert ratio == pytest.approx(results[f"{name}_us"] / results["evaluation_us"])
    text = "\n".join(format_rows(results))
    assert "target <= 8x" in text and "target <= 40x" in text


def test_hand_written_mjcf_is_the_paper_vehicle():
    """benchmarks/paper_vehicle_hand.xml (written by hand, not by the exporter) loads in MuJoCo and
    has the paper vehicle's bodies, masses, inertias and velocity size (issue 34)."""
    mujoco = pytest.importorskip("mujoco")
    import numpy as np

    from aiauv_pin.tools import native_benchmarks as bench_native

    path = bench_native.HAND_MJCF
    if not path.is_file():
        pytest.skip("benchmarks/ is in a source checkout only")
    assert "written by `aiauv export`" not in path.read_text(encoding="utf-8")  # the exporter's
    model = mujoco.MjModel.from_xml_path(str(path))
    vehicle = loading.load_vehicle()
    assert model.nv == vehicle.nv and model.nq == vehicle.nq
    masses = [inertia.mass for inertia in vehicle.model.inertias][1:]
    assert model.body_mass.sum() == pytest.approx(sum(masses), rel=1e-14)
    for joint in range(1, vehicle.model.njoints):
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"link{joint}")
        inertia = vehicle.model.inertias[joint]
        assert model.body_mass[body] == pytest.approx(inertia.mass, rel=1e-14)
        np.testing.assert_allclose(model.body_ipos[body], inertia.lever, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            np.sort(model.body_inertia[body]), np.sort(np.diag(inertia.inertia)), rtol=1e-9
        )
    assert model.nu == len(vehicle.thruster_names)
    assert model.opt.density == 1000.0  # water, MuJoCo's own fluid model


def test_native_head_to_head_times_the_hand_written_mjcf_too():
    """The native comparison times MuJoCo on the exported and on the hand-written MJCF in the same
    rounds and reports both ratios (no timing asserted)."""
    pytest.importorskip("mujoco")
    from aiauv_pin.tools import native_benchmarks as bench_native

    vehicle = loading.load_vehicle()
    if vehicle.fast is None or not bench_native.HAND_MJCF.is_file():
        pytest.skip("numba backend or source checkout unavailable")
    urdf = loading.bundled_urdf("uniform")
    result = bench_native.native_head_to_head(
        vehicle, urdf, rounds=1, calls=8, hand_mjcf=bench_native.HAND_MJCF
    )
    for name in ("forward_python_fast", "forward_python_fast_hand", "forward_native_hand"):
        assert set(result["ratios"][name]) == {"median", "min", "max"}
    assert result["hand_mjcf"] == "paper_vehicle_hand.xml"
    assert len(result["load_average"]["before"]) == 3
    lines = "\n".join(bench._native_lines({"native": result}))
    assert "hand MJCF, from Python" in lines
    assert "vehicle.fast / mj_forward (hand)" in lines
