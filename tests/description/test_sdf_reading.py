"""The SDF reader: undeclared prefixes, SDF 1.7+ frames, includes and URIs, gz systems, bad files."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from aiauv_pin import load_vehicle
from aiauv_pin.description.sdf_reading import (
    BuoyancyWorld,
    parse_sdf_text,
    read_sdf_vehicle,
    read_thruster,
)
from aiauv_pin.errors import InteropError, VehicleLoadError

DATA = Path(__file__).parents[1] / "data" / "gz"
EXAMPLES = Path(__file__).parents[2] / "examples" / "gz"

INERTIAL = (
    "<inertial><mass>{m}</mass>"
    "<inertia><ixx>0.1</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial>"
)

#: SDF 1.9 frames: a <frame> attached to a link, a link posed relative to it, a joint whose frame
#: is not its child's (pose relative to the child), an axis expressed in the model frame, and a
#: nested model posed relative to a link.
FRAMES_SDF = f"""<sdf version="1.9">
  <model name="rig">
    <frame name="mount" attached_to="hull"><pose relative_to="hull">0.5 0 0.1 0 0 0</pose></frame>
    <link name="hull"><pose>1 2 3 0 0 0.3</pose>{INERTIAL.format(m=10)}</link>
    <link name="arm">
      <pose relative_to="mount">0.2 0 0 0 0 90</pose>
      {INERTIAL.format(m=2)}
    </link>
    <joint name="shoulder" type="revolute">
      <pose>0.05 0 0 0 0 0</pose>
      <parent>hull</parent><child>arm</child>
      <axis><xyz expressed_in="__model__">0 0 1</xyz>
        <limit><lower>-1</lower><upper>1</upper></limit></axis>
    </joint>
    <model name="sensor">
      <pose relative_to="arm">0 0 0.1 0 0 0</pose>
      <link name="body">{INERTIAL.format(m=1)}</link>
    </model>
    <joint name="sensor_mount" type="fixed"><parent>arm</parent><child>sensor::body</child></joint>
  </model>
