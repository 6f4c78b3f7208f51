"""Joint PD control with hydrostatic compensation (paper, eq. 24).

``tau_q,i = -k_qP (q_i - q*_i) - k_qD q_dot_i + g_q,i``

Sign convention: ``g_q`` is the joint part of the generalised hydrostatic force ``g(q, eta)`` **as
it appears on the left-hand side** of ``M zeta_dot + C zeta + D zeta + g = tau`` (eq. 19), i.e. the
generalised force the joint motors must *supply* to hold the joints against gravity and buoyancy.
Compensating it therefore means **adding** ``g_q`` to the torque. If a simulator provides the
hydrostatic generalised force acting *on* the system (the right-hand-side convention, e.g. gravity
plus buoyancy projected with the Jacobians), pass its negative.

The reference is treated as a setpoint (its derivative is not fed forward), as in the paper.
"""

from __future__ import annotations

import numpy as np

from aiauv_control.laws import paper_laws as laws


def _array(value, n: int | None, name: str) -> np.ndarray:
    array = np.atleast_1d(np.asarray(value, dtype=float))
    if array.ndim != 1 or (n is not None and array.shape != (n,)):
        expected = "a 1-D array" if n is None else f"shape ({n},)"
        raise ValueError(f"{name}: expected {expected}, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    return array


def joint_torques(
    joint_positions,
    joint_velocities,
    joint_references,
    joint_hydrostatic_forces,
    k_qp: float,
    k_qd: float,
) -> np.ndarray:
    """Joint torques of eq. (24).

    Args:
        joint_positions: ``q`` (n,) [rad].
        joint_velocities: ``q_dot`` (n,) [rad/s].
        joint_references: ``q*`` (n,) [rad] (eq. 22).
        joint_hydrostatic_forces: ``g_q`` (n,) [N m], left-hand-side convention (module docstring).
        k_qp: Proportional gain [N m/rad] (>= 0).
        k_qd: Derivative gain [N m s/rad] (>= 0).

    Returns:
        ``tau_q`` (n,) [N m].
    """
    q = _array(joint_positions, None, "joint_positions")
    n = q.size
    q_dot = _array(joint_velocities, n, "joint_velocities")
    q_ref = _array(joint_references, n, "joint_references")
    g_q = _array(joint_hydrostatic_forces, n, "joint_hydrostatic_forces")
    for name, gain in (("k_qp", k_qp), ("k_qd", k_qd)):
        if not (np.isfinite(gain) and gain >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0, got {gain}")
    return np.array(  # eq. (24): aiauv_control.laws.paper_laws.joint_pd_torque
        [laws.joint_pd_torque(q[j], q_dot[j], q_ref[j], g_q[j], k_qp, k_qd) for j in range(n)]
    )
