"""Paths to follow: the closest point, a rotation-minimising path frame and its curvatures.

A path is a compiled function ``fn(position, params) -> PathPoint`` (same signature for every path,
so a compiled simulation loop takes any of them, or a user's own, as an argument) plus a flat
``float64`` parameter array. For an end-effector position ``p`` [m] (world frame) it returns the
closest point of the path, its arc length ``s`` [m] and the path frame there.

Frame convention
----------------
The frame ``(T, N1, N2)`` (tangent, two normals; world frame) is right-handed, ``T x N1 = N2``
(equivalently ``N1 x N2 = T``), and rotation-minimising (parallel transported; Bishop 1975):

    dT/ds = k1 N1 + k2 N2,    dN1/ds = -k1 T,    dN2/ds = -k2 T,

with the normal-development curvatures ``k1``, ``k2`` [1/m] (``k1^2 + k2^2`` is the squared Frenet
curvature) and their rates ``dk1/ds``, ``dk2/ds`` [1/m^2]. Unlike the Frenet frame it is defined on
straight pieces and never flips where the curvature vanishes or changes sign. The cross-track errors
are the components of ``p - point`` along ``N1`` and ``N2`` [m].

Built-in paths (Python classes wrap the compiled functions; :data:`PATH_TYPES` is the registry used
by :func:`from_mapping` for scenario files):

* :class:`LinePath` / :func:`line_point` - straight line; ``N2`` = world up projected onto the normal
  plane, so on the world x-axis ``(T, N1, N2) = (x, y, z)`` exactly and the cross-track errors are
  exactly ``(p_y, p_z)`` (the paper's eq. 21);
* :class:`HelixPath` / :func:`helix_point` - circular helix, closest point by safeguarded Newton;
* :class:`WaypointPath` / :func:`waypoints_point` - polyline with circular-arc corner fillets.

References:
    R. L. Bishop, "There is more than one way to frame a curve", Amer. Math. Monthly 82(3), 1975.
    W. Wang, B. Juettler, D. Zheng, Y. Liu, "Computation of rotation minimizing frames", ACM Trans.
    Graphics 27(1), 2008 (rotation-minimising frames on arcs and helices).
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import numpy as np

from hydro.jit import compiled, interpreted

Vector3 = tuple[float, float, float]

#: A direction whose horizontal part is shorter than this (unit vector) counts as vertical [-].
VERTICAL_TOLERANCE = 1e-6


class PathPoint(NamedTuple):
    """The closest point of a path to a position, and the path frame there (world frame)."""

    s: float
    """Arc length of the closest point [m] (origin: see each path)."""
    point: Vector3
    """Closest point of the path [m]."""
    tangent: Vector3
    """Unit tangent ``T`` (direction of increasing ``s``) [-]."""
    normal1: Vector3
    """First normal ``N1`` of the rotation-minimising frame [-]."""
    normal2: Vector3
    """Second normal ``N2 = T x N1`` [-]."""
    curvature1: float
    """``k1 = (dT/ds) . N1`` [1/m]."""
    curvature2: float
    """``k2 = (dT/ds) . N2`` [1/m]."""
    curvature1_rate: float
    """``dk1/ds`` [1/m^2]."""
    curvature2_rate: float
    """``dk2/ds`` [1/m^2]."""


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


@compiled
def helix_point(position, params) -> PathPoint:
    """Closest point and rotation-minimising frame of a circular helix.

    The helix is ``c(phi) = centre + R (cos(phi) u + sin(phi) v) + b phi a`` with ``b = h / (2 pi)``
    [m/rad], ``v = a x u`` (right-handed about the axis ``a`` for a pitch ``h > 0``), arc length
    ``s = L phi`` with ``L = sqrt(R^2 + b^2)`` [m/rad], ``s = 0`` at ``centre + R u``.

    Closest point: ``(p - c).T = 0`` reads ``g(delta) = r R sin(delta) + b^2 delta - b d = 0`` in
    the angle ``delta = phi - phi0`` from the initial guess ``phi0`` = angle of ``p`` about the axis
    on the turn whose axial position is nearest to ``p``'s (``d = z - b phi0``, ``r`` = distance of
    ``p`` from the axis). ``g(-pi) <= 0 <= g(pi)`` and ``g`` is increasing wherever ``g(delta)`` can
    vanish inside, so the root in ``[-pi, pi]`` is unique and is the global nearest point (the
    minimum distance over a turn grows with ``|d|``). Newton's method on ``g`` is safeguarded by
    bisection on that bracket and converges to rounding (~1e-15 rad).

    Frame: Frenet curvature ``kappa = R / L^2``, torsion ``tau = b / L^2`` [1/m]; with the Frenet
    normal ``N`` (towards the axis) and binormal ``B = T x N``, the rotation-minimising frame is
    ``N1 = cos(tau s) N - sin(tau s) B``, ``N2 = sin(tau s) N + cos(tau s) B`` (so ``N2 = B`` =
    axis projected onto the normal plane at ``s = 0``), ``k1 = kappa cos(tau s)``,
    ``k2 = kappa sin(tau s)``, ``k1' = -kappa tau sin(tau s)``, ``k2' = kappa tau cos(tau s)``
    (Bishop 1975, Sec. 2: ``k1 + i k2 = kappa exp(i int tau ds)``).

    Args:
        position: Position ``p`` (3,) [m], world frame.
        params: ``(centre (3) [m], unit axis a (3), unit u (3), unit v = a x u (3), R [m], h [m])``.
    """
    cx, cy, cz = params[0], params[1], params[2]
    ax, ay, az = params[3], params[4], params[5]
    ux, uy, uz = params[6], params[7], params[8]
    vx, vy, vz = params[9], params[10], params[11]
    radius, pitch = params[12], params[13]
    b = pitch / (2.0 * math.pi)
    speed = math.sqrt(radius * radius + b * b)  # L = ds/dphi [m/rad]
    kappa = radius / (speed * speed)
    tau = b / (speed * speed)

    dx, dy, dz = position[0] - cx, position[1] - cy, position[2] - cz
    x = dx * ux + dy * uy + dz * uz
    y = dx * vx + dy * vy + dz * vz
    z = dx * ax + dy * ay + dz * az
    r = math.sqrt(x * x + y * y)
    phi0 = math.atan2(y, x)
    if b != 0.0:
        phi0 += 2.0 * math.pi * math.floor((z / b - phi0) / (2.0 * math.pi) + 0.5)
    d = z - b * phi0
    rr = r * radius
    b2 = b * b
    lo, hi = -math.pi, math.pi
    delta = 0.0
    for _ in range(100):
        g = rr * math.sin(delta) + b2 * delta - b * d
        if g > 0.0:
            hi = delta
        elif g < 0.0:
            lo = delta
        else:
            break
        slope = rr * math.cos(delta) + b2
        new = delta - g / slope if slope > 0.0 else 0.5 * (lo + hi)
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - delta) <= 1e-15:
            delta = new
            break
        delta = new
    phi = phi0 + delta
    s = speed * phi
    c, sn = math.cos(phi), math.sin(phi)
    # T = (-R sin u + R cos v + b a) / L ; N = -(cos u + sin v) ; B = (b sin u - b cos v + R a) / L
    tx = (-radius * sn * ux + radius * c * vx + b * ax) / speed
    ty = (-radius * sn * uy + radius * c * vy + b * ay) / speed
    tz = (-radius * sn * uz + radius * c * vz + b * az) / speed
    nx, ny, nz = -(c * ux + sn * vx), -(c * uy + sn * vy), -(c * uz + sn * vz)
    bx = (b * sn * ux - b * c * vx + radius * ax) / speed
    by = (b * sn * uy - b * c * vy + radius * ay) / speed
    bz = (b * sn * uz - b * c * vz + radius * az) / speed
    psi = b * phi / speed  # tau s [rad]
    cp, sp = math.cos(psi), math.sin(psi)
    return PathPoint(
        s,
        (
            cx + radius * (c * ux + sn * vx) + b * phi * ax,
            cy + radius * (c * uy + sn * vy) + b * phi * ay,
            cz + radius * (c * uz + sn * vz) + b * phi * az,
        ),
        (tx, ty, tz),
        (cp * nx - sp * bx, cp * ny - sp * by, cp * nz - sp * bz),
        (sp * nx + cp * bx, sp * ny + cp * by, sp * nz + cp * bz),
        kappa * cp,
        kappa * sp,
        -kappa * tau * sp,
        kappa * tau * cp,
    )


#: Piece kinds and the record layout of :func:`waypoints_point`'s parameters.
LINE_PIECE, ARC_PIECE = 0.0, 1.0
#: Floats per piece: kind, s_offset, sigma_lo, sigma_hi, origin/centre (3), direction/e0 (3),
#: e1 (3), N1 at sigma = 0 (3), N2 at sigma = 0 (3), radius, k1, k2, binormal w (3).
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


# --------------------------------------------------------------------------------------------
# Python classes
# --------------------------------------------------------------------------------------------


class PathError(ValueError):
    """A bad path parameter; ``str()`` is one line ``path.<key>: <problem>``."""

    def __init__(self, key: str, problem: str, where: str = "path"):
        self.key, self.problem = key, problem
        super().__init__(f"{where}.{key}: {problem}")


def _vector(value, key: str) -> np.ndarray:
    if isinstance(value, (str, bytes, bool)) or (
        isinstance(value, (list, tuple)) and any(isinstance(x, (str, bytes, bool)) for x in value)
    ):
        raise PathError(key, f"expected 3 numbers, got {value!r}")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise PathError(key, f"expected 3 numbers, got {value!r}") from None
    if array.shape != (3,):
        raise PathError(key, f"expected 3 numbers, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise PathError(key, "contains NaN or infinite values")
    return array


def _unit(value, key: str) -> np.ndarray:
    array = _vector(value, key)
    norm = float(np.linalg.norm(array))
    if norm == 0.0:
        raise PathError(key, "zero vector")
    return array / norm


def _number(value, key: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise PathError(key, f"expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise PathError(key, "must be finite")
    if positive and not number > 0.0:
        raise PathError(key, f"must be > 0, got {number:g}")
    return number


def _as_tuple(array: np.ndarray) -> Vector3:
    return tuple(float(x) for x in array)  # type: ignore[return-value]


def _position(position) -> np.ndarray:
    try:
        return np.ascontiguousarray(_vector(position, "position"))
    except PathError as error:
        raise ValueError(f"position: {error.problem}") from None


def _path_point(result) -> PathPoint:
    """A :class:`PathPoint` with plain floats, whatever the function returned (tuple or record)."""
    s, point, tangent, normal1, normal2, k1, k2, k1_rate, k2_rate = result
    return PathPoint(
        float(s),
        _as_tuple(point),
        _as_tuple(tangent),
        _as_tuple(normal1),
        _as_tuple(normal2),
        float(k1),
        float(k2),
        float(k1_rate),
        float(k2_rate),
    )


class Path(abc.ABC):
    """Common interface: a compiled function, its parameters, and conveniences around them.

    Subclasses are frozen dataclasses that fill :attr:`params` in ``__post_init__``, set
    :attr:`function` and :attr:`type_name`, and register in :data:`PATH_TYPES`.
    """

    type_name: ClassVar[str]
    function: ClassVar[Callable]
    params: np.ndarray

    def closest(self, position) -> PathPoint:
        """The path point closest to ``position`` (3,) [m] (world frame) and the frame there."""
        p = _position(position)
        return _path_point(self.function(p, self.params))

    def cross_track_error(self, position) -> np.ndarray:
        """Components of ``position - closest point`` along ``(N1, N2)`` (2,) [m]."""
        p = _position(position)
        q = _path_point(self.function(p, self.params))
        e = (p[0] - q.point[0], p[1] - q.point[1], p[2] - q.point[2])
        n1, n2 = q.normal1, q.normal2
        return np.array(
            [
                e[0] * n1[0] + e[1] * n1[1] + e[2] * n1[2],
                e[0] * n2[0] + e[1] * n2[1] + e[2] * n2[2],
            ]
        )

    @abc.abstractmethod
    def points_at(self, s) -> np.ndarray:
        """World points (n, 3) [m] at arc lengths ``s`` (n,) [m]."""

    def sample(self, s_range: float | tuple[float, float], n: int = 200) -> np.ndarray:
        """``n`` world points (n, 3) [m] evenly spaced in arc length, for drawing.

        Args:
            s_range: ``(s_min, s_max)`` [m], or a length ``L`` meaning ``(0, L)``.
            n: Number of points (>= 2).
        """
        if isinstance(s_range, (int, float)):
            s_min, s_max = 0.0, float(s_range)
        else:
            s_min, s_max = (float(x) for x in s_range)
        if not (math.isfinite(s_min) and math.isfinite(s_max) and s_max > s_min):
            raise ValueError(f"s_range: need finite s_min < s_max, got ({s_min:g}, {s_max:g})")
        if int(n) < 2:
            raise ValueError(f"n: need at least 2 points, got {n}")
        return self.points_at(np.linspace(s_min, s_max, int(n)))

    def describe(self) -> dict[str, Any]:
        """Type and parameters, JSON-friendly; :func:`from_mapping` rebuilds the path from it."""
        table: dict[str, Any] = {"type": self.type_name}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if f.init:
                value = getattr(self, f.name)
                table[f.name] = (
                    [list(v) if isinstance(v, tuple) else v for v in value]
                    if isinstance(value, tuple) and value and isinstance(value[0], tuple)
                    else list(value)
                    if isinstance(value, tuple)
                    else value
                )
        return table


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


def _perpendicular_reference(axis: np.ndarray) -> np.ndarray:
    """World x projected onto the plane normal to ``axis`` (world y if ``axis`` is within
    :data:`VERTICAL_TOLERANCE` of the x axis), normalised."""
    reference = np.array([1.0, 0.0, 0.0])
    if math.hypot(axis[1], axis[2]) < VERTICAL_TOLERANCE:
        reference = np.array([0.0, 1.0, 0.0])
    u = reference - (reference @ axis) * axis
    return u / np.linalg.norm(u)


@dataclass(frozen=True)
class HelixPath(Path):
    """Circular helix about ``axis`` through ``centre`` [m] with ``radius`` [m] and ``pitch``.

    ``pitch`` [m per turn] is the advance along ``axis`` per turn: > 0 right-handed about the axis,
    < 0 left-handed, 0 a circle. The start point (``s = 0``) is at ``start_angle`` [rad] about the
    axis from the reference direction ``u0`` = world x projected onto the plane normal to the axis
    (world y if the axis is along x); for the vertical axis ``(0, 0, 1)`` it is
    ``centre + radius (cos(start_angle), sin(start_angle), 0)``. At ``s = 0``, ``N2`` is the axis
    projected onto the normal plane. For a circle, ``s`` is in ``(-pi R, pi R]``.
    """

    centre: Vector3
    axis: Vector3
    radius: float
    pitch: float
    start_angle: float = 0.0
    params: np.ndarray = field(init=False, repr=False, compare=False)

    type_name: ClassVar[str] = "helix"
    function: ClassVar[Callable] = staticmethod(helix_point)

    def __post_init__(self):
        centre = _vector(self.centre, "centre")
        axis = _unit(self.axis, "axis")
        radius = _number(self.radius, "radius", positive=True)
        pitch = _number(self.pitch, "pitch")
        angle = _number(self.start_angle, "start_angle")
        u0 = _perpendicular_reference(axis)
        v0 = np.cross(axis, u0)
        u = math.cos(angle) * u0 + math.sin(angle) * v0
        v = np.cross(axis, u)
        for name, value in (
            ("centre", _as_tuple(centre)),
            ("axis", _as_tuple(axis)),
            ("radius", radius),
            ("pitch", pitch),
            ("start_angle", angle),
        ):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "params", np.concatenate([centre, axis, u, v, [radius, pitch]]))

    @property
    def curvature(self) -> float:
        """Frenet curvature ``R / (R^2 + b^2)``, ``b = pitch / (2 pi)`` [1/m]."""
        b = self.pitch / (2.0 * math.pi)
        return self.radius / (self.radius**2 + b * b)

    @property
    def torsion(self) -> float:
        """Torsion ``b / (R^2 + b^2)`` [1/m]."""
        b = self.pitch / (2.0 * math.pi)
        return b / (self.radius**2 + b * b)

    def points_at(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        c, a, u, v = (self.params[i : i + 3] for i in (0, 3, 6, 9))
        b = self.pitch / (2.0 * math.pi)
        phi = (s / math.hypot(self.radius, b))[:, None]
        return c + self.radius * (np.cos(phi) * u + np.sin(phi) * v) + b * phi * a


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


@dataclass(frozen=True, eq=False)
class UserPath(Path):
    """A user's own path: a compiled ``function(position, params) -> PathPoint`` (or any callable
    returning the same nine fields) and its parameter array.

    :meth:`points_at` (and so :meth:`sample`) marches along the path with ``function`` alone:
    from the path point nearest the origin, ``q <- closest(q + (s - s_q) T_q)`` until ``s_q = s``
    (steps limited to a quarter of the radius of curvature).
    """

    function: Callable  # type: ignore[misc]
    params: np.ndarray

    type_name: ClassVar[str] = "user"

    def __post_init__(self):
        if not callable(self.function):
            raise PathError("function", f"expected a callable, got {self.function!r}")
        try:
            params = np.ascontiguousarray(self.params, dtype=np.float64)
        except (TypeError, ValueError):
            raise PathError("params", "expected an array of numbers") from None
        if params.ndim != 1 or not np.isfinite(params).all():
            raise PathError("params", "expected a 1-D array of finite numbers")
        object.__setattr__(self, "params", params)

    def points_at(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        out = np.empty((len(s), 3))
        q = self.closest(np.zeros(3))
        for i in np.argsort(s):
            for _ in range(1000):
                gap = s[i] - q.s
                if abs(gap) <= 1e-9 * max(1.0, abs(s[i])):
                    break
                curvature = math.hypot(q.curvature1, q.curvature2)
                step = (
                    gap if curvature == 0.0 else math.copysign(min(abs(gap), 0.25 / curvature), gap)
                )
                q = self.closest(np.add(q.point, np.multiply(step, q.tangent)))
            out[i] = q.point
        return out

    def describe(self) -> dict[str, Any]:
        name = getattr(self.function, "__qualname__", None) or repr(self.function)
        module = getattr(self.function, "__module__", "")
        return {"type": "user", "function": f"{module}.{name}", "params": self.params.tolist()}


#: Path types buildable from a scenario table by :func:`from_mapping` (``type`` key -> class).
PATH_TYPES: dict[str, type[Path]] = {
    "line": LinePath,
    "helix": HelixPath,
    "waypoints": WaypointPath,
}


def from_mapping(table: Mapping[str, Any], where: str = "path") -> Path:
    """Build a path from a scenario-file table such as ``{"type": "line", "point": [0, 0, 0],
    "direction": [1, 0, 0]}``; the keys are the class's constructor arguments.

    Raises:
        ValueError: one line naming the key (``path.helix.radius: must be > 0, got 0``): not a
            table, missing or unknown ``type``, unknown or missing key, wrong type, degenerate
            geometry.
    """
    if not isinstance(table, Mapping):
        raise ValueError(f"{where}: expected a table, got {type(table).__name__}")
    if "type" not in table:
        raise ValueError(f"{where}.type: missing (one of {', '.join(PATH_TYPES)})")
    name = table["type"]
    if not isinstance(name, str) or name not in PATH_TYPES:
        raise ValueError(
            f"{where}.type: unknown path type {name!r} (one of {', '.join(PATH_TYPES)})"
        )
    cls = PATH_TYPES[name]
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    prefix = f"{where}.{name}"
    for key in table:
        if key != "type" and key not in fields:
            raise ValueError(f"{prefix}.{key}: unknown key (expected {', '.join(fields)})")
    for key, f in fields.items():
        if key not in table and f.default is dataclasses.MISSING:
            raise ValueError(f"{prefix}.{key}: missing")
    arguments = {key: value for key, value in table.items() if key != "type"}
    for key, value in arguments.items():
        if isinstance(value, str):
            raise ValueError(f"{prefix}.{key}: expected numbers, got the string {value!r}")
    try:
        return cls(**arguments)
    except PathError as error:
        raise PathError(error.key, error.problem, where=prefix) from None


__all__ = [
    "PATH_TYPES",
    "PIECE_STRIDE",
    "VERTICAL_TOLERANCE",
    "HelixPath",
    "LinePath",
    "Path",
    "PathError",
    "PathPoint",
    "UserPath",
    "WaypointPath",
    "from_mapping",
    "helix_point",
    "line_frame",
    "line_point",
    "waypoints_point",
]
