"""Compiled evaluation of one vehicle from Python: thin wrappers around
:mod:`aiauv_pin.kernels.articulated_body`.

:class:`FastModel` holds a vehicle's packed records (:class:`~aiauv_pin.kernels.records.Model`), its
frames, a reusable workspace per thread and the default environment (still water, no disturbance).
It is built from the vehicle's description by :func:`aiauv_pin.model.assembly.compiled_model` and
knows nothing of the :class:`aiauv_pin.Vehicle` that holds it (``Vehicle.fast``).

Every public method checks its arguments before any compiled code runs (the kernels do not check
indices: a ``v`` one entry too long, a short record or a non-contiguous array would be read or
written past its end), with the checks of :mod:`aiauv_pin._internal.array_checks`: shapes, dtype, contiguity
of what is advanced in place, finiteness, a unit base quaternion, a checked current
(:meth:`aiauv_hydro.currents.Current.check`) and servo record. ``acceleration`` and ``step`` in still
water without a servo check the state inside the compiled call itself
(:func:`aiauv_pin.kernels.handle.state_verdict`; ``benchmarks/entry_checks.py`` measures what that
costs). Foreign exceptions leave as project errors (:func:`aiauv_pin.errors.project_errors`).

Threads: the workspace (and the handle that holds it) is per thread (``threading.local``), so one
:class:`FastModel` may be used from several threads at once; the model records are read only.
"""

from __future__ import annotations

import math
import threading

import numba  # noqa: F401  (the compiled backend needs numba: ImportError here means fall back)
import numpy as np

from aiauv_hydro.currents import Current, as_current
from aiauv_pin._internal.array_checks import (
    configuration,
    configurations,
    finite_time,
    float_array,
    frame_index,
    in_place_array,
    method_name,
    optional_current,
    positive_seconds,
    step_count,
    unit_quaternion,
)
from aiauv_pin.errors import ArgumentError, NumericalError, project_errors
from aiauv_pin.kernels import articulated_body as kernels
from aiauv_pin.kernels.disturbances import Disturbance
from aiauv_pin.kernels.handle import (
    STATE_OK,
    acceleration_of,
    checked_acceleration_of,
    checked_step_of,
    new_handle,
    step_of,
    thrust_matrix_of,
)
from aiauv_pin.kernels.records import Environment, Servo

#: ``(method name -> marker)`` for :func:`kernels.integrator_step`: the compiled loop is compiled
#: for one integrator only.
METHOD_MARKERS = {
    "rk4": kernels.RK4Method(),
    "euler": kernels.EulerMethod(),
    "midpoint": kernels.MidpointMethod(),
}

#: ``(method name -> code)`` understood by :func:`kernels.step_into` and :func:`kernels.run_steps`
#: (each marker's code).
METHOD_CODES = {name: marker.code for name, marker in METHOD_MARKERS.items()}


def no_servo() -> Servo:
    """A :class:`Servo` record that does nothing."""
    empty = np.zeros(0)
    return Servo(empty, empty, empty, False, False)


def environment(current=None, disturbance: Disturbance | None = None) -> Environment:
    """The :class:`Environment` record of a current (see :func:`aiauv_hydro.currents.as_current`) and a
    compiled disturbance (``None``: none), both checked.

    Raises:
        ArgumentError: A bad current (:func:`aiauv_pin._internal.array_checks.optional_current`) or a
            disturbance that is not a compiled :class:`~aiauv_pin.kernels.disturbances.Disturbance`.
    """
    water: Current = as_current(optional_current(current))
    if disturbance is not None and not isinstance(disturbance, Disturbance):
        raise ArgumentError(
            f"disturbance must be a compiled Disturbance, got {type(disturbance).__name__:.40}"
        )
    push = Disturbance.none() if disturbance is None else disturbance
    return Environment(
        water.user_function,
        water.kind_code,
        water.parameters,
        push.user_function,
        push.kind_code,
        push.parameters,
        water.user_acceleration,
        # a constant current never accelerates: not sampled, so its runs stay bit-identical
        water.unsteady and water.kind != "constant",
    )


