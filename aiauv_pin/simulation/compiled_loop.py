"""The compiled simulation loop: controller samples, logging and integration in one compiled call.

:func:`run_chunk` advances a run by a block of steps without returning to Python: at every control
sample it calls the controller (any compiled controller, :mod:`aiauv_pin.controllers.paper_compiled`), logs
every ``log_every`` steps, and integrates with
:func:`aiauv_pin.kernels.articulated_body.integrator_step` (current,
disturbance and joint servo at every stage). :func:`aiauv_pin.simulate` drives it in chunks so that
a progress bar and ``on_log`` callbacks still run between them.

With the midpoint method (:class:`~aiauv_pin.kernels.articulated_body.MidpointMethod`) the controller is
sampled inside every step, at the stage ``t + dt/2`` (:func:`sample_inside_step`; the step is then
completed by :func:`complete_step`). Its output is held over the step it is centred on, so the
sampling costs second-order error instead of the first-order lag that holding it from the start of
each step costs. A row at ``t`` holds, as for the other methods, the
output applied from ``t`` to ``t + dt``, with the diagnostics of its sample at ``t + dt/2``. When
the loop samples, logs and stops is :func:`step_actions`, shared with the interpreted loop.

The loop schedule, written once (:func:`step_actions`), what happens at step ``k`` of a fixed-step
run, for both loops (this one and the interpreted one of :func:`aiauv_pin.simulate` with a Python
controller):

* the controller is sampled at ``t = k dt`` every ``steps_per_control`` steps, and its output is
  held over the steps up to the next sample (zero-order hold);
* with a method that samples inside the step (the midpoint method), the controller runs at every
  step's stage ``t + dt/2`` instead, and once more at the end of the run (for the last row's
  diagnostics); there is no sample at ``t = 0``: the first stage runs with no input (``tau = 0``),
  since a sample there would be held by a controller's integrators as if it applied over
  ``[0, dt/2]`` (a visible offset along the path on the paper's surge integral);
* a row is logged every ``log_every`` steps and at the last step, after the sample of that step;
* before each step, the actuators advance over it
  (:func:`aiauv_pin.kernels.articulated_body.actuators_into`: fin angles towards the controller's
  ``W.fin_command``, the thrust of thrusters with a lag or a rate limit towards the command that
  :func:`~aiauv_pin.kernels.articulated_body.thrust_into` recorded), and the value reached is held
  over the step; the interpreted loop has no actuator state: it refuses a Python controller on a
  vehicle with thruster dynamics and holds fins at zero angle.

Which compiled controller the loop runs (:func:`run_controller`): a user's function, or a built-in
one chosen by type. numba's on-disk cache cannot key a compiled function on an argument that is
itself a function (:func:`aiauv_hydro.numerics.jit.user_or_builtin`), so the cached loop is given
``controller = None`` for the built-in controllers
(:data:`aiauv_pin.controllers.compiled_controller.BUILTIN_CONTROLLERS`) and :func:`run_controller`
chooses among them at compile time by the type of their parameters. A new built-in controller is
its module plus one branch there.
"""

from __future__ import annotations

from functools import cache, lru_cache
from typing import NamedTuple

from aiauv_hydro.numerics.jit import (
    NUMBA_AVAILABLE,
    USER_CALL_OPTIONS,
    compiled,
    is_project_function,
)
from aiauv_pin.controllers.gait_compiled import GaitParameters, serpentine_gait
from aiauv_pin.controllers.paper_compiled import (
    ConstantParameters,
    PaperParameters,
    constant_thrust,
    paper_path_following,
    passive,
)
from aiauv_pin.controllers.torpedo_compiled import TorpedoParameters, torpedo_path_following
from aiauv_pin.controllers.turning_compiled import TurningParameters, thruster_turning
from aiauv_pin.kernels.articulated_body import (
    MIDPOINT,
    MidpointMethod,
    actuators_into,
    integrator_step,
    is_finite_state,
    midpoint_final_into,
    midpoint_stage_into,
)


# ------------------------------------------------------------------ the schedule
class StepActions(NamedTuple):
    """What the loop does at step ``k``, in this order.

    Attributes:
        sample: Run the controller at ``t = k dt``.
        sample_at_stage: Run the controller at the step's stage ``t + dt/2`` (midpoint method).
        log: Log the row of ``t = k dt`` (after the sample).
        last: ``k`` is the last step: stop after logging (no integration).
    """

    sample: bool
    sample_at_stage: bool
    log: bool
    last: bool


