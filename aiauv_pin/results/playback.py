"""Self-contained HTML playback of a trajectory: one file that opens from disk with no network.

The page embeds meshcat's viewer bundle (``meshcat/viewer/dist/main.min.js``, as meshcat's own
``static_html`` does) and the scene of :class:`aiauv_pin.results.viewer.VehicleScene` as a list of meshcat
commands in JSON, replayed into ``MeshCat.Viewer.handle_command`` on load. The motion is one
meshcat animation (``set_animation``): per moving node, three.js keyframe tracks with ``times`` in
seconds (clip ``fps`` = 1, so a key's time is its simulated time) and flat ``values``; meshcat's
animation panel gives play / pause / reset, a time scrubber and the speed (``timeScale``, 1 = real
time). The camera frames the vehicle's own motion (:func:`camera_framing`): the box of every link
position over the run (and of the path, when one is followed) from a fixed camera, ``/aiauv``
shifted once so that the box's centre is at the page's origin, where the camera looks; a motion
too long for that (the vehicle would be a few pixels) is followed instead, ``/aiauv`` animated by
minus the vehicle's centroid (see :mod:`aiauv_pin.results.viewer` for why the world moves rather than the
camera).

Frames are decimated to ``fps`` per simulated second and to at most ``max_frames`` (by default as
many as fit a budget of about 16 MB of keyframes), so a 300 s run gives a file of about 7 MB.

A run in waves (``sea``, :class:`aiauv_hydro.waves.sea_state.Waves`) also draws the sea surface
(:func:`surface_commands`): :data:`SURFACE_STRIPS` translucent strips across the main wave
direction over the region of the motion, each heaving with the elevation at its centre, sampled
at :data:`SURFACE_FPS` (a long-crested picture: a short-crested sea's elevation varies along a
strip too, which the strips do not show).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aiauv_hydro.waves.kinematics import elevation_series
from aiauv_hydro.waves.sea_state import Waves
from aiauv_pin._internal.atomic import atomic_path
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.results.viewer import (
    CAMERA_DIRECTION,
    CAMERA_FOV,
    FRAME_INFO,
    LEGEND,
    LINKS,
    LOS,
    PATH,
    ROOT,
    TRAIL,
    TRAIL_COLOR,
    VehicleScene,
    line_object,
    set_object,
    set_property,
    set_transform,
    translation,
)
from aiauv_pin.simulation.fixed_step import Trajectory

#: Node of the sea surface, strips across the main wave direction, and their frame rate [1/s].
SURFACE = f"{ROOT}/surface"
SURFACE_STRIPS = 48
SURFACE_FPS = 5.0
#: Margin of the drawn surface around the motion [m], its colour (r, g, b, opacity).
SURFACE_MARGIN = 10.0
SURFACE_COLOR = (0.15, 0.45, 0.85, 0.3)

#: Default upper bound on the size of the keyframe data [bytes].
KEYFRAME_BUDGET = 16_000_000
_DIGITS = 4  # decimals kept in the page: 0.1 mm, 1e-4 in quaternions, 0.1 ms in times
_CHARS_PER_NUMBER = 9  # upper estimate of one number in the JSON, sign and comma included


def meshcat_bundle() -> str:
    """The JavaScript of meshcat's viewer (three.js included), as shipped by the meshcat package."""
    spec = importlib.util.find_spec("meshcat")  # located, not imported (that would start zmq)
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("the meshcat package is not installed")
    path = Path(spec.submodule_search_locations[0]) / "viewer" / "dist" / "main.min.js"
    return path.read_text(encoding="utf-8")


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def commands_json(commands: list[dict]) -> str:
    """``commands`` as compact JSON text (no spaces), refusing NaN and infinities.

    Written by orjson: the values of ``json.dumps(commands, separators=(",", ":"))``, every float
    the shortest text that reads back to it as there (tested; a small number may be written
    ``-0.0000913`` rather than ``-9.13e-05``), 22 ms instead of 163 ms for the paper run's
    6.5 MB. orjson writes a NaN as ``null``; text with a ``null`` is made again by ``json``,
    which raises ``ValueError`` for a NaN or an infinity as before; so is a value orjson does not
    write.
    """
    import orjson

    try:
        data = orjson.dumps(commands)
    except TypeError:  # a type orjson does not write (json may: a float subclass)
        data = b"null"
    if b"null" in data:  # a None, or a non-finite float that orjson wrote as null
        return json.dumps(commands, separators=(",", ":"), allow_nan=False)
    return data.decode("utf-8")


