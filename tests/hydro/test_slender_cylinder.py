"""Slender-cylinder matrices and batched crossflow drag against closed forms and fine quadrature."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_hydro import (
    DEFAULT_COEFFICIENTS,
    HydroError,
    SlenderCylinderCoefficients,
    added_mass_matrix,
    crossflow_wrench,
    linear_damping_matrix,
    quadratic_damping_matrix,
    slender_cylinder_link,
)

RHO = 1000.0
RADIUS = 0.085
LENGTH = 0.62


def point_transform(offset: np.ndarray) -> np.ndarray:
    """Twist at the origin -> twist at ``offset`` (same axes): v' = v + w x offset."""
    transform = np.eye(6)
    for column in range(3):
        unit = np.zeros(3)
        unit[column] = 1.0
        transform[:3, 3 + column] = np.cross(unit, offset)
    return transform


def midpoint_crossflow(velocity: np.ndarray, length: float, k: float, count: int = 200_000):
    """Crossflow wrench by a plain midpoint rule (independent of the library's quadrature)."""
    x = (np.arange(count) + 0.5) * length / count
    dx = length / count
    normal = np.stack((velocity[1] + velocity[5] * x, velocity[2] - velocity[4] * x))
    load = -k * np.linalg.norm(normal, axis=0) * normal
    return np.array(
        [0.0, load[0].sum() * dx, load[1].sum() * dx, 0.0, -(x * load[1]).sum() * dx,
         (x * load[0]).sum() * dx]
    )  # fmt: skip


def scaled_error(value: np.ndarray, reference: np.ndarray, length: float) -> float:
    """Relative error of a wrench with moments divided by the length (common units)."""
    scale = np.array([1.0, 1.0, 1.0, 1.0 / length, 1.0 / length, 1.0 / length])
    return float(np.linalg.norm((value - reference) * scale) / np.linalg.norm(reference * scale))


# ----------------------------------------------------------------------------- closed forms


def test_added_mass_equals_paper_data_closed_form():
    m_a = 1000.0 * math.pi * 0.085**2  # rho pi r^2 C_a with C_a = 1
    assert m_a == pytest.approx(22.698007, rel=1e-7)
    L = 0.62
    expected = np.zeros((6, 6))
    expected[0, 0] = 0.2 * L * m_a
    expected[1, 1] = expected[2, 2] = L * m_a
    expected[4, 4] = expected[5, 5] = L**3 / 3 * m_a
    expected[1, 5] = expected[5, 1] = L**2 / 2 * m_a
    expected[2, 4] = expected[4, 2] = -(L**2) / 2 * m_a
    matrix = added_mass_matrix(L, RADIUS, RHO)
    np.testing.assert_allclose(matrix, expected, rtol=1e-13, atol=1e-13)
    # A few entries as plain numbers.
    assert matrix[1, 1] == pytest.approx(14.072764, rel=1e-6)
    assert matrix[5, 1] == pytest.approx(4.362557, rel=1e-6)
    assert matrix[3, 3] == 0.0


def test_linear_and_quadratic_damping_equal_paper_data_closed_forms():
    L, r = 0.584, RADIUS
    k_L = 1000.0 * r * L * 0.1 * 1.0  # rho r L C_dL v_ref
    expected = np.zeros((6, 6))
    expected[0, 0] = 0.1 * k_L
    expected[1, 1] = expected[2, 2] = k_L
    expected[3, 3] = 0.1 * r**2 * k_L
    expected[4, 4] = expected[5, 5] = L**2 / 3 * k_L
    expected[1, 5] = expected[5, 1] = L / 2 * k_L
    expected[2, 4] = expected[4, 2] = -L / 2 * k_L
    np.testing.assert_allclose(linear_damping_matrix(L, r, RHO), expected, rtol=1e-13, atol=1e-15)

    quadratic = quadratic_damping_matrix(L, r, RHO)
    expected_q = np.zeros((6, 6))
    expected_q[0, 0] = 0.5 * 1000.0 * math.pi * r**2 * 0.2
    expected_q[3, 3] = 0.5 * 1000.0 * math.pi * L * r**4 * 0.1
    np.testing.assert_allclose(quadratic, expected_q, rtol=1e-13, atol=0.0)


