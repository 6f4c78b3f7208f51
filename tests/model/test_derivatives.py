"""Exact derivatives of the dynamics (issue 16) against central differences and across backends.

* Each fluid law's derivative (aiauv_hydro.laws.fluid_terms) against central differences of the law itself.
* ``Vehicle.acceleration_derivatives``: ``da_dq`` (tangent space, ``pinocchio.integrate``),
  ``da_dv``, ``da_dtau``, ``da_dcurrent`` against central differences of ``Vehicle.acceleration`` to
  1e-6 relative, on random states of the paper's two vehicles, a single body with a full Fossen
  block and generated vehicles, every fluid effect on, with and without a current; the compiled and
  the Pinocchio derivatives agree to 1e-9.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import generated_vehicle_table, random_state, single_body_urdf

import aiauv_pin
from aiauv_hydro.currents import Current
from aiauv_hydro.laws import fluid_terms as laws
from aiauv_hydro.laws.crossflow import gauss_legendre_unit
from aiauv_pin.builders.urdf_builder import build_urdf
from aiauv_pin.builders.vehicle_spec import spec_from_dict
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.derivatives import acceleration_derivatives

pytest.importorskip("numba")

FD_RTOL = 1e-6
STEP = 1e-5
CURRENTS = [None, np.array([0.3, -0.2, 0.15])]


def _central(function, x: np.ndarray, step: float = STEP) -> np.ndarray:
    """Central differences of a vector function of a vector, columns by coordinate."""
    columns = []
    for k in range(x.size):
        dx = np.zeros_like(x)
        dx[k] = step
        columns.append((np.asarray(function(x + dx)) - np.asarray(function(x - dx))) / (2 * step))
    return np.array(columns).T


def assert_close_relative(exact: np.ndarray, approx: np.ndarray, rtol: float, what: str) -> None:
    scale = max(np.abs(exact).max(), 1e-12)
    error = np.abs(exact - approx).max() / scale
    assert error <= rtol, f"{what}: relative error {error:.2e} > {rtol:.0e}"


# ---------------------------------------------------------------------- the laws' derivatives
def _random_inertia(rng):
    a = rng.normal(size=(6, 6))
    return a @ a.T + np.eye(6)


def test_coriolis_wrench_jacobian(rng):
    for _ in range(5):
        inertia, twist = _random_inertia(rng), rng.normal(size=6)
        exact = np.zeros((6, 6))
        laws.coriolis_wrench_jacobian(inertia, twist, exact)
        approx = _central(lambda x, m=inertia: laws.coriolis_wrench(m, x), twist)
        assert_close_relative(exact, approx, 1e-8, "coriolis")


def test_current_acceleration_wrench_jacobian(rng):
    for _ in range(5):
        added, omega, vc = _random_inertia(rng), rng.normal(size=3), rng.normal(size=3)
        exact = np.zeros((2, 6, 3))
        laws.current_acceleration_wrench_jacobian(added, *omega, *vc, exact[0], exact[1])
        by_omega = _central(
            lambda x, m=added, c=vc: laws.current_acceleration_wrench(m, *x, *c), omega
        )
        by_current = _central(
            lambda x, m=added, w=omega: laws.current_acceleration_wrench(m, *w, *x), vc
        )
        assert_close_relative(exact[0], by_omega, 1e-8, "d/domega")
        assert_close_relative(exact[1], by_current, 1e-8, "d/dv_c")


@pytest.mark.parametrize("diagonal", [True, False])
def test_damping_wrench_jacobian(rng, diagonal):
    for _ in range(5):
        linear = rng.normal(size=(6, 6))
        quadratic = np.diag(rng.uniform(1, 5, 6)) if diagonal else rng.normal(size=(6, 6))
        twist = rng.normal(size=6)
        exact = np.zeros((6, 6))
        laws.damping_wrench_jacobian(linear, quadratic, twist, exact)
        approx = _central(
            lambda x, d=linear, e=quadratic: laws.damping_wrench(d, e, diagonal, x), twist
        )
        assert_close_relative(exact, approx, 1e-8, "damping")


def test_forward_speed_damping_wrench_jacobian(rng):
    for _ in range(5):
        forward, twist = rng.normal(size=(6, 6)), rng.normal(size=6)
        exact = np.zeros((6, 6))
        laws.forward_speed_damping_wrench_jacobian(forward, twist, exact)
        approx = _central(lambda x, d=forward: laws.forward_speed_damping_wrench(d, x), twist)
        assert_close_relative(exact, approx, 1e-8, "forward-speed damping")


@pytest.mark.parametrize("case", ["split inside", "split at an end", "pure translation", "axial"])
def test_crossflow_wrench_jacobian_is_the_quadrature_derivative(rng, case):
    nodes, weights = gauss_legendre_unit(laws.CROSSFLOW_NODES)
    length, coefficient = 0.7, 68.0
    # cylinder-frame axial and roll drag of an off-axis cylinder (0: on-axis, in D_Q)
    axial, roll = (1.4, 0.03) if case == "axial" else (0.0, 0.0)
    for _ in range(5):
        twist = rng.normal(size=6)
        if case == "split inside":  # sway and yaw rate of opposite signs: v_n = 0 inside
            twist[1], twist[5], twist[4] = 0.3, -1.0, 0.1 * twist[4]
            twist[2] = -0.2 * twist[4] * length
        elif case == "pure translation":
            twist[4:] = 0.0
        exact = np.zeros((6, 6))
        laws.crossflow_wrench_jacobian(
            twist, length, coefficient, axial, roll, nodes, weights, exact
        )
        approx = _central(
            lambda x: laws.crossflow_wrench(x, length, coefficient, axial, roll, nodes, weights),
            twist,
            1e-6,
        )
        assert_close_relative(exact, approx, 1e-7, f"crossflow ({case})")


def test_hydrostatic_wrench_jacobian(rng):
    force, moment, up = rng.normal(), rng.normal(size=3), rng.normal(size=3)
    exact = np.zeros((6, 3))
    laws.hydrostatic_wrench_jacobian(force, *moment, exact)
    approx = _central(lambda x: laws.hydrostatic_wrench(force, *moment, *x), up)
    assert_close_relative(exact, approx, 1e-9, "hydrostatics")


# ---------------------------------------------------------------------- the dynamics
def _load(name: str, folder) -> aiauv_pin.Vehicle:
    if name in ("uniform", "stabilised"):
        return aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf(name))
    if name == "single_body":
        text = single_body_urdf()[0]
    elif name == "single_body_forward_speed":  # with UUV Simulator's surge-proportional damping
        a = np.random.default_rng(5).normal(size=(6, 6))
        forward = " ".join(repr(float(x)) for x in np.ravel(a @ a.T))
        text = single_body_urdf()[0].replace(
            "</quadratic_damping>",
            f"</quadratic_damping><linear_damping_forward_speed>{forward}"
            "</linear_damping_forward_speed>",
        )
    elif name == "off_axis_cylinder":
        text = OFF_AXIS_CYLINDER
    else:
        n, seed = (int(x) for x in name.removeprefix("generated_").split("_"))
        text = build_urdf(spec_from_dict(generated_vehicle_table(n, seed)))
    path = folder / f"{name}.urdf"
    path.write_text(text)
    return aiauv_pin.load_vehicle(path)


#: A hull and an arm whose collision cylinder is tilted and offset: the arm's axial and roll drag
#: are evaluated in the cylinder frame with the crossflow term (issue 32).
OFF_AXIS_CYLINDER = """<robot name="off_axis">
  <link name="hull"><inertial><mass value="20"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="1.5" iyz="0" izz="1.5"/></inertial>
    <collision><origin xyz="0.5 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder length="1.0" radius="0.1"/></geometry></collision></link>
  <link name="arm"><inertial><origin xyz="0.2 0 0"/><mass value="3"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
    <collision><origin xyz="0.2 0.03 0.05" rpy="0.2 1.1 0.3"/>
      <geometry><cylinder length="0.4" radius="0.05"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="hull"/><child link="arm"/>
    <origin xyz="1.0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="50" velocity="2"/></joint>
  <hydrodynamics>
    <link name="hull" model="slender_cylinder"/>
    <link name="arm" model="slender_cylinder" C_d1="0.6" C_d4="0.4"/>
  </hydrodynamics>
