"""The common part of the environments: a vehicle, its batched physics, the step and the reset.

:class:`VehicleEnv` is a :class:`gymnasium.Env` over a :class:`~aiauv_pin.envs.batch.VehicleBatch`
of one row. A task (:class:`~aiauv_pin.envs.path_following_env.PathFollowingEnv`, ...) fills in what
is its own, every hook on arrays of N rows: the initial state of an episode, the controls of an
action, the observation, the reward and the termination. The vector environment
(:class:`~aiauv_pin.envs.vector.VehicleVectorEnv`) runs the same hooks of one task instance over
N rows, so a row of the vector environment is exactly the single environment with the same seed.

Timing: an environment step is ``substeps`` integration steps of ``dt`` (defaults: the scenario's
semi-implicit Euler at 4 ms, :mod:`aiauv_pin.scenario.defaults`, 10 substeps: 0.04 s per step);
the action is held over the step (thrusts through ``B(q)`` at its start). An episode is truncated
after ``episode_steps`` steps; it terminates early if the state becomes non-finite (``info
["diverged"]``), if a joint leaves its limits (``info["beyond_joint_limit"]``: the model has no
joint stops, the URDF's limits are not forces, so a body driven past them would fold through
itself) or on the task's own condition.
"""

from __future__ import annotations

import abc
from functools import lru_cache

import gymnasium
import numpy as np

from aiauv_control.path_following import PathFollowingGains
from aiauv_pin.envs.batch import VehicleBatch
from aiauv_pin.errors import ArgumentError
from aiauv_pin.scenario.defaults import DEFAULT_DT, DEFAULT_METHOD

#: Ways the joints are driven: a servo towards joint references, or joint torques.
CONTROL_MODES = ("references", "torques")


@lru_cache(maxsize=1)
def paper_vehicle():
    """The paper's vehicle (:func:`aiauv_pin.load_vehicle`), loaded once per process and shared:
    a vehicle may be used from several threads, and the environments only read it."""
    from aiauv_pin.model.loading import load_vehicle

    return load_vehicle()


def yaw_quaternion(yaw: float) -> np.ndarray:
    """The unit quaternion ``(x, y, z, w)`` of a rotation of ``yaw`` [rad] about the world z-axis."""
    return np.array([0.0, 0.0, np.sin(0.5 * yaw), np.cos(0.5 * yaw)])


