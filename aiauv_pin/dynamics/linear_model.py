"""Linear models of a vehicle about a trim: straight-line motion, open loop or with feedback.

About a steady motion ``(q*(t), v*, u*)`` with ``dv/dt = 0`` (``q*(t) = q* exp(t v*)`` on the
free flyer), the perturbation ``q = q* (+) dq``, ``v = v* + dv``, ``u = u* + du`` obeys, to first
order (Lie-group error dynamics, e.g. Sola et al. 2018, "A micro Lie theory", Sec. 5;
``d/dt dq_base = dv_base - ad(v*) dq_base`` on SE(3), ``d/dt dq_joint = dv_joint``):

    d/dt (dq, dv) = A (dq, dv) + B du,
    A = [[-ad(v*) (+) 0, I], [da_dq, da_dv]],   B = [[0], [da_du]],

with the exact Jacobians of :mod:`aiauv_pin.model.derivatives` (the thrusters' wrenches fixed in their
bodies) and ``u = (thrusts [N], joint torques [N m])``. ``A`` does not change along the trim when
the current is uniform (the dynamics do not depend on where the vehicle is). With feedback
``du = K (dq, dv)`` the closed loop is ``A + B K``:

* the paper's joint servo (eq. (24): ``tau_q = -k_p (q - q*) - k_d qd + g_q(q)``) is exact:
  ``K = [-k_p S + dg_q/dq, -k_d S]`` with ``dg/dq`` from Pinocchio's
  ``computeGeneralizedGravityDerivatives`` of the vehicle and of its displaced water;
* a user's controller ``u = controller(q, v)`` is differentiated by central differences (in the
  tangent space): only that function, which may be anything, is not differentiated exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.array_checks import float_array
from aiauv_pin.model.derivatives import compiled_derivatives, uniform_current

#: Names of the free flyer's tangent coordinates (base frame).
BASE_POSITION = ("x", "y", "z", "roll", "pitch", "yaw")
BASE_VELOCITY = ("u", "v", "w", "p", "q", "r")


@dataclass(frozen=True)
class Trim:
    """A steady motion: state and inputs with zero acceleration (to ``residual``).

    Attributes:
        q: Configuration at ``t = 0`` (nq,).
        v: Constant velocity (nv,) [m/s, rad/s].
        thrusts: Thruster forces (m,) [N].
        joint_torques: Joint torques (nv - 6,) [N m].
        residual: Largest remaining acceleration [m/s^2, rad/s^2].
    """

    q: np.ndarray
    v: np.ndarray
    thrusts: np.ndarray
    joint_torques: np.ndarray
    residual: float


@dataclass(frozen=True)
class Mode:
    """One eigenvalue of a linear model and the coordinates its eigenvector moves most."""

    eigenvalue: complex
    time_constant: float | None  # [s], -1/Re(lambda) for a decaying mode, None otherwise
    frequency: float | None  # [rad/s], |Im(lambda)| for an oscillation
    damping_ratio: float | None  # -Re/|lambda| for an oscillation
    dominant: tuple[tuple[str, float], ...]  # (state name, share of the eigenvector's norm)


@dataclass(frozen=True)
class LinearModel:
    """``d/dt (dq, dv) = A (dq, dv) + B du`` about a trim (see the module docstring).

    Attributes:
        A: (2 nv, 2 nv) [1/s, 1/s^2].
        B: (2 nv, m + nv - 6).
        trim: The trim it linearises about.
        state_names: Names of ``(dq, dv)``.
        input_names: Names of ``du``.
        eigenvalues: Eigenvalues of ``A`` [1/s].
        eigenvectors: Columns, normalised.
        closed_loop: Which feedback is in ``A`` (``"open loop"``, ``"joint servo"``, ...).
    """

    A: np.ndarray
    B: np.ndarray
    trim: Trim
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    closed_loop: str

    def modes(self, tolerance: float = 1e-9, top: int = 3) -> list[Mode]:
        """The modes, slowest-decaying (largest real part) first; one of each conjugate pair."""
        modes = []
        order = np.argsort(-self.eigenvalues.real, kind="stable")
        for k in order:
            lam = complex(self.eigenvalues[k])
            if lam.imag < -tolerance:
                continue
            vector = np.abs(self.eigenvectors[:, k])
            share = vector**2 / max(float(np.sum(vector**2)), 1e-300)
            best = np.argsort(-share)[:top]
            oscillating = abs(lam.imag) > tolerance
            modes.append(
                Mode(
                    eigenvalue=lam,
                    time_constant=-1.0 / lam.real if lam.real < -tolerance else None,
                    frequency=abs(lam.imag) if oscillating else None,
                    damping_ratio=-lam.real / abs(lam) if oscillating else None,
                    dominant=tuple((self.state_names[i], float(share[i])) for i in best),
                )
            )
        return modes


def state_names(vehicle) -> tuple[str, ...]:
    """Names of the tangent state ``(dq, dv)``: base pose and twist, joint angles and rates."""
    joints = vehicle.joint_names
    return (
        tuple(f"base {n}" for n in BASE_POSITION)
        + tuple(f"{j} angle" for j in joints)
        + tuple(f"base {n}" for n in BASE_VELOCITY)
        + tuple(f"{j} rate" for j in joints)
    )


def input_names(vehicle) -> tuple[str, ...]:
    """Names of ``u``: thrusters, then joint torques."""
    return tuple(f"thrust {t}" for t in vehicle.thruster_names) + tuple(
        f"torque {j}" for j in vehicle.joint_names
    )


def straight_line_trim(vehicle, speed: float = 0.5, current=None, q=None) -> Trim:
    """Straight-line motion along the base's x-axis at ``speed``, and the inputs that hold it.

    The inputs are the least-squares (minimum-norm) solution of ``dv(q, v, u) = 0``, which is affine
    in ``u``; for the paper's vehicle in still water this is the surge thrust of the two axial
    thrusters that balances the axial drag, every other input zero.

    Args:
        vehicle: The vehicle.
        speed: Surge speed ``u_d`` [m/s].
        current: ``None`` or a uniform current.
        q: Configuration (default: level, joints straight, at the origin).
    """
    speed = float(speed)
    if not np.isfinite(speed):
        raise ArgumentError(f"speed must be a finite number of m/s, got {speed!r}")
    q = vehicle.neutral_configuration() if q is None else vehicle._q(q)
    v = np.zeros(vehicle.nv)
    v[0] = speed
    velocity = uniform_current(current, 0.0)
    nv, m = vehicle.nv, len(vehicle.thruster_names)
    derivatives = compiled_derivatives(vehicle)
    result, da_dthrust = derivatives(q, v, np.zeros(nv), velocity, 0.0, np.zeros(m))
    gain = np.hstack((da_dthrust, result.da_dtau[:, 6:]))
    inputs = np.linalg.lstsq(gain, -result.acceleration, rcond=None)[0]
    thrusts, torques = inputs[:m], inputs[m:]
    tau = np.zeros(nv)
    tau[6:] = torques
    check, _ = derivatives(q, v, tau, velocity, 0.0, thrusts)
    return Trim(q, v, thrusts, torques, float(np.abs(check.acceleration).max()))


def _ad(twist: np.ndarray) -> np.ndarray:
    """``ad(v)`` on SE(3) for ``(linear, angular)`` twists: ``[[ [w], [v] ], [0, [w]]]``."""
    v, w = twist[:3], twist[3:]
    return np.block([[pin.skew(w), pin.skew(v)], [np.zeros((3, 3)), pin.skew(w)]])


def restoring_derivative(vehicle, q: np.ndarray) -> np.ndarray:
    """``dg/dq`` (nv, nv), tangent space: Pinocchio's gravity derivatives, vehicle minus water."""
    model = vehicle.model
    data = model.createData()
    if not vehicle.restoring:
        return np.zeros((vehicle.nv, vehicle.nv))
    derivative = pin.computeGeneralizedGravityDerivatives(model, data, q).copy()
    if vehicle._has_buoyancy:
        derivative -= pin.computeGeneralizedGravityDerivatives(
            vehicle._buoyancy_model, vehicle._buoyancy_data, q
        )
    return derivative