@compiled
def step_actions(k, n_total, steps_per_control, log_every, inside):
    """The :class:`StepActions` of step ``k`` of a run of ``n_total`` steps.

    Args:
        k: Step index, ``0 <= k <= n_total``.
        n_total: Steps of the run.
        steps_per_control: Steps between two controller samples (1 with ``inside``).
        log_every: Steps between two logged rows.
        inside: The method samples the controller inside each step (the midpoint method).
    """
    last = k == n_total
    sample = k % steps_per_control == 0 and (not inside or last)
    return StepActions(sample, inside and not sample, k % log_every == 0 or last, last)


@compiled
def steps_to_next_event(k, n_total, steps_per_control, log_every):
    """Steps the loop may take from ``k`` without a sample, a row or the end in between: the
    interpreted loop integrates that many in one call."""
    to_sample = steps_per_control - k % steps_per_control
    to_log = log_every - k % log_every
    return min(to_sample, to_log, n_total - k)


# ------------------------------------------------------------------ the controller
def run_controller(user, t, q, v, model, workspace, parameters, state, tau, info):
    """``user(...)``, or with ``user = None`` the built-in controller ``parameters`` select:
    :class:`PaperParameters` the paper's, :class:`TurningParameters` thruster turning,
    :class:`GaitParameters` the serpentine gait, :class:`ConstantParameters` constant thrusts,
    :class:`TorpedoParameters` a torpedo's path following, anything else passive. Compiled, the
    choice is
    made at compile time (an overload)."""
    if user is not None:
        return user(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, PaperParameters):
        return paper_path_following(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, TurningParameters):
        return thruster_turning(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, GaitParameters):
        return serpentine_gait(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, ConstantParameters):
        return constant_thrust(t, q, v, model, workspace, parameters, state, tau, info)
    if isinstance(parameters, TorpedoParameters):
        return torpedo_path_following(t, q, v, model, workspace, parameters, state, tau, info)
    return passive(t, q, v, model, workspace, parameters, state, tau, info)


if NUMBA_AVAILABLE:
    from numba import types
    from numba.extending import overload

    def _is(parameters, record) -> bool:
        return isinstance(parameters, types.BaseNamedTuple) and parameters.instance_class is record

    def _is_user(user) -> bool:
        return not isinstance(user, (types.NoneType, types.Omitted))

    # with reference counting, said explicitly (USER_CALL_OPTIONS): a user's function may allocate
    @overload(run_controller, jit_options=USER_CALL_OPTIONS)
    def _run_user_controller(user, t, q, v, model, workspace, parameters, state, tau, info):
        if _is_user(user):

            def call_user(user, t, q, v, model, workspace, parameters, state, tau, info):
                user(t, q, v, model, workspace, parameters, state, tau, info)

            return call_user
        return None

    # inlined into the (compiled, reference-count free) loop: a separate function would be compiled
    # with numba's reference counting, which counts every array of the records it is passed (the
    # model, the workspace) up on entry and down on exit: about 1 us per sample of the paper's
    # controller, as much as the controller itself
    @overload(run_controller, inline="always")
    def _run_controller(user, t, q, v, model, workspace, parameters, state, tau, info):
        if _is_user(user):
            return None
        if _is(parameters, PaperParameters):

            def call_paper(user, t, q, v, model, workspace, parameters, state, tau, info):
                paper_path_following(t, q, v, model, workspace, parameters, state, tau, info)

            return call_paper
        if _is(parameters, TurningParameters):

            def call_turning(user, t, q, v, model, workspace, parameters, state, tau, info):
                thruster_turning(t, q, v, model, workspace, parameters, state, tau, info)

            return call_turning
        if _is(parameters, GaitParameters):

            def call_gait(user, t, q, v, model, workspace, parameters, state, tau, info):
                serpentine_gait(t, q, v, model, workspace, parameters, state, tau, info)

            return call_gait
        if _is(parameters, ConstantParameters):

            def call_constant(user, t, q, v, model, workspace, parameters, state, tau, info):
                constant_thrust(t, q, v, model, workspace, parameters, state, tau, info)

            return call_constant
        if _is(parameters, TorpedoParameters):

            def call_torpedo(user, t, q, v, model, workspace, parameters, state, tau, info):
                torpedo_path_following(t, q, v, model, workspace, parameters, state, tau, info)

            return call_torpedo

        def call_passive(user, t, q, v, model, workspace, parameters, state, tau, info):
            passive(t, q, v, model, workspace, parameters, state, tau, info)

        return call_passive


