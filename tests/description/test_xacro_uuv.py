"""xacro vehicles, UUV Simulator geometric models and thrusters.

The test vehicle ``tests/data/uuv_packages/minirov_description`` is written for these tests in UUV
Simulator's layout, with RexROV's and the Oberon7 arm's published parameters (see its comments).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import aiauv_pin
from aiauv_hydro.estimate.ellipsoid import ellipsoid_added_mass
from aiauv_hydro.spec import HydroError
from aiauv_hydro.urdf.block_reader import read_hydrodynamics, rpy_matrix
from aiauv_pin.app.annotate_command import annotate_file
from aiauv_pin.app.cli import main
from aiauv_pin.description.xacro_loading import expand_xacro
from aiauv_pin.errors import VehicleLoadError

PACKAGES = Path(__file__).parents[1] / "data" / "uuv_packages"
MINIROV = PACKAGES / "minirov_description" / "robots" / "minirov.urdf.xacro"
RHO = 1028.0
G = 9.81


@pytest.fixture(scope="module")
def minirov():
    return aiauv_pin.load_vehicle(MINIROV, package_path=[PACKAGES])


def test_xacro_expands_with_find_and_arguments(minirov):
    assert minirov.name == "minirov"
    assert minirov.nv == 6 + 5  # the propeller joints are fixed for the dynamics
    names = {t.name for t in minirov.hydro.thrusters}
    assert len(names) == 8
    bare = aiauv_pin.load_vehicle(
        MINIROV, package_path=[PACKAGES], xacro_args={"with_arm": "false", "namespace": "r2"}
    )
    assert bare.nv == 6
    assert {link.link for link in bare.hydro.links} == {"r2/base_link"}


def test_ros_package_path_is_searched(monkeypatch):
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(PACKAGES))
    assert "minirov/arm/wrist_link" in expand_xacro(MINIROV)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({}, "$(find minirov_description): package not found"),
        ({"package_path": [PACKAGES], "xacro_args": {"with_arm": "maybe"}}, "xacro"),
    ],
)
def test_xacro_errors_are_one_line(monkeypatch, options, message):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    with pytest.raises(VehicleLoadError) as error:
        aiauv_pin.load_vehicle(MINIROV, **options)
    assert message in str(error.value) and "\n" not in str(error.value)
    assert "<class" not in str(error.value) and str(error.value).count("package not found") <= 1


def test_cli_xacro_errors(capsys, monkeypatch):
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    assert main(["check", str(MINIROV)]) == 1
    error = capsys.readouterr().err
    assert error.startswith("aiauv: error: ") and "--package-path" in error
    assert error.count("\n") == 1
    with pytest.raises(SystemExit) as exit_info:
        main(["check", str(MINIROV), "--arg", "no_equals_sign"])
    assert exit_info.value.code == 2
    assert "NAME=VALUE" in capsys.readouterr().err


def test_xacro_include_with_entities_is_refused(tmp_path):
    (tmp_path / "evil.xacro").write_text(
        '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa">]><robot>&a;</robot>'
    )
    (tmp_path / "top.xacro").write_text(
        '<robot name="x" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="evil.xacro"/><link name="a"/></robot>'
    )
    with pytest.raises(VehicleLoadError, match="DTD"):
        expand_xacro(tmp_path / "top.xacro")


def test_undefined_argument_names_it(tmp_path):
    (tmp_path / "a.xacro").write_text(
        '<robot name="x" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<link name="$(arg which)"/></robot>'
    )
    with pytest.raises(VehicleLoadError, match="--arg which=VALUE"):
        expand_xacro(tmp_path / "a.xacro")


def test_thrusters_act_along_their_joint_axes_at_their_links(minirov):
    """Generalised force of a unit thrust on the free-flyer: (f, p x f) in the base frame."""
    q = minirov.neutral_configuration()
    matrix = minirov.thrust_matrix(q)
    # thruster 4 of RexROV: origin xyz (-0.412125, 0.505415, 0.129), rpy (0, 0, 45 deg); axis x
    position = np.array([-0.412125, 0.505415, 0.129])
    direction = rpy_matrix([0.0, 0.0, math.radians(45.0)])[:, 0]
    index = minirov.thruster_names.index("minirov_4_thruster_model")
    np.testing.assert_allclose(matrix[:3, index], direction, atol=1e-12)
    np.testing.assert_allclose(matrix[3:6, index], np.cross(position, direction), atol=1e-12)
    assert all(t.max_thrust == 2000.0 for t in minirov.hydro.thrusters)


def _plugin_robot(model: str, extra: str = "", volume: str = "<volume>0.01</volume>") -> str:
    return f"""<robot name="r">
  <link name="b"><inertial><origin xyz="0.2 0 0"/><mass value="10"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <gazebo><plugin name="p" filename="libuuv_underwater_object_ros_plugin.so">
    <fluid_density>{RHO}</fluid_density>
    <link name="b">{volume}<center_of_buoyancy>0.2 0 0</center_of_buoyancy>{extra}
      <hydrodynamic_model>{model}</hydrodynamic_model></link>
  </plugin></gazebo>
