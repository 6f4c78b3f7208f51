"""Transition Jacobians of one integrator step in the tangent space, for linear analysis and MPC.

For the step ``(q', v') = step(q, v, u)`` of :mod:`aiauv_pin.reference.integrators` (RK4 Munthe-Kaas or
semi-implicit Euler) with the input ``u = (thrusts [N], joint torques [N m])`` held over the step as
the simulator holds a controller's output (``tau = tau_0 + B(q) thrusts + S joint_torques``
evaluated at the step's start):

    (dq', dv') = A (dq, dv) + B du,

``dq`` and ``dq'`` in the tangent spaces of ``q`` and ``q'`` (``q (+) dq``, ``pinocchio.integrate``).
Exact: the compiled forward-mode derivative of the step of :mod:`aiauv_pin.kernels.step_jacobians`, built
on the exact acceleration derivatives of :mod:`aiauv_pin.model.derivatives` (MuJoCo's
``mjd_transitionFD`` takes finite differences instead).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aiauv_hydro.currents import as_current
from aiauv_pin._internal.array_checks import (
    finite_time,
    float_array,
    method_name,
    optional_current,
    positive_seconds,
)
from aiauv_pin.errors import project_errors
from aiauv_pin.model.derivatives import compiled_derivatives, refuse_fins, uniform_current

#: Integration methods with transition Jacobians.
METHODS = ("rk4", "euler")


class TransitionJacobians(NamedTuple):
    """One step and its Jacobians.

    Attributes:
        q_next, v_next: The state after the step.
        A: ``d(dq', dv') / d(dq, dv)`` (2 nv, 2 nv).
        B: ``d(dq', dv') / d(thrusts, joint torques)`` (2 nv, m + nv - 6) [per N, per N m].
    """

    q_next: np.ndarray
    v_next: np.ndarray
    A: np.ndarray
    B: np.ndarray


@project_errors("transition_jacobians")
def transition_jacobians(
    vehicle,
    q,
    v,
    thrusts=None,
    joint_torques=None,
    *,
    dt: float,
    method: str = "rk4",
    current=None,
    t: float = 0.0,
    tau=None,
) -> TransitionJacobians:
    """One step of ``method`` from ``(q, v)`` and its exact transition Jacobians (compiled kernels).

    Args:
        vehicle: The :class:`aiauv_pin.Vehicle` (its compiled model is built on first use).
        q, v: State (nq,), (nv,).
        thrusts: Thruster forces (m,) [N] (default 0).
        joint_torques: Joint torques (nv - 6,) [N m] (default 0).
        dt: Step [s].
        method: ``"rk4"`` or ``"euler"`` (semi-implicit).
        current: ``None``, a uniform velocity (3,) [m/s] or a uniform :class:`aiauv_hydro.currents.Current`.
        t: Time at the start of the step [s].
        tau: A further generalised force held over the step (nv,) [N, N m] (default 0).

    Raises:
        ArgumentError: Bad shapes or values, a non-uniform current, an unknown method.
    """
    from aiauv_pin.kernels import articulated_body as kernels
    from aiauv_pin.kernels.step_jacobians import transition_into

    refuse_fins(vehicle, "transition_jacobians")
    method = method_name(method, METHODS)
    q, v = vehicle._q(q), vehicle._v(v)
    nv, m = vehicle.nv, len(vehicle.hydro.thrusters)
    thrusts = np.zeros(m) if thrusts is None else float_array(thrusts, "thrusts", (m,))
    joint_torques = (
        np.zeros(nv - 6)
        if joint_torques is None
        else float_array(joint_torques, "joint_torques", (nv - 6,))
    )
    tau0 = np.zeros(nv) if tau is None else vehicle._v(tau, "tau")
    tau0 = tau0.copy()
    tau0[6:] += joint_torques
    dt = positive_seconds(dt, "dt")
    t = finite_time(t)
    uniform_current(current, t)  # checks it is uniform in space
    derivatives = compiled_derivatives(vehicle)
    fast = derivatives._fast
    water = as_current(optional_current(current))
    env = fast.environment(None if water.is_zero else water)
    q_next, v_next = np.empty(vehicle.nq), np.empty(nv)
    a_matrix, b_matrix = np.empty((2 * nv, 2 * nv)), np.empty((2 * nv, m + nv - 6))
    transition_into(
        fast.model,
        env,
        t,
        q,
        v,
        tau0,
        np.ascontiguousarray(thrusts),
        dt,
        kernels.RK4 if method == "rk4" else kernels.EULER,
        fast.workspace,
        derivatives.workspace,
        (q_next, v_next),
        a_matrix,
        b_matrix,
    )
    return TransitionJacobians(q_next, v_next, a_matrix, b_matrix)
