"""Compiled (numba) evaluation of a vehicle's dynamics and fixed-step integration.

The Pinocchio path of :class:`aiauv_pin.Vehicle` stays the reference: every kernel here is
tested against it (tests/test_fast.py). The kernels cover a free-flyer root with 1-DOF revolute or
prismatic joints, which is every vehicle :func:`aiauv_pin.load_vehicle` accepts except URDFs with
other joint types; those, and machines without numba, fall back to Pinocchio.

:mod:`aiauv_pin.fast.loop` runs a whole simulation (any compiled controller of
:mod:`aiauv_pin.fast.controllers`, logging, integration) in compiled code.

Set-up cost: the first use in a fresh installation compiles the kernels; they are cached on disk,
keyed on the content of every source file they depend on (:mod:`hydro.jit`), so an edit anywhere
recompiles what depends on it and a stale cache is never served.
"""

from __future__ import annotations

import importlib


def load_fast_model():
    """The :class:`~aiauv_pin.fast.model.FastModel` class.

    Raises:
        ImportError: numba is not installed (or cannot be imported).
    """
    module = importlib.import_module("aiauv_pin.fast.model")
    return module.FastModel


def available() -> bool:
    """Whether the compiled backend can be imported on this machine."""
    try:
        load_fast_model()
    except ImportError:
        return False
    return True
