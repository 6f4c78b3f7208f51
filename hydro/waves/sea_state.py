"""A sea state: a regular wave or an irregular sea, checked, with its parameter array.

:class:`Waves` holds what a user gives (the keys of a scenario file's ``[waves]`` table) and
builds the components and the flat parameter array that the compiled functions of
:mod:`aiauv_hydro.waves.kinematics` read.

Rules (each a one-line :class:`aiauv_hydro.spec.HydroError` naming the key):

* ``height`` ``H`` (regular) or ``H_s`` (irregular) [m] not negative; ``period`` ``T`` or ``T_p``
  [s] positive; ``depth`` positive (``math.inf``: deep water);
* a regular wave steeper than breaking: ``H / L > 0.142 tanh(k h)`` (Miche 1944; ``1/7`` in deep
  water, Michell 1893), with ``L`` the linear wavelength;
* an irregular sea with ``T_p < 3.6 sqrt(H_s)`` (below the validity of the spectra, DNV-RP-C205
  sec. 3.5.5; :data:`aiauv_hydro.waves.spectra.MIN_PERIOD_RATIO`), or a peak enhancement outside
  ``[1, 7]``;
* a point below the sea floor or above the still-water level (:meth:`Waves.check_point`: the
  scenario checks the start).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from aiauv_hydro.spec import HydroError
from aiauv_hydro.waves import kinematics, spectra
from aiauv_hydro.waves.dispersion import wavenumber

#: Kinds of sea: a regular (Airy) wave, a regular stream-function wave (raschii's Fenton wave,
#: optional), or an irregular sea of one of two spectra.
KINDS = ("regular", "fenton", "jonswap", "pierson_moskowitz")
#: Directional spreading of an irregular sea (``none``: long-crested).
SPREADINGS = ("none", "cos_n", "cos_2s")
#: Steepest regular wave, ``H / L = MICHE tanh(k h)`` (Miche 1944; 1/7 in deep water).
MICHE = 0.142
#: Components of an irregular sea at most (the compiled loop sums them at every probe and stage).
MAX_COMPONENTS = 10_000
#: Keys of a ``[waves]`` table (the fields of :class:`Waves`).
WAVES_KEYS = (
    "type",
    "height",
    "period",
    "heading",
    "depth",
    "surface_z",
    "phase",
    "peak_enhancement",
    "spreading",
    "spreading_exponent",
    "components",
    "seed",
    "order",
)
#: Largest order (number of Fourier harmonics) of a stream-function wave.
MAX_ORDER = 50


def _number(value, name: str, *, low: float = -math.inf, low_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise HydroError(f"waves.{name}: expected a number, got {value!r:.40}")
    number = float(value)
    if math.isnan(number) or number < low or (low_open and number == low):
        bound = f"{'>' if low_open else '>='} {low:g}" if low > -math.inf else "a number"
        raise HydroError(f"waves.{name}: expected {bound}, got {value!r}")
    return number


def _check_breaking(height: float, k: float, depth: float) -> None:
    """Refuse a regular wave steeper than Miche's limit ``H / L = 0.142 tanh(k h)``."""
    length = 2.0 * math.pi / k
    limit = MICHE * (math.tanh(k * depth) if math.isfinite(depth) else 1.0)
    if height / length > limit:
        raise HydroError(
            f"waves.height: H / L = {height:g} / {length:.4g} m = {height / length:.3f} "
            f"exceeds the breaking limit {limit:.3f} (Miche: 0.142 tanh(k h); 1/7 deep)"
        )


