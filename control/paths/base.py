"""Base of the paths: the :class:`PathPoint` record, the :class:`Path` interface, input checks.

See :mod:`aiauv_control.paths` for the frame convention.
"""

from __future__ import annotations

import abc
import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from aiauv_hydro.numerics.function_identity import stable_uuid

Vector3 = tuple[float, float, float]

#: A direction whose horizontal part is shorter than this (unit vector) counts as vertical [-].
VERTICAL_TOLERANCE = 1e-6


class PathPoint(NamedTuple):
    """The closest point of a path to a position, and the path frame there (world frame)."""

    s: float
    """Arc length of the closest point [m] (origin: see each path)."""
    point: Vector3
    """Closest point of the path [m]."""
    tangent: Vector3
    """Unit tangent ``T`` (direction of increasing ``s``) [-]."""
    normal1: Vector3
    """First normal ``N1`` of the rotation-minimising frame [-]."""
    normal2: Vector3
    """Second normal ``N2 = T x N1`` [-]."""
    curvature1: float
    """``k1 = (dT/ds) . N1`` [1/m]."""
    curvature2: float
    """``k2 = (dT/ds) . N2`` [1/m]."""
    curvature1_rate: float
    """``dk1/ds`` [1/m^2]."""
    curvature2_rate: float
    """``dk2/ds`` [1/m^2]."""


# --------------------------------------------------------------------------------------------
# Python classes
# --------------------------------------------------------------------------------------------


class PathError(ValueError):
    """A bad path parameter; ``str()`` is one line ``path.<key>: <problem>``."""

    def __init__(self, key: str, problem: str, where: str = "path"):
        self.key, self.problem = key, problem
        super().__init__(f"{where}.{key}: {problem}")


