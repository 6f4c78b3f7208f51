"""``aiauv bench``: speed and accuracy of the dynamics, the integrators and the paper scenario.

Measures, in one run on the paper vehicle:

* microseconds per forward-dynamics evaluation on both backends (Pinocchio reference, compiled
  numba, called from Python and inside compiled code);
* microseconds per RK4 and semi-implicit Euler step;
* the real-time factor of the paper scenario end to end (simulation plus ``timeseries.csv``,
  ``summary.json`` and figures; no HTML), both inside this process after a warm-up and as the
  wall time of a fresh ``aiauv simulate --no-html --quiet`` process (interpreter start, imports,
  loading the compiled kernels from the cache included);
* a new installation's first run (empty numba cache): CPU time with the kernels shipped with the
  package against compiling everything (:func:`aiauv_pin.tools.run_benchmarks.first_run`);
* an accuracy table: the largest end-effector distance, over the whole path and the whole scenario
  duration (10 s with ``--quick``), between a run at ``dt`` and one at ``dt / 4``;
* a user's compiled controller (``benchmarks/user_controller.py``, plain ``numba.njit`` outside the
  project's packages) against the built-in one on the same paper scenario, compiled loop, warm,
  interleaved repeats (source checkout only: the file is not installed);
* MuJoCo's ``mj_forward`` and ``mj_step`` (Euler, RK4) on the 9-body model that ``aiauv export``
  writes from the URDF (:func:`mujoco_model`), when the optional ``mujoco`` package is installed;
* the same comparison with both sides in native code, interleaved, as ratios with their range over
  rounds, and its scaling from 3 to 127 links (:mod:`aiauv_pin.tools.native_benchmarks`; the figure
  ``scaling.png`` is written next to the JSON).

The results are printed as a table and written atomically to JSON.
"""

from __future__ import annotations

import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from aiauv_pin._internal.argument_types import positive_seconds
from aiauv_pin._internal.atomic import write_text

#: Where ``aiauv bench`` writes its JSON by default.
DEFAULT_OUTPUT = Path("benchmarks") / "results.json"


# ---------------------------------------------------------------------- MuJoCo model
def mujoco_model(case: str, integrator: str, timestep: float = 0.01):
    """MuJoCo model of the bundled vehicle, as ``aiauv export`` writes it (:mod:`aiauv_pin.interop.mjcf`).

    Same kinematic tree, masses and inertias as the Pinocchio model, MuJoCo's ellipsoid fluid model
    on the links' collision cylinders, buoyancy as gravity compensation, the thrusters as
    actuators (idle here). MuJoCo's fluid model is not ours (no Fossen matrices), so only the cost
    is comparable, not the motion.

    Args:
        case: ``"uniform"`` or ``"stabilised"``.
        integrator: ``"Euler"`` or ``"RK4"`` (replaces the exporter's ``implicitfast``).
        timestep: ``opt.timestep`` [s].
    """
    import mujoco

    from aiauv_pin.interop.export_source import load_export_source
    from aiauv_pin.interop.mjcf import mjcf_text
    from aiauv_pin.model import loading

    model = mujoco.MjModel.from_xml_string(
        mjcf_text(load_export_source(loading.bundled_urdf(case)))
    )
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    model.opt.timestep = timestep
    return model


# ---------------------------------------------------------------------- timing helpers
# Micro-benchmarks use the process's CPU time (best of several rounds), which other processes on
# a busy machine disturb much less than wall-clock time; the scenario's real-time factor is
# wall-clock.
_clock = time.process_time


def _per_call(function, repeats: int, rounds: int = 7) -> float:
    """Best-of-rounds CPU microseconds per call of ``function()``."""
    function()
    best = float("inf")
    for _ in range(rounds):
        start = _clock()
        for _ in range(repeats):
            function()
        best = min(best, (_clock() - start) / repeats)
    return best * 1e6


def _per_unit(function, units: int, rounds: int = 7) -> float:
    """Best-of-rounds CPU microseconds per unit of ``function()`` (``units`` units of work)."""
    function()
    best = float("inf")
    for _ in range(rounds):
        start = _clock()
        function()
        best = min(best, (_clock() - start) / units)
    return best * 1e6


def _interleaved(functions: dict, rounds: int = 9) -> dict:
    """Best-of-rounds CPU microseconds per unit of each ``function()`` (name -> (function, units)),
    the functions taking turns within every round, so that a change of load on a shared machine
    hits them alike and their ratio holds."""
    for function, _ in functions.values():
        function()
    best = {name: float("inf") for name in functions}
    for _ in range(rounds):
        for name, (function, units) in functions.items():
            start = _clock()
            function()
            best[name] = min(best[name], (_clock() - start) / units)
    return {name: value * 1e6 for name, value in best.items()}


