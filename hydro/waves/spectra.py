"""Wave spectra and their discretisation into a seeded set of regular components.

Spectra (DNV-RP-C205 (2010), sec. 3.5.5; ``omega`` [rad/s], ``omega_p = 2 pi / T_p``):

* Pierson-Moskowitz, ``S_PM(omega) = 5/16 H_s^2 omega_p^4 omega^-5 exp(-5/4 (omega/omega_p)^-4)``
  [m^2 s/rad]; its variance is exactly ``H_s^2 / 16`` (its cumulative is
  ``H_s^2/16 exp(-5/4 (omega/omega_p)^-4)``);
* JONSWAP, ``S_J(omega) = A_gamma S_PM(omega) gamma^exp(-0.5 ((omega - omega_p) / (sigma
  omega_p))^2)`` with ``sigma = 0.07`` for ``omega <= omega_p`` and ``0.09`` above, and the
  normalising factor ``A_gamma = 1 - 0.287 ln(gamma)``, which keeps the
  variance within 2 % of ``H_s^2 / 16`` for ``1 <= gamma <= 7`` (tested);
* the peak enhancement when not given: ``gamma = 5`` for ``T_p / sqrt(H_s) <= 3.6``,
  ``exp(5.75 - 1.15 T_p / sqrt(H_s))`` between 3.6 and 5, and 1 from 5 on (``T_p``
  in s, ``H_s`` in m).

Validity: DNV-RP-C205 sec. 3.5.5 gives the JONSWAP spectrum as a reasonable model for
``3.6 < T_p / sqrt(H_s) < 5``; below 3.6 the sea would be steeper than the wind seas it was fitted
to (and than breaking allows), so a peak period ``T_p < 3.6 sqrt(H_s)`` is refused for both spectra
(:data:`MIN_PERIOD_RATIO`); above 5 the JONSWAP spectrum tends to Pierson-Moskowitz (``gamma = 1``).

Directional spreading (short-crested seas; DNV-RP-C205 sec. 3.5.8, ``theta`` the direction the
waves travel to, ``theta_p`` the main direction):

* ``cos_n``: ``D(theta) = Gamma(1 + n/2) / (sqrt(pi) Gamma(1/2 + n/2)) cos^n(theta - theta_p)``
  for ``|theta - theta_p| <= pi/2`` (``n`` 2 to 4 for wind seas, 6 or more for swell);
* ``cos_2s``: ``D(theta) = Gamma(s + 1) / (2 sqrt(pi) Gamma(s + 1/2)) cos^(2s)((theta -
  theta_p) / 2)`` for ``|theta - theta_p| <= pi`` (Longuet-Higgins, Cartwright and Smith 1963).

Discretisation (:func:`discretise`): ``N`` components of equal energy ("equal-area"): the
frequency axis is cut into ``N`` bins that each hold ``1/N`` of the variance, and each component
sits at the energy median of its bin, with amplitude ``a_i = sqrt(2 H_s^2 / (16 N))``, so that
``sum a_i^2 / 2 = H_s^2 / 16`` exactly (the spectrum's shape chooses the frequencies; ``H_s`` is
the one asked for, the ``A_gamma`` approximation does not change it). Equal energy puts the
components where the energy is, and the frequencies are not multiples of one step, so the record
does not repeat after ``2 pi / d omega`` as an equally spaced sum does (Faltinsen 1990, ch. 2).
Random frequencies would do the same at the price of an amplitude per frequency bin that scatters
from seed to seed; equal energy keeps ``H_s`` exact for every seed. Phases
are uniform on ``[0, 2 pi)`` from the seed. In a short-crested sea each frequency gets one
direction (the single-summation model, which keeps the sea ergodic and Gaussian; Jefferys 1987,
"Directional seas should be ergodic", Applied Ocean Research 9(4)): ``N`` equal-probability
direction bins of ``D``, at their medians, dealt to the frequencies in a random order from the
seed.
"""

from __future__ import annotations

import math

import numpy as np

#: Smallest ``T_p / sqrt(H_s)`` [s/sqrt(m)] accepted (DNV-RP-C205 sec. 3.5.5).
MIN_PERIOD_RATIO = 3.6
#: Range of the peak enhancement ``gamma`` in which the spectrum's normalisation holds (2 %).
GAMMA_RANGE = (1.0, 7.0)
#: Frequency grid for the cumulative of the JONSWAP spectrum, in units of ``omega_p``: its tail
#: beyond ``OMEGA_MAX`` holds ``1.25 / OMEGA_MAX^4 = 8e-6`` of the variance (the PM tail), below
#: ``OMEGA_MIN`` ``exp(-1.25 / OMEGA_MIN^4) < 1e-40``.
OMEGA_MIN, OMEGA_MAX, GRID_POINTS = 0.2, 20.0, 200_001