def _vector(value, key: str) -> np.ndarray:
    if isinstance(value, (str, bytes, bool)) or (
        isinstance(value, (list, tuple)) and any(isinstance(x, (str, bytes, bool)) for x in value)
    ):
        raise PathError(key, f"expected 3 numbers, got {value!r}")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise PathError(key, f"expected 3 numbers, got {value!r}") from None
    if array.shape != (3,):
        raise PathError(key, f"expected 3 numbers, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise PathError(key, "contains NaN or infinite values")
    return array


def _unit(value, key: str) -> np.ndarray:
    array = _vector(value, key)
    norm = float(np.linalg.norm(array))
    if norm == 0.0:
        raise PathError(key, "zero vector")
    return array / norm


def _number(value, key: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise PathError(key, f"expected a number, got {value!r}")
    number = float(value)
    if not math.isfinite(number):
        raise PathError(key, "must be finite")
    if positive and not number > 0.0:
        raise PathError(key, f"must be > 0, got {number:g}")
    return number


def _as_tuple(array: np.ndarray) -> Vector3:
    return tuple(float(x) for x in array)  # type: ignore[return-value]


def _position(position) -> np.ndarray:
    try:
        return np.ascontiguousarray(_vector(position, "position"))
    except PathError as error:
        raise ValueError(f"position: {error.problem}") from None


def _path_point(result) -> PathPoint:
    """A :class:`PathPoint` with plain floats, whatever the function returned (tuple or record)."""
    s, point, tangent, normal1, normal2, k1, k2, k1_rate, k2_rate = result
    return PathPoint(
        float(s),
        _as_tuple(point),
        _as_tuple(tangent),
        _as_tuple(normal1),
        _as_tuple(normal2),
        float(k1),
        float(k2),
        float(k1_rate),
        float(k2_rate),
    )


class Path(abc.ABC):
    """Common interface: a compiled function, its parameters, and conveniences around them.

    Subclasses are frozen dataclasses that fill :attr:`params` in ``__post_init__``, set
    :attr:`function` and :attr:`type_name`, and register in :data:`PATH_TYPES`.
    """

    type_name: ClassVar[str]
    function: ClassVar[Callable]
    #: Number of a built-in path in :func:`aiauv_control.paths.builtin_path_point` (-1: a user's own).
    kind_code: ClassVar[int] = -1

    @property
    def user_function(self):
        """The function to pass to compiled code: ``None`` for a built-in path (chosen by
        :attr:`kind_code`; see :func:`aiauv_hydro.numerics.jit.user_or_builtin`)."""
        return None if self.kind_code >= 0 else self.function

    params: np.ndarray

    def closest(self, position) -> PathPoint:
        """The path point closest to ``position`` (3,) [m] (world frame) and the frame there."""
        p = _position(position)
        return _path_point(self.function(p, self.params))

    def cross_track_error(self, position) -> np.ndarray:
        """Components of ``position - closest point`` along ``(N1, N2)`` (2,) [m]."""
        p = _position(position)
        q = _path_point(self.function(p, self.params))
        e = (p[0] - q.point[0], p[1] - q.point[1], p[2] - q.point[2])
        n1, n2 = q.normal1, q.normal2
        return np.array(
            [
                e[0] * n1[0] + e[1] * n1[1] + e[2] * n1[2],
                e[0] * n2[0] + e[1] * n2[1] + e[2] * n2[2],
            ]
        )

    @abc.abstractmethod
    def points_at(self, s) -> np.ndarray:
        """World points (n, 3) [m] at arc lengths ``s`` (n,) [m]."""

    def sample(self, s_range: float | tuple[float, float], n: int = 200) -> np.ndarray:
        """``n`` world points (n, 3) [m] evenly spaced in arc length, for drawing.

        Args:
            s_range: ``(s_min, s_max)`` [m], or a length ``L`` meaning ``(0, L)``.
            n: Number of points (>= 2).
        """
        if isinstance(s_range, (int, float)):
            s_min, s_max = 0.0, float(s_range)
        else:
            s_min, s_max = (float(x) for x in s_range)
        if not (math.isfinite(s_min) and math.isfinite(s_max) and s_max > s_min):
            raise ValueError(f"s_range: need finite s_min < s_max, got ({s_min:g}, {s_max:g})")
        if int(n) < 2:
            raise ValueError(f"n: need at least 2 points, got {n}")
        return self.points_at(np.linspace(s_min, s_max, int(n)))

    def describe(self) -> dict[str, Any]:
        """Type and parameters, JSON-friendly; :func:`from_mapping` rebuilds the path from it."""
        table: dict[str, Any] = {"type": self.type_name}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            if f.init:
                value = getattr(self, f.name)
                table[f.name] = (
                    [list(v) if isinstance(v, tuple) else v for v in value]
                    if isinstance(value, tuple) and value and isinstance(value[0], tuple)
                    else list(value)
                    if isinstance(value, tuple)
                    else value
                )
        return table


@dataclass(frozen=True, eq=False)
class UserPath(Path):
    """A user's own path: a compiled ``function(position, params) -> PathPoint`` (or any callable
    returning the same nine fields) and its parameter array.

    :meth:`points_at` (and so :meth:`sample`) marches along the path with ``function`` alone:
    from the path point nearest the origin, ``q <- closest(q + (s - s_q) T_q)`` until ``s_q = s``
    (steps limited to a quarter of the radius of curvature).
    """

    function: Callable  # type: ignore[misc]
    params: np.ndarray

    type_name: ClassVar[str] = "user"

    def __post_init__(self):
        if not callable(self.function):
            raise PathError("function", f"expected a callable, got {self.function!r}")
        try:
            params = np.ascontiguousarray(self.params, dtype=np.float64)
        except (TypeError, ValueError):
            raise PathError("params", "expected an array of numbers") from None
        if params.ndim != 1 or not np.isfinite(params).all():
            raise PathError("params", "expected a 1-D array of finite numbers")
        object.__setattr__(self, "params", params)
        # named by content before any compiled call, so that the compiled code taking it is found
        # again by later processes (aiauv_hydro.numerics.function_identity)
        stable_uuid(self.function)

    def points_at(self, s) -> np.ndarray:
        s = np.asarray(s, dtype=float)
        out = np.empty((len(s), 3))
        q = self.closest(np.zeros(3))
        for i in np.argsort(s):
            for _ in range(1000):
                gap = s[i] - q.s
                if abs(gap) <= 1e-9 * max(1.0, abs(s[i])):
                    break
                curvature = math.hypot(q.curvature1, q.curvature2)
                step = (
                    gap if curvature == 0.0 else math.copysign(min(abs(gap), 0.25 / curvature), gap)
                )
                q = self.closest(np.add(q.point, np.multiply(step, q.tangent)))
            out[i] = q.point
        return out

    def describe(self) -> dict[str, Any]:
        name = getattr(self.function, "__qualname__", None) or repr(self.function)
        module = getattr(self.function, "__module__", "")
        return {"type": "user", "function": f"{module}.{name}", "params": self.params.tolist()}