</sdf>
"""


def _write(tmp_path: Path, text: str, name: str = "model.sdf") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_undeclared_prefixes_are_read():
    """osrf/lrauv's tethys_equipped model uses gz: and experimental: without declaring them:
    parsed (the reported 'unbound prefix' failure), then its include is not found (one line)."""
    text = (DATA / "tethys_equipped_model.sdf").read_text(encoding="utf-8")
    root = parse_sdf_text(text, "tethys_equipped")
    assert root.tag == "sdf"
    include = root.find("model/include")
    assert "experimental:params" in [child.tag for child in include]
    with pytest.raises(InteropError, match=r"^model 'tethys' not found \(searched") as info:
        read_sdf_vehicle(DATA / "tethys_equipped_model.sdf")
    assert "\n" not in str(info.value)


def test_frames_relative_to_nested_models_and_joint_frames(tmp_path):
    path = _write(tmp_path, FRAMES_SDF.replace("0 0 90</pose>", "0 0 1.5707963267948966</pose>"))
    vehicle = load_vehicle(path, backend="pinocchio")
    q = vehicle.neutral_configuration()
    arm = vehicle.frame_placement(q, "arm")
    np.testing.assert_allclose(arm.translation, [0.7, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(arm.rotation[:, 0], [0.0, 1.0, 0.0], atol=1e-12)
    body = vehicle.frame_placement(q, "sensor/body")
    np.testing.assert_allclose(body.translation, [0.7, 0.0, 0.2], atol=1e-12)
    # the joint turns the arm about its own point (0.05 m along the arm's x), about world z
    angle = 0.3
    q[7] = angle
    joint_point = np.array([0.7, 0.05, 0.1])
    turned = joint_point + np.array(
        [-0.05 * math.cos(math.pi / 2 + angle), -0.05 * math.sin(math.pi / 2 + angle), 0.0]
    )
    np.testing.assert_allclose(vehicle.frame_placement(q, "arm").translation, turned, atol=1e-12)
    assert vehicle.model.existFrame("arm_joint_frame")
    assert math.isclose(sum(inertia.mass for inertia in vehicle.model.inertias), 13.0)
    assert vehicle.hydro.links == ()  # no gz systems: no fluid terms


def test_degrees_pose(tmp_path):
    text = FRAMES_SDF.replace(
        '<pose relative_to="mount">', '<pose relative_to="mount" degrees="true">'
    )
    vehicle = load_vehicle(_write(tmp_path, text), backend="pinocchio")
    arm = vehicle.frame_placement(vehicle.neutral_configuration(), "arm")
    np.testing.assert_allclose(arm.rotation[:, 0], [0.0, 1.0, 0.0], atol=1e-12)


@pytest.mark.parametrize(
    "change, message",
    [
        (
            (
                '<frame name="mount" attached_to="hull"><pose relative_to="hull">',
                '<frame name="mount" attached_to="hull"><pose relative_to="arm">',
            ),
            r"loop of relative_to frames: (mount -> arm -> mount|arm -> mount -> arm)",
        ),
        (
            (
                "<parent>arm</parent><child>sensor::body</child>",
                "<parent>arm</parent><child>hull</child>",
            ),
            r"link 'hull' is the child of two joints|loop in the tree",
        ),
        (("<child>sensor::body</child>", "<child>nowhere</child>"), "not a link of the model"),
        (('type="revolute"', 'type="ball"'), "has type ball, not supported"),
        (("</model>\n</sdf>", '<link name="loose"/></model>\n</sdf>'), "links without a parent"),
        (("<sdf version", "<!DOCTYPE sdf [<!ENTITY a 'b'>]><sdf version"), "DTD"),
        (("sdf", "robot"), "not an SDF file"),
        (("</model>\n</sdf>", "</model>"), "not well-formed XML"),
    ],
)
def test_bad_files_are_one_line(tmp_path, change, message):
    text = FRAMES_SDF.replace(*change)
    assert text != FRAMES_SDF
    with pytest.raises(VehicleLoadError, match=message) as info:
        load_vehicle(_write(tmp_path, text), backend="pinocchio")
    assert "\n" not in str(info.value)


def test_world_picks_its_model(tmp_path):
    model = FRAMES_SDF.split('<sdf version="1.9">')[1].split("</sdf>")[0]
    other = model.replace('name="rig"', 'name="other"')
    world = f'<sdf version="1.9"><world name="w">{model}{other}</world></sdf>'
    path = _write(tmp_path, world, "two.world")
    with pytest.raises(InteropError, match=r"2 models \('rig', 'other'\); choose one with --model"):
        load_vehicle(path, backend="pinocchio")
    assert load_vehicle(path, model="other", backend="pinocchio").name == "other"
    with pytest.raises(InteropError, match="no model named 'third'"):
        load_vehicle(path, model="third", backend="pinocchio")
    with pytest.raises(VehicleLoadError, match="only for SDF files"):
        load_vehicle(None, model="rig")


def test_model_uri_through_the_model_path(tmp_path, monkeypatch):
    folder = tmp_path / "models" / "rig"
    folder.mkdir(parents=True)
    (folder / "model.config").write_text(
        '<model><name>rig</name><sdf version="1.9">rig.sdf</sdf></model>', encoding="utf-8"
    )
    _write(folder, FRAMES_SDF, "rig.sdf")
    world = (
        '<sdf version="1.9"><world name="w"><include><name>copy</name>'
        "<uri>model://rig</uri><pose>0 0 -4 0 0 0</pose></include></world></sdf>"
    )
    path = _write(tmp_path, world, "w.sdf")
    monkeypatch.delenv("GZ_SIM_RESOURCE_PATH", raising=False)
    with pytest.raises(InteropError, match=r"model 'model://rig' not found"):
        load_vehicle(path, backend="pinocchio")
    vehicle = read_sdf_vehicle(path, model_path=[tmp_path / "models"])
    assert vehicle.name == "copy" and vehicle.world_position == (0.0, 0.0, -4.0)
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(tmp_path / "models"))
    assert load_vehicle(path, backend="pinocchio").name == "copy"


def test_fuel_uri_needs_a_local_copy(monkeypatch, tmp_path):
    monkeypatch.delenv("GZ_SIM_RESOURCE_PATH", raising=False)
    monkeypatch.setenv("GZ_FUEL_CACHE_PATH", str(tmp_path))
    with pytest.raises(InteropError) as info:
        read_sdf_vehicle(EXAMPLES / "auv_controls.sdf")
    message = str(info.value)
    assert "\n" not in message
    assert "https://fuel.gazebosim.org/1.0/accurrent/models/MBARI%20Tethys%20LRAUV" in message
    assert "is on the network" in message and "--model-path" in message
    assert "'MBARI Tethys LRAUV'" in message
    # gz's own Fuel cache layout is a local copy too
    cache = tmp_path / "fuel.gazebosim.org" / "accurrent" / "models" / "mbari tethys lrauv" / "3"
    cache.mkdir(parents=True)
    source = EXAMPLES / "models" / "MBARI Tethys LRAUV" / "model.sdf"
    (cache / "model.sdf").write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert read_sdf_vehicle(EXAMPLES / "auv_controls.sdf").name == "my_lrauv"


def _plugin(body: str):
    return parse_sdf_text(
        f"<sdf><plugin name='gz::sim::systems::Thruster'>{body}</plugin></sdf>", "t"
    )[0]


def test_thruster_limits():
    """Thruster.cc: force commands clamped to [min, max]_thrust_cmd (default +-1000 N); angular
    velocity commands to the same limits in rad/s, thrust C_t rho D^4 omega^2."""
    assert read_thruster(_plugin("<joint_name>p</joint_name>"), "").max_thrust == 1000.0
    limited = _plugin(
        "<joint_name>p</joint_name><max_thrust_cmd>40</max_thrust_cmd><min_thrust_cmd>-60</min_thrust_cmd>"
    )
    assert read_thruster(limited, "a/").max_thrust == 60.0
    assert read_thruster(limited, "a/").joint == "a/p"
    angular = _plugin(
        "<joint_name>p</joint_name><use_angvel_cmd>true</use_angvel_cmd>"
        "<thrust_coefficient>0.004422</thrust_coefficient><fluid_density>1000</fluid_density>"
        "<propeller_diameter>0.2</propeller_diameter><max_thrust_cmd>50</max_thrust_cmd>"
    )
    expected = 0.004422 * 1000 * 0.2**4 * 1000.0**2  # |min| = 1000 rad/s is the larger
    assert math.isclose(read_thruster(angular, "").max_thrust, expected, rel_tol=1e-12)
    with pytest.warns(
        UserWarning, match=r"Thruster plugin of joint 'p': unknown parameter\(s\) <bogus>"
    ):
        read_thruster(_plugin("<joint_name>p</joint_name><bogus>1</bogus>"), "")
    with pytest.raises(InteropError, match="without <joint_name>"):
        read_thruster(_plugin(""), "")


def test_graded_buoyancy_density():
    """Buoyancy.cc lines 183-230: a layer's density holds above its height, the default below."""
    world = BuoyancyWorld(1025.0, ((-10.0, 1020.0), (0.0, 1.2)))
    assert world.density_at(-20.0) == 1025.0
    assert world.density_at(-5.0) == 1020.0
    assert world.density_at(1.0) == 1.2


