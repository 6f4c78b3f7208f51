"""The water's acceleration (issue 33): the currents' ``DV/Dt``, the law of
:mod:`aiauv_hydro.laws.unsteady_flow`, and closed forms of ideal-fluid mechanics on our own
single-body vehicles (a sphere, a cylinder), on both backends.

Tolerances, stated before measuring:

* analytic accelerations of the built-in currents against central differences of their velocity:
  1e-8 relative; a user's current by differences (:func:`difference_acceleration`) against its
  analytic acceleration: 1e-8 relative;
* the law against ``(M_F + M_A)[:, :3] a`` formed with NumPy: 1e-12; its rotation derivative
  against central differences: 1e-8;
* a neutrally buoyant sphere starting with the water moves with a uniform oscillating flow: velocity
  within 1e-9 m/s and position within 1e-9 m of the water's over two periods (RK4, dt = 0.01 s:
  the integrand depends on time only, so RK4 is Simpson's rule, error ~ dt^4 / 2880 |U^(5)| T);
* a sphere twice as dense accelerates at ``(rho V + m_a) / (m + m_a) = 0.6`` of the water's
  acceleration: 1e-12 relative (one evaluation) and its velocity within 1e-9 m/s over a period;
* Morison's inertia force on a held cylinder, per metre, ``C_M rho pi D^2 / 4 dU/dt`` with
  ``C_M = 2``, at 64 instants of a period: 1e-12 of its amplitude;
* compiled against the Pinocchio reference with a tidal current: 1e-9 relative;
* a neutrally buoyant sphere released with the water 5 m below a deep-water regular wave
  (H = 0.1 m, T = 6 s: orbit radius ``r = a e^{k z}`` = 0.029 m, ``k r`` = 3.2e-3) follows the
  linear orbit up to the closed-form second-order departure (drift and sinking, from the
  convective acceleration that linear waves leave out) to within ``0.5 k r^2`` (4.6e-5 m,
  0.16 % of ``r``) over two periods; the remainder is third order (doubling the height doubles it
  relative to ``k r^2``, within 10 %); the quasi-steady sphere departs by more than ``10 r``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import random_state

import aiauv_pin
from aiauv_hydro.currents import (
    Current,
    builtin_current_acceleration,
    current_acceleration,
    current_from_mapping,
    difference_acceleration,
)
from aiauv_hydro.laws import unsteady_flow
from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE, compiled
from aiauv_hydro.spec import HydroError
from aiauv_hydro.waves import Waves

pytestmark = pytest.mark.skipif(not NUMBA_AVAILABLE, reason="compiled laws need numba")

RHO = 1000.0
RADIUS = 0.1  # [m], sphere and cylinder
SPHERE_VOLUME = 4.0 / 3.0 * math.pi * RADIUS**3  # [m^3]
CYLINDER_LENGTH = 1.0  # [m]
PERIOD = 4.0  # [s] of the oscillating flow
AMPLITUDE = np.array([0.5, 0.2, 0.0])  # [m/s], horizontal


def _numbers(a) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(a))


def body_urdf(name: str, mass: float, inertia: np.ndarray, volume: float, added: np.ndarray) -> str:
    """One rigid body, centre of gravity and of buoyancy at its origin, no damping (ideal fluid)."""
    zeros = _numbers(np.zeros((6, 6)))
    mass, volume = float(mass), float(volume)
    inertia = [float(x) for x in inertia]
    return f"""<?xml version="1.0"?>
<robot name="{name}">
  <link name="body">
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="{mass!r}"/>
      <inertia ixx="{inertia[0]!r}" ixy="0" ixz="0" iyy="{inertia[1]!r}" iyz="0"
               izz="{inertia[2]!r}"/>
    </inertial>
  </link>
  <hydrodynamics fluid_density="{RHO!r}" gravity="9.81">
    <link name="body" model="fossen">
      <volume>{volume!r}</volume>
      <center_of_buoyancy>0 0 0</center_of_buoyancy>
      <added_mass>{_numbers(added)}</added_mass>
      <linear_damping>{zeros}</linear_damping>
      <quadratic_damping>{zeros}</quadratic_damping>
    </link>
  </hydrodynamics>
