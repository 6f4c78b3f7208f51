"""aiauv-pin: articulated intervention AUVs on Pinocchio, with exact per-link hydrodynamics.

The main entry points::

    import aiauv_pin
    vehicle = aiauv_pin.load_vehicle()            # the paper's vehicle, uniform density
    dv = vehicle.acceleration(q, v, tau)          # forward dynamics with added mass, damping, restoring
    trajectory = aiauv_pin.simulate(vehicle, q0, v0, duration=10.0, dt=0.01)
    model = aiauv_pin.linearize(vehicle)          # linear model about straight-line motion
"""

import gc as _gc
from typing import TYPE_CHECKING

# The imports below (numba, Pinocchio and ours) create several hundred thousand long-lived
# objects, and the cyclic garbage collector, triggered by their allocations, would scan them
# again and again while they are made (about 170 collections, 0.05-0.1 s of every start): it is
# paused for the imports, they are then moved to its oldest generation without a scan
# (gc.freeze then gc.unfreeze; a full collection still looks at them), and it is restored as it
# was.
_collecting = _gc.isenabled()
_gc.disable()
try:
    # first: installs its import finder before numba loads its registries (no scipy.linalg)
    from aiauv_pin._internal import numba_blas as _numba_blas  # noqa: F401
    from aiauv_pin.errors import AiauvError, SimulationDiverged, VehicleLoadError
    from aiauv_pin.model.loading import BUNDLED_CASES, bundled_urdf, load_vehicle
    from aiauv_pin.model.vehicle import Vehicle
    from aiauv_pin.reference.integrators import (
        midpoint_step,
        rk4_step,
        semi_implicit_euler_step,
    )
    from aiauv_pin.simulation.fixed_step import Trajectory, simulate
    from aiauv_pin.simulation.rollout import Rollout, rollout
finally:
    _gc.freeze()
    _gc.unfreeze()
    if _collecting:
        _gc.enable()

if TYPE_CHECKING:
    from aiauv_pin.dynamics.linear_model import linearize, straight_line_trim

#: Names imported on first use (PEP 562): modules a simulation never needs.
_LAZY = {"linearize": "dynamics.linear_model", "straight_line_trim": "dynamics.linear_model"}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})


__all__ = [
    "BUNDLED_CASES",
    "AiauvError",
    "Rollout",
    "SimulationDiverged",
    "Trajectory",
    "Vehicle",
    "VehicleLoadError",
    "bundled_urdf",
    "linearize",
    "load_vehicle",
    "midpoint_step",
    "rk4_step",
    "rollout",
    "semi_implicit_euler_step",
    "simulate",
    "straight_line_trim",
]

__version__ = "0.1.0"