def linearize(
    vehicle,
    trim: Trim | None = None,
    *,
    current=None,
    joint_gains: tuple[float, float] | None = None,
    compensate_restoring: bool = True,
    controller=None,
    step: float = 1e-6,
) -> LinearModel:
    """The linear model about ``trim`` (default: :func:`straight_line_trim` at 0.5 m/s).

    Args:
        vehicle: The vehicle.
        trim: The steady motion.
        current: ``None`` or a uniform current (the one the trim was found in).
        joint_gains: ``(k_p [N m/rad], k_d [N m s/rad])`` of the paper's joint servo (eq. (24)), or
            ``None`` for none; the joints then hold the trim's angles.
        compensate_restoring: Whether the servo adds ``g_q(q)`` (eq. (24)).
        controller: ``controller(q, v) -> u`` (m + nv - 6,), a further feedback around the trim.
        step: Central-difference step for ``controller`` only.
    """
    trim = straight_line_trim(vehicle, current=current) if trim is None else trim
    velocity = uniform_current(current, 0.0)
    nv, m = vehicle.nv, len(vehicle.thruster_names)
    tau = np.zeros(nv)
    tau[6:] = trim.joint_torques
    result, da_dthrust = compiled_derivatives(vehicle)(
        trim.q, trim.v, tau, velocity, 0.0, trim.thrusts
    )
    a_matrix = np.zeros((2 * nv, 2 * nv))
    a_matrix[:nv, nv:] = np.eye(nv)
    a_matrix[:6, :6] = -_ad(trim.v[:6])
    a_matrix[nv:, :nv] = result.da_dq
    a_matrix[nv:, nv:] = result.da_dv
    b_matrix = np.zeros((2 * nv, m + nv - 6))
    b_matrix[nv:, :m] = da_dthrust
    b_matrix[nv:, m:] = result.da_dtau[:, 6:]
    loops = []
    if joint_gains is not None:
        k_p, k_d = (float(k) for k in joint_gains)
        gain = np.zeros((m + nv - 6, 2 * nv))
        joints = np.arange(nv - 6)
        gain[m + joints, 6 + joints] = -k_p
        gain[m + joints, nv + 6 + joints] = -k_d
        if compensate_restoring:
            gain[m:, :nv] += restoring_derivative(vehicle, trim.q)[6:]
        a_matrix = a_matrix + b_matrix @ gain
        loops.append("joint servo")
    if controller is not None:
        a_matrix = a_matrix + b_matrix @ _controller_gain(vehicle, trim, controller, step)
        loops.append("controller")
    eigenvalues, eigenvectors = np.linalg.eig(a_matrix)
    return LinearModel(
        A=a_matrix,
        B=b_matrix,
        trim=trim,
        state_names=state_names(vehicle),
        input_names=input_names(vehicle),
        eigenvalues=eigenvalues,
        eigenvectors=eigenvectors,
        closed_loop=" + ".join(loops) or "open loop",
    )


