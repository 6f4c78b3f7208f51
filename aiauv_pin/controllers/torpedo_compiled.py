"""Vehicle side of a torpedo AUV's path following for the compiled loop.

Measurement: the hull's origin (the point that follows the path) and its world velocity, the
hull's x-axis in the world and its rate ``R (omega x e_x)``, and the speed along it. The law is
:func:`aiauv_control.laws.torpedo_laws.torpedo_command`; the action: the propeller thrust through
``tau = B(q) thrusts`` (the paper's eq. 20, :func:`thrust_into`) and the fin angles into
``workspace.fin_command`` (the loop applies each fin's angle limit, lag and rate limit before the
step, :func:`aiauv_pin.kernels.articulated_body.actuators_into`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aiauv_control.laws.paper_laws import GuidanceState, SurgeState
from aiauv_control.laws.torpedo_laws import (
    AutopilotState,
    TorpedoBuffers,
    TorpedoGains,
    torpedo_command,
)
from aiauv_hydro.numerics.jit import compiled
from aiauv_pin.controllers.paper_compiled import thrusts_and_power_into
from aiauv_pin.kernels.articulated_body import kinematics, thrust_into


class TorpedoInfo(NamedTuple):
    """Offsets of the fields of :func:`torpedo_info_shapes` in the info row of
    :func:`torpedo_path_following` (:func:`aiauv_pin.controllers.info_rows.info_offsets`)."""

    p: int
    cross_track: int
    path_s: int
    speed: int
    heading: int
    pitch: int
    deflection: int
    fin_command: int
    fin_angle: int
    thrust: int
    thruster_power: int


class TorpedoParameters(NamedTuple):
    """What :func:`torpedo_path_following` needs besides the state (built in Python once)."""

    gains: TorpedoGains
    path_function: object  # None for a built-in path (then path_kind chooses it)
    path_kind: int
    path_parameters: np.ndarray
    surge_mask: np.ndarray  # (m,) +-1 for the propellers (their sign along the hull's x), else 0
    rudder_share: np.ndarray  # (nf,) share of delta_r [-]
    stern_share: np.ndarray  # (nf,) share of delta_s [-]
    fin_limit: np.ndarray  # (nf,) [rad]
    info: TorpedoInfo  # where the info row's fields start


class TorpedoState(NamedTuple):
    """State of :func:`torpedo_path_following` (arrays updated in place)."""

    surge: SurgeState
    guidance: GuidanceState
    autopilot: AutopilotState
    command: TorpedoBuffers


def torpedo_info_shapes(n_thrusters: int, n_fins: int) -> dict[str, tuple[int, ...]]:
    """Keys and shapes of the info row of :func:`torpedo_path_following`."""
    return {
        "p": (3,),  # the hull's origin [m]
        "cross_track": (2,),  # [m]
        "path_s": (),  # [m]
        "speed": (),  # along the hull's axis [m/s]
        "heading": (2,),  # psi, psi_d [rad]
        "pitch": (2,),  # theta, theta_d [rad], positive nose up
        "deflection": (2,),  # delta_r, delta_s [rad]
        "fin_command": (n_fins,),  # [rad]
        "fin_angle": (n_fins,),  # the angle reached [rad]
        "thrust": (n_thrusters,),
        "thruster_power": (n_thrusters,),
    }


@compiled(borrows_only=True, inline=True)
def torpedo_path_following(t, q, v, model, workspace, parameters, state, tau, info):
    """The torpedo's path following on the vehicle: measure, :func:`torpedo_command`, act."""
    W = workspace
    P = parameters
    kinematics(model.bodies, q, v, W)
    R = W.rotation[0]
    nu = W.twist[0]  # (v, omega) in the hull's axes
    position = (q[0], q[1], q[2])
    velocity = (
        R[0, 0] * nu[0] + R[0, 1] * nu[1] + R[0, 2] * nu[2],
        R[1, 0] * nu[0] + R[1, 1] * nu[1] + R[1, 2] * nu[2],
        R[2, 0] * nu[0] + R[2, 1] * nu[1] + R[2, 2] * nu[2],
    )
    axis = (R[0, 0], R[1, 0], R[2, 0])
    # d/dt (R e_x) = R (omega x e_x) = R (0, omega_z, -omega_y)
    wy, wz = nu[4], nu[5]
    axis_rate = (
        R[0, 1] * wz - R[0, 2] * wy,
        R[1, 1] * wz - R[1, 2] * wy,
        R[2, 1] * wz - R[2, 2] * wy,
    )
    out = state.command
    torpedo_command(
        P.gains,
        P.path_function,
        P.path_kind,
        P.path_parameters,
        P.surge_mask,
        P.rudder_share,
        P.stern_share,
        P.fin_limit,
        state.surge,
        state.guidance,
        state.autopilot,
        t,
        position,
        velocity,
        axis,
        axis_rate,
        nu[0],
        out,
    )
    nf = out.fins.shape[0]
    for k in range(nf):
        W.fin_command[k] = out.fins[k]
    thrust_into(model, W, out.thrusts, tau)  # eq. (20)
    # the info row, at the offsets of torpedo_info_shapes
    L = P.info
    for i in range(3):
        info[L.p + i] = position[i]
    info[L.path_s] = out.path_s[0]
    info[L.speed] = nu[0]
    for i in range(2):
        info[L.cross_track + i] = out.cross_track[i]
        info[L.heading + i] = out.angles[i]  # psi, psi_d
        info[L.pitch + i] = out.angles[2 + i]  # theta, theta_d
        info[L.deflection + i] = out.deflection[i]
    for k in range(nf):
        info[L.fin_command + k] = out.fins[k]
        info[L.fin_angle + k] = W.fin_angle[k]
    thrusts_and_power_into(model, W, out.thrusts, info, L.thrust, L.thruster_power)
