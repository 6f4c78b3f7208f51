"""Straight line (:mod:`aiauv_control.paths`): ``N2`` = world up projected onto the normal plane."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from aiauv_control.paths.base import (
    VERTICAL_TOLERANCE,
    Path,
    PathPoint,
    Vector3,
    _as_tuple,
    _unit,
    _vector,
)
from aiauv_hydro.numerics.jit import compiled

# --------------------------------------------------------------------------------------------
# Compiled kernels
# --------------------------------------------------------------------------------------------


@compiled
def line_frame(tx: float, ty: float, tz: float):
    """Normals ``(N1, N2)`` for a unit tangent ``T``: ``N2`` = world up ``(0, 0, 1)`` projected onto
    the normal plane and normalised, ``N1 = N2 x T``; for a vertical tangent (horizontal part below
    :data:`VERTICAL_TOLERANCE`) the world x axis replaces world up.

    Written so that ``T = (1, 0, 0)`` gives ``N1 = (0, 1, 0)``, ``N2 = (0, 0, 1)`` bit-exactly.
    """
    if math.sqrt(tx * tx + ty * ty) < VERTICAL_TOLERANCE:
        # reference = world x: x - (x . T) T
        ax, ay, az = 1.0 - tx * tx, 0.0 - tx * ty, 0.0 - tx * tz
    else:
        # reference = world up: z - (z . T) T
        ax, ay, az = 0.0 - tz * tx, 0.0 - tz * ty, 1.0 - tz * tz
    norm = math.sqrt(ax * ax + ay * ay + az * az)
    n2x, n2y, n2z = ax / norm, ay / norm, az / norm
    # N1 = N2 x T
    n1x = n2y * tz - n2z * ty
    n1y = n2z * tx - n2x * tz
    n1z = n2x * ty - n2y * tx
    return (n1x, n1y, n1z), (n2x, n2y, n2z)


@compiled
def line_point(position, params) -> PathPoint:
    """Closest point and frame of a straight line (the frame is constant, curvatures are zero).

    Args:
        position: Position ``p`` (3,) [m], world frame.
        params: ``(point (3) [m], unit direction (3) [-])``; ``s = 0`` at ``point``, increasing
            along ``direction``. Normals from :func:`line_frame`.
    """
    px, py, pz = params[0], params[1], params[2]
    tx, ty, tz = params[3], params[4], params[5]
    s = (position[0] - px) * tx + (position[1] - py) * ty + (position[2] - pz) * tz
    normal1, normal2 = line_frame(tx, ty, tz)
    return PathPoint(
        s,
        (px + s * tx, py + s * ty, pz + s * tz),
        (tx, ty, tz),
        normal1,
        normal2,
        0.0,
        0.0,
        0.0,
        0.0,
    )


@dataclass(frozen=True)
class LinePath(Path):
    """Straight line through ``point`` [m] along ``direction`` (normalised; any non-zero length).

    ``s = 0`` at ``point``. ``N2`` is world up projected onto the normal plane (world x for a
    direction within :data:`VERTICAL_TOLERANCE` of vertical), ``N1 = N2 x T``; on the world x-axis
    the frame is exactly ``(x, y, z)`` and the cross-track errors exactly ``(p_y, p_z)``.
    """

    point: Vector3
    direction: Vector3
    params: np.ndarray = field(init=False, repr=False, compare=False)

    type_name: ClassVar[str] = "line"
    kind_code: ClassVar[int] = 0
    function: ClassVar[Callable] = staticmethod(line_point)

    def __post_init__(self):
        point = _vector(self.point, "point")
        direction = _unit(self.direction, "direction")
        object.__setattr__(self, "point", _as_tuple(point))
        object.__setattr__(self, "direction", _as_tuple(direction))
        object.__setattr__(self, "params", np.concatenate([point, direction]))

    def points_at(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)[:, None]
        return self.params[:3] + s * self.params[3:6]
