"""Checks of the arrays passed to :class:`aiauv_pin.Vehicle` and :func:`aiauv_pin.simulate`.

Every public method of :class:`~aiauv_pin.Vehicle` runs its arguments through these checks before
they reach Pinocchio or a compiled kernel (which would read past the end of a short array), so both
backends give the same verdict on the same call. A bad argument raises
:class:`aiauv_pin.errors.ArgumentError` (a ``ValueError``) with one line naming the argument and the
expected shape:

* numbers only (bool, integer or float arrays; no strings, objects or complex numbers);
* exactly the expected shape (``q``: ``(nq,)``, ``v`` and ``tau``: ``(nv,)``, ``current``: ``(3,)``);
* finite values;
* the base quaternion of ``q`` of unit norm within :data:`QUATERNION_TOLERANCE`; within it, it is
  normalised (on a copy); a zero, far-from-unit or non-finite quaternion is refused.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from aiauv_pin.errors import ArgumentError

#: Largest accepted ``| |quaternion| - 1 |`` of the base orientation in ``q``; smaller deviations
#: (round-off of an integrator, a hand-typed ``0.7071``) are normalised away.
QUATERNION_TOLERANCE = 1e-6
#: Deviations below this are left as is (bit-identical results for unit quaternions).
EXACT_QUATERNION_DEVIATION = 1e-14


def float_array(value, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a contiguous float64 array of ``shape`` with finite entries.

    Raises:
        ArgumentError: Not numbers, wrong shape or not finite (one line naming ``name``).
    """
    if (
        type(value) is np.ndarray
        and value.dtype == np.float64
        and value.shape == shape
        and value.flags.c_contiguous
    ):
        array = value
    else:
        try:
            array = np.asarray(value)
        except (TypeError, ValueError) as exc:
            raise ArgumentError(
                f"{name} must be an array of numbers of shape {shape} ({exc.__class__.__name__})"
            ) from None
        if array.dtype.kind not in "biuf":
            raise ArgumentError(
                f"{name} must be an array of real numbers of shape {shape}, got dtype "
                f"{array.dtype.name}"
            )
        if array.shape != shape:
            raise ArgumentError(f"{name} must have shape {shape}, got {array.shape}")
        array = np.ascontiguousarray(array, dtype=np.float64)
    if not np.isfinite(array).all():  # the method: np.all's dispatch costs more than the test
        raise ArgumentError(f"{name} must be finite (shape {shape}), got NaN or infinity")
    return array


def configuration(value, nq: int, name: str = "q") -> np.ndarray:
    """A configuration ``(position, quaternion (x, y, z, w), joints)`` of size ``nq``.

    The quaternion is normalised when within :data:`QUATERNION_TOLERANCE` of unit norm.

    Raises:
        ArgumentError: See the module docstring.
    """
    q = float_array(value, name, (nq,))
    norm = math.sqrt(float(q[3] ** 2 + q[4] ** 2 + q[5] ** 2 + q[6] ** 2))
    deviation = abs(norm - 1.0)
    if deviation > QUATERNION_TOLERANCE:
        raise ArgumentError(
            f"{name}[3:7] (base quaternion x, y, z, w) must have unit norm (within "
            f"{QUATERNION_TOLERANCE:g}), got norm {norm:.6g}"
        )
    if deviation > EXACT_QUATERNION_DEVIATION:
        q = q.copy()
        q[3:7] /= norm
    return q


def optional_current(value):
    """``None``, a :class:`aiauv_hydro.currents.Current`, or a finite (3,) water velocity [m/s]."""
    from aiauv_hydro.currents import Current

    if value is None or isinstance(value, Current):
        return value
    return float_array(value, "current", (3,))


def finite_time(value) -> float:
    """A finite time [s] (a real number)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ArgumentError(f"t: expected a number of seconds, got {type(value).__name__}")
    if not math.isfinite(float(value)):
        raise ArgumentError(f"t: expected a finite time, got {value}")
    return float(value)


def positive_seconds(value, name: str, *, allow_infinity: bool = False) -> float:
    """A finite number > 0 (not a bool); ``inf`` too with ``allow_infinity``.

    Raises:
        ArgumentError: One line.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ArgumentError(f"{name} must be a positive number of seconds, got {value!r:.40}")
    value = float(value)
    if not ((math.isfinite(value) or (allow_infinity and value == math.inf)) and value > 0.0):
        raise ArgumentError(f"{name} must be a positive number of seconds, got {value!r}")
    return value


#: Most steps of one run: beyond it a step count is no longer exact in floating point.
MAX_STEPS = 2**53
#: Largest relative mismatch between ``duration`` and a whole number of steps ``dt``.
STEP_TOLERANCE = 1e-6


def check_timing(duration, dt) -> int:
    """Number of steps of a fixed-step run; ``duration`` and ``dt`` must be consistent.

    ``dt`` must not exceed ``duration``, and ``duration`` must be a whole number of steps within
    :data:`STEP_TOLERANCE` of a step (``simulate(duration=0.5, dt=10)`` would otherwise run 10 s and
    ``duration=1, dt=0.3`` 0.9 s).

    Raises:
        ArgumentError: One line.
    """
    duration = positive_seconds(duration, "duration")
    dt = positive_seconds(dt, "dt")
    if dt > duration * (1.0 + STEP_TOLERANCE):
        raise ArgumentError(f"dt = {dt:g} s must not exceed the duration = {duration:g} s")
    ratio = duration / dt
    if not ratio <= MAX_STEPS:  # also inf (duration = 1e308): round() would overflow
        raise ArgumentError(
            f"duration / dt = {ratio:.3g} steps is more than {MAX_STEPS:.3g}; use a larger dt "
            "or a shorter duration"
        )
    steps = round(ratio)
    if abs(steps * dt - duration) > STEP_TOLERANCE * dt:
        raise ArgumentError(
            f"duration = {duration:g} s is not a whole number of steps dt = {dt:g} s "
            f"({duration / dt:.6g} steps)"
        )
    return max(1, steps)
