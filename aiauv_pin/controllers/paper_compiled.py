"""Built-in controllers for the compiled loop, and the vehicle side of the paper's controller.

A compiled controller is a function

    controller(t, q, v, model, workspace, parameters, state, tau, info) -> None

called by :func:`aiauv_pin.simulation.compiled_loop.run_chunk` at every control sample. It writes
the generalised
force ``tau`` (nv,) [N, N m] to hold until the next sample and its diagnostics into ``info`` (one
row of the log, laid out as its
:class:`aiauv_pin.controllers.compiled_controller.CompiledController` declares). It may
use the kernels on ``workspace`` (e.g. :func:`aiauv_pin.kernels.articulated_body.kinematics`,
:func:`~aiauv_pin.kernels.articulated_body.thrust_into` for ``tau = B(q) thrusts``). ``parameters`` and
``state`` are whatever the controller needs (arrays, named tuples of arrays); ``state`` is updated
in place.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aiauv_control.laws.paper_laws import (
    CommandBuffers,
    GuidanceState,
    PaperGains,
    SurgeState,
    finite_difference_acceleration,
    path_following_command,
    restoring_moment_in_frame,
    thruster_power,
)
from aiauv_hydro.numerics.jit import compiled
from aiauv_pin.controllers.info_rows import info_offsets
from aiauv_pin.kernels.articulated_body import (
    frame_of_body_into,
    kinematics,
    restoring_into,
    thrust_into,
)


@compiled
def passive(t, q, v, model, workspace, parameters, state, tau, info):
    """No input: thrusters and joints idle (``tau = 0``)."""
    for i in range(tau.shape[0]):
        tau[i] = 0.0


class ThrustInfo(NamedTuple):
    """Offsets of the fields of :func:`constant_info_shapes` in the info row of
    :func:`constant_thrust` (:func:`aiauv_pin.controllers.info_rows.info_offsets`)."""

    thrust: int
    thruster_power: int


class ConstantParameters(NamedTuple):
    """Parameters of :func:`constant_thrust`: one thrust per thruster [N] (within their limits),
    and where its info row's fields start (:func:`constant_parameters` builds it)."""

    thrusts: np.ndarray
    info: ThrustInfo


def constant_info_shapes(n_thrusters: int) -> dict[str, tuple[int, ...]]:
    """Keys and shapes of the info row of :func:`constant_thrust`."""
    return {"thrust": (n_thrusters,), "thruster_power": (n_thrusters,)}


def constant_parameters(thrusts: np.ndarray) -> ConstantParameters:
    """:class:`ConstantParameters` for the thrusts ``thrusts`` (m,) [N]."""
    return ConstantParameters(thrusts, info_offsets(constant_info_shapes(thrusts.size), ThrustInfo))


@compiled
def constant_thrust(t, q, v, model, workspace, parameters, state, tau, info):
    """Constant thrusts, joints idle: ``tau = B(q) thrusts`` (eq. 20), the thrusts and their power
    logged. An open-loop command, as a thrust command on gz-sim's Thruster topic."""
    kinematics(model.bodies, q, v, workspace)
    thrust_into(model, workspace, parameters.thrusts, tau)
    layout = parameters.info
    thrusts_and_power_into(
        model, workspace, parameters.thrusts, info, layout.thrust, layout.thruster_power
    )


class FrameMeasurement(NamedTuple):
    """What a path-following controller measures of its end-effector frame at a sample: buffers
    that :func:`measure_end_effector` overwrites (:func:`new_frame_measurement` builds them)."""

    rotation: np.ndarray  # (3, 3) frame to world
    position: np.ndarray  # (3,) world [m]
    twist: np.ndarray  # (6,) (v, w) in the frame's own axes [m/s, rad/s]
    velocity: np.ndarray  # (3,) world [m/s]
    acceleration: np.ndarray  # (3,) world, finite difference over the samples [m/s^2]
    omega: np.ndarray  # (3,) angular velocity in the frame's own axes [rad/s]
    history: np.ndarray  # (5,): has previous, time [s], previous world velocity (3) [m/s]


