"""Fins: the lift/drag law against the plugins' closed forms, the actuator response, and the
``<fin>`` / thruster-dynamics format (reader, writer, round trip, one-line errors)."""

from __future__ import annotations

import math
import warnings
from xml.etree.ElementTree import tostring

import numpy as np
import pytest

from aiauv_hydro.laws.actuators import actuator_response
from aiauv_hydro.laws.lift import angle_of_attack, fin_force
from aiauv_hydro.spec import Fin, HydroError, Thruster
from aiauv_hydro.urdf.block_reader import read_hydrodynamics
from aiauv_hydro.urdf.block_writer import hydrodynamics_element
from aiauv_hydro.urdf.uuv_simulator import thruster_time_constant, uuv_fins

RHO, AREA, CLA, CD0, CDA = 1025.0, 0.01, 3.0, 0.01, 1.2
Q = 0.5 * RHO * AREA


def force(delta, velocity, axis=(0.0, 0.0, 1.0), chord=(1.0, 0.0, 0.0), stall=math.inf, cd0=CD0):
    return np.array(
        fin_force(delta, *axis, *chord, *velocity, Q, CLA, cd0, CDA, stall), dtype=float
    )


def uuv_quadratic(velocity_in_fin, lift_constant, drag_constant):
    """UUV Simulator's LiftDragQuadratic::compute (LiftDragModel.cc lines 110-139), transcribed."""
    vel = np.asarray(velocity_in_fin, dtype=float)
    angle = math.atan2(vel[1], vel[0])
    if angle > math.pi / 2:
        angle -= math.pi
    elif angle < -math.pi / 2:
        angle += math.pi
    u2 = vel @ vel
    lift = angle * u2 * lift_constant
    drag = angle * angle * u2 * drag_constant
    lift_dir = -np.cross([0.0, 0.0, 1.0], vel)
    lift_dir /= np.linalg.norm(lift_dir)
    return lift * lift_dir + drag * (-vel / np.linalg.norm(vel))


def test_closed_form_lift_and_drag_of_a_rudder():
    """A rudder (span z, chord x) moving along +x at U with angle delta: lift 0.5 rho A C_La delta
    U^2 along +y (a x v), drag 0.5 rho A (C_D0 + C_Da2 delta^2) U^2 along -x."""
    for speed in (0.3, 1.0, 2.5):
        for delta in (-0.3, -0.05, 0.0, 0.1, 0.4):
            f = force(delta, (speed, 0.0, 0.0))
            lift = Q * CLA * delta * speed**2
            drag = Q * (CD0 + CDA * delta**2) * speed**2
            np.testing.assert_allclose(f, [-drag, lift, 0.0], rtol=1e-13, atol=1e-15)


def test_zero_at_zero_speed_and_spanwise_flow_ignored():
    assert np.all(force(0.3, (0.0, 0.0, 0.0)) == 0.0)
    assert np.all(force(0.3, (0.0, 0.0, 2.0)) == 0.0)  # along the span: no in-plane velocity
    np.testing.assert_allclose(force(0.2, (1.5, 0.0, 0.7)), force(0.2, (1.5, 0.0, 0.0)), rtol=1e-14)


def test_signs_and_symmetry():
    v = (2.0, 0.0, 0.0)
    # a positive angle pushes the fin towards a x c (+y); a negative one the other way, same drag
    plus, minus = force(0.2, v), force(-0.2, v)
    assert plus[1] > 0.0 > minus[1]
    np.testing.assert_allclose(plus * [1, -1, 1], minus, rtol=1e-14)
    # sideslip: the fin moving with a +y component at zero angle has alpha < 0, lift towards -y
    alpha, *_ = angle_of_attack(0.0, 0, 0, 1, 1, 0, 0, 2.0, 0.3, 0.0)
    assert alpha == pytest.approx(-math.atan2(0.3, 2.0), abs=1e-15)
    assert force(0.0, (2.0, 0.3, 0.0))[1] < 0.0  # weathervane: restoring
    # met from behind, the angle folds: moving along -x at delta gives alpha = delta (flat plate)
    alpha, *_ = angle_of_attack(0.1, 0, 0, 1, 1, 0, 0, -1.0, 0.0, 0.0)
    assert alpha == pytest.approx(0.1, abs=1e-15)
    # the force never does positive work on the fin (lift perpendicular, drag against the motion)
    for velocity in ((1.0, 0.4, 0.0), (-0.3, 1.2, 0.5), (0.2, -0.9, 0.0)):
        in_plane = np.array(velocity) * [1, 1, 0]
        for delta in (-0.4, 0.0, 0.3):
            assert force(delta, velocity) @ in_plane < 0.0


