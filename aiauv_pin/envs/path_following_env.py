"""The paper's task as an environment: the end-effector follows a straight line
(``aiauv/PathFollowing-v0``)."""

from __future__ import annotations

import numpy as np

from aiauv_control.joint_references import joint_reference_pattern
from aiauv_control.path_following import PathFollowingGains
from aiauv_pin.controllers.paper_controller import joint_axis_labels, surge_thruster_indices
from aiauv_pin.envs.vehicle_env import VehicleEnv, yaw_quaternion
from aiauv_pin.errors import ArgumentError


class PathFollowingEnv(VehicleEnv):
    """The end-effector of the paper's vehicle follows the world x-axis (a straight line at zero
    depth) forwards, steered by the joints and pushed by the surge thrusters, as in the paper's
    path following (which steers the same joints through base-angle references).

    * **Action** (n_joints + 1 = 9,) in [-1, 1]: joint references ``a[:8] * joint_limit`` [rad]
      tracked by the paper's joint servo (eq. (24); ``control="torques"``: joint torques
      ``a[:8] * max_joint_torque`` [N m]), and the surge thrust ``a[8] * max_thrust`` [N] of each
      surge thruster (those along their link's x-axis; 50 N each on the paper's vehicle). The
      other thrusters are off. With ``steering="base_angles"`` (3,): the paper's base angles
      ``q0 = (q_y0, q_z0) = a[:2] * q_max`` [rad], spread over the joints by eq. (22)
      (``q*_{a,j} = exp(-alpha (j - 1)) q_{a,0}``, with the defaults of the project's paper
      controller, :class:`aiauv_control.path_following.PathFollowingGains`: ``alpha = 0.7`` and
      ``q_max`` = 30 deg, a project choice; ``|q0| <= q_max``, so eq. (22)'s saturation never
      acts), and the surge thrust ``a[2] * max_thrust``.
    * **Observation** (37,), either steering: the end-effector's cross-track error ``(y, z)``
      [m], its x-axis in world axes (3,), its twist in its own axes [m/s, rad/s] (6,), then the
      body state (26,): base quaternion ``(x, y, z, w)``, joint angles [rad], base twist [m/s,
      rad/s], joint rates [rad/s].
    * **Reward**: ``progress_weight * dx / T - error_weight * e - effort_weight * |a|^2``: the
      end-effector's speed along the path over the step [m/s], its cross-track error
      ``e = sqrt(y^2 + z^2)`` [m] after the step, and the effort.
    * **Start**: the vehicle straight and level at rest, its base at ``(0, y0, 0)`` with
      ``y0 ~ U(-initial_offset, initial_offset)`` [m], heading ``~ U(-initial_heading,
      initial_heading)`` [rad], joints at zero.
    * **Termination**: a cross-track error above ``max_error`` [m], a non-finite state or
      a joint beyond its limits; **truncation** after ``episode_steps`` steps (default 1000
      steps of 0.04 s: 40 s).

    Args:
        progress_weight: Weight of the speed along the path [1/(m/s)].
        error_weight: Weight of the cross-track error [1/m].
        effort_weight: Weight of ``|a|^2``.
        initial_offset: Largest initial lateral offset of the base [m].
        initial_heading: Largest initial heading error [rad].
        max_error: Cross-track error that ends an episode [m].
        steering: ``"joints"`` (joint references or torques) or ``"base_angles"`` (the paper's
            two base angles; needs ``control="references"``).
        **kwargs: Those of :class:`~aiauv_pin.envs.vehicle_env.VehicleEnv`.
    """

    def __init__(
        self,
        vehicle=None,
        *,
        progress_weight: float = 1.0,
        error_weight: float = 0.5,
        effort_weight: float = 1e-3,
        initial_offset: float = 1.0,
        initial_heading: float = 0.3,
        max_error: float = 5.0,
        steering: str = "joints",
        **kwargs,
    ) -> None:
        if steering not in ("joints", "base_angles"):
            raise ArgumentError(
                f"unknown steering {steering!r:.40} (expected one of joints, base_angles)"
            )
        if steering == "base_angles" and kwargs.get("control", "references") != "references":
            raise ArgumentError('steering="base_angles" needs control="references"')
        self.steering = steering
        self.progress_weight, self.error_weight = float(progress_weight), float(error_weight)
        self.effort_weight = float(effort_weight)
        self.initial_offset, self.initial_heading = float(initial_offset), float(initial_heading)
        if not max_error > 0.0:
            raise ArgumentError(f"max_error must be > 0 [m], got {max_error!r:.40}")
        self.max_error = float(max_error)
        super().__init__(vehicle, **kwargs)
        gains = PathFollowingGains()
        self.q_max = gains.q_max  # [rad]
        self.base_axis, self.base_scale = joint_reference_pattern(
            joint_axis_labels(self.vehicle), gains.alpha
        )
        self.surge = surge_thruster_indices(self.vehicle)
        if not self.surge:
            raise ArgumentError("the vehicle has no thruster along a link x-axis for surge")

    def observation_size(self) -> int:
        return 2 + 3 + 6 + 4 + self.n_joints + self.vehicle.nv

    def action_size(self) -> int:
        return (2 if self.steering == "base_angles" else self.n_joints) + 1

    def initial_state(self, generator):
        q = self.vehicle.neutral_configuration()
        q[1] = generator.uniform(-self.initial_offset, self.initial_offset)
        q[3:7] = yaw_quaternion(generator.uniform(-self.initial_heading, self.initial_heading))
        return q, np.zeros(self.vehicle.nv), np.zeros(3)

    def set_controls(self, actions):
        if self.steering == "base_angles":  # eq. (22), |q0| <= q_max: no saturation
            base = actions[:, :2] * self.q_max
            m, nj = self.n_thrusters, self.n_joints
            self.sim.controls[:, m + nj :] = base[:, self.base_axis] * self.base_scale
        else:
            self.joint_controls(actions[:, :-1])
        thrust = actions[:, -1, None] * self.vehicle.max_thrust[self.surge]
        self.sim.controls[:, self.surge] = thrust

    def cross_track(self) -> np.ndarray:
        """The end-effector's cross-track error ``(y, z)`` [m] (N, 2)."""
        return self.sim.position[:, 1:]

    def observe(self):
        sim = self.sim
        return np.concatenate(
            (self.cross_track(), sim.rotation[:, :, 0], sim.twist, self.body_state()), axis=1
        )

    def reward(self, actions, previous):
        progress = (self.sim.position[:, 0] - previous[:, 0]) / self.step_duration
        error = np.linalg.norm(self.cross_track(), axis=1)
        effort = np.sum(actions**2, axis=1)
        reward = (
            self.progress_weight * progress
            - self.error_weight * error
            - self.effort_weight * effort
        )
        return reward, {"progress_speed": progress, "cross_track_error": error, "effort": effort}

    def failed(self):
        return np.linalg.norm(self.cross_track(), axis=1) > self.max_error
