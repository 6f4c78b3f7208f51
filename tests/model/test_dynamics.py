"""Physics checks of the hydrodynamic multibody core (issue 2, tests 1-5 and 7; issue 17)."""

from __future__ import annotations

import fossen_reference as fossen
import numpy as np
import pinocchio as pin
import pytest
from conftest import random_state

import aiauv_pin
from aiauv_pin.checks import consistency
from aiauv_pin.description.robots import example_robot_urdf

# every physics check runs on both backends (the compiled one and the Pinocchio reference)
pytestmark = pytest.mark.usefixtures("backend")

# free-floating arms (ur5_robot.urdf has a massless 'world' root: a fixed base, tested below)
EXAMPLE_ROBOTS = ["so_arm_description/urdf/so100.urdf", "panda_description/urdf/panda.urdf"]


# The laws below are the shipped consistency checks (aiauv_pin.checks.consistency, the same functions that
# `pytest --aiauv-vehicle` and `aiauv check --physics` run on a user's vehicle), applied here to the
# shipped vehicles; each test keeps (or tightens) the tolerance it had before the checks moved.


def assert_passes(result: consistency.CheckResult) -> consistency.CheckResult:
    assert not result.skipped, result.message()
    assert result.passed, result.message()
    return result


# ---------------------------------------------------------------- 1. rigid part is Pinocchio's
@pytest.mark.parametrize("robot", [None, *EXAMPLE_ROBOTS])
def test_without_fluid_acceleration_equals_aba(robot):
    path = None if robot is None else example_robot_urdf(robot)
    vehicle = aiauv_pin.load_vehicle(path, added_mass=False, damping=False, restoring=False)
    # max |dv - aba| / (1 + |aba|) <= 1e-9, i.e. allclose(atol=1e-9, rtol=1e-9)
    assert_passes(consistency.check_aba_without_fluid(vehicle, samples=5))


@pytest.mark.parametrize("robot", EXAMPLE_ROBOTS)
def test_dry_robot_with_gravity_equals_aba(robot, rng):
    """A URDF with no hydrodynamics block: weight only, as Pinocchio with standard gravity."""
    vehicle = aiauv_pin.load_vehicle(example_robot_urdf(robot))
    model = pin.buildModelFromUrdf(str(example_robot_urdf(robot)), pin.JointModelFreeFlyer())
    q, v = random_state(model, rng)
    tau = rng.normal(size=model.nv)
    expected = pin.aba(model, model.createData(), q, v, tau)
    np.testing.assert_allclose(vehicle.acceleration(q, v, tau), expected, atol=1e-9)


def test_fixed_base_robot_equals_pinocchios_fixed_base_aba(rng):
    """UR5's 'world' root fixes its base: the joint accelerations are Pinocchio's ABA of the
    fixed-base model (no root joint, the world link the universe), the base ones zero."""
    path = example_robot_urdf("ur_description/urdf/ur5_robot.urdf")
    vehicle = aiauv_pin.load_vehicle(path)
    assert vehicle.fixed_base
    model = pin.buildModelFromUrdf(str(path))
    q, v = rng.uniform(-1.0, 1.0, model.nq), rng.normal(size=model.nv)
    tau = rng.normal(size=model.nv)
    expected = pin.aba(model, model.createData(), q, v, tau)
    q_full = np.concatenate((vehicle.neutral_configuration()[:7], q))
    v_full = np.concatenate((rng.normal(size=6), v))  # the locked base's velocity is read as 0
    tau_full = np.concatenate((rng.normal(size=6), tau))
    acceleration = vehicle.acceleration(q_full, v_full, tau_full)
    np.testing.assert_allclose(acceleration[6:], expected, atol=1e-9, rtol=1e-9)
    assert not np.any(acceleration[:6])


# ---------------------------------------------------------------- 2. mass matrix and energy rate
def test_mass_matrix_symmetric_positive_definite(paper_vehicle):
    # |M - M^T| <= 1e-12 (1 + |M|); lambda_min(M) >= 1e-12 lambda_max(M) > 0; the added mass adds a
    # positive semi-definite part: lambda_min(M - M_RB) >= -1e-12 lambda_max(M)
    assert_passes(consistency.check_mass_matrix_symmetric(paper_vehicle, samples=5))
    assert_passes(consistency.check_mass_matrix_positive_definite(paper_vehicle, samples=5))
    assert_passes(consistency.check_added_mass_positive_semidefinite(paper_vehicle, samples=5))


@pytest.mark.parametrize("case", ["uniform", "stabilised"])
def test_kinetic_energy_is_the_sum_over_bodies(case):
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
    assert_passes(consistency.check_kinetic_energy(vehicle, samples=5))


def test_kinetic_energy_rate_equals_power_of_forces():
    """d/dt (v^T M v / 2) = v^T (tau - g(q)) with added mass and restoring on, damping off:
    the rigid and added-mass Coriolis terms do no work (relative error <= 1e-6)."""
    vehicle = aiauv_pin.load_vehicle(damping=False)
    assert_passes(consistency.check_power_balance(vehicle, samples=3))


@pytest.mark.parametrize("case", ["uniform", "stabilised"])
def test_restoring_force_is_gradient_of_potential(case):
    """v . g(q) = dU/dt, U from the URDF's weight and buoyancy: |error| <= max(1e-6 |v.g|, 1e-8 W)."""
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
    result = assert_passes(consistency.check_hydrostatics(vehicle, samples=3))
    assert result.warnings == ()  # both cases are neutrally buoyant


# ---------------------------------------------------------------- 3. ideal fluid invariants
def test_ideal_fluid_conserves_energy_and_impulse():
    vehicle = aiauv_pin.load_vehicle()
    run = consistency.ideal_fluid_run(vehicle, duration=10.0, dt=0.005, speed=0.3)
    assert_passes(consistency.check_energy_conserved(vehicle, run=run))
    assert_passes(consistency.check_impulse_conserved(vehicle, run=run))
    # at dt = 0.005 s both drift by less than 1e-7 over the 10 s
    assert run.energy_drift[0] < 1e-7
    assert run.impulse_drift[0] < 1e-7
    # the joints did move: the test exercises the articulated added-mass coupling
    assert run.joint_motion > 0.05


# ---------------------------------------------------------------- 4. damping dissipates
def test_damping_never_adds_energy():
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"))
    # power of the damping forces negative at 20 states, still water and a current
    assert_passes(consistency.check_damping_dissipates(vehicle, samples=20))
    # T + U never increases (by more than 1e-9 of its range) along a 5 s run, and decreases
    assert_passes(consistency.check_energy_decays(vehicle, duration=5.0, dt=0.01))


def test_power_balance_with_damping():
    """d/dt (T + U) = v^T tau + (power of the damping forces) along the exact flow (rel. 1e-6)."""
    assert_passes(consistency.check_power_balance(aiauv_pin.load_vehicle(), samples=3))


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
def test_rigid_motion_of_whole_vehicle_leaves_body_accelerations(paper_vehicle):
    # any rigid motion without restoring forces, a yaw and translation with them, the current moved
    # along: |dv(moved) - dv| <= 1e-10 (1 + |dv|)
    assert_passes(consistency.check_invariance(paper_vehicle, samples=3))


# ---------------------------------------------------------------- 9. thrusters
@pytest.mark.parametrize("case", ["uniform", "stabilised"])
def test_thrust_matrix_is_unit_forces_at_the_declared_points(case):
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(case))
    assert_passes(consistency.check_thrusters(vehicle, samples=3))