def test_stall_holds_the_lift_at_its_stall_value():
    v = (1.0, 0.0, 0.0)
    stall = 0.3
    below = force(0.25, v, stall=stall)
    above = force(0.45, v, stall=stall)
    assert below[1] == pytest.approx(Q * CLA * 0.25, rel=1e-13)
    assert above[1] == pytest.approx(Q * CLA * stall, rel=1e-13)  # held (gz-sim, cla_stall = 0)
    assert -above[0] == pytest.approx(Q * (CD0 + CDA * 0.45**2), rel=1e-13)  # drag keeps growing


def test_any_orientation_is_a_rotation_of_the_rudder():
    rng = np.random.default_rng(3)
    for _ in range(20):
        rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        rotation *= np.sign(np.linalg.det(rotation))
        v = rng.normal(size=3)
        delta = rng.uniform(-0.5, 0.5)
        local = force(delta, v)
        turned = force(delta, rotation @ v, axis=rotation[:, 2], chord=rotation[:, 0])
        np.testing.assert_allclose(turned, rotation @ local, rtol=1e-12, atol=1e-14)


def test_same_force_as_uuv_simulator_quadratic():
    """Our law with drag_zero = 0, no stall, A = 1 and slopes 2 k / rho equals the plugin's
    force for any velocity in its lift-drag plane and any fin angle (the plugin's fin frame is
    the link frame turned by the joint angle)."""
    lift_constant, drag_constant, rho = 9.8688, 6.513408, 1028.0
    rng = np.random.default_rng(5)
    for _ in range(50):
        v = np.array([*rng.normal(size=2) * 2.0, 0.0])
        delta = rng.uniform(-1.2, 1.2)
        c, s = math.cos(delta), math.sin(delta)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # fin link at angle delta
        theirs = turn @ uuv_quadratic(turn.T @ v, lift_constant, drag_constant)
        ours = fin_force(
            delta,
            0,
            0,
            1,
            1,
            0,
            0,
            *v,
            0.5 * rho,
            2 * lift_constant / rho,
            0.0,
            2 * drag_constant / rho,
            math.inf,
        )
        np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-12)


def test_actuator_response_exact_first_order_and_rate_limit():
    tau, dt = 0.2, 0.01
    state = 0.0
    for k in range(1, 101):
        state = actuator_response(state, 1.0, math.inf, tau, math.inf, dt)
        assert state == pytest.approx(1.0 - math.exp(-k * dt / tau), abs=1e-14)
    # rate limit: a step of 1 at 2 per second takes 0.5 s, linearly
    state = 0.0
    for k in range(1, 60):
        state = actuator_response(state, 1.0, math.inf, 0.0, 2.0, dt)
        assert state == pytest.approx(min(1.0, 2.0 * k * dt), abs=1e-14)
    # the command is clipped to the limit; no dynamics: the clipped command itself, bit for bit
    assert actuator_response(0.3, 5.0, 0.5, 0.0, math.inf, dt) == 0.5
    assert actuator_response(0.3, 0.123456789, 0.5, 0.0, math.inf, dt) == 0.123456789


