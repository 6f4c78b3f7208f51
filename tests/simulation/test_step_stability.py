"""The joint servo's largest stable step (aiauv_pin.simulation.step_stability): closed forms, the full
linearisation, and the warning of simulate, rollout and the command line; the warning of a sampled
loop that oscillates at every sample."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from aiauv_pin.scenario.definition import Scenario, run_scenario
from aiauv_pin.simulation.step_stability import (
    STEP_MARGIN,
    EveryStepOscillation,
    StepNearStabilityLimit,
    amplification,
    every_sample_oscillation,
    largest_stable_step,
    servo_step_limit,
)

#: Where RK4's stability region meets the negative real axis: the real root of
#: 1 + z + z^2/2 + z^3/6 + z^4/24 = -1 (Hairer and Wanner 1996, Sec. IV.2, Fig. 2.1).
RK4_REAL_LIMIT = 2.785293563405282


def one_joint(mass: float, stiffness: float, damping: float):
    return np.array([[1.0 / mass]]), np.array([stiffness]), np.array([damping])


@pytest.mark.parametrize(("mass", "stiffness", "damping"), [(0.3, 100.0, 50.0), (2.0, 400.0, 1.0)])
def test_euler_with_the_servo_implicit_has_no_limit(mass, stiffness, damping):
    # implicit Euler on m x'' + c x' + k x = 0 multiplies each mode by 1 / (1 - h lambda), of
    # modulus below 1 for Re(lambda) < 0 at every h (A-stability); the explicit servo's closed form
    # 2 h c/m + h^2 k/m < 4 would bound h at 0.0117 s and 0.0705 s here
    inverse_mass, k, c = one_joint(mass, stiffness, damping)
    lam = np.roots([mass, damping, stiffness])
    for h in np.geomspace(1e-4, 1e2, 25):
        g = amplification(inverse_mass, k, c, "euler", h)
        expected = np.max(np.abs(1.0 / (1.0 - h * lam)))
        assert np.max(np.abs(np.linalg.eigvals(g))) == pytest.approx(expected, rel=1e-9)
        assert expected < 1.0
    assert largest_stable_step(inverse_mass, k, c, "euler") == np.inf


def test_rk4_limit_of_an_overdamped_joint_is_the_real_axis_bound():
    mass, stiffness, damping = 0.3, 100.0, 50.0
    fastest = np.abs(np.roots([mass, damping, stiffness])).max()
    limit = largest_stable_step(*one_joint(mass, stiffness, damping), "rk4")
    assert limit == pytest.approx(RK4_REAL_LIMIT / fastest, rel=2e-6)


def test_amplification_is_one_step_of_each_method():
    rng = np.random.default_rng(3)
    root = rng.normal(size=(3, 3))
    inverse_mass = root @ root.T + 3.0 * np.eye(3)
    stiffness, damping = rng.uniform(1.0, 5.0, 3), rng.uniform(0.5, 2.0, 3)
    h = 0.05
    x = rng.normal(size=6)

    def acceleration(q, qd):
        return -inverse_mass @ (stiffness * q + damping * qd)

    q, qd = x[:3], x[3:]
    # the kernels' step: (M_q + h C + h^2 K) (qd' - qd) = h (-K q - C qd - h K qd), q' = q + h qd'
    # (aiauv_control.laws.paper_laws.joint_pd_implicit_terms)
    joint_mass = np.linalg.inv(inverse_mass)
    lhs = joint_mass + np.diag(h * damping + h * h * stiffness)
    qd_euler = qd + np.linalg.solve(
        lhs, h * (joint_mass @ acceleration(q, qd) - h * stiffness * qd)
    )
    euler = np.concatenate((q + h * qd_euler, qd_euler))
    assert amplification(inverse_mass, stiffness, damping, "euler", h) @ x == pytest.approx(euler)

    def f(state):
        return np.concatenate((state[3:], acceleration(state[:3], state[3:])))

    k1 = f(x)
    k2 = f(x + 0.5 * h * k1)
    k3 = f(x + 0.5 * h * k2)
    k4 = f(x + h * k3)
    rk4 = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    assert amplification(inverse_mass, stiffness, damping, "rk4", h) @ x == pytest.approx(rk4)

    # the midpoint method: both stages take the servo-implicit acceleration of a step h
    # (aiauv_pin.reference.integrators.midpoint_step with the dynamics aiauv_pin.simulate gives it)
    def implicit_acceleration(q, qd):
        return np.linalg.solve(lhs, joint_mass @ acceleration(q, qd) - h * stiffness * qd)

    qd_stage = qd + 0.5 * h * implicit_acceleration(q, qd)
    q_stage = q + 0.5 * h * qd_stage
    midpoint = np.concatenate((q + h * qd_stage, qd + h * implicit_acceleration(q_stage, qd_stage)))
    assert amplification(inverse_mass, stiffness, damping, "midpoint", h) @ x == pytest.approx(
        midpoint
    )


@pytest.mark.parametrize(("mass", "stiffness", "damping"), [(0.3, 100.0, 50.0), (2.0, 400.0, 1.0)])
def test_midpoint_with_the_servo_implicit_has_no_limit(mass, stiffness, damping):
    # the servo alone: every step is stable (the controller's coupling is not in this model; on the
    # paper's uniform vehicle the closed loop holds up to 0.025 s, see the module docstring)
    inverse_mass, k, c = one_joint(mass, stiffness, damping)
    for h in np.geomspace(1e-4, 1e2, 25):
        g = amplification(inverse_mass, k, c, "midpoint", h)
        assert np.max(np.abs(np.linalg.eigvals(g))) < 1.0
    assert largest_stable_step(inverse_mass, k, c, "midpoint") == np.inf


def test_no_servo_has_no_limit():
    assert largest_stable_step(np.eye(2), np.zeros(2), np.zeros(2), "euler") == np.inf


@pytest.fixture(scope="module")
def paper():
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.definition import Scenario, initial_state

    vehicle = loading.load_vehicle(loading.bundled_urdf("uniform"))
    scenario = Scenario(case="uniform")
    law = VehiclePathFollowing(
        vehicle, scenario.controller_gains, path=scenario.path_to_follow
    ).compiled()
    q0, v0 = initial_state(vehicle, scenario)
    return vehicle, law, q0, v0


def test_paper_servo_limits_agree_with_the_full_linearisation(paper):
    from aiauv_pin.dynamics.linear_model import linearize

    vehicle, law, q0, _ = paper
    servo = law.servo
    model = linearize(vehicle, joint_gains=(float(servo.stiffness[0]), float(servo.damping[0])))
    fastest = np.abs(np.linalg.eigvals(model.A).real).max()  # -189 1/s: the joint-8 servo mode
    euler = servo_step_limit(vehicle, q0, servo.stiffness, servo.damping, "euler")
    rk4 = servo_step_limit(vehicle, q0, servo.stiffness, servo.damping, "rk4")
    # the servo alone, at the start, against the whole vehicle's linear model at 0.5 m/s: the
    # fast mode is overdamped, so RK4's bound is that of a real eigenvalue
    assert rk4 == pytest.approx(RK4_REAL_LIMIT / fastest, rel=0.01)
    assert euler == np.inf


def test_simulate_warns_near_the_limit_only(paper):
    from aiauv_pin.simulation.fixed_step import simulate

    vehicle, law, q0, v0 = paper
    with pytest.warns(StepNearStabilityLimit, match=r"dt = 0\.012 s is 8\d% .* RK4"):
        simulate(vehicle, q0, v0, 0.024, 0.012, law, method="rk4")
    with warnings.catch_warnings():
        warnings.simplefilter("error", StepNearStabilityLimit)
        simulate(vehicle, q0, v0, 0.02, 0.01, law, method="rk4")  # 68 % of RK4's limit
        simulate(vehicle, q0, v0, 0.1, 0.05, law, method="euler")  # the servo implicit
        simulate(vehicle, q0, v0, 0.05, 0.025, None, method="rk4")  # no servo, no limit


def test_euler_beyond_the_explicit_servo_limit_stays_on_the_reference(paper):
    """The paper's run for 20 s by Euler at 0.02 s (1.9x the explicit servo's 0.0106 s) against
    RK4 at 2 ms: the servo implicit, the path stays within the first-order error (0.49 mm per ms
    of step on the 300 s run, i.e. about 1 cm here), no trace of the servo's -189 1/s mode."""
    from aiauv_pin.simulation.fixed_step import simulate

    vehicle, law, q0, v0 = paper
    runs = {}
    for method, dt in (("rk4", 0.002), ("euler", 0.02)):
        run = simulate(vehicle, q0, v0, 20.0, dt, law, method=method, log_every=round(0.04 / dt))
        runs[method] = run.info["p"]
    error = np.linalg.norm(runs["euler"] - runs["rk4"], axis=1).max()
    assert error < 0.015, error
    assert np.all(np.isfinite(runs["euler"]))


