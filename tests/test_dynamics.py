"""Physics checks of the hydrodynamic multibody core (issue 2, tests 1-5 and 7)."""

from __future__ import annotations

import fossen_reference as fossen
import numpy as np
import pinocchio as pin
import pytest
from conftest import random_state

import aiauv_pin
from aiauv_pin.robots import example_robot_urdf

# every physics check runs on both backends (the compiled one and the Pinocchio reference)
pytestmark = pytest.mark.usefixtures("backend")

EXAMPLE_ROBOTS = ["ur_description/urdf/ur5_robot.urdf", "panda_description/urdf/panda.urdf"]


# ---------------------------------------------------------------- 1. rigid part is Pinocchio's
@pytest.mark.parametrize("robot", [None, *EXAMPLE_ROBOTS])
def test_without_fluid_acceleration_equals_aba(robot, rng):
    path = None if robot is None else example_robot_urdf(robot)
    vehicle = aiauv_pin.load_vehicle(path, added_mass=False, damping=False, restoring=False)
    for _ in range(5):
        q, v = random_state(vehicle.model, rng)
        tau = rng.normal(size=vehicle.nv)
        expected = pin.aba(vehicle.model, vehicle.model.createData(), q, v, tau)
        np.testing.assert_allclose(vehicle.acceleration(q, v, tau), expected, atol=1e-9)


@pytest.mark.parametrize("robot", EXAMPLE_ROBOTS)
def test_dry_robot_with_gravity_equals_aba(robot, rng):
    """A URDF with no hydrodynamics block: weight only, as Pinocchio with standard gravity."""
    vehicle = aiauv_pin.load_vehicle(example_robot_urdf(robot))
    model = pin.buildModelFromUrdf(str(example_robot_urdf(robot)), pin.JointModelFreeFlyer())
    q, v = random_state(model, rng)
    tau = rng.normal(size=model.nv)
    expected = pin.aba(model, model.createData(), q, v, tau)
    np.testing.assert_allclose(vehicle.acceleration(q, v, tau), expected, atol=1e-9)


# ---------------------------------------------------------------- 2. mass matrix and energy rate
def test_mass_matrix_symmetric_positive_definite(paper_vehicle, rng):
    for _ in range(5):
        q, _ = random_state(paper_vehicle.model, rng)
        mass = paper_vehicle.mass_matrix(q)
        np.testing.assert_allclose(mass, mass.T, atol=1e-12)
        assert np.linalg.eigvalsh(mass).min() > 0.0
        rigid = pin.crba(paper_vehicle.model, paper_vehicle.model.createData(), q)
        rigid = np.triu(rigid) + np.triu(rigid, 1).T
        # the added mass adds a positive semi-definite part
        assert np.linalg.eigvalsh(mass - rigid).min() > -1e-9


def _flow(vehicle, q, v, tau, h):
    """Configuration and velocity a time h later along the exact flow (fine RK4)."""
    for _ in range(4):
        q, v = aiauv_pin.rk4_step(
            vehicle.model, lambda qq, vv: vehicle.acceleration(qq, vv, tau), q, v, h / 4
        )
    return q, v


def test_kinetic_energy_rate_equals_power_of_forces(rng):
    """d/dt (v^T M v / 2) = v^T (tau - g(q)) with added mass and restoring on, damping off:
    the rigid and added-mass Coriolis terms do no work."""
    vehicle = aiauv_pin.load_vehicle(damping=False)
    q, v = random_state(vehicle.model, rng)
    tau = 5.0 * rng.normal(size=vehicle.nv)
    h = 1e-4
    qp, vp = _flow(vehicle, q, v, tau, h)
    qm, vm = _flow(vehicle, q, v, tau, -h)
    rate = (vehicle.kinetic_energy(qp, vp) - vehicle.kinetic_energy(qm, vm)) / (2 * h)
    power = v @ (tau - vehicle.restoring_forces(q))
    assert rate == pytest.approx(power, rel=1e-6, abs=1e-9)


def _potential_energy(vehicle, q) -> float:
    """Weight via Pinocchio's potential energy, buoyancy from link poses and centres of buoyancy."""
    model = vehicle.model
    weight = pin.computePotentialEnergy(model, model.createData(), q)
    rho, g = vehicle.hydro.fluid_density, vehicle.hydro.gravity
    buoyancy = 0.0
    for link, pose in zip(vehicle.hydro.links, vehicle.link_placements(q), strict=False):
        buoyancy += rho * link.volume * g * pose.act(link.center_of_buoyancy)[2]
    return weight - buoyancy


