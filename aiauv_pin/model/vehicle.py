"""An articulated underwater vehicle: Pinocchio rigid-body dynamics plus per-link hydrodynamics.

Equations of motion in Pinocchio's generalised coordinates (free-flyer base = the URDF root link,
velocity ``v`` = base body twist followed by joint rates; Antonelli 2018, Ch. 6; the paper's eq. (19)):

    (M_RB(q) + M_A(q)) dv + C_RB(q, v) v + sum_i J_i^T [M_A,i (J_i_dot v + [omega_i x v_c,i; 0])
        + C_A,i(nu_r,i) nu_r,i - tau_D,i(nu_r,i)] + g(q) = tau

with, for each link i, ``J_i`` its body Jacobian, ``nu_i = J_i v`` its twist in the link frame,
``nu_r,i = nu_i - (R_i^T V_c, 0)`` its twist relative to a constant irrotational current ``V_c``
(Fossen 2021, eq. (10.4)), ``M_A,i`` its added mass about the link origin (so
``M_A(q) = sum_i J_i^T M_A,i J_i`` exactly, never lagged), ``C_A,i`` the added-mass Coriolis matrix
(Fossen 2021, eq. (6.46)), ``tau_D,i`` the damping wrench and ``g(q)`` the hydrostatic restoring
force (weight minus buoyancy; Fossen 2021, eq. (4.6)). The relative-velocity form
``M_A nu_r_dot + C_A(nu_r) nu_r`` is Fossen 2021, eq. (10.5) (``d/dt`` of the current seen from a
rotating link is ``-omega x v_c``, which gives the ``omega x v_c`` term above).

Pinocchio's algorithms do the rigid part (``computeAllTerms``: CRBA, RNEA bias, Jacobians); the fluid
part is evaluated batched over links with numpy. This is the reference implementation
(``backend="pinocchio"``). With ``backend="auto"`` (default) or ``"numba"``, :meth:`Vehicle.acceleration`,
:meth:`Vehicle.restoring_forces`, :meth:`Vehicle.thrust_matrix` and :meth:`Vehicle.frame_motion` run the
compiled kernels of :mod:`aiauv_pin.kernels` (an articulated-body algorithm whose bodies carry the full
6x6 rigid + added inertia), tested against this path to 1e-9; ``"auto"`` falls back to Pinocchio when
numba is missing or the model has joints the kernels do not handle. The environment variable
``AIAUV_BACKEND`` overrides the default for vehicles created without an explicit backend.

Threads: one :class:`Vehicle` may be used from several threads at once, on both backends. What an
evaluation overwrites is per thread: Pinocchio's ``Data`` (of the vehicle and of its displaced
water) and the fluid scratch arrays (``threading.local``, made by ``model.createData()`` on a
thread's first call), and the compiled workspace (:class:`aiauv_pin.kernels.evaluation.FastModel`); the
model and the fluid parameters are only read. Results are bit-identical to the same calls made
serially (``tests/model/test_fuzz_entry_points.py``). Changing ``backend`` while other threads evaluate
is not supported.
"""

from __future__ import annotations

import contextlib
import os
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from aiauv_hydro.currents import Current, as_current
from aiauv_hydro.laws.fluid_terms import FluidModel, add_body_fluid_bias
from aiauv_hydro.laws.kirchhoff import momentum_in_world
from aiauv_hydro.laws.lift import add_fin_wrenches
from aiauv_hydro.laws.unsteady_flow import add_flow_acceleration_bias
from aiauv_hydro.spec import HydroSpec
from aiauv_pin._internal.array_checks import (
    configuration,
    finite_time,
    float_array,
    frame_index,
    optional_current,
)
from aiauv_pin.errors import ArgumentError, project_errors
from aiauv_pin.kernels.records import Model
from aiauv_pin.model.assembly import assemble, compiled_model, packed_records

_LOCAL = pin.ReferenceFrame.LOCAL

_BLAS_CONTROLLER = None

#: Smallest ``nv`` for which the Pinocchio path limits BLAS to one thread: the limit itself costs
#: about 0.1 ms (threadpoolctl), more than the whole gain on small matrices.
SINGLE_THREAD_BLAS_FROM_NV = 32