def _controller_gain(vehicle, trim: Trim, controller, step: float) -> np.ndarray:
    """``d controller / d(dq, dv)`` by central differences in the tangent space."""
    nv = vehicle.nv
    width = len(vehicle.thruster_names) + nv - 6
    columns = []
    for k in range(2 * nv):
        pair = []
        for sign in (1.0, -1.0):
            dx = np.zeros(2 * nv)
            dx[k] = sign * step
            q = pin.integrate(vehicle.model, trim.q, dx[:nv])
            pair.append(float_array(controller(q, trim.v + dx[nv:]), "controller output", (width,)))
        columns.append((pair[0] - pair[1]) / (2.0 * step))
    return np.array(columns).T


def format_modes(model: LinearModel, tolerance: float = 1e-9) -> str:
    """A table of the modes: eigenvalue, time constant or period, damping, dominant states."""
    trim = model.trim
    lines = [
        f"linear model about straight-line motion at {trim.v[0]:.3g} m/s ({model.closed_loop}); "
        f"trim thrusts [N]: {np.array2string(trim.thrusts, precision=2, suppress_small=True)}; "
        f"residual acceleration {trim.residual:.1e}",
        f"{'eigenvalue [1/s]':>26}  {'tau [s]':>8}  {'omega [rad/s]':>13}  {'zeta':>6}  dominant states",
    ]
    for mode in model.modes(tolerance):
        lam = mode.eigenvalue
        text = f"{lam.real:+.4e}" + (f" {lam.imag:+.4e}j" if mode.frequency else "")
        tau = f"{mode.time_constant:8.3g}" if mode.time_constant else f"{'-':>8}"
        omega = f"{mode.frequency:13.4g}" if mode.frequency else f"{'-':>13}"
        zeta = f"{mode.damping_ratio:6.3f}" if mode.damping_ratio is not None else f"{'-':>6}"
        dominant = ", ".join(f"{name} {share:.0%}" for name, share in mode.dominant)
        lines.append(f"{text:>26}  {tau}  {omega}  {zeta}  {dominant}")
    return "\n".join(lines)
