"""Intervention laws: hold or move a frame's 6-DOF pose while thrusters and joints share the work,
with strict task priority (the frame first, then low effort and a body posture in its null space).

Plain NumPy on matrices (no Pinocchio): the caller gives the mass matrix ``M`` [kg, kg m^2], the
bias ``b`` (``M dv + b = tau``), the frame Jacobian ``J`` (world-aligned: the frame origin's
velocity and the angular velocity, both in world axes), ``J_dot v`` and the actuator matrix ``A``
(the thrust matrix ``B(q)`` and one unit column per joint motor,
:func:`aiauv_control.allocation.problem.actuator_matrix`).

Sources:

- Khatib 1987, "A unified approach for motion and force control of robot manipulators: the
  operational space formulation", *IEEE J. Robotics and Automation* RA-3(1), pp. 43-53: the
  task-space inertia ``Lambda = (J M^-1 J^T)^-1``, the dynamically consistent generalised inverse
  ``J_bar = M^-1 J^T Lambda`` and the null-space projector ``N = I - J_bar J``
  (:func:`dynamically_consistent_inverse`, :func:`null_space_projector`).
- Mistry & Righetti 2011, "Operational space control of constrained and underactuated systems",
  *Robotics: Science and Systems* VII: the operational-space law written in the actuator space of
  an underactuated floating base, ``G = J M^-1 A``; here with a weighted pseudo-inverse of ``G``
  whose weight is the secondary task's Hessian (:func:`prioritised_actuation`). With full actuation
  (``A = I``) and the weight ``M^-1`` it is Khatib's law (``tests/control/test_intervention_laws.py``).
- Kanoun, Lamiraux & Wieber 2011, "Kinematic control of redundant manipulators: generalizing the
  task-priority framework to inequality tasks", *IEEE Trans. Robotics* 27(4), pp. 785-792: strict
  priority with inequality constraints as a sequence of QPs, each keeping the optimum of the ones
  before (:func:`prioritised_actuation_limited`, the actuators' limits as the inequalities).
- Flash & Hogan 1985, "The coordination of arm movements", *J. Neuroscience* 5(7), pp. 1688-1703:
  the minimum-jerk profile ``10 s^3 - 15 s^4 + 6 s^5`` of a commanded move (:func:`minimum_jerk`).
- Murray, Li & Sastry 1994, *A Mathematical Introduction to Robotic Manipulation*, Sec. 2.2
  (the exponential coordinates of a rotation, :func:`rotation_log`).
"""

from __future__ import annotations

import math

import numpy as np

#: Names of the task axes: the frame origin's position along the world x, y, z axes and the
#: rotations about the world x, y, z axes (the entries of :func:`pose_error`).
TASK_AXES = ("x", "y", "z", "rx", "ry", "rz")


def rotation_log(rotation: np.ndarray) -> np.ndarray:
    """The rotation vector ``theta k`` [rad] of a rotation matrix (``R = exp([theta k]_x)``,
    ``0 <= theta <= pi``; Murray, Li & Sastry 1994, Sec. 2.2).

    Near ``theta = pi`` the axis is read from ``R + I = 2 k k^T`` (``(1 - cos) k k^T`` with
    ``cos = -1``) instead of the vanishing skew part.
    """
    R = np.asarray(rotation, dtype=float)
    cosine = min(1.0, max(-1.0, 0.5 * (np.trace(R) - 1.0)))
    theta = math.acos(cosine)
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if theta < 1e-6:  # theta / (2 sin theta) = 1/2 + theta^2 / 12 + ...
        return (0.5 + theta * theta / 12.0) * skew
    if math.pi - theta > 1e-4:
        return theta / (2.0 * math.sin(theta)) * skew
    outer = 0.5 * (R + np.eye(3))  # ~ k k^T near pi
    column = int(np.argmax(np.diag(outer)))
    axis = outer[:, column] / math.sqrt(max(outer[column, column], 1e-300))
    if axis @ skew < 0.0:  # the skew part (2 sin(theta) k) still carries the sign
        axis = -axis
    return theta * axis


def pose_error(
    rotation: np.ndarray, position: np.ndarray, target_rotation: np.ndarray, target_position
) -> np.ndarray:
    """``(p_d - p, log(R_d R^T))`` (6,) [m, rad]: the position error and the rotation vector that
    turns the frame onto the target, both in world axes (the entries named :data:`TASK_AXES`)."""
    out = np.empty(6)
    out[:3] = np.asarray(target_position, dtype=float) - np.asarray(position, dtype=float)
    out[3:] = rotation_log(np.asarray(target_rotation) @ np.asarray(rotation).T)
    return out