_FLOAT64 = np.dtype(np.float64)


#: Largest step count of :meth:`FastModel.run` (a step count beyond it is not exact in a float).
MAX_RUN_STEPS = 2**53

#: Largest integer time the fast paths convert to a float themselves (exact in a float64).
MAX_EXACT_INT = 2**53

_INFINITY = math.inf


def _plain(array, size: int) -> bool:
    """Whether ``array`` is a float64 vector of ``size`` that compiled code may take as it is."""
    return (
        type(array) is np.ndarray
        and array.dtype is _FLOAT64
        and array.shape == (size,)
        and array.flags.carray
    )


def _float64_vectors(q, v, tau) -> bool:
    """Whether ``q, v, tau`` are 1-D float64 arrays (native order): what the fast paths check in
    Python before their compiled call checks sizes, contiguity and values
    (:func:`aiauv_pin.kernels.handle.state_verdict`); numba's unboxing needs the dtype and the
    number of dimensions right (a 2-D array would overflow a 1-D record)."""
    try:
        return (
            q.dtype is _FLOAT64
            and v.dtype is _FLOAT64
            and tau.dtype is _FLOAT64
            and q.ndim == 1
            and v.ndim == 1
            and tau.ndim == 1
        )
    except AttributeError:  # not an array
        return False


def _entry_point(dispatcher, args):
    """The compiled entry point of ``dispatcher`` for the types of ``args``, or ``dispatcher``.

    Calling a numba dispatcher from Python types every argument first (for the kernels' records,
    some 70 arrays in named tuples, that cost more than the evaluation itself; for a
    :class:`~aiauv_pin.kernels.handle.Handle` and the small environment records, still about a
    microsecond). The entry point of the overload already chosen for these types skips that step
    and only unboxes the arguments, so it may be called only with arguments of exactly these types
    (:class:`FastModel` makes sure).
    """
    try:
        signature = tuple(dispatcher.typeof_pyval(a) for a in args)
        return dispatcher.overloads[signature].entry_point
    except (AttributeError, KeyError):  # another numba version or no such overload: dispatch
        return dispatcher


class _PerThread(threading.local):
    """What one thread's evaluations overwrite: its workspace, the handle holding it, and a
    scratch configuration (``threading.local``: a new thread starts with ``None``)."""

    workspace = None
    handle = None
    q_unit = None


