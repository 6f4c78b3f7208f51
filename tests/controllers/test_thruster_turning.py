"""The thruster-turning baseline: allocation closed forms, sideslip rotation, and short closed-loop
runs on the paper's vehicle (straight path and helix)."""

from __future__ import annotations

import numpy as np
import pytest

from aiauv_control.laws.turning_laws import (
    NOT_TUNNEL,
    PITCH_PLANE,
    YAW_PLANE,
    sideslip_compensated,
    tunnel_allocation,
)
from aiauv_hydro.numerics.jit import interpreted

PLANE = np.array(
    [PITCH_PLANE, YAW_PLANE, NOT_TUNNEL, NOT_TUNNEL, PITCH_PLANE, YAW_PLANE, PITCH_PLANE]
)
FORCE = np.array([1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0])
MOMENT = np.array([0.685, -0.575, 0.0, 0.0, -0.254, 0.833, -0.943])  # the paper vehicle's [m]


@pytest.mark.parametrize("allocate", [tunnel_allocation, interpreted(tunnel_allocation)])
def test_allocation_gives_the_moment_and_no_side_force(allocate):
    thrusts = np.full(7, 7.0)
    scale = allocate(3.0, -5.0, PLANE, FORCE, MOMENT, 50.0, thrusts)
    assert scale == 1.0
    assert thrusts[2] == 7.0 and thrusts[3] == 7.0  # X thrusters untouched
    for plane, demand in ((PITCH_PLANE, 3.0), (YAW_PLANE, -5.0)):
        k = PLANE == plane
        assert np.sum(FORCE[k] * thrusts[k]) == pytest.approx(0.0, abs=1e-12)
        assert np.sum(MOMENT[k] * thrusts[k]) == pytest.approx(demand, rel=1e-12)
    # two yaw thrusters: the closed form F = +-M / (m_7 - m_3)
    assert thrusts[5] == pytest.approx(-5.0 / (0.833 + 0.575), rel=1e-12)
    assert thrusts[1] == pytest.approx(5.0 / (0.833 + 0.575), rel=1e-12)
    # minimum norm among the exact solutions (the pitch plane has one degree of freedom left)
    k = np.flatnonzero(PLANE == PITCH_PLANE)
    A = np.vstack([FORCE[k], MOMENT[k]])
    assert thrusts[k] == pytest.approx(np.linalg.pinv(A) @ [0.0, 3.0], rel=1e-12)


def test_allocation_saturates_all_tunnel_thrusts_by_one_factor():
    thrusts = np.zeros(7)
    free = np.zeros(7)
    tunnel_allocation(400.0, 300.0, PLANE, FORCE, MOMENT, 1e9, free)
    scale = tunnel_allocation(400.0, 300.0, PLANE, FORCE, MOMENT, 50.0, thrusts)
    assert np.abs(thrusts).max() == pytest.approx(50.0, rel=1e-12)
    assert scale == pytest.approx(50.0 / np.abs(free).max(), rel=1e-12)
    assert thrusts == pytest.approx(scale * free, rel=1e-12)  # the moment's direction is kept


def test_allocation_single_thruster_is_moment_only():
    plane = np.array([YAW_PLANE, PITCH_PLANE])
    thrusts = np.zeros(2)
    tunnel_allocation(2.0, 3.0, plane, np.ones(2), np.array([0.5, -0.4]), 50.0, thrusts)
    assert thrusts == pytest.approx([3.0 / 0.5, 2.0 / -0.4], rel=1e-12)


def test_sideslip_rotation_takes_velocity_to_pointing():
    rng = np.random.default_rng(3)
    theta = 0.2
    rotation = np.array(
        [[np.cos(theta), -np.sin(theta), 0.0], [np.sin(theta), np.cos(theta), 0.0], [0, 0, 1.0]]
    )
    velocity = np.array([0.5, 0.0, 0.0])  # course along x, pointing turned by theta about z
    x_dot = tuple(rng.normal(size=3))
    x, xd, xdd = sideslip_compensated(velocity, rotation, (1.0, 0.0, 0.0), x_dot, (0.0, 0.0, 1.0))
    assert x == pytest.approx((np.cos(theta), np.sin(theta), 0.0), abs=1e-14)
    assert xdd == pytest.approx((0.0, 0.0, 1.0), abs=1e-14)  # the rotation axis is kept
    assert xd == pytest.approx(rotation @ np.array(x_dot), abs=1e-14)  # the same rotation
    same = sideslip_compensated(
        np.zeros(3), rotation, (1.0, 0.0, 0.0), (0.0, 0.1, 0.0), (0.0, 0.0, 0.0)
    )
    assert same[0] == (1.0, 0.0, 0.0)  # at rest: unchanged


@pytest.mark.slow
@pytest.mark.parametrize("path", ["x-axis", "helix"])
def test_thruster_turning_approaches_the_path(path):
    """60 s from 2 m (x-axis) or 1.4 m (helix) off: the error shrinks by more than half, the body
    stays straight (joint angles below 2 deg), the tunnel thrusters turn it and energy is logged."""
    import aiauv_pin
    from aiauv_control.paths import HelixPath
    from aiauv_pin.model.loading import bundled_urdf
    from aiauv_pin.scenario.definition import Scenario, run_scenario, summary

    options = (
        dict(
            path=HelixPath(centre=(0, 0, 0), axis=(0, 0, 1), radius=10.0, pitch=10.0),
            start_position=(11.0, 0.0, -1.0),
        )
        if path == "helix"
        else {}
    )
    vehicle = aiauv_pin.load_vehicle(bundled_urdf("uniform"))
    result = run_scenario(
        vehicle, Scenario(duration=60.0, controller="thruster_turning", **options)
    )
    s = summary(result)
    info = result.trajectory.info
    start = np.hypot(*info["cross_track"][0])
    assert s["status"] == "complete"
    assert s["final"]["cross_track_error"] < 0.5 * start
    assert np.abs(result.trajectory.q[:, 7:]).max() < np.deg2rad(2.0)
    assert np.abs(info["thrust"][:, [0, 1, 4, 5, 6]]).max() > 0.1
    assert np.abs(info["thrust"]).max() <= 50.0
    assert s["energy"]["total"] > 0 and s["energy"]["per_metre"] > 0