def task_acceleration(
    error, rate_error, integral, feedforward, stiffness, damping, integral_gain
) -> np.ndarray:
    """The commanded task acceleration ``a* = a_ref + K_d (nu_ref - nu) + K_p e + K_i int e``
    [m/s^2, rad/s^2] (a PID on the pose error with the reference's acceleration fed forward;
    every gain a vector of per-axis diagonal entries [1/s^2], [1/s], [1/s^3])."""
    return (
        np.asarray(feedforward, dtype=float)
        + np.asarray(damping) * np.asarray(rate_error)
        + np.asarray(stiffness) * np.asarray(error)
        + np.asarray(integral_gain) * np.asarray(integral)
    )


def dynamically_consistent_inverse(mass: np.ndarray, jacobian: np.ndarray):
    """``(J_bar, Lambda)``: ``Lambda = (J M^-1 J^T)^-1`` and ``J_bar = M^-1 J^T Lambda`` (Khatib
    1987, eqs. for the operational-space inertia and the dynamically consistent inverse)."""
    M = np.asarray(mass, dtype=float)
    J = np.asarray(jacobian, dtype=float)
    m_inv_jt = np.linalg.solve(M, J.T)
    inertia = np.linalg.inv(J @ m_inv_jt)
    return m_inv_jt @ inertia, inertia


