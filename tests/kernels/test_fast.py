"""The compiled backend (aiauv_pin.kernels) against the Pinocchio reference (issue 5).

Every check compares the numba kernels with the Pinocchio path of the same vehicle on random
states, to 1e-9, on several vehicles: the paper's two cases, a single body with a full Fossen
block, and generated 5- and 13-module vehicles; with and without a current. The integrators are
checked against ``aiauv_pin.reference.integrators`` and the SE(3) operations against Pinocchio and an
independent series.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pinocchio as pin
import pytest
from conftest import generated_vehicle_table, random_state, single_body_urdf

import aiauv_pin
from aiauv_pin.builders.urdf_builder import build_urdf
from aiauv_pin.builders.vehicle_spec import spec_from_dict
from aiauv_pin.checks import consistency
from aiauv_pin.dynamics.joint_servo import JointServo
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.reference.integrators import INTEGRATORS

pytest.importorskip("numba")

from aiauv_pin.kernels import articulated_body as kernels
from aiauv_pin.kernels.evaluation import METHOD_CODES
from aiauv_pin.kernels.records import unsupported_reason

TOL = dict(rtol=1e-9, atol=1e-9)
CURRENTS = [None, np.array([0.3, -0.2, 0.15])]


def _load(name: str, tmp_path_factory, **options) -> Vehicle:
    if name in ("uniform", "stabilised"):
        return aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(name), **options)
    folder = tmp_path_factory.mktemp("fast")
    if name == "single_body":
        text = single_body_urdf()[0]
    else:
        n = int(name.removeprefix("generated_"))
        text = build_urdf(spec_from_dict(generated_vehicle_table(n, seed=n, side_thruster=True)))
    path = folder / f"{name}.urdf"
    path.write_text(text)
    return aiauv_pin.load_vehicle(path, **options)


VEHICLES = ["uniform", "stabilised", "single_body", "generated_5", "generated_13"]


@pytest.fixture(scope="module", params=VEHICLES)
def pair(request, tmp_path_factory):
    """(numba vehicle, Pinocchio vehicle) built from the same URDF."""
    fast = _load(request.param, tmp_path_factory)
    fast.backend = "numba"
    reference = _load(request.param, tmp_path_factory)
    reference.backend = "pinocchio"
    return fast, reference


# ---------------------------------------------------------------- dynamics
def assert_backends_agree(vehicle: Vehicle) -> None:
    """The shipped check (aiauv_pin.checks.consistency): accelerations in still water and in a current,
    g(q), B(q), the last hydrodynamic link's pose and twist at 4 random states, and a 0.2 s run, all
    within allclose(rtol=1e-9, atol=1e-9)."""
    result = consistency.check_backends_agree(vehicle, samples=4, current=CURRENTS[1])
    assert not result.skipped and result.passed, result.message()


def test_dynamics_and_kinematics_match_pinocchio(pair):
    fast, reference = pair
    assert fast.active_backend == "numba" and reference.active_backend == "pinocchio"
    assert_backends_agree(reference)


@pytest.mark.parametrize(
    "switches",
    [
        dict(added_mass=False),
        dict(damping=False),
        dict(restoring=False),
        dict(added_mass=False, damping=False, restoring=False),
    ],
    ids=["no_added_mass", "no_damping", "no_restoring", "dry"],
)
def test_fluid_switches_match_pinocchio(switches, tmp_path_factory):
    assert_backends_agree(_load("stabilised", tmp_path_factory, **switches))


def test_joint_servo_inside_kernel_matches_python(pair, rng):
    fast, reference = pair
    n = reference.nv - 6
    servo = JointServo(
        rng.uniform(5.0, 50.0, n), rng.uniform(1.0, 20.0, n), rng.uniform(-0.5, 0.5, n)
    )
    q, v = random_state(reference.model, rng)
    tau = rng.normal(size=reference.nv)
    expected = reference.acceleration(q, v, tau + servo.torque(reference, q, v))
    got = fast.fast.acceleration(q, v, tau, servo=servo.packed())
    np.testing.assert_allclose(got, expected, **TOL)


# ---------------------------------------------------------------- Lie group and integrators
def _right_jacobian_series(xi: np.ndarray) -> np.ndarray:
    """``J_r(xi) = sum_k (-ad_xi)^k / (k + 1)!`` (Barfoot 2017, eq. (7.95)), exact for small xi."""

    def skew(a):
        return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])

    ad = np.zeros((6, 6))
    ad[:3, :3] = ad[3:, 3:] = skew(xi[3:])
    ad[:3, 3:] = skew(xi[:3])
    jac, term = np.zeros((6, 6)), np.eye(6)
    for k in range(40):
        jac += term / math.factorial(k + 1)
        term = term @ (-ad)
    return jac


def test_integrate_and_tangent_rate_match_pinocchio(paper_vehicle, rng):
    model = paper_vehicle.model
    for scale in (1.5, 0.3, 0.02):
        q, _ = random_state(model, rng)
        xi = scale * rng.normal(size=model.nv)
        out = np.empty(model.nq)
        kernels.integrate(q, xi, out)
        np.testing.assert_allclose(out, pin.integrate(model, q, xi), rtol=0, atol=1e-12)
        velocity = rng.normal(size=model.nv)
        rate = np.empty(model.nv)
        kernels.tangent_rate(xi, velocity, rate)
        jacobian = pin.dIntegrate(model, q, xi, pin.ArgumentPosition.ARG1)
        np.testing.assert_allclose(jacobian @ rate, velocity, rtol=0, atol=1e-11)


def test_tangent_rate_exact_for_small_rotations(rng):
    """Tiny rotations (RK4 stages): against the exponential series (Pinocchio's own Jexp6 is only
    good to ~1e-8 in part of that range)."""
    for exponent in (-7, -5, -3, -1.5, -1.01, -0.99):
        xi = rng.normal(size=6) * 10.0**exponent
        velocity = rng.normal(size=6)
        rate = np.empty(6)
        kernels.tangent_rate(xi, velocity, rate)
        np.testing.assert_allclose(_right_jacobian_series(xi) @ rate, velocity, rtol=0, atol=1e-13)


def test_every_compiled_method_has_its_reference():
    """The reference integrators (:mod:`aiauv_pin.reference.integrators`) and the compiled ones
    are the same methods, pinned one by one below."""
    assert set(INTEGRATORS) == set(METHOD_CODES)


@pytest.mark.parametrize("method", ["rk4", "euler", "midpoint"])
def test_step_matches_reference_integrator(pair, method, rng):
    fast, reference = pair
    q, v = random_state(reference.model, rng)
    tau = rng.normal(size=reference.nv)
    current = CURRENTS[1]
    step = INTEGRATORS[method]
    expected = step(
        reference.model, lambda qq, vv: reference.acceleration(qq, vv, tau, current), q, v, 0.02
    )
    got = fast.fast.step(q, v, tau, 0.02, method=method, current=current)
    np.testing.assert_allclose(got[0], expected[0], **TOL)
    np.testing.assert_allclose(got[1], expected[1], **TOL)


@pytest.mark.parametrize("dt", [0.004, 0.05])
def test_euler_step_with_the_servo_implicit_matches_the_reference(pair, dt, rng):
    """The kernels fold the servo's implicit terms into the articulated-body pass (an armature on
    each joint); the reference solves ``(M + A) a' = M a - h k_p q_dot`` with Pinocchio's mass
    matrix (JointServo.implicit_acceleration). Stiff gains: 0.05 s is far beyond the explicit
    servo's stable step on these links."""
    fast, reference = pair
    n = reference.nv - 6
    if n == 0:
        pytest.skip("no joints")
    q, v = random_state(reference.model, rng)
    tau = rng.normal(size=reference.nv)
    servo = JointServo(
        rng.uniform(50.0, 400.0, n), rng.uniform(5.0, 60.0, n), rng.normal(scale=0.3, size=n)
    )
    current = CURRENTS[1]

    def dynamics(qq, vv):
        explicit = reference.acceleration(qq, vv, tau + servo.torque(reference, qq, vv), current)
        return servo.implicit_acceleration(reference, qq, vv, explicit, dt)

    expected = INTEGRATORS["euler"](reference.model, dynamics, q, v, dt)
    got = fast.fast.step(q, v, tau, dt, method="euler", current=current, servo=servo.packed())
    np.testing.assert_allclose(got[0], expected[0], **TOL)
    np.testing.assert_allclose(got[1], expected[1], **TOL)
    # and it is not the explicit servo's step
    explicit = v + dt * reference.acceleration(q, v, tau + servo.torque(reference, q, v), current)
    assert not np.allclose(got[1], explicit, rtol=1e-3)


