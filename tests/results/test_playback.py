"""The self-contained HTML playback and the meshcat scene behind it (and the live viewer)."""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin
import pytest

import aiauv_pin
from aiauv_pin.results import playback, viewer
from aiauv_pin.simulation.fixed_step import Trajectory

URDF = aiauv_pin.bundled_urdf("uniform")


def synthetic_trajectory(vehicle, duration: float, dt: float = 0.02) -> Trajectory:
    """A vehicle swimming along x on a lateral sinusoid, rolling and bending; thrusters cycling."""
    t = np.arange(0.0, duration + 0.5 * dt, dt)
    q = np.tile(vehicle.neutral_configuration(), (t.size, 1))
    q[:, 0] = 0.5 * t
    q[:, 1] = 0.5 * np.sin(0.2 * t)
    q[:, 2] = -0.2 + 0.1 * np.cos(0.1 * t)
    for k, tk in enumerate(t):
        rotation = pin.utils.rpyToMatrix(0.3 * np.sin(0.5 * tk), 0.05, 0.1 * np.cos(0.2 * tk))
        q[k, 3:7] = pin.Quaternion(rotation).coeffs()
    q[:, 7:] = 0.3 * np.sin(0.3 * t[:, None] + np.arange(vehicle.nq - 7))
    n = len(vehicle.thruster_names)
    heading = np.column_stack((np.ones_like(t), -0.2 * np.sin(0.2 * t), np.zeros_like(t)))
    info = {
        "thrust": 60.0 * np.sin(0.4 * t[:, None] + np.arange(n)),  # saturates beyond 50 N
        "x_ref": heading / np.linalg.norm(heading, axis=1, keepdims=True),
    }
    zeros = np.zeros((t.size, vehicle.nv))
    return Trajectory(t, q, zeros, zeros, info)


@pytest.fixture(scope="module")
def vehicle():
    return aiauv_pin.load_vehicle()


@pytest.fixture(scope="module")
def run(vehicle):
    return synthetic_trajectory(vehicle, 12.0)


@pytest.fixture(scope="module")
def page(vehicle, run, tmp_path_factory):
    path = tmp_path_factory.mktemp("playback") / "playback.html"
    written = playback.write_playback(vehicle, run, path, urdf=URDF)
    assert written == path
    return path.read_text(encoding="utf-8")


def _animation(commands):
    (command,) = [c for c in commands if c["type"] == "set_animation"]
    return {a["path"]: a["clip"] for a in command["animations"]}


def _track(clip, name):
    (track,) = [t for t in clip["tracks"] if t["name"] == f".{name}"]
    return np.array(track["times"]), np.array(track["values"])


def test_page_is_self_contained(page):
    tags = re.findall(r"<(script|link|img|iframe)\b([^>]*)>", page, flags=re.IGNORECASE)
    assert tags, "no script tag at all"
    for tag, attributes in tags:
        assert not re.search(r"\b(src|href)\s*=", attributes, flags=re.IGNORECASE), (
            tag,
            attributes,
        )
    assert "@import" not in page
    # the meshcat viewer itself is inlined
    assert "MeshCat.Viewer" in page and len(page) > 500_000


def test_animation_runs_in_real_time_with_the_expected_frames(page, run):
    commands = playback.read_commands(page)
    clips = _animation(commands)
    (command,) = [c for c in commands if c["type"] == "set_animation"]
    assert command["options"]["play"] is True
    duration = run.t[-1] - run.t[0]
    expected_frames = round(duration * 25.0) + 1  # 50 Hz log shown at 25 frames per second
    for clip in clips.values():
        assert clip["fps"] == 1  # key times are seconds: three.js divides them by fps
        for track in clip["tracks"]:
            times = np.array(track["times"])
            assert times.size == expected_frames
            assert times[0] == 0.0
            assert times[-1] == pytest.approx(duration, abs=1e-4)  # real time: clip = run length
            np.testing.assert_allclose(np.diff(times), 1.0 / 25.0, atol=1e-4)
            width = {"vector3": 3, "quaternion": 4}[track["type"]]
            assert len(track["values"]) == width * times.size


