"""Velocity control of any vehicle: track a commanded twist of a frame (the base or a named
frame) with the thrusters, computed torque on the vehicle's model, thrust allocation with limits.

The law is :func:`aiauv_control.laws.station_laws.velocity_acceleration` (``a_d = d(nu_d)/dt -
K_v (nu - nu_d) - K_i int (nu - nu_d)``, computed torque ``tau = M a_d + n``); the measurement,
allocation, saturation handling and joint servo are those of station keeping
(:class:`aiauv_pin.wholebody.station_controller.ModelBasedBody`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aiauv_control.laws.station_laws import (
    AXIS_NAMES,
    PidGains,
    velocity_acceleration,
    velocity_gains,
)
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.wholebody.station_controller import (
    DEFAULT_JOINT_DAMPING,
    DEFAULT_JOINT_STIFFNESS,
    ModelBasedBody,
    checked_gains,
)

#: Default bandwidth of velocity control [rad/s] (a time constant of 0.5 s).
DEFAULT_BANDWIDTH = 2.0


class VelocityControl(ModelBasedBody):
    """Controller for :func:`aiauv_pin.simulate`: track a body twist of a frame.

    Args:
        vehicle: The vehicle.
        twist: The commanded twist of the frame in its own axes ``(u, v, w, p, q, r)`` (6,)
            [m/s, rad/s], or a function ``t -> (nu_d, d(nu_d)/dt)``.
        frame: The frame (``None``: the base).
        gains: Per-axis gains (``k_d`` is ``K_v`` [1/s], ``k_i`` [1/s^2]); ``None``:
            :func:`~aiauv_control.laws.station_laws.velocity_gains` of ``bandwidth``.
        bandwidth: [rad/s] of the default gains.
        axes, thrust_limits, current, joint_references, joint_stiffness, joint_damping,
        actuator_period: As for
            :class:`aiauv_pin.wholebody.station_controller.StationKeeping`.

    Raises:
        ArgumentError: An unknown frame, gains or limits that are not positive, a twist that is not
            6 finite numbers, or held axes the thrusters cannot produce (one line naming them).
    """

    def __init__(
        self,
        vehicle: Vehicle,
        twist,
        *,
        frame: str | None = None,
        gains: PidGains | None = None,
        bandwidth: float = DEFAULT_BANDWIDTH,
        axes=AXIS_NAMES,
        thrust_limits=None,
        current=None,
        joint_references=None,
        joint_stiffness: float = DEFAULT_JOINT_STIFFNESS,
        joint_damping: float = DEFAULT_JOINT_DAMPING,
        q_check=None,
        actuator_period: float | None = None,
    ) -> None:
        what = "velocity control"
        if gains is None:
            try:
                gains = velocity_gains(float(bandwidth))
            except (TypeError, ValueError) as exc:
                raise ArgumentError(f"{what}: {exc}") from None
        self.gains = checked_gains(gains, what, proportional=False)
        if callable(twist):
            self.twist: Callable = twist
        else:
            nu = np.asarray(twist, dtype=float).reshape(-1)
            if nu.shape != (6,) or not np.all(np.isfinite(nu)):
                raise ArgumentError(
                    f"{what}: twist must be 6 finite numbers (u, v, w, p, q, r) [m/s, rad/s]"
                )
            zero = np.zeros(6)
            self.twist = lambda t: (nu, zero)
        super().__init__(
            vehicle,
            frame=frame,
            axes=axes,
            thrust_limits=thrust_limits,
            current=current,
            joint_references=joint_references,
            joint_stiffness=joint_stiffness,
            joint_damping=joint_damping,
            what=what,
            q_check=q_check,
            actuator_period=actuator_period,
        )

    def __call__(self, t: float, q, v):
        """``(tau, info)`` at ``(t, q, v)``; ``info["error"]`` is ``nu - nu_d`` on the held axes."""
        _, position, twist, _ = self.measure(np.asarray(q, float), np.asarray(v, float))
        target, rate = (np.asarray(x, dtype=float) for x in self.twist(t))
        error = np.where(self.held, twist - target, 0.0)
        acceleration = velocity_acceleration(
            twist, target, rate, self.integral, self.gains, self.held
        )
        tau, wrench, result = self.act(t, q, v, acceleration, error)
        info = self.info_row(error, twist, wrench, result)
        info["target"] = target
        info["frame_position"] = position
        return tau, info

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics."""
        return {**super().info_shapes(), "target": (6,), "frame_position": (3,)}