# ---------------------------------------------------------------- simulate
def _controller(vehicle):
    def control(t, q, v):
        tau = np.zeros(vehicle.nv)
        tau[:6] = -0.5 * v[:6] + np.array([3.0, 0.0, 0.5, 0.0, 0.1, 0.0]) * math.cos(t)
        return tau, {"t_squared": t * t}

    return control


@pytest.mark.parametrize("control_period", [None, 0.05])
def test_simulate_compiled_loop_matches_pinocchio(control_period, rng, tmp_path_factory):
    fast = _load("generated_5", tmp_path_factory)
    fast.backend = "numba"
    reference = _load("generated_5", tmp_path_factory)
    reference.backend = "pinocchio"
    q0, v0 = random_state(reference.model, rng, speed=0.2)
    runs = []
    for vehicle in (fast, reference):
        servo = JointServo.uniform(vehicle.nv - 6, 2.0, 0.2)
        servo.references[:] = 0.1
        runs.append(
            aiauv_pin.simulate(
                vehicle,
                q0,
                v0,
                0.4,
                0.01,
                _controller(vehicle),
                current=CURRENTS[1],
                servo=servo,
                log_every=3,
                control_period=control_period,
            )
        )
    got, expected = runs
    np.testing.assert_array_equal(got.t, expected.t)
    np.testing.assert_allclose(got.q, expected.q, **TOL)
    np.testing.assert_allclose(got.v, expected.v, **TOL)
    np.testing.assert_allclose(got.tau, expected.tau, **TOL)
    np.testing.assert_allclose(got.info["t_squared"], expected.info["t_squared"], **TOL)
    if control_period is not None:
        # held output: the row at t = 0.03 s repeats the call at t = 0
        assert got.info["t_squared"][1] == 0.0