@pytest.mark.parametrize("key", [0, 77, 300])
def test_link_keyframes_are_pinocchio_link_poses(page, run, vehicle, key):
    clips = _animation(playback.read_commands(page))
    links = [f"link{i}" for i in range(1, 10)]
    times, _ = _track(clips[f"{viewer.LINKS}/link1"], "position")
    sample = int(np.argmin(np.abs(run.t - times[key])))
    assert run.t[sample] == pytest.approx(times[key], abs=1e-4)
    expected = vehicle.link_placements(run.q[sample], links)
    for link, pose in zip(links, expected, strict=True):
        clip = clips[f"{viewer.LINKS}/{link}"]
        position = _track(clip, "position")[1].reshape(-1, 3)[key]
        x, y, z, w = _track(clip, "quaternion")[1].reshape(-1, 4)[key]
        rotation = pin.Quaternion(w, x, y, z).normalized().matrix()
        np.testing.assert_allclose(position, pose.translation, atol=2e-4)
        np.testing.assert_allclose(rotation, pose.rotation, atol=5e-4)


def test_hull_cylinders_lie_along_the_link_x_axes(vehicle):
    # URDF visuals: cylinders with rpy = (0, pi/2, 0), i.e. along the link's x-axis, centred at L/2;
    # three.js cylinders lie along their y-axis, so the visual's y-axis must be the link's x-axis.
    visuals = viewer.vehicle_visuals(vehicle, URDF)
    assert [v.link for v in visuals] == [f"link{i}" for i in range(1, 10)]
    for v in visuals:
        assert v.geometry["type"] == "CylinderGeometry"
        assert v.geometry["radiusTop"] == pytest.approx(0.085)
        np.testing.assert_allclose(v.placement[:3, 1], [1.0, 0.0, 0.0], atol=1e-12)
        np.testing.assert_allclose(v.placement[:3, 3], [v.geometry["height"] / 2, 0.0, 0.0])
        np.testing.assert_allclose(v.color, (1.0, 0.72, 0.1, 1.0), atol=1e-6)
    # the cylinders end to end make up the whole body, from link1's origin to the end effector
    head = vehicle.frame_placement(vehicle.neutral_configuration(), "end_effector").translation[0]
    assert sum(v.geometry["height"] for v in visuals) == pytest.approx(head)


def test_thruster_arrows_scale_with_thrust(page, run, vehicle):
    clips = _animation(playback.read_commands(page))
    scene = viewer.VehicleScene(vehicle, urdf=URDF)
    times, _ = _track(clips[f"{viewer.LINKS}/link1"], "position")
    samples = np.array([int(np.argmin(np.abs(run.t - s))) for s in times])
    for k, thruster in enumerate(vehicle.hydro.thrusters):
        _, scale = _track(clips[scene.thruster_path(thruster.name)], "scale")
        scale = scale.reshape(-1, 3)
        np.testing.assert_allclose(scale[:, [0, 2]], 1.0)
        fraction = np.clip(run.info["thrust"][samples, k] / thruster.max_thrust, -1.0, 1.0)
        big = np.abs(fraction) > 1e-2
        np.testing.assert_allclose(
            scale[big, 1], fraction[big] * scene.arrow_length, atol=2e-4
        )  # negative thrust: the arrow points backwards


def test_los_arrow_points_along_x_ref_at_the_head(page, run, vehicle):
    clips = _animation(playback.read_commands(page))
    clip = clips[viewer.LOS]
    times, positions = _track(clip, "position")
    _, quaternions = _track(clip, "quaternion")
    for key in (0, 150, len(times) - 1):
        sample = int(np.argmin(np.abs(run.t - times[key])))
        head = vehicle.frame_placement(run.q[sample], "end_effector").translation
        np.testing.assert_allclose(positions.reshape(-1, 3)[key], head, atol=2e-4)
        x, y, z, w = quaternions.reshape(-1, 4)[key]
        arrow_axis = pin.Quaternion(w, x, y, z).normalized().matrix()[:, 1]
        np.testing.assert_allclose(arrow_axis, run.info["x_ref"][sample], atol=5e-4)


