"""Section 3 control laws and their composition.

Joint references (eq. 22), base angles (eq. 23), joint PD with hydrostatic compensation (eq. 24),
surge PI with anti-windup (eq. 25), gains, and the composed path-following controller.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aiauv_control.joint_control import joint_torques
from aiauv_control.joint_references import (
    JointLayoutWarning,
    base_angles,
    check_joint_axes,
    joint_references,
)
from aiauv_control.path_following import (
    PathFollowingCommand,
    PathFollowingController,
    PathFollowingGains,
    PathFollowingMeasurement,
)
from aiauv_control.reduced_attitude import (
    minimal_rotation,
    minimal_rotation_rate_correction,
    reduced_attitude_torque,
)
from aiauv_control.surge import SurgePIController

PAPER_AXES = ("z", "y", "z", "y", "z", "y", "z", "y")  # joints 1..8, tail to head (Sec. 4.1)
SURGE_THRUSTERS = (2, 3)  # the two X thrusters of link 5 in thrust order (Z, Y, X, X, Z, Y, Z)
N_THRUSTERS = 7


# --------------------------------------------------------------------------------------------------
# joint references (eq. 22)
# --------------------------------------------------------------------------------------------------
def test_joint_references_closed_form_for_the_paper_layout():
    alpha, q0 = 0.7, np.array([0.2, -0.3])  # (q_y0, q_z0)
    q_ref = joint_references(q0, PAPER_AXES, alpha, q_max=1.0)
    decay = np.exp(-alpha * np.arange(4))
    np.testing.assert_allclose(q_ref[0::2], -0.3 * decay, rtol=1e-15)  # z-joints 1, 3, 5, 7
    np.testing.assert_allclose(q_ref[1::2], 0.2 * decay, rtol=1e-15)  # y-joints 2, 4, 6, 8


def test_joint_references_any_layout_and_size():
    axes = ("y", "y", "z", "y", "z", "z")
    q_ref = joint_references([0.1, 0.4], axes, alpha=0.5, q_max=1.0)
    expected = [
        0.1,
        0.1 * np.exp(-0.5),
        0.4,
        0.1 * np.exp(-1.0),
        0.4 * np.exp(-0.5),
        0.4 * np.exp(-1),
    ]
    np.testing.assert_allclose(q_ref, expected, rtol=1e-15)
    np.testing.assert_allclose(joint_references([0.3, -0.2], ("Z", "Y"), 1.0, 1.0), [-0.2, 0.3])


def test_joint_references_saturate_the_base_angles_and_keep_the_shape():
    q_max = np.deg2rad(30.0)
    q_ref = joint_references([2.0, -5.0], PAPER_AXES, alpha=0.7, q_max=q_max)
    decay = np.exp(-0.7 * np.arange(4))
    np.testing.assert_allclose(q_ref[1::2], q_max * decay, rtol=1e-15)
    np.testing.assert_allclose(q_ref[0::2], -q_max * decay, rtol=1e-15)
    assert np.max(np.abs(q_ref)) == pytest.approx(q_max)


def test_joint_references_for_unequal_signed_and_one_axis_layouts():
    """Issue 31: any numbers of pitch and yaw joints in any order; a joint about a negative axis
    gets the opposite sign, a joint about the body axis x is held straight; each axis's joints get
    eq. (22)'s pattern counted from the tail."""
    alpha, q0 = 0.4, np.array([0.15, -0.25])  # (q_y0, q_z0)
    axes = ("z", "z", "y", "-z", "y", "x")  # three yaw (one negative), two pitch, one roll
    q_ref = joint_references(q0, axes, alpha, q_max=1.0)
    expected = [
        -0.25,
        -0.25 * np.exp(-alpha),
        0.15,
        0.25 * np.exp(-2 * alpha),
        0.15 * np.exp(-alpha),
        0.0,
    ]
    np.testing.assert_allclose(q_ref, expected, rtol=1e-15, atol=0.0)
    assert check_joint_axes(axes) == ("+z", "+z", "+y", "-z", "+y", "+x")
    with pytest.warns(JointLayoutWarning, match=r"yaw \(z\) only"):
        planar = check_joint_axes(("z",) * 6)
    np.testing.assert_allclose(
        joint_references(q0, planar, alpha, 1.0), -0.25 * np.exp(-alpha * np.arange(6)), rtol=1e-15
    )
    with pytest.warns(JointLayoutWarning, match=r"pitch \(y\) only"):
        check_joint_axes(("y", "x", "-y"))


