"""Batch rollouts: N simulations of one vehicle in compiled code on every core, returned as arrays.

:func:`rollout` runs N initial states and/or controllers (each a
:class:`~aiauv_pin.controllers.compiled_controller.CompiledController`: a built-in one, e.g. the paper's from
:meth:`aiauv_pin.controllers.paper_controller.VehiclePathFollowing.compiled`, or a user's numba function) with
the same compiled loop as :func:`aiauv_pin.simulate`
(:func:`aiauv_pin.simulation.compiled_loop.run_chunk`), one
whole run per call, on a pool of Python threads. The loop is compiled with ``nogil=True``, so the
threads run on all cores at once; only the few microseconds of argument unboxing per run hold the
GIL.

Why threads driving ``nogil`` kernels rather than one ``numba.prange`` loop over the runs: the
runs of a batch may differ in their controller's parameter records and in their current, which a
``prange`` body would need as one homogeneous typed container (and a ``parallel=True`` copy of the
whole loop to compile and cache, once per controller type); the thread pool calls the loop that
:func:`aiauv_pin.simulate` already compiled and cached, so a batch adds no compilation at all, and
a run that diverges stops alone. Each run gets its own workspace and private copies of its
controller's parameters and state, so results are bit-identical to :func:`aiauv_pin.simulate` run
by run (a test checks this), in any order and with any number of threads.

Arguments are checked at the boundary, with one-line :class:`~aiauv_pin.errors.ArgumentError`\\ s
for bad shapes (as MuJoCo's ``rollout`` does), before any thread starts; so are the controllers'
records (:func:`aiauv_pin.controllers.compiled_controller.check_compiled_controller`), and a user's
controller runs
bounds-checked, so a write past its declared ``info_shapes`` is a
:class:`~aiauv_pin.errors.RecordSizeError`, never a corrupted heap.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from aiauv_hydro.currents import Current, as_current
from aiauv_pin._internal.array_checks import configuration, float_array
from aiauv_pin._internal.log_memory import empty_log
from aiauv_pin.controllers.compiled_controller import CompiledController, check_compiled_controller
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.errors import ArgumentError, bounds_checked_call
from aiauv_pin.kernels.disturbances import Disturbance
from aiauv_pin.simulation.fixed_step import check_log_size, check_run_arguments
from aiauv_pin.simulation.step_stability import warn_if_step_near_limit

__all__ = ["Rollout", "rollout"]


@dataclass
class Rollout:
    """The logged states of N runs on a common time grid.

    Attributes:
        t: Log times [s], shape (T,).
        q: Configurations, shape (N, T, nq).
        v: Velocities, shape (N, T, nv) [m/s, rad/s].
        tau: Controller output held from each logged time on, shape (N, T, nv) [N, N m].
        info: Controller diagnostics, each of shape (N, T, ...).
        steps: Steps completed by each run, shape (N,); ``n_steps`` for a complete run.
        status: ``"complete"`` or ``"diverged"`` per run, shape (N,). The rows of a diverged run
            after its last finite state are NaN.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    info: dict[str, np.ndarray] = field(default_factory=dict)
    steps: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    status: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype="<U8"))


def _private_copy(value, memo: dict):
    """``value`` with every NumPy array inside it (named tuples and tuples searched) copied once.

    Arrays shared between two places (a servo's references, also in the controller's parameters)
    stay shared between the two copies (``memo`` maps ``id(original) -> copy``).
    """
    if isinstance(value, np.ndarray):
        key = id(value)
        if key not in memo:
            memo[key] = (value, value.copy())
        return memo[key][1]
    if isinstance(value, tuple):
        items = [_private_copy(item, memo) for item in value]
        return type(value)(*items) if hasattr(value, "_fields") else tuple(items)
    return value


def _batch_size(counts: dict[str, int | None]) -> int:
    given = {name: n for name, n in counts.items() if n is not None}
    sizes = set(given.values())
    if len(sizes) > 1:
        described = ", ".join(f"{name} {n}" for name, n in given.items())
        raise ArgumentError(
            f"rollout: the batched arguments disagree on the run count ({described})"
        )
    return sizes.pop() if sizes else 1


def _states(value, size: int, name: str, check) -> tuple[np.ndarray, int | None]:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(f"rollout: {name} must be an array of numbers") from None
    if array.ndim == 1:
        return check(array, f"{name}")[None, :], None
    if array.ndim != 2 or array.shape[1] != size or array.shape[0] == 0:
        raise ArgumentError(
            f"rollout: {name} must have shape ({size},) or (N, {size}), got {array.shape}"
        )
    rows = np.stack([check(row, f"{name}[{i}]") for i, row in enumerate(array)])
    return rows, array.shape[0]