class FastModel:
    """A vehicle's equations of motion evaluated by the compiled kernels.

    Every public method checks its arguments (see the module docstring) and may be called from
    several threads at once (a workspace per thread).

    Args:
        records: The vehicle's packed records (:func:`aiauv_pin.model.assembly.packed_records`: its
            ``added_mass``, ``damping`` and ``restoring`` switches are already in them).
        nq, nv: Sizes of its configuration and velocity.
        frames: ``(body, rotation (3, 3), translation (3,) [m])`` of each of its frames, by frame
            index (:func:`aiauv_pin.model.assembly.frame_records`).
    """

    def __init__(self, records, nq: int, nv: int, frames) -> None:
        self.model = records
        self.nq, self.nv = int(nq), int(nv)
        self.n_bodies = self.model.bodies.parent.shape[0]
        self.n_thrusters = self.model.thrusters.body.shape[0]
        self.still_water = environment()
        self.no_servo = no_servo()
        self._frames: tuple[tuple[int, np.ndarray, np.ndarray], ...] = tuple(frames)
        self._entries: dict = {}
        self._local = _PerThread()
        self._checked_acceleration_entry = self._checked_step_entry = None
        self._q_shape, self._v_shape = (self.nq,), (self.nv,)
        self._local.workspace = kernels.new_workspace(self.model, self.nq, self.nv)

    @property
    def workspace(self):
        """This thread's :class:`~aiauv_pin.kernels.records.Workspace` (made on first use)."""
        local = self._local
        if local.workspace is None:
            local.workspace = kernels.new_workspace(self.model, self.nq, self.nv)
        return local.workspace

    def environment(self, current=None, disturbance=None) -> Environment:
        """The environment record (the cached still-water one when both are ``None``), checked."""
        if current is None and disturbance is None:
            return self.still_water
        return environment(current, disturbance)

    def servo_record(self, servo) -> Servo:
        """``servo`` (a :class:`~aiauv_pin.kernels.records.Servo` record, ``None`` for none) checked:
        an enabled servo's gains and references are finite float64 arrays of one entry per joint.

        Raises:
            ArgumentError: One line naming the field.
        """
        if servo is None or servo is self.no_servo:
            return self.no_servo
        if not isinstance(servo, Servo):
            raise ArgumentError(f"servo must be a Servo record, got {type(servo).__name__:.40}")
        if type(servo.enabled) is not bool or type(servo.compensate_restoring) is not bool:
            raise ArgumentError("servo.enabled and servo.compensate_restoring must be bools")
        joints = self.nv - 6
        for name in ("stiffness", "damping", "references"):
            value = getattr(servo, name)
            if not servo.enabled and isinstance(value, np.ndarray) and value.size == 0:
                continue
            in_place_array(value, f"servo.{name}", (joints,))
        return servo

    def _fixed_types(self, env, servo) -> bool:
        """Whether ``env`` and ``servo`` are of the kinds whose numba types never change for this
        model (built-in current and disturbance, no servo): then :meth:`_fast_call` applies."""
        return (
            servo is self.no_servo
            and env.current_function is None
            and env.current_acceleration_function is None
            and env.disturbance_function is None
        )

    def _fast_call(self, kernel, args):
        """``kernel(handle, ...)`` (:mod:`aiauv_pin.kernels.handle`) through its cached entry point."""
        entry = self._entries.get(kernel)
        if entry is None:
            result = kernel(*args)
            self._entries[kernel] = _entry_point(kernel, args)
            return result
        return entry(*args)

    def __getstate__(self) -> dict:
        """Picklable state: the per-thread workspaces and the entry points are process-local,
        made again on use."""
        state = self.__dict__.copy()
        state["_entries"] = {}
        state["_checked_acceleration_entry"] = state["_checked_step_entry"] = None
        del state["_local"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._local = _PerThread()

    @property
    def handle(self):
        """This thread's :class:`aiauv_pin.kernels.handle.Handle` (its workspace; made on first use)."""
        local = self._local
        handle = local.handle
        if handle is None:
            handle = local.handle = new_handle(
                self.model, self.workspace, self.still_water, self.no_servo
            )
        return handle

    def _scratch_q(self) -> np.ndarray:
        local = self._local
        if local.q_unit is None:
            local.q_unit = np.empty(self.nq)
        return local.q_unit

    # ------------------------------------------------------------------ public, checked
    def acceleration(
        self, q, v, tau, current=None, *, t: float = 0.0, servo=None, disturbance=None
    ):
        """``dv`` (nv,), as :meth:`aiauv_pin.Vehicle.acceleration` (plus an optional servo record).

        Raises:
            ArgumentError: A bad argument (see the module docstring), before anything runs.
        """
        if current is None and servo is None and disturbance is None:
            # checked_acceleration's hot block inlined (one Python call less); the first call
            # of a thread, an integer t or a refusal go through it
            entry = self._checked_acceleration_entry
            if entry is not None and type(t) is float:
                try:
                    if _float64_vectors(q, v, tau):
                        handle = self._local.handle
                        if handle is not None:
                            out = np.empty(self.nv)
                            if entry(handle, t, q, v, tau, out) == STATE_OK:
                                return out
                except TypeError:  # only looks like an array
                    pass
            out = self.checked_acceleration(q, v, tau, t)
            if out is not None:
                return out
        q = configuration(q, self.nq)
        v = float_array(v, "v", (self.nv,))
        tau = float_array(tau, "tau", (self.nv,))
        t = finite_time(t)
        env = self.environment(current, disturbance)
        return self.acceleration_unchecked(q, v, tau, env, self.servo_record(servo), t)

    @project_errors("FastModel.acceleration")
    def acceleration_unchecked(self, q, v, tau, env, servo, t: float) -> np.ndarray:
        """:meth:`acceleration` with arguments already checked (an environment record and a servo
        record): only for callers that ran the checks themselves (:class:`aiauv_pin.Vehicle`)."""
        out = np.empty(self.nv)
        if self._fixed_types(env, servo):
            self._fast_call(acceleration_of, (self.handle, env, servo, float(t), q, v, tau, out))
        else:
            kernels.acceleration_into(
                self.model, env, servo, float(t), q, v, tau, self.workspace, out, 0.0
            )
        return out

    def checked_acceleration(self, q, v, tau, t) -> np.ndarray | None:
        """``dv`` in still water, the state checked in the same compiled call, or ``None``.

        The fast path of :meth:`aiauv_pin.Vehicle.acceleration`: only 1-D float64 arrays and a
        float or integer ``t`` take it; their sizes, contiguity, finiteness and quaternion are
        checked in the compiled call (:func:`aiauv_pin.kernels.handle.state_verdict`). ``None``
        means "not taken": the arguments were of another kind or the compiled check refused them,
        and the caller's own checks then name the problem.
        """
        # the hottest entry point (benchmarks/entry_checks.py): the dtype and number of
        # dimensions checked here (numba's unboxing needs them right), everything else in the
        # compiled call
        entry = self._checked_acceleration_entry
        if entry is not None and type(t) is float:
            if not _float64_vectors(q, v, tau):
                return None
            try:
                handle = self._local.handle
                if handle is not None:
                    out = np.empty(self.nv)
                    return out if entry(handle, t, q, v, tau, out) == STATE_OK else None
            except TypeError:  # only looks like an array
                return None
        return self._first_checked_acceleration(q, v, tau, t)

    def _first_checked_acceleration(self, q, v, tau, t) -> np.ndarray | None:
        """:meth:`checked_acceleration` for the first call of a thread or model, or an integer
        ``t``: checks the arguments' kinds, then makes the handle and finds the entry point."""
        if not _float64_vectors(q, v, tau):
            return None
        if type(t) is not float:
            if type(t) is not int or not -MAX_EXACT_INT <= t <= MAX_EXACT_INT:
                return None
            t = float(t)
        handle = self._local.handle
        entry = self._checked_acceleration_entry
        out = np.empty(self.nv)
        if handle is None or entry is None:  # the first call of this thread or model
            if not (_plain(q, self.nq) and _plain(v, self.nv) and _plain(tau, self.nv)):
                return None  # (the dispatcher would compile for another layout)
            verdict = self._fast_call(checked_acceleration_of, (self.handle, t, q, v, tau, out))
            self._checked_acceleration_entry = self._entries[checked_acceleration_of]
            return out if verdict == STATE_OK else None
        try:
            if entry(handle, t, q, v, tau, out) == STATE_OK:
                return out
        except TypeError:  # an object that only looks like an array
            pass
        return None

    def restoring_forces(self, q) -> np.ndarray:
        """``g(q)`` (nv,) on the left-hand side, as :meth:`aiauv_pin.Vehicle.restoring_forces`."""
        return self.restoring_forces_unchecked(configuration(q, self.nq))

    @project_errors("FastModel.restoring_forces")
    def restoring_forces_unchecked(self, q: np.ndarray) -> np.ndarray:
        """:meth:`restoring_forces` of a checked configuration."""
        out = np.empty(self.nv)
        kernels.restoring_forces(self.model, q, self.workspace, out)
        return out

    def thrust_matrix(self, q) -> np.ndarray:
        """``B(q)`` (nv x m), as :meth:`aiauv_pin.Vehicle.thrust_matrix`."""
        return self.thrust_matrix_unchecked(configuration(q, self.nq))

    @project_errors("FastModel.thrust_matrix")
    def thrust_matrix_unchecked(self, q: np.ndarray) -> np.ndarray:
        """:meth:`thrust_matrix` of a checked configuration."""
        out = np.empty((self.nv, self.n_thrusters))
        # through the handle: the records cross as one pointer (14.5 -> 7.3 us per call, paper vehicle)
        self._fast_call(thrust_matrix_of, (self.handle, q, out))
        return out

    def frame(self, frame_id: int) -> tuple[int, np.ndarray, np.ndarray]:
        """``(body, rotation, translation)`` of a Pinocchio frame, for the kernels."""
        return self._frames[frame_index(frame_id, len(self._frames))]

    @project_errors("FastModel.frame_positions")
    def frame_positions(self, configurations_, frame_id: int) -> np.ndarray:
        """World positions [m] (n, 3) of a Pinocchio frame in each of ``configurations`` (n, nq)."""
        body, _, translation = self.frame(frame_id)
        states = configurations(configurations_, self.nq)
        out = np.empty((states.shape[0], 3))
        if body < 0:  # a frame on the world: it does not move
            out[:] = translation
            return out
        kernels.frame_positions(self.model, states, body, translation, self.workspace, out)
        return out

    def frame_motion(self, q, v, frame_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World rotation, world position and twist in its own axes of a Pinocchio frame."""
        q = configuration(q, self.nq)
        v = float_array(v, "v", (self.nv,))
        return self.frame_motion_unchecked(q, v, frame_index(frame_id, len(self._frames)))

    @project_errors("FastModel.frame_motion")
    def frame_motion_unchecked(self, q, v, frame_id: int):
        """:meth:`frame_motion` of checked arguments."""
        body, rotation, translation = self.frame(frame_id)
        if body < 0:
            return rotation.copy(), translation.copy(), np.zeros(6)
        return kernels.frame_kinematics(
            self.model, q, v, body, rotation, translation, self.workspace
        )

    def step(
        self,
        q,
        v,
        tau,
        dt: float,
        *,
        method="rk4",
        current=None,
        servo=None,
        t=0.0,
        disturbance=None,
    ):
        """One integrator step from time ``t``; returns new ``(q, v)`` (as
        :mod:`aiauv_pin.reference.integrators`).

        Raises:
            ArgumentError: A bad argument (see the module docstring), before anything runs.
            NumericalError: The step gave a non-finite state (``dt`` too large for the
                vehicle's dynamics, or a state that diverges).
        """
        # the fast path (benchmarks/entry_checks.py): a still-water step of 1-D float64 arrays,
        # their sizes, contiguity, finiteness and quaternion checked in the compiled call
        # (aiauv_pin.kernels.handle.checked_step_of); anything else goes to the checks below
        if (
            current is None
            and servo is None
            and disturbance is None
            and type(dt) is float
            and 0.0 < dt < _INFINITY
            and (type(t) is float or (type(t) is int and -MAX_EXACT_INT <= t <= MAX_EXACT_INT))
        ):
            code = METHOD_CODES.get(method) if type(method) is str else None
            if code is not None and _float64_vectors(q, v, tau):
                local = self._local
                handle, entry, q_unit = local.handle, self._checked_step_entry, local.q_unit
                q_out, v_out = np.empty(self.nq), np.empty(self.nv)
                t = float(t)
                if handle is None or entry is None or q_unit is None:  # first call, this thread
                    if _plain(q, self.nq) and _plain(v, self.nv) and _plain(tau, self.nv):
                        args = (
                            self.handle,
                            t,
                            q,
                            v,
                            tau,
                            dt,
                            code,
                            self._scratch_q(),
                            q_out,
                            v_out,
                        )
                        verdict = self._fast_call(checked_step_of, args)
                        self._checked_step_entry = self._entries[checked_step_of]
                        if verdict == STATE_OK:
                            return q_out, v_out
                else:
                    try:
                        verdict = entry(handle, t, q, v, tau, dt, code, q_unit, q_out, v_out)
                    except TypeError:  # an object that only looks like an array
                        verdict = -1
                    if verdict == STATE_OK:
                        return q_out, v_out
        method = method_name(method, METHOD_CODES)
        q = configuration(q, self.nq)
        v = float_array(v, "v", (self.nv,))
        tau = float_array(tau, "tau", (self.nv,))
        dt = positive_seconds(dt, "dt")
        t = finite_time(t)
        env = self.environment(current, disturbance)
        return self._step_unchecked(
            q, v, tau, dt, METHOD_CODES[method], env, self.servo_record(servo), t
        )

    @project_errors("FastModel.step")
    def _step_unchecked(self, q, v, tau, dt, code, env, servo, t):
        """One step with checked arguments; a non-finite result is a :class:`NumericalError`."""
        q_out, v_out = self._step_into_new(q, v, tau, dt, code, env, servo, t)
        if not (np.isfinite(q_out).all() and np.isfinite(v_out).all()):
            raise NumericalError(
                f"FastModel.step: the step gave a non-finite state at t = {float(t):g} s with "
                f"dt = {float(dt):g} s: take a smaller step"
            )
        return q_out, v_out

    def _step_into_new(self, q, v, tau, dt, code, env, servo, t):
        """The step into new arrays ``(q_out, v_out)``, unchecked."""
        q_out = np.empty(self.nq)
        v_out = np.empty(self.nv)
        if self._fixed_types(env, servo):
            self._fast_call(
                step_of,
                (self.handle, env, servo, float(t), q, v, tau, float(dt), code, q_out, v_out),
            )
        else:
            kernels.step_into(
                self.model,
                env,
                servo,
                float(t),
                q,
                v,
                tau,
                float(dt),
                code,
                self.workspace,
                q_out,
                v_out,
            )
        return q_out, v_out

    def run(
        self,
        q,
        v,
        tau,
        dt: float,
        n_steps: int,
        *,
        method="rk4",
        current=None,
        servo=None,
        t0=0.0,
        disturbance=None,
    ):
        """Advance ``q, v`` in place (writeable C-contiguous float64 arrays of shapes ``(nq,)`` and
        ``(nv,)``, a unit base quaternion); returns the number of finite steps.

        Raises:
            ArgumentError: A bad argument (see the module docstring), before anything runs.
        """
        q = in_place_array(q, "q", (self.nq,))
        unit_quaternion(q)
        v = in_place_array(v, "v", (self.nv,))
        tau = float_array(tau, "tau", (self.nv,))
        method = method_name(method, METHOD_CODES)
        dt = positive_seconds(dt, "dt")
        n_steps = step_count(n_steps, largest=MAX_RUN_STEPS)
        t0 = finite_time(t0)
        return self.run_unchecked(
            q,
            v,
            tau,
            dt,
            n_steps,
            method=method,
            current=current,
            servo=self.servo_record(servo),
            t0=t0,
            disturbance=disturbance,
        )

    @project_errors("FastModel.run")
    def run_unchecked(
        self,
        q,
        v,
        tau,
        dt: float,
        n_steps: int,
        *,
        method="rk4",
        current=None,
        servo=None,
        t0=0.0,
        disturbance=None,
    ):
        """:meth:`run` for a caller that owns and checked ``q, v, tau`` (C-contiguous float64 of
        the model's sizes; ``tau`` may be non-finite: the run then stops at once), ``method``,
        ``dt`` and ``n_steps`` (:func:`aiauv_pin.simulate`); the current, disturbance and servo
        are checked here."""
        return kernels.run_steps(
            self.model,
            self.environment(current, disturbance),
            self.servo_record(servo),
            float(t0),
            q,
            v,
            tau,
            float(dt),
            int(n_steps),
            METHOD_CODES[method],
            self.workspace,
        )
