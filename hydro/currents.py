"""Water currents: the velocity of the water at a point and time, as compiled functions.

A current is a function ``current(t, x, y, z, parameters) -> (V_x, V_y, V_z)`` giving the water
velocity [m/s] in world axes at time ``t`` [s] and world point ``(x, y, z)`` [m], compiled with
:func:`aiauv_hydro.numerics.jit.compiled` (a user's own current is any numba function with this
signature), plus its
parameter array. The simulator samples it at every integrator stage at each body's probe point
(:attr:`aiauv_hydro.laws.fluid_terms.FluidModel.current_probe`), and the fluid laws act on each
link's velocity
relative to that water (Fossen 2021, eq. (10.4)).

Built in (:class:`Current` builds them and checks their parameters):

* :func:`constant_current` - uniform and steady (Fossen 2021, Sec. 10.3);
* :func:`tidal_current` - uniform, ``V(t) = V_0 + A sin(2 pi t / T + phi)`` (a tide or a slow
  oscillation; a real tide has ``T`` near 12.42 h);
* :func:`shear_current` - steady, varying linearly with depth, ``V(z) = V_0 + G (z - z_0)`` (a
  boundary-layer or wind-driven profile near a reference depth);
* :func:`aiauv_hydro.waves.kinematics.wave_velocity` (kind ``"waves"``) - the orbital velocity of
  linear waves, regular or irregular (:class:`aiauv_hydro.waves.sea_state.Waves`), plus a uniform
  current; its local acceleration is
  :func:`aiauv_hydro.waves.kinematics.wave_acceleration` (same parameters).

A varying current is applied quasi-steadily (see :mod:`aiauv_pin.kernels.articulated_body`): the
forces use the
relative velocity, and the fluid's own acceleration is neglected.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from aiauv_hydro.numerics.function_identity import stable_uuid
from aiauv_hydro.numerics.jit import compiled, user_or_builtin
from aiauv_hydro.spec import HydroError
from aiauv_hydro.waves import kinematics as wave_kinematics
from aiauv_hydro.waves.kinematics import wave_acceleration, wave_velocity
from aiauv_hydro.waves.sea_state import Waves


@compiled
def constant_current(t, x, y, z, parameters):
    """``V = (p_0, p_1, p_2)`` [m/s] everywhere, at all times."""
    return parameters[0], parameters[1], parameters[2]


@compiled
def tidal_current(t, x, y, z, parameters):
    """``V(t) = V_0 + A sin(2 pi t / T + phi)``; parameters ``(V_0 (3), A (3), T [s], phi [rad])``."""
    s = math.sin(2.0 * math.pi * t / parameters[6] + parameters[7])
    return (
        parameters[0] + parameters[3] * s,
        parameters[1] + parameters[4] * s,
        parameters[2] + parameters[5] * s,
    )


@compiled
def shear_current(t, x, y, z, parameters):
    """``V(z) = V_0 + G (z - z_0)``; parameters ``(V_0 (3) [m/s], G (3) [1/s], z_0 [m])``."""
    dz = z - parameters[6]
    return (
        parameters[0] + parameters[3] * dz,
        parameters[1] + parameters[4] * dz,
        parameters[2] + parameters[5] * dz,
    )


#: ``kind`` numbers of the built-in currents (a user's own function has none: ``-1``).
CONSTANT, TIDAL, SHEAR, WAVES = 0, 1, 2, 3
#: ``kind -> (function, number of parameters it reads)`` of the built-in currents.
BUILTIN_CURRENTS = {
    "constant": (constant_current, 3),
    "tidal": (tidal_current, 8),
    "shear": (shear_current, 7),
    "waves": (wave_velocity, wave_kinematics.HEADER),
}
#: The local acceleration ``dV/dt`` [m/s^2] of the ``"waves"`` current (same parameters), for the
#: acceleration dispatcher of the currents (``builtin_current_acceleration``, kind :data:`WAVES`).
WAVES_ACCELERATION = wave_acceleration


@compiled
def builtin_current(kind, t, x, y, z, parameters):
    """The built-in current number ``kind`` (:data:`CONSTANT`, :data:`TIDAL`, :data:`SHEAR`,
    :data:`WAVES`)."""
    if kind == TIDAL:
        return tidal_current(t, x, y, z, parameters)
    if kind == SHEAR:
        return shear_current(t, x, y, z, parameters)
    if kind == WAVES:
        return wave_velocity(t, x, y, z, parameters)
    return constant_current(t, x, y, z, parameters)


#: ``current_velocity(user, kind, t, x, y, z, parameters) -> (V_x, V_y, V_z)``: a user's function
#: (``user``) or the built-in ``kind`` (``user = None``); see
#: :func:`aiauv_hydro.numerics.jit.user_or_builtin`.
current_velocity = user_or_builtin(builtin_current)


def _vector3(value, name: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise HydroError(f"{name}: expected three numbers, got {value!r}") from None
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise HydroError(f"{name}: expected three finite numbers, got {value!r}")
    return array


def _number(value, name: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise HydroError(f"{name}: expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number) or (positive and number <= 0.0):
        raise HydroError(
            f"{name}: expected a {'positive ' if positive else ''}finite number, got {value!r}"
        )
    return number


@dataclass(frozen=True)
class Current:
    """A water current: a compiled function and its parameters.

    Attributes:
        function: ``current(t, x, y, z, parameters) -> (V_x, V_y, V_z)`` [m/s].
        parameters: Its parameter array.
        kind: A name for reports (``"constant"``, ``"tidal"``, ``"shear"`` or ``"user"``).
    """

    function: Callable
    parameters: np.ndarray
    kind: str = "user"
    description: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        try:
            parameters = np.ascontiguousarray(self.parameters, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise HydroError(
                f"current.parameters: expected an array of numbers, got {self.parameters!r:.60}"
            ) from None
        object.__setattr__(self, "parameters", parameters)
        self.check()
        # named by content before any compiled call, so that the compiled code taking it is found
        # again by later processes (aiauv_hydro.numerics.function_identity)
        stable_uuid(self.function)

    def check(self) -> None:
        """Refuse parameters the compiled code would read past or compute NaN from.

        A built-in current (by ``kind``, or by ``function`` for a ``"user"`` current that is a
        built-in function) reads a fixed number of parameters (:data:`BUILTIN_CURRENTS`): fewer
        would be read past the end of the array (a crash). Every parameter must be finite (a NaN
        velocity makes every acceleration NaN), a tidal period positive. Run again at every
        compiled entry point (the array is mutable). ``function`` must be callable, and a
        built-in ``kind`` must come with its own function (the compiled code chooses by ``kind``,
        Python's :meth:`velocity` by ``function``: they would disagree).

        Raises:
            HydroError: One line naming the problem.
        """
        parameters = self.parameters
        if not isinstance(parameters, np.ndarray) or parameters.dtype != np.float64:
            raise HydroError("current.parameters: expected a float64 array")
        if not callable(self.function):
            raise HydroError(
                f"current.function: expected a compiled function, got {self.function!r:.60}"
            )
        needed = 0
        builtin = BUILTIN_CURRENTS.get(self.kind)
        if builtin is not None:
            if self.function is not builtin[0]:
                raise HydroError(
                    f"current: kind {self.kind!r} needs its own function "
                    f"{builtin[0].__name__}, got {getattr(self.function, '__name__', '?')}"
                )
            needed = builtin[1]
        else:
            for function, count in BUILTIN_CURRENTS.values():
                if self.function is function:
                    needed = count
        if parameters.ndim != 1 or parameters.shape[0] < needed:
            raise HydroError(
                f"current.parameters: a {self.kind} current ({getattr(self.function, '__name__', '?')}) "
                f"reads {needed} parameters, got {parameters.size}"
            )
        if not all(map(math.isfinite, parameters.tolist())):  # faster than np.isfinite here
            raise HydroError("current.parameters: expected finite numbers, got NaN or infinity")
        if self.function is tidal_current and not parameters[6] > 0.0:
            raise HydroError(f"current.period: expected a positive number, got {parameters[6]!r}")
        if self.function is wave_velocity:
            count = parameters[wave_kinematics.COUNT]
            size = wave_kinematics.HEADER + wave_kinematics.STRIDE * count
            if not (count >= 0 and count == int(count) and parameters.size == size):
                raise HydroError(
                    f"current.parameters: a waves current of {count:g} components reads "
                    f"{size:g} parameters, got {parameters.size}"
                )

    @classmethod
    def constant(cls, velocity) -> Current:
        """Uniform, steady current ``velocity`` (3,) [m/s], world axes."""
        v = _vector3(velocity, "current.velocity")
        return cls(constant_current, v, "constant", {"type": "constant", "velocity": v.tolist()})

    @classmethod
    def tidal(cls, mean, amplitude, period: float, phase: float = 0.0) -> Current:
        """``V(t) = mean + amplitude sin(2 pi t / period + phase)`` [m/s]."""
        mean = _vector3(mean, "current.velocity")
        amplitude = _vector3(amplitude, "current.amplitude")
        period = _number(period, "current.period", positive=True)
        phase = _number(phase, "current.phase")
        parameters = np.concatenate((mean, amplitude, [period, phase]))
        description = {
            "type": "tidal",
            "velocity": mean.tolist(),
            "amplitude": amplitude.tolist(),
            "period": period,
            "phase": phase,
        }
        return cls(tidal_current, parameters, "tidal", description)

    @classmethod
    def shear(cls, velocity, gradient, reference_z: float = 0.0) -> Current:
        """``V(z) = velocity + gradient (z - reference_z)`` [m/s], ``gradient`` in [1/s]."""
        velocity = _vector3(velocity, "current.velocity")
        gradient = _vector3(gradient, "current.gradient")
        reference_z = _number(reference_z, "current.reference_z")
        parameters = np.concatenate((velocity, gradient, [reference_z]))
        description = {
            "type": "shear",
            "velocity": velocity.tolist(),
            "gradient": gradient.tolist(),
            "reference_z": reference_z,
        }
        return cls(shear_current, parameters, "shear", description)

    @classmethod
    def waves(cls, sea: Waves, velocity=(0.0, 0.0, 0.0)) -> Current:
        """The water of the sea ``sea`` (:class:`aiauv_hydro.waves.sea_state.Waves`) on a uniform
        current ``velocity`` (3,) [m/s]: the two velocities add (linear superposition, no
        wave-current interaction)."""
        if not isinstance(sea, Waves):
            raise HydroError(f"current.waves: expected a Waves, got {type(sea).__name__:.40}")
        velocity = _vector3(velocity, "current.velocity")
        description = {"type": "waves", "velocity": velocity.tolist(), "waves": sea.describe()}
        return cls(wave_velocity, sea.parameters(velocity), "waves", description)

    @property
    def kind_code(self) -> int:
        """``kind`` of :func:`builtin_current` (-1 for a user's function)."""
        codes = {"constant": CONSTANT, "tidal": TIDAL, "shear": SHEAR, "waves": WAVES}
        return codes.get(self.kind, -1)

    @property
    def user_function(self):
        """The function to pass to compiled code: ``None`` for a built-in current."""
        return None if self.kind_code >= 0 else self.function

    @property
    def is_zero(self) -> bool:
        """True for a constant current of zero velocity."""
        return self.kind == "constant" and not np.any(self.parameters[:3])

    def velocity(self, t: float, position) -> np.ndarray:
        """Water velocity (3,) [m/s] at time ``t`` [s] and world ``position`` (3,) [m]."""
        p = np.asarray(position, dtype=float)
        return np.array(self.function(float(t), p[0], p[1], p[2], self.parameters))

    def describe(self) -> dict:
        """JSON-friendly description for reports."""
        return dict(self.description) or {"type": self.kind, "parameters": self.parameters.tolist()}


#: Keys accepted per current type in a scenario file's ``[current]`` table.
CURRENT_KEYS = {
    "constant": ("type", "velocity"),
    "tidal": ("type", "velocity", "amplitude", "period", "phase"),
    "shear": ("type", "velocity", "gradient", "reference_z"),
}


def as_current(value) -> Current:
    """A :class:`Current` from ``None`` (still water), a velocity (3,) or a :class:`Current`."""
    if isinstance(value, Current):
        return value
    if value is None:
        return Current.constant(np.zeros(3))
    return Current.constant(value)


def current_from_mapping(table: Mapping, where: str = "current") -> Current:
    """A :class:`Current` from a scenario file's table, e.g. ``{"velocity": [0, 0.2, 0]}``.

    ``type`` is ``"constant"`` (default), ``"tidal"`` or ``"shear"``; unknown keys, wrong types and
    non-physical values get a one-line :class:`aiauv_hydro.spec.HydroError` naming the key.
    """
    if not isinstance(table, Mapping):
        raise HydroError(f"{where}: expected a table, got {type(table).__name__}")
    kind = table.get("type", "constant")
    if kind not in CURRENT_KEYS:
        raise HydroError(
            f"{where}.type: unknown current type {kind!r} (expected one of {', '.join(CURRENT_KEYS)})"
        )
    unknown = sorted(set(table) - set(CURRENT_KEYS[kind]))
    if unknown:
        raise HydroError(f"{where}: unknown key {unknown[0]!r} for a {kind} current")
    velocity = table.get("velocity", [0.0, 0.0, 0.0])
    try:
        if kind == "constant":
            return Current.constant(velocity)
        if kind == "tidal":
            for key in ("amplitude", "period"):
                if key not in table:
                    raise HydroError(f"{where}.{key}: required for a tidal current")
            return Current.tidal(
                velocity, table["amplitude"], table["period"], table.get("phase", 0.0)
            )
        if "gradient" not in table:
            raise HydroError(f"{where}.gradient: required for a shear current")
        return Current.shear(velocity, table["gradient"], table.get("reference_z", 0.0))
    except HydroError as exc:
        message = str(exc)
        if message.startswith("current.") and where != "current":
            message = where + message[len("current") :]
        raise HydroError(message) from None
