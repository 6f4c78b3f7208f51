"""Head-to-head timings of one dynamics evaluation against MuJoCo, both in native code, and their scaling.

Part of ``aiauv bench`` (:mod:`aiauv_pin.tools.bench_command`). MuJoCo's ``mj_forward`` and ``mj_step`` are
called from a compiled (numba) loop through ``ctypes`` on the ``libmujoco`` shipped with the
``mujoco`` package, the very library its Python bindings use, so neither side pays Python's
per-call cost; our evaluation runs in the compiled loop
:func:`aiauv_pin.kernels.articulated_body.time_accelerations`.
The same figures are also taken with one Python call per evaluation on both sides
(``Vehicle.fast.acceleration`` against ``mujoco.mj_forward``).

Every comparison is interleaved (the contenders take turns within each round, so a change of load
on a shared machine hits them alike) and reported as the median and range over rounds of the
per-round ratio, with the medians of the times themselves.

The MuJoCo model of a vehicle is the MJCF that ``aiauv export`` writes (same bodies, masses and
inertias; MuJoCo's ellipsoid fluid model on the collision cylinders; buoyancy as gravity
compensation; joint limits and idle thruster actuators). Its fluid model is not ours, so only the
cost is comparable. For the paper vehicle, MuJoCo is also timed on an MJCF of the same vehicle
written by hand, independently of the exporter (:data:`HAND_MJCF`, ``benchmarks/`` of a source
checkout; its header says how it was derived): the ``*_hand`` rows and ratios.
"""

from __future__ import annotations

import ctypes
import os
import tempfile
import time
from pathlib import Path

import numpy as np

#: Link counts of the scaling figure (``2^k + 1``, as the paper's 9; the last is the builder's
#: limit, :data:`aiauv_pin.description.input_limits.MAX_LINKS`).
SCALING_LINKS = (3, 5, 9, 17, 33, 65, 127)

_clock = time.process_time

#: The paper vehicle (uniform case) written by hand as a MuJoCo user would write it, not by
#: ``aiauv export`` (source checkout only: ``benchmarks/`` is not installed).
HAND_MJCF = Path(__file__).resolve().parents[2] / "benchmarks" / "paper_vehicle_hand.xml"


# ---------------------------------------------------------------------- MuJoCo, natively
def _mujoco_library():
    """``libmujoco`` of the installed ``mujoco`` package (the one its bindings have loaded)."""
    import mujoco

    folder = Path(mujoco.__file__).resolve().parent
    candidates = sorted(folder.glob("libmujoco.so*")) + sorted(folder.glob("libmujoco*.dylib"))
    candidates += sorted(folder.glob("mujoco*.dll"))
    if not candidates:
        raise OSError(f"no MuJoCo shared library in {folder}")
    return ctypes.CDLL(str(candidates[0]))


_NATIVE_LOOPS: dict = {}


def native_loops():
    """``(forward_loop, step_loop)``: compiled ``loop(model_address, data_address, n)`` calling
    ``mj_forward`` / ``mj_step`` ``n`` times (compiled once per process: ctypes functions are not
    cacheable)."""
    if not _NATIVE_LOOPS:
        import numba

        library = _mujoco_library()
        forward = library.mj_forward
        step = library.mj_step
        for function in (forward, step):
            function.argtypes = [ctypes.c_size_t, ctypes.c_size_t]  # mjModel*, mjData*
            function.restype = None

        @numba.njit(nogil=True)
        def forward_loop(model, data, n):
            for _ in range(n):
                forward(model, data)

        @numba.njit(nogil=True)
        def step_loop(model, data, n):
            for _ in range(n):
                step(model, data)

        _NATIVE_LOOPS["loops"] = (forward_loop, step_loop)
    return _NATIVE_LOOPS["loops"]


def mujoco_model_of(urdf: Path, integrator: str, timestep: float = 0.01):
    """MuJoCo model of a vehicle URDF as ``aiauv export`` writes it, with ``integrator``."""
    import mujoco

    from aiauv_pin.interop.export_source import load_export_source
    from aiauv_pin.interop.mjcf import mjcf_text

    model = mujoco.MjModel.from_xml_string(mjcf_text(load_export_source(urdf)))
    model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    model.opt.timestep = timestep
    return model


