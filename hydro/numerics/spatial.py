"""Spatial (6-D) vector algebra used by the hydrodynamic models, batched over leading axes.

Twists are ``(v, omega)`` and wrenches ``(f, n)``: linear part first, the order of Pinocchio's
``Motion.vector`` and ``Force.vector`` and of Fossen's ``nu`` and ``tau`` (Featherstone 2008, Ch. 2).
"""

from __future__ import annotations

import numpy as np


def skew(vector: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``S(a)`` with ``S(a) b = a x b`` (Fossen 2021, eq. (2.10))."""
    x, y, z = np.asarray(vector, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (written out: ``np.cross`` costs ~10x more on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def spatial_cross_wrench(twist: np.ndarray, wrench: np.ndarray) -> np.ndarray:
    """Spatial cross product ``twist x* wrench`` (Featherstone 2008, eq. (2.32)), batched.

    Args:
        twist: Twists ``(v, omega)``, shape (..., 6) [m/s, rad/s].
        wrench: Wrenches ``(f, n)``, shape (..., 6) [N, N m].

    Returns:
        ``(omega x f, v x f + omega x n)``, shape (..., 6).
    """
    v, omega = twist[..., :3], twist[..., 3:]
    f, n = wrench[..., :3], wrench[..., 3:]
    return np.concatenate((cross(omega, f), cross(v, f) + cross(omega, n)), axis=-1)


def motion_transform(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Matrix mapping twists of a frame A to a frame B placed at ``(R, p)`` in A.

    A point with B coordinates ``x_B`` has A coordinates ``R x_B + p``; a twist ``(v, w)`` of A at
    A's origin has B coordinates ``(R^T (v + w x p), R^T w)`` at B's origin (Featherstone 2008,
    eq. (2.24)). Wrenches go back with the transpose: ``f_A = X^T f_B``, and a generalised inertia
    moves as ``M_A = X^T M_B X``.

    Args:
        rotation: Orientation ``R`` of frame B in frame A (3x3).
        translation: Origin ``p`` of frame B in frame A [m].

    Returns:
        ``X`` (6x6) with ``nu_B = X nu_A``.
    """
    rotation_t = np.asarray(rotation, dtype=float).T
    transform = np.zeros((6, 6))
    transform[:3, :3] = rotation_t
    transform[:3, 3:] = -rotation_t @ skew(translation)  # v_B = R^T (v - p x w)
    transform[3:, 3:] = rotation_t
    return transform