def _controllers(controller) -> tuple[list[CompiledController], int | None]:
    if controller is None:
        return [CompiledController.passive()], None
    if isinstance(controller, CompiledController):
        return [controller], None
    if isinstance(controller, Sequence) and not isinstance(controller, str):
        items = list(controller)
        if not items or not all(isinstance(c, CompiledController) for c in items):
            raise ArgumentError(
                "rollout: controller must be a CompiledController or a non-empty sequence of them"
            )
        if any(dict(c.info_shapes) != dict(items[0].info_shapes) for c in items):
            raise ArgumentError(
                "rollout: the controllers must log the same diagnostics (info_shapes)"
            )
        return items, len(items)
    raise ArgumentError(
        f"rollout: controller must be a CompiledController, a sequence of them or None, "
        f"got {type(controller).__name__}"
    )


def _currents(current) -> tuple[list[Current], int | None]:
    if current is None or isinstance(current, Current):
        return [as_current(current)], None
    if isinstance(current, Sequence) and current and isinstance(current[0], Current):
        if not all(isinstance(c, Current) for c in current):
            raise ArgumentError("rollout: current must be one Current or a sequence of Currents")
        return list(current), len(current)
    try:
        array = np.asarray(current, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(
            "rollout: current must be a velocity (3,) or (N, 3), a Current or a sequence of them"
        ) from None
    if array.shape == (3,):
        return [as_current(float_array(array, "current", (3,)))], None
    if array.ndim == 2 and array.shape[1] == 3 and array.shape[0] > 0:
        return [
            as_current(float_array(row, f"current[{i}]", (3,))) for i, row in enumerate(array)
        ], (array.shape[0])
    raise ArgumentError(f"rollout: current must have shape (3,) or (N, 3), got {array.shape}")


def rollout(
    vehicle,
    q0,
    v0,
    duration: float,
    dt: float,
    controller: CompiledController | Sequence[CompiledController] | None = None,
    *,
    method: str = "rk4",
    current=None,
    disturbance: Disturbance | None = None,
    servo: JointServo | None = None,
    log_every: int = 1,
    control_period: float | None = None,
    threads: int | None = None,
) -> Rollout:
    """Run N simulations of ``vehicle`` in compiled code on a thread pool; return their logs.

    Every batched argument gives N values (one per run) or one value shared by all runs; the
    batched ones must agree on N. Each run is what :func:`aiauv_pin.simulate` computes with the
    same arguments, bit for bit.

    Args:
        vehicle: The vehicle (its compiled backend is required).
        q0: Initial configuration(s): (nq,) or (N, nq).
        v0: Initial velocity(ies): (nv,) or (N, nv) [m/s, rad/s].
        duration: Simulated time of every run [s].
        dt: Step [s].
        controller: A :class:`~aiauv_pin.controllers.compiled_controller.CompiledController` shared
            by every run (each
            run gets a private copy of its parameters and state, reset first), a sequence of N of
            them (e.g. N parameter sets; they must log the same ``info_shapes``), or ``None``
            (passive).
        method: ``"rk4"``, ``"euler"`` or ``"midpoint"`` (:func:`aiauv_pin.simulate`).
        current: ``None``, a world velocity (3,) or (N, 3) [m/s], a
            :class:`aiauv_hydro.currents.Current`, or a sequence of N of them.
        disturbance: A compiled :class:`~aiauv_pin.kernels.disturbances.Disturbance` (every run).
        servo: A :class:`~aiauv_pin.dynamics.joint_servo.JointServo` for every run (default: the
            controller's own servo, if any), copied per run.
        log_every: Log every this many steps (the final state is always logged).
        control_period: Controller period [s], a whole multiple of ``dt`` (``None``: every step).
        threads: Threads of the pool (default: the usable cores, at most N).

    Returns:
        A :class:`Rollout`.

    Raises:
        ArgumentError: A bad argument (one line), before anything runs.
        ValueError: The vehicle has no compiled backend.
    """
    from aiauv_pin.kernels.articulated_body import new_workspace
    from aiauv_pin.kernels.evaluation import METHOD_MARKERS
    from aiauv_pin.simulation.compiled_loop import loop_for

    n_steps, steps_per_control = check_run_arguments(
        duration, dt, method, log_every, control_period
    )
    fast = vehicle.fast
    if fast is None:  # a project error (the campaign found a plain ValueError here)
        why = vehicle.fallback_reason or "as loaded; load it with backend='numba'"
        raise ArgumentError(
            f"rollout needs the compiled backend (the vehicle runs on {vehicle.active_backend}: "
            f"{why})"
        )
    nq, nv = fast.nq, fast.nv
    q_rows, n_q = _states(q0, nq, "q0", lambda row, name: configuration(row, nq, name))
    v_rows, n_v = _states(v0, nv, "v0", lambda row, name: float_array(row, name, (nv,)))
    if getattr(vehicle, "fixed_base", False):
        v_rows = v_rows.copy()
        v_rows[:, :6] = 0.0  # a fixed base does not move
    laws, n_c = _controllers(controller)
    for law in laws:
        check_compiled_controller(law, nq, nv, fast.n_thrusters, fast.model.fins.max_angle.shape[0])
    waters, n_w = _currents(current)
    n_runs = _batch_size({"q0": n_q, "v0": n_v, "controller": n_c, "current": n_w})
    if disturbance is not None and not isinstance(disturbance, Disturbance):
        raise ArgumentError("rollout: disturbance must be a compiled Disturbance")
    if servo is not None and not isinstance(servo, JointServo):
        raise ArgumentError("rollout: servo must be a JointServo")
    for law in laws:
        own = law.servo if servo is None else servo
        if own is not None and own.references.shape != (nv - 6,):
            raise ArgumentError(
                f"rollout: the servo must have one entry per joint ({nv - 6}), "
                f"got {own.references.size}"
            )
    checked = set()
    for i in range(n_runs):  # each servo once, at the first start it runs from
        own = laws[i % len(laws)].servo if servo is None else servo
        if own is not None and id(own) not in checked:
            checked.add(id(own))
            start = q_rows[i % len(q_rows)]
            warn_if_step_near_limit(vehicle, start, own.stiffness, own.damping, method, float(dt))
    if threads is None:
        threads = max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ArgumentError(f"rollout: threads must be a whole number >= 1, got {threads!r:.40}")

    check_log_size(n_steps, log_every, nq, nv, n_runs)
    width = laws[0].info_width
    n_logs = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    # written by the run that owns it, in its own thread (no serial first pass over what can be
    # gigabytes); rows a diverged run never reached are set to NaN after it
    log = empty_log((n_runs, n_logs, 1 + nq + 2 * nv + width))  # (no huge-page faults)
    counts = np.zeros((n_runs, 2), dtype=np.int64)  # (rows logged, steps completed)
    method_marker = METHOD_MARKERS[method]

    # everything a run mutates is private to it: workspace, state, parameters' buffers, servo
    jobs = []
    for i in range(n_runs):
        law = laws[i if len(laws) > 1 else 0]
        if law.reset is not None:
            law.reset()
        memo: dict = {}
        parameters = _private_copy(law.parameters, memo)
        state = _private_copy(law.state, memo)
        own_servo = law.servo if servo is None else servo
        servo_record = (
            _private_copy(own_servo.packed(), memo) if own_servo is not None else fast.no_servo
        )
        environment = fast.environment(waters[i if len(waters) > 1 else 0], disturbance)
        loop = loop_for(environment, law.loop_function, parameters)
        jobs.append((loop, environment, servo_record, law.loop_function, parameters, state))

    def run(i: int) -> None:
        loop, environment, servo_record, function, parameters, state = jobs[i]
        q = q_rows[i if q_rows.shape[0] > 1 else 0].copy()
        v = v_rows[i if v_rows.shape[0] > 1 else 0].copy()
        logged, done = loop(
            fast.model,
            environment,
            servo_record,
            function,
            parameters,
            state,
            q,
            v,
            np.zeros(nv),
            np.full(width, np.nan),
            float(dt),
            method_marker,
            0,
            n_steps,
            n_steps,
            steps_per_control,
            log_every,
            log[i],
            0,
            new_workspace(fast.model, nq, nv),
        )
        log[i, logged:] = np.nan
        counts[i] = logged, done

    pool_size = min(threads, n_runs)
    with bounds_checked_call("rollout"):  # a user's controller writing out of bounds
        if pool_size == 1:
            for i in range(n_runs):
                run(i)
        else:
            with ThreadPoolExecutor(
                max_workers=pool_size, thread_name_prefix="aiauv-rollout"
            ) as pool:
                for future in [pool.submit(run, i) for i in range(n_runs)]:
                    future.result()

    steps = counts[:, 1].copy()
    # the loop logs at t = k dt for k = 0, log_every, 2 log_every, ... and at n_steps
    t = np.minimum(np.arange(n_logs) * log_every, n_steps) * float(dt)
    return Rollout(
        t=t,
        q=log[:, :, 1 : 1 + nq],
        v=log[:, :, 1 + nq : 1 + nq + nv],
        tau=log[:, :, 1 + nq + nv : 1 + nq + 2 * nv],
        info=laws[0].unpack(log[:, :, 1 + nq + 2 * nv :], copy=False),
        steps=steps,
        status=np.where(steps == n_steps, "complete", "diverged"),
    )
