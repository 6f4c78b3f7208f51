"""Vector line-of-sight guidance for a straight path along the world x-axis (paper, eq. 21).

The desired direction of travel is ``mu = u_d e1 - K (0, p_y, p_z)`` with ``K = diag(k_y, k_z)``
acting on the cross-track errors of the end-effector position ``p`` in the world frame (eq. 21; a
scalar ``k_e`` gives ``k_y = k_z = k_e``), and the reference pointing direction is
``x_ref = mu / |mu|``.

Since ``u_d > 0``, ``|mu| >= u_d`` and ``x_ref`` is smooth. Its derivatives follow from
``x_ref = mu / r`` with ``r = |mu|`` and ``P = I - x_ref x_ref^T``:

* ``x_ref_dot = P mu_dot / r``;
* ``x_ref_ddot = (P mu_ddot - x_ref (x_ref_dot . mu_dot) - 2 x_ref_dot (x_ref . mu_dot)) / r``,

with ``mu_dot = -K (0, p_y_dot, p_z_dot)`` and ``mu_ddot = -K (0, p_y_ddot, p_z_ddot)``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

CrossTrackGain = float | Sequence[float]


def _vector3(value, name: str) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (3,):
        raise ValueError(f"{name}: expected shape (3,), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    return array


def cross_track_gains(k_e: CrossTrackGain) -> np.ndarray:
    """Diagonal ``(0, k_y, k_z)`` [1/s] of the gain matrix of eq. (21) acting on ``(0, p_y, p_z)``.

    Args:
        k_e: A scalar (same gain on y and z), a pair ``(k_y, k_z)``, or a triple (the diagonal of a
            3x3 matrix; its first entry multiplies the zero along-path component and is ignored).

    Raises:
        ValueError: wrong length, negative or non-finite gains.
    """
    gains = np.atleast_1d(np.asarray(k_e, dtype=float))
    if gains.ndim != 1 or gains.size not in (1, 2, 3):
        raise ValueError(
            f"k_e: expected a scalar or a sequence of 2 or 3 gains, got shape {gains.shape}"
        )
    if not np.all(np.isfinite(gains)) or np.any(gains < 0.0):
        raise ValueError(f"k_e: gains must be finite and >= 0, got {gains.tolist()}")
    if gains.size == 1:
        return np.array([0.0, gains[0], gains[0]])
    if gains.size == 2:
        return np.array([0.0, gains[0], gains[1]])
    return np.array([0.0, gains[1], gains[2]])


def los_direction(position_in_world, u_d: float, k_e: CrossTrackGain) -> np.ndarray:
    """Unnormalised desired direction of travel ``mu`` [m/s] (eq. 21).

    Args:
        position_in_world: End-effector position ``p`` in the world frame (3,) [m].
        u_d: Desired forward speed [m/s] (> 0).
        k_e: Cross-track gain(s) [1/s], see :func:`cross_track_gains`.
    """
    p = _vector3(position_in_world, "position_in_world")
    u_d = _speed(u_d)
    return np.array([u_d, 0.0, 0.0]) - cross_track_gains(k_e) * p  # eq. (21)


def _speed(u_d: float) -> float:
    u_d = float(u_d)
    if not (np.isfinite(u_d) and u_d > 0.0):
        raise ValueError(f"u_d must be positive and finite, got {u_d}")
    return u_d


def los_reference(
    position_in_world,
    velocity_in_world,
    acceleration_in_world,
    u_d: float,
    k_e: CrossTrackGain,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference pointing direction ``x_ref = mu / |mu|`` (eq. 21) and its exact time derivatives.

    Args:
        position_in_world: End-effector position ``p`` (3,) [m].
        velocity_in_world: ``p_dot`` (3,) [m/s].
        acceleration_in_world: ``p_ddot`` (3,) [m/s^2].
        u_d: Desired forward speed [m/s] (> 0).
        k_e: Cross-track gain(s) [1/s], see :func:`cross_track_gains`.

    Returns:
        ``x_ref`` (unit, 3,), ``x_ref_dot`` (3,) [1/s] and ``x_ref_ddot`` (3,) [1/s^2], world frame.
    """
    gains = cross_track_gains(k_e)
    p = _vector3(position_in_world, "position_in_world")
    p_dot = _vector3(velocity_in_world, "velocity_in_world")
    p_ddot = _vector3(acceleration_in_world, "acceleration_in_world")
    mu = np.array([_speed(u_d), 0.0, 0.0]) - gains * p  # eq. (21)
    mu_dot = -gains * p_dot
    mu_ddot = -gains * p_ddot
    r = float(np.linalg.norm(mu))
    x = mu / r
    x_dot = (mu_dot - x * (x @ mu_dot)) / r  # P mu_dot / r
    x_ddot = (
        mu_ddot - x * (x @ mu_ddot) - x * (x_dot @ mu_dot) - 2.0 * x_dot * (x @ mu_dot)
    ) / r  # d/dt of P mu_dot / r
    return x, x_dot, x_ddot