def _random_state(model, rng):
    import pinocchio as pin

    q = pin.neutral(model)
    q[:3] = rng.uniform(-1.0, 1.0, 3)
    quaternion = rng.normal(size=4)
    q[3:7] = quaternion / np.linalg.norm(quaternion)
    q[7:] = rng.uniform(-0.5, 0.5, model.nq - 7)
    return q, 0.3 * rng.normal(size=model.nv)


def dynamics_timings(vehicle, quick: bool = False) -> dict:
    """Microseconds per dynamics evaluation and per integrator step on each backend."""
    from aiauv_pin.reference.integrators import rk4_step, semi_implicit_euler_step

    rng = np.random.default_rng(5)
    q, v = _random_state(vehicle.model, rng)
    tau = rng.normal(size=vehicle.nv)
    n = 200 if quick else 2000
    requested = vehicle.backend
    results: dict = {}
    try:
        vehicle.backend = "pinocchio"
        results["pinocchio_acceleration_us"] = _per_call(
            lambda: vehicle.acceleration(q, v, tau), n // 10
        )

        def dyn(qq, vv):
            return vehicle.acceleration(qq, vv, tau)

        results["pinocchio_rk4_step_us"] = _per_call(
            lambda: rk4_step(vehicle.model, dyn, q, v, 0.01), n // 40
        )
        results["pinocchio_euler_step_us"] = _per_call(
            lambda: semi_implicit_euler_step(vehicle.model, dyn, q, v, 0.01), n // 10
        )
        vehicle.backend = "auto"
        fast = vehicle.fast
        if fast is None:
            results["numba_note"] = f"numba backend unavailable: {vehicle.fallback_reason}"
            return results
        from aiauv_pin.kernels import articulated_body as kernels
        from aiauv_pin.kernels.evaluation import METHOD_CODES

        results["numba_acceleration_python_call_us"] = _per_call(
            lambda: fast.acceleration(q, v, tau), n
        )
        model, env, servo, W = fast.model, fast.still_water, fast.no_servo, fast.workspace
        out = np.empty(vehicle.nv)
        m = 20 * n
        results["numba_acceleration_in_kernel_us"] = _per_unit(
            lambda: kernels.time_accelerations(model, env, servo, q, v, tau, m, W, out), m
        )
        for method in ("rk4", "euler"):
            steps = 5 * n

            def run(method=method, steps=steps):
                qq, vv = q.copy(), v.copy()
                done = kernels.run_steps(
                    model, env, servo, 0.0, qq, vv, tau, 0.001, steps, METHOD_CODES[method], W
                )
                if done != steps:
                    raise RuntimeError(f"bench: the {method} run diverged after {done} steps")

            results[f"numba_{method}_step_us"] = _per_unit(run, steps)
    finally:
        vehicle.backend = requested
    return results


def mujoco_timings(case: str, quick: bool = False) -> dict:
    """MuJoCo's ``mj_forward`` and ``mj_step`` on the exported model of the bundled vehicle
    (:func:`mujoco_model`; ``note`` if mujoco is not installed)."""
    try:
        import mujoco
    except ImportError:
        return {"note": "mujoco not installed (pip install 'aiauv-pin[bench]'); rows skipped"}
    n = 200 if quick else 2000
    results: dict = {"version": mujoco.__version__}
    for integrator in ("Euler", "RK4"):
        model = mujoco_model(case, integrator)
        data = mujoco.MjData(model)
        rng = np.random.default_rng(5)
        data.qvel[:] = 0.3 * rng.normal(size=model.nv)
        data.qpos[7:] = rng.uniform(-0.5, 0.5, model.nq - 7)
        mujoco.mj_forward(model, data)
        if integrator == "Euler":
            results["mj_forward_us"] = _per_call(
                lambda model=model, data=data: mujoco.mj_forward(model, data), n
            )
            results["n_bodies"] = int(model.nbody - 1)
            results["nv"] = int(model.nv)
        qpos, qvel = data.qpos.copy(), data.qvel.copy()

        def step(model=model, data=data, qpos=qpos, qvel=qvel):
            data.qpos[:] = qpos
            data.qvel[:] = qvel
            for _ in range(n):
                mujoco.mj_step(model, data)

        results[f"mj_step_{integrator.lower()}_us"] = _per_unit(step, n)
    return results