</robot>"""

VEHICLES = [
    "uniform",
    "stabilised",
    "single_body",
    "single_body_forward_speed",
    "generated_4_3",
    "generated_7_11",
    "off_axis_cylinder",
]


@pytest.fixture(scope="module", params=VEHICLES)
def vehicle(request, tmp_path_factory):
    return _load(request.param, tmp_path_factory.mktemp("deriv"))


def _finite_differences(vehicle, q, v, tau, current):
    model = vehicle.model

    def by_q(dq):
        return vehicle.acceleration(pin.integrate(model, q, dq), v, tau, current)

    da_dq = _central(by_q, np.zeros(vehicle.nv))
    da_dv = _central(lambda x: vehicle.acceleration(q, x, tau, current), v)
    da_dtau = _central(lambda x: vehicle.acceleration(q, v, x, current), tau)
    base = np.zeros(3) if current is None else current
    da_dcurrent = _central(lambda x: vehicle.acceleration(q, v, tau, x), base)
    return da_dq, da_dv, da_dtau, da_dcurrent


@pytest.mark.parametrize("current", CURRENTS, ids=["still", "current"])
def test_jacobians_match_central_differences_and_backends_agree(vehicle, current, rng):
    names = ("da_dq", "da_dv", "da_dtau", "da_dcurrent")
    for _ in range(2):
        q, v = random_state(vehicle.model, rng)
        tau = rng.normal(scale=20.0, size=vehicle.nv)
        compiled = acceleration_derivatives(vehicle, q, v, tau, current, backend="numba")
        reference = acceleration_derivatives(vehicle, q, v, tau, current, backend="pinocchio")
        np.testing.assert_allclose(
            compiled.acceleration, vehicle.acceleration(q, v, tau, current), rtol=1e-9, atol=1e-9
        )
        for name, a, b in zip(names, compiled[1:], reference[1:], strict=True):
            # 1e-9 of the matrix's scale: M(q) of a generated vehicle has a condition number near
            # 1e5, so its smallest entries carry the rounding of its largest
            scale = max(1.0, np.abs(b).max())
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * scale, err_msg=name)
        for name, exact, approx in zip(
            names, compiled[1:], _finite_differences(vehicle, q, v, tau, current), strict=True
        ):
            assert_close_relative(exact, approx, FD_RTOL, name)


def test_rigid_only_matches_pinocchio_aba_derivatives(rng):
    """With every fluid effect off the compiled derivatives are Pinocchio's own ABA derivatives."""
    vehicle = aiauv_pin.load_vehicle(added_mass=False, damping=False, restoring=False)
    q, v = random_state(vehicle.model, rng)
    tau = rng.normal(scale=20.0, size=vehicle.nv)
    ours = acceleration_derivatives(vehicle, q, v, tau, backend="numba")
    data = vehicle.model.createData()
    pin.computeABADerivatives(vehicle.model, data, q, v, tau)
    np.testing.assert_allclose(ours.da_dq, data.ddq_dq, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ours.da_dv, data.ddq_dv, rtol=1e-9, atol=1e-9)
    minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
    np.testing.assert_allclose(ours.da_dtau, minv, rtol=1e-9, atol=1e-9)