def test_control_period_must_be_a_multiple_of_dt(paper_vehicle):
    q, v = paper_vehicle.neutral_configuration(), np.zeros(paper_vehicle.nv)
    with pytest.raises(ValueError, match="control_period") as error:
        aiauv_pin.simulate(paper_vehicle, q, v, 0.1, 0.01, control_period=0.025)
    assert "\n" not in str(error.value)


# ---------------------------------------------------------------- fallbacks
def test_falls_back_to_pinocchio_without_numba(monkeypatch, rng):
    monkeypatch.setitem(sys.modules, "aiauv_pin.kernels.evaluation", None)
    vehicle = aiauv_pin.load_vehicle()
    vehicle.backend = "auto"
    assert vehicle.active_backend == "pinocchio" and vehicle.fast is None
    with pytest.raises(ValueError, match="numba backend unavailable") as error:
        vehicle.backend = "numba"
    assert "\n" not in str(error.value)
    vehicle.backend = "pinocchio"
    q, v = random_state(vehicle.model, rng)
    trajectory = aiauv_pin.simulate(vehicle, q, v, 0.05, 0.01, servo=JointServo.uniform(8, 1, 1))
    assert trajectory.status == "complete"


def test_unsupported_joint_falls_back(rng):
    model = pin.Model()
    root = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "root")
    model.appendBodyToJoint(root, pin.Inertia.Random(), pin.SE3.Identity())
    ball = model.addJoint(root, pin.JointModelSpherical(), pin.SE3.Random(), "ball")
    model.appendBodyToJoint(ball, pin.Inertia.Random(), pin.SE3.Identity())
    assert "unsupported type" in unsupported_reason(model)
    from aiauv_hydro.spec import HydroSpec

    vehicle = Vehicle(model, HydroSpec(), backend="auto")
    assert vehicle.active_backend == "pinocchio"
    with pytest.raises(ValueError, match="numba backend unavailable"):
        Vehicle(model, HydroSpec(), backend="numba")


def test_unknown_backend_is_one_line_error(paper_vehicle):
    with pytest.raises(ValueError, match="unknown backend 'cuda'"):
        paper_vehicle.backend = "cuda"


def test_python_entry_checks_shapes(paper_vehicle):
    """FastModel calls the compiled entry point without numba's type checks, so it checks the
    shapes itself (a wrong shape would otherwise read or write out of bounds)."""
    fast = paper_vehicle.fast
    if fast is None:
        pytest.skip("numba backend unavailable")
    q, v = paper_vehicle.neutral_configuration(), np.zeros(paper_vehicle.nv)
    first = fast.acceleration(q, v, np.zeros(paper_vehicle.nv))
    np.testing.assert_array_equal(fast.acceleration(q, v, np.zeros(paper_vehicle.nv)), first)
    with pytest.raises(aiauv_pin.errors.ArgumentError, match="tau must have shape"):
        fast.acceleration(q, v, np.zeros(paper_vehicle.nv + 1))
    with pytest.raises(aiauv_pin.errors.ArgumentError, match=r"q must have shape \(\d+,\), got"):
        fast.acceleration(q[:-1], v, np.zeros(paper_vehicle.nv))


