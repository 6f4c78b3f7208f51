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

The compiled entry points (:class:`aiauv_pin.kernels.evaluation.FastModel`, the derivatives, transition
Jacobians and linear models, :func:`aiauv_pin.rollout`) take their arguments through the same
functions, one per kind of argument: :func:`float_array` (any array of numbers),
:func:`configuration` (``q``), :func:`in_place_array` (an array compiled code advances in place:
no copy is possible, so it must already be a C-contiguous, writeable float64 array),
:func:`positive_seconds` (``dt``), :func:`step_count`, :func:`method_name`, :func:`frame_index`,
:func:`optional_current` (a velocity or a checked :class:`aiauv_hydro.currents.Current`); the
records a controller gives the compiled loop are checked by
:func:`aiauv_pin.controllers.compiled_controller.check_compiled_controller`. The hottest calls
(``acceleration`` and ``step`` in still water) check their state inside the compiled call instead
(:func:`aiauv_pin.kernels.handle.state_verdict`), which costs far less than these Python checks
(``benchmarks/entry_checks.py``).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from aiauv_hydro.numerics.jit import interpreted
from aiauv_hydro.numerics.spatial import (
    QUATERNION_NORMALISE,
    QUATERNION_NOT_UNIT,
    unit_quaternion_check,
)
from aiauv_pin.errors import ArgumentError, RecordSizeError

#: The unit-quaternion rule, run interpreted (cheaper than a compiled call from Python here).
_unit_quaternion_check = interpreted(unit_quaternion_check)

#: Largest accepted ``| |quaternion| - 1 |`` of the base orientation in ``q``; smaller deviations
#: (round-off of an integrator, a hand-typed ``0.7071``) are normalised away.
QUATERNION_TOLERANCE = 1e-6
#: Deviations below this are left as is (bit-identical results for unit quaternions).
EXACT_QUATERNION_DEVIATION = 1e-14


#: Up to this many entries, :func:`_all_finite` tests in Python (a list and ``math.isfinite``),
#: which costs less than a NumPy ufunc call on a small array; above it, ``np.isfinite``.
SMALL_ARRAY = 64


def _all_finite(array: np.ndarray) -> bool:
    """Whether every entry of a float array is finite."""
    if array.ndim == 1 and array.shape[0] <= SMALL_ARRAY:
        return all(map(math.isfinite, array.tolist()))
    return bool(np.isfinite(array).all())  # the method: np.all's dispatch costs more


def _numbers(value, name: str, shape: str) -> np.ndarray:
    """``np.asarray(value)``, or a one-line error naming ``name`` and the expected ``shape``."""
    try:
        return np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(
            f"{name} must be an array of numbers of shape {shape} ({exc.__class__.__name__})"
        ) from None


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
        array = _numbers(value, name, str(shape))
        if array.dtype.kind not in "biuf":
            raise ArgumentError(
                f"{name} must be an array of real numbers of shape {shape}, got dtype "
                f"{array.dtype.name}"
            )
        if array.shape != shape:
            raise ArgumentError(f"{name} must have shape {shape}, got {array.shape}")
        array = np.ascontiguousarray(array, dtype=np.float64)
    if not _all_finite(array):
        raise ArgumentError(f"{name} must be finite (shape {shape}), got NaN or infinity")
    return array


def configuration(value, nq: int, name: str = "q") -> np.ndarray:
    """A configuration ``(position, quaternion (x, y, z, w), joints)`` of size ``nq``.

    The quaternion is normalised when within :data:`QUATERNION_TOLERANCE` of unit norm.

    Raises:
        ArgumentError: See the module docstring.
    """
    q = float_array(value, name, (nq,))
    verdict, norm = _quaternion_verdict(q, name)
    if verdict == QUATERNION_NORMALISE:
        q = q.copy()
        q[3:7] /= norm
    return q