def _whole(value, name: str) -> int:
    """A whole number (an integral float, as sweeps and TOML numbers give, is taken)."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise HydroError(f"waves.{name}: expected a whole number, got {value!r:.40}")
    return int(value)


@dataclass(frozen=True)
class Waves:
    """A regular wave (linear or stream-function) or an irregular sea (linear).

    Attributes:
        type: ``"regular"`` (Airy), ``"fenton"`` (stream function, raschii), ``"jonswap"`` or
            ``"pierson_moskowitz"``.
        height: Wave height ``H`` (crest to trough, regular) or significant height ``H_s``
            (irregular) [m].
        period: Period ``T`` (regular) or peak period ``T_p`` (irregular) [s].
        heading: Direction the waves travel to [rad], from the world x-axis about z (a vehicle
            going along +x meets head seas at ``pi``, beam seas at ``pi / 2``).
        depth: Water depth ``h`` [m] (sea floor at ``surface_z - depth``; ``math.inf``: deep).
        surface_z: World ``z`` of the still-water level [m] (world z up).
        phase: Phase ``eps`` of a regular wave [rad] (crest at the origin at ``t = 0`` for 0).
        peak_enhancement: JONSWAP ``gamma`` [-] (``None``: DNV-RP-C205's rule from
            ``T_p / sqrt(H_s)``).
        spreading: ``"none"`` (long-crested), ``"cos_n"`` or ``"cos_2s"`` (short-crested).
        spreading_exponent: ``n`` of ``cos_n`` or ``s`` of ``cos_2s`` [-].
        components: Number ``N`` of components of an irregular sea.
        seed: Seed of the phases (and directions) of an irregular sea.
        order: Number ``N`` of Fourier harmonics of a ``"fenton"`` wave.
        gravity: ``g`` [m/s^2] of the dispersion relation.
    """

    type: str = "regular"
    height: float = 1.0
    period: float = 6.0
    heading: float = 0.0
    depth: float = math.inf
    surface_z: float = 0.0
    phase: float = 0.0
    peak_enhancement: float | None = None
    spreading: str = "none"
    spreading_exponent: float = 2.0
    components: int = 100
    seed: int = 0
    order: int = 10
    gravity: float = 9.81
    #: ``(a, omega, k, beta, eps, e)`` per component, each ``(N,)`` (built from the fields).
    table: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.type not in KINDS:
            raise HydroError(
                f"waves.type: unknown sea {self.type!r} (expected one of {', '.join(KINDS)})"
            )
        if self.spreading not in SPREADINGS:
            raise HydroError(
                f"waves.spreading: unknown spreading {self.spreading!r} "
                f"(expected one of {', '.join(SPREADINGS)})"
            )
        height = _number(self.height, "height", low=0.0)
        period = _number(self.period, "period", low=0.0, low_open=True)
        depth = _number(self.depth, "depth", low=0.0, low_open=True)
        for name in ("heading", "surface_z", "phase"):
            value = _number(getattr(self, name), name)
            if not math.isfinite(value):
                raise HydroError(f"waves.{name}: expected a finite number, got {value!r}")
        gravity = _number(self.gravity, "gravity", low=0.0, low_open=True)
        if not math.isfinite(height) or not math.isfinite(period) or not math.isfinite(gravity):
            raise HydroError("waves: height, period and gravity must be finite")
        if self.type == "regular":
            table = self._regular(height, period, depth, gravity)
        elif self.type == "fenton":
            table = self._fenton(height, period, depth, gravity)
        else:
            table = self._irregular(height, period, depth, gravity)
        object.__setattr__(self, "table", table)

    def _regular(self, height, period, depth, gravity):
        omega = 2.0 * math.pi / period
        k = float(wavenumber(omega, depth, gravity))
        _check_breaking(height, k, depth)
        one = np.ones(1)
        return (
            0.5 * height * one,
            omega * one,
            k * one,
            self.heading * one,
            self.phase * one,
            0.5 * height * one,
        )

    def _fenton(self, height, period, depth, gravity):
        """raschii's stream-function wave (Rienecker and Fenton 1981) as ``N`` harmonics.

        raschii's velocity in the earth frame (``raschii/wave_fenton.py``, ``_velocity``) is
        ``u = k sum_J J B_J cos(J k (x - c t)) cosh(J k z') / cosh(J k h)``,
        ``w = k sum_J J B_J sin(J k (x - c t)) sinh(J k z') / cosh(J k h)`` with ``z'`` from the
        sea floor and no mean current: harmonic ``J`` is a linear component of wavenumber
        ``J k``, frequency ``J omega`` and amplitude ``a_J = k B_J tanh(J k h) / omega``. Its
        elevation (``_surface_elevation``) is the cosine series ``2 / N trapz_J(E_J cos(J k (x -
        c t)))`` above the floor: ``e_J = 2 E_J / N`` (half at ``J = N``), the constant term being
        the still-water depth (Fenton's mean level).
        """
        if math.isinf(depth):
            raise HydroError("waves.depth: a fenton wave needs a finite depth")
        order = _whole(self.order, "order")
        if not 1 <= order <= MAX_ORDER:
            raise HydroError(f"waves.order: expected 1 to {MAX_ORDER}, got {order}")
        object.__setattr__(self, "order", order)
        _check_breaking(height, float(wavenumber(2.0 * math.pi / period, depth, gravity)), depth)
        try:
            import raschii
        except ImportError:
            raise HydroError(
                "waves.type: a fenton wave needs the optional package raschii "
                "(pip install 'aiauv-pin[waves]')"
            ) from None
        try:
            wave = raschii.FentonWave(height, depth, period=period, N=order, g=gravity)
        except (raschii.RaschiiError, ValueError, FloatingPointError) as exc:
            reason = " ".join(str(exc).split())
            raise HydroError(f"waves: raschii found no fenton wave ({reason:.120})") from None
        k, omega = float(wave.k), float(wave.omega)
        harmonics = np.arange(1, order + 1)
        b = np.asarray(wave.data["B"], dtype=float)[1:]
        elevation = 2.0 * np.asarray(wave.E, dtype=float)[1:] / order
        elevation[-1] *= 0.5
        return (
            k * b * np.tanh(harmonics * k * depth) / omega,
            harmonics * omega,
            harmonics * k,
            np.full(order, float(self.heading)),
            harmonics * self.phase,
            elevation,
        )

    def _irregular(self, height, period, depth, gravity):
        count = _whole(self.components, "components")
        if not 1 <= count <= MAX_COMPONENTS:
            raise HydroError(f"waves.components: expected 1 to {MAX_COMPONENTS}, got {count}")
        seed = _whole(self.seed, "seed")
        if seed < 0:
            raise HydroError(f"waves.seed: expected a number >= 0, got {seed}")
        object.__setattr__(self, "components", count)
        object.__setattr__(self, "seed", seed)
        if height > 0.0 and period < spectra.MIN_PERIOD_RATIO * math.sqrt(height):
            raise HydroError(
                f"waves.period: T_p = {period:g} s is below the spectra's validity, "
                f"3.6 sqrt(H_s) = {spectra.MIN_PERIOD_RATIO * math.sqrt(height):.3g} s "
                "(DNV-RP-C205 sec. 3.5.5)"
            )
        if self.type == "pierson_moskowitz":
            if self.peak_enhancement not in (None, 1, 1.0):
                raise HydroError("waves.peak_enhancement: a Pierson-Moskowitz sea has gamma = 1")
            gamma = 1.0
        elif self.peak_enhancement is None:
            gamma = spectra.default_peak_enhancement(height, period)
        else:
            gamma = _number(self.peak_enhancement, "peak_enhancement", low=spectra.GAMMA_RANGE[0])
            if gamma > spectra.GAMMA_RANGE[1]:
                raise HydroError(
                    f"waves.peak_enhancement: expected gamma in [1, 7], got {gamma:g} "
                    "(the spectrum's normalisation A_gamma holds there)"
                )
        exponent = _number(self.spreading_exponent, "spreading_exponent", low=0.0, low_open=True)
        if not math.isfinite(exponent) or exponent > 100.0:
            raise HydroError(f"waves.spreading_exponent: expected (0, 100], got {exponent!r}")
        amplitudes, omegas, offsets, phases = spectra.discretise(
            height, period, gamma, count, seed, self.spreading, exponent
        )
        return (
            amplitudes,
            omegas,
            wavenumber(omegas, depth, gravity),
            self.heading + offsets,
            phases,
            amplitudes,
        )

    @property
    def deep(self) -> bool:
        """Whether the water is deep (``depth`` infinite)."""
        return math.isinf(self.depth)

    @property
    def floor_z(self) -> float:
        """World ``z`` of the sea floor [m] (``-inf`` in deep water)."""
        return self.surface_z - self.depth

    @property
    def variance(self) -> float:
        """Variance of the elevation, ``sum e_i^2 / 2`` [m^2] (``H_s^2 / 16`` of a sea)."""
        return float(np.sum(self.table[5] ** 2) / 2.0)

    def parameters(self, velocity=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The flat parameter array of :mod:`aiauv_hydro.waves.kinematics`, with a uniform
        current ``velocity`` (3,) [m/s] added."""
        a, omega, k, beta, eps, e = self.table
        count = a.shape[0]
        out = np.empty(kinematics.HEADER + kinematics.STRIDE * count)
        out[:3] = velocity
        out[kinematics.SURFACE_Z] = self.surface_z
        out[kinematics.DEPTH] = -1.0 if self.deep else self.depth
        out[kinematics.COUNT] = count
        rows = out[kinematics.HEADER :].reshape(count, kinematics.STRIDE)
        rows[:, 0], rows[:, 1], rows[:, 2] = a, omega, k
        rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 6] = np.cos(beta), np.sin(beta), eps, e
        return out

    def check_point(self, z: float, name: str = "the point") -> None:
        """Refuse a point below the sea floor or above the still-water level (one line; the
        vehicle's hydrostatics assume it submerged)."""
        if z > self.surface_z:
            raise HydroError(
                f"waves.surface_z: {name} (z = {z:g} m) is above the still-water level "
                f"(z = {self.surface_z:g} m)"
            )
        if z < self.floor_z:
            raise HydroError(
                f"waves.depth: the sea floor (z = {self.floor_z:g} m) is above {name} (z = {z:g} m)"
            )

    def describe(self) -> dict:
        """The ``[waves]`` table of this sea (JSON-friendly; deep water has no ``depth``)."""
        out = {"type": self.type, "height": float(self.height), "period": float(self.period)}
        out["heading"] = float(self.heading)
        if not self.deep:
            out["depth"] = float(self.depth)
        out["surface_z"] = float(self.surface_z)
        if self.type in ("regular", "fenton"):
            out["phase"] = float(self.phase)
            if self.type == "fenton":
                out["order"] = int(self.order)
            return out
        if self.type == "jonswap" and self.peak_enhancement is not None:
            out["peak_enhancement"] = float(self.peak_enhancement)
        out["spreading"] = self.spreading
        if self.spreading != "none":
            out["spreading_exponent"] = float(self.spreading_exponent)
        out["components"] = int(self.components)
        out["seed"] = int(self.seed)
        return out

    @classmethod
    def from_mapping(cls, table: Mapping, where: str = "waves") -> Waves:
        """A sea from a scenario file's ``[waves]`` table (unknown keys: one line)."""
        if not isinstance(table, Mapping):
            raise HydroError(f"{where}: expected a table, got {type(table).__name__}")
        unknown = sorted(set(table) - set(WAVES_KEYS))
        if unknown:
            raise HydroError(f"{where}: unknown key {unknown[0]!r}")
        try:
            return cls(**dict(table))
        except HydroError as exc:
            message = str(exc)
            if where != "waves" and message.startswith("waves"):
                message = where + message[len("waves") :]
            raise HydroError(message) from None