def test_the_paper_layout_gives_no_warning():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_joint_axes(PAPER_AXES) == tuple("+" + a for a in PAPER_AXES)


@pytest.mark.parametrize(
    ("axes", "message"),
    [
        ((), "cannot be curved to steer: the vehicle has no joints"),
        (("x", "-x"), "cannot be curved to steer: the vehicle has joints about the body axis x"),
        (("z", "w"), "unknown"),
        (("z", "--y"), "unknown"),
        ("zy", "string"),
    ],
)
def test_bad_joint_layouts(axes, message):
    with pytest.raises(ValueError, match=message) as error:
        check_joint_axes(axes)
    assert "\n" not in str(error.value)


def test_bad_joint_reference_parameters():
    for kwargs, message in (
        ({"alpha": 0.0}, "alpha"),
        ({"q_max": -0.1}, "q_max"),
        ({"base_angles": [0.1, 0.2, 0.3]}, "base_angles"),
    ):
        arguments = {
            "base_angles": [0.1, 0.2],
            "joint_axes": PAPER_AXES,
            "alpha": 0.7,
            "q_max": 0.5,
        }
        with pytest.raises(ValueError, match=message):
            joint_references(**{**arguments, **kwargs})


# --------------------------------------------------------------------------------------------------
# base angles (eq. 23)
# --------------------------------------------------------------------------------------------------
def test_base_angles_are_eq9_with_unit_inertia_and_no_moments():
    rng = np.random.default_rng(11)
    for _ in range(5):
        R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
        omega = rng.normal(size=3)
        x = rng.normal(size=3)
        x /= np.linalg.norm(x)
        x_dot = np.cross(rng.normal(size=3), x)
        x_ddot = rng.normal(size=3)
        for feedforward in ("exact", "paper"):
            q0 = base_angles(R, omega, x, x_dot, x_ddot, 2.0, 19.0, feedforward=feedforward)
            u = reduced_attitude_torque(
                R,
                omega,
                x,
                x_dot,
                x_ddot,
                np.eye(3),
                np.zeros(3),
                2.0,
                19.0,
                feedforward=feedforward,
            )
            np.testing.assert_array_equal(q0, u)


def test_base_angles_turn_towards_the_reference():
    """Pointing along x, reference to the left: q_z0 = +k_P angle (yaw left); reference up:
    q_y0 = -k_P angle (a positive rotation about y pitches the nose down)."""
    angle = 0.2
    for axis, index, sign in (([0.0, 0.0, 1.0], 1, -1.0), ([0.0, 1.0, 0.0], 0, 1.0)):
        x = Rotation.from_rotvec(-sign * angle * np.array(axis)).as_matrix()[:, 0]
        q0 = base_angles(np.eye(3), np.zeros(3), x, np.zeros(3), np.zeros(3), 2.0, 19.0)
        assert q0[index] == pytest.approx(-sign * 2.0 * angle, rel=1e-12)
        assert q0[1 - index] == pytest.approx(0.0, abs=1e-15)


# --------------------------------------------------------------------------------------------------
# joint PD with hydrostatic compensation (eq. 24)
# --------------------------------------------------------------------------------------------------
def test_joint_torque_closed_form():
    q, q_dot, q_ref, g_q = [0.1, -0.2], [0.3, 0.0], [0.0, 0.1], [1.5, -2.0]
    tau = joint_torques(q, q_dot, q_ref, g_q, k_qp=30.0, k_qd=50.0)
    np.testing.assert_allclose(tau, [-3.0 - 15.0 + 1.5, 9.0 - 2.0], rtol=1e-15)


