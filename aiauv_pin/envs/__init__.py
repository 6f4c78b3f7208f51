"""Gymnasium environments on the compiled physics: path following, station keeping, swimming.

Needs the optional ``gymnasium`` (``pip install "aiauv-pin[gym]"``). Importing this package
registers the environments (``gymnasium.make("aiauv/PathFollowing-v0")``, or
``gymnasium.make("aiauv_pin.envs:aiauv/PathFollowing-v0")`` without importing it first) and their
vector versions (``gymnasium.make_vec(id, num_envs=N)``: :class:`~aiauv_pin.envs.vector.VehicleVectorEnv`,
N environments in one compiled call per thread). May import everything of :mod:`aiauv_pin` below
the package's ``__init__``.
"""

from __future__ import annotations

from functools import partial

try:
    import gymnasium
except ImportError as exc:  # pragma: no cover - the extra is missing
    raise ImportError('aiauv_pin.envs needs gymnasium: pip install "aiauv-pin[gym]"') from exc

from aiauv_pin.envs.path_following_env import PathFollowingEnv
from aiauv_pin.envs.station_keeping_env import StationKeepingEnv
from aiauv_pin.envs.swimming_env import SwimmingEnv
from aiauv_pin.envs.vector import VehicleVectorEnv
from aiauv_pin.envs.vehicle_env import VehicleEnv

#: Registered id -> task class.
ENVIRONMENTS = {
    "aiauv/PathFollowing-v0": PathFollowingEnv,
    "aiauv/StationKeeping-v0": StationKeepingEnv,
    "aiauv/Swimming-v0": SwimmingEnv,
}


def register_environments() -> None:
    """Register :data:`ENVIRONMENTS` with Gymnasium (again: nothing happens)."""
    for env_id, task in ENVIRONMENTS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(
                env_id,
                entry_point=f"{task.__module__}:{task.__name__}",
                vector_entry_point=partial(VehicleVectorEnv, task),
            )


register_environments()

__all__ = [
    "ENVIRONMENTS",
    "PathFollowingEnv",
    "StationKeepingEnv",
    "SwimmingEnv",
    "VehicleEnv",
    "VehicleVectorEnv",
    "register_environments",
]