</robot>"""


def _about_centre(link):
    """The link's added mass moved back to the centre of mass (0.2, 0, 0)."""
    from aiauv_hydro.numerics.spatial import motion_transform

    inverse = np.linalg.inv(motion_transform(np.eye(3), [0.2, 0.0, 0.0]))
    return inverse.T @ link.added_mass @ inverse


def test_uuv_sphere_model():
    r = 0.3
    link = read_hydrodynamics(_plugin_robot(f"<type>sphere</type><radius>{r}</radius>")).links[0]
    volume = 4.0 / 3.0 * math.pi * r**3
    np.testing.assert_allclose(np.diag(_about_centre(link))[:3], RHO * volume / 2, rtol=1e-12)
    # HMSphere: D = -1/2 rho C_D pi r^2 with C_D = 0.5; ours is positive
    np.testing.assert_allclose(
        np.diag(link.quadratic_damping)[:3], 0.5 * RHO * 0.5 * math.pi * r**2, rtol=1e-12
    )


def test_uuv_cylinder_model_from_the_bounding_box():
    # box 0.6 x 0.1 x 0.12 (x, y, z): radius = smallest extent, length = largest, axis x (i)
    box = "<box><width>0.6</width><length>0.1</length><height>0.12</height></box>"
    link = read_hydrodynamics(_plugin_robot("<type>cylinder</type>", box)).links[0]
    r, length = 0.1, 0.6
    area = math.pi * r * r
    centre = np.diag(_about_centre(link))
    np.testing.assert_allclose(
        centre,
        [RHO * area, RHO * area * length, RHO * area * length, 0.0]
        + [RHO * area * length**3 / 12.0] * 2,
        rtol=1e-12,
        atol=1e-12,
    )
    # L / 2r = 3: C_circ 0.87, C_len 0.74 (the plugin's table)
    np.testing.assert_allclose(
        np.diag(link.quadratic_damping)[:3],
        [0.5 * 0.87 * area * RHO, 0.5 * 0.74 * r * length * RHO, 0.5 * 0.74 * r * length * RHO],
        rtol=1e-12,
    )


def test_uuv_spheroid_is_lambs_prolate_spheroid():
    model = "<type>spheroid</type><radius>0.1</radius><length>0.5</length>"
    link = read_hydrodynamics(_plugin_robot(model)).links[0]
    np.testing.assert_allclose(
        np.diag(_about_centre(link)), ellipsoid_added_mass([0.5, 0.1, 0.1], RHO), rtol=1e-10
    )


def test_uuv_box_model_drag():
    model = "<type>box</type><length>0.5</length><width>0.3</width><height>0.2</height><cd>1.2</cd>"
    link = read_hydrodynamics(_plugin_robot(model)).links[0]
    np.testing.assert_allclose(
        np.diag(link.quadratic_damping)[:3],
        0.5 * 1.2 * RHO * np.array([0.3 * 0.2, 0.5 * 0.2, 0.3 * 0.5]),
        rtol=1e-12,
    )
    assert not np.any(link.added_mass)


def test_uuv_geometric_model_needs_its_size():
    with pytest.raises(HydroError, match="needs <radius>"):
        read_hydrodynamics(_plugin_robot("<type>cylinder</type>"))


