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

Depth keeping (our own design, beyond Kelasidi 2017's planar gaits; :func:`depth_command`), on the
vertical offset ``e_v = (p - c) . e_z`` [m] of the same point from its closest path point ``c``
(world z up):

* by the vertical (pitch, y-axis) joints: a vertical LOS gives the desired elevation of the body,
  ``gamma_d = atan2(-e_v, Delta_v)`` with lookahead ``Delta_v`` [m] (the vertical half of the
  project's LOS, eq. 21 of the paper, in angle form; the form of the vertical LOS for AUVs in
  Fossen, "Handbook of Marine Craft Hydrodynamics and Motion Control", 2nd ed., 2021, ch. 12,
  which we have not checked against its equation numbers), and a saturated PD on the elevation
  error gives the base angle ``q_y0 = sat(k_v (gamma_bar - gamma_d) + k_v T_v gamma_bar_dot,
  q_max)`` [rad], spread over the pitch joints from the tail by eq. (22) of the paper
  (:func:`aiauv_control.laws.paper_laws.joint_reference`, ``sign exp(-alpha (j - 1))``). The
  elevation ``gamma_bar`` is that of the mass-weighted mean of the links' x-axes (positive
  towards +z). A positive angle of a ``+y`` joint turns its head-ward link's x-axis towards the
  link's -z, down for a level link: hence the sign of the PD (too steep up, bend down);
* by the vertical (z-direction) thrusters: a PI on ``e_v``, ``F = sat(-k_p e_v - k_i integral
  e_v dt)`` along world +z per thruster, within the thruster's limit, with the conditional
  anti-windup of the paper's surge PI (eq. 25, the same law:
  :func:`aiauv_control.laws.paper_laws.surge_pi` with ``u = e_v``, ``u_d = 0``); each thruster
  pushes ``F`` times the sign of its axis along its link's z (links assumed level in roll).

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
    joint_reference,
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
#: Depth keeping (:func:`depth_command`): none, by the pitch joints, by the vertical thrusters.
DEPTH_NONE, DEPTH_JOINTS, DEPTH_THRUSTERS = 0, 1, 2
#: The depth modes by name, as scenario files and the Python API spell them.
DEPTH_MODES = {"none": DEPTH_NONE, "joints": DEPTH_JOINTS, "thrusters": DEPTH_THRUSTERS}


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
    depth: int = DEPTH_NONE  # DEPTH_NONE, DEPTH_JOINTS or DEPTH_THRUSTERS
    depth_gain: float = 0.0  # k_v: base angle per rad of elevation error [-]
    depth_damping: float = 0.0  # T_v: derivative time of the elevation PD [s]
    depth_lookahead: float = 1.0  # vertical LOS lookahead Delta_v [m]
    alpha: float = 0.7  # shape of eq. (22) over the pitch joints [-]
    q_max: float = 0.5236  # saturation of the pitch base angle [rad]
    depth_kp: float = 0.0  # depth PI on the vertical thrusters [N/m]
    depth_ki: float = 0.0  # [N/(m s)]


class GaitBuffers(NamedTuple):
    """Outputs of :func:`gait_command`, written in place."""

    joint_references: np.ndarray  # (n,) [rad]
    thrusts: np.ndarray  # (m,) [N]
    offset: np.ndarray  # (1,) phi_0 [rad], Kelasidi's sign
    heading_ref: np.ndarray  # (1,) theta_ref [rad]
    cross_track: np.ndarray  # (2,) [m] along N1, N2
    path_s: np.ndarray  # (1,) path parameter [m]
    depth: np.ndarray  # (3,) e_v [m], gamma_d [rad], q_y0 [rad] or the depth thrust F [N]


def new_gait_buffers(n_joints: int, n_thrusters: int) -> GaitBuffers:
    """Zeroed :class:`GaitBuffers`."""
    return GaitBuffers(
        np.zeros(n_joints),
        np.zeros(n_thrusters),
        np.zeros(1),
        np.zeros(1),
        np.zeros(2),
        np.zeros(1),
        np.zeros(3),
    )


