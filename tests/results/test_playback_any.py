"""Playback and viewer for any model: shapes without visuals, package:// meshes, colours, legend,
end-effector trail, camera, path through arbitrary points, the live server's address."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_playback import in_view

import aiauv_pin
from aiauv_hydro.estimate.ellipsoid import inertia_equivalent_ellipsoid
from aiauv_pin.app.annotate_command import annotate_file
from aiauv_pin.builders.uvms import uvms_urdf
from aiauv_pin.description.robots import example_robot_urdf
from aiauv_pin.results import playback, viewer


def _passive_run(vehicle, duration=1.0, dt=0.01):
    q0 = vehicle.neutral_configuration()
    return aiauv_pin.simulate(vehicle, q0, np.zeros(vehicle.nv), duration=duration, dt=dt)


@pytest.fixture(scope="module")
def ur5(tmp_path_factory):
    path = tmp_path_factory.mktemp("ur5") / "ur5.urdf"
    annotate_file(example_robot_urdf("ur_description/urdf/ur5_robot.urdf"), path, neutral=True)
    return aiauv_pin.load_vehicle(path)


def test_path_segments_follow_any_polyline_with_a_tick_every_metre():
    s = np.linspace(0.0, 3.0 * math.pi, 200)
    helix = np.column_stack((np.cos(s), np.sin(s), 0.3 * s))
    segments = viewer.path_segments(helix, tick=0.05)
    length = float(np.sum(np.linalg.norm(np.diff(helix, axis=0), axis=1)))
    pieces = segments.reshape(-1, 2, 3)
    piece_lengths = np.linalg.norm(pieces[:, 1] - pieces[:, 0], axis=1)
    ticks = np.isclose(piece_lengths, 0.1)  # crosses of half size 0.05
    assert ticks.sum() == 2 * (math.floor(length) + 1)
    along = pieces[~ticks]
    assert np.sum(np.linalg.norm(along[:, 1] - along[:, 0], axis=1)) == pytest.approx(length)
    assert piece_lengths.max() <= 1.0 + 1e-9
    # every end point of the polyline pieces lies on the helix polyline
    for point in along.reshape(-1, 3)[::17]:
        assert playback._distance_to_path(point, helix) < 1e-12
    # tick crosses are normal to the polyline piece they sit on
    centres = pieces[ticks].mean(axis=1)
    for piece, centre in zip(pieces[ticks], centres, strict=True):
        a, b = helix[:-1], helix[1:]
        s_k = np.einsum("ij,ij->i", centre - a, b - a) / np.einsum("ij,ij->i", b - a, b - a)
        gaps = np.linalg.norm(a + np.clip(s_k, 0, 1)[:, None] * (b - a) - centre, axis=1)
        k = int(np.argmin(gaps))
        direction = (b[k] - a[k]) / np.linalg.norm(b[k] - a[k])
        assert abs((piece[1] - piece[0]) @ direction) < 1e-9


def test_example_robot_meshes_resolve_and_links_get_distinct_colours(ur5):
    visuals = viewer.vehicle_visuals(ur5)
    links = {v.link for v in visuals}
    massive = {"base_link", "shoulder_link", "upper_arm_link", "forearm_link"}
    assert massive <= links
    assert any(v.geometry["type"] == "BufferGeometry" for v in visuals)  # package:// meshes
    colours = {v.link: v.color for v in visuals}
    assert len(set(colours.values())) == len(colours)


def test_links_without_geometry_are_drawn_as_their_inertia_ellipsoid(tmp_path):
    path = tmp_path / "bare.urdf"
    path.write_text(
        """<robot name="bare">
  <link name="a"><inertial><origin xyz="0.1 0 0" rpy="0 0 0.4"/><mass value="3"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.035"/></inertial></link>
  <link name="b"><inertial><mass value="1"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><origin xyz="0.25 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder length="0.5" radius="0.04"/></geometry></collision></link>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""",
        encoding="utf-8",
    )
    vehicle = aiauv_pin.load_vehicle(path)
    by_link = {v.link: v for v in viewer.vehicle_visuals(vehicle)}
    ellipsoid = by_link["a"]
    expected = inertia_equivalent_ellipsoid(
        3.0,
        np.diag([0.01, 0.03, 0.035]),
        np.array(
            [[math.cos(0.4), -math.sin(0.4), 0], [math.sin(0.4), math.cos(0.4), 0], [0, 0, 1]]
        ),
        np.array([0.1, 0.0, 0.0]),
    )
    assert ellipsoid.geometry["type"] == "SphereGeometry"
    stretch = ellipsoid.placement[:3, :3]  # rotation times the semi-axes
    np.testing.assert_allclose(stretch @ stretch.T, _shape_matrix(expected), atol=1e-12)
    np.testing.assert_allclose(ellipsoid.placement[:3, 3], [0.1, 0.0, 0.0], atol=1e-15)
    assert by_link["b"].geometry["type"] == "CylinderGeometry"  # its collision cylinder


