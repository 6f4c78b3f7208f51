"""The allocation problem's parameters, its answer, and the checks of a request.

Sources: Fossen 2021, *Handbook of Marine Craft Hydrodynamics and Motion Control*, 2nd ed.,
Ch. 11 "Control allocation" (the thrust configuration matrix, weighted least squares with
limits); Johansen & Fossen 2013, "Control allocation - A survey", *Automatica* 49(5),
pp. 1087-1103 (constrained linear allocation as a quadratic programme).

The actuators are the thrusters (the columns of the thrust matrix ``B(q)``, nv x m, of
:meth:`aiauv_pin.Vehicle.thrust_matrix`) and, optionally, joint motors sharing the task: a joint
torque on generalised coordinate ``i`` is the generalised force ``e_i``, an identity column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


class AllocationError(ValueError):
    """A request the allocator cannot take (one line saying why)."""


def _floats(values, name: str) -> tuple[float, ...]:
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise AllocationError(f"{name}: expected numbers, got {values!r}") from None
    if array.ndim != 1:
        raise AllocationError(f"{name}: expected a 1-D sequence, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise AllocationError(f"{name}: contains NaN or infinite values")
    return tuple(float(x) for x in array)


def _check_limits(low, high, name: str) -> None:
    if len(low) != len(high):
        raise AllocationError(f"{name}: {len(low)} minima but {len(high)} maxima")
    for k, (a, b) in enumerate(zip(low, high, strict=True)):
        if not a < b:
            raise AllocationError(f"{name} {k}: minimum {a} must be below maximum {b}")
        if not a <= 0.0 <= b:
            raise AllocationError(f"{name} {k}: limits [{a}, {b}] must include zero")


def _check_weights(weights, n: int, name: str) -> None:
    if len(weights) != n:
        raise AllocationError(f"{name}: expected {n} weights, got {len(weights)}")
    for k, w in enumerate(weights):
        if not w > 0.0:
            raise AllocationError(f"{name} {k}: weights must be positive, got {w}")


@dataclass(frozen=True)
class AllocationParameters:
    """The actuators' limits and the weights of the allocation (module docstring).

    Attributes:
        thrust_min: Lowest thrust of each thruster [N] (m,), ``<= 0``.
        thrust_max: Highest thrust of each thruster [N] (m,), ``>= 0`` and ``> thrust_min``.
        thrust_weights: ``W_u`` entries of the thrusters [1/N] (m,), positive; ``()``: all 1e-3.
        force_weights: ``W_f`` entries of the generalised forces [1/N or 1/(N m), per axis] (nv,),
            positive; ``()``: all 1 (given with the first request's ``B``).
        joint_dofs: Generalised-velocity indices of the joints whose motors share the task.
        joint_torque_min: Lowest torque of each of those motors [N m] (k,), ``<= 0``.
        joint_torque_max: Highest torque [N m] (k,), ``>= 0`` and ``> joint_torque_min``.
        joint_weights: ``W_u`` entries of the joint motors [1/(N m)] (k,); ``()``: all 1e-3.
        max_iterations: Active-set iteration budget of the compiled allocator [-].
        tolerance: Relative KKT tolerance of the compiled allocator and of the QP [-].
    """

    thrust_min: tuple[float, ...]
    thrust_max: tuple[float, ...]
    thrust_weights: tuple[float, ...] = ()
    force_weights: tuple[float, ...] = ()
    joint_dofs: tuple[int, ...] = ()
    joint_torque_min: tuple[float, ...] = ()
    joint_torque_max: tuple[float, ...] = ()
    joint_weights: tuple[float, ...] = ()
    max_iterations: int = 100
    tolerance: float = 1e-12

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in (
            "thrust_min",
            "thrust_max",
            "thrust_weights",
            "force_weights",
            "joint_torque_min",
            "joint_torque_max",
            "joint_weights",
        ):
            set_(self, name, _floats(getattr(self, name), name))
        m, k = len(self.thrust_min), len(self.joint_dofs)
        if m + k == 0:
            raise AllocationError("no actuators: give thrust limits or joint_dofs")
        _check_limits(self.thrust_min, self.thrust_max, "thrust")
        if not self.thrust_weights:
            set_(self, "thrust_weights", (1e-3,) * m)
        _check_weights(self.thrust_weights, m, "thrust_weights")
        dofs = []
        for d in self.joint_dofs:
            if isinstance(d, bool) or not isinstance(d, int | np.integer) or d < 0:
                raise AllocationError(f"joint_dofs: expected indices >= 0, got {d!r}")
            dofs.append(int(d))
        if len(set(dofs)) != len(dofs):
            raise AllocationError(f"joint_dofs: repeated index in {dofs}")
        set_(self, "joint_dofs", tuple(dofs))
        if len(self.joint_torque_min) != k or len(self.joint_torque_max) != k:
            raise AllocationError(
                f"joint torque limits: expected {k} minima and maxima (one per joint_dofs entry), "
                f"got {len(self.joint_torque_min)} and {len(self.joint_torque_max)}"
            )
        _check_limits(self.joint_torque_min, self.joint_torque_max, "joint torque")
        if not self.joint_weights:
            set_(self, "joint_weights", (1e-3,) * k)
        _check_weights(self.joint_weights, k, "joint_weights")
        if self.force_weights:
            _check_weights(self.force_weights, len(self.force_weights), "force_weights")
        if isinstance(self.max_iterations, bool) or not isinstance(self.max_iterations, int):
            raise AllocationError(
                f"max_iterations: expected an integer, got {self.max_iterations!r}"
            )
        if self.max_iterations < 1:
            raise AllocationError(f"max_iterations must be positive, got {self.max_iterations}")
        if not (math.isfinite(self.tolerance) and 0.0 < self.tolerance < 1.0):
            raise AllocationError(f"tolerance must be in (0, 1), got {self.tolerance}")

    @property
    def n_thrusters(self) -> int:
        """``m``, the number of thrusters."""
        return len(self.thrust_min)

    @property
    def n_actuators(self) -> int:
        """``m + k``: thrusters and joint motors."""
        return len(self.thrust_min) + len(self.joint_dofs)

    def lower(self) -> np.ndarray:
        """The actuators' minima (m + k,) [N, N m]."""
        return np.array(self.thrust_min + self.joint_torque_min)

    def upper(self) -> np.ndarray:
        """The actuators' maxima (m + k,) [N, N m]."""
        return np.array(self.thrust_max + self.joint_torque_max)

    def actuator_weights(self) -> np.ndarray:
        """``W_u`` diagonal (m + k,) [1/N, 1/(N m)]."""
        return np.array(self.thrust_weights + self.joint_weights)

    def force_weights_for(self, nv: int) -> np.ndarray:
        """``W_f`` diagonal (nv,) [1/N, 1/(N m)]: the given one, or ones."""
        if not self.force_weights:
            return np.ones(nv)
        if len(self.force_weights) != nv:
            raise AllocationError(
                f"force_weights: expected {nv} weights (one per generalised force), "
                f"got {len(self.force_weights)}"
            )
        return np.array(self.force_weights)


@dataclass(frozen=True)
class AllocationResult:
    """An allocation and what it could not produce.

    Attributes:
        thrusts: The thrusters' forces [N] (m,).
        joint_torques: The sharing joint motors' torques [N m] (k,).
        produced: ``B u`` (with the joint columns) [N, N m] (nv,).
        residual: ``tau_d - B u`` [N, N m] (nv,): the part of the request not produced.
        saturated: Which actuators (m + k,) are at a limit.
        unactuated_axes: Generalised coordinates no actuator acts on (zero rows of ``[B | E]``).
        rank: Rank of ``[B | E]``: fewer than nv means some generalised forces cannot be produced.
        status: ``"unconstrained"`` (no limit active: the closed form), ``"optimal"`` (limits
            active, KKT conditions hold), ``"budget"`` (compiled: iteration budget exhausted),
            ``"not converged"`` (QP: solver stopped short).
        iterations: Solver iterations (0 for the closed form).
    """

    thrusts: np.ndarray
    joint_torques: np.ndarray
    produced: np.ndarray
    residual: np.ndarray
    saturated: np.ndarray
    unactuated_axes: tuple[int, ...]
    rank: int
    status: str
    iterations: int


def check_request(thrust_matrix, tau_d, parameters: AllocationParameters):
    """``(B, tau_d)`` as float arrays after checking shapes and values (one-line errors)."""
    if not isinstance(parameters, AllocationParameters):
        raise AllocationError(
            f"parameters: expected AllocationParameters, got {type(parameters).__name__}"
        )
    B = np.asarray(thrust_matrix, dtype=float)
    tau = np.asarray(tau_d, dtype=float)
    m = parameters.n_thrusters
    if B.ndim != 2 or B.shape[1] != m:
        raise AllocationError(f"thrust matrix: expected shape (nv, {m}), got {B.shape}")
    nv = B.shape[0]
    if tau.shape != (nv,):
        raise AllocationError(f"tau_d: expected shape ({nv},), got {tau.shape}")
    if not np.isfinite(B).all():
        raise AllocationError("thrust matrix: contains NaN or infinite values")
    if not np.isfinite(tau).all():
        raise AllocationError("tau_d: contains NaN or infinite values")
    for d in parameters.joint_dofs:
        if d >= nv:
            raise AllocationError(f"joint_dofs: index {d} out of range for nv = {nv}")
    parameters.force_weights_for(nv)
    return B, tau


def actuator_matrix(thrust_matrix: np.ndarray, joint_dofs) -> np.ndarray:
    """``[B | E]`` (nv, m + k): ``B`` and one unit column ``e_i`` per joint motor on axis ``i``."""
    nv = thrust_matrix.shape[0]
    columns = np.zeros((nv, len(joint_dofs)))
    for c, d in enumerate(joint_dofs):
        columns[d, c] = 1.0
    return np.hstack([thrust_matrix, columns])


def unactuated_axes(matrix: np.ndarray) -> tuple[int, ...]:
    """Rows of ``matrix`` with no entry above ``1e-12`` times its largest: axes nothing acts on."""
    scale = float(np.abs(matrix).max(initial=0.0))
    if scale == 0.0:
        return tuple(range(matrix.shape[0]))
    return tuple(int(r) for r in np.flatnonzero(np.abs(matrix).max(axis=1) <= 1e-12 * scale))


def result_of(matrix, tau, parameters, u, status, iterations) -> AllocationResult:
    """The :class:`AllocationResult` of the allocation ``u`` on the actuator matrix ``matrix``."""
    m = parameters.n_thrusters
    lower, upper = parameters.lower(), parameters.upper()
    span = upper - lower
    saturated = (u <= lower + 1e-9 * span) | (u >= upper - 1e-9 * span)
    produced = matrix @ u
    return AllocationResult(
        thrusts=u[:m].copy(),
        joint_torques=u[m:].copy(),
        produced=produced,
        residual=tau - produced,
        saturated=saturated,
        unactuated_axes=unactuated_axes(matrix),
        rank=int(np.linalg.matrix_rank(matrix)) if matrix.size else 0,
        status=status,
        iterations=int(iterations),
    )
