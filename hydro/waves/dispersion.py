"""The linear dispersion relation of gravity waves at finite depth, solved for the wavenumber.

``omega^2 = g k tanh(k h)`` (Airy; DNV-RP-C205 (2010), sec. 3.2.2 and Table 3-1; Faltinsen 1990,
"Sea loads on ships and offshore structures", ch. 2, Table 2.1), with ``omega`` [rad/s] the
angular frequency, ``k`` [rad/m] the wavenumber, ``h`` [m] the water depth and ``g`` [m/s^2]
gravity; in deep water (``h`` infinite) ``k = omega^2 / g``.

Solved by Newton's method from the explicit approximation of Fenton and McKee (1990), "On
calculating the lengths of water waves", Coastal Engineering 14, 499-513 (their wavelength
``L = L_0 tanh^(2/3)((k_0 h)^(3/4))``, i.e. ``k h = k_0 h coth^(2/3)((k_0 h)^(3/4))`` with
``k_0 = omega^2 / g``), within 2 % of the root at every depth, from which Newton on
``f(k h) = k h tanh(k h) - k_0 h`` (increasing in ``k h``) converges in three or four steps to
machine precision (the test checks the residual over four decades of depth).
"""

from __future__ import annotations

import math

import numpy as np

#: Newton steps at most (3 to 4 reach machine precision from Fenton and McKee's start).
MAX_NEWTON_STEPS = 50


def wavenumber(omega, depth: float, gravity: float = 9.81) -> np.ndarray:
    """The wavenumber ``k`` [rad/m] of each angular frequency ``omega`` [rad/s] at depth ``depth``
    [m] (``math.inf``: deep water), solving ``omega^2 = g k tanh(k h)`` to machine precision.

    Args:
        omega: Positive angular frequencies [rad/s] (a number or an array).
        depth: Water depth ``h`` [m], positive (``math.inf`` for deep water).
        gravity: ``g`` [m/s^2].

    Returns:
        ``k`` with the shape of ``omega``.
    """
    omega = np.asarray(omega, dtype=float)
    k0 = omega * omega / gravity
    if math.isinf(depth):
        return k0
    k0h = k0 * depth
    kh = k0h / np.tanh(k0h**0.75) ** (2.0 / 3.0)  # Fenton and McKee (1990)
    for _ in range(MAX_NEWTON_STEPS):
        t = np.tanh(kh)
        f = kh * t - k0h  # omega^2 h / g = k h tanh(k h), in units of k h
        step = f / (t + kh * (1.0 - t * t))
        kh = kh - step
        if np.all(np.abs(step) <= 4.0 * np.finfo(float).eps * np.abs(kh)):
            break
    return kh / depth
