"""MJCF vehicles (aiauv_pin.description.mjcf_reading): MuJoCo's compiled model is the ground truth
for frames, defaults and inferred inertias, so the loaded vehicle's dynamics are MuJoCo's."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from aiauv_pin import load_vehicle
from aiauv_pin.description.mjcf_reading import MjcfDroppedWarning, is_mjcf_text, read_mjcf
from aiauv_pin.errors import VehicleLoadError

mujoco = pytest.importorskip("mujoco")

#: Every orientation MJCF knows, degrees with a zyx Euler sequence, default classes, a joint away
#: from its body origin, a slide, inertias given in full, diagonal with a frame, and inferred from
#: geoms, a welded body, thrusters from a motor and a general actuator, and a joint motor.
PROBE = """<mujoco model="probe">
  <compiler angle="degree" eulerseq="zyx"/>
  <option density="0" viscosity="0"/>
  <default>
    <joint type="hinge" axis="0 1 0"/>
    <geom type="capsule" size="0.05 0.2" density="1100" contype="0" conaffinity="0"/>
    <default class="fin"><geom type="box" size="0.1 0.02 0.005"/></default>
  </default>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1" pos="0 0 -3"/>
    <body name="hull" pos="0.3 -0.2 0.5" euler="10 20 30">
      <freejoint name="root"/>
      <inertial pos="0.01 0.02 -0.03" mass="20" fullinertia="1.0 2.0 2.5 0.1 -0.05 0.02"/>
      <geom type="cylinder" size="0.1 0.5" zaxis="1 0 0" mass="0"/>
      <site name="prop" pos="-0.6 0 0" xyaxes="0 1 0 -1 0 0"/>
      <site name="side" pos="0.2 0.1 0" axisangle="1 0 0 30"/>
      <body name="seg1" pos="0.6 0 0" axisangle="0 0 1 15">
        <joint name="j1" pos="0.05 0 0.01" range="-45 60"/>
        <geom fromto="0 0 0 0.4 0 0"/>
        <body name="seg2" pos="0.4 0 0" quat="0.9 0.1 0.2 0.3">
          <joint name="j2" type="slide" axis="1 0 0" pos="0 0.02 0"/>
          <inertial pos="0.1 0 0" mass="2" diaginertia="0.01 0.02 0.03" euler="5 10 15"/>
          <body name="fin" pos="0.2 0 0" xyaxes="0 0 1 0 1 0">
            <geom class="fin"/>
          </body>
          <body name="seg3" pos="0.3 0 0" zaxis="0 1 1">
            <joint name="j3" axis="1 0 1"/>
            <geom type="ellipsoid" size="0.1 0.05 0.04" pos="0.1 0 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="main" site="prop" gear="0 0 2 0 0 0" ctrlrange="-3 3"/>
    <general name="lateral" site="side" gear="0 1 0 0 0 0" gainprm="5" forcerange="-10 10"/>
    <motor name="j1_motor" joint="j1" gear="1" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""


def _write(tmp_path, text: str, name: str = "vehicle.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _load(path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MjcfDroppedWarning)
        return load_vehicle(path, backend="pinocchio", **options)


def _mujoco_state(model, mj, q, v, tau):
    """Pinocchio (q, v, tau) as MuJoCo (qpos, qvel, qfrc), joints matched by name (free joint:
    ``qvel = (R v_b, omega_b)``, ``qfrc = (R f_b, m_b)``)."""
    rotation = pin.Quaternion(q[3:7]).toRotationMatrix()
    qpos, qvel, qfrc = np.zeros(mj.nq), np.zeros(mj.nv), np.zeros(mj.nv)
    qpos[:3], qpos[3], qpos[4:7] = q[:3], q[6], q[3:6]
    qvel[:3], qvel[3:6] = rotation @ v[:3], v[3:6]
    qfrc[:3], qfrc[3:6] = rotation @ tau[:3], tau[3:6]
    index = {}
    for joint_id in range(2, model.njoints):
        mj_joint = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, model.names[joint_id])
        pin_q, pin_v = model.joints[joint_id].idx_q, model.joints[joint_id].idx_v
        qpos[mj.jnt_qposadr[mj_joint]] = q[pin_q]
        qvel[mj.jnt_dofadr[mj_joint]], qfrc[mj.jnt_dofadr[mj_joint]] = v[pin_v], tau[pin_v]
        index[pin_v] = mj.jnt_dofadr[mj_joint]
    return qpos, qvel, qfrc, rotation, index