@pytest.mark.parametrize("length", [0.104, 0.37, 0.726, 3.0])
@pytest.mark.parametrize("alpha", [0.0, 0.2, 1.0])
def test_added_mass_is_symmetric_positive_semidefinite(length, alpha):
    matrix = added_mass_matrix(length, 0.085, 1025.0, SlenderCylinderCoefficients(alpha=alpha))
    np.testing.assert_array_equal(matrix, matrix.T)
    eigenvalues = np.linalg.eigvalsh(matrix)
    assert eigenvalues.min() >= -1e-12 * eigenvalues.max()
    # Only roll (and, for alpha = 0, surge) carries no added mass.
    assert np.sum(eigenvalues < 1e-9 * eigenvalues.max()) == (2 if alpha == 0.0 else 1)


def test_strip_theory_about_centre_moved_to_rear_end_gives_the_couplings():
    """Centre-of-cylinder strip theory (no couplings, L^3/12) moved by a spatial transform."""
    L = 0.726
    coefficients = SlenderCylinderCoefficients(alpha=0.3, beta=0.2, gamma=0.4)
    m_a = RHO * math.pi * RADIUS**2
    about_centre = m_a * np.diag([0.3 * L, L, L, 0.0, L**3 / 12, L**3 / 12])
    to_centre = point_transform(np.array([L / 2, 0.0, 0.0]))
    moved = to_centre.T @ about_centre @ to_centre
    np.testing.assert_allclose(
        added_mass_matrix(L, RADIUS, RHO, coefficients), moved, rtol=1e-12, atol=1e-12
    )

    k_L = RHO * RADIUS * L * 0.1
    damping_centre = k_L * np.diag([0.2, 1.0, 1.0, 0.4 * RADIUS**2, L**2 / 12, L**2 / 12])
    np.testing.assert_allclose(
        linear_damping_matrix(L, RADIUS, RHO, coefficients),
        to_centre.T @ damping_centre @ to_centre,
        rtol=1e-12,
        atol=1e-12,
    )


def test_added_mass_energy_equals_strip_integral():
    """1/2 nu^T M nu = 1/2 int m_a |v_n(x)|^2 dx + 1/2 alpha m_a L u^2 for random twists."""
    rng = np.random.default_rng(1)
    L = 0.584
    m_a = RHO * math.pi * RADIUS**2
    x = (np.arange(100_000) + 0.5) * L / 100_000
    matrix = added_mass_matrix(L, RADIUS, RHO)
    for _ in range(5):
        nu = rng.normal(size=6)
        normal_squared = (nu[1] + nu[5] * x) ** 2 + (nu[2] - nu[4] * x) ** 2
        energy = 0.5 * m_a * normal_squared.sum() * L / 100_000 + 0.5 * 0.2 * m_a * L * nu[0] ** 2
        assert 0.5 * nu @ matrix @ nu == pytest.approx(energy, rel=1e-8)


# ----------------------------------------------------------------------------- link placement


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def test_link_matrices_in_a_displaced_rotated_frame_preserve_energy_and_power():
    rotation = rotation_about(np.array([0.3, -0.5, 0.8]), 0.9)
    translation = np.array([0.1, -0.05, 0.2])
    coefficients = SlenderCylinderCoefficients(C_d1=0.0, C_d4=0.0)  # no diagonal-only terms
    link = slender_cylinder_link(
        "arm", LENGTH, RADIUS, RHO, coefficients=coefficients, rotation=rotation,
        translation=translation,
    )  # fmt: skip
    m_cyl = added_mass_matrix(LENGTH, RADIUS, RHO, coefficients)
    d_cyl = linear_damping_matrix(LENGTH, RADIUS, RHO, coefficients)
    rng = np.random.default_rng(2)
    for _ in range(5):
        v, w = rng.normal(size=3), rng.normal(size=3)
        # Twist of the cylinder frame, in its own axes: rigid-body kinematics.
        nu_cyl = np.concatenate((rotation.T @ (v + np.cross(w, translation)), rotation.T @ w))
        nu_link = np.concatenate((v, w))
        assert nu_link @ link.added_mass @ nu_link == pytest.approx(nu_cyl @ m_cyl @ nu_cyl)
        assert nu_link @ link.linear_damping @ nu_link == pytest.approx(nu_cyl @ d_cyl @ nu_cyl)
    np.testing.assert_array_equal(link.added_mass, link.added_mass.T)
    np.testing.assert_allclose(
        link.center_of_buoyancy, translation + rotation @ [LENGTH / 2, 0, 0], atol=1e-15
    )
    assert link.volume == pytest.approx(math.pi * RADIUS**2 * LENGTH)
    np.testing.assert_array_equal(link.crossflow.rotation, rotation)
    np.testing.assert_array_equal(link.crossflow.translation, translation)
    assert link.crossflow.strip_coefficient == pytest.approx(RHO * RADIUS * 0.8)