def default_peak_enhancement(hs: float, tp: float) -> float:
    """DNV-RP-C205 sec. 3.5.5: ``gamma`` from ``T_p / sqrt(H_s)`` (5, then decreasing to 1)."""
    ratio = tp / math.sqrt(hs) if hs > 0.0 else math.inf
    if ratio <= 3.6:
        return 5.0
    if ratio < 5.0:
        return math.exp(5.75 - 1.15 * ratio)
    return 1.0


def pierson_moskowitz(omega, hs: float, tp: float) -> np.ndarray:
    """``S_PM(omega)`` [m^2 s/rad] (DNV-RP-C205 sec. 3.5.5)."""
    omega = np.asarray(omega, dtype=float)
    wp = 2.0 * math.pi / tp
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        r = omega / wp
        s = 5.0 / 16.0 * hs * hs * wp**4 * omega**-5 * np.exp(-1.25 * r**-4)
    return np.where(omega > 0.0, s, 0.0)


def jonswap(omega, hs: float, tp: float, gamma: float) -> np.ndarray:
    """``S_J(omega)`` [m^2 s/rad] (DNV-RP-C205 sec. 3.5.5, with ``A_gamma``)."""
    omega = np.asarray(omega, dtype=float)
    wp = 2.0 * math.pi / tp
    sigma = np.where(omega <= wp, 0.07, 0.09)
    peak = gamma ** np.exp(-0.5 * ((omega - wp) / (sigma * wp)) ** 2)
    return (1.0 - 0.287 * math.log(gamma)) * pierson_moskowitz(omega, hs, tp) * peak


def equal_energy_frequencies(count: int, tp: float, gamma: float) -> np.ndarray:
    """The energy medians [rad/s] of ``count`` bins of equal variance of the spectrum's shape
    (Pierson-Moskowitz for ``gamma = 1``: its cumulative inverted exactly; else a fine grid)."""
    wp = 2.0 * math.pi / tp
    levels = (np.arange(count) + 0.5) / count
    if gamma == 1.0:  # F(omega) = exp(-5/4 (omega/omega_p)^-4), inverted
        return wp * (-1.25 / np.log(levels)) ** 0.25
    omega = wp * np.linspace(OMEGA_MIN, OMEGA_MAX, GRID_POINTS)
    density = jonswap(omega, 4.0, tp, gamma)
    cumulative = np.concatenate(([0.0], np.cumsum(0.5 * (density[1:] + density[:-1]))))
    cumulative /= cumulative[-1]
    return np.interp(levels, cumulative, omega)


def spreading_density(theta, kind: str, exponent: float) -> np.ndarray:
    """``D(theta)`` [1/rad] of a spreading about ``theta_p = 0`` (``cos_n`` or ``cos_2s``)."""
    theta = np.asarray(theta, dtype=float)
    if kind == "cos_n":
        n = exponent
        scale = math.gamma(1.0 + n / 2.0) / (math.sqrt(math.pi) * math.gamma(0.5 + n / 2.0))
        inside = np.abs(theta) <= 0.5 * math.pi
        return np.where(inside, scale * np.abs(np.cos(theta)) ** n, 0.0)
    s = exponent
    scale = math.gamma(s + 1.0) / (2.0 * math.sqrt(math.pi) * math.gamma(s + 0.5))
    inside = np.abs(theta) <= math.pi
    return np.where(inside, scale * np.abs(np.cos(0.5 * theta)) ** (2.0 * s), 0.0)


def equal_probability_directions(count: int, kind: str, exponent: float) -> np.ndarray:
    """The medians [rad] of ``count`` bins of equal probability of ``D`` about 0."""
    half = 0.5 * math.pi if kind == "cos_n" else math.pi
    theta = np.linspace(-half, half, 100_001)
    density = spreading_density(theta, kind, exponent)
    cumulative = np.concatenate(([0.0], np.cumsum(0.5 * (density[1:] + density[:-1]))))
    cumulative /= cumulative[-1]
    return np.interp((np.arange(count) + 0.5) / count, cumulative, theta)


def discretise(
    hs: float,
    tp: float,
    gamma: float,
    count: int,
    seed: int,
    spreading: str = "none",
    exponent: float = 0.0,
):
    """``count`` components of equal energy of a JONSWAP sea (``gamma = 1``: Pierson-Moskowitz).

    Returns:
        ``(amplitudes [m], omegas [rad/s], direction offsets [rad] from the main direction,
        phases [rad])``, each ``(count,)``; ``sum amplitudes^2 / 2 = hs^2 / 16``.
    """
    rng = np.random.default_rng(seed)
    phases = rng.uniform(0.0, 2.0 * math.pi, count)
    omegas = equal_energy_frequencies(count, tp, gamma)
    amplitudes = np.full(count, math.sqrt(2.0 * hs * hs / (16.0 * count)))
    if spreading == "none":
        offsets = np.zeros(count)
    else:
        offsets = rng.permutation(equal_probability_directions(count, spreading, exponent))
    return amplitudes, omegas, offsets, phases