def html_page(
    commands: list[dict],
    *,
    title: str = "aiauv-pin playback",
    legend: list[tuple[str, str]] | None = None,
) -> str:
    """A self-contained page showing the meshcat scene the commands build.

    Args:
        commands: meshcat commands (``set_object``, ``set_transform``, ``set_property``,
            ``set_animation``), JSON-able dicts.
        title: Page title.
        legend: ``(CSS colour, text)`` rows of a legend in the lower left corner.
    """
    rows = "".join(
        f'<div><span style="display:inline-block;width:14px;height:4px;margin:0 6px 3px 0;'
        f"outline:1px solid #999;"
        f'background:{_escape(colour)}"></span>{_escape(text)}</div>'
        for colour, text in (legend or [])
    )
    legend_html = f'<div id="aiauv-legend">{rows}</div>' if rows else ""
    bundle = meshcat_bundle()
    if "</script" in bundle.lower():
        raise RuntimeError("meshcat's bundle contains '</script' and cannot be inlined")
    data = commands_json(commands).replace("</", "<\\/")
    safe_title = _escape(title)
    return f"""<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{safe_title}</title>
<style>
body {{ margin: 0; }}
#meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
#aiauv-legend {{ position: fixed; left: 8px; bottom: 8px; padding: 4px 8px; font: 12px sans-serif;
  color: #111; background: rgba(255, 255, 255, 0.8); border-radius: 4px; pointer-events: none; }}
</style>
</head>
<body>
<div id="meshcat-pane"></div>
{legend_html}
<script>
{bundle}
</script>
<script type="application/json" id="aiauv-scene">{data}</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
var commands = JSON.parse(document.getElementById("aiauv-scene").textContent);
for (var i = 0; i < commands.length; i++) {{
  viewer.handle_command(commands[i]);
}}
if (viewer.gui && commands.some(function (c) {{ return c.type === "set_animation"; }})) {{
  viewer.gui.open();  // show the Animations panel: play, pause, reset, time, speed
  var folders = viewer.gui.__folders || {{}};
  if (folders.Scene) {{ folders.Scene.close(); }}
}}
</script>
</body>
</html>
"""


def frame_indices(t: np.ndarray, fps: float, max_frames: int | None = None) -> np.ndarray:
    """Indices of the logged samples shown: about ``fps`` per simulated second, first and last kept.

    Args:
        t: Logged times [s], increasing.
        fps: Frames per simulated second [1/s].
        max_frames: Upper bound on the number of frames (>= 2).
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size == 0:
        raise ValueError("trajectory has no logged sample")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    if max_frames is not None and int(max_frames) < 2:
        raise ValueError(f"max_frames must be at least 2, got {max_frames!r}")
    if t.size == 1:
        return np.zeros(1, dtype=int)
    if not np.all(np.diff(t) > 0):
        raise ValueError("trajectory times must be increasing")
    # the first sample at or after each tick of a 1/fps clock, and the last sample
    ticks = t[0] + np.arange(0.0, t[-1] - t[0], 1.0 / fps)
    index = np.unique(np.append(np.searchsorted(t, ticks - 1e-9 / fps), t.size - 1))
    if max_frames is not None and index.size > max_frames:
        keep = np.unique(np.round(np.linspace(0, index.size - 1, int(max_frames))).astype(int))
        index = index[keep]
    return index


def _distances_to_path(points: np.ndarray, path: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Distance from each point (F, 3) to a polyline (N, 3), (F,) [m]: to its closest point."""
    points = np.asarray(points, dtype=float)
    a, b = path[:-1], path[1:]
    ab = b - a
    lengths = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    distances = np.empty(len(points))
    for start in range(0, len(points), chunk):  # (chunk, N, 3) temporaries at most
        point = points[start : start + chunk]
        s = np.clip(np.einsum("fij,ij->fi", point[:, None, :] - a, ab) / lengths, 0.0, 1.0)
        # |a + s ab - point| per axis, summed in norm's order; sqrt after the min (monotonic)
        squares = [(a[:, k] + s * ab[:, k] - point[:, k, None]) ** 2 for k in range(3)]
        distances[start : start + chunk] = np.sqrt(
            np.min((squares[0] + squares[1]) + squares[2], axis=1)
        )
    return distances


