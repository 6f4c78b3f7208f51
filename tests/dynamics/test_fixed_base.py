"""A fixed base (a robot whose root link is fixed to the world): the compiled kernels against the
Pinocchio reference, a closed form (a pendulum link in still water with buoyancy: its static
equilibrium angle and its small-oscillation period), energy, and the base held still."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.checks.consistency import potential_energy
from aiauv_pin.errors import ArgumentError
from aiauv_pin.reference.integrators import rk4_step

DATA = Path(__file__).parents[1] / "data"
OBERON7 = DATA / "oberon7_uuv_simulator.urdf"
TOL = dict(rtol=1e-9, atol=1e-9)

# the pendulum: a massless 'world' root, a bob link on a revolute joint about y
MASS, ARM, VOLUME, RHO, G = 2.0, 0.5, 1.0e-3, 1000.0, 9.81
I_YY = 0.01  # about the centre of mass [kg m^2]
ADDED_PITCH = 0.004  # added inertia about the joint axis [kg m^2]


def pendulum_urdf(cb: tuple[float, float, float], damping: float = 0.0) -> str:
    """A bob of ``MASS`` with its centre of mass ``ARM`` below a y-axis joint, displacing
    ``VOLUME`` at ``cb`` (link frame), on a world-fixed stand."""
    return f"""<?xml version="1.0"?>
<robot name="pendulum">
  <link name="world"/>
  <link name="stand">
    <inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
    </inertial>
  </link>
  <joint name="mount" type="fixed">
    <parent link="world"/><child link="stand"/><origin xyz="0.3 -0.2 1.0" rpy="0 0 0.4"/>
  </joint>
  <link name="bob">
    <inertial>
      <mass value="{MASS}"/><origin xyz="0 0 {-ARM}"/>
      <inertia ixx="{I_YY}" ixy="0" ixz="0" iyy="{I_YY}" iyz="0" izz="{I_YY}"/>
    </inertial>
  </link>
  <joint name="swing" type="revolute">
    <parent link="stand"/><child link="bob"/><origin xyz="0 0 -0.1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/>
  </joint>
  <hydrodynamics fluid_density="{RHO}" gravity="{G}">
    <link name="bob" model="fossen">
      <volume>{VOLUME}</volume>
      <center_of_buoyancy>{cb[0]} {cb[1]} {cb[2]}</center_of_buoyancy>
      <added_mass>0 0 0 0 {ADDED_PITCH} 0</added_mass>
      <linear_damping>0 0 0 0 {damping} 0</linear_damping>
    </link>
  </hydrodynamics>
</robot>
"""


def _pendulum(tmp_path, cb, backend="numba", damping=0.0):
    path = tmp_path / "pendulum.urdf"
    path.write_text(pendulum_urdf(cb, damping))
    return aiauv_pin.load_vehicle(path, backend=backend)


@pytest.fixture(scope="module")
def oberon7_pair():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fast = aiauv_pin.load_vehicle(OBERON7, lenient=True, backend="numba")
        reference = aiauv_pin.load_vehicle(OBERON7, lenient=True, backend="pinocchio")
    return fast, reference


@pytest.fixture(scope="module")
def paper_pair():
    """The paper's vehicle held by its root link: added mass, damping, crossflow, buoyancy."""
    path = aiauv_pin.bundled_urdf("uniform")
    fast = aiauv_pin.load_vehicle(path, fixed_base=True, backend="numba")
    reference = aiauv_pin.load_vehicle(path, fixed_base=True, backend="pinocchio")
    return fast, reference


def _random_state(vehicle, rng):
    q = vehicle.neutral_configuration()
    q[:3] = rng.normal(size=3)
    quaternion = rng.normal(size=4)
    q[3:7] = quaternion / np.linalg.norm(quaternion)
    q[7:] = rng.uniform(-1.0, 1.0, vehicle.nq - 7)
    return q, rng.normal(size=vehicle.nv), rng.normal(size=vehicle.nv)