def _thruster_robot(plugin: str) -> str:
    return f"""<robot name="r">
  <link name="b"><inertial><mass value="10"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="t"><inertial><mass value="0.001"/>
    <inertia ixx="1e-7" ixy="0" ixz="0" iyy="1e-7" iyz="0" izz="1e-7"/></inertial></link>
  <joint name="j" type="continuous"><parent link="b"/><child link="t"/>
    <origin xyz="0 1 0"/><axis xyz="0 0 1"/></joint>
  <gazebo><plugin name="th" filename="libuuv_thruster_ros_plugin.so">
    <linkName>t</linkName><jointName>j</jointName><thrusterID>0</thrusterID>{plugin}
  </plugin></gazebo>
</robot>"""


@pytest.mark.parametrize(
    ("plugin", "expected"),
    [
        # Basic: thrust_efficiency k (propeller_efficiency gain clampMax)^2
        (
            "<conversion><type>Basic</type><rotorConstant>0.01</rotorConstant></conversion>"
            "<gain>2</gain><clampMax>100</clampMax><clampMin>-100</clampMin>"
            "<thrust_efficiency>0.5</thrust_efficiency>",
            0.5 * 0.01 * 200.0**2,
        ),
        (
            "<conversion><type>Basic</type><rotorConstant>0.01</rotorConstant></conversion>"
            "<clampMax>100</clampMax><thrustMax>60</thrustMax>",
            60.0,
        ),
        (
            "<conversion><type>Bessa</type><rotorConstantL>0.02</rotorConstantL>"
            "<rotorConstantR>0.02</rotorConstantR><deltaL>-10</deltaL><deltaR>10</deltaR>"
            "</conversion><clampMax>50</clampMax>",
            0.02 * (2500.0 - 10.0),
        ),
        (
            "<conversion><type>LinearInterp</type><inputValues>-10 0 10</inputValues>"
            "<outputValues>-40 0 55</outputValues></conversion><clampMax>5</clampMax>",
            27.5,
        ),
    ],
)
def test_thruster_limit_is_the_steady_state_thrust_at_the_largest_command(plugin, expected):
    spec = read_hydrodynamics(_thruster_robot(plugin))
    (thruster,) = spec.thrusters
    assert thruster.max_thrust == pytest.approx(expected, rel=1e-12)
    np.testing.assert_array_equal(thruster.direction, [0.0, 0.0, 1.0])
    assert thruster.link == "t"


def test_thruster_without_a_limit_is_left_out_with_a_warning():
    plugin = "<conversion><type>Basic</type><rotorConstant>0.01</rotorConstant></conversion>"
    with pytest.warns(UserWarning, match="thrustMax"):
        assert read_hydrodynamics(_thruster_robot(plugin)).thrusters == ()


def test_unknown_conversion_is_refused():
    plugin = "<conversion><type>Magic</type></conversion><thrustMax>5</thrustMax>"
    with pytest.raises(HydroError, match="Magic"):
        read_hydrodynamics(_thruster_robot(plugin))


