"""The physics of N environments: their states, advanced together in compiled code on threads.

:class:`VehicleBatch` holds the states of N copies of one vehicle (``q`` (N, nq), ``v`` (N, nv))
and advances the rows it is given by one environment step each: ``substeps`` integrator steps of
``dt`` with the row's controls held, in one compiled call per thread
(:func:`aiauv_pin.kernels.articulated_body.run_rows` through
:func:`aiauv_pin.kernels.handle.run_rows_of`, compiled ``nogil``), as
:func:`aiauv_pin.rollout` runs its runs: the threads run on every core at once and only the
unboxing of the arguments holds the GIL. Every thread has its own workspace, environment record
and servo record, so a row's result does not depend on the thread count or on the other rows (a
test checks it bit for bit).
"""

from __future__ import annotations

import itertools
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from aiauv_hydro.currents import Current
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.errors import ArgumentError

#: Fewest rows per thread: below it the thread hand-off costs more than the physics it spreads.
ROWS_PER_THREAD = 4


def usable_cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


class VehicleBatch:
    """N states of one vehicle, stepped together (see the module docstring).

    Args:
        vehicle: The vehicle (its compiled backend is required).
        n_rows: N, the number of environments (>= 1).
        dt: Integration step [s].
        substeps: Integration steps per environment step (>= 1).
        method: ``"euler"`` (semi-implicit, the scenario's default), ``"rk4"`` or ``"midpoint"``.
        frame: The link or frame whose pose and twist each step reports (:attr:`rotation`,
            :attr:`position`, :attr:`twist`).
        servo_gains: ``(k_p [N m/rad], k_d [N m s/rad])`` of a joint servo with hydrostatic
            compensation (the paper's eq. (24)) tracking each row's joint references, or ``None``
            (no servo: the joints take torques only).
        threads: Threads (default: the usable cores, at most one per :data:`ROWS_PER_THREAD` rows).

    Attributes:
        q, v: The states (N, nq) and (N, nv) [m, rad; m/s, rad/s] (base position, base quaternion
            ``(x, y, z, w)``, joint angles; base twist in base axes, joint rates).
        t: Time of each row [s] (N,).
        controls: Each row's controls (N, m + 2 n_joints): thrusts [N] (one per thruster), joint
            torques [N m], joint references [rad] (read only with a servo).
        currents: Each row's constant current (N, 3) [m/s], world axes.
        rotation, position, twist: The frame's world rotation (N, 3, 3), world position (N, 3)
            [m] and own-axes twist ``(v, w)`` (N, 6) [m/s, rad/s], after the last step.
        centre: The vehicle's centre of mass (rigid masses) (N, 3) [m], world axes, after the
            last step.
        done: Integration steps each row completed in its last step (N,): fewer than
            ``substeps`` if its state became non-finite.
    """

    def __init__(
        self,
        vehicle,
        n_rows: int,
        *,
        dt: float,
        substeps: int,
        method: str,
        frame: str,
        servo_gains: tuple[float, float] | None,
        threads: int | None = None,
    ) -> None:
        from aiauv_pin.kernels.articulated_body import new_workspace
        from aiauv_pin.kernels.evaluation import METHOD_CODES, _entry_point
        from aiauv_pin.kernels.handle import new_handle, run_rows_of

        fast = vehicle.fast
        if fast is None:
            why = vehicle.fallback_reason or f"backend={vehicle.backend!r}"
            raise ArgumentError(
                f"the environments need the compiled backend (the vehicle runs on "
                f"{vehicle.active_backend}: {why})"
            )
        if isinstance(n_rows, bool) or not isinstance(n_rows, int) or n_rows < 1:
            raise ArgumentError(f"the number of environments must be >= 1, got {n_rows!r:.40}")
        if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
            raise ArgumentError(f"substeps must be a whole number >= 1, got {substeps!r:.40}")
        if method not in METHOD_CODES:
            raise ArgumentError(
                f"unknown method {method!r:.40} (expected one of euler, rk4, midpoint)"
            )
        if threads is None:
            threads = max(1, min(usable_cores(), n_rows // ROWS_PER_THREAD))
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ArgumentError(f"threads must be a whole number >= 1, got {threads!r:.40}")
        body, rotation, translation = fast.frame(vehicle.frame_id(frame))
        if body < 0:
            raise ArgumentError(f"frame {frame!r:.40} is fixed to the world, not to the vehicle")
        self.vehicle, self.fast, self.n_rows = vehicle, fast, n_rows
        self.dt, self.substeps, self.method = float(dt), substeps, method
        self.n_thrusters, self.n_joints = fast.n_thrusters, fast.nv - 6
        nq, nv, nj = fast.nq, fast.nv, fast.nv - 6
        self.q, self.v, self.t = np.zeros((n_rows, nq)), np.zeros((n_rows, nv)), np.zeros(n_rows)
        self.controls = np.zeros((n_rows, self.n_thrusters + 2 * nj))
        self.currents = np.zeros((n_rows, 3))
        self.rotation = np.zeros((n_rows, 3, 3))
        self.position, self.twist = np.zeros((n_rows, 3)), np.zeros((n_rows, 6))
        self.centre = np.zeros((n_rows, 3))
        self.done = np.zeros(n_rows, dtype=np.int64)
        self._frame = (int(body), np.ascontiguousarray(rotation), np.ascontiguousarray(translation))
        self._code = METHOD_CODES[method]
        bounds = np.linspace(0, n_rows, threads + 1).round().astype(int)
        self._chunks = []  # one per thread: its rows and the records it writes
        for first, stop in itertools.pairwise(bounds):
            servo = (
                fast.no_servo
                if servo_gains is None
                else JointServo.uniform(nj, servo_gains[0], servo_gains[1]).packed()
            )
            env = fast.environment(Current.constant(np.zeros(3)))
            handle = new_handle(  # the records cross into compiled code as one pointer
                fast.model, new_workspace(fast.model, nq, nv), fast.still_water, fast.no_servo
            )
            self._chunks.append((env, servo, handle, np.zeros(nv), int(first), int(stop)))
        self._pool = ThreadPoolExecutor(threads, "aiauv-envs") if threads > 1 else None
        self._kernel = run_rows_of
        self._entry = _entry_point(run_rows_of, self._arguments(self._chunks[0], 0))

    def _arguments(self, chunk, n_steps: int) -> tuple:
        env, servo, handle, tau, first, stop = chunk
        return (
            handle,
            env,
            servo,
            self.q,
            self.v,
            self.t,
            self.controls,
            self.currents,
            self.dt,
            n_steps,
            self._code,
            tau,
            self._frame,
            self.rotation,
            self.position,
            self.twist,
            self.centre,
            self.done,
            first,
            stop,
        )

    def _run(self, chunk, n_steps: int) -> None:
        try:
            self._entry(*self._arguments(chunk, n_steps))
        except TypeError:  # another layout than the one the entry point was taken for
            self._kernel(*self._arguments(chunk, n_steps))

    def advance(self, n_steps: int | None = None) -> None:
        """Advance every row by ``n_steps`` integration steps (default: :attr:`substeps`; 0
        evaluates the frame only), each with its controls and current, then the frame."""
        n_steps = self.substeps if n_steps is None else n_steps
        if self._pool is None:
            for chunk in self._chunks:
                self._run(chunk, n_steps)
        else:
            for future in [self._pool.submit(self._run, c, n_steps) for c in self._chunks]:
                future.result()
        self.t += self.done * self.dt

    def close(self) -> None:
        """Stop the threads (the batch can no longer step)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