def _distance_to_path(point: np.ndarray, path: np.ndarray) -> float:
    """Distance from a point (3,) to a polyline (N, 3) [m]."""
    return float(_distances_to_path(np.asarray(point, dtype=float)[None], path)[0])


#: The playback frames the whole motion from a fixed camera unless that camera would stand more
#: than this many times as far as one that fits the vehicle alone (the vehicle would fill less than
#: two thirds of what it fills on its own: an arm that sways or drifts a little is seen whole from
#: a fixed place, a vehicle that swims away is followed).
FOLLOW_BEYOND = 1.5
#: Margin around the link origins in a frame, as a fraction of the vehicle's size (their shapes
#: reach beyond their origins) [-].
FRAME_PADDING = 0.1
#: Width over height of the view the camera is placed for: a landscape window (a narrower one cuts
#: the sides off; meshcat's controls zoom out).
VIEW_ASPECT = 4.0 / 3.0


@dataclass(frozen=True)
class CameraFraming:
    """How a playback frames the vehicle's motion (:func:`camera_framing`).

    Attributes:
        follow: ``/aiauv`` moves by minus the vehicle's centroid, so that the vehicle stays at the
            page's origin, where the camera looks; else it is shifted by minus :attr:`centre` once.
        centre: Centre of the box of the whole motion, the world point at the page's origin when
            not following (3,) [m].
        distance: Distance of the camera from the page's origin [m].
    """

    follow: bool
    centre: np.ndarray
    distance: float


def _camera_axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors towards the camera, to the right and up of its view (world frame)."""
    back = np.array(CAMERA_DIRECTION) / np.linalg.norm(CAMERA_DIRECTION)
    right = np.cross(-back, [0.0, 0.0, 1.0])  # three.js cameras keep world up (z here) upright
    right /= np.linalg.norm(right)
    return back, right, np.cross(right, -back)


def fitting_distance(points: np.ndarray, pad: float = 0.0) -> float:
    """Distance [m] from the looked-at point at which meshcat's camera, looking from
    :data:`aiauv_pin.results.viewer.CAMERA_DIRECTION`, sees every point (N, 3) [m] (relative to the
    looked-at point) grown by ``pad`` [m] inside its view (:data:`aiauv_pin.results.viewer.CAMERA_FOV`
    vertically, :data:`VIEW_ASPECT`), with a 10 % margin.

    A point at depth ``b`` towards the camera, ``x`` to the right and ``y`` up is in view from a
    distance ``D`` when ``|y| <= tan(fov / 2) (D - b)`` and ``|x| <= aspect tan(fov / 2) (D - b)``.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    back, right, up = _camera_axes()
    half = math.tan(math.radians(CAMERA_FOV) / 2.0)
    depth = points @ back + pad
    vertical = (np.abs(points @ up) + pad) / half
    horizontal = (np.abs(points @ right) + pad) / (VIEW_ASPECT * half)
    return 1.1 * float(np.max(depth + np.maximum(vertical, horizontal)))


