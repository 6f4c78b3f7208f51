"""Compiled (numba) evaluation of a vehicle's dynamics: records, kernels, derivatives, step Jacobians.

``Vehicle.fast`` is this package's :class:`~aiauv_pin.kernels.evaluation.FastModel`. May import
:mod:`aiauv_hydro`, :mod:`aiauv_control.laws`, :mod:`aiauv_pin.errors`; never Pinocchio at call time
(records are built from a Pinocchio model by :mod:`aiauv_pin.kernels.records`).
"""

from __future__ import annotations

import importlib


def load_fast_model():
    """The :class:`~aiauv_pin.kernels.evaluation.FastModel` class.

    Raises:
        ImportError: numba is not installed (or cannot be imported).
    """
    module = importlib.import_module("aiauv_pin.kernels.evaluation")
    return module.FastModel


def available() -> bool:
    """Whether the compiled backend can be imported on this machine."""
    try:
        load_fast_model()
    except ImportError:
        return False
    return True