def test_graded_buoyancy_in_a_world(tmp_path):
    model = FRAMES_SDF.split('<sdf version="1.9">')[1].split("</sdf>")[0]
    model = model.replace(
        '<link name="hull"><pose>1 2 3 0 0 0.3</pose>',
        '<link name="hull"><pose>1 2 3 0 0 0.3</pose><collision name="c"><geometry>'
        "<box><size>1 0.1 0.1</size></box></geometry></collision>",
    ).replace('<model name="rig">', '<model name="rig"><pose>0 0 -12 0 0 0</pose>')
    plugin = (
        '<plugin filename="gz-sim-buoyancy-system" name="gz::sim::systems::Buoyancy">'
        "<graded_buoyancy><default_density>1025</default_density>"
        "<density_change><above_depth>-10</above_depth><density>1020</density></density_change>"
        "<density_change><above_depth>0</above_depth><density>1</density></density_change>"
        "</graded_buoyancy></plugin>"
    )
    path = _write(tmp_path, f'<sdf version="1.9"><world name="w">{plugin}{model}</world></sdf>')
    with pytest.warns(UserWarning, match=r"graded buoyancy: .* z = -12 m, 1025 kg/m\^3"):
        vehicle = load_vehicle(path, backend="pinocchio")
    assert vehicle.hydro.fluid_density == 1025.0
    (hull,) = vehicle.hydro.links
    assert math.isclose(hull.volume, 0.01)
