"""Vector line-of-sight guidance on a path (the paper's eq. 21, path-parametrised).

The desired direction of travel is ``mu = u_d T - k_y e_1 N1 - k_z e_2 N2`` with the path frame
``(T, N1, N2)`` at the point closest to the end-effector and the cross-track errors ``e_i``
(:mod:`aiauv_control.paths`); on the world x-axis (the default path) this is eq. (21),
``mu = u_d e1 - K (0, p_y, p_z)`` with ``K = diag(k_y, k_z)`` (a scalar ``k_e`` gives
``k_y = k_z = k_e``). The reference pointing direction is ``x_ref = mu / |mu|``. The law itself is
:func:`aiauv_control.laws.paper_laws.los_guidance`; this module checks inputs and returns arrays.

Since ``u_d > 0``, ``|mu| >= u_d`` and ``x_ref`` is smooth. Its derivatives follow from
``x_ref = mu / r`` with ``r = |mu|`` and ``P = I - x_ref x_ref^T``:

* ``x_ref_dot = P mu_dot / r``;
* ``x_ref_ddot = (P mu_ddot - x_ref (x_ref_dot . mu_dot) - 2 x_ref_dot (x_ref . mu_dot)) / r``,

with ``mu_dot = -K (0, p_y_dot, p_z_dot)`` and ``mu_ddot = -K (0, p_y_ddot, p_z_ddot)`` on a
straight path; on a curved path the derivatives of the path frame enter as well
(:func:`aiauv_control.laws.paper_laws.los_guidance`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aiauv_control.laws import paper_laws as laws
from aiauv_control.paths import LinePath, Path

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


#: The paper's path: the world x-axis.
X_AXIS = LinePath(point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0))


def los_direction(
    position_in_world, u_d: float, k_e: CrossTrackGain, path: Path | None = None
) -> np.ndarray:
    """Unnormalised desired direction of travel ``mu`` [m/s] (eq. 21).

    Args:
        position_in_world: End-effector position ``p`` in the world frame (3,) [m].
        u_d: Desired forward speed [m/s] (> 0).
        k_e: Cross-track gain(s) [1/s], see :func:`cross_track_gains`.
        path: The path (default: the world x-axis).
    """
    p = _vector3(position_in_world, "position_in_world")
    u_d = _speed(u_d)
    gains = cross_track_gains(k_e)
    point = (X_AXIS if path is None else path).closest(p)
    error = np.asarray(point.point) - p
    normal1, normal2 = np.asarray(point.normal1), np.asarray(point.normal2)
    return (  # eq. (21) on the path
        u_d * np.asarray(point.tangent)
        + gains[1] * (normal1 @ error) * normal1
        + gains[2] * (normal2 @ error) * normal2
    )


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
    path: Path | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference pointing direction ``x_ref = mu / |mu|`` (eq. 21) and its exact time derivatives.

    Args:
        position_in_world: End-effector position ``p`` (3,) [m].
        velocity_in_world: ``p_dot`` (3,) [m/s].
        acceleration_in_world: ``p_ddot`` (3,) [m/s^2].
        u_d: Desired forward speed [m/s] (> 0).
        k_e: Cross-track gain(s) [1/s], see :func:`cross_track_gains`.
        path: The path (default: the world x-axis).

    Returns:
        ``x_ref`` (unit, 3,), ``x_ref_dot`` (3,) [1/s] and ``x_ref_ddot`` (3,) [1/s^2], world frame.
    """
    gains = cross_track_gains(k_e)
    p = _vector3(position_in_world, "position_in_world")
    p_dot = _vector3(velocity_in_world, "velocity_in_world")
    p_ddot = _vector3(acceleration_in_world, "acceleration_in_world")
    path = X_AXIS if path is None else path
    point = path.function(p, path.params)
    x, x_dot, x_ddot = laws.los_guidance(  # eq. (21): aiauv_control.laws.paper_laws.los_guidance
        point, p, p_dot, p_ddot, _speed(u_d), gains[1], gains[2]
    )
    return np.array(x), np.array(x_dot), np.array(x_ddot)
