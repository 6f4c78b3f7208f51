"""Swimming forward by moving the joints only, with the thrusters off (``aiauv/Swimming-v0``)."""

from __future__ import annotations

import numpy as np

from aiauv_pin.envs.vehicle_env import VehicleEnv

#: The joint servo's ``(k_p [N m/rad], k_d [N m s/rad])`` when swimming: stiffer and less damped
#: than the paper's 30 and 50 (built to hold slow steering references), so that the joints follow
#: a wave of 0.5 to 1 Hz (on the paper's vehicle, a 1 Hz wave of 0.6 of the limits swims at
#: 0.006 m/s with the paper's gains, 0.56 m/s with these).
SWIMMING_SERVO_GAINS = (100.0, 10.0)


class SwimmingEnv(VehicleEnv):
    """Swim along the world x-axis by moving the joints, as MuJoCo's ``Swimmer-v5`` does, on the
    paper's vehicle (9 links, 8 joints) in still water with its thrusters off.

    * **Action** (``n_joints`` = 8,) in [-1, 1]: joint references ``a * joint_limit`` [rad]
      (the URDF's limits, 1.13 rad on the paper's vehicle) tracked by the joint servo with
      :data:`SWIMMING_SERVO_GAINS` (``control="references"``, the default), or joint torques
      ``a * max_joint_torque`` [N m] (``control="torques"``).
    * **Observation** (26,): base quaternion ``(x, y, z, w)``, joint angles [rad], base twist in
      base axes [m/s, rad/s], joint rates [rad/s]; no position (as ``Swimmer-v5``, the reward
      must not depend on where the vehicle is).
    * **Reward**: ``forward_weight * dx / T - effort_weight * |a|^2``: the speed [m/s] of the
      vehicle's centre of mass along the world x-axis over the step of ``T = step_duration`` [s]
      (the centre of mass, not a link: curling the body up moves a link forward, not the
      centre), minus the effort
      (``Swimmer-v5``'s ``forward_reward_weight * x_velocity - ctrl_cost_weight * |a|^2``).
    * **Start**: the vehicle straight and level at the origin, at rest, each joint at
      ``U(-initial_spread, initial_spread)`` [rad].
    * **Termination**: a joint beyond its limits or a non-finite state; **truncation** after
      ``episode_steps`` steps (default 1000 steps of 0.04 s: 40 s).

    Args:
        forward_weight: Weight of the forward speed [1/(m/s)].
        effort_weight: Weight of ``|a|^2``.
        initial_spread: Half-width of the joints' initial angles [rad].
        control, servo_gains: As in :class:`~aiauv_pin.envs.vehicle_env.VehicleEnv` (other
            defaults here).
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
        control: str = "references",
        servo_gains: tuple[float, float] = SWIMMING_SERVO_GAINS,
        **kwargs,
    ) -> None:
        self.forward_weight, self.effort_weight = float(forward_weight), float(effort_weight)
        self.initial_spread = float(initial_spread)
        super().__init__(vehicle, control=control, servo_gains=servo_gains, **kwargs)

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
        speed = (self.sim.centre[:, 0] - self.previous_centre) / self.step_duration
        self.previous_centre = self.sim.centre[:, 0].copy()
        effort = np.sum(actions**2, axis=1)
        reward = self.forward_weight * speed - self.effort_weight * effort
        return reward, {"forward_speed": speed, "effort": effort}

    def allocate_task(self, n_rows):
        self.previous_centre = np.zeros(n_rows)

    def start_row(self, row, generator):
        self.previous_centre[row] = self.sim.centre[row, 0]