def test_hydrostatic_compensation_removes_the_steady_state_error():
    """One joint with inertia I, damping d and a left-hand-side hydrostatic term g(q) = K sin(q):
    I q_ddot + d q_dot + g(q) = tau. With tau of eq. (24) (g_q added) it settles exactly at q*; with
    g_q left out it settles where k_qP (q* - q) = K sin(q)."""
    inertia, damping, stiffness, q_star = 0.5, 2.0, 20.0, 0.4

    def settle(compensate: bool) -> float:
        q, q_dot, dt = 0.0, 0.0, 5e-3
        for _ in range(12000):
            g = stiffness * np.sin(q)
            tau = joint_torques([q], [q_dot], [q_star], [g if compensate else 0.0], 30.0, 50.0)[0]
            q_ddot = (tau - damping * q_dot - g) / inertia
            q_dot += dt * q_ddot  # semi-implicit Euler
            q += dt * q_dot
        return q

    assert settle(True) == pytest.approx(q_star, abs=1e-10)
    uncompensated = settle(False)
    assert 30.0 * (q_star - uncompensated) == pytest.approx(
        stiffness * np.sin(uncompensated), abs=1e-6
    )
    assert q_star - uncompensated > 0.1


def test_joint_torque_bad_inputs():
    with pytest.raises(ValueError, match="joint_velocities"):
        joint_torques([0.0, 0.0], [0.0], [0.0, 0.0], [0.0, 0.0], 30.0, 50.0)
    with pytest.raises(ValueError, match="k_qp"):
        joint_torques([0.0], [0.0], [0.0], [0.0], -1.0, 50.0)


# --------------------------------------------------------------------------------------------------
# surge PI (eq. 25)
# --------------------------------------------------------------------------------------------------
MASS, DRAG, N_SURGE, DT_SURGE = 120.0, 40.0, 2, 0.05


def run_surge(pi: SurgePIController, u0: float, t_end: float, drag=DRAG):
    """Plant m du/dt = -d u + n T (exact step response over each zero-order-hold interval)."""
    u, history = u0, []
    decay = np.exp(-drag / MASS * DT_SURGE)
    for k in range(round(t_end / DT_SURGE)):
        thrust = pi.update(k * DT_SURGE, u)
        history.append((k * DT_SURGE, u, thrust, pi.integral))
        u_inf = N_SURGE * thrust / drag
        u = u_inf + (u - u_inf) * decay
    return np.array(history)


def test_surge_pi_reaches_zero_steady_state_error():
    pi = SurgePIController(k_p=100.0, k_i=5.0, u_d=0.5, max_thrust=50.0)
    history = run_surge(pi, u0=0.0, t_end=500.0)
    _, u, thrust, integral = history.T
    assert u[-1] == pytest.approx(0.5, abs=1e-6)
    assert thrust[-1] == pytest.approx(DRAG * 0.5 / N_SURGE, abs=1e-4)  # holds -d u_d with n T
    # The integral term supplies that thrust: -k_I * integral = d u_d / n.
    assert -5.0 * integral[-1] == pytest.approx(DRAG * 0.5 / N_SURGE, abs=1e-3)


def test_surge_pi_does_not_wind_up_while_saturated():
    """At a 5 N limit the output saturates from the start. The integral stays frozen at 0 while the
    thruster is saturated and too slow, so the speed approaches u_d with no overshoot beyond what a
    pure P response gives."""
    pi = SurgePIController(k_p=100.0, k_i=5.0, u_d=0.5, max_thrust=5.0)
    history = run_surge(pi, u0=0.0, t_end=300.0, drag=15.0)
    _, u, thrust, integral = history.T
    saturated = thrust >= 5.0
    assert saturated[:20].all()  # the first second at least
    # Frozen while saturated (the integral of the held error is skipped on those intervals).
    start_of_unsaturated = np.argmax(~saturated)
    np.testing.assert_array_equal(integral[: start_of_unsaturated + 1], 0.0)
    assert np.max(u) < 0.5 + 1e-3
    assert u[-1] == pytest.approx(0.5, abs=1e-5)


