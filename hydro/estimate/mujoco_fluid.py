"""MuJoCo's fluid models as our per-link parameters (plain numpy; no Pinocchio, no MuJoCo).

The inverse of what ``aiauv export -o model.xml`` writes (:mod:`aiauv_pin.interop.mjcf`), used by
the MJCF reader (:mod:`aiauv_pin.description.mjcf_reading`). Sources: MuJoCo's documentation,
"Computation / Fluid forces" (https://mujoco.readthedocs.io/en/stable/computation/fluid.html), and
its implementation, google-deepmind/mujoco ``src/engine/engine_passive.c``
(``mj_ellipsoidFluidModel``, ``mj_viscousForces``, ``mj_inertiaBoxFluidModel``) and
``src/engine/engine_util_misc.c`` (``mju_geomSemiAxes``), read at commit a7255075b003.

**Ellipsoid model** (``fluidshape="ellipsoid"``), per geom, in the frame of the geom's equivalent
ellipsoid (semi-axes ``r`` from :func:`geom_semi_axes`), velocity ``v, omega`` of the geom centre
relative to the fluid, ``fluidcoef = (C_blunt, C_slender, C_angular, C_K, C_M)``:

* added mass: ``m_A,i = rho V kappa_i / (2 - kappa_i)`` and ``I_A,i`` of Lamb (the documentation's
  "Added mass"), which is :func:`aiauv_hydro.estimate.ellipsoid.ellipsoid_added_mass`;
* viscous resistance (Stokes): ``f_V = -6 pi r_D beta v``, ``g_V = -8 pi r_D^3 beta omega``,
  ``r_D = (r_x + r_y + r_z) / 3``: a linear damping ``diag(6 pi r_D beta (x3), 8 pi r_D^3 beta (x3))``;
* quadratic drag ``f_D = -rho [C_blunt A_proj(v) + C_slender (A_max - A_proj(v))] |v| v`` with
  ``A_max = pi r_max r_mid``; along principal axis ``i`` the projected area is ``pi r_j r_k``, so
  the principal coefficient is ``rho [C_blunt pi r_j r_k + C_slender (A_max - pi r_j r_k)]``;
* angular drag ``g_D = -rho omega |(c_1 omega_1, c_2 omega_2, c_3 omega_3)|`` with
  ``c_i = C_angular I_D,i + C_slender (I_max - I_D,i)``, ``I_D,i = 8 pi / 15 r_i max(r_j, r_k)^4``
  and ``I_max = max_i I_D,i``; about principal axis ``i`` this is ``-rho c_i |omega_i| omega_i``.

What our per-link law keeps of it: the added mass, in full (MuJoCo applies only its
velocity-dependent forces, never ``-M_A dot(nu)``; ``engine_passive.c``, ``mj_addedMassForces``
called with no accelerations), the Stokes resistance exactly, and the quadratic drag along the
principal axes (our law is separable, ``-D_Q |nu| nu``, where MuJoCo couples the axes through
``|v|`` and ``A_proj(v)``: equal for motion along one principal axis, different obliquely). The
Kutta and Magnus lift (``C_K``, ``C_M``) have no form in our law and are dropped. Placed on the
link with :func:`aiauv_hydro.estimate.ellipsoid.placed_hydrodynamics`.

**Inertia-box model** (a body with no ``fluidshape="ellipsoid"`` geom), in the body's principal
inertia frame at its centre of mass, with the equivalent box of full sides
``s_i = sqrt(6 (I_j + I_k - I_i) / m)`` (``mj_inertiaBoxFluidModel``): quadratic drag
``1/2 rho s_j s_k`` along axis ``i``, ``rho s_i (s_j^4 + s_k^4) / 64`` about it; viscous
``3 pi d beta`` and ``pi d^3 beta`` with ``d = (s_1 + s_2 + s_3) / 3``; no added mass.

MuJoCo's fluid models apply no buoyancy; the export writes it as gravity compensation, whose
inverse is :func:`buoyant_volume`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aiauv_hydro.estimate.ellipsoid import (
    Ellipsoid,
    EllipsoidHydrodynamics,
    ellipsoid_added_mass,
    placed_hydrodynamics,
)

#: MuJoCo's default ``fluidcoef`` (blunt, slender, angular drag, Kutta, Magnus lift) [-]
#: (documentation, "Ellipsoid model", table of the 5 coefficients).
DEFAULT_FLUID_COEFFICIENTS = (0.5, 0.25, 1.5, 1.0, 1.0)


@dataclass(frozen=True)
class FluidEllipsoid:
    """One geom of MuJoCo's ellipsoid fluid model, placed in a link frame.

    Attributes:
        ellipsoid: Semi-axes along the geom's axes, the geom's orientation and centre in the link.
        coefficients: ``fluidcoef`` ``(C_blunt, C_slender, C_angular, C_K, C_M)`` [-].
    """

    ellipsoid: Ellipsoid
    coefficients: tuple[float, float, float, float, float] = DEFAULT_FLUID_COEFFICIENTS


def geom_semi_axes(kind: str, size) -> np.ndarray:
    """Semi-axes [m] of the equivalent ellipsoid of a MuJoCo geom (``mju_geomSemiAxes``).

    Args:
        kind: MuJoCo's geom type in lower case (``"sphere"``, ``"capsule"``, ``"cylinder"``,
            ``"ellipsoid"``, ``"box"``, ``"mesh"``, ...).
        size: The geom's ``size`` (MuJoCo's half-sizes: radius, half-length, half-edges) [m].
    """
    size = [float(s) for s in size]
    if kind == "sphere":
        return np.array([size[0]] * 3)
    if kind == "capsule":
        return np.array([size[0], size[0], size[1] + size[0]])
    if kind == "cylinder":
        return np.array([size[0], size[0], size[1]])
    return np.array(size[:3])  # ellipsoid, box and the other types: the size itself


def ellipsoid_fluid_principal(
    semi_axes, coefficients, density: float, viscosity: float
) -> tuple[np.ndarray, np.ndarray]:
    """Linear and quadratic damping along the principal axes of MuJoCo's fluid ellipsoid.

    Args:
        semi_axes: ``(r_x, r_y, r_z)`` [m].
        coefficients: ``fluidcoef`` (only the three drag coefficients enter) [-].
        density: ``<option density>`` [kg/m^3].
        viscosity: ``<option viscosity>`` [Pa s].

    Returns:
        ``(linear, quadratic)``, each ``(force x3, torque x3)`` (see the module docstring).
    """
    r = np.asarray(semi_axes, dtype=float)
    blunt, slender, angular = (float(c) for c in coefficients[:3])
    ordered = np.sort(r)
    area_max = math.pi * ordered[2] * ordered[1]  # A_max = pi r_max r_mid
    areas = math.pi * np.array([r[1] * r[2], r[2] * r[0], r[0] * r[1]])
    moments = np.array(
        [8.0 / 15.0 * math.pi * r[i] * max(r[(i + 1) % 3], r[(i + 2) % 3]) ** 4 for i in range(3)]
    )
    quadratic = np.concatenate(
        (
            density * (blunt * areas + slender * (area_max - areas)),
            density * (angular * moments + slender * (moments.max() - moments)),
        )
    )
    radius = float(r.sum()) / 3.0  # r_D, the equivalent sphere of Stokes' law
    linear = np.concatenate(
        (
            np.full(3, 6.0 * math.pi * radius * viscosity),
            np.full(3, 8.0 * math.pi * radius**3 * viscosity),
        )
    )
    return linear, quadratic


def fluid_ellipsoid_hydrodynamics(
    fluid: FluidEllipsoid, density: float, viscosity: float
) -> EllipsoidHydrodynamics:
    """Our parameters of one geom of MuJoCo's ellipsoid model, about the link origin.

    The volume and centre returned are the ellipsoid's; MuJoCo applies no buoyancy, so the caller
    decides the link's volume (:func:`buoyant_volume`).
    """
    linear, quadratic = ellipsoid_fluid_principal(
        fluid.ellipsoid.semi_axes, fluid.coefficients, density, viscosity
    )
    added = ellipsoid_added_mass(fluid.ellipsoid.semi_axes, density)
    return placed_hydrodynamics(fluid.ellipsoid, added, linear, quadratic)


def inertia_box_hydrodynamics(
    mass: float,
    principal_moments,
    rotation: np.ndarray,
    center: np.ndarray,
    density: float,
    viscosity: float,
) -> EllipsoidHydrodynamics:
    """Our parameters of MuJoCo's inertia-box fluid model of one body, about the link origin.

    Args:
        mass: Body mass [kg].
        principal_moments: Principal moments of inertia about the centre of mass [kg m^2].
        rotation: Principal axes in the link frame (columns).
        center: Centre of mass in the link frame [m].
        density: ``<option density>`` [kg/m^3].
        viscosity: ``<option viscosity>`` [Pa s].
    """
    moments = np.asarray(principal_moments, dtype=float)
    # mj_inertiaBoxFluidModel: box[i] = sqrt(max(mjMINVAL, I_j + I_k - I_i) / m * 6), full sides
    sides = np.sqrt(np.maximum(1e-15, moments.sum() - 2.0 * moments) / mass * 6.0)
    s0, s1, s2 = sides
    quadratic = np.array(
        [
            0.5 * density * s1 * s2,
            0.5 * density * s0 * s2,
            0.5 * density * s0 * s1,
            density * s0 * (s1**4 + s2**4) / 64.0,
            density * s1 * (s0**4 + s2**4) / 64.0,
            density * s2 * (s0**4 + s1**4) / 64.0,
        ]
    )
    diameter = float(sides.sum()) / 3.0
    linear = np.concatenate(
        (
            np.full(3, 3.0 * math.pi * diameter * viscosity),
            np.full(3, math.pi * diameter**3 * viscosity),
        )
    )
    box = Ellipsoid(sides / 2.0, np.asarray(rotation, dtype=float), np.asarray(center, dtype=float))
    return placed_hydrodynamics(box, np.zeros(6), linear, quadratic)


def gravity_compensation(volume: float, mass: float, density: float) -> float:
    """MuJoCo's ``gravcomp`` [-] of a body whose buoyancy is ``rho V g``.

    ``gravcomp`` makes MuJoCo apply ``gravcomp m g`` upwards at the centre of mass
    (``engine_passive.c``, ``mj_gravcomp``), so buoyancy ``rho V g`` is ``gravcomp = rho V / m``,
    at the centre of mass (the moment of an offset centre of buoyancy is lost).
    """
    return float(density) * float(volume) / float(mass)


def buoyant_volume(gravcomp: float, mass: float, density: float) -> float:
    """Displaced volume [m^3] of MuJoCo's gravity compensation of a body, ``V = gravcomp m / rho``
    (the inverse of :func:`gravity_compensation`); its centre of buoyancy is the centre of mass."""
    return float(gravcomp) * float(mass) / float(density)