@pytest.mark.parametrize("which", ["oberon7_pair", "paper_pair"])
@pytest.mark.parametrize("current", [None, (0.3, -0.2, 0.1)])
def test_compiled_matches_reference_with_a_fixed_base(which, current, request, rng):
    fast, reference = request.getfixturevalue(which)
    assert fast.fixed_base and reference.fixed_base and fast.active_backend == "numba"
    for _ in range(5):
        q, v, tau = _random_state(fast, rng)
        a = fast.acceleration(q, v, tau, current)
        b = reference.acceleration(q, v, tau, current)
        np.testing.assert_allclose(a, b, **TOL)
        assert not np.any(a[:6]) and not np.any(b[:6])
        # the base velocity is read as zero: the same as with v_base = 0
        still = v.copy()
        still[:6] = 0.0
        np.testing.assert_allclose(a, fast.acceleration(q, still, tau, current), **TOL)
        # the joint rows of M dv + b = tau, the reference's own mass matrix and bias
        forces = reference.fluid_forces(q, still, current)
        joints = forces.mass_matrix[6:, 6:] @ b[6:] + forces.bias[6:]
        np.testing.assert_allclose(joints, tau[6:], rtol=1e-9, atol=1e-9)


def test_world_root_fixes_the_base_and_a_flag_fixes_any(tmp_path):
    pendulum = _pendulum(tmp_path, (0.0, 0.0, -ARM))
    assert pendulum.fixed_base
    paper = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("uniform"))
    assert not paper.fixed_base
    with pytest.raises(ArgumentError, match="fixed-base"):
        aiauv_pin.load_vehicle(
            aiauv_pin.bundled_urdf("uniform"), fixed_base=True
        ).acceleration_derivatives(
            paper.neutral_configuration(), np.zeros(paper.nv), np.zeros(paper.nv)
        )


def test_static_equilibrium_angle_closed_form(tmp_path):
    """Buoyancy at ``(d, 0, 0)``, weight at ``(0, 0, -L)``: the torques about the joint balance at
    ``tan(theta) = -rho V d / (m L)`` (moments of ``m g`` and ``rho V g`` about the y axis)."""
    d = 0.2
    theta = math.atan2(-RHO * VOLUME * d, MASS * ARM)
    for backend in ("numba", "pinocchio"):
        vehicle = _pendulum(tmp_path, (d, 0.0, 0.0), backend=backend)
        q = vehicle.neutral_configuration()
        q[7] = theta
        zero = np.zeros(vehicle.nv)
        assert abs(vehicle.acceleration(q, zero, zero)[6]) < 1e-12
        q[7] = theta + 0.01  # restoring: back towards theta
        assert vehicle.acceleration(q, zero, zero)[6] < 0.0


def test_damped_run_settles_at_the_closed_form_angle(tmp_path):
    d = 0.2
    theta = math.atan2(-RHO * VOLUME * d, MASS * ARM)
    vehicle = _pendulum(tmp_path, (d, 0.0, 0.0), damping=0.5)
    trajectory = aiauv_pin.simulate(
        vehicle, vehicle.neutral_configuration(), np.zeros(vehicle.nv), 40.0, 0.005
    )
    assert abs(trajectory.q[-1, 7] - theta) < 1e-6
    # the base never moved
    np.testing.assert_array_equal(
        trajectory.q[:, :7], np.tile(trajectory.q[0, :7], (len(trajectory.q), 1))
    )
    assert not np.any(trajectory.v[:, :6])