def single_threaded_blas(nv: int):
    """Context that limits BLAS to one thread while the Pinocchio path evaluates, then restores it.

    Its matrices (nv x nv, a few hundred at most) are far too small for threads to pay: on 2 cores
    the threaded products and solve cost several times more at 127 links (measured on the
    performance page of the docs). threadpoolctl limits the BLAS that numpy actually loaded,
    only for the duration of the call, so a user's own numpy work keeps its threads; an
    environment variable such as ``OPENBLAS_NUM_THREADS`` would act only if set before numpy is
    imported, and on the whole process. Below :data:`SINGLE_THREAD_BLAS_FROM_NV` it does nothing.
    """
    global _BLAS_CONTROLLER
    if nv < SINGLE_THREAD_BLAS_FROM_NV:
        return contextlib.nullcontext()
    if _BLAS_CONTROLLER is None:
        from threadpoolctl import ThreadpoolController

        _BLAS_CONTROLLER = ThreadpoolController()  # inspects the loaded libraries once
    return _BLAS_CONTROLLER.limit(limits=1, user_api="blas")


#: Accepted values of ``Vehicle(backend=...)``.
BACKENDS = ("auto", "numba", "pinocchio")


@dataclass(frozen=True)
class FluidForces:
    """The fluid and hydrostatic terms of the equations of motion at one state.

    Attributes:
        mass_matrix: ``M_RB(q) + M_A(q)`` (nv x nv) [kg, kg m, kg m^2].
        bias: Everything on the left-hand side that does not multiply ``dv``:
            ``C_RB v + added-mass bias and Coriolis + g(q) - damping`` (nv,) [N, N m].
    """

    mass_matrix: np.ndarray
    bias: np.ndarray


class _PinocchioScratch(threading.local):
    """One thread's Pinocchio ``Data`` of the vehicle and of its displaced water, and fluid
    scratch arrays (made on the thread's first use; see :class:`Vehicle`)."""

    data = None
    buoyancy_data = None
    scratch = None


