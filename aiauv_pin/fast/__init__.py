"""Compiled (numba) evaluation of a vehicle's dynamics and fixed-step integration.

The Pinocchio path of :class:`aiauv_pin.Vehicle` stays the reference: every kernel here is
tested against it (tests/test_fast.py). The kernels cover a free-flyer root with 1-DOF revolute or
prismatic joints, which is every vehicle :func:`aiauv_pin.load_vehicle` accepts except URDFs with
other joint types; those, and machines without numba, fall back to Pinocchio.

:mod:`aiauv_pin.fast.path_following` adds the paper's path-following controller and a whole
compiled scenario loop (used by :func:`aiauv_pin.scenario.run_paper_scenario` on this backend).

Set-up cost: the first use in a fresh installation compiles the kernels (about half a minute);
they are cached on disk (numba ``cache=True``) so later processes start in well under a second.
numba's cache checks only the file that defines a function: after editing ``kernels.py``, delete
``aiauv_pin/fast/__pycache__/*.nb[ic]`` (or touch ``path_following.py``) so that the compiled
scenario loop, which inlines the kernels, is rebuilt.
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