# ---------------------------------------------------------------------- interleaved timing
def interleaved_rounds(functions: dict, rounds: int) -> dict:
    """CPU microseconds per unit of each ``function()`` in every round (name -> (function, units)),
    the functions taking turns within each round."""
    for function, _ in functions.values():
        function()
    times: dict = {name: [] for name in functions}
    for _ in range(rounds):
        for name, (function, units) in functions.items():
            start = _clock()
            function()
            times[name].append(1e6 * (_clock() - start) / units)
    return times


def ratio_summary(numerator: list, denominator: list) -> dict:
    """Median, min and max over rounds of the per-round ratio."""
    ratio = np.asarray(numerator) / np.asarray(denominator)
    return {
        "median": float(np.median(ratio)),
        "min": float(ratio.min()),
        "max": float(ratio.max()),
    }


def _stats(values: list) -> dict:
    return {
        "median_us": float(np.median(values)),
        "min_us": float(np.min(values)),
        "max_us": float(np.max(values)),
    }


def _state(vehicle, mj_model, mj_data, seed: int = 5):
    """A random state for our model and a comparable one (same joint angles and rates) for MuJoCo's."""
    import pinocchio as pin

    rng = np.random.default_rng(seed)
    q = pin.neutral(vehicle.model)
    q[:3] = rng.uniform(-1.0, 1.0, 3)
    quaternion = rng.normal(size=4)
    q[3:7] = quaternion / np.linalg.norm(quaternion)
    q[7:] = rng.uniform(-0.5, 0.5, vehicle.nq - 7)
    v = 0.3 * rng.normal(size=vehicle.nv)
    tau = rng.normal(size=vehicle.nv)
    mj_data.qpos[:3] = q[:3]
    mj_data.qpos[3:7] = (q[6], q[3], q[4], q[5])  # MuJoCo's quaternion is (w, x, y, z)
    n_joints = min(mj_model.nq - 7, vehicle.nq - 7)
    mj_data.qpos[7 : 7 + n_joints] = q[7 : 7 + n_joints]
    mj_data.qvel[: min(mj_model.nv, vehicle.nv)] = v[: min(mj_model.nv, vehicle.nv)]
    return q, v, tau


