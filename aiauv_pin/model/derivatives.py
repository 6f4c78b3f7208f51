"""Exact derivatives of a vehicle's forward dynamics, with every fluid effect, on both backends.

:func:`acceleration_derivatives` returns ``dv = f(q, v, tau, V_c)`` and its Jacobians

* ``da_dq`` (nv, nv) with respect to a tangent-space perturbation ``q (+) dq`` (the free flyer by
  ``pinocchio.integrate``: ``q_base exp(dq_base)``, joints by addition), as Pinocchio's own
  ``computeABADerivatives``;
* ``da_dv`` (nv, nv), ``da_dtau = M(q)^-1`` (nv, nv);
* ``da_dcurrent`` (nv, 3), with respect to a uniform current ``V_c`` in world axes.

Both backends use ``d dv/d x = -M^-1 d ID/d x`` at ``a = dv`` (Carpentier and Mansard 2018), with
the derivative of each fluid law from :mod:`aiauv_hydro.laws.fluid_terms` (written once, next to the law):

* ``"numba"``: :mod:`aiauv_pin.kernels.tangent_rnea`, a compiled tangent recursive Newton-Euler pass
  over the bodies' rigid + added inertias;
* ``"pinocchio"`` (the reference): Pinocchio's analytical RNEA derivatives
  (``computeRNEADerivatives`` with the fluid wrenches as external forces, held in the local
  frames) for the rigid part and the weight, ``computeGeneralizedGravityDerivatives`` of the
  displaced water for the buoyancy, and Pinocchio's kinematic derivatives
  (``getJointAccelerationDerivatives``) chained with the fluid laws' derivatives for the change of
  the fluid wrenches. The two share only the laws' derivatives, which tests check against
  central differences of the laws themselves.

The current must be uniform in space (constant, or tidal at time ``t``); a tidal current's
acceleration ``dV/dt`` (Froude-Krylov and the added mass's reaction,
:mod:`aiauv_hydro.laws.unsteady_flow`) is in the dynamics and its derivatives unless the current is
quasi-steady.
"""

from __future__ import annotations

import threading
from typing import NamedTuple

import numpy as np
import pinocchio as pin

from aiauv_hydro.currents import Current, as_current
from aiauv_hydro.laws.fluid_terms import add_body_fluid_bias, body_fluid_bias_jacobians
from aiauv_hydro.laws.unsteady_flow import (
    add_flow_acceleration_bias,
    add_flow_acceleration_rotation_jacobian,
)
from aiauv_pin._internal.array_checks import (
    configuration,
    finite_time,
    float_array,
    optional_current,
)
from aiauv_pin.errors import ArgumentError, project_errors
from aiauv_pin.model.assembly import compiled_model

_LOCAL = pin.ReferenceFrame.LOCAL


class AccelerationDerivatives(NamedTuple):
    """Forward dynamics and its exact Jacobians at one state.

    Attributes:
        acceleration: ``dv`` (nv,) [m/s^2, rad/s^2].
        da_dq: ``d dv / d dq`` (nv, nv), ``dq`` in the tangent space of ``q`` [1/s^2].
        da_dv: ``d dv / d v`` (nv, nv) [1/s].
        da_dtau: ``d dv / d tau = M(q)^-1`` (nv, nv) [1/kg, ...].
        da_dcurrent: ``d dv / d V_c`` (nv, 3), uniform current in world axes [1/s].
    """

    acceleration: np.ndarray
    da_dq: np.ndarray
    da_dv: np.ndarray
    da_dtau: np.ndarray
    da_dcurrent: np.ndarray


def uniform_current(current, t: float) -> np.ndarray:
    """The velocity (3,) [m/s] of a spatially uniform current at time ``t``.

    Raises:
        ArgumentError: A current that varies in space (a shear or a user's current).
    """
    water: Current = as_current(optional_current(current))
    if water.kind not in ("constant", "tidal"):
        raise ArgumentError(
            f"derivatives need a current uniform in space (constant or tidal), got a {water.kind} current"
        )
    return water.velocity(t, np.zeros(3))


