"""N environments of one task stepped together: a :class:`gymnasium.vector.VectorEnv`."""

from __future__ import annotations

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from aiauv_pin.errors import ArgumentError


class VehicleVectorEnv(VectorEnv):
    """``num_envs`` environments of one task, stepped in one compiled call per thread.

    One task instance (e.g. a :class:`~aiauv_pin.envs.path_following_env.PathFollowingEnv`) runs its
    hooks over N rows of a :class:`~aiauv_pin.envs.batch.VehicleBatch`: the physics of every row
    advance together on a pool of threads running compiled ``nogil`` code; observations, rewards
    and terminations are computed for all rows at once with NumPy. Row ``i`` is the single
    environment reset with seed ``seed + i``, step for step (a test checks it bit for bit).

    Autoreset (``metadata["autoreset_mode"]``, Gymnasium's default): ``NEXT_STEP``. The step after
    the one where a row terminated or was truncated resets that row, ignoring its action, and
    returns its first observation with reward 0 and neither flag set.

    Args:
        env_class: The task: a subclass of :class:`~aiauv_pin.envs.vehicle_env.VehicleEnv`.
        num_envs: N (>= 1).
        threads: Threads (default: the usable cores, at most one per four rows).
        **kwargs: The task's arguments.

    ``info`` holds each of the task's per-step quantities as an (N,) array with its mask
    ``"_" + name`` (Gymnasium's vector convention: False for the rows reset in this step).
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}  # noqa: RUF012

    def __init__(self, env_class, num_envs: int, *, threads: int | None = None, **kwargs) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ArgumentError(f"num_envs must be a whole number >= 1, got {num_envs!r:.40}")
        self.task = env_class(**kwargs)
        self.task.allocate(num_envs, threads)
        self.num_envs = num_envs
        self.single_observation_space = self.task.observation_space
        self.single_action_space = self.task.action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._generators: list[np.random.Generator | None] = [None] * num_envs
        self._autoreset = np.zeros(num_envs, dtype=bool)

    def reset(self, *, seed=None, options: dict | None = None):
        """Reset every row (or those of ``options["reset_mask"]``): ``(observations, {})``.

        ``seed``: ``None`` (each row keeps drawing from its generator, made unseeded on first
        use), an int (row ``i`` seeded with ``seed + i``) or a list of N ints or ``None``.
        """
        super().reset(seed=seed if isinstance(seed, int) else None)
        n = self.num_envs
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, int):
            seeds = [seed + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n or not all(s is None or isinstance(s, int) for s in seeds):
                raise ArgumentError(f"seed must be an int, None or {n} ints or None")
        mask = np.ones(n, dtype=bool)
        if options is not None and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"])
            if mask.shape != (n,) or mask.dtype != np.bool_:
                raise ArgumentError(f"options['reset_mask'] must be {n} bools")
        rows = np.flatnonzero(mask)
        for row in rows:
            if seeds[row] is not None or self._generators[row] is None:
                self._generators[row] = seeding.np_random(seeds[row])[0]
        self.task.reset_rows(rows, [self._generators[row] for row in rows])
        self._autoreset[rows] = False
        return self.task.observe(), {}

    def step(self, actions):
        """One step of every row: ``(observations, rewards, terminations, truncations, infos)``,
        each with N rows (see the class docstring for the autoreset)."""
        try:
            actions = np.asarray(actions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ArgumentError("actions must be an array of numbers") from None
        if actions.shape != self.action_space.shape or not np.all(np.isfinite(actions)):
            raise ArgumentError(
                f"actions must be {self.action_space.shape} finite numbers, got shape {actions.shape}"
            )
        restart = np.flatnonzero(self._autoreset)
        obs, reward, terminated, truncated, info = self.task.step_rows(actions)
        stepped = ~self._autoreset
        if restart.size:  # the rows that ended last step start again (their step is discarded)
            self.task.reset_rows(restart, [self._generators[row] for row in restart])
            obs = self.task.observe()
            reward[restart], terminated[restart], truncated[restart] = 0.0, False, False
        self._autoreset = terminated | truncated
        infos = {}
        for name, value in info.items():
            infos[name], infos["_" + name] = value, stepped.copy()
        return obs, reward, terminated, truncated, infos

    def close_extras(self, **kwargs) -> None:
        """Stop the physics' threads."""
        self.task.close()
