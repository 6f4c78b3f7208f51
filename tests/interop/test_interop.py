"""Gazebo SDF and MuJoCo MJCF interop: round trips, MuJoCo's rigid-body dynamics against Pinocchio's."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from aiauv_hydro.urdf.block_reader import read_hydrodynamics
from aiauv_pin import bundled_urdf, load_vehicle
from aiauv_pin.app.cli import main
from aiauv_pin.interop.gz import export_sdf, import_gz, read_gz_model
from aiauv_pin.interop.interop_errors import InteropError
from aiauv_pin.interop.mjcf import export_mjcf

DATA = Path(__file__).parents[1] / "data"
VEHICLES = {
    "paper_uniform": bundled_urdf("uniform"),
    "paper_stabilised": bundled_urdf("stabilised"),
    "two_link": DATA / "two_link_hydro.urdf",
    "rexrov": DATA / "rexrov_uuv_simulator.urdf",
}

#: A link with a full, coupled 6x6 added mass and damping (off-diagonal entries everywhere).
FULL_LINK_URDF = """<robot name="coupled">
  <link name="hull">
    <inertial><origin xyz="0.1 0.02 -0.03" rpy="0.1 -0.2 0.3"/><mass value="30"/>
      <inertia ixx="1.2" ixy="0.05" ixz="-0.02" iyy="2.5" iyz="0.03" izz="2.9"/></inertial>
    <collision><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.15" length="1.0"/></geometry></collision>
  </link>
  <link name="arm">
    <inertial><origin xyz="0.2 0 0"/><mass value="3"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
  </link>
  <joint name="shoulder" type="revolute"><parent link="hull"/><child link="arm"/>
    <origin xyz="0.6 0 0.1" rpy="0 0.3 0"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-1.5" upper="1.5" effort="50" velocity="2"/></joint>
  <hydrodynamics fluid_density="1025">
    <link name="hull" model="fossen">
      <volume>0.031</volume>
      <center_of_buoyancy>0.1 0.01 0.02</center_of_buoyancy>
      <added_mass>{added_mass}</added_mass>
      <linear_damping>{linear}</linear_damping>
      <quadratic_damping>{quadratic}</quadratic_damping>
    </link>
    <link name="arm" model="fossen"><volume>0.002</volume>
      <added_mass>0.5 1.5 1.5 0.001 0.02 0.02</added_mass></link>
    <thruster name="surge" link="hull" xyz="-0.4 0 0" direction="1 0 0" max_thrust="100"/>
    <thruster name="heave" link="hull" xyz="0.3 0.1 0" direction="0 0.2 1" max_thrust="60"/>
  </hydrodynamics>
