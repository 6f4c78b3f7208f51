"""The joint servo: joint PD with hydrostatic compensation, part of the plant every integrator steps.

Both backends evaluate it at every integrator stage: Pinocchio through
:meth:`JointServo.torque`, the compiled backend inside the kernel from :meth:`JointServo.packed`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from aiauv_control.laws.paper_laws import joint_pd_implicit_terms, joint_pd_torque

if TYPE_CHECKING:
    from aiauv_pin.model.vehicle import Vehicle


@dataclass(frozen=True)
class JointServo:
    """Joint PD with hydrostatic compensation, run at every integrator stage (paper, eq. (24)).

    ``tau_q = -k_p (q - q*) - k_d q_dot + g_q(q)``, with ``g_q`` the joints' part of the hydrostatic
    generalised force on the left-hand side (:meth:`Vehicle.restoring_forces`). Both backends evaluate
    it: Pinocchio through :meth:`torque`, the compiled backend inside the kernel from :meth:`packed`.

    Attributes:
        stiffness: ``k_p`` per joint (n,) [N m/rad] (or [N/m] for a prismatic joint).
        damping: ``k_d`` per joint (n,) [N m s/rad].
        references: ``q*`` per joint (n,) [rad]; a buffer the outer controller overwrites in place
            (``servo.references[:] = ...``) each time it runs.
        compensate_restoring: Add ``g_q(q)``.
    """

    stiffness: np.ndarray
    damping: np.ndarray
    references: np.ndarray
    compensate_restoring: bool = True

    def __post_init__(self) -> None:
        stiffness = np.array(self.stiffness, dtype=float).reshape(-1)
        damping = np.array(self.damping, dtype=float).reshape(-1)
        references = np.array(self.references, dtype=float).reshape(-1)
        if not (stiffness.shape == damping.shape == references.shape):
            raise ValueError(
                "joint servo: stiffness, damping and references must have one entry per joint"
            )
        if not (np.all(np.isfinite(stiffness)) and np.all(np.isfinite(damping))):
            raise ValueError("joint servo: gains must be finite")
        object.__setattr__(self, "stiffness", stiffness)
        object.__setattr__(self, "damping", damping)
        object.__setattr__(self, "references", references)

    @classmethod
    def uniform(cls, n_joints: int, k_p: float, k_d: float, compensate_restoring: bool = True):
        """The same gains on every joint, references at zero."""
        return cls(
            np.full(n_joints, float(k_p)),
            np.full(n_joints, float(k_d)),
            np.zeros(n_joints),
            compensate_restoring,
        )

    def torque(self, vehicle: Vehicle, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Generalised force (nv,) of the servo at ``(q, v)`` (zero on the base)."""
        tau = np.zeros(vehicle.nv)
        n = self.references.size
        g = vehicle.restoring_forces(q)[6:] if self.compensate_restoring else np.zeros(n)
        for k in range(n):  # eq. (24): aiauv_control.laws.paper_laws.joint_pd_torque
            tau[6 + k] = joint_pd_torque(
                q[7 + k], v[6 + k], self.references[k], g[k], self.stiffness[k], self.damping[k]
            )
        return tau

    def implicit_acceleration(
        self, vehicle: Vehicle, q: np.ndarray, v: np.ndarray, acceleration: np.ndarray, h: float
    ) -> np.ndarray:
        """The acceleration of a semi-implicit Euler step of ``h`` [s] with this servo implicit.

        From the explicit ``acceleration`` (servo included): ``(M + A) a' = M a - h k_p q_dot``, so
        ``a' = a - (M + A)^-1 (A a + h k_p q_dot)``, with the armature ``A`` and torque of
        :func:`aiauv_control.laws.paper_laws.joint_pd_implicit_terms` on the joint rows and ``M``
        the mass matrix
        (added mass included). The compiled kernels put ``A`` into the articulated-body pass.
        """
        n = self.references.size
        armature = np.zeros(vehicle.nv)
        force = np.zeros(vehicle.nv)
        for k in range(n):
            armature[6 + k], correction = joint_pd_implicit_terms(
                h, v[6 + k], self.stiffness[k], self.damping[k]
            )
            force[6 + k] = armature[6 + k] * acceleration[6 + k] - correction
        mass = vehicle.mass_matrix(q) + np.diag(armature)
        return acceleration - np.linalg.solve(mass, force)

    def packed(self):
        """The :class:`aiauv_pin.kernels.records.Servo` record the kernels read.

        It shares the ``references`` buffer, so updates made in place reach the kernels.
        """
        from aiauv_pin.kernels.records import Servo

        return Servo(
            self.stiffness,
            self.damping,
            self.references,
            self.references.size > 0,
            bool(self.compensate_restoring),
        )