ROBOT = """<robot name="r">
  <link name="hull"><inertial><mass value="1"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  {block}
</robot>"""
BLOCK = ROBOT.replace("{block}", '<hydrodynamics fluid_density="1000">{body}</hydrodynamics>')
FIN = (
    '<fin name="rudder" link="hull" xyz="-0.4 0 0.05" axis="0 0 1" chord="1 0 0" area="0.01" '
    'lift_slope="3.0" drag_zero="0.01" drag_slope="1.2" stall_angle="0.4" max_angle="0.5" '
    'max_rate="1.0" {extra}/>'
)


def test_reader_writer_round_trip_exact():
    text = BLOCK.format(
        body=FIN.format(extra='time_constant="0.1"')
        + '<fin name="plane" link="hull" axis="0 0.6 0.8" chord="1 0 0" area="0.02" '
        'lift_slope="2.5" max_angle="0.3"/>'
        + '<thruster name="prop" link="hull" xyz="-0.5 0 0" direction="1 0 0" max_thrust="50" '
        'time_constant="0.2" max_rate="100"/>'
        + '<thruster name="side" link="hull" direction="0 1 0" max_thrust="5"/>'
    )
    spec = read_hydrodynamics(text)
    assert [f.name for f in spec.fins] == ["rudder", "plane"]
    rudder, plane = spec.fins
    assert (rudder.stall_angle, rudder.max_rate, rudder.time_constant) == (0.4, 1.0, 0.1)
    assert plane.stall_angle == math.inf and plane.max_rate == math.inf and plane.drag_zero == 0.0
    prop, side = spec.thrusters
    assert (prop.time_constant, prop.max_rate) == (0.2, 100.0)
    assert (side.time_constant, side.max_rate) == (0.0, math.inf)
    written = tostring(hydrodynamics_element(spec), encoding="unicode")
    again = read_hydrodynamics(ROBOT.format(block=written))
    for a, b in zip(spec.fins + spec.thrusters, again.fins + again.thrusters, strict=True):
        for name, value in vars(a).items():
            other = getattr(b, name)
            if isinstance(value, np.ndarray):
                assert np.array_equal(value, other), (a.name, name)
            else:
                assert value == other, (a.name, name)
    # a default stays out of the text
    assert "time_constant" not in written.split('name="side"')[1].split("/>")[0]


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (FIN.format(extra="").replace('axis="0 0 1"', 'axis="0 0 0"'), "axis is the zero vector"),
        (FIN.format(extra="").replace('chord="1 0 0"', 'chord="1 0 1"'), "not perpendicular"),
        (FIN.format(extra="").replace('area="0.01"', 'area="-1"'), "area = -1 outside"),
        (FIN.format(extra="").replace('max_angle="0.5"', 'max_angle="0"'), "max_angle = 0 outside"),
        (FIN.format(extra="").replace('max_rate="1.0"', 'max_rate="-2"'), "max_rate = -2 outside"),
        (FIN.format(extra="").replace('lift_slope="3.0"', 'lift_slope="300"'), "lift_slope = 300"),
        (FIN.format(extra="").replace('link="hull"', 'link="tail"'), "link 'tail' is not"),
        (FIN.format(extra='wing="1"'), "unknown attribute 'wing'"),
        (FIN.format(extra="").replace(' max_angle="0.5"', ""), "missing max_angle"),
        (FIN.format(extra="") + FIN.format(extra=""), "fin name 'rudder' used twice"),
        (
            '<thruster name="p" link="hull" direction="1 0 0" max_thrust="5" time_constant="-1"/>',
            "time_constant must be >= 0",
        ),
        (
            '<thruster name="p" link="hull" direction="1 0 0" max_thrust="5" max_rate="0"/>',
            "max_rate must be positive",
        ),
    ],
)
def test_bad_fins_and_dynamics_give_one_line(body, message):
    with pytest.raises(HydroError, match=message) as error:
        read_hydrodynamics(BLOCK.format(body=body))
    assert "\n" not in str(error.value)