@pytest.mark.parametrize("case", ["uniform", "stabilised"])
def test_restoring_force_is_gradient_of_potential(case, rng):
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
    for _ in range(3):
        q, v = random_state(vehicle.model, rng)
        h = 1e-6
        rate = (
            _potential_energy(vehicle, pin.integrate(vehicle.model, q, h * v))
            - _potential_energy(vehicle, pin.integrate(vehicle.model, q, -h * v))
        ) / (2 * h)
        assert rate == pytest.approx(v @ vehicle.restoring_forces(q), rel=1e-6, abs=1e-8)


# ---------------------------------------------------------------- 3. ideal fluid invariants
def test_ideal_fluid_conserves_energy_and_impulse(rng):
    vehicle = aiauv_pin.load_vehicle(damping=False, restoring=False)
    q, v = random_state(vehicle.model, rng, speed=0.3)
    trajectory = aiauv_pin.simulate(vehicle, q, v, duration=10.0, dt=0.005, log_every=100)
    energy = [
        vehicle.kinetic_energy(qq, vv) for qq, vv in zip(trajectory.q, trajectory.v, strict=False)
    ]
    assert max(abs(e - energy[0]) for e in energy) < 1e-7 * energy[0]
    impulse = np.array(
        [
            vehicle.momentum_in_world(qq, vv)
            for qq, vv in zip(trajectory.q, trajectory.v, strict=False)
        ]
    )
    scale = np.linalg.norm(impulse[0])
    assert np.abs(impulse - impulse[0]).max() < 1e-7 * scale
    # the joints did move: the test exercises the articulated added-mass coupling
    assert np.ptp(trajectory.q[:, 7:], axis=0).max() > 0.05


# ---------------------------------------------------------------- 4. damping dissipates
def test_damping_never_adds_energy(rng):
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"))
    undamped = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"), damping=False)
    for _ in range(20):
        q, v = random_state(vehicle.model, rng, speed=1.0)
        # power of the damping forces, from the difference of the two models' bias terms
        damping_power = v @ (undamped.fluid_forces(q, v).bias - vehicle.fluid_forces(q, v).bias)
        assert damping_power < 0.0
    q, v = random_state(vehicle.model, rng, speed=0.5)
    trajectory = aiauv_pin.simulate(vehicle, q, v, duration=5.0, dt=0.01, log_every=5)
    energy = np.array(
        [
            vehicle.kinetic_energy(qq, vv) + _potential_energy(vehicle, qq)
            for qq, vv in zip(trajectory.q, trajectory.v, strict=False)
        ]
    )
    assert np.diff(energy).max() < 1e-9 * np.ptp(energy)
    assert energy[-1] < energy[0]


def test_power_balance_with_damping(rng):
    """d/dt (T + U) = v^T tau + (power of the damping forces) along the exact flow."""
    vehicle = aiauv_pin.load_vehicle()
    undamped = aiauv_pin.load_vehicle(damping=False)
    q, v = random_state(vehicle.model, rng, speed=0.8)
    tau = 3.0 * rng.normal(size=vehicle.nv)
    h = 1e-4
    qp, vp = _flow(vehicle, q, v, tau, h)
    qm, vm = _flow(vehicle, q, v, tau, -h)

    def energy(qq, vv):
        return vehicle.kinetic_energy(qq, vv) + _potential_energy(vehicle, qq)

    rate = (energy(qp, vp) - energy(qm, vm)) / (2 * h)
    damping_power = v @ (undamped.fluid_forces(q, v).bias - vehicle.fluid_forces(q, v).bias)
    assert rate == pytest.approx(v @ tau + damping_power, rel=1e-6)


# ---------------------------------------------------------------- 5. one body against Fossen
@pytest.mark.parametrize("current", [None, np.array([0.4, -0.25, 0.1])])
def test_single_body_matches_fossen_reference(single_body, current, rng):
    path, p = single_body
    vehicle = aiauv_pin.load_vehicle(path)
    assert vehicle.nv == 6
    for _ in range(10):
        q, v = random_state(vehicle.model, rng, speed=1.0)
        tau = 10.0 * rng.normal(size=6)
        rotation = pin.Quaternion(q[3:7]).toRotationMatrix()
        expected = fossen.acceleration(rotation, v, tau, current=current, **p)
        np.testing.assert_allclose(
            vehicle.acceleration(q, v, tau, current=current), expected, atol=1e-9, rtol=1e-9
        )


# ---------------------------------------------------------------- 7. invariance
def test_rigid_motion_of_whole_vehicle_leaves_body_accelerations(rng):
    vehicle = aiauv_pin.load_vehicle(restoring=False)
    for _ in range(3):
        q, v = random_state(vehicle.model, rng)
        tau = rng.normal(size=vehicle.nv)
        moved = q.copy()
        displacement = pin.SE3.Random()
        base = displacement * pin.XYZQUATToSE3(q[:7])
        moved[:7] = pin.SE3ToXYZQUAT(base)
        np.testing.assert_allclose(
            vehicle.acceleration(moved, v, tau), vehicle.acceleration(q, v, tau), atol=1e-10
        )