def test_rigid_body_dynamics_are_mujocos(tmp_path):
    """MuJoCo's accelerations (constraints off) equal Pinocchio's on the loaded vehicle to 1e-9 at
    random states: frames, orientations, defaults, joint positions and inertias all carried."""
    path = _write(tmp_path, PROBE)
    vehicle = _load(path)
    model, data = vehicle.model, vehicle.model.createData()
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    mj_data = mujoco.MjData(mj)
    assert (mj.nq, mj.nv) == (model.nq, model.nv)
    assert sum(i.mass for i in model.inertias) == pytest.approx(mj.body_mass.sum(), rel=1e-14)
    model.gravity.linear = np.array([0.0, 0.0, -vehicle.hydro.gravity])
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(20):
        q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
        v, tau = rng.normal(size=model.nv), rng.normal(scale=5.0, size=model.nv)
        acceleration = pin.aba(model, data, q, v, tau)
        qpos, qvel, qfrc, rotation, index = _mujoco_state(model, mj, q, v, tau)
        mj_data.qpos[:], mj_data.qvel[:], mj_data.qfrc_applied[:] = qpos, qvel, qfrc
        mujoco.mj_forward(mj, mj_data)
        expected = np.zeros(mj.nv)
        expected[:3] = rotation @ (acceleration[:3] + np.cross(v[3:6], v[:3]))
        expected[3:6] = acceleration[3:6]
        for pin_v, mj_v in index.items():
            expected[mj_v] = acceleration[pin_v]
        scale = max(1.0, float(np.max(np.abs(expected))))
        worst = max(worst, float(np.max(np.abs(mj_data.qacc - expected))) / scale)
    assert worst < 1e-9


def test_thrusters_are_mujocos_site_actuators(tmp_path):
    """Thrust [N] = |gear| gain ctrl along the gear at the site; limits from ctrlrange and
    forcerange; MuJoCo's actuator forces equal our thrust matrix times the thrusts."""
    path = _write(tmp_path, PROBE)
    vehicle = _load(path)
    thrusters = {t.name: t for t in vehicle.hydro.thrusters}
    assert list(thrusters) == ["main", "lateral"]
    assert thrusters["main"].max_thrust == pytest.approx(6.0)  # |gear| 2 x ctrl 3
    assert thrusters["lateral"].max_thrust == pytest.approx(10.0)  # forcerange
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj_data = mujoco.MjData(mj)
    model = vehicle.model
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    ctrl = np.array([0.7, -1.3, 0.0])
    thrust = np.array([2.0 * ctrl[0], 5.0 * ctrl[1]])
    expected = vehicle.thrust_matrix(q) @ thrust
    qpos, _, qfrc, _, _ = _mujoco_state(model, mj, q, np.zeros(model.nv), expected)
    mj_data.qpos[:], mj_data.ctrl[:] = qpos, ctrl
    mujoco.mj_forward(mj, mj_data)
    np.testing.assert_allclose(mj_data.qfrc_actuator, qfrc, rtol=0, atol=1e-12)


def test_what_is_dropped_is_said(tmp_path):
    text = PROBE.replace('<option density="0" viscosity="0"/>', '<option wind="0 1 0"/>')
    text = text.replace('name="j1" pos', 'name="j1" damping="0.5" pos')
    with pytest.warns(MjcfDroppedWarning) as record:
        dropped = read_mjcf(_write(tmp_path, text)).dropped
    assert len(record) == len(dropped)
    said = "\n".join(dropped)
    assert "wind 0 1.0 0 m/s: give it as the scenario's current" in said
    assert "joint damping dropped: 'j1'" in said
    assert (
        "actuators on joints left out: the joint torques are the vehicle's inputs: 'j1_motor'"
        in said
    )
    assert all("\n" not in line for line in dropped)


def test_detection_by_root_element(tmp_path):
    assert is_mjcf_text(PROBE)
    assert not is_mjcf_text('<robot name="r"><link name="a"/></robot>')
    assert not is_mjcf_text("not xml")