</robot>
"""


def _numbers(matrix) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(matrix))


@pytest.fixture(scope="module")
def coupled_urdf(tmp_path_factory) -> Path:
    rng = np.random.default_rng(7)
    root = rng.normal(size=(6, 6))
    added_mass = root @ root.T + 5.0 * np.eye(6)  # symmetric positive definite, fully coupled
    text = FULL_LINK_URDF.format(
        added_mass=_numbers(added_mass),
        # coupled everywhere, not symmetric, with a positive-definite symmetric part (Gershgorin):
        # the validation gate refuses damping that would feed energy in
        linear=_numbers(10.0 * np.eye(6) + rng.uniform(-1.0, 1.0, size=(6, 6))),
        quadratic=_numbers(30.0 * np.eye(6) + rng.uniform(-3.0, 3.0, size=(6, 6))),
    )
    path = tmp_path_factory.mktemp("coupled") / "coupled.urdf"
    path.write_text(text)
    return path


def _hydro_by_link(path) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # UUV Simulator's asymmetry and density notes
        return {link.link: link for link in read_hydrodynamics(path).links}


# --------------------------------------------------------------------------------------------------
# SDF
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("added_mass", ["sdf", "plugin"])
@pytest.mark.parametrize("name", [*VEHICLES, "coupled"])
def test_sdf_export_import_round_trip(name, added_mass, coupled_urdf, tmp_path):
    source = coupled_urdf if name == "coupled" else VEHICLES[name]
    export_sdf(source, tmp_path / "model.sdf", added_mass=added_mass)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = import_gz(tmp_path / "model.sdf", source, tmp_path / "back.urdf")
    assert report.pose_checked
    before, after = _hydro_by_link(source), _hydro_by_link(tmp_path / "back.urdf")
    assert set(before) == set(after) == set(report.links)
    for link, expected in before.items():
        got = after[link]
        for field in ("added_mass", "linear_damping", "quadratic_damping"):
            scale = max(1.0, float(np.max(np.abs(getattr(expected, field)))))
            np.testing.assert_allclose(
                getattr(got, field), getattr(expected, field), rtol=0, atol=1e-12 * scale
            )
        assert got.volume == pytest.approx(expected.volume, rel=1e-12, abs=0)
        if expected.volume > 0.0:
            np.testing.assert_allclose(
                got.center_of_buoyancy, expected.center_of_buoyancy, rtol=0, atol=1e-12
            )
        assert got.crossflow is None  # gz has no crossflow term; the export says so
    # thrusters and the rest of the URDF's block are kept
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert [t.name for t in read_hydrodynamics(tmp_path / "back.urdf").thrusters] == [
            t.name for t in read_hydrodynamics(source).thrusters
        ]
    load_vehicle(tmp_path / "back.urdf", backend="pinocchio")


def _sdf(plugin_body: str, inertial_extra: str = "", collisions: str = "", world: str = "") -> str:
    model = f"""<model name="auv">
      <link name="hull"><pose>0 0 0 0 0 0</pose>
        <inertial><mass>30</mass>{inertial_extra}</inertial>{collisions}</link>
      <plugin filename="gz-sim-hydrodynamics-system" name="gz::sim::systems::Hydrodynamics">
        <link_name>hull</link_name>{plugin_body}</plugin></model>"""
    if world:
        return f"<sdf version='1.11'><world name='w'>{world}{model}</world></sdf>"
    return f"<sdf version='1.11'>{model}</sdf>"


def test_gz_sign_conventions_by_hand(tmp_path):
    """Each SNAME parameter lands in its entry with gz's sign convention (module docstring)."""
    collisions = """
        <collision name="a"><pose>0.2 0 0 0 0 0</pose><geometry><box><size>1 0.5 0.2</size></box>
        </geometry></collision>
        <collision name="b"><pose>-0.3 0 0.1 0 1.5707963 0</pose><geometry><cylinder>
          <radius>0.1</radius><length>0.4</length></cylinder></geometry></collision>"""
    world = """<gravity>0 0 -9.8</gravity><plugin filename="gz-sim-buoyancy-system"
        name="gz::sim::systems::Buoyancy"><uniform_fluid_density>1027</uniform_fluid_density>
        </plugin>"""
    plugin = """<xU>-20</xU><nR>-3</nR><xR>-0.5</xR><yVabsV>-80</yVabsV><kPabsP>-2</kPabsP>
        <nVabsV>4</nVabsV><xDotU>-6</xDotU><yDotV>-40</yDotV><nDotR>-7</nDotR>
        <yDotR>-1.5</yDotR><nDotV>-1.5</nDotV>"""
    path = tmp_path / "auv.sdf"
    path.write_text(_sdf(plugin, collisions=collisions, world=world))
    gz = read_gz_model(path)
    assert gz.fluid_density == 1027.0 and gz.gravity == pytest.approx(9.8)
    (link,) = gz.links
    linear = np.zeros((6, 6))
    linear[0, 0], linear[5, 5], linear[0, 5] = 20.0, 3.0, 0.5
    np.testing.assert_array_equal(link.linear_damping, linear)
    quadratic = np.zeros((6, 6))
    quadratic[1, 1], quadratic[3, 3], quadratic[5, 1] = 80.0, 2.0, -4.0
    np.testing.assert_array_equal(link.quadratic_damping, quadratic)
    added = np.zeros((6, 6))
    added[0, 0], added[1, 1], added[5, 5], added[1, 5], added[5, 1] = 6.0, 40.0, 7.0, 1.5, 1.5
    np.testing.assert_array_equal(link.added_mass, added)
    box, cylinder = 0.1, math.pi * 0.1**2 * 0.4
    assert link.volume == pytest.approx(box + cylinder, rel=1e-15)
    expected_centre = (box * np.array([0.2, 0, 0]) + cylinder * np.array([-0.3, 0, 0.1])) / (
        box + cylinder
    )
    np.testing.assert_allclose(link.center_of_buoyancy, expected_centre, rtol=0, atol=1e-15)


