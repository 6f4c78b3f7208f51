"""aiauv-pin: articulated intervention AUVs on Pinocchio, with exact per-link hydrodynamics.

The main entry points::

    import aiauv_pin
    vehicle = aiauv_pin.load_vehicle()            # the paper's vehicle, uniform density
    dv = vehicle.acceleration(q, v, tau)          # forward dynamics with added mass, damping, restoring
    trajectory = aiauv_pin.simulate(vehicle, q0, v0, duration=10.0, dt=0.01)
    model = aiauv_pin.linearize(vehicle)          # linear model about straight-line motion
"""

from typing import TYPE_CHECKING

# first: installs its import finder before numba loads its registries (no scipy.linalg); it
# imports nothing but os and sys
from aiauv_pin._internal import numba_blas as _numba_blas  # noqa: F401

if TYPE_CHECKING:
    from aiauv_pin.dynamics.linear_model import linearize, straight_line_trim
    from aiauv_pin.errors import AiauvError, SimulationDiverged, VehicleLoadError
    from aiauv_pin.model.loading import BUNDLED_CASES, bundled_urdf, load_vehicle
    from aiauv_pin.model.vehicle import Vehicle
    from aiauv_pin.reference.integrators import midpoint_step, rk4_step, semi_implicit_euler_step
    from aiauv_pin.simulation.fixed_step import Trajectory, simulate
    from aiauv_pin.simulation.rollout import Rollout, rollout

#: The public names and the modules they live in, imported on first use (PEP 562): ``import
#: aiauv_pin`` alone imports neither numba nor Pinocchio, so that a command can start work on the
#: second core (``aiauv simulate``'s figure process, :mod:`aiauv_pin.results.figure_workers`)
#: before the heavy imports. The simulation's names come in together (:func:`import_all`).
_LAZY = {
    "AiauvError": "errors",
    "SimulationDiverged": "errors",
    "VehicleLoadError": "errors",
    "BUNDLED_CASES": "model.loading",
    "bundled_urdf": "model.loading",
    "load_vehicle": "model.loading",
    "Vehicle": "model.vehicle",
    "midpoint_step": "reference.integrators",
    "rk4_step": "reference.integrators",
    "semi_implicit_euler_step": "reference.integrators",
    "Trajectory": "simulation.fixed_step",
    "simulate": "simulation.fixed_step",
    "Rollout": "simulation.rollout",
    "rollout": "simulation.rollout",
    "linearize": "dynamics.linear_model",
    "straight_line_trim": "dynamics.linear_model",
}
#: Modules a simulation never needs, left out of :func:`import_all`.
_ON_DEMAND = ("dynamics.linear_model",)
#: Modules that import nothing heavy: their names come alone.
_LIGHT = ("errors",)


def import_all() -> None:
    """Import the simulation's modules (numba, Pinocchio and ours), once.

    They create several hundred thousand long-lived objects, and the cyclic garbage collector,
    triggered by their allocations, would scan them again and again while they are made (about
    170 collections, 0.05-0.1 s of every start): it is paused for the imports, they are then moved
    to its oldest generation without a scan (``gc.freeze`` then ``gc.unfreeze``; a full
    collection still looks at them), and it is restored as it was.
    """
    import gc
    import importlib

    collecting = gc.isenabled()
    gc.disable()
    try:
        for module in dict.fromkeys(_LAZY.values()):
            if module not in _ON_DEMAND:
                importlib.import_module(f".{module}", __name__)
    finally:
        gc.freeze()
        gc.unfreeze()
        if collecting:
            gc.enable()


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        if _LAZY[name] not in _ON_DEMAND + _LIGHT:
            import_all()
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