</robot>
"""


def sphere(tmp_path, density_ratio: float, backend: str = "auto") -> aiauv_pin.Vehicle:
    """A sphere of radius 0.1 m, ``density_ratio`` times as dense as the water, with the ideal-fluid
    added mass ``0.5 rho V`` in translation (Newman 1977, *Marine Hydrodynamics*, Sec. 4.13)."""
    mass = density_ratio * RHO * SPHERE_VOLUME
    added = np.diag([0.5 * RHO * SPHERE_VOLUME] * 3 + [0.0] * 3)
    inertia = np.full(3, 0.4 * mass * RADIUS**2)
    path = tmp_path / f"sphere_{density_ratio:g}.urdf"
    path.write_text(body_urdf("sphere", mass, inertia, SPHERE_VOLUME, added))
    vehicle = aiauv_pin.load_vehicle(path)
    vehicle.backend = backend
    return vehicle


def cylinder(tmp_path) -> aiauv_pin.Vehicle:
    """A neutrally buoyant circular cylinder along its x axis, radius 0.1 m, length 1 m, with the
    ideal-fluid crossflow added mass ``rho pi r^2`` per metre (``C_a = 1``; Newman 1977,
    Sec. 4.13): Morison's ``C_M = 1 + C_a = 2`` (DNV-RP-C205, Sec. 6.2)."""
    area = math.pi * RADIUS**2
    volume = area * CYLINDER_LENGTH
    mass = RHO * volume
    m_a = RHO * area * CYLINDER_LENGTH
    added = np.diag([0.1 * m_a, m_a, m_a, 0.0, m_a * CYLINDER_LENGTH**2 / 12, m_a / 12])
    inertia = np.array(
        [0.5 * mass * RADIUS**2] + [mass * (3 * RADIUS**2 + CYLINDER_LENGTH**2) / 12] * 2
    )
    path = tmp_path / "cylinder.urdf"
    path.write_text(body_urdf("cylinder", mass, inertia, volume, added))
    return aiauv_pin.load_vehicle(path)


def oscillating_flow(phase: float = 0.3) -> Current:
    """A uniform flow ``U(t) = A sin(2 pi t / T + phase)`` (a tidal current of zero mean)."""
    return Current.tidal(np.zeros(3), AMPLITUDE, PERIOD, phase)


def _central(function, x: float, step: float = 1e-5) -> np.ndarray:
    return (np.asarray(function(x + step)) - np.asarray(function(x - step))) / (2.0 * step)


def _relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(b).max(), 1e-300))


# ---------------------------------------------------------------------- the currents' DV/Dt
def test_builtin_accelerations_are_material_derivatives(rng):
    tidal = Current.tidal([0.2, -0.1, 0.05], [0.4, 0.3, -0.2], 7.0, 0.6)
    shear = Current.shear([0.3, -0.2, 0.1], [0.05, -0.08, 0.02], reference_z=-3.0)
    for _ in range(5):
        t, point = float(rng.uniform(0.0, 20.0)), rng.normal(size=3)
        dv_dt = _central(lambda s, p=point: tidal.velocity(s, p), t)
        assert _relative(tidal.water_acceleration(t, point), dv_dt) <= 1e-8
        # steady: DV/Dt = (V . grad) V, the gradient by central differences in each axis
        velocity = shear.velocity(t, point)
        gradient = np.array(
            [
                _central(lambda s, k=k, t=t, p=point: shear.velocity(t, p + s * np.eye(3)[k]), 0.0)
                for k in range(3)
            ]
        ).T
        assert _relative(shear.water_acceleration(t, point), gradient @ velocity) <= 1e-8
    assert np.all(Current.constant([0.3, 0.2, 0.1]).water_acceleration(1.0, np.ones(3)) == 0.0)
    # a horizontal shear current: the water moves along its layers without accelerating
    layered = Current.shear([0.3, 0.0, 0.0], [0.1, 0.0, 0.0])
    assert np.all(layered.water_acceleration(2.0, np.array([1.0, 2.0, -4.0])) == 0.0)
    # the dispatcher by kind number, compiled, equals each built-in's Python method
    assert builtin_current_acceleration(tidal.kind_code, 1.3, 0.0, 0.0, 0.0, tidal.parameters) == (
        pytest.approx(tuple(tidal.water_acceleration(1.3, np.zeros(3))), rel=1e-15)
    )