def test_fluid_added_mass_is_taken_as_is(tmp_path):
    fluid = "<fluid_added_mass><xx>5</xx><yy>100</yy><zz>110</zz><yr>-3</yr><qq>20</qq>"
    fluid += "<rr>16</rr><pp>1.5</pp></fluid_added_mass>"
    path = tmp_path / "auv.sdf"
    path.write_text(_sdf("<xUabsU>-6</xUabsU>", inertial_extra=fluid))
    (link,) = read_gz_model(path).links
    expected = np.diag([5.0, 100.0, 110.0, 1.5, 20.0, 16.0])
    expected[1, 5] = expected[5, 1] = -3.0
    np.testing.assert_array_equal(link.added_mass, expected)
    assert link.quadratic_damping[0, 0] == 6.0


@pytest.mark.parametrize(
    ("plugin", "inertial_extra", "message"),
    [
        ("<xUU>-3</xUU>", "", "signed quadratic term"),
        ("<xUabsV>-3</xUabsV>", "", "has no form in the <hydrodynamics> block"),
        ("<xDotU>-3</xDotU>", "<fluid_added_mass><xx>3</xx></fluid_added_mass>", "count it twice"),
        ("<xU>abc</xU>", "", "'abc' is not a number"),
        ("<xU>-1</xU><xU>-2</xU>", "", "<xU> given twice"),
        ("<xDotU>-3</xDotU><xDotV>-1</xDotV>", "", "not symmetric"),
        ("<xDotU>3</xDotU>", "", "not positive semi-definite"),
        ("", "<fluid_added_mass><xw>1</xw></fluid_added_mass>", "unknown element <xw>"),
    ],
)
def test_bad_gz_parameters_are_one_line_errors(plugin, inertial_extra, message, tmp_path):
    path = tmp_path / "auv.sdf"
    path.write_text(_sdf(plugin, inertial_extra=inertial_extra))
    with pytest.raises(InteropError, match=message) as info:
        read_gz_model(path)
    assert "\n" not in str(info.value)


def test_a_bad_boolean_in_the_gz_plugin_is_an_interop_error(tmp_path):
    path = tmp_path / "auv.sdf"
    path.write_text(_sdf("<xDotU>-9</xDotU><disable_added_mass>sometimes</disable_added_mass>"))
    with pytest.raises(InteropError, match="expected 0, 1, true or false, got 'sometimes'"):
        read_gz_model(path)


def test_disable_added_mass_drops_the_plugin_terms(tmp_path):
    path = tmp_path / "auv.sdf"
    fluid = "<fluid_added_mass><xx>3</xx></fluid_added_mass>"
    path.write_text(_sdf("<xDotU>-9</xDotU><disable_added_mass>true</disable_added_mass>", fluid))
    (link,) = read_gz_model(path).links
    assert link.added_mass[0, 0] == 3.0


def test_import_checks_link_frames(coupled_urdf, tmp_path):
    export_sdf(coupled_urdf, tmp_path / "model.sdf")
    text = (tmp_path / "model.sdf").read_text()
    # shift the arm's x by 1 cm: the first number of its pose
    start = text.index('<link name="arm">')
    pose_start = text.index("<pose>", start) + len("<pose>")
    pose_end = text.index("</pose>", pose_start)
    numbers = text[pose_start:pose_end].split()
    numbers[0] = repr(float(numbers[0]) + 0.01)
    moved = text[:pose_start] + " ".join(numbers) + text[pose_end:]
    (tmp_path / "moved.sdf").write_text(moved)
    with pytest.raises(InteropError, match="SDF link 'arm' is not where the URDF puts it"):
        import_gz(tmp_path / "moved.sdf", coupled_urdf, tmp_path / "out.urdf")
    assert not (tmp_path / "out.urdf").exists()


def test_import_refuses_links_the_urdf_lacks(tmp_path):
    path = tmp_path / "auv.sdf"
    path.write_text(_sdf("<xU>-1</xU>"))
    with pytest.raises(InteropError, match="SDF link 'hull' is not a link of"):
        import_gz(path, VEHICLES["paper_uniform"], tmp_path / "out.urdf")
    assert not (tmp_path / "out.urdf").exists()