def test_non_uniform_current_is_a_one_line_error(paper_vehicle):
    q, v = paper_vehicle.neutral_configuration(), np.zeros(paper_vehicle.nv)
    shear = Current.shear([0.2, 0.0, 0.0], [0.0, 0.0, 0.1])
    with pytest.raises(ArgumentError, match="uniform in space"):
        paper_vehicle.acceleration_derivatives(q, v, np.zeros(paper_vehicle.nv), shear)


def _random_fluid_model(rng, nb: int = 2) -> laws.FluidModel:
    """Two bodies, two links whose frames and cylinder frames are moved off the bodies' (the
    branches a bundled vehicle, whose links are their bodies, does not take)."""
    from aiauv_hydro.numerics.spatial import motion_transform

    def rotation():
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        return q * np.sign(np.linalg.det(q))

    nodes, weights = gauss_legendre_unit(laws.CROSSFLOW_NODES)
    nl = 2
    return laws.FluidModel(
        added_mass=np.array([_random_inertia(rng) for _ in range(nb)]),
        hydrostatics=rng.normal(size=(nb, 4)),
        current_probe=np.zeros((nb, 3)),
        displaced=rng.normal(size=(nb, 4)),
        link_body=np.array([0, 1], dtype=np.int64),
        link_from_body=np.array(
            [motion_transform(rotation(), rng.normal(size=3)) for _ in range(nl)]
        ),
        link_is_body=np.zeros(nl, dtype=np.int64),
        linear_damping=rng.normal(size=(nl, 6, 6)),
        quadratic_damping=rng.normal(size=(nl, 6, 6)),
        quadratic_is_diagonal=np.zeros(nl, dtype=np.int64),
        forward_speed_damping=rng.normal(size=(nl, 6, 6)),
        has_forward_speed_damping=np.ones(nl, dtype=np.int64),
        has_crossflow=np.ones(nl, dtype=np.int64),
        cylinder_from_link=np.array(
            [motion_transform(rotation(), rng.normal(size=3)) for _ in range(nl)]
        ),
        cylinder_is_link=np.zeros(nl, dtype=np.int64),
        cylinder_length=np.array([0.6, 0.9]),
        strip_coefficient=np.array([50.0, 80.0]),
        axial_coefficient=np.array([1.4, 0.0]),
        roll_coefficient=np.array([0.03, 0.0]),
        gauss_nodes=nodes,
        gauss_weights=weights,
    )