def camera_framing(
    points: np.ndarray,
    centroids: np.ndarray,
    vehicle_size: float,
    path_points: np.ndarray | None = None,
) -> CameraFraming:
    """Frame the vehicle's own motion: every link position over the run, and the path when one is
    followed, seen whole from a fixed camera that looks at the centre of their box
    (:func:`fitting_distance`), unless that camera would stand more than :data:`FOLLOW_BEYOND`
    times as far as one fitting the vehicle alone (a vehicle that swims away would shrink to a few
    pixels); then the camera follows the vehicle, fitting it and the path's distance from it.

    Args:
        points: World positions of the links (and the end-effector) in each frame (F, L, 3) [m].
        centroids: The vehicle's centroid in each frame (F, 3) [m].
        vehicle_size: The vehicle's size (:attr:`aiauv_pin.results.viewer.VehicleScene.size`) [m]; every
            position is grown by :data:`FRAME_PADDING` of it.
        path_points: The path drawn, world points (N, 3) [m], or ``None``.
    """
    points = np.asarray(points, dtype=float).reshape(len(centroids), -1, 3)
    pad = FRAME_PADDING * vehicle_size
    shown = points.reshape(-1, 3)
    if path_points is not None:
        shown = np.concatenate((shown, np.asarray(path_points, dtype=float)))
    centre = 0.5 * (shown.min(axis=0) + shown.max(axis=0))
    whole = fitting_distance(shown - centre, pad)
    first = points[0]
    alone = fitting_distance(first - 0.5 * (first.min(axis=0) + first.max(axis=0)), pad)
    if whole <= FOLLOW_BEYOND * alone:
        return CameraFraming(False, centre, whole)
    # following: the vehicle around its centroid, and the path from wherever the vehicle is (a
    # sphere of that radius fits the vertical view from radius / sin(fov / 2))
    distance = fitting_distance(points - centroids[:, None, :], pad)
    if path_points is not None:
        offset = float(np.max(_distances_to_path(centroids, path_points)))
        distance = max(distance, 1.1 * offset / math.sin(math.radians(CAMERA_FOV) / 2.0))
    return CameraFraming(True, centre, distance)


def rotation_quaternions(rotations: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(x, y, z, w)`` of rotation matrices (..., 3, 3) -> (..., 4).

    Shepperd's method as Eigen writes it (``Quaternion(const Matrix3&)``: from the trace when it
    is positive, else from the largest diagonal entry), with the same operations in the same
    order, so that it returns the bits of ``pin.Quaternion(R).coeffs()``, for many matrices at once.
    """
    rotations = np.asarray(rotations, dtype=float)
    m = rotations.reshape(-1, 3, 3)
    out = np.empty((len(m), 4))
    trace = m[:, 0, 0] + (m[:, 1, 1] + m[:, 2, 2])
    positive = trace > 0.0
    root = np.sqrt(trace[positive] + 1.0)
    half_inverse = 0.5 / root
    mp = m[positive]
    out[positive, 0] = (mp[:, 2, 1] - mp[:, 1, 2]) * half_inverse
    out[positive, 1] = (mp[:, 0, 2] - mp[:, 2, 0]) * half_inverse
    out[positive, 2] = (mp[:, 1, 0] - mp[:, 0, 1]) * half_inverse
    out[positive, 3] = 0.5 * root
    for n in np.flatnonzero(~positive):  # rare on a smooth motion
        r = m[n]
        i = 0
        if r[1, 1] > r[0, 0]:
            i = 1
        if r[2, 2] > r[i, i]:
            i = 2
        j, k = (i + 1) % 3, (i + 2) % 3
        root_i = math.sqrt(r[i, i] - r[j, j] - r[k, k] + 1.0)
        half_inverse_i = 0.5 / root_i
        out[n, i] = 0.5 * root_i
        out[n, 3] = (r[k, j] - r[j, k]) * half_inverse_i
        out[n, j] = (r[j, i] + r[i, j]) * half_inverse_i
        out[n, k] = (r[k, i] + r[i, k]) * half_inverse_i
    return out.reshape((*rotations.shape[:-2], 4))


def same_hemisphere(quaternions: np.ndarray) -> np.ndarray:
    """Quaternions (F, 4) with signs flipped so that each is on the same side as the one before
    (non-negative dot product), the first kept: keys that interpolate along the short arc."""
    quaternions = np.array(quaternions, dtype=float)
    dots = np.einsum("ij,ij->i", quaternions[1:], quaternions[:-1])
    sign = 1.0
    signs = np.ones(len(quaternions))
    for k, dot in enumerate(dots.tolist(), start=1):
        # against the previous key as flipped: its dot product is sign * dot
        sign = -1.0 if sign * dot < 0.0 else 1.0
        signs[k] = sign
    return quaternions * signs[:, None]


def legend_entries(commands: list[dict]) -> list[tuple[str, str]]:
    """``(CSS colour, text)`` of what a playback's commands draw besides the vehicle."""
    paths = {c.get("path", "") for c in commands if c["type"] == "set_object"}
    shown = []
    if any("/thrusters/" in p for p in paths):
        shown.append("thrust")
    if any(
        c["type"] == "set_property" and c["path"] == LOS and c["value"] is True for c in commands
    ):
        shown.append("los")
    if TRAIL in paths:
        shown.append("trail")
    if PATH in paths:
        shown.append("path")
    return [LEGEND[key] for key in shown]