@compiled
def vertical_los_elevation(vertical_error, lookahead):
    """Desired elevation ``gamma_d = atan2(-e_v, Delta_v)`` [rad] of the body's mean x-axis
    (vertical LOS, module docstring): towards the path from above (``e_v > 0``) or below.

    Args:
        vertical_error: ``e_v`` [m], positive above the path (world z up).
        lookahead: ``Delta_v`` [m] (> 0).
    """
    return math.atan2(-vertical_error, lookahead)


@compiled
def pitch_base_angle(elevation, elevation_rate, elevation_ref, gain, damping, q_max):
    """Base angle of the pitch joints ``q_y0 = sat(k_v (gamma_bar - gamma_d) + k_v T_v
    gamma_bar_dot, q_max)`` [rad] (saturated PD, module docstring).

    Args:
        elevation: ``gamma_bar`` [rad].
        elevation_rate: ``gamma_bar_dot`` [rad/s].
        elevation_ref: ``gamma_d`` [rad].
        gain: ``k_v`` [-].
        damping: ``T_v`` [s].
        q_max: Saturation [rad].
    """
    demand = gain * (wrap_angle(elevation - elevation_ref) + damping * elevation_rate)
    return min(max(demand, -q_max), q_max)


@compiled(borrows_only=True)
def depth_command(gains, depth_state, t, vertical_error, elevation, elevation_rate, out):
    """Depth keeping (module docstring): returns the base angle of the pitch joints [rad] (0 but
    by the joints) and the force per vertical thruster along world +z [N] (0 but by the
    thrusters); advances ``depth_state`` (a :class:`aiauv_control.laws.paper_laws.SurgeState`)
    in the thruster mode and logs ``(e_v, gamma_d, q_y0 or F)`` into ``out.depth``."""
    base = 0.0
    force = 0.0
    elevation_ref = vertical_los_elevation(vertical_error, gains.depth_lookahead)
    if gains.depth == DEPTH_JOINTS:
        base = pitch_base_angle(
            elevation,
            elevation_rate,
            elevation_ref,
            gains.depth_gain,
            gains.depth_damping,
            gains.q_max,
        )
    elif gains.depth == DEPTH_THRUSTERS:
        force = surge_pi(  # the PI of eq. (25) on e_v with u_d = 0
            depth_state, t, vertical_error, gains.depth_kp, gains.depth_ki, 0.0, gains.max_thrust
        )
    out.depth[0] = vertical_error
    out.depth[1] = elevation_ref
    out.depth[2] = base if gains.depth == DEPTH_JOINTS else force
    return base, force


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
    pitch_scale,
    heave_sign,
    depth_state,
    elevation,
    elevation_rate,
):
    """One evaluation of the steered serpentine gait into ``out`` (see the module docstring).

    Args:
        gains: :class:`GaitGains`.
        path_function, path_kind, path_parameters: The path (:mod:`aiauv_control.paths`).
        tail_index: Per joint (n,): its index ``i`` among the undulating joints counted from the
            tail (1-based), or :data:`STRAIGHT_JOINT` for a joint that does not undulate (held
            at zero, or at eq. (22)'s share of the depth base angle: ``pitch_scale``).
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
        pitch_scale: Per joint (n,): ``sign exp(-alpha (j - 1))`` of eq. (22) for the pitch joints
            (``j`` counted from the tail), 0 for the others.
        heave_sign: Per thruster (m,): the sign of its axis along its link's z for the vertical
            thrusters of the depth PI, 0 for the others.
        depth_state: :class:`aiauv_control.laws.paper_laws.SurgeState` of the depth PI.
        elevation: Mean elevation ``gamma_bar`` of the body [rad] (positive towards +z).
        elevation_rate: Its rate [rad/s].
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
    vertical_error = position[2] - point.point[2]
    base, force = depth_command(
        gains, depth_state, t, vertical_error, elevation, elevation_rate, out
    )
    for j in range(tail_index.shape[0]):
        i = tail_index[j]
        if i == STRAIGHT_JOINT:
            out.joint_references[j] = joint_reference(base, pitch_scale[j], gains.q_max)  # (22)
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
        out.thrusts[m] = thrust if surge_mask[m] != 0 else heave_sign[m] * force
    out.offset[0] = offset
    out.heading_ref[0] = heading_ref
    out.cross_track[0] = errors[0]
    out.cross_track[1] = errors[1]
    out.path_s[0] = point.s