def new_frame_measurement() -> FrameMeasurement:
    """Zeroed :class:`FrameMeasurement` buffers (no previous sample)."""
    return FrameMeasurement(
        np.zeros((3, 3)),
        np.zeros(3),
        np.zeros(6),
        np.zeros(3),
        np.zeros(3),
        np.zeros(3),
        np.zeros(5),
    )


@compiled(borrows_only=True, inline=True)
def measure_end_effector(t, q, v, model, W, body, rotation, translation, out):
    """What the path-following controllers measure at a sample into ``out`` (a
    :class:`FrameMeasurement`), and ``g(q)`` into ``W.restoring``.

    The end-effector frame (fixed to ``body`` at ``(rotation, translation)``): its rotation ``R`` to
    the world, position ``p`` [m], twist in its own axes, world velocity ``R v`` [m/s], angular
    velocity in its own axes [rad/s], and as acceleration [m/s^2] the difference of the world
    velocity with the previous sample's over the elapsed time (zero at the first sample or when
    ``t`` does not advance); ``out.history`` holds that previous sample and is updated.
    """
    kinematics(model.bodies, q, v, W)
    R, twist, history = out.rotation, out.twist, out.history
    frame_of_body_into(W, body, rotation, translation, R, out.position, twist)
    velocity, omega = out.velocity, out.omega
    for i in range(3):
        velocity[i] = R[i, 0] * twist[0] + R[i, 1] * twist[1] + R[i, 2] * twist[2]
        omega[i] = twist[3 + i]
    finite_difference_acceleration(t, velocity, history, out.acceleration)
    restoring_into(model, W, W.restoring)


@compiled(borrows_only=True, inline=True)
def thruster_power_into(model, W, thrusts, info, offset):
    """Mechanical power of each thruster [W] into ``info[offset:offset + m]`` (after kinematics).

    Thrust times the speed of the thruster's point along its axis: ``twist_b . w_k`` times
    ``T_k``, with ``w_k`` the unit-thrust wrench on body ``b`` (the ``k``-th entry of ``v^T B``).
    """
    th = model.thrusters
    for k in range(thrusts.shape[0]):
        b = th.body[k]
        speed = 0.0
        for i in range(6):
            speed += W.twist[b, i] * th.unit_wrench[k, i]
        info[offset + k] = thruster_power(speed, thrusts[k])


@compiled(borrows_only=True, inline=True)
def thrusts_and_power_into(model, W, thrusts, info, thrust_at, power_at):
    """The info row's ``thrust`` [N] and ``thruster_power`` [W] fields, ``m`` floats each, from
    ``info[thrust_at]`` and ``info[power_at]`` (after kinematics). Every built-in controller logs
    its thrusters this way."""
    for k in range(thrusts.shape[0]):
        info[thrust_at + k] = thrusts[k]
    thruster_power_into(model, W, thrusts, info, power_at)


class PaperInfo(NamedTuple):
    """Offsets of the fields of :func:`paper_info_shapes` in the info row of
    :func:`paper_path_following` (:func:`aiauv_pin.controllers.info_rows.info_offsets`)."""

    p: int
    u: int
    phi_tilde: int
    omega_tilde: int
    base_angles: int
    joint_references: int
    x_ref: int
    pointing: int
    thrust: int
    thruster_power: int
    joint_torque: int
    cross_track: int
    path_s: int


class PaperParameters(NamedTuple):
    """What :func:`paper_path_following` needs besides the state (built in Python once)."""

    gains: PaperGains
    path_function: object  # None for a built-in path (then path_kind chooses it)
    path_kind: int
    path_parameters: np.ndarray
    axis_index: np.ndarray  # (n,) base angle of each joint (0: y, 1: z)
    reference_scale: np.ndarray  # (n,) exp(-alpha (j - 1))
    surge_mask: np.ndarray  # (m,) 1 for the surge thrusters
    frame_body: int  # body carrying the end-effector frame
    frame_rotation: np.ndarray  # (3, 3) end-effector frame in that body
    frame_translation: np.ndarray  # (3,) [m]
    continuous_joints: bool  # eq. (24) as a servo at every stage (True) or sampled
    servo_references: np.ndarray  # (n,) the servo's references, updated in place
    info: PaperInfo  # where the info row's fields start