def test_rollout_warns_too(paper):
    from aiauv_pin.simulation.rollout import rollout

    vehicle, law, q0, v0 = paper
    with pytest.warns(StepNearStabilityLimit, match=f"take dt <= {STEP_MARGIN * 0.01478:.2g}"):
        rollout(vehicle, q0, v0, 0.024, 0.012, law, method="rk4", threads=1)


def test_command_line_warns_once_in_one_line(tmp_path):
    import subprocess
    import sys

    arguments = ["simulate", "--method", "rk4", "--dt", "0.012", "--duration", "0.06"]
    arguments += ["--no-html", "--quiet", "--out", str(tmp_path / "run")]
    done = subprocess.run(
        [sys.executable, "-m", "aiauv_pin.app.cli", *arguments],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if "largest stable step" in line]
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("aiauv: warning: dt = 0.012 s is 8")
    assert "Traceback" not in done.stderr


def test_every_sample_oscillation_of_closed_forms():
    k = np.arange(1000)
    # a constant, a ramp and a quadratic contribute nothing (their second differences cancel)
    assert every_sample_oscillation(np.full(1000, 0.3)) == pytest.approx(0.0, abs=1e-15)
    assert every_sample_oscillation(1e-3 * k) == pytest.approx(0.0, abs=1e-15)
    assert every_sample_oscillation(1e-6 * k**2) == pytest.approx(0.0, abs=1e-15)
    # an alternation of amplitude A on top of them gives A; the largest column counts
    signal = np.column_stack(
        (0.3 + 1e-3 * k, 0.3 + 1e-3 * k + 0.05 * (-1.0) ** k, np.sin(k / 50.0))
    )
    assert every_sample_oscillation(signal) == pytest.approx(0.05, rel=1e-9)
    # only a sustained one: an alternation that died out, or dies out within the window, is not
    # reported; one that holds or grows is
    decayed = np.where(k < 500, 0.05 * (-1.0) ** k, 0.0)
    assert every_sample_oscillation(decayed) == 0.0
    ringing = 0.05 * (-1.0) ** k * np.exp(-k / 20.0)
    assert every_sample_oscillation(ringing[:50]) == 0.0
    growing = 0.05 * (-1.0) ** k * np.exp(k / 20.0)
    assert every_sample_oscillation(growing[:50]) > 0.05  # at least where it starts
    assert every_sample_oscillation(np.zeros((1, 3))) == 0.0


def test_paper_scenario_warns_where_the_sampled_loop_oscillates(paper):
    """The midpoint method at 0.03 s on the uniform vehicle: the attitude law's loop through the
    joint servo oscillates at every step (module docstring); at 0.02 s it converges."""
    vehicle = paper[0]
    with pytest.warns(EveryStepOscillation, match=r"oscillate at every controller sample"):
        run_scenario(vehicle, Scenario(duration=60.0, dt=0.03, method="midpoint"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", EveryStepOscillation)
        result = run_scenario(vehicle, Scenario(duration=60.0, dt=0.02, method="midpoint"))
    assert every_sample_oscillation(result.trajectory.v[:, 6:]) < 1e-5


def test_an_unknown_method_is_refused_with_the_project_error():
    from aiauv_pin.errors import ArgumentError

    one = np.ones(1)
    with pytest.raises(ArgumentError, match="unknown method 'heun'"):
        amplification(np.eye(1), one, one, "heun", 0.01)
