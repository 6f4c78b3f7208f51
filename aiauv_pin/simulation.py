"""Fixed-step simulation loop with a controller callback and state logging."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from .errors import SimulationDiverged
from .integrators import INTEGRATORS
from .vehicle import Vehicle

#: ``controller(t, q, v) -> tau`` or ``-> (tau, info)``, with ``tau`` the generalised force (nv,) held
#: constant over the step and ``info`` a mapping of scalars or arrays to log.
Controller = Callable[[float, np.ndarray, np.ndarray], object]

#: ``servo(q, v) -> tau``: a generalised force evaluated at every integrator stage (a continuous-time
#: inner loop, such as joint servos running much faster than the outer controller).
Servo = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class Trajectory:
    """Logged states of a simulation.

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


def simulate(
    vehicle: Vehicle,
    q0: np.ndarray,
    v0: np.ndarray,
    duration: float,
    dt: float,
    controller: Controller | None = None,
    *,
    method: str = "rk4",
    current: np.ndarray | None = None,
    servo: Servo | None = None,
    log_every: int = 1,
    progress: bool = False,
) -> Trajectory:
    """Integrate the vehicle's dynamics with a fixed step.

    The controller is called once per step at the step's start; its output is held over the step
    (zero-order hold, as a digital controller would apply it).

    Args:
        vehicle: The vehicle.
        q0: Initial configuration (nq,).
        v0: Initial velocity (nv,) [m/s, rad/s].
        duration: Simulated time [s] (> 0).
        dt: Step [s] (> 0).
        controller: ``controller(t, q, v) -> tau | (tau, info)``; ``None`` applies no input.
        method: ``"rk4"`` (Runge-Kutta-Munthe-Kaas, order 4) or ``"euler"`` (semi-implicit, order 1).
        current: Constant water velocity in the world frame (3,) [m/s].
        servo: ``servo(q, v) -> tau`` added to the controller's output at every integrator stage.
        log_every: Log every this many steps (the final state is always logged).
        progress: Show a progress bar (tqdm).

    Returns:
        The trajectory.

    Raises:
        ValueError: Bad arguments (one line).
        SimulationDiverged: The state became NaN or infinite; the error carries the time and the
            trajectory computed so far.
    """
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive number of seconds, got {duration!r}")
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    if method not in INTEGRATORS:
        raise ValueError(f"unknown method '{method}' (expected one of {', '.join(INTEGRATORS)})")
    if int(log_every) < 1:
        raise ValueError(f"log_every must be >= 1, got {log_every!r}")
    step = INTEGRATORS[method]
    model = vehicle.model
    q = np.array(q0, dtype=float)
    v = np.array(v0, dtype=float)
    if q.shape != (model.nq,) or v.shape != (model.nv,):
        raise ValueError(f"q0 must have {model.nq} and v0 {model.nv} entries")
    current = None if current is None else np.asarray(current, dtype=float).reshape(3)
    n_steps = max(1, round(duration / dt))
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

    def dynamics_with(tau: np.ndarray):
        if servo is None:
            return lambda qq, vv: vehicle.acceleration(qq, vv, tau, current)
        return lambda qq, vv: vehicle.acceleration(qq, vv, tau + servo(qq, vv), current)

    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=n_steps, unit="step", desc=f"simulate {duration:g} s", leave=False)

    logged = 0
    try:
        for k in range(n_steps + 1):
            t = k * dt
            tau, info = _split(controller(t, q, v)) if controller is not None else (zero_tau, {})
            if k % log_every == 0 or k == n_steps:
                log(logged, t, tau, info)
                logged += 1
            if k == n_steps:
                break
            try:
                q_new, v_new = step(model, dynamics_with(tau), q, v, dt)
            except np.linalg.LinAlgError:
                q_new, v_new = q + np.nan, v + np.nan
            if not (np.all(np.isfinite(q_new)) and np.all(np.isfinite(v_new))):
                trajectory = _trajectory(t_log, q_log, v_log, tau_log, info_log, logged)
                trajectory.status = "diverged"
                trajectory.message = (
                    f"state became non-finite at t = {t + dt:.6g} s (step {k + 1}); "
                    f"try a smaller step than dt = {dt:g} s"
                )
                raise SimulationDiverged(trajectory.message, t + dt, trajectory)
            q, v = q_new, v_new
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return _trajectory(t_log, q_log, v_log, tau_log, info_log, logged)


def _trajectory(t, q, v, tau, info, n) -> Trajectory:
    return Trajectory(
        t=t[:n].copy(),
        q=q[:n].copy(),
        v=v[:n].copy(),
        tau=tau[:n].copy(),
        info={key: value[:n].copy() for key, value in info.items()},
    )