def _round(values: np.ndarray) -> list[float]:
    rounded = np.round(np.asarray(values, dtype=float), _DIGITS).ravel()
    rounded[rounded == 0.0] = 0.0  # no "-0.0"
    return rounded.tolist()


def _strip_object(width: float, length: float) -> dict:
    """A translucent box ``width`` (x) by ``length`` (y) by 2 cm, three.js ``Object`` JSON."""
    r, g, b, a = SURFACE_COLOR
    geometry = {"uuid": f"surface-{width:.4f}-{length:.4f}", "type": "BoxGeometry"}
    geometry.update(width=width, height=length, depth=0.02)
    material = {
        "uuid": "surface-material",
        "type": "MeshLambertMaterial",
        "color": (int(r * 255) << 16) + (int(g * 255) << 8) + int(b * 255),
        "opacity": a,
        "transparent": True,
        "depthWrite": False,
    }
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [geometry],
        "materials": [material],
        "object": {
            "uuid": f"surface-{width:.4f}-{length:.4f}-mesh",
            "type": "Mesh",
            "geometry": geometry["uuid"],
            "material": material["uuid"],
        },
    }


def surface_commands(
    sea: Waves, low: np.ndarray, high: np.ndarray, t0: float, t1: float
) -> tuple[list[dict], list[dict]]:
    """The sea surface over the box ``[low, high]`` (world x, y) [m] from ``t0`` to ``t1`` [s]:
    the ``set_object`` / ``set_transform`` commands of :data:`SURFACE_STRIPS` strips across the main
    wave direction and their animations (position tracks at :data:`SURFACE_FPS`, times from
    ``t0``), each strip at ``surface_z + eta(t, centre)``."""
    heading = sea.heading
    along = np.array([math.cos(heading), math.sin(heading)])
    across = np.array([-along[1], along[0]])
    corners = np.array([[x, y] for x in (low[0], high[0]) for y in (low[1], high[1])])
    centre = 0.5 * (low[:2] + high[:2])
    s = (corners - centre) @ along
    r = (corners - centre) @ across
    s0, s1 = s.min() - SURFACE_MARGIN, s.max() + SURFACE_MARGIN
    r0, r1 = r.min() - SURFACE_MARGIN, r.max() + SURFACE_MARGIN
    width = (s1 - s0) / SURFACE_STRIPS
    mid_r = 0.5 * (r0 + r1)
    times = np.arange(t0, t1 + 0.5 / SURFACE_FPS, 1.0 / SURFACE_FPS)
    parameters = sea.parameters()
    rotation = np.eye(4)
    rotation[:2, :2] = [[along[0], across[0]], [along[1], across[1]]]
    commands, animations = [], []
    eta = np.empty_like(times)
    strip = _strip_object(float(width), float(r1 - r0))
    for i in range(SURFACE_STRIPS):
        xy = centre + (s0 + (i + 0.5) * width) * along + mid_r * across
        elevation_series(times, float(xy[0]), float(xy[1]), parameters, eta)
        path = f"{SURFACE}/{i}"
        positions = np.column_stack(
            (np.full_like(times, xy[0]), np.full_like(times, xy[1]), sea.surface_z + eta)
        )
        matrix = rotation.copy()
        matrix[:3, 3] = positions[0]
        commands.extend((set_object(path, strip), set_transform(path, matrix)))
        track = {
            "name": ".position",
            "type": "vector3",
            "times": _round(times - t0),
            "values": _round(positions),
        }
        animations.append({"path": path, "clip": {"fps": 1, "name": "default", "tracks": [track]}})
    return commands, animations