def test_cli_import_and_export_errors_are_one_line(tmp_path, capsys):
    urdf = VEHICLES["paper_uniform"]
    assert main(["export", str(urdf), "-o", str(tmp_path / "x.txt")]) == 1
    assert main(["export", str(tmp_path / "missing.urdf"), "-o", str(tmp_path / "x.sdf")]) == 1
    (tmp_path / "not.sdf").write_text("<robot name='x'/>")
    assert main(["import-gz", str(tmp_path / "not.sdf"), "--urdf", str(urdf), "-o", "o.urdf"]) == 1
    (tmp_path / "dtd.sdf").write_text('<!DOCTYPE sdf [<!ENTITY a "b">]><sdf>&a;</sdf>')
    assert main(["import-gz", str(tmp_path / "dtd.sdf"), "--urdf", str(urdf), "-o", "o.urdf"]) == 1
    two = "<sdf><model name='a'/><model name='b'/></sdf>"
    (tmp_path / "two.sdf").write_text(two)
    assert main(["import-gz", str(tmp_path / "two.sdf"), "--urdf", str(urdf), "-o", "o.urdf"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 5 and all(line.startswith("aiauv: error: ") for line in err)
    assert "unknown output format" in err[0]
    assert "no such file" in err[1]
    assert "not an SDF file" in err[2]
    assert "DTD" in err[3]
    assert "choose one with --model" in err[4]
    assert not Path("o.urdf").exists()


def test_cli_export_then_import(tmp_path, capsys):
    urdf = VEHICLES["paper_stabilised"]
    assert main(["export", str(urdf), "-o", str(tmp_path / "v.sdf")]) == 0
    assert (
        main(
            [
                "import-gz",
                str(tmp_path / "v.sdf"),
                "--urdf",
                str(urdf),
                "-o",
                str(tmp_path / "v.urdf"),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "crossflow drag of 9 link(s) not exported" in out
    assert "hydrodynamics of 9 link(s)" in out and "link frames checked" in out


# --------------------------------------------------------------------------------------------------
# MJCF
# --------------------------------------------------------------------------------------------------

mujoco = pytest.importorskip("mujoco")


def _mujoco_state(model, mj, q, v, tau):
    """Pinocchio (q, v, tau) as MuJoCo (qpos, qvel, qfrc), joints matched by name.

    Pinocchio's free flyer: ``q = (p, quaternion x y z w)``, ``v = (v_b, omega_b)`` in the base frame,
    ``tau = (f_b, m_b)``; MuJoCo's free joint: ``qpos = (p, quaternion w x y z)``,
    ``qvel = (R v_b, omega_b)``, ``qfrc = (R f_b, m_b)`` (linear in the world, angular in the body).
    """
    rotation = pin.Quaternion(q[3:7]).toRotationMatrix()
    qpos, qvel, qfrc = np.zeros(mj.nq), np.zeros(mj.nv), np.zeros(mj.nv)
    qpos[:3], qpos[3], qpos[4:7] = q[:3], q[6], q[3:6]
    qvel[:3], qvel[3:6] = rotation @ v[:3], v[3:6]
    qfrc[:3], qfrc[3:6] = rotation @ tau[:3], tau[3:6]
    index = {}
    for joint_id in range(2, model.njoints):
        name = model.names[joint_id]
        mj_joint = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, name)
        assert mj_joint >= 0, name
        pin_q, pin_v = model.joints[joint_id].idx_q, model.joints[joint_id].idx_v
        mj_q, mj_v = mj.jnt_qposadr[mj_joint], mj.jnt_dofadr[mj_joint]
        qpos[mj_q], qvel[mj_v], qfrc[mj_v] = q[pin_q], v[pin_v], tau[pin_v]
        index[pin_v] = mj_v
    return qpos, qvel, qfrc, rotation, index


def _welded_to(mj, body: int, ancestor: int) -> bool:
    """Whether ``body`` hangs on ``ancestor`` through joint-less (welded) bodies only."""
    while body != ancestor and body != 0 and mj.body_jntnum[body] == 0:
        body = mj.body_parentid[body]
    return body == ancestor


@pytest.mark.parametrize("name", [*VEHICLES, "coupled"])
def test_mjcf_rigid_body_dynamics_match_pinocchio(name, coupled_urdf, tmp_path):
    source = coupled_urdf if name == "coupled" else VEHICLES[name]
    export_mjcf(source, tmp_path / "model.xml")
    mj = mujoco.MjModel.from_xml_path(str(tmp_path / "model.xml"))
    data = mujoco.MjData(mj)
    vehicle = load_vehicle(source, backend="pinocchio")
    model = vehicle.model
    assert (mj.nq, mj.nv) == (model.nq, model.nv)
    # masses, body by body (the inertias are checked through the dynamics below)
    assert mj.body_mass.sum() == pytest.approx(sum(i.mass for i in model.inertias), rel=1e-14)
    checked = 0
    for frame in model.frames:
        inertia = model.inertias[frame.parentJoint]
        if frame.type != pin.BODY or inertia.mass == 0.0:
            continue
        first_body = next(
            f for f in model.frames if f.parentJoint == frame.parentJoint and f.type == pin.BODY
        )
        if frame.name != first_body.name:
            continue
        checked += 1
        body = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, frame.name)
        subtree = [b for b in range(mj.nbody) if b == body or _welded_to(mj, b, body)]
        assert mj.body_mass[subtree].sum() == pytest.approx(inertia.mass, rel=1e-14), frame.name
        if len(subtree) == 1:  # principal moments of inertia about the centre of mass
            np.testing.assert_allclose(
                np.sort(mj.body_inertia[body]),
                np.linalg.eigvalsh(inertia.inertia),
                rtol=1e-10,
                atol=1e-12,
                err_msg=frame.name,
            )
    assert checked == model.njoints - 1
    pin_data = model.createData()
    # fluid off: the exported model is the rigid-body model, so MuJoCo's qacc is Pinocchio's aba
    mj.opt.density, mj.opt.viscosity = 0.0, 0.0
    mj.body_gravcomp[:] = 0.0
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    model.gravity.linear = np.array([0.0, 0.0, -vehicle.hydro.gravity])
    rng = np.random.default_rng(3)
    lower = np.where(np.isfinite(model.lowerPositionLimit), model.lowerPositionLimit, -1.0)
    upper = np.where(np.isfinite(model.upperPositionLimit), model.upperPositionLimit, 1.0)
    lower[:3], upper[:3] = -5.0, 5.0
    worst = 0.0
    for _ in range(20):
        q = pin.randomConfiguration(model, lower, upper)
        v = rng.normal(size=model.nv)
        tau = rng.normal(scale=10.0, size=model.nv)
        acceleration = pin.aba(model, pin_data, q, v, tau)
        qpos, qvel, qfrc, rotation, index = _mujoco_state(model, mj, q, v, tau)
        data.qpos[:], data.qvel[:], data.qfrc_applied[:] = qpos, qvel, qfrc
        data.ctrl[:] = 0.0
        mujoco.mj_forward(mj, data)
        expected = np.zeros(mj.nv)
        # d/dt (R v_b) = R (dv_b + omega_b x v_b); the angular part is in the body frame in both
        expected[:3] = rotation @ (acceleration[:3] + np.cross(v[3:6], v[:3]))
        expected[3:6] = acceleration[3:6]
        for pin_v, mj_v in index.items():
            expected[mj_v] = acceleration[pin_v]
        scale = max(1.0, float(np.max(np.abs(expected))))
        worst = max(worst, float(np.max(np.abs(data.qacc - expected))) / scale)
    assert worst < 1e-9


@pytest.mark.parametrize("name", ["paper_uniform", "coupled"])
def test_mjcf_thrusters_and_buoyancy(name, coupled_urdf, tmp_path):
    source = coupled_urdf if name == "coupled" else VEHICLES[name]
    export_mjcf(source, tmp_path / "model.xml")
    mj = mujoco.MjModel.from_xml_path(str(tmp_path / "model.xml"))
    data = mujoco.MjData(mj)
    vehicle = load_vehicle(source, backend="pinocchio")
    model = vehicle.model
    # buoyancy: rho V g in total, as gravity compensation
    hydro = vehicle.hydro
    lifted = float(np.sum(mj.body_gravcomp * mj.body_mass))
    assert lifted == pytest.approx(hydro.fluid_density * sum(k.volume for k in hydro.links))
    # thrusters: MuJoCo's actuator forces are our thrust matrix times the thrusts
    rng = np.random.default_rng(5)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    thrust = rng.uniform(-1.0, 1.0, size=len(hydro.thrusters)) * [
        t.max_thrust for t in hydro.thrusters
    ]
    generalised = vehicle.thrust_matrix(q) @ thrust
    qpos, _, expected, _, _ = _mujoco_state(model, mj, q, np.zeros(model.nv), generalised)
    data.qpos[:] = qpos
    for k, thruster in enumerate(hydro.thrusters):
        data.ctrl[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_ACTUATOR, thruster.name)] = thrust[k]
    mujoco.mj_forward(mj, data)
    np.testing.assert_allclose(data.qfrc_actuator, expected, rtol=0, atol=1e-10)
