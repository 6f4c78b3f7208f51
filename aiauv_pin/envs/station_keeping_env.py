"""Station keeping of the end-effector in a current (``aiauv/StationKeeping-v0``)."""

from __future__ import annotations

import numpy as np

from aiauv_pin.envs.vehicle_env import VehicleEnv
from aiauv_pin.errors import ArgumentError


class StationKeepingEnv(VehicleEnv):
    """Hold the end-effector of the paper's vehicle at a target pose in a current, with every
    thruster and the joints.

    * **Action** (n_thrusters + n_joints = 15,) in [-1, 1]: thrusts ``a[:7] * max_thrust`` [N]
      (50 N each on the paper's vehicle), then joint references ``a[7:] * joint_limit`` [rad]
      tracked by the paper's joint servo (eq. (24); ``control="torques"``: joint torques
      ``a[7:] * max_joint_torque`` [N m]).
    * **Observation** (41,): the end-effector's position error ``p - p*`` [m] (3,) and attitude
      error ``vee(R*^T R - R^T R*) / 2`` (3,) (along the rotation axis, of length the sine of
      the angle; world axes), its twist in its own axes [m/s, rad/s] (6,), the body state (26,):
      base quaternion ``(x, y, z, w)``, joint angles [rad], base twist [m/s, rad/s], joint rates
      [rad/s], and the current [m/s] (3,), world axes.
    * **Reward**: ``-position_weight * |p - p*| - attitude_weight * |attitude error| -
      effort_weight * |a|^2`` [the weights in 1/m, 1, 1].
    * **Start**: the vehicle straight and level at rest at the origin, joints at zero; the target
      is the end-effector's start moved by ``U(-target_offset, target_offset)`` [m] along each
      world axis, with its start attitude; the current is horizontal, of speed
      ``U(0, max_current)`` [m/s] in a uniformly drawn direction, constant over the episode.
    * **Termination**: a position error above ``max_error`` [m], a non-finite state or
      a joint beyond its limits; **truncation** after ``episode_steps`` steps (default 1000
      steps of 0.04 s: 40 s).

    Args:
        position_weight, attitude_weight, effort_weight: Weights of the reward's terms.
        target_offset: Largest target offset along each axis [m].
        max_current: Largest current speed [m/s].
        max_error: Position error that ends an episode [m].
        **kwargs: Those of :class:`~aiauv_pin.envs.vehicle_env.VehicleEnv`.
    """

    def __init__(
        self,
        vehicle=None,
        *,
        position_weight: float = 1.0,
        attitude_weight: float = 0.5,
        effort_weight: float = 1e-3,
        target_offset: float = 0.5,
        max_current: float = 0.2,
        max_error: float = 3.0,
        **kwargs,
    ) -> None:
        self.position_weight, self.attitude_weight = float(position_weight), float(attitude_weight)
        self.effort_weight, self.target_offset = float(effort_weight), float(target_offset)
        if not 0.0 <= max_current < np.inf:
            raise ArgumentError(f"max_current must be >= 0 [m/s], got {max_current!r:.40}")
        if not max_error > 0.0:
            raise ArgumentError(f"max_error must be > 0 [m], got {max_error!r:.40}")
        self.max_current, self.max_error = float(max_current), float(max_error)
        super().__init__(vehicle, **kwargs)

    def observation_size(self) -> int:
        return 3 + 3 + 6 + 4 + self.n_joints + self.vehicle.nv + 3

    def action_size(self) -> int:
        return self.n_thrusters + self.n_joints

    def allocate_task(self, n_rows):
        self.target_position = np.zeros((n_rows, 3))
        self.target_rotation = np.tile(np.eye(3), (n_rows, 1, 1))

    def initial_state(self, generator):
        direction = generator.uniform(-np.pi, np.pi)
        speed = generator.uniform(0.0, self.max_current)
        current = speed * np.array([np.cos(direction), np.sin(direction), 0.0])
        return self.vehicle.neutral_configuration(), np.zeros(self.vehicle.nv), current

    def start_row(self, row, generator):
        offset = generator.uniform(-self.target_offset, self.target_offset, 3)
        self.target_position[row] = self.sim.position[row] + offset
        self.target_rotation[row] = self.sim.rotation[row]

    def set_controls(self, actions):
        m = self.n_thrusters
        self.sim.controls[:, :m] = actions[:, :m] * self.vehicle.max_thrust
        self.joint_controls(actions[:, m:])

    def errors(self) -> tuple[np.ndarray, np.ndarray]:
        """Position error [m] (N, 3) and attitude error (N, 3) (see the class docstring)."""
        sim = self.sim
        relative = np.einsum("nji,njk->nik", self.target_rotation, sim.rotation)  # R*^T R
        skew = 0.5 * (relative - np.transpose(relative, (0, 2, 1)))
        local = np.stack((skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]), axis=1)
        attitude = np.einsum("nij,nj->ni", self.target_rotation, local)  # in world axes
        return sim.position - self.target_position, attitude

    def observe(self):
        position, attitude = self.errors()
        sim = self.sim
        return np.concatenate(
            (position, attitude, sim.twist, self.body_state(), sim.currents), axis=1
        )

    def reward(self, actions, previous):
        position, attitude = self.errors()
        distance = np.linalg.norm(position, axis=1)
        angle = np.linalg.norm(attitude, axis=1)
        effort = np.sum(actions**2, axis=1)
        reward = (
            -self.position_weight * distance
            - self.attitude_weight * angle
            - self.effort_weight * effort
        )
        return reward, {"position_error": distance, "attitude_error": angle, "effort": effort}

    def failed(self):
        return np.linalg.norm(self.errors()[0], axis=1) > self.max_error
