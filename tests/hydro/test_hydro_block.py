"""The URDF <hydrodynamics> block reader: round trips, slender-cylinder derivation, errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from aiauv_hydro import (
    HydroError,
    HydroSpec,
    SlenderCylinderCoefficients,
    cylinder_frame,
    link_cylinders,
    motion_transform,
    quadratic_damping_matrix,
    read_hydrodynamics,
    slender_cylinder_link,
)

DATA = Path(__file__).parents[1] / "data"

LINKS = """
  <link name="hull"/>
  <link name="arm">
    <collision>
      <origin xyz="0.292 0 0" rpy="0 1.5707963 0"/>
      <geometry><cylinder length="0.584" radius="0.085"/></geometry>
    </collision>
  </link>
"""


def robot(block: str, links: str = LINKS) -> str:
    return f'<?xml version="1.0"?>\n<robot name="r">{links}{block}</robot>'


def numbers(values) -> str:
    return " ".join(repr(float(value)) for value in np.ravel(values))


# ----------------------------------------------------------------------------- reading


def test_fossen_block_round_trip():
    rng = np.random.default_rng(7)
    factor = rng.normal(size=(6, 6))
    added_mass = factor @ factor.T  # symmetric positive definite
    linear = np.diag(rng.uniform(1.0, 10.0, size=6))
    quadratic = rng.uniform(0.0, 5.0, size=(6, 6))
    block = f"""
    <hydrodynamics fluid_density="1000" gravity="9.8">
      <link name="hull" model="fossen">
        <volume>0.0305</volume>
        <center_of_buoyancy>0.05 0 0.02</center_of_buoyancy>
        <added_mass>{numbers(added_mass)}</added_mass>
        <linear_damping>{numbers(np.diag(linear))}</linear_damping>
        <quadratic_damping>{numbers(quadratic)}</quadratic_damping>
      </link>
    </hydrodynamics>"""
    spec = read_hydrodynamics(robot(block))
    assert (spec.fluid_density, spec.gravity) == (1000.0, 9.8)
    (link,) = spec.links
    assert (link.link, link.model, link.volume) == ("hull", "fossen", 0.0305)
    np.testing.assert_array_equal(link.center_of_buoyancy, [0.05, 0.0, 0.02])
    np.testing.assert_array_equal(link.added_mass, added_mass)
    np.testing.assert_array_equal(link.linear_damping, linear)
    np.testing.assert_array_equal(link.quadratic_damping, quadratic)
    assert link.crossflow is None


def test_fossen_missing_matrices_are_zero_and_defaults_apply():
    block = '<hydrodynamics><link name="hull" model="fossen"><volume>0.01</volume></link>'
    spec = read_hydrodynamics(robot(block + "</hydrodynamics>"))
    assert (spec.fluid_density, spec.gravity) == (1025.0, 9.81)
    link = spec.links[0]
    for matrix in (link.added_mass, link.linear_damping, link.quadratic_damping):
        np.testing.assert_array_equal(matrix, np.zeros((6, 6)))
    np.testing.assert_array_equal(link.center_of_buoyancy, np.zeros(3))


def test_robot_without_block_gives_empty_spec():
    spec = read_hydrodynamics(robot(""))
    assert spec == HydroSpec()
    assert (spec.links, spec.thrusters) == ((), ())
    assert (spec.fluid_density, spec.gravity) == (1025.0, 9.81)


def test_data_file_by_path_and_text():
    path = DATA / "two_link_hydro.urdf"
    for source in (path, str(path), path.read_text()):
        spec = read_hydrodynamics(source)
        assert [link.link for link in spec.links] == ["hull", "arm"]
        assert [thruster.name for thruster in spec.thrusters] == ["arm_heave", "arm_sway"]
    hull, arm = spec.links
    np.testing.assert_array_equal(np.diag(hull.added_mass), [3, 25, 25, 0.1, 2, 2])
    heave, sway = spec.thrusters
    assert heave.link == "arm" and heave.max_thrust == 50.0
    np.testing.assert_array_equal(heave.position, [0.237, 0, 0])
    np.testing.assert_array_equal(sway.direction, [0, 1, 0])
    assert arm.model == "slender_cylinder"


def test_slender_cylinder_matches_the_library_for_the_papers_layout():
    block = '<hydrodynamics fluid_density="1000"><link name="arm" model="slender_cylinder"/>'
    spec = read_hydrodynamics(robot(block + "</hydrodynamics>"))
    link = spec.links[0]
    expected = slender_cylinder_link("arm", 0.584, 0.085, 1000.0)
    # The paper's collision origin makes the cylinder frame the link frame exactly.
    np.testing.assert_array_equal(link.crossflow.rotation, np.eye(3))
    np.testing.assert_array_equal(link.crossflow.translation, np.zeros(3))
    for name in ("added_mass", "linear_damping", "quadratic_damping", "center_of_buoyancy"):
        np.testing.assert_array_equal(getattr(link, name), getattr(expected, name))
    assert link.volume == pytest.approx(math.pi * 0.085**2 * 0.584)
    np.testing.assert_allclose(link.center_of_buoyancy, [0.292, 0, 0])


def test_slender_cylinder_overrides():
    block = """<hydrodynamics fluid_density="1000">
      <link name="arm" model="slender_cylinder" C_a="0.5" alpha="0.1" C_d1="0.3" C_d4="0.2"
            C_dC="1.1" C_dL="0.05" beta="0.2" gamma="0.3" v_ref="0.5" length="0.5" radius="0.1">
        <volume>0.0127</volume>
        <center_of_buoyancy>0.25 0 0.01</center_of_buoyancy>
      </link></hydrodynamics>"""
    link = read_hydrodynamics(robot(block)).links[0]
    coefficients = SlenderCylinderCoefficients(
        C_a=0.5, alpha=0.1, C_d1=0.3, C_d4=0.2, C_dC=1.1, C_dL=0.05, beta=0.2, gamma=0.3, v_ref=0.5
    )
    expected = slender_cylinder_link("arm", 0.5, 0.1, 1000.0, coefficients=coefficients)
    for name in ("added_mass", "linear_damping", "quadratic_damping"):
        np.testing.assert_allclose(getattr(link, name), getattr(expected, name), rtol=1e-15)
    assert link.volume == 0.0127
    np.testing.assert_array_equal(link.center_of_buoyancy, [0.25, 0, 0.01])
    assert (link.crossflow.length, link.crossflow.radius) == (0.5, 0.1)
    assert link.crossflow.drag_coefficient == 1.1
    # Independent spot checks: m_a = rho pi r^2 C_a, axial added mass alpha L m_a.
    m_a = 1000.0 * math.pi * 0.01 * 0.5
    assert link.added_mass[0, 0] == pytest.approx(0.1 * 0.5 * m_a)
    assert link.quadratic_damping[0, 0] == pytest.approx(0.5 * 1000.0 * math.pi * 0.01 * 0.3)


def test_visual_cylinder_is_used_without_collision_cylinder():
    links = """<link name="arm"><collision><geometry><box size="1 1 1"/></geometry></collision>
      <visual><origin xyz="0.2 0 0" rpy="0 1.5707963 0"/>
      <geometry><cylinder length="0.4" radius="0.05"/></geometry></visual></link>"""
    block = '<hydrodynamics><link name="arm" model="slender_cylinder"/></hydrodynamics>'
    link = read_hydrodynamics(robot(block, links)).links[0]
    assert (link.crossflow.length, link.crossflow.radius) == (0.4, 0.05)
    assert link.crossflow.fluid_density == 1025.0


def test_backward_pointing_cylinder_gives_the_same_frame():
    frame = cylinder_frame(0.62, 0.085, np.array([0.31, 0, 0]), np.array([0, -1.5707963, 0]))
    np.testing.assert_array_equal(frame.rotation, np.eye(3))
    np.testing.assert_array_equal(frame.translation, np.zeros(3))


def test_cylinder_across_the_link_starts_at_the_end_nearer_the_origin():
    # URDF cylinder along link -y (roll +pi/2 turns local z to -y), centre 0.3 m to the left.
    frame = cylinder_frame(0.4, 0.05, np.array([0, 0.3, 0]), np.array([1.5707963, 0, 0]))
    np.testing.assert_allclose(frame.rotation @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(frame.translation, [0, 0.1, 0], atol=1e-15)
    np.testing.assert_allclose(frame.rotation.T @ frame.rotation, np.eye(3), atol=1e-15)
    assert np.linalg.det(frame.rotation) == pytest.approx(1.0)

    links = """<link name="arm"><collision><origin xyz="0 0.3 0" rpy="1.5707963 0 0"/>
      <geometry><cylinder length="0.4" radius="0.05"/></geometry></collision></link>"""
    block = '<hydrodynamics><link name="arm" model="slender_cylinder"/></hydrodynamics>'
    link = read_hydrodynamics(robot(block, links)).links[0]
    transform = motion_transform(frame.rotation, frame.translation)
    cylinder = slender_cylinder_link("c", 0.4, 0.05, 1025.0)
    np.testing.assert_allclose(
        link.added_mass, transform.T @ cylinder.added_mass @ transform, atol=1e-12
    )
    # Axial drag now acts on sway, roll drag on pitch.
    reference = quadratic_damping_matrix(0.4, 0.05, 1025.0)
    assert link.quadratic_damping[1, 1] == pytest.approx(reference[0, 0])
    assert link.quadratic_damping[4, 4] == pytest.approx(reference[3, 3])
    np.testing.assert_allclose(link.center_of_buoyancy, [0, 0.3, 0], atol=1e-15)


def test_link_cylinders_helper():
    cylinders = link_cylinders(robot(""))
    assert list(cylinders) == ["arm"]
    assert (cylinders["arm"].length, cylinders["arm"].radius) == (0.584, 0.085)


# ----------------------------------------------------------------------------- errors


def fossen(body: str, attributes: str = 'name="hull" model="fossen"') -> str:
    return robot(f"<hydrodynamics><link {attributes}>{body}</link></hydrodynamics>")


VOLUME = "<volume>0.01</volume>"
BAD_SOURCES = {
    "unknown link": (fossen(VOLUME, 'name="fin" model="fossen"'), "not a <link>"),
    "wrong count": (fossen(VOLUME + "<added_mass>1 2 3 4 5</added_mass>"), "expected 6"),
    "not a number": (fossen(VOLUME + "<linear_damping>1 2 x 4 5 6</linear_damping>"), "'x'"),
    "nan": (fossen(VOLUME + "<quadratic_damping>1 2 nan 4 5 6</quadratic_damping>"), "finite"),
    "inf": (fossen("<volume>inf</volume>"), "finite"),
    "negative volume": (fossen("<volume>-0.01</volume>"), "volume"),
    "missing volume": (fossen(""), "volume"),
    "not PSD": (fossen(VOLUME + "<added_mass>1 1 1 -1 1 1</added_mass>"), "semi-definite"),
    "not symmetric": (
        fossen(VOLUME + f"<added_mass>{numbers(np.eye(6) + np.eye(6, k=1))}</added_mass>"),
        "symmetric",
    ),
    "no cylinder": (
        robot('<hydrodynamics><link name="hull" model="slender_cylinder"/></hydrodynamics>'),
        "cylinder",
    ),
    "unknown model": (fossen(VOLUME, 'name="hull" model="sphere"'), "unknown model"),
    "missing model": (fossen(VOLUME, 'name="hull"'), "model"),
    "duplicate link": (
        robot(
            '<hydrodynamics><link name="hull" model="fossen"><volume>1</volume></link>'
            '<link name="hull" model="fossen"><volume>1</volume></link></hydrodynamics>'
        ),
        "twice",
    ),
    "thruster on unknown link": (
        robot(
            '<hydrodynamics><thruster name="t" link="fin" direction="1 0 0" max_thrust="5"/>'
            "</hydrodynamics>"
        ),
        "fin",
    ),
    "zero direction": (
        robot(
            '<hydrodynamics><thruster name="t" link="arm" direction="0 0 0" max_thrust="5"/>'
            "</hydrodynamics>"
        ),
        "direction",
    ),
    "missing max_thrust": (
        robot('<hydrodynamics><thruster name="t" link="arm" direction="1 0 0"/></hydrodynamics>'),
        "max_thrust",
    ),
    "zero max_thrust": (
        robot(
            '<hydrodynamics><thruster name="t" link="arm" direction="1 0 0" max_thrust="0"/>'
            "</hydrodynamics>"
        ),
        "max_thrust",
    ),
    "unknown element": (fossen(VOLUME + "<added_mas>1 1 1 1 1 1</added_mas>"), "added_mas"),
    "unknown attribute": (
        robot('<hydrodynamics><link name="arm" model="slender_cylinder" C_x="1"/></hydrodynamics>'),
        "C_x",
    ),
    "bad override": (
        robot(
            '<hydrodynamics><link name="arm" model="slender_cylinder" C_dC="-1"/></hydrodynamics>'
        ),
        "C_dC",
    ),
    "two blocks": (robot("<hydrodynamics/><hydrodynamics/>"), "blocks"),
    "bad density": (robot('<hydrodynamics fluid_density="0"/>'), "fluid_density"),
    "not XML": ("<robot><link name='a'></robot>", "not well-formed"),
    "not a robot": ("<sdf version='1.6'><model name='m'/></sdf>", "<sdf>"),
    "DTD": (
        '<?xml version="1.0"?><!DOCTYPE robot [<!ELEMENT robot ANY>]><robot name="r"/>',
        "refused: XML with a DTD/entities",
    ),
    "entities": (
        '<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]>'
        '<robot name="r"><link name="&b;"/></robot>',
        "refused: XML with a DTD/entities",
    ),
    "external entity": (
        '<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY e SYSTEM "file:///etc/passwd">]>'
        '<robot name="r"><link name="&e;"/></robot>',
        "refused: XML with a DTD/entities",
    ),
    "missing file": ("/nonexistent/vehicle.urdf", "cannot read"),
}


@pytest.mark.parametrize("case", sorted(BAD_SOURCES))
def test_bad_input_raises_one_line_hydro_error(case):
    source, fragment = BAD_SOURCES[case]
    with pytest.raises(HydroError) as error:
        read_hydrodynamics(source)
    message = str(error.value)
    assert "\n" not in message
    assert fragment in message, message