class CompiledDerivatives:
    """The compiled derivatives of one vehicle (a workspace per thread, reused between calls).

    Calls check every argument before the compiled code runs (:mod:`aiauv_pin._internal.array_checks`)."""

    def __init__(self, fast_model) -> None:
        from aiauv_pin.kernels import tangent_rnea as kernels_d

        self._fast = fast_model
        self._kernels = kernels_d
        self._local = threading.local()
        self._local.workspace = kernels_d.new_derivative_workspace(fast_model.model, fast_model.nv)

    @property
    def workspace(self):
        """The calling thread's derivative workspace (made on first use)."""
        workspace = getattr(self._local, "workspace", None)
        if workspace is None:
            workspace = self._local.workspace = self._kernels.new_derivative_workspace(
                self._fast.model, self._fast.nv
            )
        return workspace

    @project_errors("compiled derivatives")
    def __call__(
        self,
        q,
        v,
        tau,
        velocity: np.ndarray,
        t: float,
        thrusts: np.ndarray | None = None,
        water: Current | None = None,
    ) -> tuple[AccelerationDerivatives, np.ndarray]:
        """Derivatives at ``(q, v)`` with the generalised force ``tau + B(q) thrusts``.

        Args:
            q: Configuration (nq,); v, tau: (nv,) [m/s, rad/s], [N, N m].
            velocity: Uniform current (3,), world axes [m/s].
            t: Time [s].
            thrusts: Thruster forces (m,) [N] (default 0).
            water: The uniform :class:`~aiauv_hydro.currents.Current` whose value at ``t`` is
                ``velocity``, for its acceleration (a tidal current); ``None``: a constant one.

        Returns:
            The :class:`AccelerationDerivatives` and ``d dv / d thrusts = M^-1 B(q)`` (nv, m).

        Raises:
            ArgumentError: A bad argument (shape, dtype, not finite), before anything runs.
        """
        fast = self._fast
        nv = fast.nv
        m = fast.n_thrusters
        q = configuration(q, fast.nq)
        v = float_array(v, "v", (nv,))
        tau = float_array(tau, "tau", (nv,))
        velocity = float_array(velocity, "current", (3,))
        t = finite_time(t)
        thrusts = np.zeros(m) if thrusts is None else float_array(thrusts, "thrusts", (m,))
        out = AccelerationDerivatives(
            np.empty(nv),
            np.empty((nv, nv)),
            np.empty((nv, nv)),
            np.empty((nv, nv)),
            np.empty((nv, 3)),
        )
        da_dthrust = np.empty((nv, m))
        if water is not None and water.kind == "tidal":
            env = fast.environment(water)
        else:
            env = fast.environment(velocity if velocity.any() else None)
        self._kernels.acceleration_derivatives_into(
            fast.model,
            env,
            t,
            q,
            v,
            tau,
            thrusts,
            fast.workspace,
            self.workspace,
            *out,
            da_dthrust,
        )
        return out, da_dthrust


@project_errors("acceleration_derivatives")
def pinocchio_derivatives(
    vehicle,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    velocity: np.ndarray,
    water: Current | None = None,
    t: float = 0.0,
) -> AccelerationDerivatives:
    """The reference derivatives on Pinocchio (see the module docstring); ``water`` the uniform
    current whose value at ``t`` is ``velocity`` (``None``: a constant one), for its acceleration."""
    model, data = vehicle.model, vehicle.data
    nb = model.njoints - 1
    if water is not None and water.kind == "tidal":
        mass, bias = vehicle._hydro_terms(q, v, water, t)
        flow = np.tile(water.water_acceleration(t, np.zeros(3)), (nb, 1))
    else:
        mass, bias = vehicle._hydro_terms(q, v, velocity, 0.0)
        flow = np.zeros((nb, 3))
    mass_inverse = np.linalg.inv(mass)
    dv = mass_inverse @ (tau - bias)
    fluid = vehicle.fluid_model(include_hydrostatics=False)
    pin.computeForwardKinematicsDerivatives(model, data, q, v, dv)
    rotation, _, twist = vehicle._body_states()
    currents = np.tile(velocity, (nb, 1))
    body_acceleration = np.array([data.a[j].vector for j in range(1, model.njoints)])
    wrench = np.einsum("nij,nj->ni", fluid.added_mass, body_acceleration)
    relative = np.empty_like(twist)
    add_body_fluid_bias(fluid, rotation, twist, currents, wrench, relative, np.zeros((3, 6)))
    add_flow_acceleration_bias(fluid, rotation, flow, wrench)
    d_twist = np.zeros((nb, 6, 6))
    d_current = np.zeros((nb, 6, 3))
    d_up = np.zeros((nb, 6, 3))
    body_fluid_bias_jacobians(
        fluid, rotation, twist, currents, d_twist, d_current, d_up, np.zeros((5, 6, 6))
    )
    d_flow = np.zeros((nb, 6, 3))  # d bias / d theta of the water's acceleration
    add_flow_acceleration_rotation_jacobian(fluid, rotation, flow, d_flow)
    fext = pin.StdVec_Force()
    fext.append(pin.Force.Zero())
    for b in range(nb):
        fext.append(pin.Force(-wrench[b]))
    d_id_dq, d_id_dv, _ = pin.computeRNEADerivatives(model, data, q, v, dv, fext)
    d_id_dq, d_id_dv = d_id_dq.copy(), d_id_dv.copy()
    d_id_dcurrent = np.zeros((vehicle.nv, 3))
    for b in range(nb):
        joint = b + 1
        dnu_dq, da_dq, da_dv, jac = pin.getJointAccelerationDerivatives(model, data, joint, _LOCAL)
        # d theta_b / d dq: the pose perturbation of body b in its own axes is J_b dq
        vc = rotation[b].T @ velocity
        d_rotation = d_up[b] @ _skew(rotation[b][2]) + d_current[b] @ _skew(vc) + d_flow[b]
        d_wrench_dq = fluid.added_mass[b] @ da_dq + d_twist[b] @ dnu_dq + d_rotation @ jac[3:]
        d_wrench_dv = fluid.added_mass[b] @ da_dv + d_twist[b] @ jac
        d_id_dq += jac.T @ d_wrench_dq
        d_id_dv += jac.T @ d_wrench_dv
        d_id_dcurrent += jac.T @ d_current[b] @ rotation[b].T
    if vehicle.restoring and vehicle._has_buoyancy:
        d_id_dq -= pin.computeGeneralizedGravityDerivatives(
            vehicle._buoyancy_model, vehicle._buoyancy_data, q
        )
    return AccelerationDerivatives(
        dv,
        -mass_inverse @ d_id_dq,
        -mass_inverse @ d_id_dv,
        mass_inverse,
        -mass_inverse @ d_id_dcurrent,
    )