@compiled
def swirl_velocity(t, x, y, z, parameters):
    """A user's unsteady, non-uniform flow: a pulsating solid-body swirl about the z axis plus a
    vertical shear, ``V = s(t) (-y, x, 0) omega + (G z, 0, 0)``, ``s = 1 + 0.5 sin(t)``."""
    s = parameters[0] * (1.0 + 0.5 * math.sin(t))
    return -s * y + parameters[1] * z, s * x, 0.0


@compiled
def swirl_acceleration(t, x, y, z, parameters):
    """Its material derivative ``dV/dt + (V . grad) V`` by hand."""
    omega = parameters[0]
    s = omega * (1.0 + 0.5 * math.sin(t))
    ds = omega * 0.5 * math.cos(t)
    u, v = -s * y + parameters[1] * z, s * x
    # grad V rows: (0, -s, G), (s, 0, 0), (0, 0, 0); (V . grad) V = (-s v, s u, 0)
    return -ds * y - s * v, ds * x + s * u, 0.0


def test_user_current_acceleration_own_or_by_differences(rng):
    parameters = np.array([0.3, 0.05])
    own = Current(swirl_velocity, parameters, acceleration=swirl_acceleration)
    by_differences = Current(swirl_velocity, parameters)
    for _ in range(5):
        t, point = float(rng.uniform(0.0, 10.0)), rng.normal(size=3) * 3.0
        exact = np.array(swirl_acceleration(t, *point, parameters))
        assert np.array_equal(own.water_acceleration(t, point), exact)
        assert _relative(by_differences.water_acceleration(t, point), exact) <= 1e-8
        # the compiled dispatcher takes the same branch as Python
        compiled_value = current_acceleration(None, swirl_velocity, -1, t, *point, parameters)
        assert np.allclose(compiled_value, difference_acceleration.py_func(
            swirl_velocity, t, *point, parameters), rtol=1e-12, atol=1e-15)  # fmt: skip
    with pytest.raises(HydroError, match="has its own acceleration"):
        Current(Current.tidal(np.zeros(3), np.ones(3), 5.0).function, np.ones(8), "tidal",
                acceleration=swirl_acceleration)  # fmt: skip


def test_quasi_steady_option_in_api_and_tables():
    table = {"type": "tidal", "velocity": [0.1, 0, 0], "amplitude": [0.2, 0, 0], "period": 9.0}
    unsteady = current_from_mapping(table)
    steady = current_from_mapping({**table, "unsteady": False})
    assert unsteady.unsteady and not steady.unsteady
    quasi = unsteady.quasi_steady()
    assert quasi.describe() == steady.describe() and quasi.function is steady.function
    by_keyword = Current.tidal([0.1, 0, 0], [0.2, 0, 0], 9.0, unsteady=False)
    assert by_keyword.describe() == steady.describe()
    assert np.array_equal(quasi.parameters, steady.parameters)
    assert np.all(steady.water_acceleration(1.0, np.zeros(3)) == 0.0)
    assert steady.describe()["unsteady"] is False and "unsteady" not in unsteady.describe()
    with pytest.raises(HydroError, match=r"current\.unsteady: expected true or false"):
        current_from_mapping({**table, "unsteady": "no"})


def test_currents_compare_by_value_and_scenarios_holding_them_too():
    """The comparison a dataclass generates compared the parameter arrays as one truth value, which
    raised (``ValueError``), and so did comparing two scenarios with currents."""
    import dataclasses

    from aiauv_pin.scenario.definition import Scenario

    table = {"type": "tidal", "velocity": [0.1, 0, 0], "amplitude": [0.2, 0, 0], "period": 9.0}
    tidal = current_from_mapping(table)
    assert tidal == current_from_mapping(table)
    assert tidal != current_from_mapping({**table, "period": 9.5})
    assert tidal != current_from_mapping({**table, "unsteady": False})
    assert tidal != Current.constant([0.1, 0, 0]) and tidal != "tidal"
    same = [dataclasses.replace(Scenario(), current=current_from_mapping(table)) for _ in range(2)]
    assert same[0] == same[1]
    assert same[0] != dataclasses.replace(Scenario(), current=Current.constant([0.1, 0, 0]))


