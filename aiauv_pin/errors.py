"""Exceptions raised by aiauv-pin; every message is a single line that names the problem.

One hierarchy: everything the API raises on bad input or a failed run is an :class:`AiauvError`
(the command line reports it as one line with a non-zero exit)::

    AiauvError
    |-- VehicleLoadError (ValueError)        a vehicle description that cannot be loaded
    |   |-- PhysicalParameterError           a non-physical or implausible parameter
    |   |-- InputLimitError                  a file beyond the input limits
    |   |-- UnsafeNameError                  a name outside the safe set
    |   `-- UrdfStructureError               (aiauv_pin.description.urdf_validation) a URDF breaking the spec
    |-- ArgumentError (ValueError)           a bad argument to an API call
    |   `-- RecordSizeError                  a record (controller info row, current parameters)
    |                                        smaller than what compiled code reads or writes
    |-- NumericalError (ArithmeticError)     a computation that failed at valid arguments
    |                                        (a singular matrix, an overflow)
    `-- SimulationDiverged (RuntimeError)    the state of a run became non-finite

    LenientRepairWarning (UserWarning)       a repair made by a lenient load (not an error)

Exceptions of other libraries never cross the API: where the API calls compiled code or Pinocchio,
:func:`project_errors` turns numba's ``TypingError``, ``OverflowError``, NumPy's ``LinAlgError``,
``KeyError`` and Boost.Python's ``ArgumentError`` (Pinocchio's bindings given a wrong type) into
the project errors above, with a one-line message naming the call (:func:`as_project_error`).
"""

from __future__ import annotations

import functools


class AiauvError(Exception):
    """Base class of the errors the command line reports as one line with a non-zero exit."""


class VehicleLoadError(AiauvError, ValueError):
    """A vehicle description that cannot be loaded (missing file, broken URDF, bad parameters)."""


class InteropError(VehicleLoadError):
    """A model of another simulator (SDF, MJCF) that cannot be read, imported or exported; the
    message is one line naming the problem. A :class:`VehicleLoadError`, since ``load_vehicle``
    reads SDF files too."""


class SimulationDiverged(AiauvError, RuntimeError):
    """The state became non-finite; ``trajectory`` holds everything computed before that.

    Attributes:
        time: Simulation time at which the state stopped being finite [s].
        trajectory: The partial trajectory up to the last finite state.
    """

    def __init__(self, message: str, time: float, trajectory=None):
        super().__init__(message)
        self.time = time
        self.trajectory = trajectory


class ArgumentError(AiauvError, ValueError):
    """A bad argument to an API call (wrong shape, type, non-finite value); one line naming it."""


class RecordSizeError(ArgumentError):
    """A record given to compiled code smaller than what the code reads or writes: a controller
    writing past its declared ``info_shapes`` (or any of its arrays), a current with too few
    parameters."""


class NumericalError(AiauvError, ArithmeticError):
    """A computation that failed at arguments that passed the checks (a singular matrix, an
    overflow to infinity); one line naming the call."""


class InputLimitError(VehicleLoadError):
    """An input file beyond the documented limits of :mod:`aiauv_pin.description.input_limits`."""


class UnsafeNameError(VehicleLoadError):
    """A link, joint, thruster or robot name outside the safe set of
    :mod:`aiauv_pin.description.safe_names`."""


class PhysicalParameterError(VehicleLoadError):
    """A non-physical or implausible vehicle parameter (:mod:`aiauv_pin.model.validation`)."""


class LenientRepairWarning(UserWarning):
    """A repair made by a lenient load (``load_vehicle(..., lenient=True)``, ``--lenient``) of data
    the validation gate refuses; one line naming whose data is wrong (the source file or our
    annotation) and the repair (:mod:`aiauv_pin.model.lenient_repairs`)."""


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    line = text[0] if text else ""
    if isinstance(exc, KeyError) and len(exc.args) == 1:
        line = f"unknown key {exc.args[0]!r:.60}"
    return f"{line[:200]} ({type(exc).__name__})" if line else type(exc).__name__


def _is_foreign_argument_error(exc: BaseException) -> bool:
    """Boost.Python's ``ArgumentError`` (a ``TypeError`` from Pinocchio's bindings given a wrong
    type) or numba's ``TypingError`` (a compiled function given a wrong type)."""
    kind = type(exc)
    return (kind.__module__ == "Boost.Python" and kind.__name__ == "ArgumentError") or (
        kind.__name__ == "TypingError" and kind.__module__.startswith("numba")
    )


def as_project_error(
    exc: BaseException, where: str, *, bounds_checked: bool = False
) -> AiauvError | None:
    """The project error for a foreign exception raised inside ``where`` (an API call's name), or
    ``None`` when ``exc`` is not one that :func:`project_errors` converts.

    ``KeyError``, numba's ``TypingError`` and Boost.Python's ``ArgumentError`` become
    :class:`ArgumentError`; ``OverflowError``, NumPy's ``LinAlgError`` and ``FloatingPointError``
    become :class:`NumericalError`; with ``bounds_checked`` (``where`` runs a bounds-checked
    compiled controller, :mod:`aiauv_pin.controllers.compiled_controller`) an ``IndexError`` becomes
    :class:`RecordSizeError`.
    """
    if isinstance(exc, AiauvError):
        return None
    kind = type(exc)
    if isinstance(exc, KeyError) or _is_foreign_argument_error(exc):
        return ArgumentError(f"{where}: bad argument: {_first_line(exc)}")
    if isinstance(exc, (OverflowError, FloatingPointError)) or kind.__name__ == "LinAlgError":
        return NumericalError(f"{where}: numerical failure: {_first_line(exc)}")
    if bounds_checked and isinstance(exc, IndexError):
        return RecordSizeError(
            f"{where}: compiled code indexed an array out of bounds (a controller writing past "
            f"its declared info_shapes, state or parameters?): {_first_line(exc)}"
        )
    return None


def project_errors(where: str):
    """Decorator: the function's foreign exceptions leave it as project errors
    (:func:`as_project_error`); everything else passes unchanged.

    Args:
        where: The API call named in the messages (e.g. ``"Vehicle.mass_matrix"``).
    """

    def decorate(function):
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            try:
                return function(*args, **kwargs)
            except Exception as exc:
                converted = as_project_error(exc, where)
                if converted is None:
                    raise
                raise converted from None

        return wrapper

    return decorate


class bounds_checked_call:
    """Context of a call into a compiled loop that runs a bounds-checked controller: its foreign
    exceptions leave as project errors (:func:`as_project_error` with ``bounds_checked``)."""

    def __init__(self, where: str) -> None:
        self.where = where

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind, exc, traceback) -> bool:
        if exc is None or not isinstance(exc, Exception):
            return False
        converted = as_project_error(exc, self.where, bounds_checked=True)
        if converted is None:
            return False
        raise converted from None
