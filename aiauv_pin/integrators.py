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


#: Integrators by name, as accepted by :func:`aiauv_pin.simulate`.
INTEGRATORS = {"rk4": rk4_step, "euler": semi_implicit_euler_step}
