"""Rotation of a unit quaternion, compiled: shared by the kernels and the disturbances."""

from __future__ import annotations

from aiauv_hydro.numerics.jit import compiled


@compiled(fastmath=True)
def quaternion_rotation(x, y, z, w):
    """Rotation matrix of a unit quaternion ``(x, y, z, w)`` (Pinocchio's order), as three rows."""
    return (
        (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)),
        (2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)),
        (2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)),
    )