def head_to_head(vehicle, case: str, quick: bool = False) -> dict:
    """The compiled dynamics and RK4 step against MuJoCo's ``mj_forward`` and RK4 ``mj_step``,
    timed interleaved (:func:`_interleaved`) in one process; the ratios are the comparison.

    Returns an empty dict without mujoco or the compiled backend.
    """
    try:
        import mujoco
    except ImportError:
        return {}
    fast = vehicle.fast
    if fast is None:
        return {}
    from aiauv_pin.kernels import articulated_body as kernels
    from aiauv_pin.kernels.evaluation import METHOD_CODES

    n = 200 if quick else 2000
    rng = np.random.default_rng(5)
    q, v = _random_state(vehicle.model, rng)
    tau = rng.normal(size=vehicle.nv)
    model, env, servo, W = fast.model, fast.still_water, fast.no_servo, fast.workspace
    out = np.empty(vehicle.nv)
    m = 2 * n  # about as long a round as MuJoCo's n calls

    def ours_forward():
        kernels.time_accelerations(model, env, servo, q, v, tau, m, W, out)

    def ours_rk4():
        qq, vv = q.copy(), v.copy()
        kernels.run_steps(model, env, servo, 0.0, qq, vv, tau, 0.001, n, METHOD_CODES["rk4"], W)

    forward_model, rk4_model = mujoco_model(case, "Euler"), mujoco_model(case, "RK4")
    forward_data, rk4_data = mujoco.MjData(forward_model), mujoco.MjData(rk4_model)
    for data in (forward_data, rk4_data):
        data.qvel[:] = 0.3 * rng.normal(size=forward_model.nv)
        data.qpos[7:] = rng.uniform(-0.5, 0.5, forward_model.nq - 7)
    qpos, qvel = rk4_data.qpos.copy(), rk4_data.qvel.copy()

    def theirs_forward():
        for _ in range(n):
            mujoco.mj_forward(forward_model, forward_data)

    def theirs_rk4():
        rk4_data.qpos[:] = qpos
        rk4_data.qvel[:] = qvel
        for _ in range(n):
            mujoco.mj_step(rk4_model, rk4_data)

    us = _interleaved(
        {
            "numba_acceleration_in_kernel_us": (ours_forward, m),
            "mj_forward_us": (theirs_forward, n),
            "numba_rk4_step_us": (ours_rk4, n),
            "mj_step_rk4_us": (theirs_rk4, n),
        },
        rounds=5 if quick else 11,
    )
    return {
        **us,
        "ratio_numba_in_kernel_to_mj_forward": us["numba_acceleration_in_kernel_us"]
        / us["mj_forward_us"],
        "ratio_numba_rk4_step_to_mj_step_rk4": us["numba_rk4_step_us"] / us["mj_step_rk4_us"],
    }


# ---------------------------------------------------------------------- scenario
def scenario_timing(case: str, duration: float, out_dir: Path) -> dict:
    """Wall time and real-time factor of the paper scenario including its result files (no HTML)."""
    from aiauv_pin.model import loading
    from aiauv_pin.results.outputs import write_results
    from aiauv_pin.scenario.definition import Scenario, run_scenario

    vehicle = loading.load_vehicle(loading.bundled_urdf(case))
    run_scenario(vehicle, Scenario(case=case, duration=1.0))  # warm-up (compilation)
    start = time.perf_counter()
    result = run_scenario(vehicle, Scenario(case=case, duration=duration))
    simulated = time.perf_counter()
    write_results(result, out_dir)
    end = time.perf_counter()
    steps = len(result.trajectory.t) - 1
    return {
        "case": case,
        "backend": vehicle.active_backend,
        "compiled_controller": bool(result.extra.get("compiled_controller", False)),
        "simulated_time_s": float(result.trajectory.t[-1]),
        "simulation_wall_s": simulated - start,
        "simulation_us_per_step": 1e6 * (simulated - start) / max(steps, 1),
        "outputs_wall_s": end - simulated,
        "real_time_factor": float(result.trajectory.t[-1]) / (end - start),
    }


#: The user's compiled controller timed by :func:`controller_comparison` (a source checkout's
#: ``benchmarks/user_controller.py``; not installed with the package).
USER_CONTROLLER_FILE = Path(__file__).resolve().parents[2] / "benchmarks" / "user_controller.py"