def _skew(a: np.ndarray) -> np.ndarray:
    """``[a]`` with ``[a] b = a x b``."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def acceleration_derivatives(
    vehicle, q, v, tau, current=None, *, t: float = 0.0, backend: str | None = None
) -> AccelerationDerivatives:
    """Forward dynamics and its exact Jacobians (see the module docstring).

    Args:
        vehicle: The :class:`aiauv_pin.Vehicle`.
        q: Configuration (nq,).
        v: Velocity (nv,) [m/s, rad/s].
        tau: Generalised force (nv,) [N, N m] (thrusters through ``thrust_matrix``).
        current: ``None``, a uniform velocity (3,) [m/s], or a uniform :class:`aiauv_hydro.currents.Current`.
        t: Time [s] at which the current is sampled.
        backend: ``"numba"``, ``"pinocchio"`` or ``None`` (the vehicle's active backend).

    Raises:
        ArgumentError: Bad shapes, a non-uniform current, an unknown or unavailable backend, or a
            vehicle with fins (their lift and drag have no derivatives here yet).
    """
    refuse_fins(vehicle, "acceleration_derivatives")
    q, v, tau = vehicle._q(q), vehicle._v(v), vehicle._v(tau, "tau")
    t = finite_time(t)
    velocity = uniform_current(current, t)
    water = as_current(optional_current(current))
    if backend is None:
        backend = vehicle.active_backend
    if not isinstance(backend, str):
        raise ArgumentError(f"backend must be numba or pinocchio, got {backend!r:.40}")
    if backend == "pinocchio":
        return pinocchio_derivatives(vehicle, q, v, tau, velocity, water, t)
    if backend != "numba":
        raise ArgumentError(f"unknown backend {backend!r:.40} (expected numba or pinocchio)")
    return compiled_derivatives(vehicle)(q, v, tau, velocity, t, water=water)[0]


def refuse_fins(vehicle, what: str) -> None:
    """One line refusing derivatives of a vehicle with fins (:mod:`aiauv_hydro.laws.lift` has no
    Jacobians yet), rather than derivatives that leave the fins out."""
    if vehicle.hydro.fins:
        raise ArgumentError(
            f"{what}: vehicle has {len(vehicle.hydro.fins)} fin(s), whose lift and drag have no "
            "derivatives yet; linearise by finite differences of Vehicle.acceleration"
        )


def compiled_derivatives(vehicle) -> CompiledDerivatives:
    """The vehicle's :class:`CompiledDerivatives` (built on first use).

    Raises:
        ArgumentError: The compiled backend is unavailable for this vehicle.
    """
    if getattr(vehicle, "fixed_base", False):
        raise ArgumentError(
            "derivatives: not available for a fixed-base vehicle (they are those of a free base)"
        )
    cached = getattr(vehicle, "_compiled_derivatives", None)
    if cached is not None:
        return cached
    fast = vehicle.fast
    if fast is None:
        try:
            fast = compiled_model(vehicle.model, vehicle._assembly)
        except (ImportError, ValueError) as exc:
            raise ArgumentError(f"numba backend unavailable: {exc}") from None
    derivatives = CompiledDerivatives(fast)
    vehicle._compiled_derivatives = derivatives
    return derivatives
