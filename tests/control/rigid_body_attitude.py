"""Test helper: a rigid body with two control torques (paper, eq. 1) and a precessing reference.

The attitude is a unit quaternion ``(w, x, y, z)`` (body to world) integrated together with the body
angular velocity by a fixed-step classical RK4; the quaternion is renormalised after each step. The
controller is evaluated at every RK4 stage, so the closed loop is integrated as the continuous-time
system it is.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aiauv_control.reduced_attitude import H


def quaternion_to_rotation(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body to world) of a unit quaternion ``(w, x, y, z)``."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def quaternion_from_axis_angle(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def quaternion_rate(q: np.ndarray, omega_body: np.ndarray) -> np.ndarray:
    """``q_dot = 1/2 q (x) (0, omega)`` for a body-frame angular velocity."""
    w, x, y, z = q
    p, r_, s = omega_body
    return 0.5 * np.array(
        [
            -x * p - y * r_ - z * s,
            w * p + y * s - z * r_,
            w * r_ + z * p - x * s,
            w * s + x * r_ - y * p,
        ]
    )


@dataclass(frozen=True)
class ConeReference:
    """Unit direction precessing on a cone about the world x-axis, with a wobbling rate.

    ``x_ref(t) = (cos a, sin a cos th(t), sin a sin th(t))`` with ``th(t) = w t + b sin(v t)``; the
    first and second derivatives are analytic.
    """

    half_angle: float = 0.5
    rate: float = 0.6
    wobble: float = 0.4
    wobble_rate: float = 0.7

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a, w, b, v = self.half_angle, self.rate, self.wobble, self.wobble_rate
        th = w * t + b * np.sin(v * t)
        th_d = w + b * v * np.cos(v * t)
        th_dd = -b * v * v * np.sin(v * t)
        s, c = np.sin(th), np.cos(th)
        x = np.array([np.cos(a), np.sin(a) * c, np.sin(a) * s])
        x_d = np.sin(a) * np.array([0.0, -s, c]) * th_d
        x_dd = np.sin(a) * (np.array([0.0, -c, -s]) * th_d**2 + np.array([0.0, -s, c]) * th_dd)
        return x, x_d, x_dd


@dataclass(frozen=True)
class ConstantReference:
    direction: tuple[float, float, float] = (0.0, 0.6, 0.8)

    def __call__(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return np.array(self.direction, dtype=float), np.zeros(3), np.zeros(3)


Reference = Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]
Controller = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


@dataclass(frozen=True)
class RigidBody:
    """``J omega_dot = m + H u`` (eq. 1) with ``m = -omega x J omega + disturbance(t)``."""

    J: np.ndarray
    disturbance: Callable[[float], np.ndarray]

    def moments(self, omega: np.ndarray, t: float) -> np.ndarray:
        """Known moments: gyroscopic ``-omega x J omega`` plus the disturbance [N m]."""
        a, b = omega, self.J @ omega
        gyroscopic = np.array(
            [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
        )
        return -gyroscopic + self.disturbance(t)

    def derivative(self, state: np.ndarray, t: float, controller: Controller) -> np.ndarray:
        q, omega = state[:4], state[4:]
        R = quaternion_to_rotation(q)
        u = controller(R, omega, t)
        omega_dot = np.linalg.solve(self.J, self.moments(omega, t) + H @ u)  # eq. (1)
        return np.concatenate([quaternion_rate(q, omega), omega_dot])

    def step(self, state: np.ndarray, t: float, dt: float, controller: Controller) -> np.ndarray:
        """One classical RK4 step of length ``dt`` (may be negative)."""
        k1 = self.derivative(state, t, controller)
        k2 = self.derivative(state + 0.5 * dt * k1, t + 0.5 * dt, controller)
        k3 = self.derivative(state + 0.5 * dt * k2, t + 0.5 * dt, controller)
        k4 = self.derivative(state + dt * k3, t + dt, controller)
        new = state + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        new[:4] /= np.linalg.norm(new[:4])
        return new

    def simulate(
        self, state0: np.ndarray, t_end: float, dt: float, controller: Controller
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return times (N,) and states (N, 7) from 0 to ``t_end``."""
        steps = round(t_end / dt)
        states = np.empty((steps + 1, 7))
        states[0] = state0
        for i in range(steps):
            states[i + 1] = self.step(states[i], i * dt, dt, controller)
        return np.arange(steps + 1) * dt, states
