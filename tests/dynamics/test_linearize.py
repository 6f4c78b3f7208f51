"""Linear models about a trim (issue 16): closed forms and the nonlinear simulation.

* A single body in an ideal fluid moving along its axis: the sway-yaw and heave-pitch pairs have
  the eigenvalues of Munk's moment instability, ``lambda^2 = M1 (M2 - M1) U^2 / (M2 J)``
  (Kirchhoff's equations linearised; Lamb 1932, Sec. 124; Fossen 2021, Sec. 6.3.4), and every other
  eigenvalue is 0.
* The paper's vehicle about straight-line motion at 0.5 m/s: the eigenvalues and eigenvectors of the
  linear model predict the decay of small perturbations in the nonlinear simulation.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import expm

import aiauv_pin
from aiauv_pin.dynamics.linear_model import format_modes, linearize, straight_line_trim

pytest.importorskip("numba")

MASS, IXX, IYY = 30.0, 0.4, 3.0
ADDED = (3.0, 25.0, 25.0, 0.0, 2.0, 2.0)  # prolate: m11 < m22 = m33


def _ideal_body(tmp_path):
    text = f"""<?xml version="1.0"?>
<robot name="prolate">
  <link name="hull">
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="{MASS}"/>
      <inertia ixx="{IXX}" ixy="0" ixz="0" iyy="{IYY}" iyz="0" izz="{IYY}"/>
    </inertial>
  </link>
  <hydrodynamics fluid_density="1000" gravity="9.81">
    <link name="hull" model="fossen">
      <volume>0.03</volume>
      <center_of_buoyancy>0 0 0</center_of_buoyancy>
      <added_mass>{" ".join(str(a) for a in ADDED)}</added_mass>
      <linear_damping>0 0 0 0 0 0</linear_damping>
      <quadratic_damping>0 0 0 0 0 0</quadratic_damping>
    </link>
  </hydrodynamics>
</robot>
"""
    path = tmp_path / "prolate.urdf"
    path.write_text(text)
    return aiauv_pin.load_vehicle(path, restoring=False)


@pytest.mark.parametrize("speed", [0.5, 2.0])
def test_munk_moment_instability_of_a_prolate_body(tmp_path, speed):
    vehicle = _ideal_body(tmp_path)
    trim = straight_line_trim(vehicle, speed)
    assert trim.residual < 1e-12 and np.allclose(trim.thrusts, 0.0)
    model = linearize(vehicle, trim)
    m1, m2 = MASS + ADDED[0], MASS + ADDED[1]
    inertia = IYY + ADDED[5]
    rate = speed * np.sqrt(m1 * (m2 - m1) / (m2 * inertia))
    expected = np.sort(np.concatenate(([rate, rate, -rate, -rate], np.zeros(8))))
    found = np.sort(model.eigenvalues.real)
    np.testing.assert_allclose(found, expected, atol=1e-9 * rate)
    np.testing.assert_allclose(model.eigenvalues.imag, 0.0, atol=1e-9)
    unstable = model.modes()[0]
    names = {name for name, _ in unstable.dominant}
    assert names & {"base v", "base r", "base w", "base q"}


def _simulate(vehicle, q, v, trim, duration, dt):
    """RK4 run holding the trim's thrusts; the simulator holds the generalised force of a step,
    computed at its start (the thrusters turn with the body only from one step to the next)."""
    fast = vehicle.fast
    for _ in range(round(duration / dt)):
        tau = fast.thrust_matrix(q) @ trim.thrusts
        tau[6:] += trim.joint_torques
        q, v = fast.step(q, v, tau, dt, method="rk4")
    return q, v


def _deviation(vehicle, model, trim, k, duration, dt):
    """Largest difference, relative to the start, between the nonlinear run from a 1e-4 perturbation
    along mode ``k`` and the linear model's ``expm(A T)`` prediction."""
    nv = vehicle.nv
    vector = model.eigenvectors[:, k]
    start = 1e-4 * np.real(vector) / np.abs(np.real(vector)).max()
    q_ref, v_ref = _simulate(vehicle, trim.q, trim.v, trim, duration, dt)
    q0 = pin.integrate(vehicle.model, trim.q, start[:nv])
    q_end, v_end = _simulate(vehicle, q0, trim.v + start[nv:], trim, duration, dt)
    nonlinear = np.concatenate((pin.difference(vehicle.model, q_ref, q_end), v_end - v_ref))
    predicted = np.real(expm(model.A * duration) @ start)
    lam = model.eigenvalues[k]
    if abs(lam.imag) < 1e-9:  # a real mode: a decay by exp(lambda T) along its eigenvector
        np.testing.assert_allclose(predicted, np.exp(lam.real * duration) * start, atol=1e-12)
    return np.abs(nonlinear - predicted).max() / np.abs(start).max()


def test_eigenvalues_predict_the_decay_of_small_perturbations():
    """Paper vehicle (roll-stabilised), open loop with the joints free, straight line at 0.5 m/s:
    a perturbation of size 1e-4 along the slowest oscillatory mode, the slowest real mode and the
    roll oscillation evolves in the nonlinear simulation as ``Re(w exp(lambda t))``. The difference is
    first order in the step (the simulator holds a step's thrust direction, the linear model turns
    it with the body continuously): it shrinks 4x from dt = 8 ms to 2 ms and is below 3e-3 there."""
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"))
    trim = straight_line_trim(vehicle, 0.5)
    assert trim.residual < 1e-10
    model = linearize(vehicle, trim)
    order = np.argsort(-model.eigenvalues.real)
    decaying = [k for k in order if model.eigenvalues[k].real < -1e-3]
    oscillating = [k for k in decaying if model.eigenvalues[k].imag > 1e-9]
    real = [k for k in decaying if abs(model.eigenvalues[k].imag) < 1e-9]
    roll = max(oscillating, key=lambda k: model.eigenvalues[k].imag)
    for k in (oscillating[0], real[0], roll):
        coarse = _deviation(vehicle, model, trim, k, 1.0, 0.008)
        fine = _deviation(vehicle, model, trim, k, 1.0, 0.002)
        assert fine < 3e-3 and fine < 0.35 * coarse + 2e-5, (model.eigenvalues[k], coarse, fine)


def test_format_modes_names_the_states(paper_vehicle):
    model = linearize(paper_vehicle, joint_gains=(30.0, 50.0))
    text = format_modes(model)
    assert "joint servo" in text and "base u" in text


def test_a_users_controller_closes_the_loop_like_the_servo(paper_vehicle):
    """A joint PD given as a controller function (differentiated by central differences) gives the
    closed loop of the exact servo without hydrostatic compensation."""
    vehicle = paper_vehicle
    trim = straight_line_trim(vehicle, 0.5)
    m, k_p, k_d = len(vehicle.thruster_names), 30.0, 50.0

    def controller(q, v):
        return np.concatenate(
            (trim.thrusts, trim.joint_torques - k_p * (q[7:] - trim.q[7:]) - k_d * v[6:])
        )

    exact = linearize(vehicle, trim, joint_gains=(k_p, k_d), compensate_restoring=False)
    by_function = linearize(vehicle, trim, controller=controller)
    assert by_function.closed_loop == "controller" and m == 7
    np.testing.assert_allclose(by_function.A, exact.A, rtol=1e-6, atol=1e-6 * np.abs(exact.A).max())
