"""UVMS (hull + example-robot-data arm) with hydrodynamics from equivalent ellipsoids."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from aiauv_pin import load_vehicle, simulate
from aiauv_pin.builders.uvms import (
    ellipsoid_added_mass,
    ellipsoid_hydrodynamics,
    inertia_equivalent_ellipsoid,
    lamb_coefficients,
    primitive_ellipsoid,
    uvms_urdf,
)

RHO = 1025.0


def _prolate_alpha0(eccentricity: float) -> float:
    """Lamb's alpha_0 of a prolate spheroid along its axis, in closed form (Lamb 1932, Sec. 115)."""
    e = eccentricity
    return 2.0 * (1.0 - e * e) / e**3 * (0.5 * math.log((1.0 + e) / (1.0 - e)) - e)


def test_sphere_added_mass_is_half_the_displaced_mass_and_no_rotation():
    radius = 0.3
    displaced = RHO * 4.0 / 3.0 * math.pi * radius**3
    added = ellipsoid_added_mass([radius] * 3, RHO)
    np.testing.assert_allclose(added[:3], 0.5 * displaced, rtol=1e-12)
    np.testing.assert_allclose(added[3:], 0.0, atol=1e-12)


@pytest.mark.parametrize("ratio", [2.0, 5.0, 10.0])
def test_prolate_spheroid_matches_closed_form(ratio):
    b = 0.1
    a = ratio * b
    e = math.sqrt(1.0 - 1.0 / ratio**2)
    alpha0 = _prolate_alpha0(e)
    beta0 = 0.5 * (2.0 - alpha0)
    np.testing.assert_allclose(lamb_coefficients([a, b, b]), [alpha0, beta0, beta0], rtol=1e-10)
    displaced = RHO * 4.0 / 3.0 * math.pi * a * b * b
    added = ellipsoid_added_mass([a, b, b], RHO)
    np.testing.assert_allclose(added[0], alpha0 / (2.0 - alpha0) * displaced, rtol=1e-10)
    np.testing.assert_allclose(added[1], beta0 / (2.0 - beta0) * displaced, rtol=1e-10)
    # rotation about a transverse axis, Lamb 1932 Sec. 115 for a spheroid:
    # k' = e^4 (beta0 - alpha0) / ((2 - e^2)(2 e^2 - (2 - e^2)(beta0 - alpha0)))
    k_rot = e**4 * (beta0 - alpha0) / ((2 - e * e) * (2 * e * e - (2 - e * e) * (beta0 - alpha0)))
    np.testing.assert_allclose(added[5], k_rot * displaced * (a * a + b * b) / 5.0, rtol=1e-9)
    assert added[3] == 0.0


def test_slender_limit_approaches_strip_theory():
    # transverse added mass of a long spheroid -> rho pi b^2 per unit length, integrated over
    # its length: rho pi int (b^2 (1 - x^2/a^2)) dx = rho V (k2 -> 1)
    a, b = 100.0, 1.0
    added = ellipsoid_added_mass([a, b, b], RHO)
    displaced = RHO * 4.0 / 3.0 * math.pi * a * b * b
    assert abs(added[1] / displaced - 1.0) < 1e-3
    assert added[0] / displaced < 1e-3


def test_inertia_equivalent_ellipsoid_reproduces_the_moments():
    rng = np.random.default_rng(3)
    rotation = pin.Quaternion(rng.normal(size=4) / 2).normalized().matrix()
    semi = np.array([0.3, 0.12, 0.07])
    mass = 4.0
    moments = (
        mass
        / 5.0
        * np.array(
            [semi[1] ** 2 + semi[2] ** 2, semi[0] ** 2 + semi[2] ** 2, semi[0] ** 2 + semi[1] ** 2]
        )
    )
    inertia = rotation @ np.diag(moments) @ rotation.T
    ellipsoid = inertia_equivalent_ellipsoid(mass, inertia, np.eye(3), np.array([0.1, 0, 0]))
    np.testing.assert_allclose(np.sort(ellipsoid.semi_axes), np.sort(semi), rtol=1e-12)
    rebuilt = (
        ellipsoid.rotation
        @ np.diag(mass / 5.0 * (np.sum(ellipsoid.semi_axes**2) - ellipsoid.semi_axes**2))
        @ ellipsoid.rotation.T
    )
    np.testing.assert_allclose(rebuilt, inertia, atol=1e-14)


def test_box_and_cylinder_keep_their_volume():
    import xml.etree.ElementTree as ET

    box = primitive_ellipsoid(ET.fromstring('<box size="0.4 0.2 0.1"/>'), np.zeros(3), np.zeros(3))
    assert math.isclose(box.volume, 0.4 * 0.2 * 0.1, rel_tol=1e-12)
    cyl = primitive_ellipsoid(
        ET.fromstring('<cylinder radius="0.05" length="0.3"/>'), np.zeros(3), np.zeros(3)
    )
    assert math.isclose(cyl.volume, math.pi * 0.05**2 * 0.3, rel_tol=1e-12)


