"""Compiled evaluation of one vehicle from Python: thin wrappers around
:mod:`aiauv_pin.kernels.articulated_body`.

:class:`FastModel` holds the vehicle's packed records (:meth:`aiauv_pin.Vehicle.packed_model`),
one reusable workspace and the default environment (still water, no disturbance), and checks the
shapes of what it passes to compiled code.
"""

from __future__ import annotations

import numba  # noqa: F401  (the compiled backend needs numba: ImportError here means fall back)
import numpy as np

from aiauv_hydro.currents import Current, as_current
from aiauv_pin.errors import ArgumentError
from aiauv_pin.kernels import articulated_body as kernels
from aiauv_pin.kernels.disturbances import Disturbance
from aiauv_pin.kernels.handle import (
    STATE_OK,
    acceleration_of,
    checked_acceleration_of,
    new_handle,
    step_of,
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
    compiled disturbance (``None``: none)."""
    water: Current = as_current(current)
    push = Disturbance.none() if disturbance is None else disturbance
    return Environment(
        water.user_function,
        water.kind_code,
        water.parameters,
        push.user_function,
        push.kind_code,
        push.parameters,
    )


_FLOAT64 = np.dtype(np.float64)


def _plain(array, size: int) -> bool:
    """Whether ``array`` is a float64 vector of ``size`` that compiled code may take as it is."""
    return (
        type(array) is np.ndarray
        and array.dtype is _FLOAT64
        and array.shape == (size,)
        and array.flags.carray
    )


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


class FastModel:
    """A vehicle's equations of motion evaluated by the compiled kernels.

    Args:
        vehicle: The vehicle (its ``added_mass``, ``damping`` and ``restoring`` switches are
            honoured; they are read once, here).

    Raises:
        ValueError: The model is not supported (see :func:`aiauv_pin.kernels.records.unsupported_reason`).
    """

    def __init__(self, vehicle) -> None:
        self.model = vehicle.packed_model()
        self.nq, self.nv = vehicle.nq, vehicle.nv
        self.n_bodies = self.model.bodies.parent.shape[0]
        self.workspace = kernels.new_workspace(self.model, self.nq, self.nv)
        self.still_water = environment()
        self.no_servo = no_servo()
        self._frames: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
        self._entries: dict = {}
        self._handle = None
        self._pin_model = vehicle.model

    def environment(self, current=None, disturbance=None) -> Environment:
        """The environment record (the cached still-water one when both are ``None``)."""
        if current is None and disturbance is None:
            return self.still_water
        return environment(current, disturbance)

    def _state(self, q, v) -> tuple[np.ndarray, np.ndarray]:
        q, v = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(v, dtype=float)
        if q.shape != (self.nq,) or v.shape != (self.nv,):
            raise ArgumentError(
                f"q and v must have shapes ({self.nq},) and ({self.nv},), got {q.shape} and {v.shape}"
            )
        return q, v

    def _generalized(self, tau) -> np.ndarray:
        tau = np.ascontiguousarray(tau, dtype=float)
        if tau.shape != (self.nv,):
            raise ArgumentError(f"tau must have shape ({self.nv},), got {tau.shape}")
        return tau

    def _fixed_types(self, env, servo) -> bool:
        """Whether ``env`` and ``servo`` are of the kinds whose numba types never change for this
        model (built-in current and disturbance, no servo): then :meth:`_fast_call` applies."""
        return (
            servo is self.no_servo
            and env.current_function is None
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
        """Picklable state: the handle and the entry points are process-local, made again on use."""
        state = self.__dict__.copy()
        state["_handle"], state["_entries"] = None, {}
        return state

    @property
    def handle(self):
        """The :class:`aiauv_pin.kernels.handle.Handle` of this model's records (made on first use)."""
        if self._handle is None:
            self._handle = new_handle(self.model, self.workspace, self.still_water, self.no_servo)
        return self._handle

    def acceleration(
        self, q, v, tau, current=None, *, t: float = 0.0, servo=None, disturbance=None
    ):
        """``dv`` (nv,), as :meth:`aiauv_pin.Vehicle.acceleration` (plus an optional servo record)."""
        out = np.empty(self.nv)
        q, v = self._state(q, v)
        tau = self._generalized(tau)
        env = self.environment(current, disturbance)
        servo = self.no_servo if servo is None else servo
        if self._fixed_types(env, servo):
            self._fast_call(acceleration_of, (self.handle, env, servo, float(t), q, v, tau, out))
        else:
            kernels.acceleration_into(
                self.model, env, servo, float(t), q, v, tau, self.workspace, out, 0.0
            )
        return out

    def checked_acceleration(
        self, q, v, tau, t, tolerance: float, exact_below: float
    ) -> np.ndarray | None:
        """``dv`` in still water, the state checked in the same compiled call, or ``None``.

        The fast path of :meth:`aiauv_pin.Vehicle.acceleration`: only plain arrays (float64,
        C-contiguous, aligned, writeable, of the right shapes) and a float or integer ``t`` take
        it. ``None`` means "not taken": the arguments were of another kind or the compiled check
        (:func:`aiauv_pin.kernels.handle.state_verdict`) refused them, and the caller's own checks
        then name the problem.
        """
        nq, nv = self.nq, self.nv
        if not (_plain(q, nq) and _plain(v, nv) and _plain(tau, nv) and type(t) in (float, int)):
            return None
        out = np.empty(nv)
        verdict = self._fast_call(
            checked_acceleration_of,
            (self.handle, float(t), q, v, tau, tolerance, exact_below, out),
        )
        return out if verdict == STATE_OK else None

    def restoring_forces(self, q) -> np.ndarray:
        """``g(q)`` (nv,) on the left-hand side, as :meth:`aiauv_pin.Vehicle.restoring_forces`."""
        out = np.empty(self.nv)
        kernels.restoring_forces(
            self.model, np.ascontiguousarray(q, dtype=float), self.workspace, out
        )
        return out

    def thrust_matrix(self, q) -> np.ndarray:
        """``B(q)`` (nv x m), as :meth:`aiauv_pin.Vehicle.thrust_matrix`."""
        out = np.empty((self.nv, self.model.thrusters.body.shape[0]))
        kernels.thrust_matrix(self.model, np.ascontiguousarray(q, dtype=float), self.workspace, out)
        return out

    def frame(self, frame_id: int) -> tuple[int, np.ndarray, np.ndarray]:
        """``(body, rotation, translation)`` of a Pinocchio frame, for the kernels."""
        if frame_id not in self._frames:
            frame = self._pin_model.frames[frame_id]
            self._frames[frame_id] = (
                int(frame.parentJoint) - 1,
                np.ascontiguousarray(frame.placement.rotation),
                np.ascontiguousarray(frame.placement.translation),
            )
        return self._frames[frame_id]

    def frame_positions(self, configurations, frame_id: int) -> np.ndarray:
        """World positions [m] (n, 3) of a Pinocchio frame in each of ``configurations`` (n, nq)."""
        body, _, translation = self.frame(frame_id)
        configurations = np.ascontiguousarray(configurations, dtype=float)
        if configurations.ndim != 2 or configurations.shape[1] != self.nq:
            raise ArgumentError(
                f"configurations must have shape (n, {self.nq}), got {configurations.shape}"
            )
        out = np.empty((configurations.shape[0], 3))
        kernels.frame_positions(self.model, configurations, body, translation, self.workspace, out)
        return out

    def frame_motion(self, q, v, frame_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World rotation, world position and twist in its own axes of a Pinocchio frame."""
        body, rotation, translation = self.frame(frame_id)
        q, v = self._state(q, v)
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
        :mod:`aiauv_pin.dynamics.integrators`)."""
        q_out = np.empty(self.nq)
        v_out = np.empty(self.nv)
        q, v = self._state(q, v)
        tau = self._generalized(tau)
        env = self.environment(current, disturbance)
        servo = self.no_servo if servo is None else servo
        code = METHOD_CODES[method]
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
        """Advance contiguous float arrays ``q, v`` in place; returns the number of finite steps."""
        return kernels.run_steps(
            self.model,
            self.environment(current, disturbance),
            self.no_servo if servo is None else servo,
            float(t0),
            q,
            v,
            np.ascontiguousarray(tau, dtype=float),
            float(dt),
            int(n_steps),
            METHOD_CODES[method],
            self.workspace,
        )
