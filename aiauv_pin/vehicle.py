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
compiled kernels of :mod:`aiauv_pin.fast` (an articulated-body algorithm whose bodies carry the full
6x6 rigid + added inertia), tested against this path to 1e-9; ``"auto"`` falls back to Pinocchio when
numba is missing or the model has joints the kernels do not handle. The environment variable
``AIAUV_BACKEND`` overrides the default for vehicles created without an explicit backend.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from hydro.crossflow import crossflow_wrench
from hydro.damping import linear_quadratic_wrench
from hydro.kirchhoff import coriolis_wrench, cross, momentum_in_world
from hydro.spatial import motion_transform
from hydro.spec import HydroSpec

from .arguments import configuration, float_array, optional_current
from .errors import ArgumentError

_LOCAL = pin.ReferenceFrame.LOCAL

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


class Vehicle:
    """An underwater multibody vehicle ready for simulation.

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
        backend: ``"auto"``, ``"numba"`` or ``"pinocchio"`` (see the module docstring); settable.
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
    ) -> None:
        self.model = model
        self.hydro = hydro
        self.name = name
        self.added_mass = bool(added_mass)
        self.damping = bool(damping)
        self.restoring = bool(restoring)
        self.urdf_path: Path | None = None  # set by load_vehicle; the viewer reads visuals from it
        self.model.gravity = pin.Motion(
            np.array([0.0, 0.0, -hydro.gravity if restoring else 0.0]), np.zeros(3)
        )
        self.data = model.createData()
        self._zero_v = np.zeros(model.nv)
        self._setup_links()
        self._setup_buoyancy()
        self._setup_thrusters()
        self._fast = None
        self._fast_reason: str | None = None
        self.backend = os.environ.get("AIAUV_BACKEND", "auto") if backend is None else backend

    # ------------------------------------------------------------------ set-up
    def _link_placement(self, link: str) -> tuple[int, pin.SE3]:
        frame_id = self.model.getFrameId(link, pin.FrameType.BODY)
        if frame_id >= len(self.model.frames):
            raise ValueError(f"unknown link '{link}'")
        frame = self.model.frames[frame_id]
        return int(frame.parentJoint), frame.placement

    def _setup_links(self) -> None:
        links = self.hydro.links
        bodies: list[int] = []
        body_of_link = []
        link_from_body = []
        for link in links:
            joint, placement = self._link_placement(link.link)
            if joint not in bodies:
                bodies.append(joint)
            body_of_link.append(bodies.index(joint))
            # nu_link = X nu_joint with X the motion transform to the link frame
            link_from_body.append(motion_transform(placement.rotation, placement.translation))
        self._bodies = bodies
        self._body_of_link = np.array(body_of_link, dtype=int)
        self._link_from_body = np.array(link_from_body) if links else np.zeros((0, 6, 6))
        n_bodies = len(bodies)
        added = np.zeros((n_bodies, 6, 6))
        for k, link in enumerate(links):
            x = self._link_from_body[k]
            added[self._body_of_link[k]] += x.T @ link.added_mass @ x
        self._added_mass_in_body = added
        self._linear_damping = np.array([link.linear_damping for link in links]).reshape(-1, 6, 6)
        self._quadratic_damping = np.array([link.quadratic_damping for link in links]).reshape(
            -1, 6, 6
        )
        crossflow = [(k, link.crossflow) for k, link in enumerate(links) if link.crossflow]
        self._crossflow_links = np.array([k for k, _ in crossflow], dtype=int)
        self._cylinder_from_link = np.array(
            [motion_transform(c.rotation, c.translation) for _, c in crossflow]
        ).reshape(-1, 6, 6)
        self._crossflow_length = np.array([c.length for _, c in crossflow])
        self._crossflow_coefficient = np.array([c.strip_coefficient for _, c in crossflow])
        # generalised inertia per Pinocchio joint body (rigid, plus added if on), for the momentum
        self._inertia_in_joint = np.array([inertia.matrix() for inertia in self.model.inertias])
        if self.added_mass:
            for b, joint in enumerate(bodies):
                self._inertia_in_joint[joint] += added[b]

    def _setup_buoyancy(self) -> None:
        # Buoyancy as the weight of a "negative-mass" copy of the vehicle: each Pinocchio body gets
        # the displaced mass rho V of its links at their centre of buoyancy (Fossen 2021, eq. (4.6)).
        model = self.model
        buoyancy_model = pin.Model(model)
        for joint in range(model.njoints):
            buoyancy_model.inertias[joint] = pin.Inertia.Zero()
        rho = self.hydro.fluid_density
        for link in self.hydro.links:
            if link.volume == 0.0:
                continue
            joint, placement = self._link_placement(link.link)
            displaced = pin.Inertia(
                rho * link.volume, placement.act(link.center_of_buoyancy), np.zeros((3, 3))
            )
            buoyancy_model.inertias[joint] = buoyancy_model.inertias[joint] + displaced
        buoyancy_model.gravity = model.gravity
        self._buoyancy_model = buoyancy_model
        self._buoyancy_data = buoyancy_model.createData()

    def _setup_thrusters(self) -> None:
        bodies: list[int] = []
        body_of = []
        wrenches = []
        for thruster in self.hydro.thrusters:
            joint, placement = self._link_placement(thruster.link)
            if joint not in bodies:
                bodies.append(joint)
            body_of.append(bodies.index(joint))
            direction = placement.rotation @ thruster.direction
            position = placement.act(thruster.position)
            wrenches.append(np.concatenate((direction, np.cross(position, direction))))
        self._thruster_bodies = bodies
        self._thruster_body_of = np.array(body_of, dtype=int)
        self._thruster_wrench = np.array(wrenches).reshape(-1, 6)

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
        try:
            from .fast import load_fast_model

            fast_model = load_fast_model()
        except ImportError as exc:
            self._fast_reason = f"numba cannot be imported ({exc.__class__.__name__})"
            return None
        try:
            return fast_model(self)
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
        """The compiled model (:class:`aiauv_pin.fast.model.FastModel`) or ``None`` on Pinocchio."""
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

    def neutral_configuration(self) -> np.ndarray:
        """Base at the world origin, level, joints at zero."""
        return pin.neutral(self.model)

    # ------------------------------------------------------------------ dynamics
    def _added_mass_matrix(self, jac: np.ndarray) -> np.ndarray:
        """``sum_i J_i^T M_A,i J_i`` from the bodies' local Jacobians (n, 6, nv).

        One product of the stacked ``(6 n, nv)`` Jacobian with the stacked ``M_A,i J_i``: no
        ``n x nv x nv`` temporary (8 GB for a 1000-body vehicle).
        """
        nv = jac.shape[2]
        weighted = self._added_mass_in_body @ jac
        return jac.reshape(-1, nv).T @ weighted.reshape(-1, nv)

    def _q(self, q) -> np.ndarray:
        return configuration(q, self.model.nq)

    def _v(self, v, name: str = "v") -> np.ndarray:
        return float_array(v, name, (self.model.nv,))

    def _body_jacobians(self) -> np.ndarray:
        """Local Jacobians of the hydrodynamic bodies, after ``computeJointJacobians``."""
        return np.array(
            [pin.getJointJacobian(self.model, self.data, j, _LOCAL) for j in self._bodies]
        )

    def _hydro_terms(
        self, q: np.ndarray, v: np.ndarray, current: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rigid + fluid mass matrix and left-hand-side bias, after ``computeAllTerms``."""
        model, data = self.model, self.data
        pin.computeAllTerms(model, data, q, v)
        mass = data.M.copy()
        bias = data.nle.copy()
        if self.restoring and self.hydro.links:
            bias -= pin.computeGeneralizedGravity(self._buoyancy_model, self._buoyancy_data, q)
        if not self._bodies or not (self.added_mass or self.damping):
            return mass, bias
        bodies = self._bodies
        jac = self._body_jacobians()
        twist = np.array([data.v[j].vector for j in bodies])
        if current is not None:
            current_in_body = np.array([data.oMi[j].rotation.T @ current for j in bodies])
            relative = twist.copy()
            relative[:, :3] -= current_in_body
        else:
            current_in_body = None
            relative = twist
        wrench = np.zeros((len(bodies), 6))
        if self.added_mass:
            added = self._added_mass_in_body
            accel = np.array([data.a[j].vector for j in bodies])
            if current_in_body is not None:
                # d/dt of the current seen in a rotating frame: nu_r_dot = nu_dot + (omega x v_c, 0)
                accel[:, :3] += cross(twist[:, 3:], current_in_body)
            wrench += np.einsum("nij,nj->ni", added, accel) + coriolis_wrench(added, relative)
            mass += self._added_mass_matrix(jac)
        if self.damping and self.hydro.links:
            link_twist = np.einsum("nij,nj->ni", self._link_from_body, relative[self._body_of_link])
            link_wrench = linear_quadratic_wrench(
                self._linear_damping, self._quadratic_damping, link_twist
            )
            if self._crossflow_links.size:
                cyl = self._cylinder_from_link
                cyl_twist = np.einsum("nij,nj->ni", cyl, link_twist[self._crossflow_links])
                cyl_wrench = crossflow_wrench(
                    cyl_twist, self._crossflow_length, self._crossflow_coefficient
                )
                link_wrench[self._crossflow_links] += np.einsum("nji,nj->ni", cyl, cyl_wrench)
            body_wrench = np.einsum("nji,nj->ni", self._link_from_body, link_wrench)
            np.add.at(wrench, self._body_of_link, -body_wrench)
        bias += np.einsum("nji,nj->i", jac, wrench)
        return mass, bias

    def acceleration(
        self,
        q: np.ndarray,
        v: np.ndarray,
        tau: np.ndarray,
        current: np.ndarray | None = None,
    ) -> np.ndarray:
        """Forward dynamics ``dv`` [m/s^2, rad/s^2] in Pinocchio's convention.

        Args:
            q: Configuration (nq,).
            v: Generalised velocity (nv,) [m/s, rad/s].
            tau: Generalised actuator forces (nv,) [N, N m]; thrusters enter through
                :meth:`thrust_matrix`.
            current: Constant irrotational water velocity in the world frame (3,) [m/s].

        Returns:
            ``dv`` (nv,), the time derivative of ``v``'s coordinates (Fossen's ``nu_dot`` for the base).
        """
        q, v, tau = self._q(q), self._v(v), self._v(tau, "tau")
        current = optional_current(current)
        if self._fast is not None:
            return self._fast.acceleration(q, v, tau, current)
        mass, bias = self._hydro_terms(q, v, current)
        return np.linalg.solve(mass, tau - bias)

    def fluid_forces(
        self, q: np.ndarray, v: np.ndarray, current: np.ndarray | None = None
    ) -> FluidForces:
        """Mass matrix and bias of the equations of motion ``M dv + bias = tau``."""
        q, v, current = self._q(q), self._v(v), optional_current(current)
        mass, bias = self._hydro_terms(q, v, current)
        return FluidForces(mass, bias)

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """``M(q) = M_RB(q) + sum_i J_i^T M_A,i J_i`` (nv x nv), symmetric positive definite."""
        q = self._q(q)
        mass = pin.crba(self.model, self.data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T  # CRBA fills the upper triangle
        if self.added_mass and self._bodies:
            pin.computeJointJacobians(self.model, self.data, q)
            mass += self._added_mass_matrix(self._body_jacobians())
        return mass

    def kinetic_energy(self, q: np.ndarray, v: np.ndarray) -> float:
        """Kinetic energy of body and fluid, ``v^T M(q) v / 2`` [J] (water at rest)."""
        v = self._v(v)
        return 0.5 * float(v @ self.mass_matrix(q) @ v)

    def restoring_forces(self, q: np.ndarray) -> np.ndarray:
        """Hydrostatic generalised force ``g(q)`` (weight minus buoyancy) as on the left-hand side [N, N m].

        Zero when the vehicle was loaded with ``restoring=False``.
        """
        q = self._q(q)
        if self._fast is not None:
            return self._fast.restoring_forces(q)
        weight = pin.computeGeneralizedGravity(self.model, self.data, q)
        if not self.hydro.links:
            return weight
        return weight - pin.computeGeneralizedGravity(self._buoyancy_model, self._buoyancy_data, q)

    def thrust_matrix(self, q: np.ndarray) -> np.ndarray:
        """``B(q)`` (nv x m): generalised forces of unit thrusts (the paper's eq. (20))."""
        q = self._q(q)
        if self._fast is not None:
            return self._fast.thrust_matrix(q)
        pin.computeJointJacobians(self.model, self.data, q)
        matrix = np.zeros((self.nv, len(self.hydro.thrusters)))
        for b, joint in enumerate(self._thruster_bodies):
            jac = pin.getJointJacobian(self.model, self.data, joint, _LOCAL)
            columns = np.flatnonzero(self._thruster_body_of == b)
            matrix[:, columns] = jac.T @ self._thruster_wrench[columns].T
        return matrix

    def momentum_in_world(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Impulse of body plus fluid about the world origin, in world axes (6,).

        For added mass, Kirchhoff's impulse ``M_A nu`` (Lamb 1932, Sec. 119); in an ideal fluid with no
        external force it is conserved.

        Returns:
            ``(linear [kg m/s], angular [kg m^2/s])``.
        """
        q, v = self._q(q), self._v(v)
        pin.forwardKinematics(self.model, self.data, q, v)
        joints = range(1, self.model.njoints)
        inertia = self._inertia_in_joint[1:]
        twist = np.array([self.data.v[j].vector for j in joints])
        rotation = np.array([self.data.oMi[j].rotation for j in joints])
        translation = np.array([self.data.oMi[j].translation for j in joints])
        return momentum_in_world(inertia, twist, rotation, translation)

    # ------------------------------------------------------------------ kinematics
    def frame_id(self, name: str) -> int:
        """Pinocchio frame index of a link or frame, with a one-line error if unknown."""
        if not isinstance(name, str) or not self.model.existFrame(name):
            raise ArgumentError(f"unknown link or frame {name!r:.80}")
        return self.model.getFrameId(name)

    def frame_placement(self, q: np.ndarray, name: str) -> pin.SE3:
        """Pose of a link or frame in the world."""
        q = self._q(q)
        pin.framesForwardKinematics(self.model, self.data, q)
        return self.data.oMf[self.frame_id(name)].copy()

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
        if isinstance(frame_id, bool) or not isinstance(frame_id, (int, np.integer)):
            raise ArgumentError(f"frame_id must be a frame index (int), got {frame_id!r:.40}")
        if not 0 <= int(frame_id) < len(self.model.frames):
            raise ArgumentError(
                f"frame_id must be in [0, {len(self.model.frames)}), got {int(frame_id)}"
            )
        frame_id = int(frame_id)
        if self._fast is not None:
            return self._fast.frame_motion(q, v, frame_id)
        pin.forwardKinematics(self.model, self.data, q, v)
        pose = pin.updateFramePlacement(self.model, self.data, frame_id)
        twist = pin.getFrameVelocity(self.model, self.data, frame_id, _LOCAL)
        return pose.rotation.copy(), pose.translation.copy(), twist.vector.copy()

    def link_placements(self, q: np.ndarray, links: list[str] | None = None) -> list[pin.SE3]:
        """World poses of several links (default: every link with hydrodynamics)."""
        names = [link.link for link in self.hydro.links] if links is None else links
        ids = [self.frame_id(n) for n in names]
        q = self._q(q)
        pin.framesForwardKinematics(self.model, self.data, q)
        return [self.data.oMf[i].copy() for i in ids]