def null_space_projector(mass: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
    """``N = I - J_bar J`` (nv x nv; Khatib 1987): accelerations ``N a_0`` leave the task's
    acceleration unchanged (``J N = 0``), ``N^2 = N``, and ``M N = N^T M`` (dynamic consistency: a
    torque ``N^T tau_0`` produces no task acceleration)."""
    j_bar, _ = dynamically_consistent_inverse(mass, jacobian)
    J = np.asarray(jacobian, dtype=float)
    return np.eye(J.shape[1]) - j_bar @ J


def weighted_pseudo_inverse(matrix: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """``G^# = Q^-1 G^T (G Q^-1 G^T)^-1`` for a full-row-rank ``G`` and a positive definite ``Q``:
    the minimiser of ``w^T Q w`` among the solutions of ``G w = r`` is ``G^# r``."""
    G = np.asarray(matrix, dtype=float)
    q_inv_gt = np.linalg.solve(np.asarray(weight, dtype=float), G.T)
    return q_inv_gt @ np.linalg.inv(G @ q_inv_gt)


def secondary_objective(response, offset, target, actuator_weights, posture_weights):
    """``(Q, c)`` of the secondary task ``|W_u w|^2 + |W_p (a(w) - a_0)|^2 = w^T Q w - 2 c^T w +
    const`` with the acceleration ``a(w) = H w - h`` (``H = M^-1 A``, ``h = M^-1 b``):
    ``Q = W_u^2 + H^T W_p^2 H``, ``c = H^T W_p^2 (a_0 + h)``.

    Args:
        response: ``H`` (n, n_a) [1/kg, ...]: accelerations per unit actuator force.
        offset: ``h`` (n,) [m/s^2, rad/s^2]: the acceleration of the bias alone, negated.
        target: ``a_0`` (n,): the posture's desired acceleration.
        actuator_weights: ``W_u`` diagonal (n_a,) [1/N, 1/(N m)], positive.
        posture_weights: ``W_p`` diagonal (n,) [s^2/m, s^2/rad], non-negative.
    """
    H = np.asarray(response, dtype=float)
    wp2 = np.asarray(posture_weights, dtype=float) ** 2
    hessian = np.diag(np.asarray(actuator_weights, dtype=float) ** 2) + H.T @ (wp2[:, None] * H)
    linear = H.T @ (wp2 * (np.asarray(target) + np.asarray(offset)))
    return hessian, linear


def prioritised_actuation(task_matrix, task_target, hessian, linear) -> np.ndarray:
    """The actuator forces that produce the task exactly and, among those, minimise the secondary
    objective ``w^T Q w / 2 - c^T w`` (no limits)::

        w = G^# r + (I - G^# G) Q^-1 c,     G^# = Q^-1 G^T (G Q^-1 G^T)^-1

    ``I - G^# G`` is the projector onto the task's null space in the actuator space (Mistry &
    Righetti 2011; Khatib 1987 for ``A = I``, ``Q = M^-1``, where ``G^# = J^T Lambda`` and the
    projector is ``N^T``). ``G`` must have full row rank (:func:`unproducible_axes`).
    """
    G = np.asarray(task_matrix, dtype=float)
    g_sharp = weighted_pseudo_inverse(G, hessian)
    free = np.linalg.solve(np.asarray(hessian, dtype=float), np.asarray(linear, dtype=float))
    return g_sharp @ np.asarray(task_target, dtype=float) + free - g_sharp @ (G @ free)


def prioritised_actuation_limited(
    task_matrix, task_target, hessian, linear, lower, upper, task_weights=None
):
    """:func:`prioritised_actuation` with the actuators' limits ``lower <= w <= upper``, as two QPs
    in strict priority (Kanoun, Lamiraux & Wieber 2011), solved by ProxQP (``proxsuite``):

    1. ``r_1 = G w_1`` with ``w_1`` minimising ``|W_t (G w - r)|^2 + eps |w|^2`` within the limits
       (the task as close as the limits allow; ``eps`` a regularisation of ``1e-9`` times the
       scale of ``G^T G``);
    2. ``w`` minimising the secondary objective subject to ``G w = r_1`` and the limits.

    The closed form is returned when it is within the limits (it is then the answer of both QPs).

    Returns:
        ``(w, limited)``: the actuator forces and whether the limits changed the answer.
    """
    G = np.asarray(task_matrix, dtype=float)
    r = np.asarray(task_target, dtype=float)
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    w = prioritised_actuation(G, r, hessian, linear)
    if np.all(w >= lower) and np.all(w <= upper):
        return w, False
    import proxsuite  # a heavy import, only when a limit binds

    weights = np.ones(G.shape[0]) if task_weights is None else np.asarray(task_weights, float)
    wg = weights[:, None] * G
    first_hessian = wg.T @ wg
    first_hessian += 1e-9 * max(1.0, float(np.abs(first_hessian).max())) * np.eye(G.shape[1])
    first = proxsuite.proxqp.dense.solve(
        first_hessian, -(wg.T @ (weights * r)), l_box=lower, u_box=upper, eps_abs=1e-9
    )
    w_1 = np.clip(first.x, lower, upper)
    achieved = G @ w_1
    second = proxsuite.proxqp.dense.solve(
        np.asarray(hessian, dtype=float),
        -np.asarray(linear, dtype=float),
        A=G,
        b=achieved,
        l_box=lower,
        u_box=upper,
        eps_abs=1e-9,
    )
    solved = second.info.status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
    w_2 = np.clip(second.x, lower, upper)
    if solved and np.all(np.isfinite(w_2)):
        return w_2, True
    return w_1, True


def unproducible_axes(task_matrix: np.ndarray, tolerance: float = 1e-6) -> tuple[int, ...]:
    """Rows ``i`` of the task for which no actuator force produces the unit task acceleration
    ``e_i``: the relative least-squares residual ``|e_i - G G^+ e_i|`` exceeds ``0.5`` (``G^+``
    with singular values below ``tolerance`` times the largest dropped)."""
    G = np.asarray(task_matrix, dtype=float)
    if not np.any(G):
        return tuple(range(G.shape[0]))
    U, S, _ = np.linalg.svd(G, full_matrices=False)
    kept = U[:, S > tolerance * S[0]]
    residual = np.eye(G.shape[0]) - kept @ kept.T
    return tuple(int(i) for i in np.flatnonzero(np.linalg.norm(residual, axis=0) > 0.5))


def minimum_jerk(s: float) -> tuple[float, float, float]:
    """``(sigma, d sigma / ds, d^2 sigma / ds^2)`` of the minimum-jerk profile
    ``sigma = 10 s^3 - 15 s^4 + 6 s^5`` on ``s`` in ``[0, 1]`` (Flash & Hogan 1985), clamped
    outside: zero velocity and acceleration at both ends."""
    if s <= 0.0:
        return 0.0, 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0, 0.0
    s2 = s * s
    return (
        s2 * s * (10.0 - 15.0 * s + 6.0 * s2),
        30.0 * s2 * (1.0 - 2.0 * s + s2),
        60.0 * s * (1.0 - 3.0 * s + 2.0 * s2),
    )