def _link_points(commands) -> np.ndarray:
    """World positions of every link in every frame of a playback's animation (F, L, 3)."""
    clips = _animation(commands)
    links = [
        path
        for path in clips
        if path.startswith(viewer.LINKS + "/") and "/" not in path[len(viewer.LINKS) + 1 :]
    ]
    return np.stack([_track(clips[path], "position")[1].reshape(-1, 3) for path in links], axis=1)


def _camera_distance(commands) -> float:
    (camera,) = [
        c for c in commands if c["path"] == viewer.CAMERA_OBJECT and c.get("property") == "position"
    ]
    return float(np.linalg.norm(camera["value"]))


def in_view(points: np.ndarray, distance: float, aspect: float = 4.0 / 3.0) -> np.ndarray:
    """Whether each point (relative to the looked-at point) is inside the view of meshcat's camera
    at ``distance`` along :data:`viewer.CAMERA_DIRECTION` (75 deg vertically, ``aspect``)."""
    back = np.array(viewer.CAMERA_DIRECTION) / np.linalg.norm(viewer.CAMERA_DIRECTION)
    relative = np.asarray(points, dtype=float).reshape(-1, 3) - distance * back
    depth = -(relative @ back)  # in front of the camera
    horizontal = np.array([back[1], -back[0], 0.0]) / np.hypot(back[0], back[1])
    vertical = np.cross(horizontal, -back)
    half = math.tan(math.radians(viewer.CAMERA_FOV) / 2)
    return (
        (depth > 0)
        & (np.abs(relative @ vertical) <= half * depth)
        & (np.abs(relative @ horizontal) <= aspect * half * depth)
    )


def test_a_short_motion_is_framed_whole_from_a_fixed_camera(vehicle):
    """2 s at 0.5 m/s, no path: the box of the links' motion is centred on the page's origin,
    where the camera looks, and every link is in view all the way; nothing moves the world."""
    short = synthetic_trajectory(vehicle, 2.0)
    commands = playback.playback_commands(vehicle, short, urdf=URDF)
    assert viewer.ROOT not in _animation(commands)  # no following
    (shift,) = [c for c in commands if c["type"] == "set_transform" and c["path"] == viewer.ROOT]
    centre = -np.array(shift["matrix"]).reshape(4, 4).T[:3, 3]  # column-major
    points = _link_points(commands).reshape(-1, 3)
    np.testing.assert_allclose(centre, 0.5 * (points.min(0) + points.max(0)), atol=0.5)
    distance = _camera_distance(commands)
    assert in_view(points - centre, distance).all()
    assert not in_view(points - centre, 0.7 * distance).all()  # and no farther than needed
    # no path given: none drawn, none in the legend
    assert not [c for c in commands if c["type"] == "set_object" and c["path"] == viewer.PATH]
    assert viewer.LEGEND["path"] not in playback.legend_entries(commands)