# ---------------------------------------------------------------------- the law
def test_law_is_the_displaced_water_plus_added_mass_inertia(rng):
    nb = 3
    a = rng.normal(size=(nb, 6, 6))
    added = a @ a.transpose(0, 2, 1)
    displaced = rng.normal(size=(nb, 4))
    for b in range(nb):
        acc = rng.normal(size=3)
        m, first = displaced[b, 0], displaced[b, 1:]
        froude_krylov = np.concatenate((m * acc, np.cross(first, acc)))
        expected = froude_krylov + added[b][:, :3] @ acc
        for law in (
            unsteady_flow.flow_acceleration_wrench,
            unsteady_flow.flow_acceleration_wrench.py_func,
        ):
            assert np.allclose(law(added, displaced, b, *acc), expected, rtol=1e-12, atol=1e-12)  # fmt: skip


def _rotation(theta: np.ndarray) -> np.ndarray:
    angle = np.linalg.norm(theta)
    k = np.array([[0, -theta[2], theta[1]], [theta[2], 0, -theta[0]], [-theta[1], theta[0], 0]])
    if angle == 0.0:
        return np.eye(3)
    return np.eye(3) + math.sin(angle) / angle * k + (1 - math.cos(angle)) / angle**2 * k @ k


def test_law_rotation_derivative_matches_central_differences(paper_vehicle, rng):
    fluid = paper_vehicle.fluid_model()
    nb = fluid.added_mass.shape[0]
    rotation = np.array([_rotation(rng.normal(size=3)) for _ in range(nb)])
    flow = rng.normal(size=(nb, 3))
    exact = np.zeros((nb, 6, 3))
    unsteady_flow.add_flow_acceleration_rotation_jacobian(fluid, rotation, flow, exact)
    for b in range(nb):
        for k in range(3):

            def bias(step, b=b, k=k):
                turned = rotation.copy()
                turned[b] = rotation[b] @ _rotation(step * np.eye(3)[k])  # R exp([d theta])
                out = np.zeros((nb, 6))
                unsteady_flow.add_flow_acceleration_bias(fluid, turned, flow, out)
                return out[b]

            approx = _central(bias, 0.0)
            assert np.abs(exact[b, :, k] - approx).max() <= 1e-8 * max(1.0, np.abs(approx).max())


# ---------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("backend", ["auto", "pinocchio"])
def test_neutral_sphere_instant_acceleration_equals_the_waters(tmp_path, backend):
    vehicle = sphere(tmp_path, 1.0, backend)
    flow = oscillating_flow()
    q = vehicle.neutral_configuration()
    for t in np.linspace(0.0, PERIOD, 9):
        v = np.zeros(6)
        v[:3] = flow.velocity(t, np.zeros(3))  # with the water
        dv = vehicle.acceleration(q, v, np.zeros(6), flow, t=t)
        water = flow.water_acceleration(t, np.zeros(3))
        assert np.abs(dv[:3] - water).max() <= 1e-12 * np.abs(AMPLITUDE).max()
        assert np.abs(dv[3:]).max() <= 1e-12


def test_neutral_sphere_moves_with_an_oscillating_flow(tmp_path):
    """Over 2.25 periods (RK4, dt = 0.01 s) the sphere's velocity and position stay the water's;
    with the quasi-steady model (the water's acceleration neglected, no damping) it stays put."""
    vehicle = sphere(tmp_path, 1.0)
    flow = oscillating_flow()
    dt, steps = 0.01, round(2.25 * PERIOD / 0.01)  # ends a quarter period off the start
    results = {}
    for name, water in (("unsteady", flow), ("quasi-steady", flow.quasi_steady())):
        q = vehicle.neutral_configuration()
        v = np.zeros(6)
        v[:3] = flow.velocity(0.0, np.zeros(3))
        vehicle.fast.run(q, v, np.zeros(6), dt, steps, current=water)
        results[name] = (q.copy(), v.copy())
    t_end = dt * steps
    omega, phase = 2 * math.pi / PERIOD, 0.3
    # x(t) = x(0) + int_0^t U = A (cos(phase) - cos(omega t + phase)) / omega
    displacement = AMPLITUDE * (math.cos(phase) - math.cos(omega * t_end + phase)) / omega
    q, v = results["unsteady"]
    assert np.abs(v[:3] - flow.velocity(t_end, np.zeros(3))).max() <= 1e-9
    assert np.abs(q[:3] - displacement).max() <= 1e-9
    assert np.abs(v[3:]).max() <= 1e-12
    v_steady = results["quasi-steady"][1]
    assert np.abs(v_steady[:3] - v[:3]).max() > 0.1  # keeps its start velocity, lags the water