class PaperState(NamedTuple):
    """State of :func:`paper_path_following` (arrays updated in place)."""

    surge: SurgeState
    measurement: FrameMeasurement  # the end-effector at the sample (its history kept)
    command: CommandBuffers
    guidance: GuidanceState  # integral LOS (used when the gains ask for it)


#: Diagnostics of the paper's controller, in the order of its info row: name -> shape.
def paper_info_shapes(n_joints: int, n_thrusters: int) -> dict[str, tuple[int, ...]]:
    """Keys and shapes of the info row of :func:`paper_path_following` (and of the Python controller)."""
    return {
        "p": (3,),
        "u": (),
        "phi_tilde": (),
        "omega_tilde": (2,),
        "base_angles": (2,),
        "joint_references": (n_joints,),
        "x_ref": (3,),
        "pointing": (3,),
        "thrust": (n_thrusters,),
        "thruster_power": (n_thrusters,),
        "joint_torque": (n_joints,),
        "cross_track": (2,),
        "path_s": (),
    }


@compiled(borrows_only=True, inline=True)
def paper_path_following(t, q, v, model, workspace, parameters, state, tau, info):
    """The paper's controller on the vehicle: measure,
    :func:`aiauv_control.laws.paper_laws.path_following_command`, act.

    Measurement: the end-effector pose and twist from the kinematics, its world velocity, the
    difference of that velocity with the previous sample over the elapsed time as its acceleration
    (zero at the first sample), the joints' hydrostatic forces ``g_q`` (left-hand side) and the
    surge speed ``u`` (x-component of the end-effector velocity in its own axes). Action: ``tau =
    B(q) tau_thr`` (eq. 20), plus the joint torques of eq. (24) when they are sampled; with the
    continuous servo the joint references go to ``parameters.servo_references``.
    """
    W = workspace
    P = parameters
    meas = state.measurement
    measure_end_effector(
        t, q, v, model, W, P.frame_body, P.frame_rotation, P.frame_translation, meas
    )
    R, p, twist = meas.rotation, meas.position, meas.twist
    g = W.restoring
    n = q.shape[0] - 7
    out = state.command
    # restoring moment about the end-effector (base body 0), for the hydrostatic compensation
    restoring_moment = restoring_moment_in_frame(W.rotation[0], W.position[0], R, p, g)
    path_following_command(
        P.gains,
        P.path_function,
        P.path_kind,
        P.path_parameters,
        P.axis_index,
        P.reference_scale,
        P.surge_mask,
        state.surge,
        state.guidance,
        t,
        R,
        p,
        meas.velocity,
        meas.acceleration,
        meas.omega,
        twist[0],
        q[7:],
        v[6:],
        g[6:],
        restoring_moment,
        out,
    )
    thrust_into(model, W, out.thrusts, tau)  # eq. (20)
    if P.continuous_joints:
        for j in range(n):
            P.servo_references[j] = out.joint_references[j]
    else:
        for j in range(n):
            tau[6 + j] += out.joint_torques[j]
    # the info row, at the offsets of paper_info_shapes
    L = P.info
    for i in range(3):
        info[L.p + i] = p[i]
        info[L.x_ref + i] = out.x_ref[i]
        info[L.pointing + i] = R[i, 0]
    info[L.u] = twist[0]
    info[L.phi_tilde] = out.phi_tilde[0]
    for i in range(2):
        info[L.omega_tilde + i] = out.omega_tilde[i]
        info[L.base_angles + i] = out.base_angles[i]
        info[L.cross_track + i] = out.cross_track[i]
    for j in range(n):
        info[L.joint_references + j] = out.joint_references[j]
        info[L.joint_torque + j] = out.joint_torques[j]
    thrusts_and_power_into(model, W, out.thrusts, info, L.thrust, L.thruster_power)
    info[L.path_s] = out.path_s[0]