def in_place_array(value, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` itself, which compiled code will overwrite: a C-contiguous, aligned, writeable
    float64 array of ``shape`` with finite entries (a copy would leave the caller's array as it
    was, so nothing is converted).

    Raises:
        ArgumentError: One line naming ``name`` and what it must be.
    """
    if not (
        type(value) is np.ndarray
        and value.dtype == np.float64
        and value.shape == shape
        and value.flags.carray
        and value.flags.writeable
    ):
        got = (
            f"{value.dtype.name} array of shape {value.shape}"
            + ("" if value.flags.carray else ", not C-contiguous")
            + ("" if value.flags.writeable else ", read-only")
            if isinstance(value, np.ndarray)
            else type(value).__name__
        )
        raise ArgumentError(
            f"{name} is advanced in place: it must be a writeable C-contiguous float64 array of "
            f"shape {shape}, got {got}"
        )
    if not _all_finite(value):
        raise ArgumentError(f"{name} must be finite (shape {shape}), got NaN or infinity")
    return value


def _quaternion_verdict(q: np.ndarray, name: str) -> tuple[int, float]:
    """``(verdict, norm)`` of a finite configuration's base quaternion ``q[3:7]`` by
    :func:`aiauv_hydro.numerics.spatial.unit_quaternion_check` (the rule the compiled checks apply
    too), with :data:`QUATERNION_TOLERANCE` and :data:`EXACT_QUATERNION_DEVIATION`.

    Raises:
        ArgumentError: Beyond :data:`QUATERNION_TOLERANCE`.
    """
    x, y, z, w = q[3:7].tolist()
    verdict, norm = _unit_quaternion_check(
        x, y, z, w, QUATERNION_TOLERANCE, EXACT_QUATERNION_DEVIATION
    )
    if verdict == QUATERNION_NOT_UNIT:
        raise ArgumentError(
            f"{name}[3:7] (base quaternion x, y, z, w) must have unit norm (within "
            f"{QUATERNION_TOLERANCE:g}), got norm {norm:.6g}"
        )
    return verdict, norm


def unit_quaternion(q: np.ndarray, name: str = "q") -> int:
    """Refuse a finite configuration whose base quaternion ``q[3:7]`` is not of unit norm within
    :data:`QUATERNION_TOLERANCE`; return the verdict of
    :func:`aiauv_hydro.numerics.spatial.unit_quaternion_check` (unit, or to be normalised).

    Raises:
        ArgumentError: Beyond :data:`QUATERNION_TOLERANCE`.
    """
    return _quaternion_verdict(q, name)[0]


def configurations(value, nq: int, name: str = "configurations") -> np.ndarray:
    """Configurations ``(n, nq)`` (each as :func:`configuration`, normalised on a copy)."""
    array = _numbers(value, name, f"(n, {nq})")
    if array.ndim != 2 or array.shape[1] != nq:
        raise ArgumentError(f"{name} must have shape (n, {nq}), got {array.shape}")
    array = float_array(array, name, array.shape)
    rows = [configuration(row, nq, f"{name}[{i}]") for i, row in enumerate(array)]
    return np.ascontiguousarray(rows).reshape(array.shape)


def step_count(value, name: str = "n_steps", *, largest: int = 2**53) -> int:
    """A whole number of steps ``0 <= value <= largest`` (an int, not a bool or a float).

    Raises:
        ArgumentError: One line.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ArgumentError(f"{name} must be a whole number, got {value!r:.40}")
    if not 0 <= int(value) <= largest:
        raise ArgumentError(f"{name} must be in [0, {largest}], got {int(value)}")
    return int(value)


def method_name(value, methods) -> str:
    """One of the integration ``methods`` (names).

    Raises:
        ArgumentError: Another value.
    """
    if not isinstance(value, str) or value not in methods:
        raise ArgumentError(f"unknown method {value!r:.40} (expected one of {', '.join(methods)})")
    return value


def frame_index(value, n_frames: int) -> int:
    """A Pinocchio frame index in ``[0, n_frames)``.

    Raises:
        ArgumentError: Not an integer, or out of range.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ArgumentError(f"frame_id must be a frame index (int), got {value!r:.40}")
    if not 0 <= int(value) < n_frames:
        raise ArgumentError(f"frame_id must be in [0, {n_frames}), got {int(value)}")
    return int(value)


def optional_current(value):
    """``None``, a checked :class:`aiauv_hydro.currents.Current` (:meth:`aiauv_hydro.currents.Current.check`:
    enough finite parameters for its function), or a finite (3,) water velocity [m/s].

    Raises:
        ArgumentError: One line naming the current's problem.
    """
    from aiauv_hydro.currents import Current
    from aiauv_hydro.spec import HydroError

    if value is None:
        return value
    if isinstance(value, Current):
        try:
            value.check()
        except HydroError as exc:
            raise RecordSizeError(str(exc)) from None
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
