"""Exceptions raised by aiauv-pin; every message is a single line that names the problem."""

from __future__ import annotations


class AiauvError(Exception):
    """Base class of the errors the command line reports as one line with a non-zero exit."""


class VehicleLoadError(AiauvError, ValueError):
    """A vehicle description that cannot be loaded (missing file, broken URDF, bad parameters)."""


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


class InputLimitError(VehicleLoadError):
    """An input file beyond the documented limits of :mod:`aiauv_pin.description.input_limits`."""


class UnsafeNameError(VehicleLoadError):
    """A link, joint, thruster or robot name outside the safe set of
    :mod:`aiauv_pin.description.safe_names`."""


class PhysicalParameterError(VehicleLoadError):
    """A non-physical or implausible vehicle parameter (:mod:`aiauv_pin.model.validation`)."""