def test_link_added_mass_about_an_offset_origin_is_the_moved_matrix():
    # a sphere at c: M_A about the origin has the parallel-axis term m_a |c|^2 for rotation
    import xml.etree.ElementTree as ET

    centre = np.array([0.0, 0.0, 0.5])
    sphere = primitive_ellipsoid(ET.fromstring('<sphere radius="0.2"/>'), centre, np.zeros(3))
    params = ellipsoid_hydrodynamics(sphere, RHO)
    m_a = 0.5 * RHO * sphere.volume
    np.testing.assert_allclose(params.added_mass[3, 3], m_a * 0.25, rtol=1e-12)
    np.testing.assert_allclose(params.added_mass[2, 2], m_a, rtol=1e-12)
    assert np.min(np.linalg.eigvalsh(params.added_mass)) > -1e-12
    assert np.min(np.linalg.eigvalsh(params.linear_damping)) > -1e-12


@pytest.fixture(scope="module")
def uvms(tmp_path_factory):
    path = tmp_path_factory.mktemp("uvms") / "uvms_panda.urdf"
    path.write_text(uvms_urdf("panda_description/urdf/panda.urdf"), encoding="utf-8")
    return path


def test_uvms_is_neutrally_buoyant_with_hydrodynamics_on_every_massive_link(uvms):
    vehicle = load_vehicle(uvms)
    named = {link.link for link in vehicle.hydro.links}
    massive = {
        vehicle.model.frames[i].name
        for i in range(len(vehicle.model.frames))
        if vehicle.model.frames[i].type == pin.FrameType.BODY
        and vehicle.model.frames[i].inertia.mass > 0.0
    }
    assert massive <= named
    q = vehicle.neutral_configuration()
    # weight minus buoyancy has no net force: the force part of g(q) on the free-flyer vanishes
    restoring = vehicle.restoring_forces(q)
    weight = vehicle.hydro.gravity * sum(i.mass for i in vehicle.model.inertias)
    assert np.linalg.norm(restoring[:3]) < 1e-9 * weight


def test_uvms_mass_matrix_is_symmetric_positive_definite(uvms):
    vehicle = load_vehicle(uvms)
    rng = np.random.default_rng(0)
    model = vehicle.model
    for _ in range(5):
        q = vehicle.neutral_configuration()
        q[:3] = rng.normal(size=3)
        q[3:7] = pin.Quaternion(rng.normal(size=4)).normalized().coeffs()
        q[7:] = rng.uniform(model.lowerPositionLimit[7:], model.upperPositionLimit[7:])
        mass = vehicle.mass_matrix(q)
        np.testing.assert_allclose(mass, mass.T, atol=1e-12 * np.abs(mass).max())
        assert np.linalg.eigvalsh(mass)[0] > 0.0
        # and it is the kinetic-energy Hessian: v^T M v / 2 = rigid + fluid energy
        v = rng.normal(size=vehicle.nv)
        rigid = pin.computeKineticEnergy(model, model.createData(), q, v)
        assert vehicle.kinetic_energy(q, v) > rigid > 0.0


def test_uvms_conserves_impulse_and_energy_in_an_ideal_fluid(uvms):
    vehicle = load_vehicle(uvms, added_mass=True, damping=False, restoring=False)
    rng = np.random.default_rng(42)
    q0 = vehicle.neutral_configuration()
    q0[7:] = 0.3 * rng.uniform(-1.0, 1.0, vehicle.nv - 6)
    v0 = np.concatenate((0.2 * rng.normal(size=3), 0.1 * rng.normal(size=3)))
    v0 = np.concatenate((v0, 0.3 * rng.normal(size=vehicle.nv - 6)))
    trajectory = simulate(vehicle, q0, v0, duration=2.0, dt=0.002, method="rk4", log_every=100)
    impulse0 = vehicle.momentum_in_world(trajectory.q[0], trajectory.v[0])
    energy0 = vehicle.kinetic_energy(trajectory.q[0], trajectory.v[0])
    moved = np.linalg.norm(trajectory.q[-1, 7:] - q0[7:])
    assert moved > 0.1  # the arm moved: the test is not trivially at rest
    for q, v in zip(trajectory.q, trajectory.v, strict=True):
        impulse = vehicle.momentum_in_world(q, v)
        np.testing.assert_allclose(
            impulse[:3], impulse0[:3], atol=1e-7 * np.abs(impulse0[:3]).max()
        )
        np.testing.assert_allclose(
            impulse[3:], impulse0[3:], atol=1e-7 * np.abs(impulse0[3:]).max()
        )
        assert abs(vehicle.kinetic_energy(q, v) - energy0) < 1e-7 * energy0
