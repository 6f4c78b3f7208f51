"""Path following of a torpedo AUV (one propeller, rudders and stern planes), written once for
every backend.

The vehicle is underactuated: the propeller sets the speed, the fins turn the hull. The law is the
classic three loops of a torpedo AUV:

* **guidance**: 3-D line of sight on the project's paths (line, helix, waypoints,
  :mod:`aiauv_control.paths`): the path-parametrised vector LOS
  (:func:`aiauv_control.laws.paper_laws.biased_los_guidance` with ``u_d = 1`` and ``k = 1 /
  Delta``), ``x_ref = (T - (e_1 + b_1) N1 / Delta - (e_2 + b_2) N2 / Delta) / |.|``, with lookahead
  distance ``Delta`` [m] and the optional integral-LOS bias ``b`` of Borhaug, Pavlov and Pettersen
  (2008) (:func:`~aiauv_control.laws.paper_laws.integral_los_bias`, whose integrator turns with a
  helix's torsion). On the x-axis and in the horizontal plane this is the LOS of Breivik and
  Fossen (2005) and Fossen (2021, "Handbook of Marine Craft Hydrodynamics and Motion Control", 2nd
  ed., Wiley, Sec. 12.4), ``chi_d = pi_h - atan(e / Delta)``; in the vertical plane
  ``theta_d = atan(-e_v / Delta)`` (Fossen 2021, Sec. 12.5, LOS for the pitch angle of an AUV;
  we have not checked our notation against their equation numbers). The integral bias takes up
  the steady sideslip and angle of attack of a turning, climbing hull (the crab angles that
  Fossen's ILOS and ALOS (Fossen and Aguiar 2024, Automatica 163) estimate). The desired heading
  and pitch and their rates are the angles of ``x_ref`` and of ``x_ref_dot``
  (:func:`direction_angles`);
* **autopilots** (:func:`pid_autopilot`): PID on the heading error by the rudders and on the pitch
  error by the stern planes, with the rates of the desired angles fed forward in the derivative
  term, ``u = sat(k_p e + k_d (x_dot - x_d_dot) + k_i int e dt)``, ``e = ssa(x - x_d)``, saturated
  at the fins' limit with conditional-integration anti-windup (that of the paper's surge PI,
  :func:`aiauv_control.laws.paper_laws.surge_pi`). It is the form of the pitch autopilot of
  Fossen's remus100.py (PythonVehicleSimulator, commit c717e07,
  src/python_vehicle_simulator/vehicles/remus100.py lines 464-466: ``delta_s = -Kp_theta ssa(theta
  - theta_d) - Kd_theta q - Ki_theta theta_int``) and of the PID autopilots of Fossen (2021,
  Sec. 15.3, whose pole-placement gains are in lib/control.py lines 38-40 of the same commit);
  the heading loop here is the same PID, not remus100.py's sliding-mode heading autopilot;
* **allocation**: a rudder deflection ``delta_r`` (positive turns to starboard: a negative yaw
  rate about world +z, Fossen's sign) and a stern-plane deflection ``delta_s`` (positive pitches
  the nose up) go to each fin by its share of yaw and pitch moment (:func:`fin_share`, from the
  fin's geometry), ``delta_k = sat(a_k delta_r + b_k delta_s)``: on a cruciform tail both
  rudders get ``delta_r`` and both stern planes ``delta_s``; an X tail mixes them. Roll is left
  to the hull's metacentric stiffness (the rudders' roll moments cancel pairwise);
* **speed**: the propeller thrust ``T = sat(-k_1p (u - u_d) - k_1i int (u - u_d) dt)`` (the
  paper's surge PI, eq. 25, :func:`~aiauv_control.laws.paper_laws.surge_pi`) on the speed ``u``
  along the hull's axis, or a constant thrust.

Signs: the heading error ``psi - psi_d > 0`` (turned too far to port) needs a starboard turn,
a positive rudder: ``delta_r = u_yaw``; the pitch error ``theta - theta_d > 0`` (nose too high)
needs a nose-down moment, a negative stern-plane angle: ``delta_s = -u_pitch`` (remus100.py's
sign in its z-down axes; ours are z up, pitch positive nose up).

No fast-math: the saturations and the anti-windup take the same decisions compiled and
interpreted.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from aiauv_control.laws.gait_laws import wrap_angle
from aiauv_control.laws.paper_laws import (
    biased_los_guidance,
    cross_track_errors,
    integral_los_bias,
    normal_plane_turn_rate,
    surge_pi,
)
from aiauv_control.paths import path_point_of
from aiauv_hydro.numerics.jit import compiled

#: Autopilot axes of :class:`AutopilotState`: heading (rudders), pitch (stern planes).
YAW, PITCH = 0, 1


class TorpedoGains(NamedTuple):
    """Parameters of :func:`torpedo_command` as plain numbers."""

    lookahead: float  # LOS lookahead distance Delta [m]
    integral: bool  # integral LOS (Borhaug et al. 2008) instead of LOS
    sigma: float  # integral gain of the integral LOS [-]
    speed_control: bool  # PI on the speed (else the constant thrust)
    u_d: float  # desired speed [m/s]
    thrust: float  # constant thrust per propeller without speed control [N]
    k_1p: float  # speed PI [N s/m]
    k_1i: float  # [N/m]
    max_thrust: float  # per propeller [N]
    yaw_kp: float  # heading PID: rudder per heading error [rad/rad]
    yaw_kd: float  # [rad s/rad]
    yaw_ki: float  # [rad/(rad s)]
    pitch_kp: float  # pitch PID: stern plane per pitch error [rad/rad]
    pitch_kd: float  # [rad s/rad]
    pitch_ki: float  # [rad/(rad s)]
    max_deflection: float  # saturation of delta_r and delta_s [rad]


class AutopilotState(NamedTuple):
    """State of :func:`pid_autopilot`, per axis (:data:`YAW`, :data:`PITCH`), updated in place.

    Attributes:
        integral: ``int e dt`` (2,) [rad s].
        has_previous: 1 once a sample has been taken (2,).
        time: Time of the previous sample (2,) [s].
        error: Error of the previous sample (2,) [rad].
        saturation: +1 / -1 if the previous output was clipped at +/- the limit, else 0 (2,).
    """

    integral: np.ndarray
    has_previous: np.ndarray
    time: np.ndarray
    error: np.ndarray
    saturation: np.ndarray


def new_autopilot_state() -> AutopilotState:
    """A cleared :class:`AutopilotState`."""
    return AutopilotState(*(np.zeros(2) for _ in AutopilotState._fields))


class TorpedoBuffers(NamedTuple):
    """Outputs of :func:`torpedo_command`, written in place."""

    thrusts: np.ndarray  # (m,) [N]
    fins: np.ndarray  # (nf,) commanded fin angles [rad]
    deflection: np.ndarray  # (2,) delta_r, delta_s [rad]
    angles: np.ndarray  # (4,) heading, desired heading, pitch, desired pitch [rad]
    cross_track: np.ndarray  # (2,) [m] along N1, N2
    path_s: np.ndarray  # (1,) path parameter [m]


def new_torpedo_buffers(n_thrusters: int, n_fins: int) -> TorpedoBuffers:
    """Zeroed :class:`TorpedoBuffers`."""
    return TorpedoBuffers(
        np.zeros(n_thrusters), np.zeros(n_fins), np.zeros(2), np.zeros(4), np.zeros(2), np.zeros(1)
    )


@compiled
def direction_angles(x0, x1, x2, d0, d1, d2):
    """Heading ``psi = atan2(x_y, x_x)`` and elevation ``theta = atan2(x_z, h)``, ``h = |(x_x,
    x_y)|`` [rad] of a direction ``x`` (world axes, z up; elevation positive nose up), and their
    rates [rad/s] from ``x_dot = d``: ``psi_dot = (x_x d_y - x_y d_x) / h^2``, ``theta_dot = (h
    d_z - x_z h_dot) / (h^2 + x_z^2)`` with ``h_dot = (x_x d_x + x_y d_y) / h``. A vertical
    direction (``h = 0``) has heading 0 and heading rate 0."""
    h2 = x0 * x0 + x1 * x1
    h = math.sqrt(h2)
    heading = math.atan2(x1, x0)
    heading_rate = (x0 * d1 - x1 * d0) / h2 if h2 > 0.0 else 0.0
    h_dot = (x0 * d0 + x1 * d1) / h if h > 0.0 else 0.0
    norm2 = h2 + x2 * x2
    elevation_rate = (h * d2 - x2 * h_dot) / norm2 if norm2 > 0.0 else 0.0
    return heading, heading_rate, math.atan2(x2, h), elevation_rate


@compiled(borrows_only=True)
def pid_autopilot(state, axis, t, error, rate_error, k_p, k_d, k_i, limit):
    """``u = sat(k_p e + k_d e_dot + k_i int e dt, limit)`` [rad] at time ``t`` [s]; advances
    ``state`` on ``axis`` (module docstring).

    The integral advances by the previous error held over the elapsed time (zero-order hold); it
    is frozen while the previous output was saturated with an error pushing further into the
    limit (conditional integration, as :func:`aiauv_control.laws.paper_laws.surge_pi`).

    Args:
        state: :class:`AutopilotState`.
        axis: :data:`YAW` or :data:`PITCH`.
        t: Time [s].
        error: ``e = ssa(x - x_d)`` [rad].
        rate_error: ``x_dot - x_d_dot`` [rad/s].
        k_p, k_d, k_i: Gains [-], [s], [1/s].
        limit: Saturation [rad] (> 0).
    """
    if state.has_previous[axis] != 0.0:
        winding_up = state.saturation[axis] * state.error[axis] > 0.0
        if not winding_up:
            state.integral[axis] += state.error[axis] * (t - state.time[axis])
    demand = k_p * error + k_d * rate_error + k_i * state.integral[axis]
    out = min(max(demand, -limit), limit)
    saturation = 0.0
    if out != demand:
        saturation = 1.0 if demand > 0.0 else -1.0
    state.saturation[axis] = saturation
    state.has_previous[axis] = 1.0
    state.time[axis] = t
    state.error[axis] = error
    return out


def fin_share(moment_per_angle) -> tuple[np.ndarray, np.ndarray]:
    """Shares ``(a, b)`` (nf,) [-] of the rudder and stern-plane deflections for fins whose moment
    per unit angle about the vehicle's centre is ``moment_per_angle`` (nf, 3) (body axes, x
    forward, y port, z up; any positive scale): ``a_k = -m_z / |(m_y, m_z)|`` (a positive
    ``delta_r`` turns to starboard, a negative yaw moment), ``b_k = -m_y / |(m_y, m_z)|`` (a
    positive ``delta_s`` pitches the nose up, a negative moment about +y). A fin that gives no yaw
    or pitch moment gets ``(0, 0)``."""
    m = np.asarray(moment_per_angle, dtype=float).reshape(-1, 3)
    size = np.hypot(m[:, 1], m[:, 2])
    scale = np.where(size > 0.0, 1.0 / np.where(size > 0.0, size, 1.0), 0.0)
    a = -m[:, 2] * scale
    b = -m[:, 1] * scale
    # snap the rounding of a fin set along a body axis (an exact cruciform gets exactly 0 and 1)
    a = np.where(np.abs(a) < 1e-12, 0.0, a)
    b = np.where(np.abs(b) < 1e-12, 0.0, b)
    a = np.where(np.abs(np.abs(a) - 1.0) < 1e-12, np.sign(a), a)
    b = np.where(np.abs(np.abs(b) - 1.0) < 1e-12, np.sign(b), b)
    return a, b


@compiled(borrows_only=True)
def torpedo_command(
    gains,
    path_function,
    path_kind,
    path_parameters,
    surge_mask,
    rudder_share,
    stern_share,
    fin_limit,
    surge_state,
    guidance_state,
    autopilot_state,
    t,
    position,
    velocity,
    axis,
    axis_rate,
    surge_velocity,
    out,
):
    """One evaluation of the torpedo's path following into ``out`` (module docstring).

    Args:
        gains: :class:`TorpedoGains`.
        path_function, path_kind, path_parameters: The path (:mod:`aiauv_control.paths`).
        surge_mask: Per thruster (m,): +1 (-1) for a propeller pushing the hull along its +x
            (-x) axis, 0 for the other thrusters (left at zero).
        rudder_share, stern_share: ``a_k``, ``b_k`` of each fin (nf,) (:func:`fin_share`).
        fin_limit: Each fin's angle limit (nf,) [rad].
        surge_state: :class:`aiauv_control.laws.paper_laws.SurgeState` (speed PI).
        guidance_state: :class:`aiauv_control.laws.paper_laws.GuidanceState` (integral LOS).
        autopilot_state: :class:`AutopilotState`.
        t: Time [s].
        position: The point that follows the path, world [m].
        velocity: Its velocity, world [m/s].
        axis: The hull's x-axis in the world (3,) [-].
        axis_rate: Its time derivative (3,) [1/s].
        surge_velocity: Speed along the hull's axis [m/s].
        out: :class:`TorpedoBuffers`.
    """
    point = path_point_of(path_function, path_kind, position, path_parameters)
    errors = cross_track_errors(point, position, velocity)
    k = 1.0 / gains.lookahead
    bias = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if gains.integral:
        turn = normal_plane_turn_rate(point, velocity, errors[0], errors[1])
        bias = integral_los_bias(guidance_state, t, errors, 1.0, k, k, gains.sigma, turn)
    still = (0.0, 0.0, 0.0)
    x_ref, x_dot, _ = biased_los_guidance(point, position, velocity, still, 1.0, k, k, bias)
    psi_d, psi_d_dot, theta_d, theta_d_dot = direction_angles(
        x_ref[0], x_ref[1], x_ref[2], x_dot[0], x_dot[1], x_dot[2]
    )
    psi, psi_dot, theta, theta_dot = direction_angles(
        axis[0], axis[1], axis[2], axis_rate[0], axis_rate[1], axis_rate[2]
    )
    limit = gains.max_deflection
    delta_r = pid_autopilot(
        autopilot_state,
        YAW,
        t,
        wrap_angle(psi - psi_d),
        psi_dot - psi_d_dot,
        gains.yaw_kp,
        gains.yaw_kd,
        gains.yaw_ki,
        limit,
    )
    delta_s = -pid_autopilot(
        autopilot_state,
        PITCH,
        t,
        wrap_angle(theta - theta_d),
        theta_dot - theta_d_dot,
        gains.pitch_kp,
        gains.pitch_kd,
        gains.pitch_ki,
        limit,
    )
    for f in range(out.fins.shape[0]):
        angle = rudder_share[f] * delta_r + stern_share[f] * delta_s
        out.fins[f] = min(max(angle, -fin_limit[f]), fin_limit[f])
    if gains.speed_control:
        thrust = surge_pi(  # the paper's eq. (25)
            surge_state, t, surge_velocity, gains.k_1p, gains.k_1i, gains.u_d, gains.max_thrust
        )
    else:
        thrust = gains.thrust
    for m in range(surge_mask.shape[0]):
        out.thrusts[m] = thrust * surge_mask[m]
    out.deflection[0] = delta_r
    out.deflection[1] = delta_s
    out.angles[0] = psi
    out.angles[1] = psi_d
    out.angles[2] = theta
    out.angles[3] = theta_d
    out.cross_track[0] = errors[0]
    out.cross_track[1] = errors[1]
    out.path_s[0] = point.s