@pytest.mark.parametrize("backend", ["auto", "pinocchio"])
def test_dense_sphere_accelerates_at_the_closed_form_fraction(tmp_path, backend):
    """``m = 2 rho V``: ``dv/dt = (rho V + m_a) / (m + m_a) dU/dt = 0.6 dU/dt`` horizontally."""
    vehicle = sphere(tmp_path, 2.0, backend)
    flow = oscillating_flow()
    ratio = (RHO * SPHERE_VOLUME + 0.5 * RHO * SPHERE_VOLUME) / (
        2.0 * RHO * SPHERE_VOLUME + 0.5 * RHO * SPHERE_VOLUME
    )
    assert ratio == pytest.approx(0.6, rel=1e-15)
    q = vehicle.neutral_configuration()
    for t in np.linspace(0.1, PERIOD, 7):
        dv = vehicle.acceleration(q, np.zeros(6), np.zeros(6), flow, t=t)
        water = flow.water_acceleration(t, np.zeros(3))
        assert _relative(dv[:2], ratio * water[:2]) <= 1e-12
    if backend == "auto":  # integrated: v_x(t) - v_x(0) = 0.6 (U(t) - U(0))
        v = np.zeros(6)
        vehicle.fast.run(q, v, np.zeros(6), 0.01, 400, current=flow)
        gained = flow.velocity(4.0, np.zeros(3)) - flow.velocity(0.0, np.zeros(3))
        assert np.abs(v[:2] - ratio * gained[:2]).max() <= 1e-9


def test_morison_inertia_force_on_a_held_cylinder(tmp_path):
    """Per metre, ``F(t) = C_M rho (pi D^2 / 4) dU/dt`` with ``C_M = 2`` (Morison et al. 1950;
    DNV-RP-C205, Sec. 6.2) in a uniform crossflow ``U(t) = U_m sin(omega t)``, at 64 instants of
    a period, on the reference's wrench and on the compiled dynamics (``bias = -M dv`` at rest)."""
    vehicle = cylinder(tmp_path)
    u_max, omega = 0.8, 2 * math.pi / PERIOD
    flow = Current.tidal(np.zeros(3), [0.0, u_max, 0.0], PERIOD, 0.0)
    q, rest = vehicle.neutral_configuration(), np.zeros(6)
    mass = vehicle.mass_matrix(q)
    amplitude = 2.0 * RHO * math.pi * (2 * RADIUS) ** 2 / 4 * u_max * omega  # [N/m]
    errors = []
    for t in np.arange(64) * PERIOD / 64:
        morison = amplitude * math.cos(omega * t)
        # the force the water exerts on the held body is minus its left-hand-side bias
        reference = -vehicle.fluid_forces(q, rest, flow, t=t).bias / CYLINDER_LENGTH
        compiled_bias = -mass @ vehicle.acceleration(q, rest, np.zeros(6), flow, t=t)
        kernel = -compiled_bias / CYLINDER_LENGTH
        for force in (reference, kernel):
            errors.append(abs(force[1] - morison))
            assert np.abs(force[[0, 2, 3, 4, 5]]).max() <= 1e-12 * amplitude
    assert max(errors) <= 1e-12 * amplitude


