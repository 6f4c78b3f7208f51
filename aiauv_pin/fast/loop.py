"""The compiled simulation loop: controller samples, logging and integration in one compiled call.

:func:`run_chunk` advances a run by a block of steps without returning to Python: at every control
sample it calls the controller (any compiled controller, :mod:`aiauv_pin.fast.controllers`), logs
every ``log_every`` steps, and integrates with :func:`aiauv_pin.fast.kernels.integrator_step` (current,
disturbance and joint servo at every stage). :func:`aiauv_pin.simulate` drives it in chunks so that
a progress bar and ``on_log`` callbacks still run between them.
"""

from __future__ import annotations

from functools import lru_cache

from hydro.jit import NUMBA_AVAILABLE, PROJECT_PACKAGES, compiled

from .dispatch import run_controller
from .kernels import integrator_step, is_finite_state


@compiled(borrows_only=True)
def run_chunk(
    model,
    env,
    servo,
    controller,
    parameters,
    state,
    q,
    v,
    tau,
    info,
    dt,
    method,
    k_start,
    k_stop,
    n_total,
    steps_per_control,
    log_every,
    log,
    log_index,
    W,
):
    """Steps ``k_start .. k_stop - 1`` (controller, logging, integration), plus the final sample.

    ``controller`` is a user's compiled controller, or ``None`` for the built-in one that
    ``parameters`` select (:func:`aiauv_pin.fast.dispatch.run_controller`).

    ``method`` is a :class:`aiauv_pin.fast.kernels.EulerMethod` or ``RK4Method`` (the loop is
    compiled for that integrator alone) or a method code.

    ``log`` rows are ``(t, q, v, tau, info)``; ``tau`` and ``info`` hold the last controller output
    between calls (zero-order hold).

    Returns:
        ``(next log index, steps completed)``; fewer steps than asked means the state became
        non-finite (``q, v`` then hold the last finite state).
    """
    nq = q.shape[0]
    nv = v.shape[0]
    width = info.shape[0]
    k = k_start
    while True:
        if k == k_stop and k != n_total:
            return log_index, k - k_start
        t = k * dt
        if k % steps_per_control == 0:
            run_controller(controller, t, q, v, model, W, parameters, state, tau, info)
        if k % log_every == 0 or k == n_total:
            row = log[log_index]
            row[0] = t
            for i in range(nq):
                row[1 + i] = q[i]
            for i in range(nv):
                row[1 + nq + i] = v[i]
                row[1 + nq + nv + i] = tau[i]
            base = 1 + nq + 2 * nv
            for i in range(width):
                row[base + i] = info[i]
            log_index += 1
        if k == n_total:
            return log_index, k - k_start
        integrator_step(method, model, env, servo, t, q, v, tau, dt, W, W.q_next, W.v_next)
        if not is_finite_state(W.q_next, W.v_next):
            return log_index, k - k_start
        q_next, v_next = W.q_next, W.v_next
        for i in range(nq):
            q[i] = q_next[i]
        for i in range(nv):
            v[i] = v_next[i]
        k += 1


def _dispatchers(value, found: list) -> list:
    """Every numba dispatcher inside ``value`` (named tuples and tuples searched recursively)."""
    if hasattr(value, "py_func"):
        found.append(value)
    elif isinstance(value, tuple):
        for item in value:
            _dispatchers(item, found)
    return found


def is_project_function(function) -> bool:
    """Whether a compiled function is one of the project's own (its module is in its packages)."""
    module = getattr(function, "__module__", "") or ""
    return module.split(".")[0] in PROJECT_PACKAGES


@lru_cache(maxsize=1)
def _run_chunk_uncached():
    import numba

    # with reference counting: a user's function may allocate and return arrays of its own
    return numba.njit(nogil=True, error_model="numpy")(run_chunk.py_func)


def loop_for(*arguments):
    """The compiled loop to call with these arguments.

    numba's on-disk cache stores each specialisation's signature, which names the first-class
    functions it was compiled for; a user's own function (a controller, path, current or
    disturbance defined outside the project) cannot be found again by a later process, so its
    specialisations are compiled in memory, once per process, by an uncached copy of the same loop
    (:func:`run_chunk`'s source). With only built-in functions the cached loop is used.
    """
    if not NUMBA_AVAILABLE:
        return run_chunk
    functions = _dispatchers(tuple(arguments), [])
    if all(is_project_function(function) for function in functions):
        return run_chunk
    return _run_chunk_uncached()
