"""Hydrodynamics of a link from its equivalent ellipsoid (plain numpy; no Pinocchio).

Used by ``aiauv annotate`` (:mod:`aiauv_hydro.urdf.annotate`) and the UVMS builder
(:mod:`aiauv_pin.builders.uvms`).
The *equivalent ellipsoid* of a link has semi-axes ``a, b, c`` along principal axes placed in the
link frame, centred at the shape's centre (which is the centre of buoyancy):

* from a URDF ``<sphere>``: the sphere itself; from a ``<box>`` or a ``<cylinder>`` (along its local
  z): the ellipsoid with the same volume and the same axis proportions;
* from a mesh: the ellipsoid with the mesh's centroid, principal axes and axis proportions of its
  second moments, scaled to the mesh's volume (:func:`aiauv_hydro.urdf.annotate.mesh_ellipsoid`);
* from the link's ``<inertial>`` alone: the *inertia-equivalent ellipsoid*, the homogeneous solid
  ellipsoid with the link's mass and principal moments, ``I_1 = m (b^2 + c^2) / 5`` and cyclic, so
  ``a^2 = 5 (I_2 + I_3 - I_1) / (2 m)`` (standard solid-ellipsoid moments). Its volume is the link's
  volume at a uniform density, an approximation: a real link's displaced volume depends on its
  hollow parts.

Added mass of an ellipsoid in an ideal fluid (Lamb 1932, *Hydrodynamics*, Sec. 114-115): with
``alpha_0 = a b c int_0^inf dl / ((a^2 + l) D(l))``, ``D = sqrt((a^2+l)(b^2+l)(c^2+l))`` and
``beta_0``, ``gamma_0`` alike,

    m_11 = alpha_0 / (2 - alpha_0) rho V                                     (Lamb 1932, Sec. 115)
    m_44 = rho V / 5 (b^2 - c^2)^2 (gamma_0 - beta_0)
           / (2 (b^2 - c^2) + (b^2 + c^2)(beta_0 - gamma_0))                 (Lamb 1932, Sec. 115)

and cyclic permutations; the integrals are Carlson's ``R_D`` (``alpha_0 = 2/3 a b c R_D(b^2, c^2,
a^2)``; Carlson 1995, Numer. Algorithms 10, eq. (2.5) with the DLMF 19.16.5 definition). A sphere
gives ``m_11 = rho V / 2`` and no rotational added mass. The diagonal matrix in the ellipsoid frame
is moved to the link origin with the motion transform ``X`` of the ellipsoid frame,
``M_A = X^T diag(m) X`` (Fossen 2021, eq. (6.71) in matrix form), which keeps it symmetric PSD.

Damping (coarse, order of magnitude): quadratic drag ``1/2 rho C_D A`` per translational axis with
``C_D = 1`` (bluff body; Hoerner 1965, *Fluid-Dynamic Drag*, Ch. 3) and ``A`` the ellipsoid's
projected area normal to that principal axis (``pi b c`` for the first); rotational quadratic drag
of the flat strip of half length ``l`` (largest semi-axis across the rotation axis) and width ``w``
(twice the other), ``rho C_D w l^4 / 4`` (the strip integral
``2 int_0^l 1/2 rho C_D w (omega x)^2 x dx``); linear damping is the quadratic coefficient times
``v_ref = 0.1 m/s``, moved to the link origin like the added mass. The quadratic matrices stay
diagonal in the link frame (rotated diagonals, no lever arm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import elliprd

from aiauv_hydro.numerics.spatial import motion_transform
from aiauv_hydro.spec import HydroError

#: Bluff-body drag coefficient of an ellipsoid link [-] (Hoerner 1965, Ch. 3).
DRAG_COEFFICIENT = 1.0
#: Speed turning quadratic drag coefficients into linear ones [m/s].
LINEAR_DAMPING_SPEED = 0.1
#: Relative difference of two semi-axes below which they count as equal.
_EQUAL_AXES = 1e-7


@dataclass(frozen=True)
class Ellipsoid:
    """A solid ellipsoid placed in a link frame.

    Attributes:
        semi_axes: ``(a, b, c)`` along the columns of ``rotation`` [m].
        rotation: Orientation of the ellipsoid's principal axes in the link frame (3x3).
        center: Centre in the link frame [m].
    """

    semi_axes: np.ndarray
    rotation: np.ndarray
    center: np.ndarray

    @property
    def volume(self) -> float:
        """``4/3 pi a b c`` [m^3]."""
        a, b, c = self.semi_axes
        return 4.0 / 3.0 * math.pi * a * b * c


def lamb_coefficients(semi_axes) -> np.ndarray:
    """Lamb's ``(alpha_0, beta_0, gamma_0)`` of an ellipsoid (they sum to 2).

    ``alpha_0 = 2/3 a b c R_D(b^2, c^2, a^2)`` (Lamb 1932, Sec. 114; Carlson's ``R_D``).
    """
    a, b, c = (float(s) for s in semi_axes)
    a2, b2, c2 = a * a, b * b, c * c
    abc = a * b * c
    return np.array(
        [
            2.0 / 3.0 * abc * elliprd(b2, c2, a2),
            2.0 / 3.0 * abc * elliprd(c2, a2, b2),
            2.0 / 3.0 * abc * elliprd(a2, b2, c2),
        ]
    )


def ellipsoid_added_mass(semi_axes, fluid_density: float) -> np.ndarray:
    """Diagonal added mass ``(m_11, m_22, m_33, m_44, m_55, m_66)`` in the ellipsoid's frame.

    Args:
        semi_axes: ``(a, b, c)`` [m].
        fluid_density: ``rho`` [kg/m^3].

    Returns:
        [kg, kg, kg, kg m^2, kg m^2, kg m^2] (Lamb 1932, Sec. 115).
    """
    axes = np.asarray(semi_axes, dtype=float)
    coefficients = lamb_coefficients(axes)
    displaced = fluid_density * 4.0 / 3.0 * math.pi * float(np.prod(axes))
    translational = coefficients / (2.0 - coefficients) * displaced  # Lamb 1932, Sec. 115
    rotational = np.zeros(3)
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        s2, t2 = axes[i] ** 2, axes[j] ** 2
        if abs(s2 - t2) <= _EQUAL_AXES * (s2 + t2):
            continue  # a body of revolution about this axis: no rotational added mass
        d = coefficients[i] - coefficients[j]
        # Lamb 1932, Sec. 115 (cyclic in (a, b, c))
        value = displaced / 5.0 * (s2 - t2) ** 2 * (-d) / (2.0 * (s2 - t2) + (s2 + t2) * d)
        rotational[k] = max(value, 0.0)
    return np.concatenate((translational, rotational))


def inertia_equivalent_ellipsoid(
    mass: float, inertia: np.ndarray, rotation: np.ndarray, center: np.ndarray
) -> Ellipsoid:
    """The homogeneous solid ellipsoid with a body's mass and principal moments.

    Args:
        mass: [kg] (> 0).
        inertia: Inertia about the centre of mass in the frame ``rotation`` (3x3) [kg m^2].
        rotation: Orientation of that frame in the link frame.
        center: Centre of mass in the link frame [m].

    Raises:
        HydroError: Non-positive mass, or moments that break the triangle inequality (no
            ellipsoid has them).
    """
    if not (math.isfinite(mass) and mass > 0.0):
        raise HydroError(f"equivalent ellipsoid needs a positive mass, got {mass!r}")
    inertia = np.asarray(inertia, dtype=float)
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    total = moments.sum()
    squared = 5.0 / (2.0 * mass) * (total - 2.0 * moments)  # a^2 = 5 (I_2 + I_3 - I_1) / (2 m)
    if np.any(squared <= 0.0):
        raise HydroError(
            f"inertia moments {moments} break the triangle inequality: no equivalent ellipsoid"
        )
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] *= -1.0
    return Ellipsoid(np.sqrt(squared), np.asarray(rotation) @ axes, np.asarray(center, dtype=float))


def scaled_to_volume(ellipsoid: Ellipsoid, volume: float) -> Ellipsoid:
    """The ellipsoid with the same centre, axes and proportions and the given volume [m^3]."""
    scale = (volume / ellipsoid.volume) ** (1.0 / 3.0)
    return Ellipsoid(scale * ellipsoid.semi_axes, ellipsoid.rotation, ellipsoid.center)


@dataclass(frozen=True)
class EllipsoidHydrodynamics:
    """Fossen-model parameters of one link, about the link origin in link axes.

    Attributes:
        volume: [m^3].
        center_of_buoyancy: [m].
        added_mass: 6x6, symmetric PSD.
        linear_damping: 6x6, symmetric PSD.
        quadratic_damping: Diagonal (6,).
    """

    volume: float
    center_of_buoyancy: np.ndarray
    added_mass: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray


def placed_hydrodynamics(
    ellipsoid: Ellipsoid, added_mass, linear_damping, quadratic_damping
) -> EllipsoidHydrodynamics:
    """Diagonal coefficients given in an ellipsoid's frame, moved to the link origin.

    Added mass and linear damping (linear laws) move exactly with the motion transform ``X`` of the
    ellipsoid frame, ``X^T diag(d) X`` (Fossen 2021, eq. (6.71)); the quadratic coefficients stay
    diagonal in the link frame (rotated diagonals ``sum_j R_ij^2 d_j``, no lever arm: the module
    docstring's approximation).

    Args:
        ellipsoid: Its centre and principal axes place the coefficients.
        added_mass: ``(m_11, ..., m_66)`` in the ellipsoid frame [kg, kg m^2].
        linear_damping: Diagonal linear damping in the ellipsoid frame [N s/m, N m s].
        quadratic_damping: Diagonal quadratic damping in the ellipsoid frame [N s^2/m^2, N m s^2].
    """
    transform = motion_transform(ellipsoid.rotation, ellipsoid.center)
    added = transform.T @ np.diag(np.asarray(added_mass, dtype=float)) @ transform
    linear = transform.T @ np.diag(np.asarray(linear_damping, dtype=float)) @ transform
    principal = np.asarray(quadratic_damping, dtype=float)
    weights = ellipsoid.rotation**2  # link axis i gets sum_j R_ij^2 d_j
    quadratic = np.concatenate((weights @ principal[:3], weights @ principal[3:]))
    return EllipsoidHydrodynamics(
        ellipsoid.volume,
        ellipsoid.center.copy(),
        0.5 * (added + added.T),
        0.5 * (linear + linear.T),
        quadratic,
    )


def ellipsoid_hydrodynamics(ellipsoid: Ellipsoid, fluid_density: float) -> EllipsoidHydrodynamics:
    """Added mass and damping of an ellipsoid, about the link origin (see the module docstring)."""
    a, b, c = ellipsoid.semi_axes
    rho = fluid_density
    # quadratic drag in the ellipsoid frame: projected areas and rotating strips
    areas = math.pi * np.array([b * c, a * c, a * b])
    semi = ellipsoid.semi_axes
    strips = np.zeros(3)
    for k in range(3):
        across = sorted((semi[(k + 1) % 3], semi[(k + 2) % 3]))
        strips[k] = rho * DRAG_COEFFICIENT * 2.0 * across[0] * across[1] ** 4 / 4.0
    principal = np.concatenate((0.5 * rho * DRAG_COEFFICIENT * areas, strips))
    return placed_hydrodynamics(
        ellipsoid,
        ellipsoid_added_mass(ellipsoid.semi_axes, rho),
        LINEAR_DAMPING_SPEED * principal,
        principal,
    )