def test_surge_pi_integral_stays_frozen_when_the_speed_is_unreachable():
    """If u_d is above the top speed at the thrust limit, the integral stays at zero however long it
    runs (no wind-up), and the controller leaves the limit as soon as the error changes sign."""
    pi = SurgePIController(k_p=100.0, k_i=5.0, u_d=2.0, max_thrust=5.0)
    history = run_surge(pi, u0=0.0, t_end=100.0, drag=15.0)
    _, u, thrust, integral = history.T
    np.testing.assert_array_equal(thrust, 5.0)
    np.testing.assert_array_equal(integral, 0.0)
    assert u[-1] == pytest.approx(N_SURGE * 5.0 / 15.0, rel=1e-3)
    # Once the demand drops (slower target), the controller leaves the limit at once.
    pi.u_d = 0.3
    assert pi.update(100.0, u[-1]) < 0.0


def test_surge_integrator_zero_order_hold_and_reset():
    pi = SurgePIController(k_p=100.0, k_i=5.0, u_d=0.5, max_thrust=50.0)
    assert pi.update(3.0, 0.3) == pytest.approx(20.0)  # first call integrates nothing
    assert pi.update(3.1, 0.4) == pytest.approx(10.0 + 5.0 * 0.2 * 0.1)  # held error -0.2 for 0.1 s
    assert pi.integral == pytest.approx(-0.02)
    assert pi.update(3.1, 0.4) == pytest.approx(10.0 + 5.0 * 0.02)  # zero elapsed time
    with pytest.raises(ValueError, match="backwards"):
        pi.update(3.0, 0.4)
    pi.reset()
    assert pi.integral == 0.0
    assert pi.update(0.0, 0.4) == pytest.approx(10.0)


def test_surge_pi_bad_parameters():
    with pytest.raises(ValueError, match="max_thrust"):
        SurgePIController(100.0, 5.0, 0.5, 0.0)
    with pytest.raises(ValueError, match="k_1i"):
        SurgePIController(100.0, -5.0, 0.5, 50.0)


