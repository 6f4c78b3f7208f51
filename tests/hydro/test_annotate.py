"""``aiauv annotate``: hydrodynamics estimated for any URDF, checked against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

import aiauv_pin
from aiauv_hydro.estimate.ellipsoid import ellipsoid_added_mass
from aiauv_hydro.urdf.annotate import annotate_robot, primitive_ellipsoid
from aiauv_hydro.urdf.block_reader import read_hydrodynamics
from aiauv_pin.app.annotate_command import annotate_file
from aiauv_pin.app.cli import main
from aiauv_pin.description.robots import example_robot_urdf

RHO = 1025.0
G = 9.81

ONE_LINK = """<robot name="one">
  <link name="body">
    <inertial><origin xyz="0 0 0"/><mass value="{mass}"/>
      <inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial>
    {geometry}
  </link>
</robot>"""


def _one_link(geometry: str, mass: float = 2.0, inertia: float = 0.01) -> str:
    return ONE_LINK.format(mass=mass, i=inertia, geometry=geometry)


def _loaded(annotation):
    return {link.link: link for link in read_hydrodynamics(annotation.root).links}


def test_sphere_added_mass_is_half_the_displaced_mass():
    radius = 0.2
    geometry = f'<collision><geometry><sphere radius="{radius}"/></geometry></collision>'
    annotation = annotate_robot(_one_link(geometry), fluid_density=RHO)
    link = _loaded(annotation)["body"]
    volume = 4.0 / 3.0 * math.pi * radius**3
    assert link.model == "fossen"
    assert math.isclose(link.volume, volume, rel_tol=1e-12)
    np.testing.assert_allclose(np.diag(link.added_mass)[:3], 0.5 * RHO * volume, rtol=1e-12)
    np.testing.assert_allclose(link.added_mass[3:, 3:], 0.0, atol=1e-15)
    assert annotation.links[0].source == "collision sphere"


# Lamb 1932, Sec. 115, table for prolate spheroids (a/b, k1, k2, k'), printed to three decimals:
# added mass along the axis k1 rho V, across it k2 rho V, rotation across it k' rho V (a^2 + b^2)/5.
LAMB_TABLE = [
    (1.0, 0.5, 0.5, 0.0),
    (2.0, 0.209, 0.702, 0.240),
    (2.99, 0.122, 0.803, 0.465),
    (4.99, 0.059, 0.895, 0.701),
    (9.97, 0.021, 0.960, 0.883),
]


@pytest.mark.parametrize(("ratio", "k1", "k2", "k_rot"), LAMB_TABLE)
def test_prolate_spheroid_matches_lambs_table(ratio, k1, k2, k_rot):
    b = 0.1
    a = ratio * b
    volume = 4.0 / 3.0 * math.pi * a * b * b
    added = ellipsoid_added_mass([a, b, b], RHO) / (RHO * volume)
    # Lamb's entries at a/b = 2 differ from the closed form by up to 2e-3 (table precision)
    assert added[0] == pytest.approx(k1, abs=3e-3)
    assert added[1] == pytest.approx(k2, abs=3e-3)
    assert added[2] == pytest.approx(k2, abs=3e-3)
    assert added[5] / ((a * a + b * b) / 5.0) == pytest.approx(k_rot, abs=3e-3)
    assert added[3] == 0.0


def test_cylinder_gets_the_slender_cylinder_model_with_strip_theory_added_mass():
    length, radius = 0.8, 0.05
    geometry = (
        f'<collision><origin xyz="{length / 2} 0 0" rpy="0 1.5707963267948966 0"/>'
        f'<geometry><cylinder length="{length}" radius="{radius}"/></geometry></collision>'
    )
    annotation = annotate_robot(_one_link(geometry), fluid_density=RHO)
    link = _loaded(annotation)["body"]
    assert link.model == "slender_cylinder"
    per_length = RHO * math.pi * radius**2  # C_a = 1: the displaced mass per unit length
    # transverse added mass and, about the rear end (the link origin), int_0^L x^2 dx
    assert link.added_mass[1, 1] == pytest.approx(per_length * length, rel=1e-9)
    assert link.added_mass[2, 2] == pytest.approx(per_length * length, rel=1e-9)
    assert link.added_mass[5, 5] == pytest.approx(per_length * length**3 / 3.0, rel=1e-9)
    assert link.volume == pytest.approx(math.pi * radius**2 * length, rel=1e-12)
    assert annotation.links[0].dimensions == (length, radius)


def test_box_becomes_the_ellipsoid_of_the_same_volume_and_proportions():
    geometry = (
        '<collision><origin xyz="0.1 0 0" rpy="0 0 0.3"/>'
        '<geometry><box size="0.4 0.2 0.1"/></geometry></collision>'
    )
    annotation = annotate_robot(_one_link(geometry), fluid_density=RHO)
    link = _loaded(annotation)["body"]
    assert link.volume == pytest.approx(0.4 * 0.2 * 0.1, rel=1e-12)
    np.testing.assert_allclose(link.center_of_buoyancy, [0.1, 0.0, 0.0], atol=1e-15)
    semi = np.array(annotation.links[0].dimensions)
    np.testing.assert_allclose(semi / semi[0], [1.0, 0.5, 0.25], rtol=1e-12)
    assert np.min(np.linalg.eigvalsh(link.added_mass)) > -1e-12


def test_mesh_box_gives_the_same_ellipsoid_as_the_primitive_box(tmp_path):
    # a solid box's second moments are proportional to its half-extents squared, so the fitted
    # ellipsoid of its mesh, scaled to its volume, is the primitive box's equivalent ellipsoid
    import xml.etree.ElementTree as ET

    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box(extents=[0.4, 0.2, 0.1]).export(tmp_path / "box.stl")
    origin = '<origin xyz="0.1 -0.05 0.2" rpy="0.2 -0.4 0.3"/>'
    mesh = f'<collision>{origin}<geometry><mesh filename="box.stl"/></geometry></collision>'
    annotation = annotate_robot(
        _one_link(mesh), fluid_density=RHO, resolve_mesh=lambda name: tmp_path / name
    )
    expected = primitive_ellipsoid(
        ET.fromstring('<box size="0.4 0.2 0.1"/>'),
        np.array([0.1, -0.05, 0.2]),
        np.array([0.2, -0.4, 0.3]),
    )
    link = _loaded(annotation)["body"]
    assert annotation.links[0].source == "collision mesh box.stl"
    # STL stores single-precision vertices: agreement to ~1e-8 relative
    np.testing.assert_allclose(
        np.sort(annotation.links[0].dimensions), np.sort(expected.semi_axes), rtol=1e-7
    )
    assert link.volume == pytest.approx(expected.volume, rel=1e-7)
    np.testing.assert_allclose(link.center_of_buoyancy, expected.center, atol=1e-8)
    from aiauv_hydro.estimate.ellipsoid import ellipsoid_hydrodynamics

    np.testing.assert_allclose(
        link.added_mass, ellipsoid_hydrodynamics(expected, RHO).added_mass, rtol=1e-6, atol=1e-9
    )


def test_missing_mesh_falls_back_to_the_inertia_and_says_so():
    mesh = '<collision><geometry><mesh filename="package://nowhere/x.stl"/></geometry></collision>'
    mass, inertia = 3.0, 0.02  # a sphere: I = 2/5 m r^2 -> r = sqrt(5 I / (2 m))
    annotation = annotate_robot(_one_link(mesh, mass, inertia), fluid_density=RHO)
    row = annotation.links[0]
    assert "not found" in row.source and "inertia" in row.source
    np.testing.assert_allclose(row.dimensions, math.sqrt(5 * inertia / (2 * mass)), rtol=1e-12)


def test_zero_inertia_gets_a_neutral_sphere():
    annotation = annotate_robot(_one_link("", mass=1.5, inertia=0.0), fluid_density=RHO)
    row = annotation.links[0]
    assert "unusable" in row.source
    assert row.volume == pytest.approx(1.5 / RHO, rel=1e-12)


def test_neutral_gives_every_link_its_mass_over_rho_and_keeps_massless_links_bare():
    annotation = annotate_robot(
        example_robot_urdf("panda_description/urdf/panda.urdf"), fluid_density=RHO, neutral=True
    )
    for row in annotation.links:
        if row.mass > 0:
            assert row.volume == pytest.approx(row.mass / RHO, rel=1e-12)
        else:
            assert row.model == "-"


def test_links_with_hydrodynamics_are_kept():
    text = _one_link('<collision><geometry><sphere radius="0.1"/></geometry></collision>').replace(
        "</robot>",
        '<hydrodynamics fluid_density="1000"><link name="body" model="fossen">'
        "<volume>0.5</volume></link></hydrodynamics></robot>",
    )
    annotation = annotate_robot(text)
    assert annotation.links[0].source == "already in the file"
    assert _loaded(annotation)["body"].volume == 0.5
    assert annotation.fluid_density == 1000.0


def _float_free(path):
    """Drop a massless 'world' root and its joint (which would fix the base): a floating arm."""
    import xml.etree.ElementTree as ET

    tree = ET.parse(path)
    root = tree.getroot()
    for element in list(root):
        anchored = element.tag == "joint" and element.find("parent").get("link") == "world"
        if anchored or (element.tag == "link" and element.get("name") == "world"):
            root.remove(element)
    tree.write(path)


def _linear_impulse(vehicle, q, v):
    return vehicle.momentum_in_world(q, v)[:3]


@pytest.mark.parametrize(
    ("arm", "neutral"),
    [("panda_description/urdf/panda.urdf", False), ("ur_description/urdf/ur5_robot.urdf", True)],
)
def test_annotated_arm_floats_passively_with_the_impulse_the_net_buoyancy_gives(
    tmp_path, arm, neutral
):
    """Kirchhoff impulse of body plus fluid: dP/dt = net hydrostatic force (rho V - m) g e_z.

    With damping off the only external forces are weight and buoyancy, whose sum is constant in
    the world frame (Lamb 1932, Sec. 119); with damping on the run must stay finite and slow down.
    """
    out = annotate_file(
        example_robot_urdf(arm), tmp_path / "arm.urdf", fluid_density=RHO, neutral=neutral
    )
    total_mass = sum(row.mass for row in out.links)
    total_volume = sum(row.volume for row in out.links)
    net = (RHO * total_volume - total_mass) * G
    if neutral:
        assert abs(net) < 1e-9 * total_mass * G
    _float_free(tmp_path / "arm.urdf")
    vehicle = aiauv_pin.load_vehicle(tmp_path / "arm.urdf", damping=False)
    assert not vehicle.fixed_base
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    run = aiauv_pin.simulate(vehicle, q0, v0, duration=1.0, dt=0.002)
    assert run.status == "complete"
    impulse = np.array([_linear_impulse(vehicle, q, v) for q, v in zip(run.q, run.v, strict=True)])
    expected = np.outer(run.t, [0.0, 0.0, net])
    scale = max(abs(net), total_mass * 0.01)
    np.testing.assert_allclose(impulse, expected, atol=1e-6 * scale)
    assert np.ptp(run.q[:, 7:], axis=0).max() > 1e-4  # the arm does move (hydrostatic torques)

    damped = aiauv_pin.load_vehicle(tmp_path / "arm.urdf")
    run = aiauv_pin.simulate(damped, q0, v0, duration=2.0, dt=0.005)
    assert run.status == "complete" and np.all(np.isfinite(run.q))


def test_cli_annotate_prints_the_table_and_check_suggests_it(tmp_path, capsys):
    source = example_robot_urdf("ur_description/urdf/ur5_robot.urdf")
    assert main(["check", str(source)]) == 0
    assert "aiauv annotate" in capsys.readouterr().out
    out = tmp_path / "ur5.urdf"
    assert main(["annotate", str(source), "-o", str(out), "--neutral"]) == 0
    printed = capsys.readouterr().out
    assert "upper_arm_link" in printed and "collision mesh upperarm.stl" in printed
    assert main(["check", str(out)]) == 0
    assert "no hydrodynamic parameters" not in capsys.readouterr().out


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["missing.urdf", "-o", "x.urdf"], "no such file"),
        (["in.urdf", "-o", "in.urdf"], "would overwrite the input"),
        (["in.urdf", "-o", "x.urdf", "--arg", "a=1"], "only for .xacro"),
        (["bad.urdf", "-o", "x.urdf"], "not well-formed"),
    ],
)
def test_cli_annotate_bad_input_is_one_line(tmp_path, capsys, monkeypatch, arguments, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "in.urdf").write_text(_one_link(""), encoding="utf-8")
    (tmp_path / "bad.urdf").write_text("<robot name='x'><link", encoding="utf-8")
    assert main(["annotate", *arguments]) == 1
    error = capsys.readouterr().err
    assert error.startswith("aiauv: error: ") and message in error
    assert error.count("\n") == 1
    assert not (tmp_path / "x.urdf").exists()


def test_cli_annotate_bad_density_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["annotate", "in.urdf", "-o", "x.urdf", "--fluid-density", "-1"])
    assert exit_info.value.code == 2
    assert "positive density" in capsys.readouterr().err


def _hostile_input_helpers():
    """tests/app/test_hostile_input.py as a module, by its path (this test runs alone too)."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "app" / "test_hostile_input.py"
    spec = importlib.util.spec_from_file_location("_hostile_input_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("case", "fragments"),
    [
        ("laughs", ("refused", "DTD")),
        ("negative volume", ("volume",)),
        ("nan mass", ("mass",)),
        ("binary", ("not a text file",)),
        ("directory", ("directory",)),
        ("laughs xacro", ("refused", "DTD")),
    ],
)
def test_cli_annotate_hostile_input_is_one_line(tmp_path, capfd, case, fragments):
    hostile = _hostile_input_helpers()
    BILLION_LAUGHS, assert_one_line_error = hostile.BILLION_LAUGHS, hostile.assert_one_line_error
    run_cli, vehicle_urdf = hostile.run_cli, hostile.vehicle_urdf

    path = tmp_path / "vehicle.urdf"
    if case == "laughs":
        path.write_text(BILLION_LAUGHS, encoding="utf-8")
    elif case == "negative volume":
        path.write_text(vehicle_urdf(volume="-1"), encoding="utf-8")
    elif case == "nan mass":
        path.write_text(vehicle_urdf(mass="nan"), encoding="utf-8")
    elif case == "binary":
        path.write_bytes(bytes(range(256)) * 4)
    elif case == "directory":
        path = tmp_path
    else:
        path = tmp_path / "vehicle.urdf.xacro"
        path.write_text(BILLION_LAUGHS, encoding="utf-8")
    out = tmp_path / "out.urdf"
    code, printed, err = run_cli(capfd, ["annotate", path, "-o", out])
    assert_one_line_error(code, err, *fragments)
    assert "lollol" not in err + printed
    assert not out.exists()


