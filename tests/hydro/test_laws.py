"""Every law of :mod:`aiauv_control.laws.paper_laws` and :mod:`aiauv_hydro.laws.fluid_terms`:
compiled against interpreted execution of
the same function, and the new path-parametrised LOS against finite differences in time.

The laws are written once; these tests check that numba's compilation of each (with fast-math for
the fluid terms) gives what its Python source gives, on random inputs, through saturations,
anti-windup and the singular points of the pointing error.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_control.laws import paper_laws as control_laws
from aiauv_control.paths import HelixPath, LinePath, WaypointPath
from aiauv_hydro.laws import fluid_terms as hydro_laws
from aiauv_hydro.laws.crossflow import gauss_legendre_unit
from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE, interpreted

pytestmark = pytest.mark.skipif(not NUMBA_AVAILABLE, reason="compiled laws need numba")
TIGHT = dict(rtol=1e-12, atol=1e-12)


def _rotation(rng) -> np.ndarray:
    quaternion = rng.normal(size=4)
    x, y, z, w = quaternion / np.linalg.norm(quaternion)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _both(function, *args):
    return function(*args), interpreted(function)(*args)


def _paths():
    return [
        LinePath(point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0)),
        LinePath(point=(1.0, -2.0, 0.5), direction=(0.3, 0.8, -0.2)),
        HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=10.0),
        WaypointPath(points=[(0, 0, 0), (20, 0, 0), (30, 10, -3), (30, 30, -3)], corner_radius=4.0),
    ]


# ---------------------------------------------------------------------- control laws
@pytest.mark.parametrize("path", _paths(), ids=["x_axis", "line", "helix", "waypoints"])
def test_los_guidance_compiled_equals_interpreted(path, rng):
    for _ in range(50):
        p = rng.uniform(-5, 25, 3)
        point = path.closest(p)
        args = (point, p, rng.normal(size=3), rng.normal(size=3), 0.5, 0.05, 0.08)
        got, expected = _both(control_laws.los_guidance, *args)
        np.testing.assert_allclose(np.array(got), np.array(expected), **TIGHT)


@pytest.mark.parametrize("path", _paths()[1:], ids=["line", "helix", "waypoints"])
def test_los_derivatives_match_finite_differences_in_time(path, rng):
    """x_ref_dot and x_ref_ddot are d/dt of x_ref along a smooth end-effector motion p(t)."""
    checked = 0
    while checked < 12:
        p0 = path.closest(rng.uniform(0, 20, 3)).point + rng.normal(scale=1.0, size=3)
        velocity, accel, jerk = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)

        def motion(t, p0=p0, velocity=velocity, accel=accel, jerk=jerk):
            p = p0 + velocity * t + accel * t**2 / 2 + jerk * t**3 / 6
            return p, velocity + accel * t + jerk * t**2 / 2, accel + jerk * t

        def x_ref(t):
            p, p_dot, p_ddot = motion(t)
            return control_laws.los_guidance(path.closest(p), p, p_dot, p_ddot, 0.5, 0.2, 0.3)

        # away from the curvature jumps of the waypoint path
        s = [path.closest(motion(t)[0]).s for t in (-1e-3, 0.0, 1e-3)]
        breaks = getattr(path, "breakpoints", ())
        if any(min(s) - 0.01 <= b <= max(s) + 0.01 for b in breaks):
            continue
        h = 1e-4
        x0, x_dot, x_ddot = (np.array(a) for a in x_ref(0.0))
        plus, minus = np.array(x_ref(h)[0]), np.array(x_ref(-h)[0])
        np.testing.assert_allclose((plus - minus) / (2 * h), x_dot, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose((plus - 2 * x0 + minus) / h**2, x_ddot, rtol=1e-4, atol=1e-5)
        checked += 1


@pytest.mark.parametrize("exact", [True, False])
def test_reduced_attitude_law_compiled_equals_interpreted(exact, rng):
    for case in range(80):
        R = _rotation(rng)
        x_ref = rng.normal(size=3)
        if case < 3:  # aligned, antipodal and near antipodal
            x_ref = R[:, 0] * [1.0, -1.0, -1.0][case]
            if case == 2:
                x_ref = -R[:, 0] + 1e-9 * R[:, 1]
        J = np.diag(rng.uniform(0.5, 3.0, 3))
        J[1, 2] = J[2, 1] = 0.1
        args = (R, rng.normal(size=3), x_ref, rng.normal(size=3), rng.normal(size=3), J)
        args += (*rng.normal(size=2), *rng.uniform(0.1, 5, 2), exact)
        got, expected = _both(control_laws.reduced_attitude_law, *args)
        np.testing.assert_allclose(np.array(got), np.array(expected), **TIGHT)
        assert all(math.isfinite(x) for x in got)


def _gains(rng, exact: bool, beyond: bool = False) -> control_laws.PaperGains:
    extensions = {}
    if beyond:  # the extensions beyond the paper, all on
        extensions = dict(
            turn_feedforward=True,
            turn_rate_gain=float(rng.uniform(0.05, 1.0)),
            turn_time_constant=float(rng.uniform(0.0, 5.0)),
            integral_los=True,
            los_integral_gain=float(rng.uniform(0.1, 3.0)),
            hydrostatic_compensation=True,
            turn_moment_gain=float(rng.uniform(10.0, 200.0)),
        )
    return control_laws.PaperGains(
        u_d=float(rng.uniform(0.1, 2.0)),
        k_y=float(rng.uniform(0.01, 1.0)),
        k_z=float(rng.uniform(0.01, 1.0)),
        k_p=float(rng.uniform(0.1, 5.0)),
        k_d=float(rng.uniform(0.1, 30.0)),
        k_qp=float(rng.uniform(1, 50)),
        k_qd=float(rng.uniform(0, 60)),
        k_1p=float(rng.uniform(0, 200)),
        k_1i=float(rng.uniform(0, 20)),
        max_thrust=float(rng.uniform(2.0, 50.0)),
        q_max=float(rng.uniform(0.05, 1.0)),  # small limits: many references saturate
        exact=exact,
        **extensions,
    )


@pytest.mark.parametrize(
    "exact, beyond",
    [(True, False), (False, False), (True, True)],
    ids=["exact", "paper", "exact_beyond"],  # beyond: the extensions beyond the paper, all on
)
@pytest.mark.parametrize("path", _paths(), ids=["x_axis", "line", "helix", "waypoints"])
def test_path_following_command_compiled_equals_interpreted(exact, beyond, path, rng):
    n, m = 6, 4
    axis_index = np.array([1, 0, 1, 0, 1, 0])
    scale = np.exp(-0.7 * np.array([0, 0, 1, 1, 2, 2]))
    mask = np.array([1, 0, 1, 0])
    saturated = 0
    for _ in range(20):
        gains = _gains(rng, exact, beyond)
        states = [control_laws.new_surge_state() for _ in range(2)]
        guidance = [control_laws.new_guidance_state() for _ in range(2)]
        t = 0.0
        for _ in range(5):  # a sequence: the surge integral advances (and may saturate)
            t += float(rng.uniform(0.0, 0.3))
            measurement = (
                _rotation(rng),
                rng.uniform(-3, 3, 3),
                rng.normal(size=3),
                rng.normal(size=3),
                rng.normal(size=3),
                float(rng.uniform(-1, 2)),
                rng.uniform(-1, 1, n),
                rng.normal(size=n),
                rng.normal(size=n),
                rng.normal(size=3) * 30.0,
            )
            outs = [control_laws.new_command_buffers(n, m) for _ in range(2)]
            for function, state, guide, out in zip(
                (
                    control_laws.path_following_command,
                    interpreted(control_laws.path_following_command),
                ),
                states,
                guidance,
                outs,
                strict=True,
            ):
                function(
                    gains, path.user_function, path.kind_code, path.params, axis_index, scale,
                    mask, state, guide, t,
                    *measurement, out,
                )  # fmt: skip
            for name, got, expected in zip(outs[0]._fields, outs[0], outs[1], strict=True):
                np.testing.assert_allclose(got, expected, err_msg=name, **TIGHT)
            for got, expected in zip(states[0], states[1], strict=True):
                np.testing.assert_allclose(got, expected, **TIGHT)
            for got, expected in zip(guidance[0], guidance[1], strict=True):
                np.testing.assert_allclose(got, expected, **TIGHT)
            saturated += int(np.any(np.abs(outs[0].base_angles) > gains.q_max))
    assert saturated > 10  # the saturation of eq. (22) was exercised


def test_surge_pi_saturation_and_anti_windup_compiled_equals_interpreted():
    states = [control_laws.new_surge_state() for _ in range(2)]
    functions = (control_laws.surge_pi, interpreted(control_laws.surge_pi))
    t = 0.0
    history = []
    # too slow (saturated at +max, integral frozen), then too fast (leaves the limit, integrates)
    for surge in [0.0] * 6 + [0.45] * 3 + [1.5] * 6 + [0.5] * 3:
        t += 0.1
        thrusts = [
            f(s, t, surge, 100.0, 5.0, 0.5, 4.0) for f, s in zip(functions, states, strict=True)
        ]
        assert thrusts[0] == pytest.approx(thrusts[1], abs=1e-12)
        np.testing.assert_allclose(states[0].integral, states[1].integral, **TIGHT)
        history.append((abs(thrusts[0]) == 4.0, float(states[0].integral[0])))
    assert history[0][0] and history[1][0] and history[2][1] == history[1][1]
    assert any(not saturated for saturated, _ in history)


# ---------------------------------------------------------------------- fluid laws
def test_single_vector_fluid_laws_compiled_equal_interpreted(rng):
    nodes, weights = gauss_legendre_unit(16)
    for _ in range(30):
        a = rng.normal(size=(6, 6))
        inertia = a @ a.T
        twist = rng.normal(size=6)
        for function, args in (
            (hydro_laws.coriolis_wrench, (inertia, twist)),
            (hydro_laws.current_acceleration_wrench, (inertia, *rng.normal(size=6))),
            (hydro_laws.damping_wrench, (inertia, np.diag(rng.uniform(0, 5, 6)), True, twist)),
            (hydro_laws.damping_wrench, (inertia, a, False, twist)),
            (hydro_laws.forward_speed_damping_wrench, (a, twist)),
            (hydro_laws.crossflow_wrench, (twist, 0.7, 68.0, 0.0, 0.0, nodes, weights)),
            (hydro_laws.crossflow_wrench, (twist, 0.7, 68.0, 1.4, 0.03, nodes, weights)),
            (hydro_laws.hydrostatic_wrench, tuple(rng.normal(size=7))),
        ):
            got, expected = _both(function, *args)
            np.testing.assert_allclose(np.array(got), np.array(expected), rtol=1e-11, atol=1e-11)


def test_body_fluid_bias_compiled_equals_interpreted(paper_vehicle, rng):
    fluid = paper_vehicle.fluid_model()
    nb = fluid.added_mass.shape[0]
    rotation = np.array([_rotation(rng) for _ in range(nb)])
    twist = rng.normal(size=(nb, 6))
    current = rng.normal(scale=0.3, size=(nb, 3))
    results = []
    for function in (hydro_laws.add_body_fluid_bias, interpreted(hydro_laws.add_body_fluid_bias)):
        bias = np.zeros((nb, 6))
        relative = np.zeros((nb, 6))
        function(fluid, rotation, twist, current, bias, relative, np.zeros((3, 6)))
        results.append((bias, relative))
    np.testing.assert_allclose(results[0][0], results[1][0], rtol=1e-11, atol=1e-10)
    np.testing.assert_allclose(results[0][1], results[1][1], **TIGHT)


def test_forward_speed_damping_closed_form_and_power(rng):
    """``-u D_F nu`` (UUV Simulator's forward-speed term): its power ``-u nu^T D_F nu`` is
    dissipative for u > 0 and a PSD ``D_F``, and changes sign with the surge speed."""
    a = rng.normal(size=(6, 6))
    forward = a @ a.T + np.diag([0, 0, 0, 0, 0, 0.0])
    for _ in range(20):
        twist = rng.normal(size=6)
        wrench = np.array(hydro_laws.forward_speed_damping_wrench(forward, twist))
        np.testing.assert_allclose(wrench, -twist[0] * forward @ twist, rtol=1e-12, atol=1e-12)
        power = float(wrench @ twist)
        assert np.sign(power) == -np.sign(twist[0]) or abs(power) < 1e-12


# ---------------------------------------------------------------------- measurement and checks
def test_finite_difference_acceleration_compiled_equals_interpreted(rng):
    """One measurement for both controllers: zero at the first sample and when ``t`` does not
    advance, else the velocity difference over the elapsed time."""
    functions = (
        control_laws.finite_difference_acceleration,
        interpreted(control_laws.finite_difference_acceleration),
    )
    histories = [np.zeros(5), np.zeros(5)]
    previous = None
    for t in (0.0, 0.1, 0.1, 0.35, 0.3, 0.6):
        velocity = rng.normal(size=3)
        outs = [np.full(3, np.nan), np.full(3, np.nan)]
        for f, history, out in zip(functions, histories, outs, strict=True):
            f(t, velocity, history, out)
        assert np.array_equal(outs[0], outs[1])
        assert np.array_equal(histories[0], histories[1])
        if previous is None or t <= previous[0]:
            assert np.array_equal(outs[0], np.zeros(3))
        else:
            np.testing.assert_allclose(outs[0], (velocity - previous[1]) / (t - previous[0]))
        previous = (t, velocity)


def test_thruster_power_on_scalars_and_arrays(rng):
    speeds, thrusts = rng.normal(size=5), rng.normal(size=5)
    expected = speeds * thrusts
    compiled = [control_laws.thruster_power(s, f) for s, f in zip(speeds, thrusts, strict=True)]
    assert np.array_equal(np.array(compiled), expected)
    assert np.array_equal(interpreted(control_laws.thruster_power)(speeds, thrusts), expected)


def test_unit_quaternion_rule_compiled_equals_interpreted():
    from aiauv_hydro.numerics import spatial

    tolerance, exact = 1e-6, 1e-14
    unit = np.array([0.1, 0.2, 0.3, 0.9]) / np.linalg.norm([0.1, 0.2, 0.3, 0.9])
    expected = {
        0.0: spatial.QUATERNION_UNIT,
        1e-15: spatial.QUATERNION_UNIT,
        1e-12: spatial.QUATERNION_NORMALISE,
        0.5e-6: spatial.QUATERNION_NORMALISE,
        2e-6: spatial.QUATERNION_NOT_UNIT,
        -0.5: spatial.QUATERNION_NOT_UNIT,
        math.inf: spatial.QUATERNION_NOT_UNIT,
        math.nan: spatial.QUATERNION_NOT_UNIT,
    }
    for scale, verdict in expected.items():
        x, y, z, w = (unit * (1.0 + scale)).tolist()
        got = [
            f(x, y, z, w, tolerance, exact)
            for f in (spatial.unit_quaternion_check, interpreted(spatial.unit_quaternion_check))
        ]
        assert got[0][0] == got[1][0] == verdict, scale
        assert got[0][1] == got[1][1] or math.isnan(got[0][1])
