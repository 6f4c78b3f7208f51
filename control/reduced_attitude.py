"""Reduced-attitude (pointing-direction) tracking with two control torques (paper, Section 2).

A rigid body with attitude ``R = R_b^I`` (body frame to world) and body angular velocity ``omega``
[rad/s] obeys ``J omega_dot = m + H u`` (eq. 1) with ``H = [e2 e3]``: only the body y- and z-axes
are actuated. The goal is to align the unactuated body axis ``e1`` with a unit reference direction
``x_ref(t)`` given in the world frame.

Notation used throughout (all body-frame quantities carry ``_b``):

* ``y = x_ref^b = R^T x_ref`` - the reference seen from the body;
* ``phi_tilde = arccos(e1 . y)`` - the pointing error (eq. 4), in ``[0, pi]``;
* ``k = y x e1`` (``|k| = sin phi_tilde``) and ``n = k / |k|``;
* ``R_tilde`` - the minimal rotation taking ``y`` to ``e1`` (eq. 5);
* ``omega_ref^b = R^T (x_ref x x_ref_dot)`` - reference angular velocity (eq. 3);
* ``omega_tilde = H^T (omega - R_tilde omega_ref^b)`` - the realisable velocity error (eq. 8).

Two findings about the paper are built in (see ``PAPER_DATA.md``):

1. The feedforward of eq. (9) must contain the reference angular *acceleration*
   ``x_ref x x_ref_ddot`` (as eqs. 10 and 23 show), not ``x_ref x x_ref_dot`` as printed.
2. ``d/dt R_tilde = R_tilde S(delta + mu y)`` with ``delta = omega - omega_ref^b`` and
   ``mu = -(e1 . delta + y . delta) / (1 + e1 . y)``; the proof used ``R_tilde S(delta)``, which is
   right only for a constant reference. Law (9) therefore gives ``V_dot = -k_D |omega_tilde|^2``
   only for a constant reference. ``feedforward="exact"`` adds
   ``mu H^T J R_tilde (y x omega_ref^b)`` to the torque, which restores
   ``V_dot = -k_D |omega_tilde|^2`` exactly for any smooth reference; ``feedforward="paper"`` is
   eq. (9) with finding 1 applied and nothing else.

Singular points: ``R_tilde`` and ``phi_tilde n`` are smooth at ``phi_tilde = 0`` in the form used
here (``R_tilde = I + S(k) + S(k)^2 / (1 + e1 . y)`` and
``phi_tilde n = (phi_tilde / sin phi_tilde) k``). At the antipodal point ``phi_tilde = pi``
(``y = -e1``) the rotation axis is undefined; as the paper does, we then set ``phi_tilde n := 0``
and ``R_tilde := I``, and we set the finding-2 scalar ``mu := 0`` as well, so every output is
finite there. The point is detected as ``e1 . y < 0`` and ``|y x e1| <= ANTIPODAL_TOLERANCE``
(``pi - phi_tilde`` below 1e-12 rad). On that side ``1 + e1 . y`` is evaluated as
``|y x e1|^2 / (1 - e1 . y)``, so ``R_tilde`` stays an accurate rotation right up to the threshold.

The law is discontinuous at ``phi_tilde = pi`` (no continuous feedback stabilises a point of the
sphere globally). Near it ``mu`` grows like ``1 / (pi - phi_tilde)`` because the minimal rotation's
axis swings fast there, so the exact correction is large but finite. Theorem 1 covers initial
conditions with ``V < k_P pi^2 / 2`` (eq. 13); since ``V`` never increases with the exact law,
``phi_tilde`` then stays bounded away from ``pi``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np

from aiauv_control.laws import paper_laws as laws
from aiauv_hydro.numerics.spatial import cross, skew  # noqa: F401  (skew: part of this module's API)

Feedforward = Literal["exact", "paper"]
FEEDFORWARD_OPTIONS: tuple[str, ...] = ("exact", "paper")
"""Accepted values of the ``feedforward`` switch."""

ANTIPODAL_TOLERANCE = laws.ANTIPODAL_TOLERANCE
"""``|x_ref^b x e1|`` (with ``e1 . x_ref^b < 0``) at or below which ``phi_tilde = pi`` [-]."""

E1 = np.array([1.0, 0.0, 0.0])
E1.setflags(write=False)
H = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])  # eq. (1): H = [e2 e3]
H.setflags(write=False)

_IDENTITY = np.eye(3)
_IDENTITY.setflags(write=False)
_UNIT_TOLERANCE = 1e-6  # allowed deviation of |x_ref| from 1 and of R^T R from I
_BLOCK_TOLERANCE = 1e-9  # allowed |J[0, 1:]| relative to |J| (Assumption 1)


# --------------------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------------------
def _vector(value, size: int, name: str) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (size,):
        raise ValueError(f"{name}: expected shape ({size},), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    return array


def _unit_vector(value, name: str) -> np.ndarray:
    array = _vector(value, 3, name)
    norm = float(np.linalg.norm(array))
    if abs(norm - 1.0) > _UNIT_TOLERANCE:
        raise ValueError(f"{name}: must be a unit vector, got norm {norm:.6g}")
    return array / norm


def check_rotation(value, name: str = "R") -> np.ndarray:
    """``value`` as a 3x3 rotation matrix, or a one-line ``ValueError`` naming ``name``."""
    return _rotation(value, name)


def _rotation(value, name: str = "R") -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (3, 3):
        raise ValueError(f"{name}: expected a 3x3 rotation matrix, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    orthogonality_error = np.abs(array.T @ array - _IDENTITY).max()
    determinant = array[:, 0] @ cross(array[:, 1], array[:, 2])
    if orthogonality_error > _UNIT_TOLERANCE or determinant <= 0.0:
        raise ValueError(f"{name}: not a rotation matrix (R^T R != I or det R <= 0)")
    return array


def _positive(value, name: str) -> float:
    number = float(value)
    if not (np.isfinite(number) and number > 0.0):
        raise ValueError(f"{name} must be positive and finite, got {value}")
    return number


def check_feedforward(feedforward: str) -> str:
    """Return ``feedforward`` if it is one of :data:`FEEDFORWARD_OPTIONS`, else raise ValueError."""
    if feedforward not in FEEDFORWARD_OPTIONS:
        raise ValueError(f"feedforward must be one of {FEEDFORWARD_OPTIONS}, got {feedforward!r}")
    return feedforward


def check_block_diagonal_inertia(J) -> np.ndarray:
    """Validate an inertia matrix against Assumption 1 (eq. 2) and return it as an array.

    Args:
        J: 3x3 inertia matrix [kg m^2], symmetric positive definite with ``J[0, 1:] = J[1:, 0] = 0``
            to a relative tolerance of 1e-9 (``J_22`` may be a full 2x2 block).

    Raises:
        ValueError: wrong shape, non-finite, not symmetric, not block-diagonal or not positive
            definite.
    """
    array = np.asarray(J, dtype=float)
    if array.shape != (3, 3):
        raise ValueError(f"J: expected a 3x3 inertia matrix, got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError("J: contains NaN or infinite values")
    scale = float(np.abs(array).max())
    if np.abs(array - array.T).max() > _BLOCK_TOLERANCE * scale:
        raise ValueError("J: inertia matrix is not symmetric")
    if max(abs(array[0, 1]), abs(array[0, 2])) > _BLOCK_TOLERANCE * scale:
        raise ValueError(
            "J: not block-diagonal (Assumption 1, eq. 2: J[0,1], J[0,2], J[1,0], J[2,0] must be 0)"
        )
    J22_determinant = array[1, 1] * array[2, 2] - array[1, 2] * array[2, 1]
    if not (array[0, 0] > 0.0 and array[1, 1] > 0.0 and J22_determinant > 0.0):
        raise ValueError("J: inertia matrix is not positive definite")
    return array


# --------------------------------------------------------------------------------------------------
# geometry of the error
# --------------------------------------------------------------------------------------------------
def _one_plus_cos(y: np.ndarray) -> float:
    """``1 + e1 . y`` for unit ``y`` (:func:`aiauv_control.laws.paper_laws.one_plus_cos`)."""
    return float(laws.one_plus_cos(y[0], y[1], y[2]))


def is_antipodal(x_ref_b) -> bool:
    """True if ``x_ref^b`` is within :data:`ANTIPODAL_TOLERANCE` of ``-e1`` (``phi_tilde = pi``)."""
    return bool(laws.is_antipodal(float(x_ref_b[0]), float(x_ref_b[1]), float(x_ref_b[2])))


def _error_angle(y: np.ndarray) -> float:
    return float(laws.error_angle(y[0], y[1], y[2]))  # eq. (4)


def _error_axis_angle(y: np.ndarray) -> np.ndarray:
    return np.array(laws.error_axis_angle(y[0], y[1], y[2]))


def _minimal_rotation(y: np.ndarray) -> np.ndarray:
    return np.array(laws.minimal_rotation(y[0], y[1], y[2]))  # eq. (5)


def _rate_correction(delta: np.ndarray, y: np.ndarray) -> float:
    return float(laws.rate_correction(delta[0], delta[1], delta[2], y[0], y[1], y[2]))  # finding 2


def error_angle(x_ref_b) -> float:
    """Pointing error ``phi_tilde = arccos(e1 . x_ref^b)`` in ``[0, pi]`` [rad] (eq. 4).

    Evaluated as ``atan2(|x_ref^b x e1|, e1 . x_ref^b)``, which is accurate near 0 and pi.
    """
    return _error_angle(_unit_vector(x_ref_b, "x_ref_b"))


def error_axis_angle(x_ref_b) -> np.ndarray:
    """The vector ``phi_tilde n`` of eq. (9) [rad], with ``n = (y x e1) / |y x e1|``.

    Computed as ``(phi_tilde / sin phi_tilde) (y x e1)``, smooth at ``phi_tilde = 0`` (where it is
    0). Set to zero at the antipodal point ``phi_tilde = pi`` (paper, after eq. 9).
    """
    return _error_axis_angle(_unit_vector(x_ref_b, "x_ref_b"))


def minimal_rotation(x_ref_b) -> np.ndarray:
    """Minimal rotation ``R_tilde`` with ``R_tilde x_ref^b = e1`` (eq. 5).

    Uses ``R_tilde = I + S(k) + S(k)^2 / (1 + e1 . y)`` with ``k = y x e1`` (eq. 5 with
    ``(1 - cos) / sin^2 = 1 / (1 + cos)``), smooth at ``phi_tilde = 0`` where it equals ``I``. At
    the antipodal point ``phi_tilde = pi`` it is defined as ``I`` (paper, after eq. 9).

    Args:
        x_ref_b: Reference direction in the body frame (unit vector).
    """
    return _minimal_rotation(_unit_vector(x_ref_b, "x_ref_b"))


def reference_angular_velocity(R, x_ref, x_ref_dot) -> np.ndarray:
    """Reference angular velocity in the body frame, ``R^T (x_ref x x_ref_dot)`` [rad/s] (eq. 3).

    Args:
        R: Body-to-world rotation ``R_b^I``.
        x_ref: Unit reference direction in the world frame.
        x_ref_dot: Its time derivative in the world frame [1/s].
    """
    x_ref, x_ref_dot = _vector(x_ref, 3, "x_ref"), _vector(x_ref_dot, 3, "x_ref_dot")
    return np.array(  # eq. (3)
        laws.reference_rate_in_body(_rotation(R), x_ref[0], x_ref[1], x_ref[2], x_ref_dot)
    )


def reference_angular_acceleration(R, x_ref, x_ref_ddot) -> np.ndarray:
    """World-frame reference angular acceleration expressed in the body frame [rad/s^2].

    ``R^T d/dt(x_ref x x_ref_dot) = R^T (x_ref x x_ref_ddot)``, the term that eqs. (10) and (23) use
    (finding 1: eq. 9 as printed has ``x_ref_dot`` here). This is *not* the body-frame derivative of
    :func:`reference_angular_velocity`, which also contains ``-omega x omega_ref^b``.
    """
    x_ref, x_ref_ddot = _vector(x_ref, 3, "x_ref"), _vector(x_ref_ddot, 3, "x_ref_ddot")
    return np.array(  # eq. (10), last line
        laws.reference_rate_in_body(_rotation(R), x_ref[0], x_ref[1], x_ref[2], x_ref_ddot)
    )


def minimal_rotation_rate_correction(omega, omega_ref_b, x_ref_b) -> float:
    """Scalar ``mu`` of finding 2: ``d/dt R_tilde = R_tilde S(delta + mu y)`` [rad/s].

    ``mu = -(e1 . delta + y . delta) / (1 + e1 . y)`` with ``delta = omega - omega_ref^b`` and
    ``y = x_ref^b``. It grows like ``1 / (pi - phi_tilde)`` near the antipode and is undefined at
    ``y = -e1``, where it is set to zero (module docstring).

    Args:
        omega: Body angular velocity [rad/s].
        omega_ref_b: Reference angular velocity in the body frame [rad/s] (eq. 3).
        x_ref_b: Reference direction in the body frame (unit vector).
    """
    delta = _vector(omega, 3, "omega") - _vector(omega_ref_b, 3, "omega_ref_b")
    return _rate_correction(delta, _unit_vector(x_ref_b, "x_ref_b"))


def lyapunov_function(phi_tilde: float, omega_tilde, J22, k_p: float) -> float:
    """Lyapunov function ``V = k_P/2 phi_tilde^2 + 1/2 omega_tilde^T J_22 omega_tilde`` (eq. 14).

    Args:
        phi_tilde: Pointing error [rad].
        omega_tilde: Angular velocity error (2,) [rad/s] (eq. 8).
        J22: Actuated 2x2 block of the inertia matrix [kg m^2] (eq. 2).
        k_p: Proportional gain [N m/rad].

    Returns:
        V [J].
    """
    w = _vector(omega_tilde, 2, "omega_tilde")
    J22 = np.asarray(J22, dtype=float)
    if J22.shape != (2, 2):
        raise ValueError(f"J22: expected shape (2, 2), got {J22.shape}")
    return float(0.5 * k_p * phi_tilde**2 + 0.5 * w @ J22 @ w)  # eq. (14)


# --------------------------------------------------------------------------------------------------
# errors and control law
# --------------------------------------------------------------------------------------------------
def reduced_attitude_errors(R, omega, x_ref, x_ref_dot) -> tuple[float, np.ndarray]:
    """Tracking errors ``(phi_tilde, omega_tilde)`` of eqs. (4) and (8).

    Args:
        R: Body-to-world rotation ``R_b^I`` (3x3).
        omega: Body angular velocity in the body frame (3,) [rad/s].
        x_ref: Unit reference direction in the world frame (3,).
        x_ref_dot: Its time derivative in the world frame (3,) [1/s].

    Returns:
        ``phi_tilde`` in ``[0, pi]`` [rad] and ``omega_tilde = H^T (omega - R_tilde omega_ref^b)``
        (2,) [rad/s].
    """
    R = _rotation(R)
    omega = _vector(omega, 3, "omega")
    x_ref = _unit_vector(x_ref, "x_ref")
    x_ref_dot = _vector(x_ref_dot, 3, "x_ref_dot")
    command = laws.reduced_attitude_law(
        R, omega, x_ref, x_ref_dot, np.zeros(3), _IDENTITY, 0.0, 0.0, 1.0, 1.0, False
    )
    return float(command.phi_tilde), np.array([command.omega_tilde_y, command.omega_tilde_z])


class ReducedAttitudeOutput(NamedTuple):
    """Result of one evaluation of :class:`ReducedAttitudeLaw`."""

    torque: np.ndarray
    """Control torques about the body y- and z-axes (2,) [N m] (eq. 9)."""
    phi_tilde: float
    """Pointing error [rad] (eq. 4)."""
    omega_tilde: np.ndarray
    """Angular velocity error (2,) [rad/s] (eq. 8)."""


@dataclass(frozen=True)
class ReducedAttitudeLaw:
    """The tracking law of eq. (9) with fixed, validated parameters (findings 1 and 2 applied).

    ``u = -k_P phi_tilde H^T n - k_D omega_tilde + H^T (J R_tilde R^T (x_ref x x_ref_ddot) - m)``
    (``"paper"``), plus ``mu H^T J R_tilde (y x omega_ref^b)`` for ``"exact"`` (the default), which
    makes ``V_dot = -k_D |omega_tilde|^2`` hold exactly for a time-varying reference.

    Attributes:
        J: Inertia matrix (3x3) [kg m^2], block-diagonal per Assumption 1 (eq. 2).
        k_p: Proportional gain [N m/rad] (> 0).
        k_d: Derivative gain [N m s/rad] (> 0).
        feedforward: ``"exact"`` or ``"paper"``, see the module docstring.
    """

    J: np.ndarray
    k_p: float
    k_d: float
    feedforward: Feedforward = "exact"

    def __post_init__(self) -> None:
        J = check_block_diagonal_inertia(self.J).copy()
        J.setflags(write=False)
        object.__setattr__(self, "J", J)
        object.__setattr__(self, "k_p", _positive(self.k_p, "k_p"))
        object.__setattr__(self, "k_d", _positive(self.k_d, "k_d"))
        check_feedforward(self.feedforward)

    def __call__(self, R, omega, x_ref, x_ref_dot, x_ref_ddot, m=None) -> ReducedAttitudeOutput:
        """Evaluate the law.

        Args:
            R: Body-to-world rotation ``R_b^I`` (3x3).
            omega: Body angular velocity in the body frame (3,) [rad/s].
            x_ref: Unit reference direction in the world frame (3,).
            x_ref_dot: First time derivative of ``x_ref`` (3,) [1/s].
            x_ref_ddot: Second time derivative of ``x_ref`` (3,) [1/s^2].
            m: Known body-frame moments other than the control (3,) [N m] (eq. 1); ``None`` = 0.

        Raises:
            ValueError: bad shapes or values.
        """
        R = _rotation(R)
        omega = _vector(omega, 3, "omega")
        x_ref = _unit_vector(x_ref, "x_ref")
        x_ref_dot = _vector(x_ref_dot, 3, "x_ref_dot")
        x_ref_ddot = _vector(x_ref_ddot, 3, "x_ref_ddot")

        m = np.zeros(3) if m is None else _vector(m, 3, "m")
        command = (
            laws.reduced_attitude_law(  # eq. (9), findings 1 and 2: aiauv_control.laws.paper_laws
                R,
                omega,
                x_ref,
                x_ref_dot,
                x_ref_ddot,
                self.J,
                m[1],
                m[2],
                self.k_p,
                self.k_d,
                self.feedforward == "exact",
            )
        )
        torque = np.array([command.u_y, command.u_z])
        omega_tilde = np.array([command.omega_tilde_y, command.omega_tilde_z])
        return ReducedAttitudeOutput(torque, float(command.phi_tilde), omega_tilde)


def reduced_attitude_torque(
    R,
    omega,
    x_ref,
    x_ref_dot,
    x_ref_ddot,
    J,
    m,
    k_p: float,
    k_d: float,
    *,
    feedforward: Feedforward = "exact",
) -> np.ndarray:
    """Reduced-attitude tracking torque ``u`` (eq. 9, with findings 1 and 2).

    Functional form of :class:`ReducedAttitudeLaw`; prefer the class in loops (``J`` and the gains
    are then validated once).

    Args:
        R: Body-to-world rotation ``R_b^I`` (3x3).
        omega: Body angular velocity in the body frame (3,) [rad/s].
        x_ref: Unit reference direction in the world frame (3,).
        x_ref_dot: First time derivative of ``x_ref`` (3,) [1/s].
        x_ref_ddot: Second time derivative of ``x_ref`` (3,) [1/s^2].
        J: Inertia matrix (3x3) [kg m^2], block-diagonal per Assumption 1 (eq. 2).
        m: Known body-frame moments other than the control (3,) [N m] (eq. 1).
        k_p: Proportional gain [N m/rad] (> 0).
        k_d: Derivative gain [N m s/rad] (> 0).
        feedforward: ``"exact"`` or ``"paper"``, see the module docstring.

    Returns:
        Torques about the body y- and z-axes (2,) [N m].

    Raises:
        ValueError: bad shapes or values, ``J`` not block-diagonal, unknown ``feedforward``.
    """
    m = _vector(m, 3, "m")
    law = ReducedAttitudeLaw(J, k_p, k_d, feedforward)
    return law(R, omega, x_ref, x_ref_dot, x_ref_ddot, m).torque
