"""Fixed-step simulation loop with a controller callback and state logging.

On the compiled backend (``vehicle.active_backend == "numba"``) the steps between two controller calls
(or log points) run in one compiled call, with a :class:`JointServo` evaluated inside the kernel at every
integrator stage, so no Python runs per step; a servo given as a Python callable is still supported but
then every step goes through Python. On Pinocchio every step calls :mod:`aiauv_pin.reference.integrators`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from aiauv_hydro.currents import as_current
from aiauv_hydro.laws.fluid_terms import UUV_SIMULATOR_FILTER
from aiauv_pin._internal.array_checks import (
    check_timing,
    configuration,
    float_array,
    optional_current,
    positive_seconds,
)
from aiauv_pin._internal.log_memory import empty_log
from aiauv_pin.controllers.compiled_controller import CompiledController, check_compiled_controller
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.dynamics.lagged_added_mass import LaggedAddedMass, check_filter, check_scheme
from aiauv_pin.errors import ArgumentError, SimulationDiverged, bounds_checked_call
from aiauv_pin.kernels.articulated_body import reset_actuators
from aiauv_pin.kernels.disturbances import Disturbance
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.reference.integrators import (
    INTEGRATORS,
    SAMPLES_INSIDE_STEP,
    midpoint_final,
    midpoint_stage,
)
from aiauv_pin.simulation.compiled_loop import step_actions, steps_to_next_event
from aiauv_pin.simulation.step_stability import warn_if_step_near_limit

#: ``controller(t, q, v) -> tau`` or ``-> (tau, info)``, with ``tau`` the generalised force (nv,) held
#: constant over the step and ``info`` a mapping of scalars or arrays to log.
Controller = Callable[[float, np.ndarray, np.ndarray], object]

#: ``servo(q, v) -> tau``: a generalised force evaluated at every integrator stage (a continuous-time
#: inner loop, such as joint servos running much faster than the outer controller).
Servo = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class Trajectory:
    """Logged states of a simulation.

    A compiled run's arrays are views of its log's rows (:func:`trajectory_of_log`): strided, not
    C-contiguous (``np.ascontiguousarray`` gives a contiguous copy).

    Attributes:
        t: Times [s], shape (N,).
        q: Configurations, shape (N, nq).
        v: Velocities, shape (N, nv).
        tau: Generalised forces applied from each logged time on, shape (N, nv) [N, N m].
        info: Controller diagnostics, each stacked to shape (N, ...).
        status: ``"complete"`` or ``"diverged"``.
        message: Why the run stopped early, if it did.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    info: dict[str, np.ndarray] = field(default_factory=dict)
    status: str = "complete"
    message: str = ""


def _split(output) -> tuple[np.ndarray, Mapping[str, object]]:
    if isinstance(output, tuple):
        tau, info = output
        return np.asarray(tau, dtype=float), info
    return np.asarray(output, dtype=float), {}


#: Largest log :func:`simulate` allocates [bytes] (times, states and forces; a controller's
#: diagnostics come on top): a longer run must log less often (``log_every``).
MAX_LOG_BYTES = 8 * 2**30


