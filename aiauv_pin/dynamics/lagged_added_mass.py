"""Lagged added mass: the scheme of UUV Simulator and gz-sim, to compare with the exact one.

Gazebo's rigid-body solvers know nothing of added mass, so UUV Simulator's underwater-object plugin
and gz-sim's Hydrodynamics system apply it as an external wrench, computed at the start of each
step from the acceleration of the previous step(s)
(:func:`aiauv_hydro.laws.fluid_terms.add_lagged_added_mass_bias`
has the formula and the sources): UUV Simulator low-pass filters the differenced velocity with
``alpha = 0.3``, gz-sim uses it unfiltered (``alpha = 1``). :func:`aiauv_pin.simulate` runs this
scheme with ``added_mass="lagged"``: the rigid-body dynamics see the rigid mass only (a copy of
the vehicle with its added mass off; damping, current and hydrostatics unchanged and exact), and
the added-mass wrench of every body, held over the step as a Gazebo plugin's force is, enters as
a generalised force ``-sum_i J_i^T (M_A,i f_i + C_A,i(nu_r,i) nu_r,i)``.

Stability (:func:`growth_factors`): for a body at rest or in slow motion under forces that do not
depend on the state, the acceleration obeys a linear recursion whose per-step factors are
``lambda_k = 1 - alpha (1 + mu_k)``, with ``mu_k`` the generalised eigenvalues of the added and
rigid mass matrices (``M_A x = mu M_RB x``); the scheme is stable only if
``alpha (1 + mu_max) < 2``, independently of the step ``dt``.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from aiauv_hydro.currents import as_current
from aiauv_hydro.laws.fluid_terms import UUV_SIMULATOR_FILTER, add_lagged_added_mass_bias
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle

#: Accepted values of ``simulate(..., added_mass=...)`` and of a scenario file's ``added_mass``.
ADDED_MASS_SCHEMES = ("exact", "lagged")

_LOCAL = pin.ReferenceFrame.LOCAL


def check_filter(alpha) -> float:
    """The filter coefficient as a float in ``(0, 1]``, or a one-line :class:`ArgumentError`."""
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float)):
        raise ArgumentError(f"lagged_filter must be a number in (0, 1], got {alpha!r:.40}")
    alpha = float(alpha)
    if not (math.isfinite(alpha) and 0.0 < alpha <= 1.0):
        raise ArgumentError(f"lagged_filter must be in (0, 1], got {alpha!r}")
    return alpha


def check_scheme(scheme) -> str:
    """``"exact"`` or ``"lagged"``, or a one-line :class:`ArgumentError`."""
    if not isinstance(scheme, str) or scheme not in ADDED_MASS_SCHEMES:
        raise ArgumentError(
            f"added_mass must be one of {', '.join(ADDED_MASS_SCHEMES)}, got {scheme!r:.40}"
        )
    return scheme


def growth_factors(alpha: float, mass_ratio) -> np.ndarray:
    """Per-step factors ``lambda = 1 - alpha (1 + mu)`` of the lagged acceleration.

    Derivation, for rigid mass ``m``, added mass ``mu m`` and a force ``F`` that does not depend on
    the state: the step takes ``m d_n+1 = F - mu m f_n`` with ``d_n+1 = (v_n+1 - v_n) / dt`` the
    mean acceleration of the step and ``f_n = (1 - alpha) f_n-1 + alpha d_n``. Eliminating ``f``,
    ``d_n+1 = alpha F / m + (1 - alpha (1 + mu)) d_n``: a first-order linear recursion whose fixed
    point ``F / (m + mu m)`` is the exact acceleration and whose factor does not involve ``dt``.
    For several degrees of freedom, ``mu`` runs over the generalised eigenvalues of ``(M_A, M_RB)``
    (:func:`mass_ratios`). The deviation decays if ``|lambda| < 1``, i.e. ``mu < 2 / alpha - 1``:
    below 1 for gz-sim (``alpha = 1``), below 17/3 for UUV Simulator (``alpha = 0.3``).

    Args:
        alpha: Filter coefficient in ``(0, 1]``.
        mass_ratio: ``mu`` [-], a number or an array.

    Returns:
        ``lambda`` for each ``mu`` [-].
    """
    return 1.0 - alpha * (1.0 + np.asarray(mass_ratio, dtype=float))


def mass_ratios(vehicle: Vehicle, q: np.ndarray) -> np.ndarray:
    """Generalised eigenvalues ``mu`` of ``M_A(q) x = mu M_RB(q) x`` (ascending) [-].

    ``M_A(q) = sum_i J_i^T M_A,i J_i`` and ``M_RB(q)`` Pinocchio's CRBA; their ratios along each
    mode decide the stability of the lagged scheme (:func:`growth_factors`).
    """
    total = vehicle.mass_matrix(q)
    rigid = pin.crba(vehicle.model, vehicle.data, np.asarray(q, dtype=float))
    rigid = np.triu(rigid) + np.triu(rigid, 1).T
    import scipy.linalg  # here: 0.3 s of imports that a run without the lagged scheme never needs

    return scipy.linalg.eigh(total - rigid, rigid, eigvals_only=True)


class LaggedAddedMass:
    """Per-step state of the lagged scheme for one run (see the module docstring).

    Attributes:
        rigid: The vehicle without added mass (same model, damping, hydrostatics and backend)
            whose dynamics the integrator steps.
        alpha: Filter coefficient [-].
        added_mass: ``M_A`` of each body, body axes (nb, 6, 6), taken from the full vehicle.
    """

    def __init__(self, vehicle: Vehicle, alpha: float = UUV_SIMULATOR_FILTER) -> None:
        self.alpha = check_filter(alpha)
        self.added_mass = vehicle.fluid_model(include_hydrostatics=False).added_mass.copy()
        self.rigid = Vehicle(
            pin.Model(vehicle.model),
            vehicle.hydro,
            name=vehicle.name,
            added_mass=False,
            damping=vehicle.damping,
            restoring=vehicle.restoring,
            backend=vehicle.backend,
        )
        self.rigid.urdf_path = vehicle.urdf_path
        nb = self.added_mass.shape[0]
        self._previous: np.ndarray | None = None
        self._filtered = np.zeros((nb, 6))
        self._bias = np.zeros((nb, 6))

    def _relative_twists(self, q, v, current, t: float) -> np.ndarray:
        rigid = self.rigid
        pin.forwardKinematics(rigid.model, rigid.data, q, v)
        rotation, position, twist = rigid._body_states()
        water = rigid._currents_at_probes(current, t, rotation, position)
        relative = twist.copy()
        relative[:, :3] -= np.einsum("nji,nj->ni", rotation, water)  # R^T V_c
        return relative

    def generalized_force(self, q, v, dt: float, current=None, t: float = 0.0) -> np.ndarray:
        """The added-mass generalised force for the step starting at ``(q, v)`` (nv,) [N, N m].

        Call it once per step, in order: it differences the relative twists against the previous
        call's. On the first call the previous twists are the current ones (no start-up spike, as
        gz-sim does since 2026) and the filtered acceleration is zero (as both plugins start).
        """
        current = as_current(current)
        relative = self._relative_twists(q, v, current, t)
        if self._previous is None:
            self._previous = relative.copy()
        self._bias[:] = 0.0
        add_lagged_added_mass_bias(
            self.added_mass, relative, self._previous, self._filtered, dt, self.alpha, self._bias
        )
        rigid = self.rigid
        pin.computeJointJacobians(rigid.model, rigid.data, q)
        jac = rigid._body_jacobians()
        return -np.einsum("nji,nj->i", jac, self._bias)


def slender_link_urdf(
    mass_ratio: float = 1.0,
    length: float = 1.0,
    radius: float = 0.05,
    fluid_density: float = 1000.0,
) -> str:
    """URDF text of one slender cylinder whose sway added mass is ``mass_ratio`` times its mass.

    Strip theory with ``C_a = 1`` gives the cylinder the sway and heave added mass
    ``rho pi r^2 L``, its displaced mass (``model="slender_cylinder"``); the rigid mass is that over
    ``mass_ratio`` (1: a solid cylinder of the water's density), with a solid cylinder's inertia
    about its centre and ``<volume>`` set to ``m / rho`` so that it is neutrally buoyant whatever
    the ratio. The link frame is at its rear end, x along its axis.

    Args:
        mass_ratio: Sway added mass over rigid mass ``mu`` [-] (> 0).
        length: ``L`` [m].
        radius: ``r`` [m].
        fluid_density: ``rho`` [kg/m^3].
    """
    for name, value in (
        ("mass_ratio", mass_ratio),
        ("length", length),
        ("radius", radius),
        ("fluid_density", fluid_density),
    ):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ArgumentError(f"{name} must be a positive number, got {value!r:.40}")
    mass = fluid_density * math.pi * radius**2 * length / mass_ratio
    axial = 0.5 * mass * radius**2
    transverse = mass * (3.0 * radius**2 + length**2) / 12.0
    return f"""<?xml version="1.0"?>
<robot name="slender_link">
  <link name="rod">
    <inertial>
      <origin xyz="{length / 2!r} 0 0" rpy="0 0 0"/>
      <mass value="{mass!r}"/>
      <inertia ixx="{axial!r}" ixy="0" ixz="0" iyy="{transverse!r}" iyz="0" izz="{transverse!r}"/>
    </inertial>
  </link>
  <hydrodynamics fluid_density="{float(fluid_density)!r}">
    <link name="rod" model="slender_cylinder" length="{float(length)!r}" radius="{float(radius)!r}">
      <volume>{mass / fluid_density!r}</volume>
      <center_of_buoyancy>{length / 2!r} 0 0</center_of_buoyancy>
    </link>
  </hydrodynamics>
</robot>
"""