# --------------------------------------------------------------------------------------------------
# gains
# --------------------------------------------------------------------------------------------------
def test_paper_gains():
    gains = PathFollowingGains()
    assert (gains.u_d, gains.k_e, gains.alpha, gains.k_p, gains.k_d) == (0.5, 0.05, 0.7, 2.0, 19.0)
    assert (gains.k_qp, gains.k_qd, gains.k_1p, gains.k_1i) == (30.0, 50.0, 100.0, 5.0)
    assert gains.feedforward == "exact"
    assert 0.0 < gains.q_max < np.deg2rad(65.0)
    assert PathFollowingGains.uniform() == gains
    assert PathFollowingGains.stabilised().k_d == 12.0
    assert PathFollowingGains.for_case("stabilised", feedforward="paper").feedforward == "paper"
    assert PathFollowingGains(u_d=1.0).k_e == pytest.approx(0.1)  # k_e = u_d / 10 by default
    assert PathFollowingGains(k_e=(0.05, 0.1)).k_e == (0.05, 0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        gains.k_p = 3.0  # type: ignore[misc]


@pytest.mark.parametrize(
    "change",
    [
        {"u_d": 0.0},
        {"k_e": 0.0},
        {"k_e": (0.05, -0.1)},
        {"alpha": -0.7},
        {"k_p": float("nan")},
        {"k_d": 0.0},
        {"k_qd": -1.0},
        {"q_max": 4.0},
        {"feedforward": "printed"},
        {"k_1p": "fast"},
    ],
)
def test_bad_gains_raise_one_line_errors(change):
    with pytest.raises(ValueError) as error:
        PathFollowingGains(**change)
    assert "\n" not in str(error.value)
    assert next(iter(change)) in str(error.value)


def test_unknown_case():
    with pytest.raises(ValueError, match="case"):
        PathFollowingGains.for_case("heavy")


# --------------------------------------------------------------------------------------------------
# composed controller
# --------------------------------------------------------------------------------------------------
def make_controller(**gains) -> PathFollowingController:
    return PathFollowingController(
        PAPER_AXES, SURGE_THRUSTERS, N_THRUSTERS, 50.0, PathFollowingGains(**gains)
    )


def measurement(
    position=(0.0, 0.0, 0.0),
    velocity=(0.5, 0.0, 0.0),
    rotation=None,
    omega=(0.0, 0.0, 0.0),
    q=None,
    q_dot=None,
    g_q=None,
    surge=0.5,
    n=8,
) -> PathFollowingMeasurement:
    return PathFollowingMeasurement(
        position_in_world=np.array(position, dtype=float),
        velocity_in_world=np.array(velocity, dtype=float),
        acceleration_in_world=np.zeros(3),
        rotation_to_world=np.eye(3) if rotation is None else rotation,
        angular_velocity_in_ee=np.array(omega, dtype=float),
        joint_positions=np.zeros(n) if q is None else q,
        joint_velocities=np.zeros(n) if q_dot is None else q_dot,
        joint_hydrostatic_forces=np.zeros(n) if g_q is None else g_q,
        surge_velocity=surge,
    )


def test_on_the_path_at_speed_only_the_hydrostatic_torques_remain():
    g_q = np.linspace(-1.0, 1.0, 8)
    command = make_controller().command(0.0, measurement(g_q=g_q))
    assert isinstance(command, PathFollowingCommand)
    assert command.phi_tilde == 0.0
    np.testing.assert_array_equal(command.base_angles, np.zeros(2))
    np.testing.assert_array_equal(command.joint_references, np.zeros(8))
    np.testing.assert_array_equal(command.joint_torques, g_q)
    np.testing.assert_array_equal(command.thrusts, np.zeros(N_THRUSTERS))
    np.testing.assert_array_equal(command.x_ref, [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(command.pointing_direction, [1.0, 0.0, 0.0])


def test_cross_track_offset_bends_the_z_joints_towards_the_path():
    """Offset p_y > 0, pointing and moving along x: phi = atan(k_e p_y / u_d), q_z0 = -k_P phi,
    z-joint references exp(-alpha (j-1)) q_z0, y-joints straight; torques -k_qP (q - q*)."""
    p_y = 2.0  # 2 phi = 0.39 rad, below q_max
    controller = make_controller()
    command = controller.command(0.0, measurement(position=(1.0, p_y, 0.0)))
    phi = np.arctan(0.05 * p_y / 0.5)
    assert command.phi_tilde == pytest.approx(phi, rel=1e-12)
    np.testing.assert_allclose(command.base_angles, [0.0, -2.0 * phi], atol=1e-14)
    decay = np.exp(-0.7 * np.arange(4))
    np.testing.assert_allclose(command.joint_references[0::2], -2.0 * phi * decay, rtol=1e-12)
    np.testing.assert_allclose(command.joint_references[1::2], 0.0, atol=1e-14)
    np.testing.assert_allclose(command.joint_torques, 30.0 * command.joint_references, rtol=1e-12)
    np.testing.assert_allclose(command.x_ref_dot, 0.0, atol=1e-15)
    np.testing.assert_allclose(command.omega_tilde, 0.0, atol=1e-15)


def test_large_offset_saturates_the_references():
    command = make_controller().command(0.0, measurement(position=(0.0, -40.0, 25.0)))
    q_max = PathFollowingGains().q_max
    assert np.max(np.abs(command.base_angles)) > q_max
    assert np.max(np.abs(command.joint_references)) == pytest.approx(q_max)


def test_only_the_surge_thrusters_push_with_equal_thrust():
    controller = PathFollowingController(
        PAPER_AXES, SURGE_THRUSTERS, N_THRUSTERS, [50, 50, 30, 40, 50, 50, 50], PathFollowingGains()
    )
    command = controller.command(0.0, measurement(position=(0.0, 2.0, -1.0), surge=0.1))
    others = np.delete(command.thrusts, SURGE_THRUSTERS)
    np.testing.assert_array_equal(others, 0.0)
    np.testing.assert_array_equal(command.thrusts[list(SURGE_THRUSTERS)], [30.0, 30.0])  # min limit


def test_surge_integrator_advances_between_calls_and_resets():
    controller = make_controller()
    first = controller.command(10.0, measurement(surge=0.3))
    second = controller.command(10.5, measurement(surge=0.3))
    assert first.thrusts[2] == pytest.approx(20.0)
    assert second.surge_integral == pytest.approx(-0.1)
    assert second.thrusts[2] == pytest.approx(20.0 + 5.0 * 0.1)
    controller.reset()
    assert controller.command(0.0, measurement(surge=0.3)).thrusts[2] == pytest.approx(20.0)


def test_feedforward_option_reaches_the_base_angles():
    """A turning end effector tracking a moving reference: the two options differ exactly by the
    finding-2 term mu H^T R_tilde (y x omega_ref^e)."""
    R = Rotation.from_rotvec([0.05, -0.1, 0.2]).as_matrix()
    state = measurement(
        position=(3.0, 1.0, -2.0), velocity=(0.4, 0.3, -0.2), rotation=R, omega=(0.3, -0.1, 0.2)
    )
    exact = make_controller().command(0.0, state)
    paper = make_controller(feedforward="paper").command(0.0, state)
    x, x_dot = exact.x_ref, exact.x_ref_dot
    y = R.T @ x
    omega_ref = R.T @ np.cross(x, x_dot)
    mu = minimal_rotation_rate_correction(state.angular_velocity_in_ee, omega_ref, y)
    correction = mu * (minimal_rotation(y) @ np.cross(y, omega_ref))[1:]
    np.testing.assert_allclose(exact.base_angles - paper.base_angles, correction, atol=1e-15)
    assert np.linalg.norm(correction) > 1e-4


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"joint_axes": ("x",)}, "cannot be curved"),
        ({"surge_thrusters": (2, 7)}, "surge_thrusters"),
        ({"surge_thrusters": (2, 2)}, "surge_thrusters"),
        ({"surge_thrusters": ()}, "surge_thrusters"),
        ({"n_thrusters": 0}, "n_thrusters"),
        ({"max_thrust": [50.0, 50.0]}, "max_thrust"),
        ({"max_thrust": -1.0}, "max_thrust"),
    ],
)
def test_bad_controller_configuration(kwargs, message):
    arguments = {
        "joint_axes": PAPER_AXES,
        "surge_thrusters": SURGE_THRUSTERS,
        "n_thrusters": N_THRUSTERS,
        "max_thrust": 50.0,
        **kwargs,
    }
    with pytest.raises(ValueError, match=message) as error:
        PathFollowingController(**arguments)
    assert "\n" not in str(error.value)


def test_bad_measurements():
    controller = make_controller()
    with pytest.raises(ValueError, match="joints"):
        controller.command(0.0, measurement(n=6))
    with pytest.raises(ValueError, match="rotation"):
        controller.command(0.0, measurement(rotation=np.diag([1.0, 1.0, -1.0])))
    with pytest.raises(ValueError, match="joint_velocities"):
        measurement(q_dot=np.zeros(7))
    with pytest.raises(ValueError, match="surge_velocity"):
        measurement(surge=float("nan"))
    controller.command(1.0, measurement())
    with pytest.raises(ValueError, match="backwards"):
        controller.command(0.5, measurement())
