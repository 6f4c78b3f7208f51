"""Surge-speed PI control on the longitudinal thrusters (paper, eq. 25), with anti-windup.

``T = sat(-k_1P (u - u_d) - k_1I integral_0^t (u - u_d) dtau)``, the same thrust ``T`` [N] for every
longitudinal (x) thruster, saturated at ``+-max_thrust``.

Discrete time: the controller is sampled by the caller. The error integral advances at each call by
the error of the previous call times the time elapsed since it (the exact integral of the error held
constant between samples: zero-order hold); the first call after construction or :meth:`reset`
integrates nothing.

Anti-windup by conditional integration: if the previous output was saturated and its error pushed
further into that saturation (too slow while at ``+max_thrust``, too fast while at ``-max_thrust``),
the integral is frozen for that interval. The integral thus never grows while the thrust limit is
active, and integration resumes as soon as the error changes sign or the output leaves the limit.
"""

from __future__ import annotations

import numpy as np

from aiauv_control.laws import paper_laws as laws


def _finite(value, name: str) -> float:
    number = float(value)
    if not np.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value}")
    return number


class SurgePIController:
    """PI controller for the surge speed ``u`` with conditional-integration anti-windup (eq. 25).

    Args:
        k_p: Proportional gain ``k_1P`` [N s/m] (>= 0).
        k_i: Integral gain ``k_1I`` [N/m] (>= 0).
        u_d: Desired surge speed [m/s].
        max_thrust: Thrust limit of each longitudinal thruster [N] (> 0).
    """

    def __init__(self, k_p: float, k_i: float, u_d: float, max_thrust: float) -> None:
        for name, gain in (("k_1p", k_p), ("k_1i", k_i)):
            if not (np.isfinite(gain) and gain >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {gain}")
        if not (np.isfinite(max_thrust) and max_thrust > 0.0):
            raise ValueError(f"max_thrust must be positive and finite, got {max_thrust}")
        self.k_p = float(k_p)
        self.k_i = float(k_i)
        self.u_d = _finite(u_d, "u_d")
        self.max_thrust = float(max_thrust)
        self.reset()

    def reset(self) -> None:
        """Clear the integral and the sampling history."""
        self.state = laws.new_surge_state()

    @property
    def integral(self) -> float:
        """Current value of ``integral (u - u_d) dt`` [m]."""
        return float(self.state.integral[0])

    @property
    def saturated(self) -> bool:
        """True if the last output was clipped at the thrust limit."""
        return self.state.saturation[0] != 0.0

    def update(self, t: float, surge_velocity: float) -> float:
        """Advance the integral to time ``t`` and return the thrust per longitudinal thruster [N].

        Args:
            t: Time [s], not earlier than that of the previous call.
            surge_velocity: Measured surge speed ``u`` [m/s].

        Raises:
            ValueError: non-finite input or time going backwards.
        """
        t = _finite(t, "t")
        u = _finite(surge_velocity, "surge_velocity")
        if self.state.has_previous[0] and t < self.state.time[0]:
            raise ValueError(f"time went backwards: t = {t} < previous {self.state.time[0]}")
        return float(  # eq. (25): aiauv_control.laws.paper_laws.surge_pi
            laws.surge_pi(self.state, t, u, self.k_p, self.k_i, self.u_d, self.max_thrust)
        )
