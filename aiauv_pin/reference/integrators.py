"""Fixed-step integrators on the configuration Lie group.

The state is ``(q, v)``: ``q`` on the configuration manifold (SE(3) x R^n for a free-flyer base), ``v``
in the tangent space, with ``q_dot = q * v`` (left trivialisation, Pinocchio's ``integrate``) and
``v_dot = f(q, v)``.

:func:`rk4_step` is the Runge-Kutta-Munthe-Kaas method of order 4 (Munthe-Kaas 1999; Hairer, Lubich and
Wanner 2006, Sec. IV.8.2): every stage lives in the tangent space at the step's start,
``q_i = integrate(q_n, xi_i)``, and its velocity is pulled back with the inverse of the right Jacobian
of ``integrate``, ``xi_dot = (d integrate / d xi)^-1 v_i`` (Pinocchio's ``dIntegrate`` w.r.t. its second
argument). Averaging stage velocities directly, ``q_{n+1} = integrate(q_n, h/6 (v1 + 2 v2 + 2 v3 +
v4))``, mixes vectors of different tangent spaces and is only second order for a rotating base.

:func:`semi_implicit_euler_step` is the symplectic Euler method (order 1): ``v`` first, then ``q`` with
the new ``v``.

:func:`midpoint_step` is the explicit midpoint rule (order 2; Hairer, Norsett and Wanner 1993, Sec.
II.1) in two halves, :func:`midpoint_stage` (the state at ``t + dt/2``) and :func:`midpoint_final`,
so that a simulation can sample its controller at the stage. On the group the step is ``q_{n+1} =
q_n * exp(dt v_1)`` with ``v_1`` the stage velocity, which is the step's Magnus increment to second
order (Iserles, Munthe-Kaas, Norsett and Zanna 2000, "Lie-group methods", Sec. 4). Given dynamics
with a joint servo made implicit over ``dt`` (as :func:`aiauv_pin.simulate` gives them), both
stages use that servo-implicit acceleration, as the compiled kernels do
(:func:`aiauv_pin.kernels.articulated_body.midpoint_stage_into`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

#: ``f(q, v) -> dv``, or ``f(q, v, t) -> dv`` when the step is given its start time ``t``.
Dynamics = Callable[..., np.ndarray]

_ARG1 = pin.ArgumentPosition.ARG1


def _tangent_rate(model: pin.Model, q0: np.ndarray, xi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``d xi / dt`` for a stage at ``integrate(q0, xi)`` moving with velocity ``v``."""
    jacobian = pin.dIntegrate(model, q0, xi, _ARG1)
    return np.linalg.solve(jacobian, v)


def _timed(
    dynamics: Dynamics, t: float | None
) -> Callable[[np.ndarray, np.ndarray, float], np.ndarray]:
    if t is None:
        return lambda q, v, _t: dynamics(q, v)
    return dynamics


def rk4_step(
    model: pin.Model,
    dynamics: Dynamics,
    q: np.ndarray,
    v: np.ndarray,
    dt: float,
    t: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """One Runge-Kutta-Munthe-Kaas step of order 4.

    Args:
        model: Pinocchio model (defines the configuration group).
        dynamics: ``f(q, v) -> dv``, or ``f(q, v, t) -> dv`` when ``t`` is given.
        q: Configuration at the step's start (nq,).
        v: Velocity at the step's start (nv,).
        dt: Step [s].
        t: Time at the step's start [s]; the stages are then evaluated at ``t``, ``t + dt/2``
            (twice) and ``t + dt``.

    Returns:
        ``(q, v)`` at the step's end.
    """
    half = 0.5 * dt
    t0 = 0.0 if t is None else t
    dynamics = _timed(dynamics, t)
    a1 = dynamics(q, v, t0)
    k1 = v  # xi = 0: the Jacobian is the identity

    xi = half * k1
    q2 = pin.integrate(model, q, xi)
    v2 = v + half * a1
    a2 = dynamics(q2, v2, t0 + half)
    k2 = _tangent_rate(model, q, xi, v2)

    xi = half * k2
    q3 = pin.integrate(model, q, xi)
    v3 = v + half * a2
    a3 = dynamics(q3, v3, t0 + half)
    k3 = _tangent_rate(model, q, xi, v3)

    xi = dt * k3
    q4 = pin.integrate(model, q, xi)
    v4 = v + dt * a3
    a4 = dynamics(q4, v4, t0 + dt)
    k4 = _tangent_rate(model, q, xi, v4)

    sixth = dt / 6.0
    q_next = pin.integrate(model, q, sixth * (k1 + 2.0 * k2 + 2.0 * k3 + k4))
    v_next = v + sixth * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return q_next, v_next


def semi_implicit_euler_step(
    model: pin.Model,
    dynamics: Dynamics,
    q: np.ndarray,
    v: np.ndarray,
    dt: float,
    t: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """One semi-implicit (symplectic) Euler step: ``v += dt f(q, v)``, then ``q = q * exp(dt v)``."""
    v_next = v + dt * _timed(dynamics, t)(q, v, 0.0 if t is None else t)
    return pin.integrate(model, q, dt * v_next), v_next


def midpoint_stage(
    model: pin.Model,
    dynamics: Dynamics,
    q: np.ndarray,
    v: np.ndarray,
    dt: float,
    t: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The midpoint method's stage: ``v_1 = v + dt/2 f(q, v)``, ``q_1 = q * exp(dt/2 v_1)``, a
    semi-implicit Euler step of ``dt/2`` (with ``dynamics`` whose servo, if implicit, is so over
    the whole ``dt``).

    Returns:
        ``(q_1, v_1)``, the state at ``t + dt/2``.
    """
    return semi_implicit_euler_step(model, dynamics, q, v, 0.5 * dt, t)


def midpoint_final(
    model: pin.Model,
    dynamics: Dynamics,
    q: np.ndarray,
    v: np.ndarray,
    q_mid: np.ndarray,
    v_mid: np.ndarray,
    dt: float,
    t: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The midpoint method's completion from its stage ``(q_mid, v_mid)`` (:func:`midpoint_stage`):
    ``v' = v + dt f(q_1, v_1)`` (at ``t + dt/2``), ``q' = q * exp(dt v_1)``."""
    t_mid = (0.0 if t is None else t) + 0.5 * dt
    v_next = v + dt * _timed(dynamics, t)(q_mid, v_mid, t_mid)
    return pin.integrate(model, q, dt * v_mid), v_next


def midpoint_step(
    model: pin.Model,
    dynamics: Dynamics,
    q: np.ndarray,
    v: np.ndarray,
    dt: float,
    t: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """One step of the midpoint method (order 2): :func:`midpoint_stage`, then :func:`midpoint_final`."""
    q_mid, v_mid = midpoint_stage(model, dynamics, q, v, dt, t)
    return midpoint_final(model, dynamics, q, v, q_mid, v_mid, dt, t)


#: Integrators by name, as accepted by :func:`aiauv_pin.simulate`.
INTEGRATORS = {"rk4": rk4_step, "euler": semi_implicit_euler_step, "midpoint": midpoint_step}

#: Methods whose simulation samples the controller inside each step (at the stage ``t + dt/2``).
SAMPLES_INSIDE_STEP = ("midpoint",)