def load_user_controller(path: Path = USER_CONTROLLER_FILE):
    """The module ``benchmarks/user_controller.py``, imported from its file (once per process).

    It is loaded under a name outside the project's packages, as a user's own module would be, so
    the compiled loop runs its controller in a copy cached by the function's content
    (:func:`aiauv_pin.simulation.compiled_loop.loop_for`).
    """
    import importlib.util

    name = "aiauv_bench_user_controller"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def controller_comparison(case: str, duration: float, repeats: int) -> dict:
    """A user's compiled controller against the built-in one on the same paper scenario.

    Both run the paper's path following (the user's from the public laws,
    ``benchmarks/user_controller.py``; the built-in
    :func:`aiauv_pin.controllers.paper_compiled.paper_path_following`)
    with the same parameters, start state and servo, through :func:`aiauv_pin.simulate`'s compiled
    loop. Each is run once for 1 s first, which compiles or loads it (the user's function in a copy of
    the loop cached by its content, :func:`aiauv_pin.simulation.compiled_loop.loop_for`), so
    compilation is excluded; then
    ``repeats`` runs of each, interleaved, timed in process CPU time and wall time. The ratio is
    the user's best time over the built-in's best time (and the same with the medians). The
    largest difference between the two trajectories' configurations is reported too: they run the
    same law and must agree.
    """
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.definition import Scenario, initial_state
    from aiauv_pin.simulation.fixed_step import simulate

    if not USER_CONTROLLER_FILE.is_file():
        return {"note": f"{USER_CONTROLLER_FILE} not found (source checkout only); skipped"}
    vehicle = loading.load_vehicle(loading.bundled_urdf(case))
    if vehicle.fast is None:
        return {"note": f"numba backend unavailable: {vehicle.fallback_reason}; skipped"}
    from aiauv_pin.simulation.compiled_loop import loop_for

    user_module = load_user_controller()
    scenario = Scenario(case=case, duration=duration)
    q0, v0 = initial_state(vehicle, scenario)
    adapter = VehiclePathFollowing(
        vehicle,
        scenario.controller_gains,
        continuous_joints=scenario.continuous_joints,
        path=scenario.path_to_follow,
    )
    built_in = adapter.compiled()
    controllers = {"built_in": built_in, "user": user_module.user_controller(built_in)}

    def run(controller, seconds: float):
        return simulate(
            vehicle,
            q0,
            v0,
            seconds,
            scenario.dt,
            controller,
            method=scenario.method,
            current=scenario.water,
            control_period=scenario.control_period,
            log_every=scenario.steps_per_control,
        )

    for controller in controllers.values():
        run(controller, 1.0)  # warm-up: compiles the loop for this controller
    cpu: dict[str, list[float]] = {key: [] for key in controllers}
    wall: dict[str, list[float]] = {key: [] for key in controllers}
    configurations = {}
    for _ in range(repeats):
        for key, controller in controllers.items():
            start_cpu, start_wall = _clock(), time.perf_counter()
            trajectory = run(controller, duration)
            cpu[key].append(_clock() - start_cpu)
            wall[key].append(time.perf_counter() - start_wall)
            if trajectory.status != "complete":
                raise RuntimeError(f"bench: the {key} controller's run {trajectory.status}")
            configurations[key] = trajectory.q
    steps = round(duration / scenario.dt)
    results: dict = {
        "case": case,
        "duration_s": duration,
        "steps": steps,
        "repeats": repeats,
        "user_controller": f"benchmarks/{USER_CONTROLLER_FILE.name}::user_path_following",
        # run_chunk_for_<digest>: cached by the content of the user's function (loop_for)
        "user_loop": loop_for(controllers["user"].loop_function, built_in.parameters).__name__,
        "compilation_excluded": True,
    }
    for key in controllers:
        results[key] = {
            "cpu_s_best": min(cpu[key]),
            "cpu_s_median": float(np.median(cpu[key])),
            "cpu_s_all": cpu[key],
            "wall_s_all": wall[key],
            "us_per_step_best": 1e6 * min(cpu[key]) / steps,
        }
    results["ratio_user_to_built_in_best"] = min(cpu["user"]) / min(cpu["built_in"])
    results["ratio_user_to_built_in_median"] = float(np.median(cpu["user"])) / float(
        np.median(cpu["built_in"])
    )
    results["max_configuration_difference"] = float(
        np.max(np.abs(configurations["user"] - configurations["built_in"]))
    )
    return results