# ------------------------------------------------------------------ the step
def samples_inside_step(method) -> bool:
    """Whether the loop samples the controller inside each step of ``method`` (a marker or a code
    of :mod:`aiauv_pin.kernels.articulated_body`): the midpoint method."""
    code = method if isinstance(method, int) else method.code
    return code == MIDPOINT


def sample_inside_step(
    method, controller, parameters, state, model, env, servo, t, q, v, tau, info, dt, W
):
    """The midpoint method's stage from ``(t, q, v)`` into ``W.q_stage, W.v_stage``, and the
    controller sampled there (``t + dt/2``), writing ``tau`` and ``info``; nothing for the others."""
    if samples_inside_step(method):
        midpoint_stage_into(model, env, servo, t, q, v, tau, dt, W, W.q_stage, W.v_stage)
        run_controller(
            controller, t + 0.5 * dt, W.q_stage, W.v_stage, model, W, parameters, state, tau, info
        )


def complete_step(method, model, env, servo, t, q, v, tau, dt, W):
    """The step of ``method`` from ``(t, q, v)`` into ``W.q_next, W.v_next`` with ``tau``: the
    midpoint method's completion from the stage :func:`sample_inside_step` left in ``W``, the
    others' whole step."""
    if samples_inside_step(method):
        midpoint_final_into(
            model, env, servo, t, q, v, W.q_stage, W.v_stage, tau, dt, W, W.q_next, W.v_next
        )
    else:
        integrator_step(method, model, env, servo, t, q, v, tau, dt, W, W.q_next, W.v_next)


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
    ``parameters`` select (:func:`run_controller`).

    ``method`` is a :class:`aiauv_pin.kernels.articulated_body.EulerMethod` or ``RK4Method`` (the loop is
    compiled for that integrator alone) or a method code.

    ``log`` rows are ``(t, q, v, tau, info)``; ``tau`` and ``info`` hold the last controller output
    between calls (zero-order hold). With the midpoint method the controller runs inside every
    step at its stage ``t + dt/2`` (then ``steps_per_control`` must be 1), before the step's row
    is logged, and at the end; a row at ``t`` then holds the output applied over ``[t, t + dt]``
    and the diagnostics of its sample at ``t + dt/2``.

    Returns:
        ``(next log index, steps completed)``; fewer steps than asked means the state became
        non-finite (``q, v`` then hold the last finite state).
    """
    nq = q.shape[0]
    nv = v.shape[0]
    width = info.shape[0]
    inside = samples_inside_step(method)
    k = k_start
    while True:
        if k == k_stop and k != n_total:
            return log_index, k - k_start
        t = k * dt
        act = step_actions(k, n_total, steps_per_control, log_every, inside)
        if act.sample:
            run_controller(controller, t, q, v, model, W, parameters, state, tau, info)
        elif act.sample_at_stage:  # the output applied over this step, sampled at its middle
            sample_inside_step(
                method, controller, parameters, state, model, env, servo, t, q, v, tau, info, dt, W
            )
        if act.log:
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
        if act.last:
            return log_index, k - k_start
        if actuators_into(model, W, q, v, tau, dt):  # lagged thrusters: tau corrected
            complete_step(method, model, env, servo, t, q, v, W.tau_actuated, dt, W)
        else:
            complete_step(method, model, env, servo, t, q, v, tau, dt, W)
        if not is_finite_state(W.q_next, W.v_next):
            return log_index, k - k_start
        q_next, v_next = W.q_next, W.v_next
        for i in range(nq):
            q[i] = q_next[i]
        for i in range(nv):
            v[i] = v_next[i]
        k += 1


if NUMBA_AVAILABLE:
    from numba import types
    from numba.extending import overload

    @overload(samples_inside_step)
    def _samples_inside_step(method):
        chosen = getattr(method, "instance_class", None)
        if chosen is not None:
            inside = chosen is MidpointMethod

            def constant(method):
                return inside

            return constant
        if isinstance(method, types.Integer):

            def by_code(method):
                return method == MIDPOINT

            return by_code
        return None

    # chosen by the marker's type, so a loop compiled for Euler or RK4 does not compile the
    # midpoint's stages and second controller call; a code is chosen at run time. Compiled without
    # reference counting, as the loop: the built-in controller is inlined here (run_controller)
    @overload(sample_inside_step, jit_options={"_nrt": False})
    def _sample_inside_step(
        method, controller, parameters, state, model, env, servo, t, q, v, tau, info, dt, W
    ):
        if getattr(method, "instance_class", None) in (None, MidpointMethod):
            return sample_inside_step

        def nothing(
            method, controller, parameters, state, model, env, servo, t, q, v, tau, info, dt, W
        ):
            pass

        return nothing

    @overload(complete_step)
    def _complete_step(method, model, env, servo, t, q, v, tau, dt, W):
        if getattr(method, "instance_class", None) in (None, MidpointMethod):
            return complete_step

        def whole(method, model, env, servo, t, q, v, tau, dt, W):
            integrator_step(method, model, env, servo, t, q, v, tau, dt, W, W.q_next, W.v_next)

        return whole


def _dispatchers(value, found: list) -> list:
    """Every numba dispatcher inside ``value`` (named tuples and tuples searched recursively)."""
    if hasattr(value, "py_func"):
        found.append(value)
    elif isinstance(value, tuple):
        for item in value:
            _dispatchers(item, found)
    return found


#: How the loop is compiled for a user's functions: as :func:`run_chunk`, without reference
#: counting. The loop never calls a user's function itself: a controller through
#: :func:`run_controller`'s separate function for it, a path, current or disturbance through
#: :func:`aiauv_hydro.numerics.jit.user_or_builtin`'s or a reference-counted kernel, so what a
#: user's function allocates and returns is counted there. Counted in the loop too (as it was),
#: every record read there counted each of its arrays up and down: the paper's path following
#: written as a user's controller (``benchmarks/user_controller.py``) took 1.9-2.0x the built-in
#: controller's CPU time.
_USER_LOOP_OPTIONS = {"nogil": True, "error_model": "numpy", "_nrt": False}


@lru_cache(maxsize=1)
def _run_chunk_uncached():
    import numba

    # without reference counting, as run_chunk (_USER_LOOP_OPTIONS)
    return numba.njit(**_USER_LOOP_OPTIONS)(run_chunk.py_func)


def loop_for(*arguments):
    """The compiled loop to call with these arguments.

    With only built-in functions it is :func:`run_chunk` (cached, shipped with the package). A
    user's own function (a controller, path, current or disturbance defined outside the project)
    appears in the loop's signature, and numba's on-disk cache names it by its dispatcher's uuid,
    random in every process (numba issue 6251). Each such function is therefore named by its
    content (:func:`aiauv_hydro.numerics.function_identity.stable_uuid`: source, globals, options,
    recursively for the user's functions it calls), and the loop runs in a copy of
    :func:`run_chunk` cached under a name of its own for that set of functions
    (:func:`_run_chunk_for`): compiled once per installation and content, found again by later
    processes, compiled again when a function's source or globals change.

    A function that cannot be named by content (no readable source, e.g. defined in a REPL; a
    global of a kind the digest does not describe) runs, as before, in an uncached copy of the loop
    compiled once per process.
    """
    if not NUMBA_AVAILABLE:
        return run_chunk
    functions = _dispatchers(tuple(arguments), [])
    if all(is_project_function(function) for function in functions):
        return run_chunk
    from aiauv_hydro.numerics.function_identity import stable_uuid

    uuids = [stable_uuid(function) for function in functions]
    if None in uuids:
        return _run_chunk_uncached()
    return _run_chunk_for(tuple(sorted(set(uuids))))


@cache
def _run_chunk_for(uuids: tuple[str, ...]):
    """A copy of :func:`run_chunk` cached on disk for the user's functions named ``uuids``.

    Its own name (``run_chunk_for_<digest of the uuids>``) gives it its own index file in the
    cache, so that loading it never unpickles the entries of other user functions (numba unpickles
    a whole index: an entry naming a module since deleted would fail to load). A signature numba
    cannot pickle into the index is not saved (the loop is then compiled in every process).
    """
    import hashlib
    import types as python_types

    import numba

    from aiauv_hydro.numerics.function_identity import saving_only_what_pickles
    from aiauv_hydro.numerics.jit import disk_cache_usable

    digest = hashlib.sha256("\0".join(uuids).encode()).hexdigest()[:16]
    source = run_chunk.py_func
    copy = python_types.FunctionType(
        source.__code__, source.__globals__, f"run_chunk_for_{digest}", source.__defaults__
    )
    copy.__qualname__ = copy.__name__
    copy.__module__ = source.__module__
    copy.__doc__ = source.__doc__
    loop = numba.njit(cache=disk_cache_usable(), **_USER_LOOP_OPTIONS)(copy)
    return saving_only_what_pickles(loop)