def native_head_to_head(
    vehicle, urdf: Path, *, rounds: int = 15, calls: int = 2000, hand_mjcf: Path | None = None
) -> dict:
    """One evaluation and one RK4 step of ``vehicle`` (compiled) against MuJoCo's ``mj_forward`` and
    RK4 ``mj_step`` on the exported model, both natively and both from Python, interleaved.

    With ``hand_mjcf`` (an MJCF of the same vehicle written by hand, :data:`HAND_MJCF`), MuJoCo's
    ``mj_forward`` on it is timed in the same rounds, natively and from Python (rows and ratios
    ``*_hand``). The load average (``os.getloadavg``) before and after is part of the result.

    Returns ``{}`` without mujoco or the compiled backend.
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

    forward_loop, step_loop = native_loops()
    forward_model = mujoco_model_of(urdf, "Euler")
    rk4_model = mujoco_model_of(urdf, "RK4")
    forward_data, rk4_data = mujoco.MjData(forward_model), mujoco.MjData(rk4_model)
    q, v, tau = _state(vehicle, forward_model, forward_data)
    _state(vehicle, rk4_model, rk4_data)
    mujoco.mj_forward(forward_model, forward_data)
    qpos, qvel = rk4_data.qpos.copy(), rk4_data.qvel.copy()
    model, env, servo, W = fast.model, fast.still_water, fast.no_servo, fast.workspace
    out = np.empty(vehicle.nv)
    steps = max(calls // 4, 1)
    python_calls = max(calls // 4, 1)
    fm, fd = forward_model._address, forward_data._address
    rm, rd = rk4_model._address, rk4_data._address
    contenders: dict = {}
    if hand_mjcf is not None:
        hand_model = mujoco.MjModel.from_xml_path(str(hand_mjcf))
        hand_data = mujoco.MjData(hand_model)
        _state(vehicle, hand_model, hand_data)
        mujoco.mj_forward(hand_model, hand_data)
        hm, hd = hand_model._address, hand_data._address

        def mujoco_forward_hand():
            forward_loop(hm, hd, calls)

        def mujoco_python_hand():
            for _ in range(python_calls):
                mujoco.mj_forward(hand_model, hand_data)

        contenders = {
            "mujoco_forward_native_hand": (mujoco_forward_hand, calls),
            "mujoco_forward_python_hand": (mujoco_python_hand, python_calls),
        }

    def ours_forward():
        kernels.time_accelerations(model, env, servo, q, v, tau, calls, W, out)

    def mujoco_forward():
        forward_loop(fm, fd, calls)

    def ours_rk4():
        qq, vv = q.copy(), v.copy()
        kernels.run_steps(model, env, servo, 0.0, qq, vv, tau, 0.001, steps, METHOD_CODES["rk4"], W)

    def mujoco_rk4():
        rk4_data.qpos[:] = qpos
        rk4_data.qvel[:] = qvel
        step_loop(rm, rd, steps)

    def ours_python():
        for _ in range(python_calls):
            fast.acceleration(q, v, tau)

    def vehicle_python():
        for _ in range(python_calls):
            vehicle.acceleration(q, v, tau)

    def mujoco_python():
        for _ in range(python_calls):
            mujoco.mj_forward(forward_model, forward_data)

    load_before = os.getloadavg()
    times = interleaved_rounds(
        {
            "ours_forward_native": (ours_forward, calls),
            "mujoco_forward_native": (mujoco_forward, calls),
            "ours_rk4_step_native": (ours_rk4, steps),
            "mujoco_rk4_step_native": (mujoco_rk4, steps),
            "ours_forward_python": (ours_python, python_calls),
            "ours_forward_vehicle_python": (vehicle_python, python_calls),
            "mujoco_forward_python": (mujoco_python, python_calls),
            **contenders,
        },
        rounds,
    )
    ratios = {}
    if contenders:
        ratios = {
            "forward_native_hand": ratio_summary(
                times["ours_forward_native"], times["mujoco_forward_native_hand"]
            ),
            "forward_python_fast_hand": ratio_summary(
                times["ours_forward_python"], times["mujoco_forward_python_hand"]
            ),
            "forward_python_vehicle_hand": ratio_summary(
                times["ours_forward_vehicle_python"], times["mujoco_forward_python_hand"]
            ),
        }
    return {
        "links": int(vehicle.model.njoints - 1),
        "nv": int(vehicle.nv),
        "mujoco_nv": int(forward_model.nv),
        "rounds": rounds,
        "load_average": {"before": list(load_before), "after": list(os.getloadavg())},
        **({"hand_mjcf": Path(hand_mjcf).name} if contenders else {}),
        "times": {name: _stats(values) for name, values in times.items()},
        "ratios": {
            "forward_native": ratio_summary(
                times["ours_forward_native"], times["mujoco_forward_native"]
            ),
            "rk4_step_native": ratio_summary(
                times["ours_rk4_step_native"], times["mujoco_rk4_step_native"]
            ),
            "forward_python_fast": ratio_summary(
                times["ours_forward_python"], times["mujoco_forward_python"]
            ),
            "forward_python_vehicle": ratio_summary(
                times["ours_forward_vehicle_python"], times["mujoco_forward_python"]
            ),
            **ratios,
        },
    }


# ---------------------------------------------------------------------- scaling
def chain_spec(n_links: int) -> dict:
    """A vehicle spec of ``n_links`` equal modules of the paper's make (0.37 m, 8 kg, radius
    0.085 m), joints alternating about z and y, a surge thruster on the tail and head."""
    modules = []
    for k in range(n_links):
        module: dict = {"name": f"m{k}", "length": 0.37, "mass": 8.0}
        if k < n_links - 1:
            module["joint"] = "z" if k % 2 == 0 else "y"
        if k in (0, n_links - 1):
            module["thruster"] = [{"name": f"t{k}", "x": 0.185, "direction": "x"}]
        modules.append(module)
    return {"name": f"chain{n_links}", "radius": 0.085, "fluid_density": 1000.0, "module": modules}


def scaling(
    links: tuple[int, ...] = SCALING_LINKS, *, rounds: int = 7, pinocchio: bool = True
) -> dict:
    """Cost per evaluation and per RK4 step against MuJoCo's (native, interleaved) for chains of
    ``links`` modules (:func:`chain_spec`), and the Pinocchio reference's cost per evaluation."""
    from aiauv_pin.builders.urdf_builder import build_urdf
    from aiauv_pin.builders.vehicle_spec import spec_from_dict
    from aiauv_pin.model import loading

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for n in links:
            urdf = Path(folder) / f"chain{n}.urdf"
            urdf.write_text(build_urdf(spec_from_dict(chain_spec(n))), encoding="utf-8")
            vehicle = loading.load_vehicle(urdf)
            # about 20 ms of work per contender and round whatever the size
            calls = max(int(2e4 / (n + 2)), 20)
            row = native_head_to_head(vehicle, urdf, rounds=rounds, calls=calls)
            if not row:
                return {"note": "mujoco or the compiled backend unavailable; skipped"}
            if pinocchio:
                reference = loading.load_vehicle(urdf, backend="pinocchio")
                q, v, tau = _state(reference, *_dummy_mujoco(urdf))
                repeats = max(int(2000 / (n + 2)), 3)

                def evaluate(reference=reference, q=q, v=v, tau=tau, repeats=repeats):
                    for _ in range(repeats):
                        reference.acceleration(q, v, tau)

                times = interleaved_rounds({"pinocchio": (evaluate, repeats)}, 3)
                row["times"]["pinocchio_forward_python"] = _stats(times["pinocchio"])
            rows.append(row)
    return {"links": list(links), "rows": rows}


