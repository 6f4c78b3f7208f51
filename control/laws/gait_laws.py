"""Serpentine swimming gaits and their path following, written once for every backend.

Underwater snake robots swim without thrusters by undulating the body. The gait laws here are those
of Kelasidi, Liljeback, Pettersen and Gravdahl, "Integral line-of-sight guidance for path following
control of underwater snake robots: theory and experiments", IEEE Trans. Robotics 33(3), 2017
(called *Kelasidi 2017* below), and of Kelasidi et al., "Innovation in underwater robots:
biologically inspired swimming snake robots", IEEE Robotics & Automation Magazine 23(1), March 2016:

* the serpenoid joint references (:func:`serpenoid_reference`), for joint ``i = 1 .. n - 1``
  counted from the tail of an ``n``-link snake,

      phi_i(t) = alpha g(i) sin(omega t + (i - 1) delta) + phi_0,

  with amplitude ``alpha`` [rad], angular frequency ``omega`` [rad/s], phase offset ``delta``
  [rad] between neighbouring joints, offset ``phi_0`` [rad] and the head-to-tail envelope ``g(i)``
  (:func:`gait_envelope`): ``g(i) = 1`` for lateral undulation, ``g(i) = (n - i) / (n + 1)`` for
  eel-like motion (amplitude growing from head to tail);
* the directional (heading) controller (:func:`heading_offset`): the offset steers the snake,
  ``phi_0 = k_theta (theta_bar - theta_ref)`` saturated at ``phi_0_max``, with ``theta_bar`` the
  snake's mean heading [rad] and ``theta_ref`` the LOS heading: a proportional heading law on the
  offset, of the form of Kelasidi 2017's directional controller (their model-based controller
  adds feedforward terms in the reference's derivatives, not used here; we have not checked our
  form against their equation numbers). Joint angles as we read their convention,
  ``phi_i = theta_i - theta_{i+1}`` (link ``i`` behind link ``i + 1``): a positive offset turns the
  snake towards smaller heading (the path-following tests check that the snake turns towards
  ``theta_ref``);
* the LOS and integral LOS heading reference (Kelasidi 2017, after Borhaug et al. 2008):
  ``theta_ref = -atan((p_y + sigma y_int) / Delta)`` on the x-axis, ``y_int_dot = Delta p_y /
  ((p_y + sigma y_int)^2 + Delta^2)``, with lookahead distance ``Delta`` [m]. On our paths (line,
  helix, waypoints, :mod:`aiauv_control.paths`) it is the project's path-parametrised LOS
  (:func:`aiauv_control.laws.paper_laws.biased_los_guidance` and
  :func:`~aiauv_control.laws.paper_laws.integral_los_bias` with ``u_d = 1`` and ``k = 1 / Delta``,
  which is Kelasidi's law on the x-axis), projected on the horizontal plane.

A joint's reference in the project's convention (a positive angle turns the head-ward link
counter-clockwise about the joint axis, ``q_j = theta_{j+1} - theta_j``) is ``-phi_i`` times the
joint axis's sign (:func:`gait_command`). The heading ``theta_bar`` the law takes is the direction
of the mass-weighted mean of the links' x-axes in the horizontal plane (Kelasidi's mean of the
link angles for equal links; measured by :mod:`aiauv_pin.controllers.gait_compiled`).

No fast-math: the saturations take the same decisions compiled and interpreted.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_control.laws.paper_laws import (
    biased_los_guidance,
    cross_track_errors,
    integral_los_bias,
    normal_plane_turn_rate,
    surge_pi,
)
from aiauv_control.paths import path_point_of
from aiauv_hydro.numerics.jit import compiled

#: Envelope codes of :func:`gait_envelope`: lateral undulation ``g(i) = 1``, eel-like motion
#: ``g(i) = (n - i) / (n + 1)`` (Kelasidi 2017).
LATERAL_UNDULATION, EEL_LIKE = 0, 1
#: The gaits by name, as scenario files and the Python API spell them.
GAIT_KINDS = {"lateral_undulation": LATERAL_UNDULATION, "eel_like": EEL_LIKE}
#: Joint roles in :func:`gait_command`: held straight (a pitch joint), undulating (a yaw joint).
STRAIGHT_JOINT = 0


@compiled
def gait_envelope(kind, i, n):
    """Head-to-tail amplitude envelope ``g(i)`` [-] of joint ``i`` (1 at the tail) of an ``n``-link
    snake: 1 for lateral undulation, ``(n - i) / (n + 1)`` for eel-like motion (Kelasidi 2017)."""
    if kind == EEL_LIKE:
        return (n - i) / (n + 1.0)
    return 1.0


@compiled
def serpenoid_reference(t, amplitude, omega, delta, offset, envelope, i):
    """``phi_i(t) = alpha g(i) sin(omega t + (i - 1) delta) + phi_0`` [rad] (Kelasidi 2017).

    Args:
        t: Time [s].
        amplitude: ``alpha`` [rad].
        omega: Angular frequency [rad/s].
        delta: Phase offset between neighbouring joints [rad].
        offset: ``phi_0`` [rad].
        envelope: ``g(i)`` [-] (:func:`gait_envelope`).
        i: Joint index from the tail, 1-based.
    """
    return amplitude * envelope * math.sin(omega * t + (i - 1) * delta) + offset


@compiled
def wrap_angle(angle):
    """``angle`` wrapped into ``[-pi, pi)`` [rad]."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@compiled
