"""Named records of a vehicle for the compiled kernels, built from its Pinocchio model.

The kernels (:mod:`aiauv_pin.kernels.articulated_body`) take a vehicle as a :class:`Model`: the kinematic
tree with rigid-plus-added inertias (:class:`RigidBodies`), the fluid parameters
(:class:`aiauv_hydro.laws.fluid_terms.FluidModel`), the thrusters (:class:`Thrusters`) and the fins
(:class:`aiauv_hydro.laws.lift.FinModel`).
Supported: a free-flyer
root (identity placement) and 1-DOF revolute or prismatic joints below it. A fixed-base vehicle keeps
the free-flyer layout of ``q`` and ``v``; its root is marked :data:`LOCKED_ROOT` (base velocity and
acceleration zero, see :func:`aiauv_pin.kernels.articulated_body.articulated_into`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from aiauv_hydro.laws.fluid_terms import FluidModel
from aiauv_hydro.laws.lift import FinModel

FREE_FLYER, REVOLUTE, PRISMATIC = 0, 1, 2
#: The root of a fixed-base vehicle: a free flyer's coordinates, its velocity and acceleration zero.
LOCKED_ROOT = 3

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


class RigidBodies(NamedTuple):
    """The kinematic tree and inertias, one row per Pinocchio body (nb = joints below the universe).

    Attributes:
        parent: Parent body (-1 for the root) (nb,).
        kind: Joint type: 0 free flyer, 1 revolute, 2 prismatic, 3 locked root (a fixed base) (nb,).
        q_index: First index of the joint in ``q`` (nb,).
        v_index: First index of the joint in ``v`` (nb,).
        placement: Joint placement in the parent body (nb, 4, 3): rows 0-2 rotation, row 3 translation [m].
        axis: Motion subspace ``S`` of a 1-DOF joint in the child frame (nb, 6).
        inertia: Rigid plus added inertia about the body origin, body axes (nb, 6, 6).
        rigid_inertia: Rigid inertia alone (nb, 6, 6) [kg, kg m, kg m^2].
        axis_index: ``k`` where ``S`` is the unit vector ``e_k`` (a joint about or along a body axis,
            the usual case), else -1 (nb,); the kernels then read one column instead of
            multiplying by ``S``.
    """

    parent: np.ndarray
    kind: np.ndarray
    q_index: np.ndarray
    v_index: np.ndarray
    placement: np.ndarray
    axis: np.ndarray
    inertia: np.ndarray
    rigid_inertia: np.ndarray
    axis_index: np.ndarray


class Thrusters(NamedTuple):
    """Thrusters as unit-thrust wrenches on bodies, with their actuator dynamics.

    Attributes:
        body: Body of each thruster (m,).
        unit_wrench: Wrench of 1 N of thrust about the body origin, body axes (m, 6) [-, m].
        max_thrust: Thrust limits [N] (m,).
        time_constant: First-order lags [s] (m,) (0: none).
        max_rate: Slew-rate limits [N/s] (m,) (``inf``: none).
        dynamic: Whether any thruster has a lag or a rate limit: then the compiled loop carries
            the produced thrusts as actuator state
            (:func:`aiauv_pin.kernels.articulated_body.actuators_into`).
    """

    body: np.ndarray
    unit_wrench: np.ndarray
    max_thrust: np.ndarray
    time_constant: np.ndarray
    max_rate: np.ndarray
    dynamic: bool


class Model(NamedTuple):
    """Everything the kernels know about a vehicle."""

    bodies: RigidBodies
    fluid: FluidModel
    thrusters: Thrusters
    fins: FinModel


class Servo(NamedTuple):
    """Joint PD with hydrostatic compensation run at every stage (paper, eq. (24)).

    ``tau_q = -k_p (q - q*) - k_d q_dot + g_q(q)`` (the last term if ``compensate_restoring``).
    Empty arrays (or ``enabled=False``) mean no servo.
    """

    stiffness: np.ndarray
    damping: np.ndarray
    references: np.ndarray
    enabled: bool
    compensate_restoring: bool


class Environment(NamedTuple):
    """Water current and external disturbance (see the module docstring of the kernels).

    A built-in current or disturbance is chosen by its ``kind`` with ``*_function = None``; a user's
    own compiled function is passed in ``*_function`` (:func:`aiauv_hydro.numerics.jit.user_or_builtin`).
    ``current_acceleration_function`` is a user's own acceleration of the water (``None``: the
    built-in's, or differences of the user's velocity; :func:`aiauv_hydro.currents.current_acceleration`);
    ``current_unsteady`` is ``False`` where the water never accelerates (a constant current) or
    for the quasi-steady model, and then the water's acceleration is not sampled.
    """

    current_function: object
    current_kind: int
    current_parameters: np.ndarray
    disturbance_function: object
    disturbance_kind: int
    disturbance_parameters: np.ndarray
    current_acceleration_function: object
    current_unsteady: bool


class Workspace(NamedTuple):
    """Scratch arrays reused by every evaluation (no allocation inside the step loop)."""

    rotation: np.ndarray  # (nb, 3, 3) body-to-world
    position: np.ndarray  # (nb, 3) body origins in the world [m]
    placement: np.ndarray  # (nb, 4, 3) placements in the parent at q
    twist: np.ndarray  # (nb, 6) body twists, body axes
    bias_acceleration: np.ndarray  # (nb, 6) v x S qd
    bias: np.ndarray  # (nb, 6) body bias forces p
    relative: np.ndarray  # (nb, 6) twists relative to the water; body wrenches
    current: np.ndarray  # (nb, 3) water velocity at each probe, world axes
    articulated_inertia: np.ndarray  # (nb, 6, 6)
    articulated_bias: np.ndarray  # (nb, 6)
    u_vector: np.ndarray  # (nb, 6) U = I^A S
    d_inverse: np.ndarray  # (nb,) 1 / (S^T U)
    u_scalar: np.ndarray  # (nb,) tau - S^T p^A
    acceleration: np.ndarray  # (nb, 6) body accelerations
    fluid_scratch: np.ndarray  # (3, 6)
    m66: np.ndarray  # (3, 6, 6)
    v6: np.ndarray  # (8, 6)
    m33: np.ndarray  # (2, 3, 3)
    tau_total: np.ndarray  # (nv,) tau + servo + disturbance
    restoring: np.ndarray  # (nv,) g(q)
    zero_velocity: np.ndarray  # (nv,)
    acc1: np.ndarray  # (nv,) RK4 stage accelerations
    acc2: np.ndarray
    acc3: np.ndarray
    acc4: np.ndarray
    rate2: np.ndarray  # (nv,) RK4 stage tangent rates
    rate3: np.ndarray
    rate4: np.ndarray
    xi: np.ndarray  # (nv,) tangent-space increment
    v_stage: np.ndarray  # (nv,)
    v_next: np.ndarray  # (nv,)
    q_stage: np.ndarray  # (nq,)
    q_next: np.ndarray  # (nq,)
    subtree_restoring: (
        np.ndarray
    )  # (nb, 6) -hydrostatic wrench of each body's subtree (servo's g(q))
    fin_angle: np.ndarray  # (nf,) fin angles acting on the plant [rad] (read at every stage)
    fin_command: np.ndarray  # (nf,) fin angles commanded by a compiled controller [rad]
    thrust: np.ndarray  # (m,) thrusts produced (actuator state of dynamic thrusters) [N]
    thrust_command: np.ndarray  # (m,) thrusts last commanded through thrust_into [N]
    thrust_delta: np.ndarray  # (m,) produced minus commanded thrust [N]
    tau_actuated: np.ndarray  # (nv,) the loop's held tau corrected for the thrusters' lag
    flow_acceleration: np.ndarray  # (nb, 3) the water's acceleration DV/Dt at each probe, world


def _joint_kind_axis(joint) -> tuple[int, np.ndarray] | None:
    name = joint.shortname().removeprefix("JointModel")
    if name in ("RX", "RY", "RZ"):
        return REVOLUTE, np.array(_AXES[name[1]])
    if name in ("PX", "PY", "PZ"):
        return PRISMATIC, np.array(_AXES[name[1]])
    if name in ("RevoluteUnaligned", "PrismaticUnaligned"):
        axis = np.asarray(joint.extract().axis, dtype=float)
        if abs(np.linalg.norm(axis) - 1.0) > 1e-12:
            return None
        kind = REVOLUTE if name.startswith("Revolute") else PRISMATIC
        return kind, axis
    return None


def unsupported_reason(model: pin.Model) -> str | None:
    """Why the kernels cannot run this model (``None`` if they can)."""
    if model.njoints < 2 or model.joints[1].shortname() != "JointModelFreeFlyer":
        return "the root joint is not a free flyer"
    if not model.jointPlacements[1].isIdentity():
        return "the free flyer has a non-identity placement"
    for j in range(2, model.njoints):
        if _joint_kind_axis(model.joints[j]) is None:
            return f"joint '{model.names[j]}' has unsupported type {model.joints[j].shortname()}"
        if model.parents[j] < 1:
            return f"joint '{model.names[j]}' is not below the free flyer"
    return None


def rigid_bodies(model: pin.Model, added_mass: np.ndarray, fixed_base: bool = False) -> RigidBodies:
    """The kinematic tree and inertias of a supported Pinocchio model (see :func:`unsupported_reason`).

    Args:
        model: The Pinocchio model.
        added_mass: ``M_A`` per body (nb, 6, 6), added to the rigid inertia.
        fixed_base: The root is locked (:data:`LOCKED_ROOT`) instead of free.
    """
    nb = model.njoints - 1
    kind = np.zeros(nb, dtype=np.int64)
    placement = np.zeros((nb, 4, 3))
    axis = np.zeros((nb, 6))
    rigid = np.zeros((nb, 6, 6))
    for j in range(1, model.njoints):
        b = j - 1
        joint_placement = model.jointPlacements[j]
        placement[b, :3] = joint_placement.rotation
        placement[b, 3] = joint_placement.translation
        if j >= 2:
            kind[b], unit = _joint_kind_axis(model.joints[j])
            if kind[b] == REVOLUTE:
                axis[b, 3:] = unit
            else:
                axis[b, :3] = unit
        rigid[b] = model.inertias[j].matrix()
    if fixed_base:
        kind[0] = LOCKED_ROOT
    return RigidBodies(
        parent=np.array([model.parents[j] - 1 for j in range(1, model.njoints)], dtype=np.int64),
        kind=kind,
        q_index=np.array([model.idx_qs[j] for j in range(1, model.njoints)], dtype=np.int64),
        v_index=np.array([model.idx_vs[j] for j in range(1, model.njoints)], dtype=np.int64),
        placement=placement,
        axis=axis,
        inertia=rigid + added_mass,
        rigid_inertia=rigid,
        axis_index=np.array([_unit_index(row) for row in axis], dtype=np.int64),
    )


def _unit_index(axis: np.ndarray) -> int:
    """``k`` if ``axis`` is exactly the unit vector ``e_k``, else -1."""
    hits = np.flatnonzero(axis)
    return int(hits[0]) if len(hits) == 1 and axis[hits[0]] == 1.0 else -1