def test_records_refuse_bad_values():
    with pytest.raises(HydroError, match="not perpendicular"):
        Fin("f", "l", np.zeros(3), (0, 0, 1), (0.1, 0, 1), 0.01, 3.0)
    with pytest.raises(HydroError, match="area must be positive"):
        Fin("f", "l", np.zeros(3), (0, 0, 1), (1, 0, 0), 0.0, 3.0)
    with pytest.raises(HydroError, match="max_rate must be positive"):
        Thruster("t", "l", np.zeros(3), (1, 0, 0), 5.0, max_rate=math.nan)


LAUV_FIN = """<robot name="lauv">
  <link name="lauv/base_link"><inertial><mass value="18"/>
    <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="lauv/fin0"/>
  <joint name="lauv/fin0_joint" type="revolute">
    <limit effort="0" lower="-1.5707963267948966" upper="1.5707963267948966" velocity="0"/>
    <origin xyz="-0.4 0 0.04" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <parent link="lauv/base_link"/><child link="lauv/fin0"/>
  </joint>
  <gazebo>
    <plugin name="lauv_fin0_model" filename="libuuv_fin_ros_plugin.so">
      <dynamics><type>FirstOrder</type><timeConstant>0.2</timeConstant></dynamics>
      <liftdrag><type>Quadratic</type><lift_constant>9.8688</lift_constant>
        <drag_constant>6.513408</drag_constant></liftdrag>
      <current_velocity_topic>hydrodynamics/current_velocity</current_velocity_topic>
      <fin_id>0</fin_id><link_name>lauv/fin0</link_name><joint_name>lauv/fin0_joint</joint_name>
    </plugin>
  </gazebo>
</robot>"""


def test_uuv_simulator_fin_plugin_becomes_a_fin():
    """LAUV's fin macro (lauv_gazebo snippets.xacro: lift_constant = 0.5 * 1028 * 0.0064 * 3.0,
    drag_constant = 0.5 * 1028 * 0.0064 * 1.98; FirstOrder 0.2 s; joint limits +-90 deg)."""
    from aiauv_hydro.urdf.xml_reading import parse_robot_text, robot_links

    root = parse_robot_text(LAUV_FIN)
    (fin,) = uuv_fins(root, robot_links(root), 1028.0)
    assert fin.name == "lauv_fin0_model" and fin.link == "lauv/fin0"
    assert fin.area == 1.0
    assert 0.5 * 1028.0 * fin.area * fin.lift_slope == pytest.approx(9.8688, rel=1e-15)
    assert 0.5 * 1028.0 * fin.area * fin.drag_slope == pytest.approx(6.513408, rel=1e-15)
    assert fin.max_angle == pytest.approx(math.pi / 2) and fin.time_constant == 0.2
    assert np.array_equal(fin.axis, [0, 0, 1]) and np.array_equal(fin.chord, [1, 0, 0])
    spec = read_hydrodynamics(LAUV_FIN)
    assert [f.name for f in spec.fins] == ["lauv_fin0_model"]


def test_uuv_simulator_dynamics_types():
    from xml.etree.ElementTree import fromstring

    def dyn(text):
        return thruster_time_constant(fromstring(f"<dynamics>{text}</dynamics>"), "t")

    assert dyn("<type>ZeroOrder</type>") == 0.0
    assert dyn("<type>FirstOrder</type><timeConstant>0.05</timeConstant>") == 0.05
    assert dyn("<type>FirstOrder</type><time_constant>0.3</time_constant>") == 0.3
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert dyn("<type>Yoerger</type><alpha>1</alpha><beta>1</beta>") == 0.0
    assert "zero order" in str(caught[0].message)
    with pytest.raises(HydroError, match="not supported"):
        dyn("<type>Second</type>")
    assert thruster_time_constant(None, "t") == 0.0


def test_lauv_thruster_reads_its_first_order_dynamics():
    spec = read_hydrodynamics("tests/data/lauv_uuv_simulator.urdf")
    assert [t.time_constant for t in spec.thrusters] == [0.05]