def test_a_longer_motion_is_followed_and_the_path_covers_it(vehicle, run):
    """12 s at 0.5 m/s (6 m, twice the vehicle's length) along the x-axis: the world follows the
    vehicle (it stays at the page's origin) and the camera fits it and the path beside it."""
    ends = [run.q[:, 0].min() - 5.0, run.q[:, 0].max() + 5.0]
    axis = np.column_stack((ends, np.zeros(2), np.zeros(2)))
    commands = playback.playback_commands(vehicle, run, urdf=URDF, path_points=axis)
    clips = _animation(commands)
    times, offset = _track(clips[viewer.ROOT], "position")
    offset = offset.reshape(-1, 3)
    scene = viewer.VehicleScene(vehicle, urdf=URDF)
    for key in (0, len(times) // 2, len(times) - 1):
        sample = int(np.argmin(np.abs(run.t - times[key])))
        centre = scene.frame(run.q[sample]).centroid
        np.testing.assert_allclose(offset[key], -centre, atol=2e-4)  # vehicle at the page origin
    distance = _camera_distance(commands)
    links = _link_points(commands)
    assert in_view(links + offset[:, None, :], distance).all()  # the vehicle, all the way
    assert distance < 5.0  # a few metres: the 3.5 m vehicle fills the view
    (path,) = [c for c in commands if c["type"] == "set_object" and c["path"] == viewer.PATH]
    points = np.array(path["object"]["geometries"][0]["data"]["attributes"]["position"]["array"])
    points = points.reshape(-1, 3)
    on_axis = points[(points[:, 1] == 0) & (points[:, 2] == 0)]
    assert on_axis[:, 0].min() <= run.q[:, 0].min() and on_axis[:, 0].max() >= run.q[:, 0].max()
    # the pieces of the axis line join up: sorted segment ends chain without gaps
    segments = on_axis.reshape(-1, 2, 3)[:, :, 0]
    segments = segments[np.argsort(segments[:, 0])]
    np.testing.assert_allclose(segments[1:, 0], segments[:-1, 1])


def test_camera_framing_fits_the_motion_or_follows_it():
    """:func:`playback.camera_framing` on made-up motions: a 0.8 m arm held still (framed from
    under a metre), the same arm carried 0.5 m (framed whole, farther) and 2 m (followed), and a
    3.5 m vehicle swimming 150 m 2.8 m off its path (followed, a few metres away)."""
    arm = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.4], [0.4, 0.0, 0.4], [0.8, 0.0, 0.4]])
    still = np.tile(arm, (10, 1, 1))
    framing = playback.camera_framing(still, still.mean(axis=1), vehicle_size=1.0)
    assert not framing.follow
    np.testing.assert_allclose(framing.centre, [0.4, 0.0, 0.2])
    # the arm grown by a tenth of its size (0.1 m) is in view, just
    corners = np.array([[x, y, z] for x in (-0.1, 0.9) for y in (-0.1, 0.1) for z in (-0.1, 0.5)])
    assert in_view(corners - framing.centre, framing.distance).all()
    assert not in_view(corners - framing.centre, 0.85 * framing.distance).all()
    assert framing.distance < 1.0  # a metre-sized arm fills the view
    along_x = np.array([1.0, 0.0, 0.0])
    carried = still + np.linspace(0.0, 0.5, 10)[:, None, None] * along_x
    farther = playback.camera_framing(carried, carried.mean(axis=1), vehicle_size=1.0)
    assert not farther.follow and framing.distance < farther.distance < 1.5
    assert in_view(carried.reshape(-1, 3) - farther.centre, farther.distance).all()
    away = still + np.linspace(0.0, 2.0, 10)[:, None, None] * along_x
    followed = playback.camera_framing(away, away.mean(axis=1), vehicle_size=1.0)
    assert followed.follow and followed.distance < 1.0
    assert in_view(away - away.mean(axis=1, keepdims=True), followed.distance).all()
    # a long swim: following, the camera fits the vehicle and its distance from the path
    body = np.column_stack((np.linspace(-3.5, 0.0, 10), np.zeros(10), np.zeros(10)))
    shift = np.linspace(0.0, 150.0, 300)[:, None, None] * along_x
    swim = body[None] + shift + np.array([0.0, 2.0, 2.0])
    path = np.array([[-10.0, 0.0, 0.0], [160.0, 0.0, 0.0]])
    swimming = playback.camera_framing(swim, swim.mean(axis=1), 3.5, path_points=path)
    assert swimming.follow
    offset = 2.0 * math.sqrt(2.0)  # the centroid's distance from the path
    assert swimming.distance == pytest.approx(1.1 * offset / math.sin(math.radians(37.5)))
    assert swimming.distance < 6.0


