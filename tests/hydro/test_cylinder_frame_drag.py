"""Axial and roll quadratic drag of a cylinder off its link's axis, evaluated in the cylinder frame
with the crossflow term (issue 32): against a direct strip sum, against the link-frame ``D_Q`` of an
on-axis cylinder, its power, and on an annotated Z1 arm on both backends."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import aiauv_pin
from aiauv_hydro.estimate.slender_cylinder import (
    SlenderCylinderCoefficients,
    exact_axial_and_roll,
    quadratic_damping_matrix,
    slender_cylinder_link,
)
from aiauv_hydro.laws.crossflow import crossflow_wrench
from aiauv_hydro.numerics.spatial import motion_transform
from aiauv_hydro.spec import CrossflowDrag, HydroError
from aiauv_hydro.urdf.annotate import format_annotation
from aiauv_hydro.urdf.block_reader import read_hydrodynamics
from aiauv_pin.app.annotate_command import annotate_file
from aiauv_pin.errors import VehicleLoadError

RHO, LENGTH, RADIUS = 1025.0, 0.4, 0.03
#: Only the axial and roll quadratic drag (the other terms are checked elsewhere).
AXIAL_AND_ROLL = SlenderCylinderCoefficients(C_d1=0.3, C_d4=0.15, C_dC=0.0)

#: One link on a tilted, offset collision cylinder, with a slender-cylinder block.
TILTED = (
    '<robot name="r"><link name="arm"><inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'
    '<collision><origin xyz="0.2 0 0" rpy="0 1.0 0"/>'
    '<geometry><cylinder length="0.4" radius="0.05"/></geometry></collision></link>'
    '<hydrodynamics><link name="arm" model="slender_cylinder" C_d1="0.25" C_d4="0.05"/>'
    "</hydrodynamics></robot>"
)


def _rotation(rng) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _placements(rng):
    """(rotation, translation) of cylinders: on the link axis, Z1-like offset, tilted, general."""
    y_down = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # cylinder x on link -z
    return {
        "on the link axis": (np.eye(3), np.zeros(3)),
        "along link z": (y_down, np.zeros(3)),
        "offset, parallel (Z1 link03)": (y_down, np.array([0.128, 0.0, 0.055])),
        "tilted through the origin": (_rotation(rng), np.zeros(3)),
        "tilted and offset": (_rotation(rng), rng.normal(scale=0.2, size=3)),
    }


def _link_wrench(link, twist: np.ndarray) -> np.ndarray:
    """The link-frame axial and roll drag as the laws apply it: ``-D_Q |nu| nu`` plus the
    crossflow record's cylinder-frame wrench moved back, ``X^T w(X nu)``."""
    c = link.crossflow
    transform = motion_transform(c.rotation, c.translation)
    in_cylinder = crossflow_wrench(
        transform @ twist,
        c.length,
        c.strip_coefficient,
        axial_coefficient=c.axial_coefficient,
        roll_coefficient=c.roll_coefficient,
    )
    return -link.quadratic_damping @ (np.abs(twist) * twist) + transform.T @ in_cylinder


def _strip_sum(rotation, translation, twist, stations: int = 20_000) -> np.ndarray:
    """Direct strip sum, link frame, about the link origin: station ``s = r0 + x e`` moves with
    ``v + omega x s``; per unit length the axial drag ``-(c_1 / L) |u_a| u_a e`` acts at ``s`` and
    the roll moment ``-(c_4 / L) |p_a| p_a e`` (midpoint rule over ``[0, L]``)."""
    c1 = 0.5 * RHO * math.pi * RADIUS**2 * AXIAL_AND_ROLL.C_d1
    c4 = 0.5 * RHO * math.pi * LENGTH * RADIUS**4 * AXIAL_AND_ROLL.C_d4
    axis = rotation[:, 0]
    dx = LENGTH / stations
    x = (np.arange(stations) + 0.5) * dx
    points = translation + x[:, None] * axis
    velocity = twist[:3] + np.cross(twist[3:], points)
    u_a = velocity @ axis
    p_a = twist[3:] @ axis
    force = -(c1 / LENGTH) * (np.abs(u_a) * u_a)[:, None] * axis * dx
    moment = np.cross(points, force).sum(axis=0) - c4 * abs(p_a) * p_a * axis
    return np.concatenate((force.sum(axis=0), moment))


