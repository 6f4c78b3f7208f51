"""Lift and drag of fins (control surfaces), written once for every backend.

The law is the quadratic-coefficient model of UUV Simulator's fin plugin and gz-sim's LiftDrag
system, on the velocity of the fin's centre of pressure relative to the water projected on the
plane normal to the fin's span axis:

* UUV Simulator (uuvsimulator/uuv_simulator, commit bfb40cb, uuv_gazebo_plugins/uuv_gazebo_plugins/
  src/FinPlugin.cc lines 169-177: the velocity relative to the current, projected on the plane
  normal to the fin link's z (span) axis, ``ldNormal x (vel x ldNormal)``; src/LiftDragModel.cc
  lines 110-139, ``LiftDragQuadratic::compute``: ``angle = atan2(v_y, v_x)`` of that velocity in
  the fin frame (x the chord), folded into ``[-pi/2, pi/2]``, lift ``lift_constant * angle * u^2``
  along ``-z x v / |z x v|``, drag ``drag_constant * angle^2 * u^2`` along ``-v``); its
  ``lift_constant`` is ``0.5 rho A C_L_alpha`` and ``drag_constant`` ``0.5 rho A C_D_alpha2`` (LAUV's
  uuvsimulator/lauv_gazebo lauv_description/urdf/snippets.xacro lines 112-127 build them so).
* gz-sim (gazebosim/gz-sim, commit 01d9d94, src/systems/lift_drag/LiftDrag.cc,
  ``LiftDragPrivate::Update``): the same projection (``velInLDPlane = vel - (vel . span) span``),
  lift along ``span x velInLDPlane``, drag along ``-velInLDPlane``, dynamic pressure
  ``0.5 rho |velInLDPlane|^2``, and the stall branch ``cl = cla alpha_stall + cla_stall (alpha -
  alpha_stall)`` beyond ``alpha_stall``.

Our form (the fin frame: span axis ``a``, chord ``c(delta) = cos(delta) c + sin(delta) a x c`` at
fin angle ``delta``; ``v`` the point's velocity relative to the water, ``v_p = v - (v . a) a``, ``U =
|v_p|``):

* angle of attack ``alpha`` = the angle from ``v_p`` to ``c(delta)`` about ``a`` (right-hand rule),
  folded into ``[-pi/2, pi/2]`` (a flat plate met from behind; both plugins fold so);
* ``C_L = C_L_alpha alpha`` for ``|alpha| <= alpha_stall``, else ``C_L_alpha alpha_stall sign(alpha)``
  (gz-sim's stall branch with ``cla_stall = 0``: the lift stays at its stall value; UUV Simulator's
  ``Quadratic`` has no stall, ``stall_angle = inf``);
* ``C_D = C_D0 + C_D_alpha2 alpha^2`` (UUV Simulator's ``Quadratic`` with ``C_D0 = 0``);
* force ``F = 0.5 rho A U (C_L a x v_p - C_D v_p)``: lift ``0.5 rho A C_L U^2`` along ``a x v_p / U``,
  drag ``0.5 rho A C_D U^2`` against ``v_p``; zero at zero speed (no direction is needed).

Signs: a fin moving along its chord (``v_p`` along ``c``) with a positive angle ``delta`` has
``alpha = delta > 0`` and its lift along ``a x c``; e.g. a rudder with ``a = +z`` and ``c = +x`` at
the tail of a vehicle moving along ``+x`` pushes the tail to ``+y`` (port), and the vehicle turns
to starboard (negative yaw rate about the up axis ``z``). UUV Simulator's angle is ``-alpha`` and
its lift direction ``-(a x v_p)``, so its force is the same.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_hydro.laws.fluid_terms import current_in_body
from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import cross3


class FinModel(NamedTuple):
    """The fins of a vehicle, packed for :func:`add_fin_wrenches` (``nf`` fins).

    Attributes:
        body: Body (Pinocchio joint - 1) carrying each fin (nf,).
        position: Centre of pressure in the body frame (nf, 3) [m].
        axis: Unit span axis in body axes (nf, 3).
        chord: Unit chord at zero angle in body axes (nf, 3).
        half_rho_area: ``0.5 rho A`` (nf,) [kg/m].
        lift_slope: ``C_L_alpha`` (nf,) [1/rad].
        drag_zero: ``C_D0`` (nf,).
        drag_slope: ``C_D_alpha2`` (nf,) [1/rad^2].
        stall_angle: ``alpha_stall`` (nf,) [rad] (``inf``: none).
        max_angle: Angle limits [rad] (nf,).
        max_rate: Rate limits [rad/s] (nf,) (``inf``: none).
        time_constant: First-order lags of the angle [s] (nf,) (0: none).
    """

    body: np.ndarray
    position: np.ndarray
    axis: np.ndarray
    chord: np.ndarray
    half_rho_area: np.ndarray
    lift_slope: np.ndarray
    drag_zero: np.ndarray
    drag_slope: np.ndarray
    stall_angle: np.ndarray
    max_angle: np.ndarray
    max_rate: np.ndarray
    time_constant: np.ndarray


def no_fins() -> FinModel:
    """A :class:`FinModel` with no fins (the right array types for the compiled kernels)."""
    return FinModel(
        np.zeros(0, dtype=np.int64),
        np.zeros((0, 3)),
        np.zeros((0, 3)),
        np.zeros((0, 3)),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
        np.zeros(0),
    )


@compiled
def angle_of_attack(delta, a0, a1, a2, c0, c1, c2, v0, v1, v2):
    """Angle of attack ``alpha`` [rad] in ``[-pi/2, pi/2]`` and the in-plane velocity ``v_p`` (3 floats).

    Args:
        delta: Fin angle about the span axis [rad].
        a0, a1, a2: Unit span axis ``a``.
        c0, c1, c2: Unit chord at zero angle ``c`` (perpendicular to ``a``).
        v0, v1, v2: Velocity of the centre of pressure relative to the water [m/s] (same axes).
    """
    along = v0 * a0 + v1 * a1 + v2 * a2
    p0, p1, p2 = v0 - along * a0, v1 - along * a1, v2 - along * a2
    n0, n1, n2 = cross3(a0, a1, a2, c0, c1, c2)
    cd, sd = math.cos(delta), math.sin(delta)
    k0, k1, k2 = cd * c0 + sd * n0, cd * c1 + sd * n1, cd * c2 + sd * n2  # c(delta)
    x0, x1, x2 = cross3(p0, p1, p2, k0, k1, k2)
    alpha = math.atan2(a0 * x0 + a1 * x1 + a2 * x2, p0 * k0 + p1 * k1 + p2 * k2)
    if alpha > 0.5 * math.pi:  # met from behind: the plate's other edge leads
        alpha -= math.pi
    elif alpha < -0.5 * math.pi:
        alpha += math.pi
    return alpha, p0, p1, p2


@compiled
def fin_force(
    delta,
    a0,
    a1,
    a2,
    c0,
    c1,
    c2,
    v0,
    v1,
    v2,
    half_rho_area,
    lift_slope,
    drag_zero,
    drag_slope,
    stall_angle,
):
    """Lift plus drag on a fin, ``0.5 rho A U (C_L a x v_p - C_D v_p)`` [N] (3 floats, the axes of ``a``).

    Args:
        delta: Fin angle [rad].
        a0, a1, a2: Unit span axis.
        c0, c1, c2: Unit chord at zero angle.
        v0, v1, v2: Velocity of the centre of pressure relative to the water [m/s].
        half_rho_area: ``0.5 rho A`` [kg/m].
        lift_slope: ``C_L_alpha`` [1/rad].
        drag_zero: ``C_D0``.
        drag_slope: ``C_D_alpha2`` [1/rad^2].
        stall_angle: ``alpha_stall`` [rad] (``inf``: no stall).
    """
    alpha, p0, p1, p2 = angle_of_attack(delta, a0, a1, a2, c0, c1, c2, v0, v1, v2)
    if alpha > stall_angle:
        lift = lift_slope * stall_angle
    elif alpha < -stall_angle:
        lift = -lift_slope * stall_angle
    else:
        lift = lift_slope * alpha
    drag = drag_zero + drag_slope * alpha * alpha
    speed = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
    l0, l1, l2 = cross3(a0, a1, a2, p0, p1, p2)
    scale = half_rho_area * speed
    return (
        scale * (lift * l0 - drag * p0),
        scale * (lift * l1 - drag * p1),
        scale * (lift * l2 - drag * p2),
    )


@compiled(borrows_only=True)
def add_fin_wrenches(fins, angles, rotation, twist, current, bias):
    """Subtract every fin's wrench from ``bias`` (left-hand side, body axes, about the body origin).

    The fin at ``r`` on body ``b`` sees ``v = v_b + omega_b x r - R_b^T V_c`` (the body's current
    sample ``V_c``, as the other fluid terms of the body); its force ``F`` (:func:`fin_force`) acts
    at ``r``: wrench ``(F, r x F)``.

    Args:
        fins: The vehicle's :class:`FinModel`.
        angles: Fin angles [rad] (nf,).
        rotation: Body-to-world rotations (nb, 3, 3).
        twist: Body twists in body axes (nb, 6) [m/s, rad/s].
        current: Water velocity at each body's probe point, world axes (nb, 3) [m/s].
        bias: Accumulator (nb, 6) [N, N m].
    """
    body, position, axis, chord = fins.body, fins.position, fins.axis, fins.chord
    half_rho_area, lift_slope = fins.half_rho_area, fins.lift_slope
    drag_zero, drag_slope, stall = fins.drag_zero, fins.drag_slope, fins.stall_angle
    for k in range(body.shape[0]):
        b = body[k]
        r0, r1, r2 = position[k, 0], position[k, 1], position[k, 2]
        w0, w1, w2 = cross3(twist[b, 3], twist[b, 4], twist[b, 5], r0, r1, r2)
        c0, c1, c2 = current_in_body(rotation, current, b)
        v0, v1, v2 = twist[b, 0] + w0 - c0, twist[b, 1] + w1 - c1, twist[b, 2] + w2 - c2
        f0, f1, f2 = fin_force(
            angles[k],
            axis[k, 0],
            axis[k, 1],
            axis[k, 2],
            chord[k, 0],
            chord[k, 1],
            chord[k, 2],
            v0,
            v1,
            v2,
            half_rho_area[k],
            lift_slope[k],
            drag_zero[k],
            drag_slope[k],
            stall[k],
        )
        n0, n1, n2 = cross3(r0, r1, r2, f0, f1, f2)
        bias[b, 0] -= f0
        bias[b, 1] -= f1
        bias[b, 2] -= f2
        bias[b, 3] -= n0
        bias[b, 4] -= n1
        bias[b, 5] -= n2