def test_300_s_run_stays_under_20_mb(vehicle, tmp_path):
    long_run = synthetic_trajectory(vehicle, 300.0)
    path = playback.write_playback(vehicle, long_run, tmp_path / "long.html", urdf=URDF)
    size = path.stat().st_size
    assert size < 20e6, f"{size / 1e6:.1f} MB"
    clips = _animation(playback.read_commands(path.read_text(encoding="utf-8")))
    times, _ = _track(clips[f"{viewer.LINKS}/link1"], "position")
    assert times[-1] == pytest.approx(300.0)
    assert times.size == 300 * 25 + 1  # the default budget does not cut a 300 s run


def test_max_frames_caps_the_frames_and_keeps_the_duration(vehicle, run, tmp_path):
    path = playback.write_playback(vehicle, run, tmp_path / "p.html", max_frames=40, urdf=URDF)
    clips = _animation(playback.read_commands(path.read_text(encoding="utf-8")))
    times, _ = _track(clips[f"{viewer.LINKS}/link1"], "position")
    assert times.size == 40
    assert times[-1] == pytest.approx(run.t[-1])


def test_frame_indices():
    t = np.arange(0.0, 1.0 + 1e-9, 0.01)
    np.testing.assert_array_equal(playback.frame_indices(t, 10.0), np.arange(0, 101, 10))
    # uneven log: first sample at or after each tick, and the last one
    t = np.array([0.0, 0.03, 0.09, 0.1, 0.22, 0.25])
    np.testing.assert_array_equal(playback.frame_indices(t, 10.0), [0, 3, 4, 5])
    assert playback.frame_indices(np.array([3.0]), 25.0).tolist() == [0]
    with pytest.raises(ValueError, match="fps"):
        playback.frame_indices(t, 0.0)
    with pytest.raises(ValueError, match="increasing"):
        playback.frame_indices(t[::-1], 10.0)


def test_write_is_atomic(vehicle, run, tmp_path):
    target = tmp_path / "playback.html"
    target.write_text("old page")
    playback.write_playback(vehicle, run, target, max_frames=10, urdf=URDF)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["playback.html"]
    assert target.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    # a failure leaves the previous file and no temporary file
    target.write_text("old page")
    broken = Trajectory(run.t, run.q[:, :5], run.v, run.tau, {})
    with pytest.raises(ValueError, match=r"trajectory\.q must have shape") as error:
        playback.write_playback(vehicle, broken, target, urdf=URDF)
    assert "\n" not in str(error.value)
    assert target.read_text() == "old page"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["playback.html"]


def test_non_finite_trajectory_is_refused(vehicle, run, tmp_path):
    q = run.q.copy()
    q[5, 0] = math.nan
    with pytest.raises(ValueError, match="non-finite configuration at sample 5"):
        playback.write_playback(vehicle, Trajectory(run.t, q, run.v, run.tau, {}), tmp_path / "x")


class _RecordingWindow:
    def __init__(self):
        self.commands = []

    def send(self, command):
        self.commands.append(command.lower())


class _FakeVisualizer:
    def __init__(self):
        self.window = _RecordingWindow()


