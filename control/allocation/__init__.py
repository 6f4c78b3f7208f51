"""Thrust allocation for any vehicle: the actuator forces that best produce a desired generalised
force, within each actuator's limits, and what cannot be produced.

May import :mod:`aiauv_hydro.numerics` only (with NumPy, and ``proxsuite`` where the Python
allocator runs).

Modules: :mod:`~aiauv_control.allocation.problem` (parameters, result, checks),
:mod:`~aiauv_control.allocation.allocator` (the Python allocator on ProxQP),
:mod:`~aiauv_control.allocation.kernels` (the compiled active-set allocator).
Sources: Fossen 2021, Ch. 11; Johansen & Fossen 2013, *Automatica* 49(5).
"""

from aiauv_control.allocation.allocator import allocate, allocate_compiled
from aiauv_control.allocation.kernels import allocate_into, workspace
from aiauv_control.allocation.problem import (
    AllocationError,
    AllocationParameters,
    AllocationResult,
)

__all__ = [
    "AllocationError",
    "AllocationParameters",
    "AllocationResult",
    "allocate",
    "allocate_compiled",
    "allocate_into",
    "workspace",
]
