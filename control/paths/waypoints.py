"""Waypoint path (:mod:`aiauv_control.paths`): a polyline with circular-arc corner fillets."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from aiauv_control.paths.base import (
    Path,
    PathError,
    PathPoint,
    Vector3,
    _as_tuple,
    _number,
    _vector,
)
from aiauv_control.paths.line import line_frame
from aiauv_hydro.numerics.jit import compiled, interpreted

LINE_PIECE, ARC_PIECE = 0.0, 1.0
PIECE_STRIDE = 25
#: Header of :func:`waypoints_point`'s parameters: number of pieces, stride.
WAYPOINTS_HEADER = 2


@compiled
def _rotate(vx, vy, vz, wx, wy, wz, c, s):
    """Rodrigues: ``v`` rotated about the unit axis ``w`` by the angle with cosine ``c``, sine
    ``s``: ``v c + (w x v) s + w (w . v)(1 - c)``."""
    wv = wx * vx + wy * vy + wz * vz
    return (
        vx * c + (wy * vz - wz * vy) * s + wx * wv * (1.0 - c),
        vy * c + (wz * vx - wx * vz) * s + wy * wv * (1.0 - c),
        vz * c + (wx * vy - wy * vx) * s + wz * wv * (1.0 - c),
    )


@compiled
def waypoints_point(position, params) -> PathPoint:
    """Closest point and transported frame of a polyline with circular-arc corner fillets.

    The path is a sequence of pieces, each a record of :data:`PIECE_STRIDE` floats after a header
    ``(number of pieces, stride)``, built by :class:`WaypointPath`. A line piece is
    ``origin + sigma d``, ``sigma`` in ``[lo, hi]`` (``lo = -inf`` on the first piece, ``hi = +inf``
    on the last: the path continues along its end segments). An arc piece of radius ``rho`` is
    ``centre + rho (cos(theta) e0 + sin(theta) e1)``, ``theta = sigma / rho`` in ``[0, hi / rho]``;
    its frame is the start frame rotated rigidly about the binormal ``w = e0 x e1`` by ``theta``,
    which is rotation-minimising (``dN/ds = (w x N) / rho`` is along ``T`` for every ``N`` normal
    to ``T``), so ``k1``, ``k2`` are constant on an arc, zero on a line, and their rates are zero.

    The result is the global nearest point over all pieces (first piece on ties); ``s`` = arc
    length from the first waypoint.

    Args:
        position: Position ``p`` (3,) [m], world frame.
        params: Header and flat piece records (:data:`PIECE_STRIDE`), built by :class:`WaypointPath`.
    """
    count = int(params[0])
    stride = int(params[1])
    px, py, pz = position[0], position[1], position[2]
    best = 0
    best_sigma = 0.0
    best_distance = math.inf
    for i in range(count):
        k = WAYPOINTS_HEADER + i * stride
        lo, hi = params[k + 2], params[k + 3]
        ox, oy, oz = params[k + 4], params[k + 5], params[k + 6]
        if params[k] == LINE_PIECE:
            sigma = (
                (px - ox) * params[k + 7] + (py - oy) * params[k + 8] + (pz - oz) * params[k + 9]
            )
            sigma = min(max(sigma, lo), hi)
            qx = ox + sigma * params[k + 7]
            qy = oy + sigma * params[k + 8]
            qz = oz + sigma * params[k + 9]
            distance = (px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2
        else:
            rho = params[k + 19]
            dx, dy, dz = px - ox, py - oy, pz - oz
            x = dx * params[k + 7] + dy * params[k + 8] + dz * params[k + 9]
            y = dx * params[k + 10] + dy * params[k + 11] + dz * params[k + 12]
            theta_end = hi / rho
            theta = math.atan2(y, x)
            if theta < 0.0 or theta > theta_end:  # nearer arc end
                d0 = (x - rho) ** 2 + y * y
                d1 = (x - rho * math.cos(theta_end)) ** 2 + (y - rho * math.sin(theta_end)) ** 2
                theta = 0.0 if d0 <= d1 else theta_end
            sigma = rho * theta
            # squared distance = |p - c|^2 - (in-plane radius)^2 + (in-plane radius - rho)^2 ...
            # written directly: in-plane part relative to the arc point, plus the out-of-plane part
            ex = x - rho * math.cos(theta)
            ey = y - rho * math.sin(theta)
            out_of_plane = dx * dx + dy * dy + dz * dz - x * x - y * y
            distance = ex * ex + ey * ey + max(out_of_plane, 0.0)
        if distance < best_distance:
            best_distance = distance
            best = i
            best_sigma = sigma
    k = WAYPOINTS_HEADER + best * stride
    sigma = best_sigma
    s = params[k + 1] + sigma
    ox, oy, oz = params[k + 4], params[k + 5], params[k + 6]
    n1x, n1y, n1z = params[k + 13], params[k + 14], params[k + 15]
    n2x, n2y, n2z = params[k + 16], params[k + 17], params[k + 18]
    if params[k] == LINE_PIECE:
        tx, ty, tz = params[k + 7], params[k + 8], params[k + 9]
        return PathPoint(
            s,
            (ox + sigma * tx, oy + sigma * ty, oz + sigma * tz),
            (tx, ty, tz),
            (n1x, n1y, n1z),
            (n2x, n2y, n2z),
            0.0,
            0.0,
            0.0,
            0.0,
        )
    rho = params[k + 19]
    theta = sigma / rho
    c, sn = math.cos(theta), math.sin(theta)
    e0x, e0y, e0z = params[k + 7], params[k + 8], params[k + 9]
    e1x, e1y, e1z = params[k + 10], params[k + 11], params[k + 12]
    wx, wy, wz = params[k + 22], params[k + 23], params[k + 24]
    return PathPoint(
        s,
        (
            ox + rho * (c * e0x + sn * e1x),
            oy + rho * (c * e0y + sn * e1y),
            oz + rho * (c * e0z + sn * e1z),
        ),
        (-sn * e0x + c * e1x, -sn * e0y + c * e1y, -sn * e0z + c * e1z),
        _rotate(n1x, n1y, n1z, wx, wy, wz, c, sn),
        _rotate(n2x, n2y, n2z, wx, wy, wz, c, sn),
        params[k + 20],
        params[k + 21],
        0.0,
        0.0,
    )


#: Turns smaller than this [rad] get no fillet (the segments are collinear).
COLLINEAR_TOLERANCE = 1e-12


@dataclass(frozen=True)
class WaypointPath(Path):
    """Polyline through ``points`` [m] (>= 2) with circular-arc fillets of ``corner_radius`` [m].

    At each interior waypoint ``points[i]`` the corner is cut by the arc of radius
    ``corner_radius`` tangent to both segments, in their plane; it starts ``corner_radius *
    tan(turn / 2)`` before the waypoint. Before the first and after the last waypoint the path
    continues along the first/last segment, so two waypoints make a line (same frame as
    :class:`LinePath`). ``s = 0`` at ``points[0]``. The frame starts as :class:`LinePath`'s on the
    first segment, stays constant on lines and rotates rigidly about each arc's binormal: it is
    continuous, but the curvature is piecewise constant, so anything depending on it (e.g. the
    second derivative of an LOS reference) jumps at the arc ends, listed in :attr:`breakpoints`.
    """

    points: tuple[Vector3, ...]
    corner_radius: float = 1.0
    params: np.ndarray = field(init=False, repr=False, compare=False)
    breakpoints: tuple[float, ...] = field(init=False, repr=False, compare=False)

    type_name: ClassVar[str] = "waypoints"
    kind_code: ClassVar[int] = 2
    function: ClassVar[Callable] = staticmethod(waypoints_point)

    def __post_init__(self):
        try:
            raw = [list(p) for p in self.points]
        except TypeError:
            raise PathError("points", "expected a list of [x, y, z] waypoints") from None
        points = np.array([_vector(p, f"points[{i}]") for i, p in enumerate(raw)])
        rho = _number(self.corner_radius, "corner_radius", positive=True)
        if len(points) < 2:
            raise PathError("points", "need at least 2 distinct waypoints")
        segments = np.diff(points, axis=0)
        lengths = np.linalg.norm(segments, axis=1)
        for i, length in enumerate(lengths):
            if length == 0.0:
                raise PathError("points", f"waypoints {i} and {i + 1} coincide")
        directions = segments / lengths[:, None]
        tangent_lengths = np.zeros(len(points))
        turns = np.zeros(len(points))
        for i in range(1, len(points) - 1):
            cosine = float(np.clip(directions[i - 1] @ directions[i], -1.0, 1.0))
            turns[i] = math.atan2(
                np.linalg.norm(np.cross(directions[i - 1], directions[i])), cosine
            )
            if math.pi - turns[i] < 1e-9:
                raise PathError("points", f"the path reverses at waypoint {i} (turn of 180 deg)")
            tangent_lengths[i] = rho * math.tan(turns[i] / 2.0)
        for j, length in enumerate(lengths):
            needed = tangent_lengths[j] + tangent_lengths[j + 1]
            if needed > length * (1.0 + 1e-12):
                corner = j if tangent_lengths[j] >= tangent_lengths[j + 1] else j + 1
                raise PathError(
                    "corner_radius",
                    f"corner at waypoint {corner} does not fit (needs {needed:.3g} m, "
                    f"segment {j}-{j + 1} has {length:.3g} m)",
                )
        object.__setattr__(self, "points", tuple(_as_tuple(p) for p in points))
        object.__setattr__(self, "corner_radius", rho)

        records: list[np.ndarray] = []
        n1, n2 = (np.array(n) for n in interpreted(line_frame)(*directions[0]))
        s = 0.0
        origin = points[0]
        last = len(points) - 2
        for j in range(len(lengths)):
            d = directions[j]
            # line from origin (tangent point after corner j, or points[0]) to the next corner
            lo = -math.inf if j == 0 else 0.0
            end = lengths[j] - tangent_lengths[j + 1] - (0.0 if j == 0 else tangent_lengths[j])
            hi = math.inf if j == last else end
            records.append(_piece(LINE_PIECE, s, lo, hi, origin, d, np.zeros(3), n1, n2))
            s += end
            if j == last or turns[j + 1] < COLLINEAR_TOLERANCE:
                origin = origin + end * d
                continue
            # arc at waypoint j + 1, from the tangent point A with the frame (d, n1, n2)
            start = points[j + 1] - tangent_lengths[j + 1] * d
            inward = directions[j + 1] - (directions[j + 1] @ d) * d
            inward /= np.linalg.norm(inward)
            centre = start + rho * inward
            e0, e1 = -inward, d
            w = np.cross(e0, e1)
            angle = turns[j + 1]
            arc = _piece(ARC_PIECE, s, 0.0, rho * angle, centre, e0, e1, n1, n2, rho, w)
            arc[20], arc[21] = inward @ n1 / rho, inward @ n2 / rho  # k = (dT/ds) . N
            records.append(arc)
            s += rho * angle
            rotate = interpreted(_rotate)
            c, sn = math.cos(angle), math.sin(angle)
            n1 = np.array(rotate(*n1, *w, c, sn))
            # re-orthonormalise against the next segment's direction (rounding only)
            d_next = directions[j + 1]
            n1 -= (n1 @ d_next) * d_next
            n1 /= np.linalg.norm(n1)
            n2 = np.cross(d_next, n1)
            origin = points[j + 1] + tangent_lengths[j + 1] * d_next
        header = np.array([float(len(records)), float(PIECE_STRIDE)])
        object.__setattr__(self, "params", np.concatenate([header, *records]))
        bounds = [r[1] + r[3] for r in records[:-1]]
        object.__setattr__(self, "breakpoints", tuple(float(b) for b in bounds))

    def points_at(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        out = np.empty((len(s), 3))
        count = int(self.params[0])
        records = self.params[WAYPOINTS_HEADER:].reshape(count, PIECE_STRIDE)
        starts = np.array([r[1] + r[2] for r in records])
        index = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, count - 1)
        for i, (si, k) in enumerate(zip(s, index, strict=True)):
            r = records[k]
            sigma = si - r[1]
            if r[0] == LINE_PIECE:
                out[i] = r[4:7] + sigma * r[7:10]
            else:
                theta = sigma / r[19]
                out[i] = r[4:7] + r[19] * (math.cos(theta) * r[7:10] + math.sin(theta) * r[10:13])
        return out


def _piece(kind, s, lo, hi, origin, a, b, n1, n2, radius=0.0, w=(0.0, 0.0, 0.0)) -> np.ndarray:
    record = np.zeros(PIECE_STRIDE)
    record[0:4] = kind, s, lo, hi
    record[4:7], record[7:10], record[10:13] = origin, a, b
    record[13:16], record[16:19] = n1, n2
    record[19] = radius
    record[22:25] = w
    return record