def test_uuv_xacro_vehicle_annotate_check_simulate(tmp_path, capsys):
    """annotate -> check -> simulate without a hand edit; dP/dt = net hydrostatic force."""
    out = tmp_path / "minirov.urdf"
    args = ["--package-path", str(PACKAGES), "--arg", "max_thrust=1500"]
    assert main(["annotate", str(MINIROV), "-o", str(out), *args]) == 0
    assert main(["check", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "no hydrodynamic parameters" not in printed and "1500" in printed
    annotation = annotate_file(MINIROV, tmp_path / "again.urdf", package_path=[PACKAGES])
    net = (
        RHO * sum(row.volume for row in annotation.links)
        - sum(row.mass for row in annotation.links)
    ) * G
    vehicle = aiauv_pin.load_vehicle(out, damping=False)
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    run = aiauv_pin.simulate(vehicle, q0, v0, duration=0.5, dt=0.005)
    impulse = np.array(
        [vehicle.momentum_in_world(q, v)[:3] for q, v in zip(run.q, run.v, strict=True)]
    )
    np.testing.assert_allclose(impulse, np.outer(run.t, [0, 0, net]), atol=1e-6 * abs(net))
    damped = aiauv_pin.load_vehicle(out)
    run = aiauv_pin.simulate(damped, q0, v0, duration=3.0, dt=0.01)
    assert run.status == "complete"
    assert run.q[-1, 2] < q0[2]  # net buoyancy is negative: it sinks
    placement = pin.XYZQUATToSE3(run.q[-1, :7])
    assert np.isfinite(placement.translation).all()
    # playback: every link drawn (collision boxes; the propellers as their inertia ellipsoids)
    from aiauv_pin.results import playback, viewer

    page = playback.write_playback(damped, run, tmp_path / "playback.html")
    commands = playback.read_commands(page.read_text(encoding="utf-8"))
    drawn = {
        c["path"][len(viewer.LINKS) + 1 :].rsplit("/", 1)[0]
        for c in commands
        if c["type"] == "set_object" and "/visual_" in c["path"]
    }
    assert {"minirov/base_link", "minirov/arm/wrist_link", "minirov/thruster_7"} <= drawn
    assert "thruster force" in page.read_text(encoding="utf-8")


def test_lauv_thruster_with_swapped_clamps_and_coupled_damping():
    """LAUV's file swaps clampMin/clampMax: the plugin drops the clamp, thrustMin/Max limit it."""
    lauv = Path(__file__).parents[1] / "data" / "lauv_uuv_simulator.urdf"
    with pytest.warns(UserWarning, match="off-diagonal"):
        vehicle = aiauv_pin.load_vehicle(lauv)
    (thruster,) = vehicle.hydro.thrusters
    assert thruster.max_thrust == 50.0
    q = vehicle.neutral_configuration()
    column = vehicle.thrust_matrix(q)[:, 0]
    # joint axis x turned by pi about z: positive thrust pushes the hull backwards, on its axis
    np.testing.assert_allclose(column[:6], [-1, 0, 0, 0, 0, 0], atol=1e-12)
    (link,) = vehicle.hydro.links
    # FRD sway-yaw coupling 11.5 of DLin becomes -11.5 in our FLU, positive-dissipative form
    # (D_L = -T DLin T with T = diag(1, -1, -1, 1, -1, -1))
    assert link.linear_damping[1, 5] == pytest.approx(-11.5)
    assert link.linear_damping[5, 1] == pytest.approx(3.1)
    assert link.linear_damping[1, 1] == pytest.approx(23.0)


def test_eca_a9_is_read_but_refused_for_its_inertia():
    """As published, ECA A9's inertia breaks the triangle inequality (0.6 + 30 < 35 kg m^2), so the
    validation gate refuses it in one line; its hydrodynamic block is still read (forward-speed
    damping included), and says what it cannot apply (a thruster with no limit)."""
    from aiauv_hydro.urdf.block_reader import read_hydrodynamics
    from aiauv_pin.errors import PhysicalParameterError

    eca = Path(__file__).parents[1] / "data" / "eca_a9_uuv_simulator.urdf"
    with pytest.raises(PhysicalParameterError, match="triangle inequality") as error:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            aiauv_pin.load_vehicle(eca)
    assert "\n" not in str(error.value)
    with pytest.warns(UserWarning) as record:
        hydro = read_hydrodynamics(eca)
    messages = " ".join(str(item.message) for item in record)
    assert "linear_damping_forward_speed" not in messages
    assert "no finite positive thrust limit" in messages
    assert hydro.thrusters == ()
    (link,) = hydro.links
    np.testing.assert_allclose(np.diag(link.added_mass), [4, 95, 75, 0.4, 27, 32])
    assert not np.any(link.linear_damping) and not np.any(link.quadratic_damping)
    # published DLinForwardSpeed (FRD, negative = dissipative) in FLU, positive = dissipative
    assert link.forward_speed_damping[1, 1] == pytest.approx(162.0)
    assert link.forward_speed_damping[1, 5] == pytest.approx(-150.0)
    assert link.forward_speed_damping[5, 1] == pytest.approx(34.0)


def test_forward_speed_damping_conversion():
    from aiauv_hydro.urdf.uuv_simulator import convert_forward_speed_damping

    forward = np.zeros((6, 6))
    forward[1, 5], forward[1, 1] = 150.0, -162.0
    converted = convert_forward_speed_damping(forward)
    # UUV wrench u F nu (FRD) equals our -u D_F nu (FLU) for any velocity
    rng = np.random.default_rng(2)
    flip = np.diag([1.0, -1, -1, 1, -1, -1])
    for _ in range(3):
        nu = rng.normal(size=6)
        theirs = flip @ (nu[0] * forward @ (flip @ nu))
        np.testing.assert_allclose(-nu[0] * converted @ nu, theirs, atol=1e-12)
