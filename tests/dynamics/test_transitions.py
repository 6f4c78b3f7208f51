"""Transition Jacobians of one RK4 and one semi-implicit Euler step (issue 16) against central
differences of the compiled step, in the tangent space, with thrusters and joint torques as inputs."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_state

import aiauv_pin
from aiauv_hydro.currents import Current
from aiauv_pin.dynamics.transitions import transition_jacobians
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.derivatives import compiled_derivatives

pytest.importorskip("numba")

STEP = 1e-6


def _step(vehicle, q, v, thrusts, joint_torques, dt, method, current):
    fast = compiled_derivatives(vehicle)._fast  # the kernels (interpreted under NUMBA_DISABLE_JIT)
    tau = fast.thrust_matrix(q) @ thrusts
    tau[6:] += joint_torques
    return fast.step(q, v, tau, dt, method=method, current=current)


def _finite_difference_jacobians(vehicle, q, v, thrusts, torques, dt, method, current):
    model, nv = vehicle.model, vehicle.nv
    q0, _ = _step(vehicle, q, v, thrusts, torques, dt, method, current)

    def state(x):
        dq, dv = x[:nv], x[nv : 2 * nv]
        u = x[2 * nv :]
        q_next, v_next = _step(
            vehicle,
            pin.integrate(model, q, dq),
            v + dv,
            thrusts + u[: thrusts.size],
            torques + u[thrusts.size :],
            dt,
            method,
            current,
        )
        return np.concatenate((pin.difference(model, q0, q_next), v_next))

    size = 2 * nv + thrusts.size + torques.size
    columns = []
    for k in range(size):
        dx = np.zeros(size)
        dx[k] = STEP
        columns.append((state(dx) - state(-dx)) / (2 * STEP))
    jac = np.array(columns).T
    return jac[:, : 2 * nv], jac[:, 2 * nv :]


def _relative(exact, approx):
    return np.abs(exact - approx).max() / np.abs(exact).max()


@pytest.mark.parametrize("method", ["rk4", "euler"])
@pytest.mark.parametrize(
    "current",
    [
        None,
        np.array([0.2, -0.1, 0.05]),
        # the water's acceleration in the step Jacobians (issue 33)
        Current.tidal([0.2, -0.1, 0.05], [0.4, 0.3, -0.2], 5.0, 0.4),
    ],
    ids=["still", "current", "tidal"],
)
def test_transition_jacobians_match_central_differences(method, current, rng):
    vehicle = aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised"))
    q, v = random_state(vehicle.model, rng)
    thrusts = rng.uniform(-20, 20, len(vehicle.thruster_names))
    torques = rng.uniform(-5, 5, vehicle.nv - 6)
    dt = 0.05
    result = transition_jacobians(
        vehicle, q, v, thrusts, torques, dt=dt, method=method, current=current
    )
    q_next, v_next = _step(vehicle, q, v, thrusts, torques, dt, method, current)
    np.testing.assert_allclose(result.q_next, q_next, rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.v_next, v_next, rtol=1e-12, atol=1e-12)
    a_fd, b_fd = _finite_difference_jacobians(vehicle, q, v, thrusts, torques, dt, method, current)
    assert _relative(result.A, a_fd) < 1e-6
    assert _relative(result.B, b_fd) < 1e-6


def test_transition_rejects_bad_input(paper_vehicle):
    q, v = paper_vehicle.neutral_configuration(), np.zeros(paper_vehicle.nv)
    with pytest.raises(ArgumentError, match="unknown method"):
        transition_jacobians(paper_vehicle, q, v, dt=0.01, method="midpoint")
    with pytest.raises(ArgumentError, match="dt"):
        transition_jacobians(paper_vehicle, q, v, dt=-0.01)
    with pytest.raises(ArgumentError, match="thrusts"):
        transition_jacobians(paper_vehicle, q, v, np.zeros(3), dt=0.01)
