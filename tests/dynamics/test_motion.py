"""Whole-vehicle behaviour against closed forms (issue 2, tests 8-10) and integrator orders."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import aiauv_pin

# every physics check runs on both backends (the compiled one and the Pinocchio reference)
pytestmark = pytest.mark.usefixtures("backend")

RHO, R, G = 1000.0, 0.085, 9.81
LENGTHS = [0.62, 0.104, 0.584, 0.104, 0.726, 0.104, 0.584, 0.104, 0.37]
MASS = 81.3


def roll_angle(q: np.ndarray) -> float:
    rotation = pin.Quaternion(q[3:7]).toRotationMatrix()
    return float(np.arctan2(rotation[2, 1], rotation[2, 2]))


def rolled(vehicle, angle: float) -> np.ndarray:
    q = vehicle.neutral_configuration()
    q[3:7] = pin.Quaternion(pin.utils.rpyToMatrix(angle, 0.0, 0.0)).coeffs()
    return q


# ---------------------------------------------------------------- 8. hydrostatics
def test_neutral_uniform_vehicle_at_rest_stays_at_rest(paper_vehicle, rng):
    for _ in range(3):
        q = paper_vehicle.neutral_configuration()
        q[:3] = rng.uniform(-5, 5, 3)
        axis = rng.normal(size=3)
        q[3:7] = pin.Quaternion(pin.exp3(axis)).coeffs()
        q[7:] = rng.uniform(-0.5, 0.5, paper_vehicle.nq - 7)
        dv = paper_vehicle.acceleration(q, np.zeros(paper_vehicle.nv), np.zeros(paper_vehicle.nv))
        assert np.abs(dv).max() < 1e-12


def _linearised_roll_frequency(vehicle) -> float:
    q0 = vehicle.neutral_configuration()
    h = 1e-6
    stiffness = np.zeros((vehicle.nv, vehicle.nv))
    for i in range(vehicle.nv):
        step = np.zeros(vehicle.nv)
        step[i] = h
        stiffness[:, i] = (
            vehicle.restoring_forces(pin.integrate(vehicle.model, q0, step))
            - vehicle.restoring_forces(pin.integrate(vehicle.model, q0, -step))
        ) / (2 * h)
    # roll restoring of the whole vehicle: W d with d = r/2 (PAPER_DATA: about 34 N m/rad)
    assert stiffness[3, 3] == pytest.approx(MASS * G * 0.5 * R, rel=1e-6)
    eigenvalues, vectors = np.linalg.eig(np.linalg.solve(vehicle.mass_matrix(q0), stiffness))
    roll_mode = np.argmax(np.abs(vectors[3, :]) / np.linalg.norm(vectors, axis=0))
    return float(np.sqrt(eigenvalues[roll_mode].real))


def test_stabilised_roll_period_matches_linearisation():
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"), damping=False)
    omega = _linearised_roll_frequency(vehicle)
    period = 2 * np.pi / omega
    trajectory = aiauv_pin.simulate(
        vehicle, rolled(vehicle, np.deg2rad(2.0)), np.zeros(vehicle.nv), 8 * period, period / 200
    )
    roll = np.array([roll_angle(q) for q in trajectory.q])
    # upward zero crossings, linearly interpolated
    idx = np.flatnonzero((roll[:-1] < 0) & (roll[1:] >= 0))
    t = trajectory.t
    crossings = t[idx] - roll[idx] * (t[idx + 1] - t[idx]) / (roll[idx + 1] - roll[idx])
    measured = np.diff(crossings).mean()
    assert len(crossings) >= 6
    assert measured == pytest.approx(period, rel=0.02)


def test_stabilised_vehicle_rights_itself():
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"))
    trajectory = aiauv_pin.simulate(
        vehicle,
        rolled(vehicle, np.deg2rad(10.0)),
        np.zeros(vehicle.nv),
        120.0,
        0.02,
        log_every=5,
    )
    roll = np.abs([roll_angle(q) for q in trajectory.q])
    last = trajectory.t > trajectory.t[-1] - 5.0
    assert roll[last].max() < 0.2 * np.deg2rad(10.0)
    # and the uniform vehicle, which has no roll stiffness, does not
    uniform = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("uniform"))
    q = rolled(uniform, np.deg2rad(10.0))
    dv = uniform.acceleration(q, np.zeros(uniform.nv), np.zeros(uniform.nv))
    assert np.abs(dv).max() < 1e-12


# ---------------------------------------------------------------- 9. terminal surge speed
def test_constant_thrust_reaches_analytic_terminal_speed(paper_vehicle):
    thrust = 20.0  # per longitudinal thruster [N]
    names = paper_vehicle.thruster_names
    command = np.array([thrust if "_x_" in n else 0.0 for n in names])
    assert np.count_nonzero(command) == 2

    def controller(t, q, v):
        # joints held straight by a PD (eq. 24 with zero reference, lighter damping): a passive
        # articulated body buckles under the destabilising Munk moments
        tau = paper_vehicle.thrust_matrix(q) @ command
        tau[6:] += -30.0 * q[7:] - 5.0 * v[6:]
        return tau

    trajectory = aiauv_pin.simulate(
        paper_vehicle,
        paper_vehicle.neutral_configuration(),
        np.zeros(paper_vehicle.nv),
        40.0,  # ~20 time constants; the straight motion of a finless body is unstable in the long run
        0.05,
        controller,
        log_every=20,
    )
    # axial drag of nine links: linear rho r L C_dL v_ref beta u, quadratic 1/2 rho pi r^2 C_d1 u^2
    linear = RHO * R * sum(LENGTHS) * 0.1 * 1.0 * 0.1
    quadratic = len(LENGTHS) * 0.5 * RHO * np.pi * R**2 * 0.2
    terminal = (-linear + np.sqrt(linear**2 + 4 * quadratic * 2 * thrust)) / (2 * quadratic)
    assert trajectory.v[-1, 0] == pytest.approx(terminal, rel=0.005)
    # the straight vehicle stays straight
    assert np.abs(trajectory.q[-1, 7:]).max() < 1e-6


# ---------------------------------------------------------------- 10. carried by the current
def test_neutral_vehicle_is_carried_by_current(paper_vehicle):
    current = np.array([0.15, 0.3, -0.1])
    trajectory = aiauv_pin.simulate(
        paper_vehicle,
        paper_vehicle.neutral_configuration(),
        np.zeros(paper_vehicle.nv),
        300.0,
        0.05,
        current=current,
        log_every=50,
    )
    q, v = trajectory.q[-1], trajectory.v[-1]
    rotation = pin.Quaternion(q[3:7]).toRotationMatrix()
    velocity_in_world = rotation @ v[:3]
    np.testing.assert_allclose(velocity_in_world, current, atol=2e-3)
    assert np.abs(v[3:]).max() < 1e-3


# ---------------------------------------------------------------- integrator orders
def _tumbling_errors(vehicle, method, steps):
    q0 = vehicle.neutral_configuration()
    v0 = np.array([0.3, -0.2, 0.1, 0.05, 2.0, 0.1])  # close to the intermediate axis
    duration = 2.0
    reference = aiauv_pin.simulate(vehicle, q0, v0, duration, duration / 4096, method="rk4")
    errors = []
    for n in steps:
        run = aiauv_pin.simulate(vehicle, q0, v0, duration, duration / n, method=method)
        dq = pin.difference(vehicle.model, reference.q[-1], run.q[-1])
        errors.append(np.linalg.norm(np.concatenate((dq, run.v[-1] - reference.v[-1]))))
    return np.array(errors)


@pytest.mark.parametrize(
    ("method", "steps", "order"),
    [
        ("rk4", [32, 64, 128], 4.0),
        ("euler", [256, 512, 1024], 1.0),
        ("midpoint", [128, 256, 512], 2.0),
    ],
)
def test_integrator_convergence_order_on_tumbling_body(single_body, method, steps, order):
    path, _ = single_body
    vehicle = aiauv_pin.load_vehicle(path, added_mass=False, damping=False, restoring=False)
    errors = _tumbling_errors(vehicle, method, steps)
    slopes = np.log2(errors[:-1] / errors[1:])
    assert slopes == pytest.approx(order, abs=0.3)