def _orbit_departure(vehicle, height: float, quasi_steady: bool = False) -> tuple[float, float]:
    """The sphere released with the water 5 m below a deep-water regular wave (T = 6 s, travelling
    to +x, phase 0), two periods by RK4 at 0.01 s: the largest departure from the linear orbit
    minus the second-order departure, and the largest departure from the linear orbit, each over
    ``k r^2`` and ``r`` respectively (sampled every 0.3 s).

    The linear orbit about the start ``x_0`` (Faltinsen 1990, ch. 2; DNV-RP-C205 Table 3-1), with
    ``r = a e^{k z_0}``, ``k = omega^2 / g``: ``x - x_0 = r sin(omega t)``, ``z - z_0 = r (cos(omega
    t) - 1)``. The body's equation is ``dv/dt = dU/dt`` (local acceleration) at its own position:
    expanding it about ``x_0`` the error ``(delta . grad) dU/dt`` is ``k r^2 omega^2 (sin(omega t),
    0, cos(omega t) - 1)``, so, to second order, ``Delta x = k r^2 (omega t - sin(omega t))`` (the
    Stokes drift ``k r^2 omega``; G. G. Stokes, "On the theory of oscillatory waves", 1847) and
    ``Delta z = -k r^2 ((omega t)^2 / 2 + cos(omega t) - 1)``: a sinking at ``-k r^2 omega^2``,
    the mean of the convective acceleration ``grad |U|^2 / 2`` that linear theory leaves out (a
    fluid particle's orbit closes because of it)."""
    period, depth = 6.0, 5.0
    sea = Waves(type="regular", height=height, period=period, heading=0.0, surface_z=0.0)
    water = Current.waves(sea, unsteady=not quasi_steady)
    omega = 2 * math.pi / period
    k = omega**2 / 9.81
    r = height / 2 * math.exp(-k * depth)
    q = vehicle.neutral_configuration()
    q[2] = -depth
    start = q[:3].copy()
    v = np.zeros(6)
    v[:3] = water.velocity(0.0, start)
    dt, chunk, t = 0.01, 30, 0.0
    residual = departure = 0.0
    for _ in range(40):
        vehicle.fast.run(q, v, np.zeros(6), dt, chunk, current=water, t0=t)
        t += chunk * dt
        phase = omega * t
        linear = start + r * np.array([math.sin(phase), 0.0, math.cos(phase) - 1.0])
        second = (
            k
            * r**2
            * np.array([phase - math.sin(phase), 0.0, 1.0 - phase**2 / 2 - math.cos(phase)])
        )
        residual = max(residual, np.abs(q[:3] - linear - second).max())
        departure = max(departure, np.abs(q[:3] - linear).max())
    assert np.abs(v[3:]).max() <= 1e-12
    return residual / (k * r**2), departure / r


def test_neutral_sphere_follows_the_orbit_of_a_regular_wave(tmp_path):
    vehicle = sphere(tmp_path, 1.0)
    residual, departure = _orbit_departure(vehicle, 0.1)
    assert residual <= 0.5
    assert 0.2 < departure < 0.3  # the secular sinking: k r (omega t)^2 / 2 = 0.25 at the end
    doubled, _ = _orbit_departure(vehicle, 0.2)
    assert doubled / residual == pytest.approx(2.0, rel=0.1)  # third order
    _, lagging = _orbit_departure(vehicle, 0.1, quasi_steady=True)
    assert lagging > 10.0  # keeps its start velocity r omega: 4 pi r away after two periods


# ---------------------------------------------------------------------- both backends
@pytest.mark.parametrize("name", ["paper", "single_body", "sphere"])
def test_compiled_equals_reference_with_a_tidal_current(
    name, paper_vehicle, single_body, tmp_path, rng
):
    if name == "paper":
        vehicle = paper_vehicle
    elif name == "single_body":
        vehicle = aiauv_pin.load_vehicle(single_body[0])
    else:
        vehicle = sphere(tmp_path, 1.3)
    reference = (
        aiauv_pin.load_vehicle(vehicle.urdf_path) if name != "paper" else aiauv_pin.load_vehicle()
    )
    reference.backend = "pinocchio"
    flow = Current.tidal([0.2, -0.1, 0.05], [0.5, 0.3, -0.2], 6.0, 0.2)
    for t in (0.4, 2.1, 4.7):
        q, v = random_state(vehicle.model, rng)
        tau = rng.normal(scale=10.0, size=vehicle.nv)
        fast = vehicle.acceleration(q, v, tau, flow, t=t)
        slow = reference.acceleration(q, v, tau, flow, t=t)
        assert _relative(fast, slow) <= 1e-9
        # the new terms are there: the quasi-steady model differs
        assert _relative(vehicle.acceleration(q, v, tau, flow.quasi_steady(), t=t), slow) > 1e-6