def test_body_fluid_bias_jacobians_with_moved_link_frames(rng):
    fluid = _random_fluid_model(rng)
    nb = 2
    rotation = np.tile(np.eye(3), (nb, 1, 1))  # body axes = world axes: v_c is the current
    twist = rng.normal(size=(nb, 6))
    current = rng.normal(size=(nb, 3))

    def bias(twist, current):
        out = np.zeros((nb, 6))
        laws.add_body_fluid_bias(
            fluid, rotation, twist, current, out, np.zeros((nb, 6)), np.zeros((3, 6))
        )
        return out

    d_twist, d_current, d_up = np.zeros((nb, 6, 6)), np.zeros((nb, 6, 3)), np.zeros((nb, 6, 3))
    laws.body_fluid_bias_jacobians(
        fluid, rotation, twist, current, d_twist, d_current, d_up, np.zeros((5, 6, 6))
    )
    for b in range(nb):

        def by_twist(x, b=b):
            moved = twist.copy()
            moved[b] = x
            return bias(moved, current)[b]

        def by_current(x, b=b):
            moved = current.copy()
            moved[b] = x
            return bias(twist, moved)[b]

        assert_close_relative(d_twist[b], _central(by_twist, twist[b], 1e-6), 1e-7, "d/dnu")
        assert_close_relative(d_current[b], _central(by_current, current[b], 1e-6), 1e-7, "d/dv_c")


# ---------------------------------------------------------------------- the water's acceleration
TIDAL = dict(amplitude=[0.4, -0.25, 0.3], period=5.0, phase=0.4)
TIDAL_TIME = 1.7  # [s]: cos(2 pi t / T + phi) = -0.74, the water accelerates at ~0.37 m/s^2


def _tidal(mean) -> Current:
    return Current.tidal(mean, TIDAL["amplitude"], TIDAL["period"], TIDAL["phase"])


@pytest.mark.parametrize("name", ["uniform", "single_body", "generated_4_3"])
def test_tidal_current_jacobians_include_the_water_acceleration(name, rng, tmp_path):
    """With a tidal current (Froude-Krylov and the added mass's reaction to ``dV/dt``, issue 33)
    the exact Jacobians match central differences of ``Vehicle.acceleration`` at the same time to
    ``FD_RTOL`` (1e-6, stated before measuring) and the two backends agree to 1e-9; the
    quasi-steady current gives other derivatives (the new terms are in them)."""
    vehicle = _load(name, tmp_path)
    mean = np.array([0.3, -0.2, 0.15])
    water, t = _tidal(mean), TIDAL_TIME
    names = ("da_dq", "da_dv", "da_dtau", "da_dcurrent")
    q, v = random_state(vehicle.model, rng)
    tau = rng.normal(scale=20.0, size=vehicle.nv)
    compiled = acceleration_derivatives(vehicle, q, v, tau, water, t=t, backend="numba")
    reference = acceleration_derivatives(vehicle, q, v, tau, water, t=t, backend="pinocchio")
    np.testing.assert_allclose(
        compiled.acceleration, vehicle.acceleration(q, v, tau, water, t=t), rtol=1e-9, atol=1e-9
    )
    for what, a, b in zip(names, compiled[1:], reference[1:], strict=True):
        scale = max(1.0, np.abs(b).max())
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * scale, err_msg=what)
    model = vehicle.model
    approx = (
        _central(lambda dq: vehicle.acceleration(pin.integrate(model, q, dq), v, tau, water, t=t),
                 np.zeros(vehicle.nv)),
        _central(lambda x: vehicle.acceleration(q, x, tau, water, t=t), v),
        _central(lambda x: vehicle.acceleration(q, v, x, water, t=t), tau),
        _central(lambda x: vehicle.acceleration(q, v, tau, _tidal(x), t=t), mean),
    )  # fmt: skip
    for what, exact, fd in zip(names, compiled[1:], approx, strict=True):
        assert_close_relative(exact, fd, FD_RTOL, what)
    steady = acceleration_derivatives(vehicle, q, v, tau, water.quasi_steady(), t=t)
    assert np.abs(steady.da_dq - compiled.da_dq).max() > 1e-6 * np.abs(compiled.da_dq).max()
