"""Paths (aiauv_control.paths): closest point, rotation-minimising frame, curvatures, scenario tables.

Geometry is checked against its definition: stationarity ``(p - c).T = 0`` and a dense sampling
for the closest point, central finite differences along ``s`` for the frame equations
``dT/ds = k1 N1 + k2 N2``, ``dN_i/ds = -k_i T`` and the curvature rates (Bishop 1975), the helix's
closed-form curvature and torsion, and exact floating-point values on the paper's x-axis.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from aiauv_control.paths import (
    PATH_TYPES,
    HelixPath,
    LinePath,
    PathPoint,
    UserPath,
    WaypointPath,
    from_mapping,
    helix_point,
)
from aiauv_hydro.numerics.jit import interpreted

RNG = np.random.default_rng(12)

WAYPOINTS = [(0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (10.0, 10.0, 5.0), (0.0, 20.0, 0.0), (5, 25, -3)]

PATHS = {
    "line": LinePath((1.0, -2.0, 3.0), (1.0, 2.0, -0.5)),
    "helix": HelixPath((1.0, 2.0, -3.0), (0.3, -0.2, 1.0), 10.0, 10.0, start_angle=0.7),
    "helix_left": HelixPath((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 4.0, -30.0),
    "circle": HelixPath((0.0, 0.0, 0.0), (0.0, 1.0, 1.0), 5.0, 0.0),
    "waypoints": WaypointPath(WAYPOINTS, 2.0),
}


def arr(t) -> np.ndarray:
    return np.asarray(t, dtype=float)


def frame(q: PathPoint) -> np.ndarray:
    """Rows T, N1, N2."""
    return np.array([q.tangent, q.normal1, q.normal2])


def s_grid(path, n: int) -> np.ndarray:
    if isinstance(path, HelixPath) and path.pitch == 0.0:  # a circle: s in (-pi R, pi R]
        return np.linspace(-3.1 * path.radius, 3.1 * path.radius, n)
    if isinstance(path, HelixPath):
        return np.linspace(-40.0, 160.0, n)  # several turns
    if isinstance(path, WaypointPath):
        return np.linspace(-5.0, path.breakpoints[-1] + 5.0, n)
    return np.linspace(-20.0, 20.0, n)


def on_path(path, s: float) -> PathPoint:
    q = path.closest(path.points_at([s])[0])
    assert q.s == pytest.approx(s, abs=1e-9)
    return q


# --- closest point --------------------------------------------------------------------------


@pytest.mark.parametrize("name", PATHS)
def test_closest_point_is_stationary_and_beats_dense_sampling(name):
    path = PATHS[name]
    grid = s_grid(path, 40001)
    samples = path.points_at(grid)
    lo, hi = samples.min(axis=0), samples.max(axis=0)
    for _ in range(60):
        p = lo + (hi - lo) * RNG.uniform(-0.3, 1.3, 3)
        q = path.closest(p)
        assert abs((p - arr(q.point)) @ arr(q.tangent)) < 1e-9 * max(1.0, np.linalg.norm(p))
        assert np.allclose(path.points_at([q.s])[0], q.point, atol=1e-9)
        distance = np.linalg.norm(p - arr(q.point))
        assert distance <= np.linalg.norm(samples - p, axis=1).min() + 1e-12
    # points near the helix axis and far from it, on many turns
    if isinstance(path, HelixPath):
        centre, axis = arr(path.centre), arr(path.axis)
        for z in np.linspace(-30.0, 80.0, 23):
            for offset in (1e-3, 0.5, 30.0, 300.0):
                p = centre + z * axis + offset * np.cross(axis, [0.6, 0.8, 0.0]) / 1.0
                q = path.closest(p)
                distance = np.linalg.norm(p - arr(q.point))
                assert distance <= np.linalg.norm(samples - p, axis=1).min() + 1e-12


def test_helix_closest_point_converges_to_rounding():
    path = PATHS["helix"]
    for _ in range(200):
        p = arr(path.centre) + RNG.normal(0.0, 15.0, 3)
        q = path.closest(p)
        assert abs((p - arr(q.point)) @ arr(q.tangent)) < 1e-12


# --- frame ----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", PATHS)
def test_frame_orthonormal_right_handed_and_without_flips(name):
    path = PATHS[name]
    previous = None
    for s in s_grid(path, 1201):
        q = on_path(path, s)
        f = frame(q)
        assert np.allclose(f @ f.T, np.eye(3), atol=1e-12)
        assert np.allclose(np.cross(f[0], f[1]), f[2], atol=1e-12)  # T x N1 = N2
        if previous is not None:  # ds <= 0.17 m: neighbouring frames nearly equal
            assert f[1] @ previous[1] > 0.99 and f[2] @ previous[2] > 0.99
        previous = f


@pytest.mark.parametrize("name", PATHS)
def test_rotation_minimising_frame_and_curvatures_by_finite_differences(name):
    path = PATHS[name]
    h = 1e-4
    breaks = np.array(getattr(path, "breakpoints", ()))
    for s in s_grid(path, 157):
        if breaks.size and np.abs(breaks - s).min() < 2 * h:
            continue
        q, qm, qp = on_path(path, s), on_path(path, s - h), on_path(path, s + h)
        dT, dN1, dN2 = (frame(qp) - frame(qm)) / (2 * h)
        T, N1, N2 = frame(q)
        k1, k2 = q.curvature1, q.curvature2
        assert np.allclose(dT, k1 * N1 + k2 * N2, atol=1e-7)
        assert np.allclose(dN1, -k1 * T, atol=1e-7)
        assert np.allclose(dN2, -k2 * T, atol=1e-7)
        assert (qp.curvature1 - qm.curvature1) / (2 * h) == pytest.approx(
            q.curvature1_rate, abs=1e-8
        )
        assert (qp.curvature2 - qm.curvature2) / (2 * h) == pytest.approx(
            q.curvature2_rate, abs=1e-8
        )
        assert np.allclose(arr(qp.point) - arr(qm.point), 2 * h * T, atol=1e-9)


@pytest.mark.parametrize("name", ["helix", "helix_left", "circle"])
def test_helix_curvature_and_torsion_match_closed_forms(name):
    path = PATHS[name]
    b = path.pitch / (2 * math.pi)
    kappa, tau = path.radius / (path.radius**2 + b**2), b / (path.radius**2 + b**2)
    assert (path.curvature, path.torsion) == pytest.approx((kappa, tau), rel=1e-15)
    h = 1e-4
    for s in s_grid(path, 41):
        q, qm, qp = on_path(path, s), on_path(path, s - h), on_path(path, s + h)
        assert math.hypot(q.curvature1, q.curvature2) == pytest.approx(kappa, rel=1e-12)
        # k1 + i k2 = kappa exp(i tau s): the development angle turns at the torsion
        turn = math.atan2(qp.curvature2, qp.curvature1) - math.atan2(qm.curvature2, qm.curvature1)
        turn = (turn + math.pi) % (2 * math.pi) - math.pi
        assert turn / (2 * h) == pytest.approx(tau, abs=1e-9)
        # Frenet curvature from the curve itself: kappa = |c' x c''| at unit speed
        c = path.points_at(s + 1e-3 * np.arange(-1, 2))
        d1 = (c[2] - c[0]) / 2e-3
        d2 = (c[2] - 2 * c[1] + c[0]) / 1e-6
        assert np.linalg.norm(np.cross(d1, d2)) == pytest.approx(kappa, rel=1e-5)


def test_helix_start_point_and_start_frame():
    path = HelixPath((1.0, 2.0, 3.0), (0.0, 0.0, 1.0), 4.0, 6.0, start_angle=0.5)
    start = arr(path.centre) + 4.0 * np.array([math.cos(0.5), math.sin(0.5), 0.0])
    q = path.closest(start)
    assert q.s == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(q.point, start, atol=1e-12)
    T = arr(q.tangent)
    projected = arr(path.axis) - (arr(path.axis) @ T) * T
    assert np.allclose(q.normal2, projected / np.linalg.norm(projected), atol=1e-12)
    # right-handed about the axis: moving counter-clockwise seen from +z and upwards
    assert T[2] > 0 and np.cross(start - arr(path.centre), T)[2] > 0
    one_turn = 2 * math.pi * math.hypot(4.0, 6.0 / (2 * math.pi))  # [m]
    assert path.closest(start + np.array([0.0, 0.0, 6.0])).s == pytest.approx(one_turn, abs=1e-12)


# --- lines ----------------------------------------------------------------------------------


def test_x_axis_line_gives_the_paper_cross_track_errors_exactly():
    path = LinePath((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    for function in (path.function, interpreted(path.function)):
        for p in RNG.normal(0.0, 50.0, (200, 3)):
            q = function(p, path.params)
            assert q.s == p[0]
            assert tuple(q.point) == (p[0], 0.0, 0.0)
            assert tuple(q.tangent) == (1.0, 0.0, 0.0)
            assert tuple(q.normal1) == (0.0, 1.0, 0.0)
            assert tuple(q.normal2) == (0.0, 0.0, 1.0)
    for p in RNG.normal(0.0, 50.0, (200, 3)):
        error = path.cross_track_error(p)
        assert error[0] == p[1] and error[1] == p[2]


def test_line_in_any_direction_is_the_x_axis_case_rotated():
    for _ in range(50):
        point, direction = RNG.normal(0.0, 5.0, 3), RNG.normal(0.0, 1.0, 3)
        path = LinePath(point, direction)
        rows = frame(path.closest(point))
        assert np.allclose(rows[0], direction / np.linalg.norm(direction), atol=1e-15)
        # N2 lies in the plane of T and world up, pointing up
        assert abs(np.cross(rows[0], [0, 0, 1.0]) @ rows[2]) < 1e-12 and rows[2][2] > 0
        local = RNG.normal(0.0, 10.0, 3)
        q = path.closest(point + rows.T @ local)
        assert q.s == pytest.approx(local[0], abs=1e-12)
        assert np.allclose(path.cross_track_error(point + rows.T @ local), local[1:], atol=1e-12)
        assert np.allclose(frame(q), rows, atol=0)


def test_vertical_line_uses_world_x_as_reference():
    for direction in ((0.0, 0.0, 1.0), (1e-8, 0.0, -1.0)):
        q = LinePath((0.0, 0.0, 0.0), direction).closest([1.0, 2.0, 3.0])
        T, N1, N2 = frame(q)
        projected = np.array([1.0, 0, 0]) - T[0] * T
        assert np.allclose(N2, projected / np.linalg.norm(projected), atol=1e-15)
        assert np.allclose(np.cross(T, N1), N2, atol=1e-15)


# --- waypoints ------------------------------------------------------------------------------


def test_two_waypoints_are_a_line():
    a, b = np.array([1.0, 2.0, 3.0]), np.array([4.0, -2.0, 8.0])
    waypoints, line = WaypointPath([a, b], 1.0), LinePath(a, b - a)
    for p in RNG.normal(0.0, 10.0, (50, 3)):
        assert np.allclose(np.hstack(waypoints.closest(p)), np.hstack(line.closest(p)), atol=1e-12)


def test_waypoint_corners_are_tangent_arcs_of_the_corner_radius():
    path = PATHS["waypoints"]
    assert path.closest(WAYPOINTS[0]).s == 0.0
    bounds = (-np.inf, *path.breakpoints, np.inf)
    for k in range(len(bounds) - 1):
        middle = 0.5 * (max(bounds[k], -3.0) + min(bounds[k + 1], bounds[-2] + 3.0))
        q = on_path(path, middle)
        curvature = math.hypot(q.curvature1, q.curvature2)
        assert curvature == pytest.approx(0.5 if k % 2 else 0.0, abs=1e-12)  # 1 / corner radius
        assert q.curvature1_rate == q.curvature2_rate == 0.0
    # each arc leaves its segments tangentially and touches no waypoint, the tangent is continuous
    for s in path.breakpoints:
        before, after = on_path(path, s - 1e-7), on_path(path, s + 1e-7)
        assert np.allclose(frame(before), frame(after), atol=1e-6)
    # the tangent on the last piece is the last segment's direction
    last = arr(WAYPOINTS[-1]) - arr(WAYPOINTS[-2])
    assert np.allclose(
        on_path(path, path.breakpoints[-1] + 1.0).tangent, last / np.linalg.norm(last)
    )


def test_collinear_waypoint_needs_no_arc():
    path = WaypointPath([(0, 0, 0), (1, 0, 0), (3, 0, 0), (3, 4, 0)], 0.5)
    assert len(path.breakpoints) == 3  # line, line, arc, line
    assert path.closest([2.0, 1.0, 1.0]).normal1 == pytest.approx((0.0, 1.0, 0.0))


# --- compiled and interpreted ---------------------------------------------------------------


@pytest.mark.parametrize("name", PATHS)
def test_compiled_and_interpreted_agree(name):
    path = PATHS[name]
    plain = interpreted(path.function)
    samples = path.points_at(s_grid(path, 50))
    for p in samples + RNG.normal(0.0, 3.0, samples.shape):
        fast, slow = path.function(p, path.params), plain(p, path.params)
        assert np.allclose(np.hstack(fast), np.hstack(slow), rtol=0, atol=1e-12)


def test_user_path_takes_a_compiled_function_and_samples_by_marching():
    helix = PATHS["helix"]
    user = UserPath(helix_point, helix.params)
    p = np.array([3.0, 1.0, 4.0])
    assert user.closest(p) == helix.closest(p)
    assert np.allclose(user.cross_track_error(p), helix.cross_track_error(p), atol=0)
    assert np.allclose(user.sample((-5.0, 50.0), 23), helix.sample((-5.0, 50.0), 23), atol=1e-8)
    assert json.loads(json.dumps(user.describe()))["type"] == "user"


# --- tables and errors ----------------------------------------------------------------------


@pytest.mark.parametrize("name", PATHS)
def test_describe_round_trips_through_from_mapping(name):
    path = PATHS[name]
    table = json.loads(json.dumps(path.describe()))  # JSON-friendly, for summary.json
    rebuilt = from_mapping(table)
    assert type(rebuilt) is PATH_TYPES[table["type"]]
    assert np.allclose(rebuilt.params, path.params, rtol=0, atol=1e-15)


def test_sample_returns_points_on_the_path():
    path = PATHS["helix"]
    points = path.sample(30.0, 7)
    assert points.shape == (7, 3)
    assert np.allclose([path.closest(p).s for p in points], np.linspace(0.0, 30.0, 7), atol=1e-9)


BAD_CLASSES = [
    (lambda: LinePath((0, 0, 0), (0, 0, 0)), "path.direction: zero vector"),
    (lambda: LinePath((0, 0), (1, 0, 0)), "path.point: expected 3 numbers"),
    (lambda: LinePath((0, 0, math.nan), (1, 0, 0)), "path.point: contains NaN"),
    (lambda: HelixPath((0, 0, 0), (0, 0, 1), 0.0, 1.0), "path.radius: must be > 0"),
    (lambda: HelixPath((0, 0, 0), (0, 0, 1), -2.0, 1.0), "path.radius: must be > 0"),
    (lambda: HelixPath((0, 0, 0), (0, 0, 0), 2.0, 1.0), "path.axis: zero vector"),
    (lambda: HelixPath((0, 0, 0), (0, 0, 1), 2.0, math.inf), "path.pitch: must be finite"),
    (lambda: WaypointPath([(0, 0, 0)], 1.0), "path.points: need at least 2 distinct waypoints"),
    (lambda: WaypointPath([(0, 0, 0), (0, 0, 0)], 1.0), "path.points: waypoints 0 and 1 coincide"),
    (lambda: WaypointPath([(0, 0, 0), (1, 0, 0), (0, 0, 0)], 1.0), "path.points: the path reve"),
    (lambda: WaypointPath([(0, 0, 0), (1, 0, 0)], 0.0), "path.corner_radius: must be > 0"),
    (
        lambda: WaypointPath([(0, 0, 0), (10, 0, 0), (10, 1.1, 0), (20, 1.1, 0)], 1.6),
        "path.corner_radius: corner at waypoint 1 does not fit (needs 3.2 m, segment 1-2 has 1.1 m)",
    ),
    (lambda: UserPath(3.0, np.zeros(3)), "path.function: expected a callable"),
    (lambda: PATHS["line"].sample((1.0, 1.0)), "s_range: need finite s_min < s_max"),
    (lambda: PATHS["line"].sample(5.0, 1), "n: need at least 2 points"),
    (lambda: PATHS["line"].closest([0.0, 1.0]), "position: expected 3 numbers"),
    (lambda: UserPath(helix_point, np.zeros((2, 2))), "path.params: expected a 1-D array"),
]


@pytest.mark.parametrize(("build", "message"), BAD_CLASSES)
def test_degenerate_paths_raise_one_line_errors(build, message):
    with pytest.raises(ValueError) as error:
        build()
    assert str(error.value).startswith(message) and "\n" not in str(error.value)


BAD_TABLES = [
    ([1, 2], "path: expected a table"),
    ({"point": [0, 0, 0]}, "path.type: missing"),
    ({"type": "spiral"}, "path.type: unknown path type 'spiral'"),
    ({"type": "line", "point": [0, 0, 0]}, "path.line.direction: missing"),
    (
        {"type": "line", "point": [0, 0, 0], "direction": [1, 0, 0], "speed": 1},
        "path.line.speed: unknown key",
    ),
    (
        {"type": "line", "point": [0, 0, 0], "direction": "x"},
        "path.line.direction: expected numbers",
    ),
    (
        {"type": "line", "point": [0, "0", 0], "direction": [1, 0, 0]},
        "path.line.point: expected 3 numbers",
    ),
    (
        {"type": "line", "point": [0, 0, 0], "direction": [0, 0, 0]},
        "path.line.direction: zero vector",
    ),
    (
        {"type": "helix", "centre": [0, 0, 0], "axis": [0, 0, 1], "radius": 0, "pitch": 1},
        "path.helix.radius: must be > 0",
    ),
    (
        {"type": "helix", "centre": [0, 0, 0], "axis": [0, 0, 1], "radius": True, "pitch": 1},
        "path.helix.radius: expected a number",
    ),
    (
        {"type": "helix", "centre": [0, 0, 0], "axis": [0, 0, 1], "radius": 1},
        "path.helix.pitch: missing",
    ),
    ({"type": "waypoints", "points": [[0, 0, 0]]}, "path.waypoints.points: need at least 2"),
    (
        {"type": "waypoints", "points": [[0, 0, 0], [1, 0]]},
        "path.waypoints.points[1]: expected 3 numbers",
    ),
    ({"type": "waypoints", "points": 5}, "path.waypoints.points: expected a list"),
]


@pytest.mark.parametrize(("table", "message"), BAD_TABLES)
def test_bad_scenario_tables_raise_one_line_errors_naming_the_key(table, message):
    with pytest.raises(ValueError) as error:
        from_mapping(table)
    assert str(error.value).startswith(message) and "\n" not in str(error.value)


def test_from_mapping_builds_each_type():
    line = from_mapping({"type": "line", "point": [0, 0, 0], "direction": [2, 0, 0]})
    assert line == LinePath((0, 0, 0), (1, 0, 0))
    helix = from_mapping(
        {"type": "helix", "centre": [0, 0, 0], "axis": [0, 0, 1], "radius": 10, "pitch": 10}
    )
    assert (helix.radius, helix.pitch, helix.start_angle) == (10.0, 10.0, 0.0)
    waypoints = from_mapping({"type": "waypoints", "points": WAYPOINTS, "corner_radius": 2.0})
    assert np.array_equal(waypoints.params, PATHS["waypoints"].params)
    assert from_mapping({"type": "waypoints", "points": WAYPOINTS}).corner_radius == 1.0


@pytest.mark.parametrize("name", PATHS)
def test_path_errors_of_many_positions_match_one_at_a_time(name, rng):
    """``aiauv_control.laws.paper_laws.path_errors_of_positions`` (one compiled call for a logged
    run) gives exactly
    what :meth:`Path.closest` and :meth:`Path.cross_track_error` give sample by sample."""
    from aiauv_control.laws.paper_laws import path_errors_of_positions

    path = PATHS[name]
    positions = path.points_at(s_grid(path, 40)) + rng.normal(scale=0.7, size=(40, 3))
    s, errors = np.empty(40), np.empty((40, 2))
    path_errors_of_positions(path.user_function, path.kind_code, path.params, positions, s, errors)
    for k, p in enumerate(positions):
        assert s[k] == path.closest(p).s
        np.testing.assert_array_equal(errors[k], path.cross_track_error(p))
