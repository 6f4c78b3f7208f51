"""Swimming forward by moving the joints only, with the thrusters off (``aiauv/Swimming-v0``)."""

from __future__ import annotations

import numpy as np

from aiauv_pin.envs.vehicle_env import VehicleEnv


class SwimmingEnv(VehicleEnv):
    """Swim along the world x-axis by moving the joints, as MuJoCo's ``Swimmer-v5`` does, on the
    paper's vehicle (9 links, 8 joints) in still water with its thrusters off.

    * **Action** (``n_joints`` = 8,) in [-1, 1]: joint torques ``a * max_joint_torque`` [N m]
      (``control="torques"``, the default here) or joint references ``a * joint_limit`` [rad]
      tracked by the joint servo (``control="references"``).
    * **Observation** (26,): base quaternion ``(x, y, z, w)``, joint angles [rad], base twist in
      base axes [m/s, rad/s], joint rates [rad/s]; no position (as ``Swimmer-v5``, the reward
      must not depend on where the vehicle is).
    * **Reward**: ``forward_weight * dx / T - effort_weight * |a|^2``: the speed [m/s] of the base
      origin along the world x-axis over the step of ``T = step_duration`` [s], minus the effort
      (``Swimmer-v5``'s ``forward_reward_weight * x_velocity - ctrl_cost_weight * |a|^2``).
    * **Start**: the vehicle straight and level at the origin, at rest, each joint at
      ``U(-initial_spread, initial_spread)`` [rad].
    * **Termination**: only a non-finite state (``info["diverged"]``); **truncation** after
      ``episode_steps`` steps (default 1000 steps of 0.04 s: 40 s).

    Args:
        forward_weight: Weight of the forward speed [1/(m/s)].
        effort_weight: Weight of ``|a|^2``.
        initial_spread: Half-width of the joints' initial angles [rad].
        **kwargs: Those of :class:`~aiauv_pin.envs.vehicle_env.VehicleEnv`.
    """

    frame = "link1"

    def __init__(
        self,
        vehicle=None,
        *,
        forward_weight: float = 1.0,
        effort_weight: float = 1e-3,
        initial_spread: float = 0.1,
        control: str = "torques",
        **kwargs,
    ) -> None:
        self.forward_weight, self.effort_weight = float(forward_weight), float(effort_weight)
        self.initial_spread = float(initial_spread)
        super().__init__(vehicle, control=control, **kwargs)

    def observation_size(self) -> int:
        return 4 + self.n_joints + self.vehicle.nv

    def action_size(self) -> int:
        return self.n_joints

    def initial_state(self, generator):
        q = self.vehicle.neutral_configuration()
        q[7:] = generator.uniform(-self.initial_spread, self.initial_spread, self.n_joints)
        return q, np.zeros(self.vehicle.nv), np.zeros(3)

    def set_controls(self, actions):
        self.joint_controls(actions)

    def observe(self):
        return self.body_state()

    def reward(self, actions, previous):
        speed = (self.sim.position[:, 0] - previous[:, 0]) / self.step_duration  # base origin
        effort = np.sum(actions**2, axis=1)
        reward = self.forward_weight * speed - self.effort_weight * effort
        return reward, {"forward_speed": speed, "effort": effort}
