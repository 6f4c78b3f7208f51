"""Station keeping and velocity control of any vehicle: the laws (written once, NumPy only).

The design is computed torque (feedback linearisation) with a PID outer loop: with the vehicle's
mass matrix ``M(q)`` (rigid and added, full 6x6 couplings) and left-hand-side bias ``n(q, v)``
(Coriolis, damping, restoring, current), the wrench

    tau = M a_d + n(q, v)                                               (computed torque)

makes the body's acceleration ``a_d`` exactly when the thrusters can produce ``tau`` (Fossen 2021,
*Handbook of Marine Craft Hydrodynamics and Motion Control*, 2nd ed., Sec. 13.2 "state feedback
linearization", decoupling in the BODY frame; Siciliano, Sciavicco, Villani and Oriolo 2009,
*Robotics: Modelling, Planning and Control*, Sec. 8.5.2 "inverse dynamics control"). The outer
loop chooses ``a_d`` axis by axis (Fossen 2021, Sec. 12 PID with acceleration feed-forward):

* station keeping (a pose ``(R_d, p_d)`` of a frame, frame axes)::

      e = (R^T (p - p_d), log(R_d^T R)),   a_d = -K_p e - K_d nu - K_i int e dt

  linearised about the target, ``de/dt = nu`` and each axis closes as
  ``s^3 + k_d s^2 + k_p s + k_i`` (:func:`pid_gains` places its roots);
* velocity control (a body twist ``nu_d``)::

      a_d = d(nu_d)/dt - K_v (nu - nu_d) - K_i int (nu - nu_d) dt,   each axis ``s^2 + k_v s + k_i``.

Why computed torque rather than a PID on the error with model feed-forward only: the 6x6 added
mass of an ROV couples the axes (surge with pitch, sway with roll) and its diagonal differs by a
factor 50 between heave and pitch; computed torque takes both out with the model, so that one set
of per-axis gains places known poles on every axis of every vehicle (the closed forms tested in
``tests/control/test_station_laws.py``), and the integral removes what the model misses (an
unknown current, a buoyancy error). Integral windup under saturation is avoided by conditional
integration (Astrom and Murray 2008, *Feedback Systems*, Sec. 10.4: the integral is frozen while
the thrusters cannot produce the demanded wrench).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: The six axes of a body wrench/twist, in the order of the generalised velocity's base part.
AXIS_NAMES = ("surge", "sway", "heave", "roll", "pitch", "yaw")


def skew(w) -> np.ndarray:
    """``S(w)`` with ``S(w) x = w x x`` (3, 3)."""
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rotation_log(rotation) -> np.ndarray:
    """The rotation vector ``theta k`` of a rotation matrix (3,) [rad], ``theta`` in ``[0, pi]``.

    The logarithm of SO(3) (Lynch and Park 2017, *Modern Robotics*, Algorithm in Sec. 3.2.3.3):
    ``theta = acos((tr R - 1) / 2)``, ``[theta k] = theta (R - R^T) / (2 sin theta)``; near
    ``theta = 0`` the series ``(R - R^T) / 2 (1 + theta^2 / 6)``; near ``pi`` the axis from the
    largest diagonal entry of ``(R + I) / 2``.
    """
    R = np.asarray(rotation, dtype=float)
    cos_theta = min(1.0, max(-1.0, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)))
    theta = math.acos(cos_theta)
    vee = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if theta < 1e-6:
        return vee * (1.0 + theta * theta / 6.0)
    if math.pi - theta > 1e-6:
        return vee * (theta / math.sin(theta))
    outer = 0.5 * (R + np.eye(3))
    i = int(np.argmax(np.diag(outer)))
    axis = outer[:, i] / math.sqrt(max(outer[i, i], 1e-300))
    if axis @ vee < 0.0:
        axis = -axis
    return theta * axis


def pose_error(rotation, position, target_rotation, target_position) -> np.ndarray:
    """``e = (R^T (p - p_d), log(R_d^T R))`` (6,) [m, rad]: the pose error in the frame's axes."""
    R = np.asarray(rotation, dtype=float)
    position_error = R.T @ (np.asarray(position, dtype=float) - np.asarray(target_position))
    return np.concatenate(
        (position_error, rotation_log(np.asarray(target_rotation, dtype=float).T @ R))
    )