def _shape_matrix(ellipsoid):
    r = ellipsoid.rotation
    return r @ np.diag(ellipsoid.semi_axes**2) @ r.T


def test_uvms_plays_back(tmp_path):
    path = tmp_path / "uvms.urdf"
    path.write_text(uvms_urdf(), encoding="utf-8")
    vehicle = aiauv_pin.load_vehicle(path)
    page = playback.write_playback(vehicle, _passive_run(vehicle, 0.5), tmp_path / "uvms.html")
    commands = playback.read_commands(page.read_text(encoding="utf-8"))
    drawn = {c["path"].split("/")[3] for c in commands if c["path"].startswith(viewer.LINKS)}
    assert {"hull", "panda_link1", "panda_hand"} <= drawn


def test_trail_legend_and_camera(ur5, tmp_path):
    run = _passive_run(ur5, 2.0)
    page = playback.write_playback(ur5, run, tmp_path / "ur5.html").read_text(encoding="utf-8")
    commands = playback.read_commands(page)
    (trail,) = [c for c in commands if c["type"] == "set_object" and c["path"] == viewer.TRAIL]
    points = np.array(trail["object"]["geometries"][0]["data"]["attributes"]["position"]["array"])
    points = points.reshape(-1, 3)
    scene = viewer.VehicleScene(ur5)
    tip = ur5.model.frames[scene.trail_frame].name
    assert tip in ("wrist_3_link", "ee_link", "tool0")
    np.testing.assert_allclose(points[0], scene.trail_point(run.q[0]), atol=1e-4)
    np.testing.assert_allclose(points[-1], scene.trail_point(run.q[-1]), atol=1e-4)
    assert "end-effector trail" in page
    assert "path (tick every metre)" not in page  # a run without a path draws none
    assert "line-of-sight" not in page  # no LOS in a passive run
    # the camera frames the arm's own motion from a fixed place: a metre-sized arm fills the
    # view from a few metres at most, and every link stays inside the view
    assert not [
        c
        for c in commands
        if c["type"] == "set_animation" and any(a["path"] == viewer.ROOT for a in c["animations"])
    ]
    (camera,) = [c for c in commands if c["path"] == viewer.CAMERA_OBJECT]
    distance = float(np.linalg.norm(camera["value"]))
    assert distance < 3.0
    links = np.array(
        [
            [pose.translation for pose in ur5.link_placements(q, scene.links)]
            for q in run.q[:: max(1, len(run.q) // 20)]
        ]
    )
    (shift,) = [c for c in commands if c["type"] == "set_transform" and c["path"] == viewer.ROOT]
    centre = -np.array(shift["matrix"]).reshape(4, 4).T[:3, 3]
    assert in_view(links - centre, distance).all()


def test_path_points_are_drawn_as_given(ur5, tmp_path):
    run = _passive_run(ur5, 0.5)
    circle = np.column_stack(
        (
            np.cos(np.linspace(0, 2 * math.pi, 50)),
            np.sin(np.linspace(0, 2 * math.pi, 50)),
            0 * np.ones(50),
        )
    )
    commands = playback.playback_commands(ur5, run, path_points=3.0 * circle)
    (path,) = [c for c in commands if c["type"] == "set_object" and c["path"] == viewer.PATH]
    points = np.array(path["object"]["geometries"][0]["data"]["attributes"]["position"]["array"])
    radii = np.linalg.norm(points.reshape(-1, 3)[:, :2], axis=1)
    assert radii.min() > 2.9 and radii.max() < 3.2


def test_live_server_listens_on_loopback_only():
    from aiauv_pin.results.meshcat_server import start_server

    server = start_server()
    try:
        ports = {
            int(server.web_url.rsplit(":", 1)[1].split("/")[0]),
            int(server.zmq_url.rsplit(":", 1)[1]),
        }
        listening = []
        for table in ("/proc/net/tcp", "/proc/net/tcp6"):
            for line in open(table, encoding="ascii").read().splitlines()[1:]:
                fields = line.split()
                address, port = fields[1].rsplit(":", 1)
                if fields[3] == "0A" and int(port, 16) in ports:
                    listening.append(address)
        assert listening and set(listening) == {"0100007F"}, listening
    finally:
        server.stop()