def _dummy_mujoco(urdf: Path):
    import mujoco

    model = mujoco_model_of(urdf, "Euler")
    return model, mujoco.MjData(model)


def scaling_figure(result: dict, path: Path) -> Path:
    """Plot :func:`scaling`'s result: cost per evaluation, and its ratio to MuJoCo's, against links."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    links = [row["links"] for row in rows]

    def series(name):
        return [row["times"][name]["median_us"] for row in rows]

    figure, (cost, ratio) = plt.subplots(1, 2, figsize=(10, 4))
    cost.loglog(links, series("ours_forward_native"), "o-", label="aiauv-pin, compiled")
    cost.loglog(links, series("mujoco_forward_native"), "s-", label="MuJoCo mj_forward")
    if all("pinocchio_forward_python" in row["times"] for row in rows):
        cost.loglog(
            links, series("pinocchio_forward_python"), "^--", label="aiauv-pin, Pinocchio reference"
        )
    cost.set_xlabel("links")
    cost.set_ylabel("one evaluation [us] (median, CPU time)")
    cost.grid(True, which="both", alpha=0.3)
    cost.legend()
    for name, label, marker in (
        ("forward_native", "evaluation / mj_forward", "o-"),
        ("rk4_step_native", "RK4 step / mj_step (RK4)", "s-"),
    ):
        median = [row["ratios"][name]["median"] for row in rows]
        low = [row["ratios"][name]["median"] - row["ratios"][name]["min"] for row in rows]
        high = [row["ratios"][name]["max"] - row["ratios"][name]["median"] for row in rows]
        ratio.errorbar(links, median, yerr=[low, high], fmt=marker, capsize=3, label=label)
    ratio.set_xscale("log")
    ratio.axhline(1.0, color="grey", lw=0.8)
    ratio.set_xlabel("links")
    ratio.set_ylabel("aiauv-pin / MuJoCo (median, range over rounds)")
    ratio.grid(True, which="both", alpha=0.3)
    ratio.legend()
    figure.suptitle("Cost of one dynamics evaluation, both native, interleaved in one process")
    figure.tight_layout()
    from aiauv_pin._internal.atomic import atomic_path

    path = Path(path)
    with atomic_path(path) as temporary:  # never through a FIFO, device or link at ``path``
        figure.savefig(temporary, dpi=120, format=path.suffix.lstrip(".") or "png")
    plt.close(figure)
    return path