def rotation_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``R = R_z(yaw) R_y(pitch) R_x(roll)`` (3, 3) (Fossen 2021, eq. 2.18, zyx convention)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, -sy * cr + cy * sp * sr, sy * sr + cy * cr * sp],
            [sy * cp, cy * cr + sr * sp * sy, -cy * sr + sp * sy * cr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@dataclass(frozen=True)
class PidGains:
    """Per-axis gains of the outer loop (6,) each, on accelerations (computed torque).

    Attributes:
        k_p: Proportional [1/s^2] (station keeping; zero for velocity control).
        k_d: Derivative (station keeping) or velocity (velocity control) gain [1/s].
        k_i: Integral [1/s^3] (station keeping) or [1/s^2] (velocity control).
    """

    k_p: np.ndarray
    k_d: np.ndarray
    k_i: np.ndarray


def pid_gains(omega: float, zeta: float = 1.0, integral_pole: float | None = None) -> PidGains:
    """Station-keeping gains placing every axis's roots at ``-a`` and ``-zeta omega +- ...``:

    ``s^3 + k_d s^2 + k_p s + k_i = (s + a)(s^2 + 2 zeta omega s + omega^2)``, hence
    ``k_d = a + 2 zeta omega``, ``k_p = omega^2 + 2 zeta omega a``, ``k_i = a omega^2``
    (pole placement, Fossen 2021, Sec. 12 "PID pole placement"); ``a`` defaults to
    ``omega / 4`` (the integral slower than the PD pair).

    Args:
        omega: Natural frequency [rad/s], > 0.
        zeta: Damping ratio [-], > 0.
        integral_pole: ``a`` [1/s], >= 0 (0: no integral).
    """
    a = omega / 4.0 if integral_pole is None else integral_pole
    if not (math.isfinite(omega) and omega > 0 and math.isfinite(zeta) and zeta > 0):
        raise ValueError(f"omega and zeta must be positive, got {omega!r}, {zeta!r}")
    if not (math.isfinite(a) and a >= 0):
        raise ValueError(f"integral_pole must be >= 0, got {a!r}")
    ones = np.ones(6)
    return PidGains(
        k_p=(omega**2 + 2 * zeta * omega * a) * ones,
        k_d=(a + 2 * zeta * omega) * ones,
        k_i=(a * omega**2) * ones,
    )


def velocity_gains(bandwidth: float, integral_pole: float | None = None) -> PidGains:
    """Velocity-control gains with roots ``-bandwidth`` and ``-a``:
    ``s^2 + k_v s + k_i = (s + bandwidth)(s + a)``, ``a`` defaults to ``bandwidth / 4``."""
    a = bandwidth / 4.0 if integral_pole is None else integral_pole
    if not (math.isfinite(bandwidth) and bandwidth > 0):
        raise ValueError(f"bandwidth must be positive, got {bandwidth!r}")
    if not (math.isfinite(a) and a >= 0):
        raise ValueError(f"integral_pole must be >= 0, got {a!r}")
    ones = np.ones(6)
    return PidGains(k_p=np.zeros(6), k_d=(bandwidth + a) * ones, k_i=bandwidth * a * ones)


def closed_loop_roots(k_p: float, k_d: float, k_i: float) -> np.ndarray:
    """Roots of one axis's linearised closed loop: ``s^3 + k_d s^2 + k_p s + k_i`` (station
    keeping) or, with ``k_p = 0`` read as velocity control, ``s^2 + k_d s + k_i``."""
    if k_p == 0.0:
        return np.roots([1.0, k_d, k_i])
    return np.roots([1.0, k_d, k_p, k_i])


def station_acceleration(error, twist, integral, gains: PidGains, held) -> np.ndarray:
    """``a_d = -K_p e - K_d nu - K_i int e`` (6,) [m/s^2, rad/s^2] on the held axes, zero on the
    others (``held``: (6,) bool)."""
    a = -gains.k_p * error - gains.k_d * np.asarray(twist) - gains.k_i * integral
    return np.where(held, a, 0.0)


def velocity_acceleration(twist, target, target_rate, integral, gains: PidGains, held):
    """``a_d = d(nu_d)/dt - K_v (nu - nu_d) - K_i int (nu - nu_d)`` (6,) on the held axes."""
    error = np.asarray(twist) - np.asarray(target)
    a = np.asarray(target_rate) - gains.k_d * error - gains.k_i * integral
    return np.where(held, a, 0.0)


def computed_wrench(mass, acceleration, bias) -> np.ndarray:
    """``tau = M a + n`` (Fossen 2021, Sec. 13.2; the model's ``M dv + n = tau``) [N, N m]."""
    return np.asarray(mass) @ np.asarray(acceleration) + np.asarray(bias)


def integrate_error(integral, error, dt: float, frozen: bool, held) -> np.ndarray:
    """The error integral advanced by ``error dt`` on the held axes, unless ``frozen``
    (conditional integration against windup, Astrom and Murray 2008, Sec. 10.4)."""
    if frozen or dt <= 0.0:
        return np.asarray(integral, dtype=float)
    return np.where(held, integral + np.asarray(error) * dt, 0.0)


def unproducible_axes(matrix, held, tolerance: float = 1e-6) -> tuple[str, ...]:
    """Names of the held axes whose unit wrench is not in the range of ``matrix`` (6, m): the axes
    no combination of the actuators produces (relative residual of the least-squares fit of
    ``e_i`` above ``tolerance``)."""
    B = np.asarray(matrix, dtype=float)
    if B.size == 0 or not np.abs(B).max() > 0.0:
        return tuple(name for name, h in zip(AXIS_NAMES, held, strict=True) if h)
    u, s, _ = np.linalg.svd(B, full_matrices=False)
    basis = u[:, s > tolerance * s[0]]
    missing = []
    for i, name in enumerate(AXIS_NAMES):
        if not held[i]:
            continue
        unit = np.zeros(6)
        unit[i] = 1.0
        if np.linalg.norm(unit - basis @ (basis.T @ unit)) > tolerance:
            missing.append(name)
    return tuple(missing)
