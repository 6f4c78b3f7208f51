"""The playback's frames computed in arrays agree with the one-frame-at-a-time definitions.

:meth:`VehicleScene.frames` against :meth:`VehicleScene.frame` and :meth:`VehicleScene.trail_point`,
:func:`playback.rotation_quaternions` against Pinocchio's (Eigen's) conversion, and
:func:`playback.same_hemisphere` against its definition.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from test_playback import URDF, synthetic_trajectory

import aiauv_pin
from aiauv_pin.results import playback, viewer


@pytest.fixture(scope="module")
def scene_and_run():
    vehicle = aiauv_pin.load_vehicle()
    run = synthetic_trajectory(vehicle, 3.0, dt=0.05)
    info = dict(run.info)
    info["thrust"] = info["thrust"].copy()
    info["thrust"][5, 2] = np.nan  # a non-finite thrust is drawn as none
    info["x_ref"] = info["x_ref"].copy()
    info["x_ref"][7] = 0.0  # no direction: the LOS arrow keeps the identity rotation
    return viewer.VehicleScene(vehicle, urdf=URDF), run.q, info


def test_frames_are_frame_row_by_row(scene_and_run):
    scene, q, info = scene_and_run
    states = scene.frames(q, info)
    assert len(states.poses) == len(scene.links) + 1  # the links and the LOS arrow
    for k in range(len(q)):
        state = scene.frame(q[k], {key: value[k] for key, value in info.items()})
        assert list(state.poses) == list(states.poses)
        assert list(state.scales) == list(states.scales)
        for path, pose in state.poses.items():
            np.testing.assert_array_equal(states.poses[path][k], pose)
        for path, scale in state.scales.items():
            np.testing.assert_array_equal(states.scales[path][k], scale)
        np.testing.assert_array_equal(states.centroid[k], state.centroid)
        np.testing.assert_array_equal(states.trail[k], scene.trail_point(q[k]))
    scales = np.array([states.scales[scene.thruster_path(t.name)][:, 1] for t in scene.thrusters])
    assert np.all(np.abs(scales) <= scene.arrow_length) and np.all(scales != 0.0)


def test_frames_refuse_a_thrust_of_the_wrong_size(scene_and_run):
    scene, q, info = scene_and_run
    with pytest.raises(ValueError, match="info\\['thrust'\\] must have 7 entries, got 6"):
        scene.frames(q, {"thrust": info["thrust"][:, :6]})


def test_rotation_quaternions_are_eigens():
    rng = np.random.default_rng(3)
    quaternions = rng.normal(size=(4000, 4))
    rotations = np.array([pin.Quaternion(*x).normalized().matrix() for x in quaternions])
    rotations = np.concatenate((rotations, [np.eye(3), np.diag([1.0, -1.0, -1.0])]))
    expected = np.array([pin.Quaternion(r).coeffs() for r in rotations])
    traces = np.trace(rotations, axis1=1, axis2=2)
    assert np.sum(traces <= 0.0) > 1000  # both of Shepperd's branches are exercised
    got = playback.rotation_quaternions(rotations)
    np.testing.assert_allclose(got, expected, rtol=0.0, atol=1e-15)
    assert playback.rotation_quaternions(rotations.reshape(2, -1, 3, 3)).shape == (2, 2001, 4)


def test_same_hemisphere_flips_only_signs():
    rng = np.random.default_rng(4)
    quaternions = rng.normal(size=(500, 4))
    flipped = playback.same_hemisphere(quaternions)
    np.testing.assert_array_equal(np.abs(flipped), np.abs(quaternions))
    np.testing.assert_array_equal(flipped[0], quaternions[0])
    assert np.all(np.einsum("ij,ij->i", flipped[1:], flipped[:-1]) >= 0.0)


def test_distances_to_a_polyline_are_those_of_each_point():
    rng = np.random.default_rng(5)
    path = np.cumsum(rng.normal(size=(300, 3)), axis=0)
    points = 3.0 * rng.normal(size=(700, 3))  # several chunks
    a, ab = path[:-1], np.diff(path, axis=0)
    expected = []
    for point in points:  # closest point of each segment, then the closest segment
        s = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
        expected.append(np.min(np.linalg.norm(a + s[:, None] * ab - point, axis=1)))
    got = playback._distances_to_path(points, path)
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=0.0)
    assert playback._distance_to_path(points[3], path) == got[3]