def check_log_size(n_steps: int, log_every: int, nq: int, nv: int, runs: int = 1) -> None:
    """Refuse runs whose logs of ``(t, q, v, tau)`` would exceed :data:`MAX_LOG_BYTES` together
    (``runs`` of them: :func:`aiauv_pin.rollout` allocates one per run).

    Raises:
        ArgumentError: One line, with the size and the way out.
    """
    rows = runs * (n_steps // log_every + 2)
    size = rows * (1 + nq + 2 * nv) * 8
    if size > MAX_LOG_BYTES:
        raise ArgumentError(
            f"the log of {rows:.3g} samples would need {size / 2**30:.3g} GiB (more than "
            f"{MAX_LOG_BYTES / 2**30:g} GiB); log less often (log_every) or run shorter"
        )


def _finite(*arrays: np.ndarray) -> bool:
    """Whether every entry of every array is finite (a state or force the integrator may use)."""
    return all(bool(np.all(np.isfinite(a))) for a in arrays)


def _finite_step(step: Callable[..., tuple[np.ndarray, np.ndarray]], *arguments):
    """``step(*arguments)``'s ``(q, v)``, or ``None`` if it is not finite or its linear solve
    failed."""
    try:
        q_new, v_new = step(*arguments)
    except np.linalg.LinAlgError:
        return None
    return (q_new, v_new) if _finite(q_new, v_new) else None


def check_run_arguments(
    duration: float, dt: float, method: str, log_every: int, control_period: float | None
) -> tuple[int, int]:
    """Validate :func:`simulate`'s timing arguments; return ``(n_steps, steps_per_control)``.

    Raises:
        ValueError: A bad argument (one line).
    """
    n_steps = check_timing(duration, dt)  # consistent duration and dt, or ArgumentError
    if not isinstance(method, str) or method not in INTEGRATORS:
        raise ArgumentError(
            f"unknown method {method!r:.40} (expected one of {', '.join(INTEGRATORS)})"
        )
    if isinstance(log_every, bool) or not isinstance(log_every, int) or log_every < 1:
        raise ArgumentError(f"log_every must be a whole number >= 1, got {log_every!r:.40}")
    steps_per_control = 1
    if control_period is not None:
        if isinstance(control_period, bool) or not isinstance(control_period, (int, float)):
            raise ArgumentError(
                f"control_period must be a number of seconds, got {control_period!r:.40}"
            )
        ratio = control_period / dt if math.isfinite(control_period) else math.nan
        if not (control_period > 0 and abs(ratio - round(ratio)) < 1e-9 * max(1.0, ratio)):
            raise ArgumentError(
                f"control_period must be a positive whole multiple of dt = {dt:g} s, "
                f"got {control_period!r}"
            )
        steps_per_control = max(1, round(ratio))
    if method in SAMPLES_INSIDE_STEP and steps_per_control != 1:
        raise ArgumentError(
            f"method {method!r} samples the controller inside every step: control_period must "
            f"equal dt = {dt:g} s, got {control_period!r}"
        )
    return n_steps, steps_per_control


def simulate(
    vehicle: Vehicle,
    q0: np.ndarray,
    v0: np.ndarray,
    duration: float,
    dt: float,
    controller: Controller | None = None,
    *,
    method: str = "rk4",
    current=None,
    disturbance=None,
    servo: Servo | JointServo | None = None,
    log_every: int = 1,
    progress: bool = False,
    on_log: Callable[[float, np.ndarray, Mapping[str, object]], None] | None = None,
    control_period: float | None = None,
    chunk_seconds: float | None = None,
    after_first_chunk: Callable[[], None] | None = None,
    log_reader: Callable[[np.ndarray], None] | None = None,
    log_memory: Callable[[tuple[int, int]], np.ndarray] | None = None,
    added_mass: str = "exact",
    lagged_filter: float = UUV_SIMULATOR_FILTER,
    compile_only: bool = False,
) -> Trajectory | None:
    """Integrate the vehicle's dynamics with a fixed step.

    The controller is called at the start of every control period (default: every step); its output is
    held until the next call (zero-order hold, as a digital controller would apply it). Rows logged
    between two calls repeat the last call's output and diagnostics. The midpoint method instead
    calls it inside every step, at its stage ``t + dt/2``, and at the end, not at ``t = 0`` (see
    :mod:`aiauv_pin.simulation.compiled_loop`): a row at ``t`` then holds the output applied over
    ``[t, t + dt]``
    and the diagnostics of that call at ``t + dt/2``.

    Args:
        vehicle: The vehicle.
        q0: Initial configuration (nq,).
        v0: Initial velocity (nv,) [m/s, rad/s]; a fixed-base vehicle's base entries are
            taken as zero.
        duration: Simulated time [s] (> 0).
        dt: Step [s] (> 0).
        controller: ``controller(t, q, v) -> tau | (tau, info)`` (Python), a
            :class:`aiauv_pin.controllers.compiled_controller.CompiledController` (the whole run
            then executes in
            compiled code, in chunks of ``chunk_seconds`` of simulated time between which the
            progress bar and ``on_log`` run), or ``None`` (no input).
        method: ``"rk4"`` (Runge-Kutta-Munthe-Kaas, order 4), ``"euler"`` (semi-implicit, order 1;
            a :class:`JointServo` is implicit in it, so the servo bounds no step) or
            ``"midpoint"`` (:func:`aiauv_pin.reference.integrators.midpoint_step`, two evaluations, the
            servo implicit in both, the controller called at the middle of each step: its
            sampling then costs second-order error instead of a lag of ``dt / 2``; needs
            ``control_period = dt``; the sampled controller loop bounds its step, see the
            README's accuracy per cost).
        current: Water velocity: ``None`` (still water), a constant world velocity (3,) [m/s], or a
            :class:`aiauv_hydro.currents.Current` (time- and space-varying, compiled), sampled at every
            body at every integrator stage.
        disturbance: External generalised force (nv,) [N, N m] at every integrator stage: a
            :class:`aiauv_pin.kernels.disturbances.Disturbance` (compiled, runs inside the compiled loop) or
            a Python callable ``fn(t, q, v) -> (nv,)`` (Python speed).
        servo: ``servo(q, v) -> tau`` or a :class:`JointServo`, added to the controller's output at
            every integrator stage.
        log_every: Log every this many steps (the final state is always logged).
        progress: Show a progress bar (tqdm).
        control_period: Controller sampling period [s], a whole multiple of ``dt``; ``None`` means
            ``dt``.
        on_log: ``on_log(t, q, info)`` called at every logged sample (e.g. a live viewer).
        chunk_seconds: Compiled controller only: simulated time per compiled call (default 1 s
            with ``on_log``, 10 s with a progress bar, the first 10 s and then the rest with
            ``after_first_chunk`` alone, else the whole run in one call).
        after_first_chunk: Compiled controller only: called once after the first chunk (the code
            is then compiled; later chunks release the GIL, so a background thread started here
            overlaps them).
        log_reader: Compiled controller only: called once, before the first step, with the
            whole log (rows ``(t, q, v, tau, info)``, as :func:`trajectory_of_log` reads them),
            for a thread that reads it while the loop runs (it releases the GIL). The rows are
            written in order, each row's time first, and the log is zero where nothing was
            written yet: a row is complete once the next row's time is not zero
            (:func:`complete_rows`).
        log_memory: Compiled controller only: ``log_memory(shape)`` returns the memory the
            loop logs into, a zero C-ordered float64 array of ``shape`` (rows, columns), such as
            :meth:`aiauv_pin._internal.log_memory.SharedLog.empty`, whose log a process forked
            before the run reads (default: :func:`aiauv_pin._internal.log_memory.empty_log`).
        added_mass: ``"exact"`` (added mass in the mass matrix) or ``"lagged"``, the scheme of
            UUV Simulator and gz-sim (:mod:`aiauv_pin.dynamics.lagged_added_mass`: rigid mass in
            the dynamics, the
            added-mass wrench from the previous steps' filtered acceleration, held over each
            step; a Python controller or none, with the dynamics on either backend).
        lagged_filter: The lagged scheme's filter coefficient ``alpha`` in ``(0, 1]``: 0.3 is UUV
            Simulator's (default), 1 gz-sim's (no filter).
        compile_only: Check the arguments and load (or compile) the compiled loop's
            specialisation for their types, then return ``None`` without taking a step: the
            loop is called with no step to take (``k_start == k_stop``). With a Python
            controller there is no loop to compile: ``None`` once the arguments are checked.

    Returns:
        The trajectory (``None`` with ``compile_only``).

    Raises:
        ValueError: Bad arguments (one line).
        SimulationDiverged: The state became NaN or infinite; the error carries the time and the
            trajectory computed so far.
    """
    n_steps, steps_per_control = check_run_arguments(
        duration, dt, method, log_every, control_period
    )
    model = vehicle.model
    check_log_size(n_steps, log_every, model.nq, model.nv)
    q0 = configuration(q0, model.nq, "q0").copy()
    v0 = float_array(v0, "v0", (model.nv,)).copy()
    if getattr(vehicle, "fixed_base", False):
        v0[:6] = 0.0  # a fixed base does not move (its acceleration is zero in both backends)
    current = optional_current(current)
    if isinstance(servo, JointServo) and servo.references.shape != (model.nv - 6,):
        raise ArgumentError(
            f"servo must have one entry per joint ({model.nv - 6}), got {servo.references.size}"
        )
    # checked even where unused (exact added mass, a Python controller): a bad value is a mistake
    lagged_filter = check_filter(lagged_filter)
    if chunk_seconds is not None:
        chunk_seconds = positive_seconds(chunk_seconds, "chunk_seconds", allow_infinity=True)
    lag = None
    if check_scheme(added_mass) == "lagged":
        if isinstance(controller, CompiledController):
            raise ArgumentError(
                "added_mass='lagged' runs with a Python controller (or none), not a compiled one"
            )
        lag = LaggedAddedMass(vehicle, lagged_filter)
    joint_servo = servo
    if servo is None and isinstance(controller, CompiledController):
        joint_servo = controller.servo
    if isinstance(joint_servo, JointServo) and lag is None:
        # near its stability limit a run stays finite but goes far off: say so before it runs
        warn_if_step_near_limit(
            vehicle, q0, joint_servo.stiffness, joint_servo.damping, method, float(dt)
        )
    if isinstance(controller, CompiledController):
        return _simulate_compiled(
            vehicle,
            controller,
            q0,
            v0,
            n_steps,
            steps_per_control,
            dt,
            method=method,
            current=current,
            disturbance=disturbance,
            servo=servo,
            log_every=log_every,
            progress=progress,
            on_log=on_log,
            chunk_seconds=chunk_seconds,
            after_first_chunk=after_first_chunk,
            log_reader=log_reader,
            log_memory=log_memory,
            compile_only=compile_only,
        )
    # a controller that carries the thrusters' state itself (station keeping, velocity control)
    carried = getattr(controller, "handles_thruster_dynamics", False)
    if controller is not None and has_thruster_dynamics(vehicle) and not carried:
        raise ArgumentError(
            "this vehicle has thrusters with a lag or a rate limit, whose state only the compiled "
            "loop carries: give a CompiledController (it commands thrusts through thrust_into)"
        )
    if compile_only:
        return None
    if vehicle.fast is not None:
        reset_actuators(vehicle.fast.workspace)  # fins at zero (a Vehicle.step may have set them)
    step = INTEGRATORS[method]
    q, v = q0, v0
    current = as_current(current)
    compiled_disturbance = disturbance if isinstance(disturbance, Disturbance) else None
    python_disturbance = None
    if disturbance is not None and compiled_disturbance is None:
        if not callable(disturbance):
            raise ArgumentError(
                "disturbance must be a Disturbance or a callable fn(t, q, v) -> (nv,)"
            )
        python_disturbance = disturbance
    log_every = int(log_every)
    n_logs = n_steps // log_every + 1 + (1 if n_steps % log_every else 0)

    t_log = np.empty(n_logs)
    q_log = np.empty((n_logs, model.nq))
    v_log = np.empty((n_logs, model.nv))
    tau_log = np.zeros((n_logs, model.nv))
    info_log: dict[str, np.ndarray] = {}
    zero_tau = np.zeros(model.nv)

    def log(index: int, t: float, tau: np.ndarray, info: Mapping[str, object]) -> None:
        t_log[index], q_log[index], v_log[index], tau_log[index] = t, q, v, tau
        for key, value in info.items():
            value = np.asarray(value, dtype=float)
            if key not in info_log:
                info_log[key] = np.full((n_logs, *value.shape), np.nan)
            info_log[key][index] = value
        if on_log is not None:
            on_log(t, q, info)

    servo_function = (
        (lambda qq, vv: servo.torque(vehicle, qq, vv)) if isinstance(servo, JointServo) else servo
    )

    # semi-implicit Euler and the midpoint method make a JointServo implicit over the step
    # (aiauv_control.laws.paper_laws.joint_pd_implicit_terms)
    implicit_servo = method in ("euler", "midpoint") and isinstance(servo, JointServo)

    def dynamics_with(tau: np.ndarray):
        def dynamics(qq, vv, tt):
            if not _finite(qq, vv):
                return np.full(model.nv, np.nan)  # a stage overflowed: the step diverges
            total = tau
            if servo_function is not None:
                total = total + servo_function(qq, vv)
            if python_disturbance is not None:
                total = total + _generalized(python_disturbance(tt, qq, vv), model.nv)
            elif compiled_disturbance is not None:
                total = total + compiled_disturbance.generalized_force(tt, qq, vv)
            acceleration = body.acceleration(qq, vv, total, current, t=tt)
            if implicit_servo:
                return servo.implicit_acceleration(body, qq, vv, acceleration, dt)
            return acceleration

        return dynamics

    body = vehicle if lag is None else lag.rigid  # the dynamics the integrator steps
    compiled_ok = (servo is None or isinstance(servo, JointServo)) and python_disturbance is None
    fast = body.fast if compiled_ok else None

    def advance(tau: np.ndarray, n: int, t0: float) -> int:
        """Take ``n`` steps from ``t0`` with ``tau`` held; returns how many stayed finite."""
        if lag is None:
            return advance_held(tau, n, t0)
        for i in range(n):  # the lagged added-mass force, recomputed and held step by step
            t_i = t0 + i * dt
            force = lag.generalized_force(q, v, dt, current, t_i)
            if not _finite(force) or advance_held(tau + force, 1, t_i) < 1:
                return i
        return n

    def advance_held(tau: np.ndarray, n: int, t0: float) -> int:
        nonlocal q, v
        if fast is not None:
            packed = servo.packed() if servo is not None else None
            tau_c = np.ascontiguousarray(tau, dtype=float)
            return fast.run_unchecked(  # q, v its own; tau's shape checked by sample()
                q,
                v,
                tau_c,
                dt,
                n,
                method=method,
                current=current,
                servo=packed,
                t0=t0,
                disturbance=compiled_disturbance,
            )
        dynamics = dynamics_with(tau)
        for i in range(n):
            new = _finite_step(step, model, dynamics, q, v, dt, t0 + i * dt)
            if new is None:
                return i
            q, v = new
        return n

    def sample(t: float, qq: np.ndarray, vv: np.ndarray) -> tuple[np.ndarray, Mapping]:
        tau, info = _split(controller(t, qq, vv))
        if tau.shape != (model.nv,):  # never hand a short array to a kernel
            raise ArgumentError(
                f"controller must return tau of shape ({model.nv},), got {tau.shape}"
            )
        return tau, info

    def sample_at_stage(t0: float):
        """The midpoint method's stage from ``(t0, q, v)`` and the controller sampled there, as the
        compiled loop does (:func:`aiauv_pin.simulation.compiled_loop.sample_inside_step`); ``(q_1,
        v_1, lagged
        force)``, or ``None`` if the stage is not finite."""
        nonlocal tau, info
        # the lagged added-mass force, computed once per step and held over it (as in advance)
        force = None if lag is None else lag.generalized_force(q, v, dt, current, t0)
        if force is not None and not _finite(force):
            return None
        held = tau if force is None else tau + force
        mid = _finite_step(midpoint_stage, model, dynamics_with(held), q, v, dt, t0)
        if mid is None:
            return None
        q_mid, v_mid = mid
        tau, info = sample(t0 + 0.5 * dt, q_mid, v_mid)
        return q_mid, v_mid, force

    def complete_sampled(t0: float, stage) -> bool:
        """The midpoint step from ``t0`` completed from ``stage`` with the sampled output; whether
        it stayed finite."""
        nonlocal q, v
        q_mid, v_mid, force = stage
        held = tau if force is None else tau + force
        new = _finite_step(midpoint_final, model, dynamics_with(held), q, v, q_mid, v_mid, dt, t0)
        if new is None:
            return False
        q, v = new
        return True

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_steps, unit="step", desc=f"simulate {duration:g} s", leave=False)

    # the midpoint method samples the controller inside every step (fast.schedule)
    inside = method in SAMPLES_INSIDE_STEP and controller is not None
    logged = 0
    tau, info = zero_tau, {}
    try:
        k = 0
        # without a controller there is no sample: one "sample period" longer than the run
        period = steps_per_control if controller is not None else n_steps + 1
        while True:
            t = k * dt
            stage = None
            act = step_actions(k, n_steps, period, log_every, inside)
            if act.sample and controller is not None:
                tau, info = sample(t, q, v)
            elif act.sample_at_stage:  # the output applied over this step, sampled at its middle
                stage = sample_at_stage(t)
            if act.log:
                log(logged, t, tau, info)
                logged += 1
            if act.last:
                break
            if inside:
                if stage is None or not complete_sampled(t, stage):
                    trajectory = _trajectory(t_log, q_log, v_log, tau_log, info_log, logged)
                    raise diverged(trajectory, k + 1, dt)
                k += 1
                if bar is not None:
                    bar.update(1)
                continue
            # run up to the next controller call or log point
            n = steps_to_next_event(k, n_steps, period, log_every)
            done = advance(tau, n, t)
            if done < n:
                trajectory = _trajectory(t_log, q_log, v_log, tau_log, info_log, logged)
                raise diverged(trajectory, k + done + 1, dt)
            k += n
            if bar is not None:
                bar.update(n)
    finally:
        if bar is not None:
            bar.close()
    return _trajectory(t_log, q_log, v_log, tau_log, info_log, logged)


