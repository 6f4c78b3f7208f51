"""The largest stable step of the integrators for a vehicle's joint servo, and the warning of a step near it.

The paper's joint servo (eq. (24), :class:`aiauv_pin.dynamics.joint_servo.JointServo`) is usually the stiffest
part of an AIAUV's dynamics: on the paper's vehicle its fastest mode is -189 1/s (``aiauv
linearize``), which bounds RK4's step at 0.0148 s. Close to that bound a run does not diverge but
is far off, so :func:`warn_if_step_near_limit` warns before such a run. Semi-implicit Euler makes
the servo implicit (:func:`aiauv_control.laws.paper_laws.joint_pd_implicit_terms`) and has no such
bound: on the
paper's scenario it stays within 4.9 mm of the converged path at 0.01 s and 2 cm at 0.04 s, where
the explicit servo went 0.6 m off at 0.01 s and diverged beyond 0.0106 s.

With the base free (no force on it but the servo's reaction), the joints obey
``M_q q_ddot = -K q - C q_dot`` with ``K``, ``C`` the servo's diagonal gains and
``M_q = ((M^-1)_qq)^-1`` the joints' effective inertia (the joint block of the inverse of the whole
mass matrix, added mass included; Featherstone 2008, Sec. 9.2: the articulated inertia seen by the
joints of a floating base). With ``A = [[0, I], [-W K, -W C]]``, ``W = (M^-1)_qq``, one step ``h``
of a method maps ``(q, q_dot)`` by an amplification matrix ``G(h)``; the step is stable when the
spectral radius of ``G`` is at most 1 (e.g. Hairer and Wanner 1996, "Solving ordinary differential
equations II", Sec. IV.2):

* semi-implicit Euler with the servo implicit (``(M_q + h C + h^2 K) (q_dot' - q_dot) = h (-K q -
  C q_dot - h K q_dot)``, ``q' = q + h q_dot'``, i.e. ``M_q (q_dot' - q_dot) / h = -K q' - C
  q_dot'``): implicit Euler, ``G = (I - h A)^-1``, stable at every step when the servo is (Hairer
  and Wanner 1996, Sec. IV.3: A-stability);
* RK4: ``G = I + hA + (hA)^2/2 + (hA)^3/6 + (hA)^4/24``;
* the midpoint method (:func:`aiauv_pin.reference.integrators.midpoint_step`), both stages with the
  servo-implicit acceleration of a step ``h``, ``a(x) = E_v ((I - hA)^-1 - I) x / h``: ``v_1 = v +
  h/2 a(x)``, ``q_1 = q + h/2 v_1``, then ``v' = v + h a(q_1, v_1)``, ``q' = q + h v_1``.

The rest of the dynamics (fluid damping, coupling with the base's motion through velocity terms) is
left out: on the paper's vehicle the servo alone gives -188.4 1/s against the full linearisation's
-189 1/s.

So is the controller: a sampled controller whose joint references feed back the joint rates (the
paper's attitude law, through its gain ``k_d``) closes a discrete loop that this model does not
see. For the midpoint method, whose servo alone is stable at every step, it is that loop which
bounds the step (on the paper's scenario): on the uniform vehicle (``k_d =
19``) the run converges at 0.025 s and oscillates at every step from 0.03 s; at 0.02 s it rings for
the first second (0.003 rad/s half a second in), and the joints' work is 0.174 J instead of the
converged 0.107 J (0.099 J at 0.01 s); with ``k_d = 25`` it oscillates at 0.02 s, with ``k_d =
30`` at 0.01 s, where semi-implicit Euler at 0.004 s converges up to ``k_d = 50`` (and oscillates
at 80).

Why the midpoint method loses range, on a scalar model: the rate loop ``w' = u`` with ``u = -a w``
sampled at ``t + theta dt`` and held over the step, the sample's state predicted with the previous
output (``w_s = w_k + theta dt u_(k-1)``, as the midpoint method's stage, ``theta = 1/2``), gives
``w_(k+1) = w_k - a dt w_s``. Its characteristic polynomial ``z^2 - (1 - (1 + theta) a dt) z -
theta a dt`` has its roots inside the unit circle iff ``a dt < 2 / (1 + 2 theta)`` (Jury's
conditions; checked against the recurrence): 2 for a sample at the step's start (semi-implicit
Euler), 1 at its middle, so half of Euler's stable range of gains at the same step. Predicting the
stage again with the first sample's output (a second sample per step) gives ``a dt < 2`` back, a
third 1.48. On the paper's vehicle the midpoint method keeps less than half (gain margins measured
by :func:`aiauv_pin.tools.run_benchmarks.accuracy_per_cost`: 1.5 at 0.004 s, where Euler keeps 2 at 0.01 s),
which this model does not explain. :func:`warn_if_oscillating` catches the sustained oscillation
after a run (:func:`aiauv_pin.scenario.definition.run_scenario` calls it).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from aiauv_pin.errors import ArgumentError

#: :func:`warn_if_step_near_limit` warns when the step is beyond this fraction of the largest
#: stable step.
STEP_MARGIN = 0.75


class StepNearStabilityLimit(UserWarning):
    """The integration step is close to (or beyond) the largest stable step of the joint servo."""


class EveryStepOscillation(UserWarning):
    """A run's joint rates oscillate from one controller sample to the next: the sampled loop is
    unstable at this step (its output is then far from the continuous closed loop's)."""


#: :func:`warn_if_oscillating` warns above this amplitude of the every-sample component of the
#: joint rates [rad/s, m/s] (an unstable sampled loop on the paper's vehicle: 0.05-0.3 rad/s; a
#: converged run: below 1e-5).
OSCILLATION_THRESHOLD = 1e-3


def amplification(
    joint_inverse_mass: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray,
    method: str,
    h: float,
) -> np.ndarray:
    """``G(h)``: one step of ``method`` on the servo's linear joint dynamics (module docstring).

    Args:
        joint_inverse_mass: ``W = (M^-1)_qq`` (n, n) [1/(kg m^2)].
        stiffness: ``k_p`` per joint (n,) [N m/rad].
        damping: ``k_d`` per joint (n,) [N m s/rad].
        method: ``"euler"`` (semi-implicit, the servo implicit), ``"rk4"`` or ``"midpoint"`` (the
            servo implicit in both stages).
        h: Step [s].

    Returns:
        ``G`` (2n, 2n) acting on ``(q, q_dot)``.
    """
    n = stiffness.shape[0]
    a = _state_matrix(joint_inverse_mass, stiffness, damping)
    if method == "euler":
        return np.linalg.inv(np.eye(2 * n) - h * a)
    if method == "midpoint":
        identity = np.eye(2 * n)
        rows_q, rows_v = identity[:n], identity[n:]
        # the servo-implicit acceleration as a matrix on (q, q_dot) [1/s^2, 1/s]
        acceleration = rows_v @ (np.linalg.inv(identity - h * a) - identity) / h
        v_stage = rows_v + 0.5 * h * acceleration
        q_stage = rows_q + 0.5 * h * v_stage
        stage = np.vstack([q_stage, v_stage])
        return np.vstack([rows_q + h * v_stage, rows_v + h * acceleration @ stage])
    if method == "rk4":
        term = np.eye(2 * n)
        total = term.copy()
        for k in range(1, 5):
            term = term @ (h * a) / k
            total += term
        return total
    raise ArgumentError(f"unknown method {method!r} (expected 'euler', 'rk4' or 'midpoint')")


def _state_matrix(joint_inverse_mass, stiffness, damping) -> np.ndarray:
    """``A = [[0, I], [-W K, -W C]]`` (2n, 2n): the servo's linear joint dynamics [1/s, 1/s^2]."""
    n = stiffness.shape[0]
    return np.block(
        [
            [np.zeros((n, n)), np.eye(n)],
            [-joint_inverse_mass * stiffness[np.newaxis, :], -joint_inverse_mass * damping],
        ]
    )


def spectral_radius(matrix: np.ndarray) -> float:
    """Largest eigenvalue modulus of a square matrix [-]."""
    return float(np.max(np.abs(np.linalg.eigvals(matrix)))) if matrix.size else 0.0


def largest_stable_step(
    joint_inverse_mass: np.ndarray, stiffness: np.ndarray, damping: np.ndarray, method: str
) -> float:
    """The largest step [s] for which ``G(h)`` has spectral radius at most 1 (``inf`` when the
    servo has no stiffness or damping, or when the method stays stable up to ``|h lambda| = 1e6``,
    as semi-implicit Euler with its servo implicit does), by bisection to a relative 1e-6, starting
    from the fastest mode's ``4 / |lambda|`` (above RK4's real-axis limit 2.785)."""
    n = stiffness.shape[0]
    if n == 0 or not (np.any(stiffness > 0.0) or np.any(damping > 0.0)):
        return math.inf
    a = _state_matrix(joint_inverse_mass, stiffness, damping)
    fastest = float(np.max(np.abs(np.linalg.eigvals(a))))
    if fastest == 0.0:
        return math.inf
    stable, unstable = 0.0, 4.0 / fastest
    # the bound can be stable for a mode far from the real axis: widen until unstable
    while _is_stable(joint_inverse_mass, stiffness, damping, method, unstable):
        stable, unstable = unstable, 2.0 * unstable
        if unstable * fastest > 1e6:
            return math.inf
    while unstable - stable > 1e-6 * unstable:
        middle = 0.5 * (stable + unstable)
        if _is_stable(joint_inverse_mass, stiffness, damping, method, middle):
            stable = middle
        else:
            unstable = middle
    return stable


def _is_stable(joint_inverse_mass, stiffness, damping, method, h) -> bool:
    g = amplification(joint_inverse_mass, stiffness, damping, method, h)
    return spectral_radius(g) <= 1.0 + 1e-12


def joint_inverse_mass(vehicle, q: np.ndarray) -> np.ndarray:
    """``(M(q)^-1)_qq``, the joint block of the inverse mass matrix (added mass included) (n, n)."""
    mass = vehicle.mass_matrix(q)
    return np.linalg.inv(mass)[6:, 6:]


def servo_step_limit(vehicle, q: np.ndarray, stiffness, damping, method: str) -> float:
    """The largest stable step [s] of ``method`` for the joint servo of gains ``stiffness``
    [N m/rad] and ``damping`` [N m s/rad] at configuration ``q`` (module docstring)."""
    return largest_stable_step(
        joint_inverse_mass(vehicle, q),
        np.asarray(stiffness, dtype=float),
        np.asarray(damping, dtype=float),
        method,
    )


def warn_if_step_near_limit(vehicle, q: np.ndarray, stiffness, damping, method: str, dt: float):
    """Warn (:class:`StepNearStabilityLimit`) when ``dt`` is beyond :data:`STEP_MARGIN` of the joint
    servo's largest stable step at ``q``; return that step [s]."""
    limit = servo_step_limit(vehicle, q, stiffness, damping, method)
    if dt > STEP_MARGIN * limit:
        name = {"euler": "semi-implicit Euler", "midpoint": "the midpoint method"}.get(
            method, "RK4"
        )
        advice = f"take dt <= {STEP_MARGIN * limit:.3g} s"
        if method != "euler":
            advice += " or method 'euler' (its servo is implicit: stable at any step)"
        warnings.warn(
            f"dt = {dt:g} s is {dt / limit:.0%} of the largest stable step of {name} for the "
            f"joint servo ({limit:.3g} s at the start): the run may stay finite but be far off; "
            f"{advice}",
            StepNearStabilityLimit,
            stacklevel=3,
        )
    return limit


def _alternating_amplitude(x: np.ndarray) -> np.ndarray:
    """Amplitude of the every-sample alternation of each column of ``x`` (k, n): from the second
    differences ``d_k = x_{k+1} - 2 x_k + x_{k-1}`` (blind to a constant and a ramp), ``|sum_k
    (-1)^k d_k| / (4 m)`` over an even number ``m`` of them; an alternation ``A (-1)^k`` gives
    ``A``."""
    d = x[2:] - 2.0 * x[1:-1] + x[:-2]
    m = d.shape[0] - d.shape[0] % 2
    if m < 2:
        return np.zeros(x.shape[1])
    signs = np.where(np.arange(m) % 2 == 0, 1.0, -1.0)
    return np.abs(signs @ d[-m:]) / (4.0 * m)


def every_sample_oscillation(joint_rates: np.ndarray, tail: float = 0.1) -> float:
    """Amplitude of a sustained alternation at every sample of a sampled signal [its unit]: over
    the last ``tail`` of the samples (at least 50), the smaller of the alternation amplitudes of the
    window's two halves (:func:`_alternating_amplitude`) if the second is at least half the first,
    else 0; the largest over the columns.

    A slowly varying signal gives next to nothing (the second differences of a quadratic are
    constant and cancel in pairs), an alternation ``A (-1)^k`` gives ``A``, and one that dies out
    within the window (a loop that rings at the start of a run before it settles: on the paper's
    uniform vehicle at 0.02 s, 0.003 rad/s half a second in, 1e-4 after two) gives 0.

    Args:
        joint_rates: Samples (k,) or (k, n), one per controller sample; fewer than 20 give 0.
        tail: Fraction of the samples, at the end, to look at.
    """
    x = np.asarray(joint_rates, dtype=float)
    if x.ndim == 1:
        x = x[:, np.newaxis]
    m = min(x.shape[0], max(50, int(tail * x.shape[0])))
    if m < 20 or x.shape[1] == 0:  # too short a run to tell a sustained oscillation
        return 0.0
    window = x[-m:]
    half = m // 2
    first = _alternating_amplitude(window[:half])
    second = _alternating_amplitude(window[half:])
    sustained = second >= 0.5 * first  # not dying out over the window
    return float(np.max(np.where(sustained, np.minimum(first, second), 0.0)))


def warn_if_oscillating(joint_rates: np.ndarray, method: str, dt: float, period: float) -> float:
    """Warn (:class:`EveryStepOscillation`) when the joint rates, logged once per controller sample
    of ``period`` [s], oscillate at every sample over the end of the run by more than
    :data:`OSCILLATION_THRESHOLD`; return that amplitude.

    What :func:`warn_if_step_near_limit` cannot see: the loop that a sampled controller closes
    through the joint servo (module docstring). A run that oscillates so stays finite but is far
    from the continuous closed loop (on the paper's uniform vehicle, the midpoint method at 0.04 s
    ends 0.54 m off the converged path). A controller that chatters (switches at every sample, e.g.
    on a saturation) alternates too, by an amount that shrinks with the step rather than vanishing
    below a limit (the paper's gains on a 3-module vehicle: 0.06 rad/s at 4 ms, 0.009 at 0.5 ms with
    semi-implicit Euler); the warning says both.
    """
    amplitude = every_sample_oscillation(joint_rates)
    if amplitude > OSCILLATION_THRESHOLD:
        warnings.warn(
            f"the joint rates oscillate at every controller sample ({amplitude:.2g} rad/s over the "
            f"end of the run) with method {method!r} at dt = {dt:g} s (samples every "
            f"{period:g} s): the sampled control loop is unstable at this step (the run is then far "
            f"off) or chatters, e.g. on a saturation; compare with a smaller step"
            + (" or method 'euler'" if method != "euler" else ""),
            EveryStepOscillation,
            stacklevel=3,
        )
    return amplitude
