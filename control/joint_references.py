"""Joint-angle references that steer the pointing direction by curving the body (paper, Sec. 3.4).

The joint layout is the sequence of axis labels of the actuated joints in model order, tail to
head, e.g. ``("z", "y", "z", "y", ...)`` for the paper's vehicle (joints 1, 3, 5, 7 about z; 2, 4,
6, 8 about y). The paper's vehicle has equally many of each; the law below takes any numbers in any
order: each axis's joints get the exponential pattern of eq. (22) counted from the
tail, a joint about a negative axis the opposite sign, and a joint about the body axis x none.

* Base angles ``q0 = (q_y0, q_z0)`` (eq. 23) are the reduced-attitude law of Section 2 evaluated on
  the end-effector frame ``e`` with unit inertia and no known moments: eq. (23) is eq. (9) with
  ``J = I`` and ``m = 0``. With ``feedforward="exact"`` (the default) the finding-2 correction of
  :mod:`aiauv_control.reduced_attitude` is therefore ``mu H^T R_tilde (y x omega_ref^e)`` (no ``J``); with
  ``"paper"`` it is eq. (23) as printed. The joints act on the pointing direction only indirectly,
  so neither choice guarantees tracking here (paper, Sec. 3.4); the exact one keeps the structure
  that gives ``V_dot = -k_D |omega_tilde|^2`` in the rigid-body case.
* Joint references (eq. 22): the ``j``-th joint about axis ``a`` (``j = 1`` nearest the tail) gets
  ``q*_{a,j} = s exp(-alpha (j - 1)) sat(q_{a,0})``, ``sat`` clipping to ``[-q_max, q_max]``, with
  ``s = -1`` for a joint about the link's negative axis (``s = 1`` on the paper's vehicle).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from aiauv_control.laws import paper_laws as laws
from aiauv_control.reduced_attitude import Feedforward, ReducedAttitudeLaw

AXIS_LABELS = ("y", "z")
"""Steering axis labels; their order is also the order of the base angles ``q0 = (q_y0, q_z0)``."""

#: Every joint label :func:`check_joint_axes` accepts: an axis of the joint's link, with an
#: optional sign (``"-z"``: the joint turns about the link's negative z-axis). ``"x"`` joints (about
#: the body's own axis) cannot curve it and are held straight.
JOINT_LABELS = ("y", "z", "x", "+y", "+z", "+x", "-y", "-z", "-x")

_UNIT_INERTIA = np.eye(3)
_UNIT_INERTIA.setflags(write=False)


class JointLayoutWarning(UserWarning):
    """The joints steer about one axis only: the other axis's error is left to the thrusters."""


def check_joint_axes(joint_axes: Sequence[str]) -> tuple[str, ...]:
    """Validate a joint layout and return it as a tuple of signed lower-case labels (``"+y"``,
    ``"-z"``, ``"+x"``, ...).

    Any number of pitch (``y``) and yaw (``z``) joints in any order steers (universal joints are two
    consecutive labels, single-axis modules one each). A layout with joints about one axis only
    (e.g. a planar snake with yaw joints only) steers about that axis and warns
    (:class:`JointLayoutWarning`): the other axis's error is left to the thrusters, or not
    corrected. Joints about the body axis ``x`` are held straight.

    Args:
        joint_axes: Axis label of each actuated joint, model order, tail to head: ``"y"``, ``"z"``
            or ``"x"``, with an optional sign ``+``/``-`` for a joint turning about the link's
            negative axis.

    Raises:
        ValueError: unknown label, no joints, or no joint that can steer (every axis along x).
    """
    signed = _signed_labels(joint_axes)
    n_y = sum(label[1] == "y" for label in signed)
    n_z = sum(label[1] == "z" for label in signed)
    if n_y == 0 or n_z == 0:
        steered, other = ("yaw (z)", "pitch (y)") if n_y == 0 else ("pitch (y)", "yaw (z)")
        warnings.warn(
            f"joint_axes: the joints steer in {steered} only; the {other} error is not corrected "
            "by the joints (only by thrusters, if the vehicle has them for it)",
            JointLayoutWarning,
            stacklevel=2,
        )
    return signed


def _signed_labels(joint_axes: Sequence[str]) -> tuple[str, ...]:
    """:func:`check_joint_axes` without its warning."""
    if isinstance(joint_axes, str):
        raise ValueError(
            f"joint_axes: expected a sequence of 'y'/'z' labels, got the string {joint_axes!r}"
        )
    labels = tuple(str(label).lower().strip() for label in joint_axes)
    unknown = sorted({label for label in labels if label not in JOINT_LABELS})
    if unknown:
        raise ValueError(
            f"joint_axes: unknown axis labels {unknown}, expected 'y', 'z' or 'x' (signed: '-z')"
        )
    signed = tuple(label if label[0] in "+-" else "+" + label for label in labels)
    n_y = sum(label[1] == "y" for label in signed)
    n_z = sum(label[1] == "z" for label in signed)
    if n_y == 0 and n_z == 0:
        what = "has no joints" if not signed else "has joints about the body axis x only"
        raise ValueError(
            f"joint_axes: the body cannot be curved to steer: the vehicle {what} (the paper's "
            "law needs joints about a link y- or z-axis)"
        )
    return signed


def joint_reference_pattern(
    joint_axes: Sequence[str], alpha: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint base-angle index and scale factor of eq. (22), for any layout.

    Args:
        joint_axes: Joint layout (see :func:`check_joint_axes`).
        alpha: Shape parameter ``alpha > 0`` [-].

    Returns:
        ``axis_index`` (n,) with 0 for y-joints and 1 for z-joints (an index into ``q0``; 0 for
        x-joints), and ``scale`` (n,) with ``sign exp(-alpha (j - 1))``, ``j`` counting joints of
        the same axis from the tail and ``sign`` -1 for a joint about the negative axis (0 for
        x-joints, held straight). On the paper's layout (equal numbers of ``+y`` and ``+z``
        joints) it is eq. (22) as printed.
    """
    labels = _signed_labels(joint_axes)
    alpha = float(alpha)
    if not (np.isfinite(alpha) and alpha > 0.0):
        raise ValueError(f"alpha must be positive and finite, got {alpha}")
    axes = [label[1] for label in labels]
    axis_index = np.array([AXIS_LABELS.index(axis) if axis != "x" else 0 for axis in axes])
    rank = np.array([axes[:i].count(axis) for i, axis in enumerate(axes)])  # j - 1
    sign = np.array(
        [
            0.0 if axis == "x" else (-1.0 if label[0] == "-" else 1.0)
            for axis, label in zip(axes, labels, strict=True)
        ]
    )
    return axis_index, sign * np.exp(-alpha * rank)  # eq. (22), per axis, signed


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