def _simulate_compiled(
    vehicle: Vehicle,
    controller: CompiledController,
    q0,
    v0,
    n_steps: int,
    steps_per_control: int,
    dt: float,
    *,
    method: str,
    current,
    disturbance,
    servo,
    log_every: int,
    progress: bool,
    on_log,
    chunk_seconds: float | None,
    after_first_chunk,
    log_reader=None,
    log_memory=None,
    compile_only: bool = False,
) -> Trajectory | None:
    """:func:`simulate` with a compiled controller: the whole loop in compiled code (only loaded
    or compiled with ``compile_only``)."""
    from aiauv_pin.kernels.evaluation import METHOD_MARKERS
    from aiauv_pin.simulation.compiled_loop import loop_for

    fast = vehicle.fast
    if fast is None:  # project errors here (the campaign found plain ValueErrors)
        why = vehicle.fallback_reason or "as loaded; load it with backend='numba'"
        raise ArgumentError(
            f"a compiled controller needs the numba backend (the vehicle runs on "
            f"{vehicle.active_backend}: {why})"
        )
    if disturbance is not None and not isinstance(disturbance, Disturbance):
        raise ArgumentError(
            "a compiled controller runs with compiled disturbances only (a Disturbance)"
        )
    servo = controller.servo if servo is None else servo
    if servo is not None and not isinstance(servo, JointServo):
        raise ArgumentError("a compiled controller runs with a JointServo only, not a Python servo")
    nq, nv = fast.nq, fast.nv
    q = np.array(q0, dtype=float)
    v = np.array(v0, dtype=float)
    if q.shape != (nq,) or v.shape != (nv,):
        raise ArgumentError(f"q0 must have {nq} and v0 {nv} entries")
    check_compiled_controller(  # the records it writes
        controller, nq, nv, fast.n_thrusters, fast.model.fins.max_angle.shape[0]
    )
    if controller.reset is not None:
        controller.reset()
    environment = fast.environment(as_current(current), disturbance)
    servo_record = servo.packed() if servo is not None else fast.no_servo
    log_every = int(log_every)
    n_logs = 1 if compile_only else n_steps // log_every + 1 + (1 if n_steps % log_every else 0)
    width = controller.info_width
    # (no huge-page faults; zero for a reader, which finds the rows written by their times)
    shape = (n_logs, 1 + nq + 2 * nv + width)
    if log_memory is None or compile_only:
        log = empty_log(shape, zeroed=log_reader is not None)
    else:
        log = log_memory(shape)
        if not (isinstance(log, np.ndarray) and log.shape == shape and log.dtype == np.float64):
            raise ArgumentError(f"log_memory must return a float64 array of shape {shape}")
        if not log.flags.c_contiguous:
            raise ArgumentError("log_memory must return a C-ordered array")
    tau = np.zeros(nv)
    info = np.full(width, np.nan)
    workspace = fast.workspace
    reset_actuators(workspace)  # fins at zero, thrusters at rest
    loop = loop_for(environment, controller.loop_function, controller.parameters)

    def run_chunk(k: int, stop: int, logged: int) -> tuple[int, int]:
        """Steps ``k .. stop - 1`` of the run (:func:`aiauv_pin.simulation.compiled_loop.run_chunk`)."""
        with bounds_checked_call("simulate"):
            return loop(
                fast.model,
                environment,
                servo_record,
                controller.loop_function,
                controller.parameters,
                controller.state,
                q,
                v,
                tau,
                info,
                float(dt),
                METHOD_MARKERS[method],
                k,
                stop,
                n_steps,
                steps_per_control,
                log_every,
                log,
                logged,
                workspace,
            )

    if compile_only:  # no step to take: the call only loads or compiles the loop for these types
        run_chunk(0, 0, 0)
        return None
    # nothing to run between chunks (no bar, no callback, no viewer thread): one compiled call,
    # with no yield to the scheduler between chunks (a sweep's runs on a loaded machine lost
    # whole time slices there); the steps and their results are the same
    interactive = progress or on_log is not None or after_first_chunk is not None
    # with only ``after_first_chunk`` (a background thread), the rest is one call: each return from
    # a chunk waits for the GIL that thread holds (about one switch interval, 5 ms, per chunk)
    rest_in_one_call = chunk_seconds is None and not progress and on_log is None
    if chunk_seconds is None:
        chunk_seconds = 1.0 if on_log is not None else (10.0 if interactive else math.inf)
    chunk = max(1, n_steps) if math.isinf(chunk_seconds) else max(1, round(chunk_seconds / dt))
    if log_reader is not None:
        log_reader(log)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_steps, unit="step", desc=f"simulate {n_steps * dt:g} s", leave=False)
    logged = 0
    k = 0
    diverged_at = None
    try:
        while True:
            stop = min(k + chunk, n_steps)
            start_log = logged
            logged, done = run_chunk(k, stop, logged)
            if on_log is not None:
                for row in log[start_log:logged]:
                    on_log(
                        float(row[0]),
                        row[1 : 1 + nq].copy(),
                        controller.unpack(row[1 + nq + 2 * nv :]),
                    )
            if bar is not None:
                bar.update(done)
            if k == 0 and after_first_chunk is not None:
                after_first_chunk()
                if rest_in_one_call:
                    chunk = max(1, n_steps)
            if k + done < stop:
                diverged_at = k + done
                break
            k = stop
            if k == n_steps:
                break
            if interactive:
                time.sleep(0)  # let other threads (a viewer) run between chunks
    finally:
        if bar is not None:
            bar.close()
    trajectory = trajectory_of_log(log[:logged], nq, nv, controller.unpack)
    if diverged_at is not None:
        raise diverged(trajectory, diverged_at + 1, dt)
    return trajectory