def test_frame_positions_of_a_run_match_the_pinocchio_frame(paper_vehicle, rng):
    """``FastModel.frame_positions`` (a logged run's end-effector in one compiled call) against
    Pinocchio's frame placement, configuration by configuration."""
    if paper_vehicle.fast is None:
        pytest.skip("compiled backend unavailable")
    frame = paper_vehicle.frame_id("end_effector")
    configurations = []
    for _ in range(12):
        q = paper_vehicle.neutral_configuration()
        q[:3] = rng.normal(size=3)
        quaternion = rng.normal(size=4)
        q[3:7] = quaternion / np.linalg.norm(quaternion)
        q[7:] = rng.uniform(-1.0, 1.0, paper_vehicle.nv - 6)
        configurations.append(q)
    positions = paper_vehicle.fast.frame_positions(np.array(configurations), frame)
    for q, p in zip(configurations, positions, strict=True):
        expected = paper_vehicle.frame_placement(q, "end_effector").translation
        np.testing.assert_allclose(p, expected, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="configurations must have shape"):
        paper_vehicle.fast.frame_positions(np.zeros((3, 4)), frame)


# ---------------------------------------------------------------- one builder, one state rule
def test_the_compiled_model_is_built_from_the_description_alone(paper_vehicle, rng):
    """:func:`aiauv_pin.model.assembly.compiled_model` builds ``Vehicle.fast`` from the Pinocchio
    model and the packed description: no Vehicle is needed, and the result is the vehicle's."""
    from aiauv_pin.model.assembly import assemble, compiled_model

    vehicle = paper_vehicle
    parts = assemble(vehicle.model, vehicle.hydro, added_mass=True, damping=True, restoring=True)
    fast = compiled_model(vehicle.model, parts)
    assert vehicle.fast is not None and vehicle.packed_model() is vehicle.fast.model
    q, v = random_state(vehicle.model, rng)
    tau = rng.normal(size=vehicle.nv)
    assert np.array_equal(fast.acceleration(q, v, tau), vehicle.fast.acceleration(q, v, tau))
    frame = vehicle.frame_id("end_effector")
    for got, expected in zip(fast.frame(frame), vehicle.fast.frame(frame), strict=True):
        assert np.array_equal(got, expected)


@pytest.mark.parametrize("scale", [1.0, 1.0 + 1e-15, 1.0 + 1e-12, 1.0 + 5e-7, 1.0 + 2e-6])
def test_python_and_compiled_state_checks_apply_one_quaternion_rule(paper_vehicle, scale):
    """:func:`aiauv_pin._internal.array_checks.configuration` and
    :func:`aiauv_pin.kernels.handle.state_verdict` (both through
    :func:`aiauv_hydro.numerics.spatial.unit_quaternion_check`): same verdict, same bits."""
    from aiauv_pin._internal.array_checks import configuration
    from aiauv_pin.errors import ArgumentError
    from aiauv_pin.kernels.handle import STATE_OK, STATE_QUATERNION_NOT_UNIT, state_verdict

    nq, nv = paper_vehicle.nq, paper_vehicle.nv
    q = paper_vehicle.neutral_configuration()
    q[3:7] = np.array([0.1, 0.2, 0.3, 0.9]) / np.linalg.norm([0.1, 0.2, 0.3, 0.9]) * scale
    q_unit = np.full(nq, np.nan)
    verdict, normalised = state_verdict(0.0, q, np.zeros(nv), np.zeros(nv), nq, nv, q_unit)
    try:
        checked = configuration(q, nq)
    except ArgumentError:
        assert verdict == STATE_QUATERNION_NOT_UNIT
        return
    assert verdict == STATE_OK
    assert np.array_equal(q_unit if normalised else q, checked)
    assert normalised == (checked is not q)


@pytest.mark.parametrize("dt", [1e308, 1e200])
@pytest.mark.parametrize("path", ["fast", "with a current", "euler"])
def test_a_step_that_overflows_is_refused_in_one_line(dt, path):
    """Issue 29's campaign: ``fast.step(..., dt=1e308)`` returned NaN; a step whose result is not
    finite raises :class:`NumericalError` naming ``dt``, on the compiled fast path and the checked
    path alike."""
    from aiauv_pin.errors import NumericalError

    vehicle = aiauv_pin.load_vehicle()
    fast = vehicle.fast
    if fast is None:
        pytest.skip(vehicle.fallback_reason)
    q, v = vehicle.neutral_configuration(), np.full(vehicle.nv, 0.3)
    tau = np.ones(vehicle.nv)
    options = {
        "with a current": {"current": np.array([0.2, 0.0, 0.0])},
        "euler": {"method": "euler"},
    }
    with pytest.raises(NumericalError, match=r"non-finite state .* dt = 1e\+(308|200) s") as error:
        fast.step(q, v, tau, dt, **options.get(path, {}))
    assert "\n" not in str(error.value)
    q_next, v_next = fast.step(q, v, tau, 0.01, **options.get(path, {}))  # a usual step still works
    assert np.all(np.isfinite(q_next)) and np.all(np.isfinite(v_next))
