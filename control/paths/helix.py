"""Circular helix (:mod:`aiauv_control.paths`): closest point by safeguarded Newton, rotating frame.

The frame is the Frenet frame turned by ``-tau s`` (rotation-minimising).
"""

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
    _number,
    _unit,
    _vector,
)
from aiauv_hydro.numerics.jit import compiled


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
#: Floats per piece: kind, s_offset, sigma_lo, sigma_hi, origin/centre (3), direction/e0 (3),
#: e1 (3), N1 at sigma = 0 (3), N2 at sigma = 0 (3), radius, k1, k2, binormal w (3).


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
    kind_code: ClassVar[int] = 1
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