def command_line_timing(case: str, duration: float, out_dir: Path, repeats: int = 3) -> dict:
    """Wall time of a fresh ``aiauv simulate --no-html --quiet`` process (best of ``repeats``)."""
    command = [
        sys.executable,
        "-m",
        "aiauv_pin.app.cli",
        "simulate",
        "--case",
        case,
        "--duration",
        f"{duration:g}",
        "--no-html",
        "--quiet",
        "--out",
        str(out_dir),
    ]
    walls = []
    out_dir = Path(out_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    for _ in range(repeats):
        start = time.perf_counter()
        # run outside the current folder: ``python -m`` puts it first on sys.path, and in a source
        # checkout (the repository root) that would import the source tree instead of the
        # installed package (whose aiauv_pin.urdf lives in urdf/ of the tree)
        run = subprocess.run(command, capture_output=True, text=True, cwd=out_dir)
        walls.append(time.perf_counter() - start)
        if run.returncode != 0:
            said = (run.stderr.strip().splitlines() or ["no message"])[-1]
            from aiauv_pin.errors import AiauvError

            raise AiauvError(f"'aiauv simulate' failed in a fresh process: {said}")
    return {
        "command": "aiauv " + " ".join(command[3:-2]),
        "wall_s": min(walls),
        "wall_s_all": walls,
        "real_time_factor": duration / min(walls),
    }


def accuracy_table(case: str, duration: float, dts: tuple[float, ...]) -> list[dict]:
    """Largest end-effector distance over the path between RK4 runs at ``dt`` and ``dt / 4`` (the
    error against a converged reference, every method: ``accuracy-per-cost``)."""
    from aiauv_pin.errors import SimulationDiverged
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.definition import Scenario, run_scenario

    vehicle = loading.load_vehicle(loading.bundled_urdf(case))
    rows = []
    for dt in dts:
        try:
            coarse = run_scenario(
                vehicle, Scenario(case=case, duration=duration, dt=dt, method="rk4")
            )
        except SimulationDiverged:
            rows.append({"dt": dt, "reference_dt": dt / 4, "max_end_effector_error_m": None})
            continue
        fine = run_scenario(
            vehicle, Scenario(case=case, duration=duration, dt=dt / 4, method="rk4")
        )
        p_coarse = coarse.trajectory.info["p"]
        p_fine = fine.trajectory.info["p"][::4]
        n = min(len(p_coarse), len(p_fine))
        if not np.allclose(coarse.trajectory.t[:n], fine.trajectory.t[::4][:n], atol=1e-9):
            raise RuntimeError("accuracy table: log times of the two runs do not coincide")
        error = np.linalg.norm(p_coarse[:n] - p_fine[:n], axis=1)
        rows.append(
            {"dt": dt, "reference_dt": dt / 4, "max_end_effector_error_m": float(error.max())}
        )
    return rows


# ---------------------------------------------------------------------- command
def machine() -> dict:
    """The machine and the versions of everything timed."""
    import importlib.metadata
    import os

    versions = {}
    for package in ("aiauv-pin", "numpy", "numba", "pin", "mujoco", "threadpoolctl"):
        try:
            versions[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            versions[package] = None
    try:
        load = os.getloadavg()
    except OSError:
        load = None
    return {
        "python": platform.python_version(),
        "processor": platform.processor() or platform.machine(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "load_average_at_start": load,
        "versions": versions,
        # what numba compiles for: the portable level of the shipped kernels, or the host's CPU
        "numba_cpu_name": os.environ.get("NUMBA_CPU_NAME", "host"),
    }


def run_bench(
    quick: bool = False, case: str = "uniform", duration: float | None = None, only: str = "all"
) -> dict:
    """Every measurement of ``aiauv bench``; see the module docstring.

    ``only="kernels"`` times the dynamics, the MuJoCo comparisons and the scaling only (no scenario
    runs, no accuracy table).
    """
    from aiauv_pin.model import loading
    from aiauv_pin.tools import native_benchmarks as bench_native

    urdf = loading.bundled_urdf(case)
    vehicle = loading.load_vehicle(urdf)
    scenario_duration = duration if duration is not None else (20.0 if quick else 300.0)
    accuracy_duration = 10.0 if quick else scenario_duration
    results: dict = {
        "machine": machine(),
        "quick": quick,
        "vehicle": {"case": case, "nq": vehicle.nq, "nv": vehicle.nv},
        "dynamics": dynamics_timings(vehicle, quick),
        "mujoco": mujoco_timings(case, quick),
        "head_to_head": head_to_head(vehicle, case, quick),
        "native": native_part(vehicle, urdf, case, quick),
        "scaling": bench_native.scaling(
            (3, 9) if quick else bench_native.SCALING_LINKS, rounds=3 if quick else 9
        ),
    }
    if only == "kernels":
        return results
    with tempfile.TemporaryDirectory() as folder:
        results["scenario"] = scenario_timing(case, scenario_duration, Path(folder))
        results["controllers"] = controller_comparison(
            case, scenario_duration, repeats=3 if quick else 7
        )
        results["command_line"] = command_line_timing(
            case, scenario_duration, Path(folder) / "cli", repeats=1 if quick else 3
        )
    results["accuracy"] = {
        "case": case,
        "duration_s": accuracy_duration,
        "rows": accuracy_table(case, accuracy_duration, (0.01,) if quick else (0.02, 0.01, 0.005)),
    }
    results.update(run_parts(WHOLE_RUN_PARTS, quick=quick, case=case, duration=duration))
    dyn, mj = results["dynamics"], results["mujoco"]
    if "mj_forward_us" in mj and "numba_acceleration_python_call_us" in dyn:
        results["ratio_numba_python_call_to_mj_forward"] = (
            dyn["numba_acceleration_python_call_us"] / mj["mj_forward_us"]
        )
    from aiauv_pin.tools.derivative_benchmarks import derivative_timings

    results["derivatives"] = derivative_timings(vehicle, quick)
    h2h = results["head_to_head"]
    if h2h:
        results["ratio_numba_in_kernel_to_mj_forward"] = h2h["ratio_numba_in_kernel_to_mj_forward"]
        results["ratio_numba_rk4_step_to_mj_step_rk4"] = h2h["ratio_numba_rk4_step_to_mj_step_rk4"]
    return results


def native_part(vehicle, urdf, case: str, quick: bool) -> dict:
    """:func:`aiauv_pin.tools.native_benchmarks.native_head_to_head` of the paper vehicle, with
    MuJoCo also on the hand-written MJCF of the uniform case when the checkout has it
    (``aiauv bench --only native``, and part of ``kernels``)."""
    from aiauv_pin.tools import native_benchmarks as bench_native

    hand = bench_native.HAND_MJCF
    return bench_native.native_head_to_head(
        vehicle,
        urdf,
        rounds=5 if quick else 21,
        hand_mjcf=hand if case == "uniform" and hand.is_file() else None,
    )


#: Whole-run measurements of :mod:`aiauv_pin.tools.run_benchmarks` (``aiauv bench --only PART ...``).
WHOLE_RUN_PARTS = (
    "throughput",
    "end-to-end",
    "memory",
    "first-run",
    "accuracy-per-cost",
    "gym",
)


def run_parts(
    parts, quick: bool = False, case: str = "uniform", duration: float | None = None
) -> dict:
    """The whole-run measurements ``parts`` (keys of the results: ``-`` becomes ``_``)."""
    from aiauv_pin.tools import run_benchmarks as bench_run

    seconds = duration if duration is not None else (20.0 if quick else 300.0)
    out: dict = {}
    for part in parts:
        if part == "throughput":
            out["throughput"] = bench_run.throughput(
                case, seconds, runs=2 if quick else 8, rounds=1 if quick else 3
            )
        elif part == "end-to-end":
            out["end_to_end"] = bench_run.end_to_end(case, seconds, repeats=1 if quick else 5)
        elif part == "memory":
            out["memory"] = bench_run.memory(
                (9, 127) if quick else bench_run.MEMORY_LINKS,
                duration=1.0 if quick else 10.0,
                repeats=1 if quick else 3,
            )
        elif part == "first-run":
            out["first_run"] = bench_run.first_run(
                case, repeats=1 if quick else 3, compile_repeats=1 if quick else 2
            )
        elif part == "accuracy-per-cost":
            out["accuracy_per_cost"] = bench_run.accuracy_per_cost(
                case, 10.0 if quick else seconds, repeats=1 if quick else 3
            )
        elif part == "gym":
            try:
                from aiauv_pin.tools.gym_benchmarks import gym_timings

                out["gym"] = gym_timings(quick)
            except ImportError as exc:  # the optional gymnasium[mujoco]
                out["gym"] = {"note": f"skipped: {exc}"}
    return out


def _native_lines(results: dict) -> list[str]:
    """The native and scaling comparisons (:mod:`aiauv_pin.tools.native_benchmarks`) as table lines."""
    lines = []
    m = results.get("machine", {})
    versions = ", ".join(f"{k} {v}" for k, v in m.get("versions", {}).items() if v)
    lines.append(
        f"machine: {m.get('processor')}, {m.get('cpus')} CPUs, load average at start "
        f"{m.get('load_average_at_start')}; {m.get('platform')}; Python {m.get('python')}"
    )
    lines.append(f"versions: {versions}; numba compiles for {m.get('numba_cpu_name', 'host')}")
    native = results.get("native") or {}
    if native:
        t, r = native["times"], native["ratios"]
        load = native.get("load_average")
        lines.append(
            f"interleaved, {native['rounds']} rounds, {native['links']} links (median [min-max] us)"
            + (f", load {load['before'][0]:.2f} -> {load['after'][0]:.2f}:" if load else ":")
        )
        for name, label in (
            ("ours_forward_native", "evaluation, compiled loop"),
            ("mujoco_forward_native", "MuJoCo mj_forward, compiled loop"),
            ("ours_rk4_step_native", "RK4 step, compiled loop"),
            ("mujoco_rk4_step_native", "MuJoCo mj_step RK4, compiled loop"),
            ("ours_forward_python", "evaluation, vehicle.fast.acceleration from Python"),
            ("ours_forward_vehicle_python", "evaluation, Vehicle.acceleration from Python"),
            ("mujoco_forward_python", "MuJoCo mj_forward from Python"),
            ("mujoco_forward_native_hand", "MuJoCo mj_forward, hand MJCF, compiled loop"),
            ("mujoco_forward_python_hand", "MuJoCo mj_forward, hand MJCF, from Python"),
        ):
            if name not in t:
                continue
            lines.append(
                f"  {label:<52} {t[name]['median_us']:8.2f} "
                f"[{t[name]['min_us']:.2f}-{t[name]['max_us']:.2f}]"
            )
        for name, label in (
            ("forward_native", "ratio evaluation / mj_forward, both native"),
            ("rk4_step_native", "ratio RK4 step / mj_step RK4, both native"),
            ("forward_python_fast", "ratio from Python: vehicle.fast / mj_forward"),
            ("forward_python_vehicle", "ratio from Python: Vehicle.acceleration / mj_forward"),
            ("forward_native_hand", "ratio evaluation / mj_forward (hand), both native"),
            ("forward_python_fast_hand", "ratio from Python: vehicle.fast / mj_forward (hand)"),
            ("forward_python_vehicle_hand", "ratio from Python: Vehicle.accel. / mj_fwd (hand)"),
        ):
            if name not in r:
                continue
            x = r[name]
            lines.append(f"  {label:<52} {x['median']:8.3f} [{x['min']:.3f}-{x['max']:.3f}]")
    rows = (results.get("scaling") or {}).get("rows", [])
    if rows:
        lines.append(
            "scaling (chains of equal modules; median us per evaluation; ratios median [range]):"
        )
        lines.append(
            "  links   compiled    MuJoCo  Pinocchio   eval/mj_forward        RK4/mj_step(RK4)"
        )
        for row in rows:
            t, r = row["times"], row["ratios"]
            pinocchio = t.get("pinocchio_forward_python", {}).get("median_us", float("nan"))
            f, k = r["forward_native"], r["rk4_step_native"]
            lines.append(
                f"  {row['links']:5d} {t['ours_forward_native']['median_us']:10.2f} "
                f"{t['mujoco_forward_native']['median_us']:9.2f} {pinocchio:10.1f}   "
                f"{f['median']:.3f} [{f['min']:.3f}-{f['max']:.3f}]   "
                f"{k['median']:.3f} [{k['min']:.3f}-{k['max']:.3f}]"
            )
    return lines


def format_table(results: dict) -> str:
    """Human-readable summary of :func:`run_bench`'s results."""
    dyn, mj = results["dynamics"], results["mujoco"]
    sc = results.get("scenario")
    lines = ["quantity                                         value"]

    def row(label: str, value, unit: str = "us") -> None:
        if value is not None:
            lines.append(f"{label:<48} {value:10.2f} {unit}")

    row("Pinocchio acceleration", dyn.get("pinocchio_acceleration_us"))
    row("numba acceleration (Python call)", dyn.get("numba_acceleration_python_call_us"))
    row("numba acceleration (inside compiled code)", dyn.get("numba_acceleration_in_kernel_us"))
    row("Pinocchio RK4 step", dyn.get("pinocchio_rk4_step_us"))
    row("Pinocchio Euler step", dyn.get("pinocchio_euler_step_us"))
    row("numba RK4 step", dyn.get("numba_rk4_step_us"))
    row("numba Euler step", dyn.get("numba_euler_step_us"))
    if "note" in mj:
        lines.append(f"MuJoCo: {mj['note']}")
    else:
        row(f"MuJoCo {mj['version']} mj_forward ({mj['n_bodies']} bodies)", mj["mj_forward_us"])
        row("MuJoCo mj_step Euler", mj["mj_step_euler_us"])
        row("MuJoCo mj_step RK4", mj["mj_step_rk4_us"])
        row(
            "ratio numba (Python call) / mj_forward",
            results.get("ratio_numba_python_call_to_mj_forward"),
            "",
        )
        h2h = results.get("head_to_head") or {}
        if h2h:
            row(
                "interleaved: numba (in kernel) acceleration",
                h2h["numba_acceleration_in_kernel_us"],
            )
            row("interleaved: MuJoCo mj_forward", h2h["mj_forward_us"])
            row("interleaved: numba RK4 step", h2h["numba_rk4_step_us"])
            row("interleaved: MuJoCo mj_step RK4", h2h["mj_step_rk4_us"])
        row(
            "ratio numba (in kernel) / mj_forward (interleaved)",
            results.get("ratio_numba_in_kernel_to_mj_forward"),
            "",
        )
        row(
            "ratio numba RK4 step / mj_step RK4 (interleaved)",
            results.get("ratio_numba_rk4_step_to_mj_step_rk4"),
            "",
        )
    lines.extend(_native_lines(results))
    if sc is None:
        return "\n".join(lines)
    row(
        f"scenario {sc['case']} {sc['simulated_time_s']:.0f} s [{sc['backend']}] per step",
        sc.get("simulation_us_per_step"),
    )
    row(
        f"scenario {sc['case']} {sc['simulated_time_s']:.0f} s [{sc['backend']}] real-time factor",
        sc["real_time_factor"],
        "x",
    )
    cc = results.get("controllers")
    if cc is not None and "note" in cc:
        lines.append(f"user's compiled controller: {cc['note']}")
    elif cc is not None:
        label = f"scenario {cc['case']} {cc['duration_s']:.0f} s, compiled loop, warm, CPU"
        row(f"{label}: built-in controller", cc["built_in"]["cpu_s_best"], "s")
        row("  user's compiled controller (benchmarks/)", cc["user"]["cpu_s_best"], "s")
        row(
            f"  ratio user / built-in (best of {cc['repeats']} each)",
            cc["ratio_user_to_built_in_best"],
            "x",
        )
        row("  ratio user / built-in (medians)", cc["ratio_user_to_built_in_median"], "x")
        lines.append(
            f"  largest configuration difference user vs built-in: "
            f"{cc['max_configuration_difference']:.3g}"
        )
    cl = results.get("command_line")
    if cl is not None:
        row(f"'{cl['command']}' wall time", cl["wall_s"], "s")
        row("  end-to-end real-time factor (fresh process)", cl["real_time_factor"], "x")
    if "derivatives" in results:
        from aiauv_pin.tools.derivative_benchmarks import format_rows

        lines.extend(format_rows(results["derivatives"]))
    acc = results["accuracy"]
    for r in acc["rows"]:
        if r["max_end_effector_error_m"] is None:
            lines.append(f"dt={r['dt']:g}: the scenario diverges (joint servo too stiff for RK4)")
            continue
        row(
            f"max EE error RK4 dt={r['dt']:g} vs {r['reference_dt']:g} ({acc['duration_s']:.0f} s)",
            1000.0 * r["max_end_effector_error_m"],
            "mm",
        )
    from aiauv_pin.tools.run_benchmarks import format_parts

    lines.extend(format_parts(results))
    return "\n".join(lines)


def add_bench_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="measure dynamics, integrator and scenario speed (and MuJoCo's, if installed)",
        description="Benchmark both dynamics backends, the integrators, the paper scenario end to "
        "end and its time-step accuracy, and MuJoCo on the equivalent model; print a table and "
        "write JSON.",
    )
    parser.add_argument("--quick", action="store_true", help="short CI-friendly run")
    parser.add_argument(
        "--case",
        choices=("uniform", "stabilised"),
        default="uniform",
        help="the paper vehicle's case to time (uniform)",
    )
    parser.add_argument(
        "--duration",
        type=positive_seconds,
        default=None,
        help="scenario duration [s] (300; 20 with --quick)",
    )
    parser.add_argument("--out", type=Path, default=DEFAULT_OUTPUT, help="JSON file to write")
    parser.add_argument(
        "--only",
        nargs="+",
        choices=("kernels", "native", *WHOLE_RUN_PARTS),
        metavar="PART",
        help="measure only these parts and update them in the JSON file (kernels: the dynamics, "
        "MuJoCo and scaling figures, no scenario runs; native: only the paper vehicle against "
        "MuJoCo (exported and hand-written MJCF), natively and from Python, part of kernels; "
        "throughput: runs per minute of sweeps and "
        "rollout; end-to-end: fresh 'aiauv simulate' processes; memory: peak memory of fresh "
        "processes simulating 9- to 127-link chains; first-run: a new installation's first run, "
        "shipped kernels against compiling everything; accuracy-per-cost: error against a "
        "converged reference per method and step; gym: the Gymnasium environments' steps per "
        "second against MuJoCo's Swimmer-v5, single and vectorised)",
    )
    parser.set_defaults(handler=_run_bench_command)


def _run_bench_command(args) -> int:
    from aiauv_pin._internal.atomic import check_output_file

    for path in (args.out, Path(args.out).parent / "scaling.png"):  # refused before measuring
        check_output_file(path)
    if args.only:
        results = {}
        if args.out.is_file():
            results = json.loads(args.out.read_text(encoding="utf-8"))
        lines = []
        if "kernels" in args.only:
            kernels = run_bench(
                quick=args.quick, case=args.case, duration=args.duration, only="kernels"
            )
            results.update(kernels)
            lines.append(format_table(kernels))
        if "native" in args.only and "kernels" not in args.only:
            from aiauv_pin.model import loading

            urdf = loading.bundled_urdf(args.case)
            native = {
                "machine": machine(),
                "native": native_part(loading.load_vehicle(urdf), urdf, args.case, args.quick),
            }
            results["native"] = native["native"]
            lines.extend(_native_lines(native))
        parts = [part for part in args.only if part not in ("kernels", "native")]
        if parts:
            from aiauv_pin.tools.run_benchmarks import format_parts

            measured = run_parts(parts, quick=args.quick, case=args.case, duration=args.duration)
            results.update(measured)
            lines.extend(format_parts(measured))
        write_text(args.out, json.dumps(results, indent=2) + "\n")
        print("\n".join(lines))
        print(f"-> {args.out}")
        if "kernels" in args.only:  # the figure of the scaling just measured
            _write_scaling_figure(results, args.out)
        return 0
    results = run_bench(quick=args.quick, case=args.case, duration=args.duration)
    write_text(args.out, json.dumps(results, indent=2) + "\n")
    print(format_table(results))
    print(f"-> {args.out}")
    _write_scaling_figure(results, args.out)
    return 0


def _write_scaling_figure(results: dict, out: Path) -> None:
    """``scaling.png`` next to the JSON file ``out``, from ``results``' scaling rows (if any)."""
    if (results.get("scaling") or {}).get("rows"):
        from aiauv_pin.tools.native_benchmarks import scaling_figure

        print(f"-> {scaling_figure(results['scaling'], Path(out).parent / 'scaling.png')}")