def _crossing_times(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Times where ``x`` goes from negative to positive, linearly interpolated."""
    up = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
    return t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])


@pytest.mark.parametrize("backend", ["numba", "pinocchio"])
def test_small_oscillation_period_closed_form(tmp_path, backend):
    """Buoyancy at ``(0, 0, -l_B)``: ``T = 2 pi sqrt(J / k)``, ``J = I_yy + m L^2 + A_55``
    (added inertia about the joint) and ``k = (m L - rho V l_B) g`` (the net righting moment per
    radian)."""
    l_b = 0.3
    inertia = I_YY + MASS * ARM**2 + ADDED_PITCH
    stiffness = (MASS * ARM - RHO * VOLUME * l_b) * G
    period = 2.0 * math.pi * math.sqrt(inertia / stiffness)
    vehicle = _pendulum(tmp_path, (0.0, 0.0, -l_b), backend=backend)
    dt, amplitude = 0.002, 1.0e-3
    q = vehicle.neutral_configuration()
    q[7] = amplitude
    v = np.zeros(vehicle.nv)
    tau = np.zeros(vehicle.nv)
    steps = int(3.2 * period / dt)
    angles, times = [q[7]], [0.0]
    for k in range(steps):
        q, v = rk4_step(vehicle.model, lambda q_, v_: vehicle.acceleration(q_, v_, tau), q, v, dt)
        angles.append(q[7])
        times.append((k + 1) * dt)
    crossings = _crossing_times(np.array(times), np.array(angles))
    measured = float(np.mean(np.diff(crossings)))
    # the amplitude's own correction is theta_0^2 / 16 = 6e-8 of the period
    assert abs(measured - period) / period < 1e-6
    np.testing.assert_array_equal(q[:7], vehicle.neutral_configuration()[:7])


def test_energy_is_conserved_without_damping(oberon7_pair, rng):
    """No damping: kinetic plus potential energy of the arm on its fixed base stays constant."""
    fast, _ = oberon7_pair
    q = fast.neutral_configuration()
    q[7:] = rng.uniform(-0.5, 0.5, fast.nq - 7)
    v = np.zeros(fast.nv)
    v[6:] = rng.normal(scale=0.3, size=fast.nv - 6)
    energy = fast.kinetic_energy(q, v) + potential_energy(fast, q)
    trajectory = aiauv_pin.simulate(fast, q, v, 1.0, 2.0e-4)
    final = fast.kinetic_energy(trajectory.q[-1], trajectory.v[-1]) + potential_energy(
        fast, trajectory.q[-1]
    )
    assert abs(final - energy) < 1e-6 * max(1.0, abs(energy))
    np.testing.assert_array_equal(trajectory.q[-1, :7], q[:7])


def test_step_and_simulate_hold_the_base(paper_pair, rng):
    fast, _ = paper_pair
    q, v, _ = _random_state(fast, rng)
    controls = rng.normal(size=fast.n_controls)
    q1, v1 = fast.step(q, v, controls, 0.01)
    np.testing.assert_array_equal(q1[:3], q[:3])
    np.testing.assert_allclose(q1[3:7], q[3:7], rtol=0, atol=1e-15)
    assert not np.any(v1[:6])
    trajectory = aiauv_pin.simulate(fast, q, v, 0.5, 0.01)
    assert np.all(np.isfinite(trajectory.q))
    np.testing.assert_allclose(
        trajectory.q[:, :7], np.tile(q[:7], (len(trajectory.q), 1)), atol=1e-15
    )


def test_rollout_holds_the_base_and_matches_simulate(paper_pair, rng):
    fast, _ = paper_pair
    q, v, _ = _random_state(fast, rng)
    batch = aiauv_pin.rollout(fast, q, np.stack([v, 2.0 * v]), 0.2, 0.01)
    assert np.all(batch.status == "complete")
    np.testing.assert_allclose(
        batch.q[:, :, :7], np.broadcast_to(q[:7], batch.q[:, :, :7].shape), atol=1e-15
    )
    assert not np.any(batch.v[:, :, :6])
    single = aiauv_pin.simulate(fast, q, v, 0.2, 0.01)
    np.testing.assert_allclose(batch.q[0], single.q, rtol=1e-12, atol=1e-12)