def complete_rows(log: np.ndarray) -> int:
    """How many leading rows of a log that ``simulate`` is writing are complete (its
    ``log_reader``): those before the last row whose time is not zero (that one may be in
    writing; times grow from 0, and the log is zero where nothing was written yet)."""
    low, high = 0, log.shape[0] - 1  # the last row written is in [low, high]
    while low < high:
        middle = (low + high + 1) // 2
        if log[middle, 0] > 0.0:
            low = middle
        else:
            high = middle - 1
    return low


def trajectory_of_log(rows: np.ndarray, nq: int, nv: int, unpack) -> Trajectory:
    """The :class:`Trajectory` of the compiled loop's log rows ``(t, q, v, tau, info)``: views of
    the rows (columns ``t``, the ``nq`` configuration, ``nv`` velocity and ``nv`` force entries,
    and the named diagnostics that ``unpack(info_columns, copy=False)`` finds,
    :meth:`aiauv_pin.controllers.compiled_controller.CompiledController.unpack`), not copies.

    Copying them into arrays of their own cost about 0.045 s of the paper run (a second map of the
    log's size made present, then filled column by column) and nothing reads them faster enough to
    repay it; the views keep the log alive, which the copies replaced.
    """
    info = unpack(rows[:, 1 + nq + 2 * nv :], copy=False)
    return Trajectory(
        t=rows[:, 0],
        q=rows[:, 1 : 1 + nq],
        v=rows[:, 1 + nq : 1 + nq + nv],
        tau=rows[:, 1 + nq + nv : 1 + nq + 2 * nv],
        info=dict(info),
    )