def test_constant_current_is_bit_identical_to_the_quasi_steady_model(paper_vehicle, rng):
    q, v = random_state(paper_vehicle.model, rng)
    tau = rng.normal(size=paper_vehicle.nv)
    water = Current.constant([0.3, -0.2, 0.1])
    a = paper_vehicle.acceleration(q, v, tau, water)
    b = paper_vehicle.acceleration(q, v, tau, water.quasi_steady())
    assert np.array_equal(a, b)


@compiled
def users_tidal_velocity(t, x, y, z, parameters):
    """A user's own copy of the tidal current, ``V = A sin(omega t + phi)``."""
    s = math.sin(parameters[3] * t + parameters[4])
    return parameters[0] * s, parameters[1] * s, parameters[2] * s


@compiled
def users_tidal_acceleration(t, x, y, z, parameters):
    """Its acceleration, by hand."""
    c = parameters[3] * math.cos(parameters[3] * t + parameters[4])
    return parameters[0] * c, parameters[1] * c, parameters[2] * c


def test_users_current_in_the_compiled_loop(tmp_path):
    """``simulate`` (compiled loop) with a user's current: with its own acceleration it runs the
    built-in tidal current's dynamics to round-off (1e-12), by differences to 1e-8."""
    vehicle = sphere(tmp_path, 1.5)
    omega, phase = 2 * math.pi / PERIOD, 0.3
    parameters = np.array([*AMPLITUDE, omega, phase])
    runs = {}
    for name, water in (
        ("builtin", oscillating_flow(phase)),
        ("own", Current(users_tidal_velocity, parameters, acceleration=users_tidal_acceleration)),
        ("differences", Current(users_tidal_velocity, parameters)),
    ):
        run = aiauv_pin.simulate(
            vehicle, vehicle.neutral_configuration(), np.zeros(6), 2.0, 0.01, current=water
        )
        runs[name] = run.v
    scale = np.abs(runs["builtin"]).max()
    assert scale > 0.05  # the sphere was set moving by the water's acceleration
    assert np.abs(runs["own"] - runs["builtin"]).max() <= 1e-12 * max(scale, 1.0)
    assert np.abs(runs["differences"] - runs["builtin"]).max() <= 1e-8 * max(scale, 1.0)


def test_probe_point_against_the_strip_on_the_paper_vehicle(paper_vehicle):
    """Why the law takes one probe per body and no strip (docs/source/unsteady_flow.md): on every
    slender link of the paper vehicle the probe is the strip's midpoint (to 1e-12 m), so the strip
    integral of a water acceleration varying linearly along the link equals the probe's value; in
    a deep-water wave of period 6 s (``k = omega^2 / g``) the force the probe misses,
    ``1 - sin(kL/2) / (kL/2)``, is below 3e-4 (Gauss-Legendre strip, 32 nodes)."""
    fluid = paper_vehicle.fluid_model()
    k = (2 * math.pi / 6.0) ** 2 / 9.81
    nodes, weights = np.polynomial.legendre.leggauss(32)
    worst = 0.0
    for b, link in enumerate(paper_vehicle.hydro.links):  # one link per body on this vehicle
        strip = link.crossflow
        assert strip is not None
        midpoint = strip.translation + strip.rotation @ np.array([strip.length / 2, 0.0, 0.0])
        assert np.abs(fluid.current_probe[b] - midpoint).max() <= 1e-12
        x = 0.5 * strip.length * nodes  # about the midpoint
        missed = 0.0
        for phase in np.linspace(0.0, math.pi, 9):
            by_strip = 0.5 * strip.length * np.sum(weights * np.cos(k * x + phase))
            at_probe = strip.length * math.cos(phase)
            missed = max(missed, abs(by_strip - at_probe) / strip.length)
        assert missed <= (k * strip.length) ** 2 / 24  # 1 - sin(u) / u <= u^2 / 6
        worst = max(worst, missed)
    assert worst <= 3e-4