def heading_offset(heading, heading_ref, k_theta, max_offset):
    """Gait offset ``phi_0 = sat(k_theta (theta_bar - theta_ref))`` [rad], saturated at
    ``+-max_offset`` (a proportional heading law of the form of Kelasidi 2017's directional
    controller; sign convention in the module docstring). The heading error is wrapped into
    ``[-pi, pi)``.

    Args:
        heading: Mean heading ``theta_bar`` [rad].
        heading_ref: LOS heading ``theta_ref`` [rad].
        k_theta: Gain [-].
        max_offset: Saturation [rad].
    """
    offset = k_theta * wrap_angle(heading - heading_ref)
    return min(max(offset, -max_offset), max_offset)


class GaitGains(NamedTuple):
    """Parameters of :func:`gait_command` as plain numbers."""

    kind: int  # LATERAL_UNDULATION or EEL_LIKE
    amplitude: float  # alpha [rad]
    omega: float  # angular frequency [rad/s]
    delta: float  # phase offset between neighbouring joints [rad]
    k_theta: float  # heading gain [-]
    max_offset: float  # saturation of phi_0 [rad]
    lookahead: float  # LOS lookahead distance Delta [m]
    integral: bool  # integral LOS (Kelasidi 2017) instead of LOS
    sigma: float  # integral gain of the integral LOS [-]
    surge: bool  # combined mode: the X thrusters push with the surge PI (eq. 25 of the paper)
    u_d: float  # desired speed of the combined mode [m/s]
    k_1p: float  # surge PI [N s/m]
    k_1i: float  # surge PI [N/m]
    max_thrust: float  # per thruster [N]


class GaitBuffers(NamedTuple):
    """Outputs of :func:`gait_command`, written in place."""

    joint_references: np.ndarray  # (n,) [rad]
    thrusts: np.ndarray  # (m,) [N]
    offset: np.ndarray  # (1,) phi_0 [rad], Kelasidi's sign
    heading_ref: np.ndarray  # (1,) theta_ref [rad]
    cross_track: np.ndarray  # (2,) [m] along N1, N2
    path_s: np.ndarray  # (1,) path parameter [m]


def new_gait_buffers(n_joints: int, n_thrusters: int) -> GaitBuffers:
    """Zeroed :class:`GaitBuffers`."""
    return GaitBuffers(
        np.zeros(n_joints),
        np.zeros(n_thrusters),
        np.zeros(1),
        np.zeros(1),
        np.zeros(2),
        np.zeros(1),
    )


@compiled(borrows_only=True)
def gait_command(
    gains,
    path_function,
    path_kind,
    path_parameters,
    tail_index,
    joint_sign,
    n_links,
    surge_mask,
    surge_state,
    guidance_state,
    t,
    position,
    velocity,
    heading,
    surge_velocity,
    out,
):
    """One evaluation of the steered serpentine gait into ``out`` (see the module docstring).

    Args:
        gains: :class:`GaitGains`.
        path_function, path_kind, path_parameters: The path (:mod:`aiauv_control.paths`).
        tail_index: Per joint (n,): its index ``i`` among the undulating joints counted from the
            tail (1-based), or :data:`STRAIGHT_JOINT` for a joint held at zero.
        joint_sign: Per joint (n,): +1 if the joint turns about the link's +z axis, -1 about -z.
        n_links: ``n`` of the envelope: undulating joints + 1.
        surge_mask: 1 for the X thrusters (m,).
        surge_state: :class:`aiauv_control.laws.paper_laws.SurgeState` (advanced in combined mode).
        guidance_state: :class:`aiauv_control.laws.paper_laws.GuidanceState` (integral LOS).
        t: Time [s].
        position: The point that follows the path (the centre of mass), world [m].
        velocity: Its velocity, world [m/s].
        heading: Mean heading ``theta_bar`` [rad].
        surge_velocity: Speed along the mean heading [m/s] (combined mode).
        out: :class:`GaitBuffers`.
    """
    point = path_point_of(path_function, path_kind, position, path_parameters)
    errors = cross_track_errors(point, position, velocity)
    k = 1.0 / gains.lookahead
    bias = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if gains.integral:
        turn = normal_plane_turn_rate(point, velocity, errors[0], errors[1])
        bias = integral_los_bias(guidance_state, t, errors, 1.0, k, k, gains.sigma, turn)
    still = (0.0, 0.0, 0.0)
    x_ref = biased_los_guidance(point, position, velocity, still, 1.0, k, k, bias)[0]
    heading_ref = math.atan2(x_ref[1], x_ref[0])
    offset = heading_offset(heading, heading_ref, gains.k_theta, gains.max_offset)
    for j in range(tail_index.shape[0]):
        i = tail_index[j]
        if i == STRAIGHT_JOINT:
            out.joint_references[j] = 0.0
        else:
            g = gait_envelope(gains.kind, i, n_links)
            phi = serpenoid_reference(t, gains.amplitude, gains.omega, gains.delta, offset, g, i)
            out.joint_references[j] = -joint_sign[j] * phi  # q_j = -phi_i (module docstring)
    thrust = 0.0
    if gains.surge:
        thrust = surge_pi(  # the paper's eq. (25)
            surge_state, t, surge_velocity, gains.k_1p, gains.k_1i, gains.u_d, gains.max_thrust
        )
    for m in range(surge_mask.shape[0]):
        out.thrusts[m] = thrust if surge_mask[m] != 0 else 0.0
    out.offset[0] = offset
    out.heading_ref[0] = heading_ref
    out.cross_track[0] = errors[0]
    out.cross_track[1] = errors[1]
    out.path_s[0] = point.s