class VehicleEnv(gymnasium.Env, abc.ABC):
    """A vehicle in water as a Gymnasium environment (see the module docstring).

    Args:
        vehicle: The vehicle (default: the paper's, :func:`paper_vehicle`).
        control: ``"references"`` (the joints follow references through the paper's joint
            servo, eq. (24), with ``servo_gains``) or ``"torques"`` (the actions are the joint
            torques).
        dt: Integration step [s].
        substeps: Integration steps per environment step.
        method: Integrator: ``"euler"``, ``"rk4"`` or ``"midpoint"``.
        episode_steps: Steps after which an episode is truncated.
        servo_gains: ``(k_p [N m/rad], k_d [N m s/rad])`` (default: the paper's 30 and 50).
        max_joint_torque: The joint torque of an action of 1 in ``"torques"`` mode [N m].
    """

    metadata = {"render_modes": []}  # noqa: RUF012 (gymnasium's class attribute)

    #: The link or frame whose pose the task reads (the batch reports it after every step).
    frame = "end_effector"

    def __init__(
        self,
        vehicle=None,
        *,
        control: str = "references",
        dt: float = DEFAULT_DT,
        substeps: int = 10,
        method: str = DEFAULT_METHOD,
        episode_steps: int = 1000,
        servo_gains: tuple[float, float] | None = None,
        max_joint_torque: float = 20.0,
    ) -> None:
        super().__init__()
        self.vehicle = paper_vehicle() if vehicle is None else vehicle
        if control not in CONTROL_MODES:
            raise ArgumentError(
                f"unknown control {control!r:.40} (expected one of {', '.join(CONTROL_MODES)})"
            )
        if (
            isinstance(episode_steps, bool)
            or not isinstance(episode_steps, int)
            or episode_steps < 1
        ):
            raise ArgumentError(
                f"episode_steps must be a whole number >= 1, got {episode_steps!r:.40}"
            )
        if not (isinstance(dt, (int, float)) and 0.0 < dt < np.inf):
            raise ArgumentError(f"dt must be a positive number of seconds, got {dt!r:.40}")
        if not (isinstance(max_joint_torque, (int, float)) and 0.0 < max_joint_torque < np.inf):
            raise ArgumentError(
                f"max_joint_torque must be a positive number [N m], got {max_joint_torque!r:.40}"
            )
        if servo_gains is None:
            paper = PathFollowingGains()
            servo_gains = (paper.k_qp, paper.k_qd)
        if not (len(servo_gains) == 2 and all(0.0 <= float(g) < np.inf for g in servo_gains)):
            raise ArgumentError(f"servo_gains must be two gains >= 0, got {servo_gains!r:.60}")
        self.control, self.episode_steps = control, episode_steps
        self.max_joint_torque = float(max_joint_torque)
        self.servo_gains = (float(servo_gains[0]), float(servo_gains[1]))
        self._physics = dict(dt=float(dt), substeps=substeps, method=method)
        model = self.vehicle.model
        self.n_thrusters, self.n_joints = len(self.vehicle.hydro.thrusters), self.vehicle.nv - 6
        self.joint_limit = np.minimum(
            np.abs(model.lowerPositionLimit[7:]), np.abs(model.upperPositionLimit[7:])
        )  # [rad], the references' scale
        self.step_duration = float(dt) * substeps  # [s]
        self.observation_space = gymnasium.spaces.Box(
            -np.inf, np.inf, (self.observation_size(),), np.float64
        )
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (self.action_size(),), np.float64)
        self.allocate(1)

    # ------------------------------------------------------------------ rows
    def allocate(self, n_rows: int, threads: int | None = None) -> None:
        """Make the physics of ``n_rows`` rows (the vector environment calls it with N)."""
        old = getattr(self, "sim", None)
        if old is not None:
            old.close()
        self.sim = VehicleBatch(
            self.vehicle,
            n_rows,
            frame=self.frame,
            servo_gains=self.servo_gains if self.control == "references" else None,
            threads=threads,
            **self._physics,
        )
        self.steps = np.zeros(n_rows, dtype=np.int64)
        self.allocate_task(n_rows)

    def reset_rows(self, rows, generators) -> None:
        """Start a new episode in each of ``rows``, drawing from its generator."""
        sim = self.sim
        for row, generator in zip(rows, generators, strict=True):
            q, v, current = self.initial_state(generator)
            sim.q[row], sim.v[row], sim.currents[row] = q, v, current
            sim.t[row], sim.controls[row] = 0.0, 0.0
            self.steps[row] = 0
        sim.advance(0)  # the frame at the new states (no step)
        for row, generator in zip(rows, generators, strict=True):
            self.start_row(row, generator)

    def step_rows(self, actions: np.ndarray):
        """One step of every row: ``(observations, rewards, terminated, truncated, info)``."""
        sim = self.sim
        actions = np.clip(actions, -1.0, 1.0)
        previous = sim.position.copy()
        self.set_controls(actions)
        sim.advance()
        self.steps += 1
        reward, info = self.reward(actions, previous)
        diverged = sim.done < sim.substeps
        beyond = np.any(np.abs(sim.q[:, 7:]) > self.joint_limit, axis=1)
        info["diverged"], info["beyond_joint_limit"] = diverged, beyond
        terminated = diverged | beyond | self.failed()
        truncated = self.steps >= self.episode_steps
        return self.observe(), reward, terminated, truncated & ~terminated, info

    def joint_controls(self, actions: np.ndarray) -> None:
        """Write the joint part of the actions (N, n_joints) into the controls: references
        ``a * joint_limit`` [rad] or torques ``a * max_joint_torque`` [N m]."""
        m, nj = self.n_thrusters, self.n_joints
        if self.control == "references":
            self.sim.controls[:, m + nj :] = actions * self.joint_limit
        else:
            self.sim.controls[:, m : m + nj] = actions * self.max_joint_torque

    def body_state(self) -> np.ndarray:
        """The observation's common part (N, 26 for the paper's vehicle): base quaternion
        ``(x, y, z, w)``, joint angles [rad], base twist in base axes [m/s, rad/s], joint rates
        [rad/s]."""
        return np.concatenate((self.sim.q[:, 3:], self.sim.v), axis=1)

    # ------------------------------------------------------------------ gymnasium
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new episode: ``(observation, info)``; the same seed gives the same episode."""
        super().reset(seed=seed)
        self.reset_rows([0], [self.np_random])
        return self.observe()[0], {}

    def step(self, action):
        """One step of ``step_duration`` [s]: ``(observation, reward, terminated, truncated, info)``."""
        try:
            action = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            raise ArgumentError("action must be an array of numbers") from None
        if action.shape != self.action_space.shape or not np.all(np.isfinite(action)):
            raise ArgumentError(
                f"action must be {self.action_space.shape} finite numbers, got shape {action.shape}"
            )
        obs, reward, terminated, truncated, info = self.step_rows(action[None, :])
        info = {key: value[0].item() for key, value in info.items()}
        return obs[0], float(reward[0]), bool(terminated[0]), bool(truncated[0]), info

    def close(self) -> None:
        """Stop the physics' threads."""
        self.sim.close()

    # ------------------------------------------------------------------ the task's hooks
    @abc.abstractmethod
    def observation_size(self) -> int:
        """Length of an observation."""

    @abc.abstractmethod
    def action_size(self) -> int:
        """Length of an action."""

    def allocate_task(self, n_rows: int) -> None:
        """Make the task's own per-row arrays (targets, ...)."""

    @abc.abstractmethod
    def initial_state(self, generator: np.random.Generator):
        """``(q (nq,), v (nv,), current (3,) [m/s])`` of a new episode."""

    def start_row(self, row: int, generator: np.random.Generator) -> None:
        """The task's own start of an episode in ``row`` (the frame is already evaluated)."""

    @abc.abstractmethod
    def set_controls(self, actions: np.ndarray) -> None:
        """Write the controls of ``actions`` (N, action_size), each in [-1, 1]."""

    @abc.abstractmethod
    def observe(self) -> np.ndarray:
        """Observations (N, observation_size)."""

    @abc.abstractmethod
    def reward(self, actions: np.ndarray, previous: np.ndarray):
        """``(rewards (N,), info: name -> (N,) array)`` of the step just taken; ``previous`` is the
        frame's position before it (N, 3) [m]."""

    def failed(self) -> np.ndarray:
        """The task's own termination (N,) bool."""
        return np.zeros(self.sim.n_rows, dtype=bool)