def _info_at(info: dict[str, np.ndarray], k: int) -> dict[str, np.ndarray]:
    return {key: value[k] for key, value in info.items() if key in FRAME_INFO}


def playback_commands(
    vehicle: Vehicle,
    trajectory: Trajectory,
    *,
    fps: float = 25.0,
    max_frames: int | None = None,
    urdf: str | os.PathLike | None = None,
    path_points: np.ndarray | None = None,
    sea: Waves | None = None,
) -> list[dict]:
    """The meshcat commands of a playback: the scene, the first frame, and the animation.

    Besides the vehicle: the thruster arrows, the LOS arrow, the path
    (:func:`aiauv_pin.results.viewer.path_segments` of ``path_points``), the end-effector trail over the
    whole run (:data:`aiauv_pin.results.viewer.TRAIL`) and a camera that frames the vehicle's motion and
    the path (:func:`camera_framing`).

    Args:
        vehicle: The simulated vehicle.
        trajectory: The trajectory (``t``, ``q``; ``info`` may hold ``thrust``, ``x_ref``, ``p``).
        fps: Frames per simulated second [1/s].
        max_frames: Upper bound on the number of frames; default from :data:`KEYFRAME_BUDGET`.
        urdf: URDF with the visuals (see :func:`aiauv_pin.results.viewer.vehicle_visuals`).
        path_points: The path drawn, world points in order (N, 3) [m]; ``None`` draws no path (a
            run that follows none), the grid then lies under the box of the motion.
        sea: The waves of the run, whose surface is drawn (:func:`surface_commands`); ``None``:
            no surface.

    Raises:
        ValueError: A malformed trajectory (one line).
    """
    t = np.asarray(trajectory.t, dtype=float)
    q = np.asarray(trajectory.q, dtype=float)
    if q.ndim != 2 or q.shape[1] != vehicle.nq or q.shape[0] != t.size:
        raise ValueError(f"trajectory.q must have shape ({t.size}, {vehicle.nq}), got {q.shape}")
    finite = np.all(np.isfinite(q), axis=1) & np.isfinite(t)
    if not np.all(finite):
        bad = int(np.flatnonzero(~finite)[0])
        raise ValueError(f"trajectory has a non-finite configuration at sample {bad}")
    info = {k: np.asarray(v, dtype=float) for k, v in (trajectory.info or {}).items()}
    for key in FRAME_INFO:
        if key in info and info[key].shape[0] != t.size:
            raise ValueError(
                f"trajectory.info['{key}'] has {info[key].shape[0]} rows, not {t.size}"
            )
    scene = VehicleScene(vehicle, urdf=urdf, path_points=path_points)
    show_los = scene.head_frame is not None and "x_ref" in info

    if max_frames is None:
        states = scene.frame(q[0], _info_at(info, 0))
        numbers = 8 * len(states.poses) + 4 * len(states.scales) + 4  # values and times per frame
        max_frames = max(2, KEYFRAME_BUDGET // (_CHARS_PER_NUMBER * numbers))
    index = frame_indices(t, fps, max_frames)

    states = scene.frames(q[index], {key: info[key][index] for key in FRAME_INFO if key in info})
    poses, scales, centroid = states.poses, states.scales, states.centroid
    if not show_los:
        poses.pop(LOS, None)
    times = _round(t[index] - t[0])
    links = [frames[:, :3, 3] for path, frames in poses.items() if path.startswith(LINKS)]
    points = np.stack([*links, states.trail], axis=1)  # (F, links + 1, 3)
    motion = points.reshape(-1, 3)
    framing = camera_framing(points, centroid, scene.size, path_points)
    scene.camera_distance = framing.distance
    if path_points is None:  # no path: the grid lies under the box of the motion
        scene.path_points = np.array([points.reshape(-1, 3).min(0), points.reshape(-1, 3).max(0)])

    commands = scene.static_commands()
    if path_points is None:
        commands = [c for c in commands if c.get("path") != PATH]
    if len(states.trail) >= 2:
        points = states.trail
        segments = np.stack((points[:-1], points[1:]), axis=1).reshape(-1, 3)
        commands.append(set_object(TRAIL, line_object(segments, TRAIL_COLOR)))
    # the first frame, so that the scene is right before the animation starts (and if it is paused)
    for path, frames in poses.items():
        commands.append(set_transform(path, frames[0]))
    for path, frames in scales.items():
        commands.append(set_transform(path, np.diag([*frames[0], 1.0])))
    shift = -centroid if framing.follow else np.tile(-framing.centre, (len(centroid), 1))
    commands.append(set_transform(ROOT, translation(shift[0])))
    if show_los:
        commands.append(set_property(LOS, "visible", True))
    surface_animations = []
    if sea is not None:
        surface, surface_animations = surface_commands(
            sea, motion.min(0), motion.max(0), float(t[0]), float(t[-1])
        )
        commands.extend(surface)

    def clip(tracks: list[dict]) -> dict:
        return {"fps": 1, "name": "default", "tracks": tracks}

    def track(name: str, kind: str, values) -> dict:
        return {"name": f".{name}", "type": kind, "times": times, "values": _round(values)}

    animations = []
    for path, matrices in poses.items():
        quaternions = same_hemisphere(rotation_quaternions(matrices[:, :3, :3]))  # x y z w
        tracks = [
            track("position", "vector3", matrices[:, :3, 3]),
            track("quaternion", "quaternion", quaternions),
        ]
        animations.append({"path": path, "clip": clip(tracks)})
    for path, frames in scales.items():
        animations.append({"path": path, "clip": clip([track("scale", "vector3", frames)])})
    if framing.follow:
        animations.append({"path": ROOT, "clip": clip([track("position", "vector3", shift)])})
    animations.extend(surface_animations)
    commands.append(
        {
            "type": "set_animation",
            "path": "",
            "animations": animations,
            "options": {"play": True, "repetitions": 1},
        }
    )
    return commands


def write_playback(
    vehicle: Vehicle,
    trajectory: Trajectory,
    path: str | os.PathLike,
    *,
    max_frames: int | None = None,
    fps: float = 25.0,
    urdf: str | os.PathLike | None = None,
    path_points: np.ndarray | None = None,
    sea: Waves | None = None,
) -> Path:
    """Write a self-contained ``playback.html`` of a trajectory, animated at real-time speed.

    The page needs no network: it carries meshcat's viewer and the whole animation. Open it with any
    browser; the animation starts on load, and meshcat's *Animations* panel pauses, resumes, scrubs
    and changes the speed. The file is written atomically (temporary file + rename).

    Args:
        vehicle: The simulated vehicle.
        trajectory: Its trajectory.
        path: Output file.
        max_frames: Upper bound on the number of frames; default keeps the file under about 20 MB.
        fps: Frames per simulated second [1/s].
        urdf: URDF with the visuals (see :func:`aiauv_pin.results.viewer.vehicle_visuals`).
        path_points: The path drawn (N, 3) [m]; ``None`` draws none.
        sea: The waves of the run, whose surface is drawn; ``None``: none.

    Returns:
        The path written.
    """
    commands = playback_commands(
        vehicle,
        trajectory,
        fps=fps,
        max_frames=max_frames,
        urdf=urdf,
        path_points=path_points,
        sea=sea,
    )
    page = html_page(
        commands,
        title=f"{vehicle.name}: {float(trajectory.t[-1]):g} s",
        legend=legend_entries(commands),
    )
    with atomic_path(path) as temporary:
        temporary.write_text(page, encoding="utf-8")
    return Path(path)


def read_commands(page: str) -> list[dict]:
    """The meshcat commands embedded in a page written by :func:`html_page`."""
    start_tag = '<script type="application/json" id="aiauv-scene">'
    start = page.index(start_tag) + len(start_tag)
    end = page.index("</script>", start)
    return json.loads(page[start:end].replace("<\\/", "</"))