def has_thruster_dynamics(vehicle) -> bool:
    """Whether ``vehicle`` has thrusters with a lag or a rate limit (state the interpreted loop
    does not carry). Its fins are held at zero angle under a Python controller, whose generalised
    force cannot command them: fixed surfaces."""
    return any(t.time_constant > 0.0 or t.max_rate != math.inf for t in vehicle.hydro.thrusters)


def _generalized(value, nv: int) -> np.ndarray:
    force = np.asarray(value, dtype=float)
    if force.shape != (nv,):
        raise ArgumentError(
            f"disturbance must return a generalised force of shape ({nv},), got {force.shape}"
        )
    return force


def diverged(trajectory: Trajectory, step: int, dt: float) -> SimulationDiverged:
    """Mark ``trajectory`` (the part computed so far) as diverged at ``step``; the error to raise."""
    t_bad = step * dt
    trajectory.status = "diverged"
    trajectory.message = (
        f"state became non-finite at t = {t_bad:.6g} s (step {step}); "
        f"try a smaller step than dt = {dt:g} s"
    )
    return SimulationDiverged(trajectory.message, t_bad, trajectory)


def _trajectory(t, q, v, tau, info, n) -> Trajectory:
    return Trajectory(
        t=t[:n].copy(),
        q=q[:n].copy(),
        v=v[:n].copy(),
        tau=tau[:n].copy(),
        info={key: value[:n].copy() for key, value in info.items()},
    )
