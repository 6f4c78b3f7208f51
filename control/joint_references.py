"""Joint-angle references that steer the pointing direction by curving the body (paper, Sec. 3.4).

The vehicle has equally many joints about the link y- and z-axes. The joint layout is the sequence
of axis labels of the actuated joints in model order, tail to head, e.g. ``("z", "y", "z", "y",
...)`` for the paper's vehicle (joints 1, 3, 5, 7 about z; 2, 4, 6, 8 about y).

* Base angles ``q0 = (q_y0, q_z0)`` (eq. 23) are the reduced-attitude law of Section 2 evaluated on
  the end-effector frame ``e`` with unit inertia and no known moments: eq. (23) is eq. (9) with
  ``J = I`` and ``m = 0``. With ``feedforward="exact"`` (the default) the finding-2 correction of
  :mod:`aiauv_control.reduced_attitude` is therefore ``mu H^T R_tilde (y x omega_ref^e)`` (no ``J``); with
  ``"paper"`` it is eq. (23) as printed. The joints act on the pointing direction only indirectly,
  so neither choice guarantees tracking here (paper, Sec. 3.4); the exact one keeps the structure
  that gives ``V_dot = -k_D |omega_tilde|^2`` in the rigid-body case.
* Joint references (eq. 22): the ``j``-th joint about axis ``a`` (``j = 1`` nearest the tail) gets
  ``q*_{a,j} = exp(-alpha (j - 1)) sat(q_{a,0})``, ``sat`` clipping to ``[-q_max, q_max]``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from aiauv_control.laws import paper_laws as laws
from aiauv_control.reduced_attitude import Feedforward, ReducedAttitudeLaw

AXIS_LABELS = ("y", "z")
"""Joint axis labels; their order is also the order of the base angles ``q0 = (q_y0, q_z0)``."""

_UNIT_INERTIA = np.eye(3)
_UNIT_INERTIA.setflags(write=False)


def check_joint_axes(joint_axes: Sequence[str]) -> tuple[str, ...]:
    """Validate a joint layout and return it as a tuple of lower-case labels.

    Args:
        joint_axes: Axis label (``"y"`` or ``"z"``) of each actuated joint, model order, tail to
            head.

    Raises:
        ValueError: unknown label, no joints, or unequal numbers of y- and z-joints.
    """
    if isinstance(joint_axes, str):
        raise ValueError(
            f"joint_axes: expected a sequence of 'y'/'z' labels, got the string {joint_axes!r}"
        )
    labels = tuple(str(label).lower() for label in joint_axes)
    unknown = sorted({label for label in labels if label not in AXIS_LABELS})
    if unknown:
        raise ValueError(f"joint_axes: unknown axis labels {unknown}, expected 'y' or 'z'")
    n_y, n_z = labels.count("y"), labels.count("z")
    if n_y == 0 or n_y != n_z:
        raise ValueError(
            f"joint_axes: need equal, nonzero numbers of y- and z-joints, got {n_y} y and {n_z} z"
        )
    return labels


def joint_reference_pattern(
    joint_axes: Sequence[str], alpha: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint base-angle index and scale factor of eq. (22).

    Args:
        joint_axes: Joint layout (see :func:`check_joint_axes`).
        alpha: Shape parameter ``alpha > 0`` [-].

    Returns:
        ``axis_index`` (n,) with 0 for y-joints and 1 for z-joints (an index into ``q0``), and
        ``scale`` (n,) with ``exp(-alpha (j - 1))``, ``j`` counting joints of the same axis from the
        tail.
    """
    labels = check_joint_axes(joint_axes)
    alpha = float(alpha)
    if not (np.isfinite(alpha) and alpha > 0.0):
        raise ValueError(f"alpha must be positive and finite, got {alpha}")
    axis_index = np.array([AXIS_LABELS.index(label) for label in labels])
    rank = np.array([labels[:i].count(label) for i, label in enumerate(labels)])  # j - 1
    return axis_index, np.exp(-alpha * rank)  # eq. (22)


def joint_references(
    base_angles, joint_axes: Sequence[str], alpha: float, q_max: float
) -> np.ndarray:
    """Joint-angle references ``q*`` (eq. 22), in model order.

    Args:
        base_angles: ``q0 = (q_y0, q_z0)`` [rad] (eq. 23).
        joint_axes: Joint layout, tail to head (see :func:`check_joint_axes`).
        alpha: Shape parameter ``alpha > 0`` [-]; larger values curve mainly the tail.
        q_max: Saturation of the base angles [rad] (> 0).

    Returns:
        ``q*`` (n,) [rad].
    """
    q0 = np.asarray(base_angles, dtype=float)
    if q0.shape != (2,) or not np.all(np.isfinite(q0)):
        raise ValueError(f"base_angles: expected 2 finite values (q_y0, q_z0), got {q0.tolist()}")
    q_max = float(q_max)
    if not (np.isfinite(q_max) and q_max > 0.0):
        raise ValueError(f"q_max must be positive and finite, got {q_max}")
    axis_index, scale = joint_reference_pattern(joint_axes, alpha)
    return np.array(  # eq. (22): aiauv_control.laws.paper_laws.joint_reference
        [laws.joint_reference(q0[a], k, q_max) for a, k in zip(axis_index, scale, strict=True)]
    )


def pointing_law(k_p: float, k_d: float, feedforward: Feedforward = "exact") -> ReducedAttitudeLaw:
    """The law of eq. (23) as a reusable :class:`ReducedAttitudeLaw` (``J = I``, no moments).

    Its ``torque`` output is ``q0 = (q_y0, q_z0)`` [rad] when evaluated on the end-effector frame.
    """
    return ReducedAttitudeLaw(_UNIT_INERTIA, k_p, k_d, feedforward)  # eq. (23) = eq. (9), J = I


def base_angles(
    rotation_to_world,
    angular_velocity_in_ee,
    x_ref,
    x_ref_dot,
    x_ref_ddot,
    k_p: float,
    k_d: float,
    *,
    feedforward: Feedforward = "exact",
) -> np.ndarray:
    """Base angles ``q0 = (q_y0, q_z0)`` [rad] of the joint references (eq. 23).

    ``q0 = -k_P phi_tilde H^T n - k_D omega_tilde^e + H^T R_tilde R_I^e (x_ref x x_ref_ddot)``, plus
    ``mu H^T R_tilde (y x omega_ref^e)`` with ``feedforward="exact"`` (see the module docstring).

    Args:
        rotation_to_world: End-effector-to-world rotation ``R_e^I`` (3x3).
        angular_velocity_in_ee: End-effector angular velocity in its own frame (3,) [rad/s].
        x_ref: Unit reference pointing direction, world frame (3,).
        x_ref_dot: Its first time derivative (3,) [1/s].
        x_ref_ddot: Its second time derivative (3,) [1/s^2].
        k_p: Proportional gain [-] (> 0).
        k_d: Derivative gain [s] (> 0).
        feedforward: ``"exact"`` or ``"paper"``.
    """
    return pointing_law(k_p, k_d, feedforward)(
        rotation_to_world, angular_velocity_in_ee, x_ref, x_ref_dot, x_ref_ddot
    ).torque