@pytest.mark.parametrize(
    "which",
    [
        "on the link axis",
        "along link z",
        "offset, parallel (Z1 link03)",
        "tilted through the origin",
        "tilted and offset",
    ],
)
def test_axial_and_roll_drag_match_a_direct_strip_sum(which, rng):
    rotation, translation = _placements(rng)[which]
    link = slender_cylinder_link(
        "arm",
        LENGTH,
        RADIUS,
        RHO,
        coefficients=AXIAL_AND_ROLL,
        rotation=rotation,
        translation=translation,
    )
    axial_exact, roll_exact = exact_axial_and_roll(rotation, translation)
    # exact link-frame forms stay in D_Q (nothing moves for them); the others ride the crossflow
    assert (link.crossflow.axial_drag_coefficient == 0.0) == axial_exact
    assert (link.crossflow.roll_drag_coefficient == 0.0) == roll_exact
    for _ in range(20):
        twist = rng.normal(size=6) * np.array([1.0, 1.0, 1.0, 3.0, 3.0, 3.0])
        expected = _strip_sum(rotation, translation, twist)
        got = _link_wrench(link, twist)
        scale = max(1.0, float(np.abs(expected).max()))
        assert np.abs(got - expected).max() < 1e-9 * scale, (which, got, expected)


def test_on_axis_cylinder_gives_the_same_wrench_through_the_new_terms(rng):
    """An on-axis cylinder: today's link-frame ``-D_Q |nu| nu`` and the cylinder-frame terms agree
    (1e-12), so moving a cylinder off the axis changes only where the term is evaluated."""
    d_q = quadratic_damping_matrix(LENGTH, RADIUS, RHO, AXIAL_AND_ROLL)
    swap = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    for rotation in (np.eye(3), swap):
        transform = motion_transform(rotation, np.zeros(3))
        link_d_q = transform.T @ d_q @ transform  # exact: rows 0 and 3 are signed unit rows
        record = CrossflowDrag(
            LENGTH,
            RADIUS,
            0.0,
            RHO,
            rotation,
            np.zeros(3),
            axial_drag_coefficient=AXIAL_AND_ROLL.C_d1,
            roll_drag_coefficient=AXIAL_AND_ROLL.C_d4,
        )
        assert record.axial_coefficient == pytest.approx(d_q[0, 0], rel=1e-15)
        assert record.roll_coefficient == pytest.approx(d_q[3, 3], rel=1e-15)
        for _ in range(50):
            twist = rng.normal(size=6)
            today = -link_d_q @ (np.abs(twist) * twist)
            new = transform.T @ crossflow_wrench(
                transform @ twist,
                LENGTH,
                0.0,
                axial_coefficient=record.axial_coefficient,
                roll_coefficient=record.roll_coefficient,
            )
            np.testing.assert_allclose(
                new, today, rtol=0.0, atol=1e-12 * max(1.0, abs(today).max())
            )


def test_zero_coefficients_leave_the_crossflow_wrench_bit_identical(rng):
    twists = rng.normal(size=(200, 6))
    plain = crossflow_wrench(twists, LENGTH, 25.0)
    explicit = crossflow_wrench(twists, LENGTH, 25.0, axial_coefficient=0.0, roll_coefficient=0.0)
    assert np.array_equal(plain, explicit)
    assert not np.any(plain[:, 0]) and not np.any(plain[:, 3])