@pytest.mark.parametrize(
    ("origin", "moved"),
    [
        ('xyz="0.128 0 0.055" rpy="0 1.5707963267948966 0"', ["C_d1"]),  # Z1's link03: offset
        ('xyz="0 0 0" rpy="0.3 0.4 0"', ["C_d1", "C_d4"]),  # tilted: no link axis
    ],
)
def test_cylinder_off_the_link_axis_keeps_the_strip_integral(origin, moved):
    """An off-axis cylinder keeps added mass, linear damping and the crossflow strip integral
    (any placement); the axial / roll quadratic drag, with no exact form in the link frame there,
    is evaluated in the cylinder frame with the crossflow term (issue 32), and the table says so."""
    geometry = (
        f"<collision><origin {origin}/>"
        '<geometry><cylinder length="0.4" radius="0.03"/></geometry></collision>'
    )
    annotation = annotate_robot(_one_link(geometry))
    (row,) = annotation.links
    assert "off the link axis" in row.source and "left out" not in row.source
    assert "cylinder frame" in row.source and all(c in row.source for c in moved)
    element = annotation.root.find("hydrodynamics/link")
    assert element.get("C_d1") is None and element.get("C_d4") is None  # the defaults, all kept
    link = _loaded(annotation)["body"]
    assert link.crossflow is not None and link.crossflow.length == pytest.approx(0.4)
    assert link.crossflow.axial_drag_coefficient == (0.2 if "C_d1" in moved else 0.0)
    assert link.crossflow.roll_drag_coefficient == (0.1 if "C_d4" in moved else 0.0)
    roll_in_link_frame = np.abs(link.quadratic_damping).sum()  # what has an exact D_Q form
    assert (roll_in_link_frame > 0.0) == ("C_d4" not in moved)
    assert np.linalg.eigvalsh(link.added_mass)[0] >= -1e-12


def test_annotate_says_when_the_robots_own_inertia_fails(tmp_path):
    """A link whose own inertia breaks the triangle inequality: the message blames the robot's
    data, not the annotation, and --lenient annotates it."""
    geometry = '<collision><geometry><box size="0.3 0.2 0.1"/></geometry></collision>'
    text = _one_link(geometry).replace(
        'ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"',
        'ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.03"',
    )
    source = tmp_path / "robot.urdf"
    source.write_text(text)
    with pytest.raises(aiauv_pin.VehicleLoadError, match=r"robot.s own data .* not the annotation"):
        annotate_file(source, tmp_path / "out.urdf")
    assert not (tmp_path / "out.urdf").exists()
    with pytest.warns(aiauv_pin.errors.LenientRepairWarning):
        annotate_file(source, tmp_path / "out.urdf", lenient=True)
    assert (tmp_path / "out.urdf").exists()