def test_cylinder_along_link_y_moves_axial_and_roll_drag_to_sway_and_pitch():
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # x_c = link y
    link = slender_cylinder_link(
        "arm", LENGTH, RADIUS, RHO, rotation=rotation, translation=np.array([0, 0.1, 0])
    )
    reference = quadratic_damping_matrix(LENGTH, RADIUS, RHO)
    expected = np.zeros((6, 6))
    expected[1, 1] = reference[0, 0]
    expected[4, 4] = reference[3, 3]
    np.testing.assert_allclose(link.quadratic_damping, expected, rtol=1e-15, atol=0.0)


def test_axial_drag_offset_from_the_axis_moves_to_the_cylinder_frame():
    """Refused before issue 32; now the axial drag rides the crossflow record (exact in the
    cylinder frame; tests/hydro/test_cylinder_frame_drag.py) and the roll drag stays in D_Q."""
    link = slender_cylinder_link("arm", LENGTH, RADIUS, RHO, translation=np.array([0, 0, 0.1]))
    reference = quadratic_damping_matrix(LENGTH, RADIUS, RHO)
    assert link.crossflow.axial_drag_coefficient == DEFAULT_COEFFICIENTS.C_d1
    assert link.crossflow.axial_coefficient == pytest.approx(reference[0, 0], rel=1e-15)
    assert link.crossflow.roll_drag_coefficient == 0.0
    expected = np.zeros((6, 6))
    expected[3, 3] = reference[3, 3]
    np.testing.assert_allclose(link.quadratic_damping, expected, rtol=1e-15, atol=0.0)


@pytest.mark.parametrize(
    "kwargs", [{"C_a": -1.0}, {"v_ref": 0.0}, {"C_dC": float("nan")}, {"alpha": "x"}]
)
def test_bad_coefficients_are_refused(kwargs):
    with pytest.raises(HydroError) as error:
        SlenderCylinderCoefficients(**kwargs)
    assert "\n" not in str(error.value)


def test_bad_dimensions_and_rotation_are_refused():
    with pytest.raises(HydroError):
        added_mass_matrix(-0.1, RADIUS, RHO)
    with pytest.raises(HydroError):
        slender_cylinder_link("a", LENGTH, RADIUS, RHO, rotation=2 * np.eye(3))


# ----------------------------------------------------------------------------- crossflow


K = RHO * RADIUS * 0.8  # strip coefficient rho r C_dC