def test_live_viewer_sends_pinocchio_poses_and_thrust(vehicle, run):
    fake = _FakeVisualizer()
    live = viewer.MeshcatViewer(vehicle, urdf=URDF, visualizer=fake)
    built = {c["path"] for c in fake.window.commands if c["type"] == "set_object"}
    assert {f"{viewer.LINKS}/link{i}/visual_{i - 1}" for i in range(1, 10)} <= built
    fake.window.commands.clear()
    k = 333
    live.display(run.q[k], {key: value[k] for key, value in run.info.items()})
    sent = {c["path"]: c for c in fake.window.commands if c["type"] == "set_transform"}
    links = [f"link{i}" for i in range(1, 10)]
    for link, pose in zip(links, vehicle.link_placements(run.q[k], links), strict=True):
        matrix = np.array(sent[f"{viewer.LINKS}/{link}"]["matrix"]).reshape(4, 4).T  # column-major
        np.testing.assert_allclose(matrix, pose.homogeneous, atol=1e-12)
    thruster = vehicle.hydro.thrusters[2]
    arrow = np.array(sent[live.scene.thruster_path(thruster.name)]["matrix"]).reshape(4, 4).T
    fraction = np.clip(run.info["thrust"][k, 2] / thruster.max_thrust, -1, 1)
    assert arrow[1, 1] == pytest.approx(fraction * live.scene.arrow_length)
    visible = [c for c in fake.window.commands if c["type"] == "set_property"]
    assert visible == [viewer.set_property(viewer.LOS, "visible", True)]
    with pytest.raises(ValueError, match="info\\['thrust'\\] must have 7 entries"):
        live.display(run.q[k], {"thrust": np.zeros(3)})


def test_visuals_without_urdf_come_from_the_crossflow_cylinders(vehicle):
    # write_playback(vehicle, trajectory, path) as the CLI calls it: the vehicle alone; its
    # slender-cylinder hydrodynamics give the same cylinders as the URDF's <visual> elements
    from_urdf = viewer.vehicle_visuals(vehicle, URDF)
    from_hydro = viewer.vehicle_visuals(vehicle)
    assert [v.link for v in from_hydro] == [v.link for v in from_urdf]
    for a, b in zip(from_hydro, from_urdf, strict=True):
        assert a.geometry["height"] == pytest.approx(b.geometry["height"])
        assert a.geometry["radiusTop"] == pytest.approx(b.geometry["radiusTop"])
        np.testing.assert_allclose(a.placement[:3, 3], b.placement[:3, 3], atol=1e-12)
        np.testing.assert_allclose(a.placement[:3, 1], b.placement[:3, 1], atol=1e-12)  # axis


def test_live_viewer_draws_the_scenario_path(vehicle):
    """``aiauv simulate --view`` draws the scenario's own path (here a helix), not the x-axis."""
    from aiauv_control.paths import HelixPath
    from aiauv_pin.results.outputs import live_path_points
    from aiauv_pin.scenario.definition import Scenario

    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=10.0, pitch=10.0)
    scenario = Scenario(path=helix, start_position=(10.0, 0.0, 0.0), duration=60.0)
    points = live_path_points(scenario)
    radius = np.hypot(points[:, 0], points[:, 1])
    np.testing.assert_allclose(radius, 10.0, rtol=1e-12)
    fake = _FakeVisualizer()
    viewer.MeshcatViewer(vehicle, urdf=URDF, visualizer=fake, path_points=points)
    (path,) = [
        c for c in fake.window.commands if c["type"] == "set_object" and c["path"] == viewer.PATH
    ]
    drawn = np.array(path["object"]["geometries"][0]["data"]["attributes"]["position"]["array"])
    drawn = drawn.reshape(-1, 3)
    assert drawn[:, 2].max() - drawn[:, 2].min() > 5.0  # climbs with the helix
    # on the helix's cylinder, but for the tick marks sticking out across it
    assert np.median(np.hypot(drawn[:, 0], drawn[:, 1])) == pytest.approx(10.0, rel=1e-3)


def test_the_scene_json_holds_the_values_json_writes(vehicle, run):
    import json

    from aiauv_hydro.waves import Waves

    for sea in (None, Waves(height=0.5, period=4.0)):
        commands = playback.playback_commands(vehicle, run, urdf=URDF, sea=sea)
        ours = playback.commands_json(commands)
        # the same values, every float exactly (both write the shortest text that reads back)
        assert json.loads(ours) == json.loads(json.dumps(commands))
    odd = [{"none": None, "float": np.float64(0.25), "nested": [[1, 2.5e-05], "é"]}]
    assert json.loads(playback.commands_json(odd)) == odd
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(ValueError, match="Out of range float"):
            playback.commands_json([{"values": [0.0, bad]}])