BAD = {
    "ball joint": (
        ('range="-45 60"', 'type="ball"'),
        "ball joint 'j1': not supported",
    ),
    "loop": (
        (
            "</actuator>",
            '</actuator><equality><connect body1="seg3" body2="hull" anchor="0 0 0"/></equality>',
        ),
        "equality constraint(s) (closed loops or welds): not supported",
    ),
    "two joints": (
        ('<joint name="j3" axis="1 0 1"/>', '<joint name="j3"/><joint name="j4" axis="1 0 0"/>'),
        "body 'seg3' has 2 joints: one joint a body is supported",
    ),
    "torque gear": (
        ('gear="0 0 2 0 0 0"', 'gear="0 0 2 1 0 0"'),
        "actuator 'main' has a torque gear: not a thruster",
    ),
    "servo": (
        (
            '<general name="lateral"',
            '<position name="servo" site="side" kp="10"/><general name="lateral"',
        ),
        "actuator 'servo' is not a force proportional to its control",
    ),
    "unlimited thruster": (
        ('gear="0 0 2 0 0 0" ctrlrange="-3 3"', 'gear="0 0 2 0 0 0" ctrllimited="false"'),
        "actuator 'main' has neither ctrlrange nor forcerange",
    ),
    "unknown element": (
        ("<worldbody>", "<worldbody><propeller/>"),
        "MuJoCo cannot compile it (XML Error: Schema violation: unrecognized element",
    ),
    "missing include": (
        ("<worldbody>", '<include file="missing.xml"/><worldbody>'),
        "MuJoCo cannot compile it",
    ),
    "two vehicles": (
        ("</worldbody>", '<body name="other"><freejoint/><geom size="0.1"/></body></worldbody>'),
        "several moving bodies under <worldbody> ('hull', 'other')",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_files_give_one_line(case, tmp_path):
    (old, new), message = BAD[case]
    assert old in PROBE
    with pytest.raises(VehicleLoadError) as error:
        _load(_write(tmp_path, PROBE.replace(old, new)))
    text = str(error.value)
    assert "\n" not in text and message in text, text
    assert text.startswith(str(tmp_path))


def test_missing_file_gives_one_line(tmp_path):
    with pytest.raises(VehicleLoadError) as error:
        load_vehicle(tmp_path / "absent.xml")
    assert "\n" not in str(error.value)


ARM = """<mujoco model="arm">
  <option density="1000" viscosity="0.001"/>
  <worldbody>
    <body name="shoulder" pos="0.1 0.2 -0.5" euler="0.1 0.2 0.3">
      <joint name="pan" axis="0 0 1" pos="0 0 0.05"/>
      <geom type="cylinder" size="0.05 0.2" pos="0.2 0 0" zaxis="1 0 0" fluidshape="ellipsoid"/>
      <body name="forearm" pos="0.4 0 0">
        <joint name="tilt" axis="0 1 0"/>
        <geom type="box" size="0.15 0.03 0.03" pos="0.15 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.filterwarnings("ignore::aiauv_pin.description.mjcf_reading.MjcfDroppedWarning")
def test_a_base_fixed_to_the_world_is_a_world_link(tmp_path):
    """Without a free joint, MuJoCo's world body is the URDF's massless root link ``world``, the
    root body hangs on its own joint below it, and the frames are MuJoCo's; the loader makes it a
    fixed base (:attr:`Vehicle.fixed_base`)."""
    path = _write(tmp_path, ARM)
    read = read_mjcf(path)
    assert read.fixed_base
    model = pin.buildModelFromXML(read.urdf_text)  # the world link is the root: fixed
    assert [model.names[j] for j in range(1, model.njoints)] == ["pan", "tilt"]
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj_data, data = mujoco.MjData(mj), model.createData()
    for angles in ([0.0, 0.0], [0.7, -1.1], [-2.0, 0.4]):
        mj_data.qpos[:] = angles
        mujoco.mj_forward(mj, mj_data)
        pin.forwardKinematics(model, data, np.array(angles))
        pin.updateFramePlacements(model, data)
        for body in ("shoulder", "forearm"):
            # a link frame is its body frame moved by its joint's pos
            mj_body = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, body)
            placement = data.oMf[model.getFrameId(body, pin.FrameType.BODY)]
            joint = mj.body_jntadr[mj_body]
            expected = (
                mj_data.xpos[mj_body] + mj_data.xmat[mj_body].reshape(3, 3) @ mj.jnt_pos[joint]
            )
            np.testing.assert_allclose(placement.translation, expected, atol=1e-12)
            np.testing.assert_allclose(
                placement.rotation, mj_data.xmat[mj_body].reshape(3, 3), atol=1e-12
            )
    assert _load(path).fixed_base


@pytest.mark.filterwarnings("ignore::aiauv_pin.description.mjcf_reading.MjcfDroppedWarning")
def test_a_fixed_base_mjcf_arm_moves_as_mujoco_moves_it(tmp_path):
    """The arm hanging from MuJoCo's world body, in a fluid a million times thinner than water (the
    fluid forces, and our added mass that MuJoCo leaves out of its mass matrix, vanish): its joint
    accelerations are MuJoCo's at rest, on both backends, and the base does not move."""
    path = _write(tmp_path, ARM.replace('density="1000"', 'density="0.001"'))
    mj = mujoco.MjModel.from_xml_path(str(path))
    mj_data = mujoco.MjData(mj)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MjcfDroppedWarning)
        vehicles = [_load(path), load_vehicle(path, backend="numba")]
    for angles in ([0.0, 0.0], [0.7, -1.1], [-2.0, 0.4]):
        mj_data.qpos[:] = angles
        mujoco.mj_forward(mj, mj_data)
        q = np.zeros(vehicles[0].nq)
        q[6], q[7:] = 1.0, angles
        for vehicle in vehicles:
            assert vehicle.fixed_base
            dv = vehicle.acceleration(q, np.zeros(vehicle.nv), np.zeros(vehicle.nv))
            assert np.all(dv[:6] == 0.0)
            np.testing.assert_allclose(dv[6:], mj_data.qacc, rtol=1e-5, atol=1e-6)