@pytest.mark.parametrize("sway", [0.7, -0.4])
def test_pure_sway(sway):
    wrench = crossflow_wrench(np.array([0, sway, 0, 0, 0, 0.0]), LENGTH, K)
    force = -K * LENGTH * abs(sway) * sway
    expected = [0, force, 0, 0, 0, force * LENGTH / 2]  # resultant at mid-length
    np.testing.assert_allclose(wrench, expected, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("yaw_rate", [1.3, -0.6])
def test_pure_yaw_rotation(yaw_rate):
    wrench = crossflow_wrench(np.array([0, 0, 0, 0, 0, yaw_rate]), LENGTH, K)
    force = -K * abs(yaw_rate) * yaw_rate * LENGTH**3 / 3
    moment = -K * abs(yaw_rate) * yaw_rate * LENGTH**4 / 4
    np.testing.assert_allclose(wrench, [0, force, 0, 0, 0, moment], rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("heave", [0.5, -0.9])
def test_pure_heave(heave):
    wrench = crossflow_wrench(np.array([0, 0, heave, 0, 0, 0.0]), LENGTH, K)
    force = -K * LENGTH * abs(heave) * heave
    # M_y = -int x f_z dx: a downward-resisting force ahead of the origin pitches nose up.
    expected = [0, 0, force, 0, -force * LENGTH / 2, 0]
    np.testing.assert_allclose(wrench, expected, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("pitch_rate", [0.8, -1.1])
def test_pure_pitch_rotation(pitch_rate):
    wrench = crossflow_wrench(np.array([0, 0, 0, 0, pitch_rate, 0.0]), LENGTH, K)
    # v_n,z = -q x, so f_z = +k |q| q x^2 and M_y = -int x f_z = -k |q| q L^4 / 4.
    force = K * abs(pitch_rate) * pitch_rate * LENGTH**3 / 3
    moment = -K * abs(pitch_rate) * pitch_rate * LENGTH**4 / 4
    np.testing.assert_allclose(wrench, [0, 0, force, 0, moment, 0], rtol=1e-13, atol=1e-15)


def test_sway_and_yaw_with_sign_change_inside_the_cylinder():
    velocity = np.array([0.2, 0.3, 0.0, 0.1, 0.0, -1.0])  # v_n,y = 0.3 - x changes sign at 0.3
    reference = midpoint_crossflow(velocity, 0.6, K)
    assert scaled_error(crossflow_wrench(velocity, 0.6, K), reference, 0.6) < 1e-9
    # Analytic: F_y = -k int_0^0.6 |0.3 - x| (0.3 - x) dx = 0 by antisymmetry about x = 0.3.
    assert abs(crossflow_wrench(velocity, 0.6, K)[1]) < 1e-12


def test_general_states_match_a_fine_midpoint_rule():
    rng = np.random.default_rng(3)
    for _ in range(20):
        velocity = rng.normal(size=6) * [0.5, 0.5, 0.5, 1.0, 1.0, 1.0]
        length = rng.uniform(0.1, 1.0)
        reference = midpoint_crossflow(velocity, length, K)
        assert scaled_error(crossflow_wrench(velocity, length, K), reference, length) < 1e-7


def near_singular_states(rng: np.random.Generator, count: int, length: float) -> np.ndarray:
    """States whose normal velocity nearly vanishes somewhere on or near the cylinder."""
    states = np.zeros((count, 6))
    for index in range(count):
        angle = rng.uniform(0, 2 * math.pi)
        direction = np.array([math.cos(angle), math.sin(angle)])
        slope = direction * rng.uniform(0.2, 2.0)
        closest = rng.uniform(-0.2, 1.2) * length
        miss = 10.0 ** rng.uniform(-7, 0) * np.linalg.norm(slope) * length
        offset = -slope * closest + miss * np.array([-direction[1], direction[0]])
        states[index] = [rng.normal(), offset[0], offset[1], rng.normal(), -slope[1], slope[0]]
    return states


def test_default_quadrature_is_converged_to_one_part_per_million():
    """A much finer rule (200 nodes per part, and the midpoint rule) changes nothing above 1e-6."""
    rng = np.random.default_rng(4)
    length = 0.584
    states = np.concatenate((near_singular_states(rng, 40, length), rng.normal(size=(40, 6)) * 0.5))
    default = crossflow_wrench(states, length, K)
    fine = crossflow_wrench(states, length, K, nodes=200)
    for index in range(len(states)):
        assert scaled_error(default[index], fine[index], length) < 1e-6
    for index in range(0, len(states), 8):
        reference = midpoint_crossflow(states[index], length, K)
        assert scaled_error(default[index], reference, length) < 1e-6


def test_crossflow_dissipates():
    """wrench . nu = -k int |v_n|^3 dx <= 0 (power of the drag on the body)."""
    rng = np.random.default_rng(5)
    velocities = rng.normal(size=(500, 6))
    lengths = rng.uniform(0.05, 2.0, size=500)
    wrenches = crossflow_wrench(velocities, lengths, K)
    power = np.einsum("ij,ij->i", wrenches, velocities)
    assert np.all(power <= 1e-12 * np.abs(wrenches).max())
    state = velocities[0]
    x = (np.arange(100_000) + 0.5) * lengths[0] / 100_000
    cubed = np.hypot(state[1] + state[5] * x, state[2] - state[4] * x) ** 3
    assert power[0] == pytest.approx(-K * cubed.sum() * lengths[0] / 100_000, rel=1e-7)


def test_axial_velocity_and_roll_give_no_crossflow():
    wrench = crossflow_wrench(np.array([1.0, 0, 0, 2.0, 0, 0]), LENGTH, K)
    np.testing.assert_array_equal(wrench, np.zeros(6))


def test_batched_equals_one_by_one():
    rng = np.random.default_rng(6)
    velocities = rng.normal(size=(3, 4, 6))
    lengths = rng.uniform(0.1, 1.0, size=(3, 4))
    coefficients = rng.uniform(10.0, 100.0, size=(3, 4))
    batched = crossflow_wrench(velocities, lengths, coefficients)
    assert batched.shape == (3, 4, 6)
    for i in range(3):
        for j in range(4):
            single = crossflow_wrench(velocities[i, j], lengths[i, j], coefficients[i, j])
            np.testing.assert_allclose(batched[i, j], single, rtol=1e-14, atol=1e-14)


def test_crossflow_input_errors():
    with pytest.raises(HydroError):
        crossflow_wrench(np.zeros(5), LENGTH, K)
    with pytest.raises(HydroError):
        crossflow_wrench(np.zeros(6), 0.0, K)
    with pytest.raises(HydroError):
        crossflow_wrench(np.zeros(6), LENGTH, -1.0)
    with pytest.raises(HydroError):
        crossflow_wrench(np.zeros(6), LENGTH, K, nodes=0)