def test_the_new_terms_never_add_energy(rng):
    """Power ``nu . tau`` of the whole cylinder-frame wrench (crossflow, axial, roll) <= 0, in the
    link frame too (``X^T`` preserves power)."""
    coefficients = SlenderCylinderCoefficients(C_d1=0.3, C_d4=0.15, C_dC=0.9)
    for _ in range(5):
        rotation, translation = _rotation(rng), rng.normal(scale=0.2, size=3)
        link = slender_cylinder_link(
            "arm",
            LENGTH,
            RADIUS,
            RHO,
            coefficients=coefficients,
            rotation=rotation,
            translation=translation,
        )
        for _ in range(100):
            twist = rng.normal(size=6) * rng.uniform(0.01, 5.0)
            power = twist @ _link_wrench(link, twist)
            assert power <= 0.0
        c = link.crossflow
        only_new = crossflow_wrench(
            np.array([1.3, 0.0, 0.0, -2.0, 0.0, 0.0]),
            LENGTH,
            0.0,
            axial_coefficient=c.axial_coefficient,
            roll_coefficient=c.roll_coefficient,
        )
        assert only_new[0] < 0.0 and only_new[3] > 0.0  # opposes u_a = 1.3 and p_a = -2


def test_tilted_slender_link_in_a_hydrodynamics_block_loads():
    """``<link model="slender_cylinder"/>`` on a tilted cylinder: refused before issue 32 (no exact
    link-frame form), now loaded with the axial and roll drag in the cylinder frame."""
    text = TILTED
    (link,) = read_hydrodynamics(text).links
    assert link.crossflow.axial_drag_coefficient == 0.25
    assert link.crossflow.roll_drag_coefficient == 0.05
    assert not np.any(link.quadratic_damping)
    with pytest.raises(HydroError) as refused:  # the reader's plausible range still applies
        read_hydrodynamics(text.replace('C_d1="0.25"', 'C_d1="1e20"'))
    assert "C_d1" in str(refused.value) and "\n" not in str(refused.value)


@pytest.fixture(scope="module")
def annotated_z1(tmp_path_factory):
    from aiauv_pin.description.robots import example_robot_urdf

    try:
        source = example_robot_urdf("z1_description/urdf/z1.urdf")
    except VehicleLoadError:
        pytest.skip("example-robot-data is not installed")
    out = tmp_path_factory.mktemp("z1") / "z1.urdf"
    annotation = annotate_file(source, out, fluid_density=RHO)
    return annotation, out


def test_annotated_z1_keeps_the_axial_drag_of_its_off_axis_links(annotated_z1):
    annotation, out = annotated_z1
    table = format_annotation(annotation)
    assert "left out" not in table
    off_axis = [row for row in annotation.links if "off the link axis" in row.source]
    assert {row.link for row in off_axis} >= {"link03", "link04"}
    assert all("cylinder frame" in row.source for row in off_axis)
    loaded = {link.link: link for link in read_hydrodynamics(out).links}
    for row in off_axis:
        crossflow = loaded[row.link].crossflow
        assert crossflow.axial_drag_coefficient == 0.2  # C_d1's default, no longer 0


def test_annotated_z1_compiled_matches_reference(annotated_z1, rng):
    _, out = annotated_z1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fast = aiauv_pin.load_vehicle(out, backend="numba")
        reference = aiauv_pin.load_vehicle(out, backend="pinocchio")
    assert fast.active_backend == "numba" and fast.fixed_base
    fluid = fast.fluid_model()
    assert np.count_nonzero(fluid.axial_coefficient) >= 2
    for current in (None, (0.3, -0.2, 0.1)):
        for _ in range(5):
            q = fast.neutral_configuration()
            q[7:] = rng.uniform(-1.0, 1.0, fast.nq - 7)
            v, tau = rng.normal(size=fast.nv) * 2.0, rng.normal(size=fast.nv)
            a = fast.acceleration(q, v, tau, current)
            b = reference.acceleration(q, v, tau, current)
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


def test_gz_export_says_the_off_axis_axial_drag_stays_behind(tmp_path):
    from aiauv_pin.interop.gz import export_sdf

    source = tmp_path / "tilted.urdf"
    source.write_text(TILTED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        notes = export_sdf(source, tmp_path / "tilted.sdf")
    assert any("axial/roll drag of 1 off-axis cylinder(s)" in note for note in notes), notes
