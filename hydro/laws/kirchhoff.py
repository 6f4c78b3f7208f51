"""Kirchhoff's equations for a body in an ideal fluid, batched over bodies.

A body with generalised inertia ``M`` (6x6, rigid or added mass, about its frame origin) moving with
body-frame twist ``nu = (v, omega)`` has momentum ``h = M nu`` and obeys

    M nu_dot + nu x* (M nu) = wrench,                               Fossen 2021, eq. (6.43)

where ``x*`` is the spatial cross product on wrenches,
``(v, omega) x* (f, n) = (omega x f, v x f + omega x n)``. For the added mass this is
``C_A(nu) nu`` of Fossen 2021, eq. (6.46); written this way it needs no skew matrices and holds for
any full symmetric 6x6 ``M``.
"""

from __future__ import annotations

import numpy as np

from aiauv_hydro.laws import fluid_terms as laws
from aiauv_hydro.numerics.spatial import cross, spatial_cross_wrench

__all__ = ["coriolis_wrench", "cross", "momentum_in_world", "spatial_cross_wrench"]


def coriolis_wrench(inertia: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """Coriolis-centripetal wrench ``C(nu) nu = nu x* (M nu)`` (Fossen 2021, eq. (6.43), (6.46)).

    Args:
        inertia: Generalised inertia matrices, shape (..., 6, 6).
        twist: Body-frame twists, shape (..., 6) [m/s, rad/s].

    Returns:
        The wrench that appears on the left-hand side of the equations of motion, shape (..., 6).
    """
    inertia = np.asarray(inertia, dtype=float)
    twist = np.asarray(twist, dtype=float)
    batch = np.broadcast_shapes(inertia.shape[:-2], twist.shape[:-1])
    inertia = np.broadcast_to(inertia, (*batch, 6, 6)).reshape(-1, 6, 6)
    twist = np.broadcast_to(twist, (*batch, 6)).reshape(-1, 6)
    wrench = np.empty(twist.shape)
    for k in range(twist.shape[0]):  # the one implementation of the law
        wrench[k] = laws.coriolis_wrench(
            np.ascontiguousarray(inertia[k]), np.ascontiguousarray(twist[k])
        )
    return wrench.reshape((*batch, 6))


def momentum_in_world(
    inertia: np.ndarray, twist: np.ndarray, rotation: np.ndarray, translation: np.ndarray
) -> np.ndarray:
    """Sum of body momenta ``M nu``, expressed as one wrench-like vector about the world origin.

    Args:
        inertia: Generalised inertias in body frames, shape (n, 6, 6).
        twist: Body-frame twists, shape (n, 6).
        rotation: Body-to-world rotations, shape (n, 3, 3).
        translation: Body origins in the world frame, shape (n, 3) [m].

    Returns:
        ``(linear momentum [kg m/s], angular momentum about the world origin [kg m^2/s])``, shape (6,).
    """
    local = np.einsum("nij,nj->ni", inertia, twist)
    linear = np.einsum("nij,nj->ni", rotation, local[:, :3])
    angular = np.einsum("nij,nj->ni", rotation, local[:, 3:]) + cross(translation, linear)
    return np.concatenate((linear.sum(axis=0), angular.sum(axis=0)))
