"""An independent single-body 6-DOF underwater vehicle model written from Fossen (2021), for tests.

Matrices are built explicitly (no spatial cross products, no Pinocchio), with z up (gravity along -z):

    M_RB nu_dot + C_RB(nu) nu + M_A nu_r_dot + C_A(nu_r) nu_r + D(nu_r) nu_r + g(R) = tau

M_RB: eq. (3.44); C_RB: the velocity-independent-of-linear-velocity form, eq. (3.60); C_A: eq. (6.46);
D: linear plus quadratic; g: eq. (4.6) with z up; nu_r = nu - (R^T V_c, 0), and
nu_r_dot = nu_dot + (S(omega) R^T V_c, 0) for a constant current.
"""

from __future__ import annotations

import numpy as np


def skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rigid_body_mass(mass: float, r_g: np.ndarray, inertia_cg: np.ndarray) -> np.ndarray:
    """Fossen 2021, eq. (3.44): M_RB about the body origin."""
    inertia_o = inertia_cg - mass * skew(r_g) @ skew(r_g)  # parallel-axis theorem, eq. (3.36)
    top = np.hstack((mass * np.eye(3), -mass * skew(r_g)))
    bottom = np.hstack((mass * skew(r_g), inertia_o))
    return np.vstack((top, bottom))


def rigid_body_coriolis(mass: float, r_g: np.ndarray, inertia_cg: np.ndarray, nu: np.ndarray):
    """Fossen 2021, eq. (3.60)."""
    omega = nu[3:]
    inertia_o = inertia_cg - mass * skew(r_g) @ skew(r_g)
    top = np.hstack((mass * skew(omega), -mass * skew(omega) @ skew(r_g)))
    bottom = np.hstack((mass * skew(r_g) @ skew(omega), -skew(inertia_o @ omega)))
    return np.vstack((top, bottom))


def added_mass_coriolis(added_mass: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Fossen 2021, eq. (6.46)."""
    a11, a12 = added_mass[:3, :3], added_mass[:3, 3:]
    a21, a22 = added_mass[3:, :3], added_mass[3:, 3:]
    p = a11 @ nu[:3] + a12 @ nu[3:]
    h = a21 @ nu[:3] + a22 @ nu[3:]
    top = np.hstack((np.zeros((3, 3)), -skew(p)))
    bottom = np.hstack((-skew(p), -skew(h)))
    return np.vstack((top, bottom))


def restoring(rotation, weight, buoyancy, r_g, r_b) -> np.ndarray:
    """Fossen 2021, eq. (4.6), for a world frame with z up."""
    f_g = rotation.T @ np.array([0.0, 0.0, -weight])
    f_b = rotation.T @ np.array([0.0, 0.0, buoyancy])
    return -np.concatenate((f_g + f_b, np.cross(r_g, f_g) + np.cross(r_b, f_b)))


def acceleration(
    rotation: np.ndarray,
    nu: np.ndarray,
    tau: np.ndarray,
    *,
    mass: float,
    r_g: np.ndarray,
    inertia_cg: np.ndarray,
    added_mass: np.ndarray,
    linear_damping: np.ndarray,
    quadratic_damping: np.ndarray,
    volume: float,
    r_b: np.ndarray,
    rho: float,
    g: float,
    current: np.ndarray | None = None,
) -> np.ndarray:
    """nu_dot of one rigid body in a constant irrotational current."""
    v_c = np.zeros(3) if current is None else rotation.T @ current
    nu_r = nu - np.concatenate((v_c, np.zeros(3)))
    nu_c_dot = np.concatenate((-skew(nu[3:]) @ v_c, np.zeros(3)))  # d/dt (R^T V_c)
    m_rb = rigid_body_mass(mass, r_g, inertia_cg)
    rhs = (
        tau
        - rigid_body_coriolis(mass, r_g, inertia_cg, nu) @ nu
        - added_mass_coriolis(added_mass, nu_r) @ nu_r
        - linear_damping @ nu_r
        - quadratic_damping @ (np.abs(nu_r) * nu_r)
        - restoring(rotation, mass * g, rho * g * volume, r_g, r_b)
        + added_mass @ nu_c_dot  # M_A nu_r_dot = M_A nu_dot - M_A nu_c_dot
    )
    return np.linalg.solve(m_rb + added_mass, rhs)