class Vehicle:
    r"""An underwater multibody vehicle ready for simulation.

    Build it with :func:`aiauv_pin.load_vehicle`. The arrays it returns are in Pinocchio's conventions:
    ``q`` has the base position, base orientation quaternion ``(x, y, z, w)`` and joint angles
    (``model.nq``); ``v`` has the base twist in the base frame ``(v, omega)`` and joint rates
    (``model.nv``).

    Attributes:
        model: The Pinocchio model (free-flyer root). Its gravity is ``(0, 0, -g)`` when restoring
            forces are on and zero otherwise, so that with every fluid effect off
            ``acceleration == pinocchio.aba``.
        hydro: The hydrodynamic parameters read from the URDF.
        name: Robot name from the URDF.
        added_mass, damping, restoring: Which fluid effects are on.
        fixed_base: The root link is fixed to the world: ``q`` and ``v`` keep the free-flyer
            layout, the base velocity and acceleration are zero in both backends (the base
            entries of ``v`` are read as zero, the base rows of :meth:`acceleration` are zero and
            the joint rows solve ``M_jj ddq_j = tau_j - b_j``).
        backend: ``"auto"``, ``"numba"`` or ``"pinocchio"`` (see the module docstring); settable.
        data: Pinocchio's ``Data`` of the calling thread (each thread has its own).

    Thread safety: the methods may be called from several threads at once on either backend; each
    thread evaluates on its own Pinocchio data and compiled workspace, and gets bit for bit what
    the same calls give serially (see the module docstring). :func:`aiauv_pin.rollout` runs its
    runs on threads with a workspace of their own.

    Every method checks its arguments before Pinocchio or compiled code sees them
    (:mod:`aiauv_pin._internal.array_checks`), and raises only :class:`aiauv_pin.errors.AiauvError` on bad
    input (:func:`aiauv_pin.errors.project_errors` converts what Pinocchio or numba raise).
    """

    def __init__(
        self,
        model: pin.Model,
        hydro: HydroSpec,
        *,
        name: str = "vehicle",
        added_mass: bool = True,
        damping: bool = True,
        restoring: bool = True,
        backend: str | None = None,
        fixed_base: bool = False,
    ) -> None:
        self.model = model
        self.fixed_base = bool(fixed_base)
        self.hydro = hydro
        self.name = name
        self.added_mass = bool(added_mass)
        self.damping = bool(damping)
        self.restoring = bool(restoring)
        self.urdf_path: Path | None = None  # set by load_vehicle; the viewer reads visuals from it
        # set by load_vehicle(lenient=True): the repairs made, and {merged link: its carrier}
        self.lenient_repairs = None
        self.merged_links: dict[str, str] = {}
        #: What the conversion of an SDF file changed or left out (one line each; set by load_vehicle)
        self.description_notes: tuple[str, ...] = ()
        self.model.gravity = pin.Motion(
            np.array([0.0, 0.0, -hydro.gravity if restoring else 0.0]), np.zeros(3)
        )
        self._pinocchio = _PinocchioScratch()  # Pinocchio data made on first use
        self._packed: Model | None = None
        # the description packed once (aiauv_pin.model.assembly): both backends evaluate it
        self._assembly = parts = assemble(
            model,
            hydro,
            added_mass=self.added_mass,
            damping=self.damping,
            restoring=restoring,
            fixed_base=self.fixed_base,
        )
        self._fluid_net, self._fluid_reference = parts.fluid_net, parts.fluid_reference
        self._thrusters = parts.thrusters
        self._buoyancy_model, self._has_buoyancy = parts.buoyancy_model, parts.has_buoyancy
        self._has_fluid, self._inertia_in_body = parts.has_fluid, parts.inertia_in_body
        self._fins = parts.fins
        self._has_fluid = self._has_fluid or bool(hydro.fins)
        self._fast = None
        self._fast_reason: str | None = None
        self.backend = os.environ.get("AIAUV_BACKEND", "auto") if backend is None else backend

    def fluid_model(self, include_hydrostatics: bool = True) -> FluidModel:
        """The packed per-body and per-link fluid parameters the laws of
        :mod:`aiauv_hydro.laws.fluid_terms` take.

        Args:
            include_hydrostatics: With the hydrostatics (buoyancy minus weight, what the compiled kernels
                use) or without (the Pinocchio reference computes them with Pinocchio).
        """
        return self._fluid_net if include_hydrostatics else self._fluid_reference

    def packed_model(self) -> Model:
        """The vehicle as the flat records of :mod:`aiauv_pin.kernels.articulated_body` (a :class:`Model`),
        built by :func:`aiauv_pin.model.assembly.packed_records` (those of :attr:`fast` when the
        vehicle runs compiled).

        Raises:
            ValueError: A joint the kernels do not support (see
                :func:`aiauv_pin.kernels.records.unsupported_reason`).
        """
        if self._packed is None:
            self._packed = (
                self._fast.model
                if self._fast is not None
                else packed_records(self.model, self._assembly)
            )
        return self._packed

    # ------------------------------------------------------------------ per-thread data
    def __getstate__(self) -> dict:
        """Picklable state: the per-thread Pinocchio data are made again on use."""
        state = self.__dict__.copy()
        del state["_pinocchio"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._pinocchio = _PinocchioScratch()

    def _per_thread(self, name: str, make):
        """The calling thread's ``name`` in :class:`_PinocchioScratch`, made by ``make()`` on the
        thread's first use."""
        local = self._pinocchio
        value = getattr(local, name)
        if value is None:
            value = make()
            setattr(local, name, value)
        return value

    @property
    def data(self) -> pin.Data:
        """Pinocchio's ``Data`` of the calling thread (``model.createData()`` on first use)."""
        return self._per_thread("data", self.model.createData)

    @property
    def _buoyancy_data(self) -> pin.Data:
        """The calling thread's ``Data`` of the displaced-water model."""
        return self._per_thread("buoyancy_data", self._buoyancy_model.createData)

    @property
    def _scratch(self) -> tuple[np.ndarray, np.ndarray]:
        """The calling thread's fluid scratch: body wrenches (nb, 6) and (3, 6)."""
        nb = self.model.njoints - 1
        return self._per_thread("scratch", lambda: (np.zeros((nb, 6)), np.zeros((3, 6))))

    # ------------------------------------------------------------------ backend
    @property
    def backend(self) -> str:
        """Requested backend: ``"auto"``, ``"numba"`` or ``"pinocchio"``."""
        return self._backend

    @backend.setter
    def backend(self, value: str) -> None:
        if not isinstance(value, str) or value not in BACKENDS:
            raise ArgumentError(
                f"unknown backend {value!r:.40} (expected one of {', '.join(BACKENDS)})"
            )
        self._backend = value
        self._fast = None
        if value != "pinocchio":
            self._fast = self._build_fast()
            if self._fast is None and value == "numba":
                raise ArgumentError(f"numba backend unavailable: {self._fast_reason}")

    def _build_fast(self):
        from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE

        if not NUMBA_AVAILABLE:
            self._fast_reason = "numba is disabled (NUMBA_DISABLE_JIT)"
            return None
        try:
            return compiled_model(self.model, self._assembly, self._packed)
        except ImportError as exc:
            self._fast_reason = f"numba cannot be imported ({exc.__class__.__name__})"
            return None
        except ValueError as exc:
            self._fast_reason = str(exc)
            return None

    @property
    def active_backend(self) -> str:
        """The backend in use: ``"numba"`` or ``"pinocchio"``."""
        return "pinocchio" if self._fast is None else "numba"

    @property
    def fallback_reason(self) -> str | None:
        """Why ``backend="auto"`` fell back to Pinocchio (``None`` if it did not)."""
        return self._fast_reason if self._fast is None else None

    @property
    def fast(self):
        """The compiled model (:class:`aiauv_pin.kernels.evaluation.FastModel`) or ``None`` on Pinocchio."""
        return self._fast

    # ------------------------------------------------------------------ properties
    @property
    def nq(self) -> int:
        """Size of the configuration vector."""
        return self.model.nq

    @property
    def nv(self) -> int:
        """Size of the velocity vector (6 + number of joints)."""
        return self.model.nv

    @property
    def joint_names(self) -> list[str]:
        """Names of the actuated joints, in the order of ``v[6:]``."""
        return list(self.model.names)[2:]

    @property
    def thruster_names(self) -> list[str]:
        """Names of the thrusters, in the order of the thrust vector."""
        return [t.name for t in self.hydro.thrusters]

    @property
    def max_thrust(self) -> np.ndarray:
        """Thrust limits [N], one per thruster."""
        return np.array([t.max_thrust for t in self.hydro.thrusters])

    @property
    def fin_names(self) -> list[str]:
        """Names of the fins, in the order of the fin angles."""
        return [f.name for f in self.hydro.fins]

    @property
    def n_fins(self) -> int:
        """Number of fins (control surfaces)."""
        return len(self.hydro.fins)

    @property
    def max_fin_angle(self) -> np.ndarray:
        """Fin angle limits [rad], one per fin."""
        return np.array([f.max_angle for f in self.hydro.fins])

    def _fin_angles(self, fin_angles) -> np.ndarray:
        """``fin_angles`` checked (zeros for ``None``): finite, one per fin [rad]."""
        if fin_angles is None:
            return np.zeros(self.n_fins)
        return float_array(fin_angles, "fin_angles", (self.n_fins,))

    def neutral_configuration(self) -> np.ndarray:
        """Base at the world origin, level, joints at zero."""
        return pin.neutral(self.model)

    # ------------------------------------------------------------------ dynamics
    def _body_states(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rotations, origins and twists of every body after Pinocchio's forward kinematics."""
        data = self.data
        joints = range(1, self.model.njoints)
        rotation = np.array([data.oMi[j].rotation for j in joints])
        position = np.array([data.oMi[j].translation for j in joints])
        twist = np.array([data.v[j].vector for j in joints])
        return rotation, position, twist

    def _currents_at_probes(
        self, current: Current, t: float, rotation: np.ndarray, position: np.ndarray
    ) -> np.ndarray:
        """Water velocity at each body's probe point (nb, 3) [m/s], world axes."""
        if current.is_zero:
            return np.zeros((len(position), 3))
        probe = position + np.einsum("nij,nj->ni", rotation, self._fluid_reference.current_probe)
        return np.array([current.velocity(t, point) for point in probe])

    def _flow_accelerations_at_probes(
        self, current: Current, t: float, rotation: np.ndarray, position: np.ndarray
    ) -> np.ndarray | None:
        """The water's acceleration ``DV/Dt`` at each body's probe point (nb, 3) [m/s^2], world
        axes; ``None`` where it is never sampled (a constant current, the quasi-steady model), as
        in the compiled kernels (:func:`aiauv_pin.kernels.articulated_body.sample_current`)."""
        if current.kind == "constant" or not current.unsteady:
            return None
        probe = position + np.einsum("nij,nj->ni", rotation, self._fluid_reference.current_probe)
        return np.array([current.water_acceleration(t, point) for point in probe])

    def _q(self, q) -> np.ndarray:
        return configuration(q, self.model.nq)

    def _v(self, v, name: str = "v") -> np.ndarray:
        return float_array(v, name, (self.model.nv,))

    def _body_jacobians(self) -> np.ndarray:
        """Local Jacobians of every body (nb, 6, nv), after ``computeJointJacobians``."""
        return np.array(
            [
                pin.getJointJacobian(self.model, self.data, j, _LOCAL)
                for j in range(1, self.model.njoints)
            ]
        )

    def _added_mass_matrix(self, jac: np.ndarray) -> np.ndarray:
        """``sum_i J_i^T M_A,i J_i``, accumulated body by body (no (nb, nv, nv) temporary)."""
        mass = np.zeros((self.nv, self.nv))
        for b, added in enumerate(self._fluid_reference.added_mass):
            if added.any():
                mass += jac[b].T @ added @ jac[b]
        return mass

    def _hydro_terms(self, q: np.ndarray, v: np.ndarray, current, t: float, fin_angles=None):
        """Rigid + fluid mass matrix and left-hand-side bias (the Pinocchio reference path).

        Pinocchio gives the rigid part (``computeAllTerms``: CRBA, RNEA bias with the weight,
        Jacobians, bias accelerations); every fluid term comes from
        :func:`aiauv_hydro.laws.fluid_terms.add_body_fluid_bias` and
        :func:`aiauv_hydro.laws.unsteady_flow.add_flow_acceleration_bias`, the functions the
        compiled kernels call, and the fins' lift and drag at ``fin_angles`` [rad] (zeros for
        ``None``) from :func:`aiauv_hydro.laws.lift.add_fin_wrenches`, as in the kernels.
        """
        model, data = self.model, self.data
        pin.computeAllTerms(model, data, q, v)
        mass = np.triu(data.M) + np.triu(data.M, 1).T
        bias = data.nle.copy()
        water = as_current(current)
        accelerating = water.unsteady and water.kind != "constant" and self._has_buoyancy
        if not self._has_fluid and not accelerating:
            if self.restoring and self._has_buoyancy:
                bias -= pin.computeGeneralizedGravity(self._buoyancy_model, self._buoyancy_data, q)
            return mass, bias
        rotation, position, twist = self._body_states()
        currents = self._currents_at_probes(water, t, rotation, position)
        flow_accelerations = self._flow_accelerations_at_probes(water, t, rotation, position)
        if self.restoring and self._has_buoyancy:
            bias -= pin.computeGeneralizedGravity(self._buoyancy_model, self._buoyancy_data, q)
        fluid_bias, scratch = self._scratch
        fluid_bias[:] = 0.0
        relative = np.empty_like(twist)
        add_body_fluid_bias(
            self._fluid_reference, rotation, twist, currents, fluid_bias, relative, scratch
        )
        if self.n_fins:
            angles = np.zeros(self.n_fins) if fin_angles is None else fin_angles
            add_fin_wrenches(self._fins, angles, rotation, twist, currents, fluid_bias)
        if flow_accelerations is not None:
            add_flow_acceleration_bias(
                self._fluid_reference, rotation, flow_accelerations, fluid_bias
            )
        jac = self._body_jacobians()
        if self.added_mass:
            # M_A times the bias acceleration J_dot v (data.a with zero dv after computeAllTerms);
            # M_A J dv goes into the mass matrix
            accel = np.array([data.a[j].vector for j in range(1, model.njoints)])
            fluid_bias += np.einsum("nij,nj->ni", self._fluid_reference.added_mass, accel)
            mass += self._added_mass_matrix(jac)
        bias += np.einsum("nji,nj->i", jac, fluid_bias)
        return mass, bias

    def acceleration(
        self,
        q: np.ndarray,
        v: np.ndarray,
        tau: np.ndarray,
        current=None,
        *,
        t: float = 0.0,
        fin_angles=None,
    ) -> np.ndarray:
        """Forward dynamics ``dv`` [m/s^2, rad/s^2] in Pinocchio's convention.

        Args:
            q: Configuration (nq,).
            v: Generalised velocity (nv,) [m/s, rad/s].
            tau: Generalised actuator forces (nv,) [N, N m]; thrusters enter through
                :meth:`thrust_matrix`.
            current: Water velocity: ``None`` (still water), a constant world velocity (3,) [m/s], or
                a :class:`aiauv_hydro.currents.Current` (sampled at each body at time ``t``).
            t: Time [s] at which a time-varying current is sampled.
            fin_angles: Angles of the fins acting now [rad] (:attr:`fin_names` order; ``None``: all
                zero); taken as given (the limits of :attr:`max_fin_angle` apply where a command
                reaches the plant: :meth:`step` and the simulation loops).

        Returns:
            ``dv`` (nv,), the time derivative of ``v``'s coordinates (Fossen's ``nu_dot`` for the base).
        """
        if self.hydro.fins:  # (not the n_fins property: the hottest entry point, issue 34)
            return self._finned_acceleration(q, v, tau, current, t, self._fin_angles(fin_angles))
        if fin_angles is not None:
            self._fin_angles(fin_angles)  # names the problem: this vehicle has no fins
        if self._fast is not None and current is None:
            # the arguments checked in the compiled call itself (the checks below cost more than
            # an evaluation); anything it does not take goes on to the checks, which name it
            out = self._fast.checked_acceleration(q, v, tau, t)
            if out is not None:
                return out
        q, v, tau = self._q(q), self._v(v), self._v(tau, "tau")
        t = finite_time(t)
        fast = self._fast
        if fast is not None:  # environment() checks the current
            env = fast.environment(current)
            return fast.acceleration_unchecked(q, v, tau, env, fast.no_servo, t)
        return self._pinocchio_acceleration(q, v, tau, optional_current(current), t)

    @project_errors("Vehicle.acceleration")
    def _pinocchio_acceleration(self, q, v, tau, current, t: float, fin_angles=None) -> np.ndarray:
        with single_threaded_blas(self.nv):
            if not self.fixed_base:
                mass, bias = self._hydro_terms(q, v, current, t, fin_angles)
                return np.linalg.solve(mass, tau - bias)
            # fixed base: v_base = 0, a_base = 0; the joint rows alone,
            # ddq_j = M_jj^-1 (tau_j - b_j) (Featherstone 2008, Sec. 6.1, a fixed-base tree)
            v = v.copy()
            v[:6] = 0.0
            mass, bias = self._hydro_terms(q, v, current, t, fin_angles)
            out = np.zeros(self.nv)
            if self.nv > 6:
                out[6:] = np.linalg.solve(mass[6:, 6:], tau[6:] - bias[6:])
            return out

    def _finned_acceleration(self, q, v, tau, current, t, fin_angles) -> np.ndarray:
        """:meth:`acceleration` of a vehicle with fins: the angles go into this thread's compiled
        workspace (``W.fin_angle``, read by the kernels at every stage) or to the reference."""
        q, v, tau = self._q(q), self._v(v), self._v(tau, "tau")
        t = finite_time(t)
        fast = self._fast
        if fast is not None:
            env = fast.environment(current)
            fast.workspace.fin_angle[:] = fin_angles
            return fast.acceleration_unchecked(q, v, tau, env, fast.no_servo, t)
        return self._pinocchio_acceleration(q, v, tau, optional_current(current), t, fin_angles)

    @project_errors("Vehicle.acceleration_derivatives")
    def acceleration_derivatives(
        self, q: np.ndarray, v: np.ndarray, tau: np.ndarray, current=None, *, t: float = 0.0
    ):
        """Exact Jacobians of :meth:`acceleration` (see :mod:`aiauv_pin.model.derivatives`).

        Returns:
            An :class:`aiauv_pin.model.derivatives.AccelerationDerivatives`: ``(acceleration, da_dq,
            da_dv, da_dtau, da_dcurrent)``, ``da_dq`` with respect to ``q (+) dq`` (tangent space, as
            ``pinocchio.integrate``), ``da_dcurrent`` with respect to a uniform current (world axes).
        """
        from aiauv_pin.model.derivatives import acceleration_derivatives

        if self.fixed_base:
            raise ArgumentError(
                "derivatives: not available for a fixed-base vehicle (they are those of a free base)"
            )
        return acceleration_derivatives(self, q, v, tau, current, t=t)

    @project_errors("Vehicle.fluid_forces")
    def fluid_forces(
        self, q: np.ndarray, v: np.ndarray, current=None, *, t: float = 0.0
    ) -> FluidForces:
        """Mass matrix and bias of the equations of motion ``M dv + bias = tau``."""
        q, v, current = self._q(q), self._v(v), optional_current(current)
        t = finite_time(t)
        with single_threaded_blas(self.nv):
            mass, bias = self._hydro_terms(q, v, current, t)
        return FluidForces(mass, bias)

    @project_errors("Vehicle.mass_matrix")
    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """``M(q) = M_RB(q) + sum_i J_i^T M_A,i J_i`` (nv x nv), symmetric positive definite."""
        q = self._q(q)
        mass = pin.crba(self.model, self.data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T  # CRBA fills the upper triangle
        if self.added_mass and self._fluid_reference.added_mass.any():
            pin.computeJointJacobians(self.model, self.data, q)
            with single_threaded_blas(self.nv):
                mass += self._added_mass_matrix(self._body_jacobians())
        return mass

    def kinetic_energy(self, q: np.ndarray, v: np.ndarray) -> float:
        """Kinetic energy of body and fluid, ``v^T M(q) v / 2`` [J] (water at rest)."""
        v = self._v(v)
        return 0.5 * float(v @ self.mass_matrix(q) @ v)

    @project_errors("Vehicle.restoring_forces")
    def restoring_forces(self, q: np.ndarray) -> np.ndarray:
        """Hydrostatic generalised force ``g(q)`` (weight minus buoyancy) as on the left-hand side [N, N m].

        Zero when the vehicle was loaded with ``restoring=False``. The compiled backend evaluates
        :func:`aiauv_hydro.laws.fluid_terms.hydrostatic_wrench`; the Pinocchio reference,
        Pinocchio's generalised
        gravity of the vehicle and of its displaced water.
        """
        q = self._q(q)
        if self._fast is not None:
            return self._fast.restoring_forces_unchecked(q)
        weight = pin.computeGeneralizedGravity(self.model, self.data, q)
        if not self._has_buoyancy:
            return weight
        return weight - pin.computeGeneralizedGravity(self._buoyancy_model, self._buoyancy_data, q)

    @project_errors("Vehicle.thrust_matrix")
    def thrust_matrix(self, q: np.ndarray) -> np.ndarray:
        """``B(q)`` (nv x m): generalised forces of unit thrusts (the paper's eq. (20))."""
        q = self._q(q)
        if self._fast is not None:
            return self._fast.thrust_matrix_unchecked(q)
        pin.computeJointJacobians(self.model, self.data, q)
        matrix = np.zeros((self.nv, len(self.hydro.thrusters)))
        for k, (b, wrench) in enumerate(
            zip(self._thrusters.body, self._thrusters.unit_wrench, strict=True)
        ):
            jac = pin.getJointJacobian(self.model, self.data, int(b) + 1, _LOCAL)
            matrix[:, k] = jac.T @ wrench
        return matrix

    @property
    def n_controls(self) -> int:
        """Size of the control vector of :meth:`step`: one thrust per thruster, one angle per fin,
        one torque per joint."""
        return len(self.hydro.thrusters) + self.n_fins + self.nv - 6

    def controls_to_forces(self, q: np.ndarray, controls) -> np.ndarray:
        """Generalised forces ``tau = B(q) u + (0, tau_q)`` (nv,) [N, N m] of a control vector.

        Args:
            q: Configuration (nq,).
            controls: (:attr:`n_controls`,): the thrusts ``u`` [N] in the order of
                :attr:`thruster_names`, then the fin angles [rad] in the order of :attr:`fin_names`
                (not forces: they act through the dynamics, :meth:`acceleration`, and are left out
                here), then the joint torques ``tau_q`` [N m] in the order of
                :attr:`joint_names`. ``B(q)`` is :meth:`thrust_matrix` (the paper's eq. (20)).

        Raises:
            ArgumentError: A bad configuration or control vector (one line).
        """
        q = self._q(q)
        controls = float_array(controls, "controls", (self.n_controls,))
        m = len(self.hydro.thrusters)
        tau = self.thrust_matrix(q) @ controls[:m]
        tau[6:] += controls[m + self.n_fins :]
        return tau

    def step(
        self,
        q: np.ndarray,
        v: np.ndarray,
        controls,
        dt: float,
        *,
        method: str = "rk4",
        current=None,
        t: float = 0.0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """One integrator step of the compiled backend from ``(q, v)`` at time ``t``, with thrusts and
        joint torques as controls; returns the new ``(q, v)`` (new arrays).

        The controls enter as ``tau = B(q) u + (0, tau_q)`` (:meth:`controls_to_forces`) at the
        step's start and are held over the step (the compiled loop holds a controller's output
        the same way), then :meth:`aiauv_pin.kernels.evaluation.FastModel.step` integrates: the
        integrators of :func:`aiauv_pin.simulate` (``"rk4"``: Munthe-Kaas RK4 on SE(3),
        ``"euler"``: semi-implicit Euler, ``"midpoint"``). For a run of many steps with a
        controller, :func:`aiauv_pin.simulate` or :func:`aiauv_pin.rollout` cost far less per step.

        Args:
            q: Configuration (nq,).
            v: Velocity (nv,) [m/s, rad/s].
            controls: Thrusts [N], fin angles [rad] (clipped to :attr:`max_fin_angle` and held
                over the step; no rate limit in one stateless step), then joint torques [N m],
                (:attr:`n_controls`,).
            dt: Step [s], > 0.
            method: ``"rk4"``, ``"euler"`` or ``"midpoint"``.
            current: As in :meth:`acceleration`.
            t: Time [s] of the step's start (a time-varying current is sampled from it).

        Raises:
            ArgumentError: A bad argument (one line), or a vehicle on the Pinocchio backend
                (:func:`aiauv_pin.rk4_step` steps that one).
        """
        fast = self._fast
        if fast is None:
            why = self._fast_reason or f"backend={self.backend!r}"
            raise ArgumentError(
                f"Vehicle.step needs the compiled backend (this vehicle runs on Pinocchio: "
                f"{why}); aiauv_pin.rk4_step steps it"
            )
        tau = self.controls_to_forces(q, controls)
        if self.n_fins:
            m, limit = len(self.hydro.thrusters), self.max_fin_angle
            angles = np.clip(np.asarray(controls, dtype=float)[m : m + self.n_fins], -limit, limit)
            fast.workspace.fin_angle[:] = angles
        if self.fixed_base:  # the locked base does not move: its velocity is zero
            v = float_array(v, "v", (self.nv,)).copy()
            v[:6] = 0.0
        return fast.step(q, v, tau, dt, method=method, current=current, t=t)

    @project_errors("Vehicle.momentum_in_world")
    def momentum_in_world(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Impulse of body plus fluid about the world origin, in world axes (6,).

        For added mass, Kirchhoff's impulse ``M_A nu`` (Lamb 1932, Sec. 119); in an ideal fluid with no
        external force it is conserved.

        Returns:
            ``(linear [kg m/s], angular [kg m^2/s])``.
        """
        q, v = self._q(q), self._v(v)
        pin.forwardKinematics(self.model, self.data, q, v)
        rotation, position, twist = self._body_states()
        return momentum_in_world(self._inertia_in_body, twist, rotation, position)

    # ------------------------------------------------------------------ kinematics
    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of a link or frame, with a one-line error if unknown."""
        if not isinstance(name, str) or not self.model.existFrame(name):
            raise ArgumentError(f"unknown link or frame {name!r:.80}")
        return self.model.getFrameId(name)

    @project_errors("Vehicle.frame_placement")
    def frame_placement(self, q: np.ndarray, name: str) -> pin.SE3:
        """Pose of a link or frame in the world."""
        q = self._q(q)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.frame_id(name)].copy()

    @project_errors("Vehicle.frame_motion")
    def frame_motion(
        self, q: np.ndarray, v: np.ndarray, frame_id: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose and velocity of a frame in one call.

        Args:
            q: Configuration (nq,).
            v: Velocity (nv,) [m/s, rad/s].
            frame_id: Pinocchio frame index (see :meth:`frame_id`).

        Returns:
            ``(rotation to world (3x3), position in world [m], twist (v, omega) in the frame's axes)``.
        """
        q, v = self._q(q), self._v(v)
        frame_id = frame_index(frame_id, len(self.model.frames))
        if self._fast is not None:
            return self._fast.frame_motion_unchecked(q, v, frame_id)
        pin.forwardKinematics(self.model, self.data, q, v)
        pose = pin.updateFramePlacement(self.model, self.data, frame_id)
        twist = pin.getFrameVelocity(self.model, self.data, frame_id, _LOCAL)
        return pose.rotation.copy(), pose.translation.copy(), twist.vector.copy()

    @project_errors("Vehicle.link_placements")
    def link_placements(self, q: np.ndarray, links: list[str] | None = None) -> list[pin.SE3]:
        """World poses of several links (default: every link with hydrodynamics)."""
        names = [link.link for link in self.hydro.links] if links is None else links
        ids = [self.frame_id(n) for n in names]
        q = self._q(q)
        pin.framesForwardKinematics(self.model, self.data, q)
        return [self.data.oMf[i].copy() for i in ids]
