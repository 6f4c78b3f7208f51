"""The meshcat scene of a vehicle, and a live meshcat viewer.

The scene is described once, as meshcat commands (plain JSON-able dicts in the form meshcat's
viewer ``handle_command`` takes), so that the live viewer (:class:`MeshcatViewer`, over meshcat's
ZeroMQ server) and the self-contained playback page (:mod:`aiauv_pin.playback`) draw the same thing:

- ``/aiauv/links/<link>``: one node per URDF link that has visual geometry, placed at the link's
  world pose; its children are the link's visuals (cylinders, boxes, spheres, capsules, meshes),
  read from the URDF's ``<visual>`` elements with Pinocchio, in the colours the URDF gives;
- ``/aiauv/links/<link>/thrusters/<name>/arrow``: the thruster's force, an arrow along the
  thruster's positive direction, its length proportional to the thrust (backwards when negative);
- ``/aiauv/los``: the line-of-sight reference direction ``x_ref`` at the end effector, when the
  controller reports one (``info["x_ref"]``, ``info["p"]``);
- ``/aiauv/path``: the path, the world x-axis, with a tick every metre, over a grid of 1 m squares
  1 m below it (meshcat's own grid and axes, fixed at the page's origin, are hidden);
- ``/aiauv`` itself is translated by minus the vehicle's centroid, so that the vehicle stays in view
  around the page's origin while the path and grid slide past.

Why the world moves rather than the camera: meshcat's camera sits in ``/Cameras/default/rotated``,
and in the bundled three.js the orbit controls make the camera look at their target in *world*
coordinates every frame, while they orbit in the camera's *parent* coordinates: translating
``/Cameras/default`` therefore turns the camera back towards the page's origin. Keeping the camera's
parent fixed and moving ``/aiauv`` gives a following view that orbits and zooms as usual.

meshcat's conventions: three.js cylinders and cones have their axis along ``y``; quaternions are
``(x, y, z, w)``; the camera lives in a frame rotated by +90 degrees about ``x`` (three.js is y-up).
"""

from __future__ import annotations

import itertools
import math
import os
import time
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from .vehicle import Vehicle

#: Root of everything this module draws.
ROOT = "/aiauv"
LINKS = f"{ROOT}/links"
LOS = f"{ROOT}/los"
PATH = f"{ROOT}/path"
CAMERA_OBJECT = "/Cameras/default/rotated/<object>"

_THRUST_COLOR = (0.85, 0.1, 0.1, 1.0)
_LOS_COLOR = (0.1, 0.75, 0.2, 1.0)
_PATH_COLOR = (1.0, 1.0, 1.0, 1.0)
_GRID_COLOR = (0.55, 0.6, 0.7, 1.0)
GRID = f"{ROOT}/grid"
_DOUBLE_SIDE = 2  # THREE.DoubleSide: arrows are mirrored (negative scale) for negative thrust

# three.js cylinders/cones lie along y, URDF cylinders along z: rotate y onto z (+90 deg about x)
_Y_TO_Z = pin.SE3(pin.utils.rotate("x", math.pi / 2), np.zeros(3))


@dataclass(frozen=True)
class Visual:
    """One visual shape of a link.

    Attributes:
        link: Name of the URDF link (a Pinocchio BODY frame) it is attached to.
        placement: Pose of the shape in the link frame (4x4), in three.js's convention for the shape
            (cylinder axis along y).
        geometry: three.js geometry JSON (without ``uuid``).
        color: ``(r, g, b, a)`` in [0, 1].
    """

    link: str
    placement: np.ndarray
    geometry: dict
    color: tuple[float, float, float, float]


def _rgba(color) -> tuple[float, float, float, float]:
    values = [float(c) for c in np.asarray(color, dtype=float).ravel()[:4]]
    if len(values) != 4 or not all(math.isfinite(c) for c in values):
        return (0.7, 0.7, 0.7, 1.0)
    return tuple(min(1.0, max(0.0, c)) for c in values)  # type: ignore[return-value]


def _shift_y(offset: float) -> pin.SE3:
    return pin.SE3(np.eye(3), np.array([0.0, offset, 0.0]))


def _shape_geometry(shape) -> list[tuple[dict, pin.SE3]]:
    """three.js geometries of a coal shape, each with its pose in the shape's frame."""
    kind = type(shape).__name__
    if kind in ("Cylinder", "Capsule"):
        radius, half = float(shape.radius), float(shape.halfLength)
        parts = [
            (
                {
                    "type": "CylinderGeometry",
                    "radiusTop": radius,
                    "radiusBottom": radius,
                    "height": 2.0 * half,
                    "radialSegments": 32,
                },
                _Y_TO_Z,
            )
        ]
        if kind == "Capsule":  # this three.js has no CapsuleGeometry: cylinder + two half-spheres
            ball = {
                "type": "SphereGeometry",
                "radius": radius,
                "widthSegments": 32,
                "heightSegments": 16,
            }
            parts += [(ball, _Y_TO_Z * _shift_y(half)), (ball, _Y_TO_Z * _shift_y(-half))]
        return parts
    if kind == "Box":
        x, y, z = (2.0 * float(h) for h in shape.halfSide)
        return [({"type": "BoxGeometry", "width": x, "height": y, "depth": z}, pin.SE3.Identity())]
    if kind == "Sphere":
        geometry = {
            "type": "SphereGeometry",
            "radius": float(shape.radius),
            "widthSegments": 32,
            "heightSegments": 16,
        }
        return [(geometry, pin.SE3.Identity())]
    if hasattr(shape, "num_vertices") and hasattr(shape, "num_tris"):
        # a mesh (BVH model; Pinocchio applied the URDF's scale when loading it)
        vertices = np.array([shape.vertices(i) for i in range(shape.num_vertices)], dtype=float)
        triangles = []
        for i in range(shape.num_tris):
            tri = shape.tri_indices(i)
            triangles.extend(int(tri[k]) for k in range(3))
        geometry = {
            "type": "BufferGeometry",
            "data": {
                "attributes": {
                    "position": {
                        "itemSize": 3,
                        "type": "Float32Array",
                        "array": np.round(vertices, 5).ravel().tolist(),
                        "normalized": False,
                    }
                },
                "index": {"type": "Uint32Array", "array": triangles},
            },
        }
        return [(geometry, pin.SE3.Identity())]
    raise ValueError(f"cannot draw a visual of type {kind}")


def vehicle_visuals(vehicle: Vehicle, urdf: str | os.PathLike | None = None) -> list[Visual]:
    """The visual shapes of a vehicle's links, from its URDF's ``<visual>`` elements.

    Args:
        vehicle: The vehicle.
        urdf: URDF file or XML text. Default: ``vehicle.visual_model`` (a ``pin.GeometryModel``) if
            the vehicle has one, else the URDF it was loaded from (``vehicle.urdf_path``), else
            cylinders from the links' crossflow hydrodynamics.

    Raises:
        ValueError: Nothing to draw, or a shape meshcat cannot show (one line).
    """
    model = vehicle.model
    geometry_model = None
    if urdf is None:
        geometry_model = getattr(vehicle, "visual_model", None)
        if geometry_model is None and getattr(vehicle, "urdf_path", None) is not None:
            urdf = vehicle.urdf_path
    if geometry_model is None and urdf is not None:
        visual = pin.GeometryType.VISUAL
        try:
            if "<robot" in str(urdf):
                geometry_model = pin.buildGeomFromUrdfString(model, str(urdf), visual)
            else:
                source = Path(urdf)
                # meshes are looked up beside the URDF
                geometry_model = pin.buildGeomFromUrdf(
                    model, str(source), visual, package_dirs=[str(source.parent)]
                )
        except (RuntimeError, ValueError, OSError) as exc:
            reason = " ".join(str(exc).split())
            raise ValueError(f"cannot read the visuals of the URDF ({reason})") from None
    visuals: list[Visual] = []
    if geometry_model is not None:
        for obj in geometry_model.geometryObjects:
            frame = model.frames[obj.parentFrame]  # the link's BODY frame
            in_link = frame.placement.actInv(obj.placement)
            for geometry, in_shape in _shape_geometry(obj.geometry):
                placement = (in_link * in_shape).homogeneous
                visuals.append(Visual(frame.name, placement, geometry, _rgba(obj.meshColor)))
    else:
        for link in vehicle.hydro.links:
            if link.crossflow is None:
                continue
            c = link.crossflow
            # crossflow frame c: x-axis on the cylinder axis, origin at the rear end
            along_x = pin.SE3(np.asarray(c.rotation), np.asarray(c.translation)) * pin.SE3(
                pin.utils.rotate("z", -math.pi / 2), np.array([c.length / 2.0, 0.0, 0.0])
            )
            geometry = {
                "type": "CylinderGeometry",
                "radiusTop": float(c.radius),
                "radiusBottom": float(c.radius),
                "height": float(c.length),
                "radialSegments": 32,
            }
            visuals.append(Visual(link.link, along_x.homogeneous, geometry, (1.0, 0.72, 0.1, 1.0)))
    if not visuals:
        raise ValueError(f"vehicle '{vehicle.name}' has no visual geometry to draw")
    return visuals


def _uuid() -> str:
    return str(uuid.uuid4())


def _mesh_object(geometry: dict, color, *, double_side: bool = False) -> dict:
    """A three.js ``Object`` JSON of one mesh with a Lambert material."""
    g = dict(geometry, uuid=_uuid())
    r, gr, b, a = color
    material = {
        "uuid": _uuid(),
        "type": "MeshLambertMaterial",
        "color": (int(r * 255) << 16) + (int(gr * 255) << 8) + int(b * 255),
        "opacity": a,
        "transparent": a < 1.0,
        "reflectivity": 0.5,
    }
    if double_side:
        material["side"] = _DOUBLE_SIDE
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [g],
        "materials": [material],
        "object": {
            "uuid": _uuid(),
            "type": "Mesh",
            "geometry": g["uuid"],
            "material": material["uuid"],
        },
    }


def _line_object(points: np.ndarray, color) -> dict:
    """A three.js ``LineSegments`` JSON (pairs of points)."""
    g = {
        "uuid": _uuid(),
        "type": "BufferGeometry",
        "data": {
            "attributes": {
                "position": {
                    "itemSize": 3,
                    "type": "Float32Array",
                    "array": np.round(points, 4).ravel().tolist(),
                    "normalized": False,
                }
            }
        },
    }
    r, gr, b, _ = color
    material = {
        "uuid": _uuid(),
        "type": "LineBasicMaterial",
        "color": (int(r * 255) << 16) + (int(gr * 255) << 8) + int(b * 255),
    }
    return {
        "metadata": {"version": 4.5, "type": "Object"},
        "geometries": [g],
        "materials": [material],
        "object": {
            "uuid": _uuid(),
            "type": "LineSegments",
            "geometry": g["uuid"],
            "material": material["uuid"],
        },
    }


def set_object(path: str, obj: dict) -> dict:
    """meshcat ``set_object`` command."""
    return {"type": "set_object", "path": path, "object": obj}


def set_transform(path: str, matrix: np.ndarray) -> dict:
    """meshcat ``set_transform`` command (matrix sent column-major, as three.js reads it)."""
    return {
        "type": "set_transform",
        "path": path,
        "matrix": [float(x) for x in np.asarray(matrix, dtype=float).T.ravel()],
    }


def set_property(path: str, key: str, value) -> dict:
    """meshcat ``set_property`` command."""
    return {"type": "set_property", "path": path, "property": key, "value": value}


def translation(offset: np.ndarray) -> np.ndarray:
    """Homogeneous matrix of a translation (4x4)."""
    matrix = np.eye(4)
    matrix[:3, 3] = offset
    return matrix


def _rotation_y_to(direction: np.ndarray) -> np.ndarray:
    """A rotation taking the y-axis onto a unit ``direction``."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 1.0, 0.0]), d).matrix()


def _arrow_commands(path: str, color, *, shaft_radius: float, head_fraction: float) -> list[dict]:
    """A unit-length arrow along +y at ``path`` (shaft and cone head), to be scaled along y."""
    shaft_length = 1.0 - head_fraction
    shaft = {
        "type": "CylinderGeometry",
        "radiusTop": shaft_radius,
        "radiusBottom": shaft_radius,
        "height": shaft_length,
        "radialSegments": 12,
    }
    head = {
        "type": "ConeGeometry",
        "radius": 2.5 * shaft_radius,
        "height": head_fraction,
        "radialSegments": 16,
    }
    shift_shaft = np.eye(4)
    shift_shaft[1, 3] = shaft_length / 2.0
    shift_head = np.eye(4)
    shift_head[1, 3] = shaft_length + head_fraction / 2.0
    return [
        set_object(f"{path}/shaft", _mesh_object(shaft, color, double_side=True)),
        set_transform(f"{path}/shaft", shift_shaft),
        set_object(f"{path}/head", _mesh_object(head, color, double_side=True)),
        set_transform(f"{path}/head", shift_head),
    ]


def _thrust_scale(thrust: float, max_thrust: float, length: float) -> np.ndarray:
    # never exactly zero: a singular matrix has no inverse for the normal matrix
    fraction = thrust / max_thrust if max_thrust > 0 else 0.0
    s = float(np.clip(fraction, -1.0, 1.0)) * length
    if abs(s) < 1e-4:
        s = 1e-4
    return np.array([1.0, s, 1.0])


@dataclass
class FrameState:
    """What moves in one frame: node poses and node scales.

    Attributes:
        poses: Node path -> world (or parent-frame) pose (4x4).
        scales: Node path -> scale ``(sx, sy, sz)``.
        centroid: Centroid of the link visuals in the world [m]; ``/aiauv`` is moved by minus it.
    """

    poses: dict[str, np.ndarray] = field(default_factory=dict)
    scales: dict[str, np.ndarray] = field(default_factory=dict)
    centroid: np.ndarray = field(default_factory=lambda: np.zeros(3))


class VehicleScene:
    """The meshcat scene of a vehicle: what to draw once, and what moves with ``(q, info)``.

    Args:
        vehicle: The vehicle.
        urdf: URDF file or text with the visuals (see :func:`vehicle_visuals`).
        path_range: ``(x_start, x_end)`` of the path line drawn on the world x-axis [m].
        camera_distance: Distance of the camera from the vehicle's centroid [m]; default scales with
            the vehicle's size.
    """

    def __init__(
        self,
        vehicle: Vehicle,
        *,
        urdf: str | os.PathLike | None = None,
        path_range: tuple[float, float] = (-5.0, 100.0),
        camera_distance: float | None = None,
    ) -> None:
        self.vehicle = vehicle
        self.visuals = vehicle_visuals(vehicle, urdf)
        self.links = list(dict.fromkeys(v.link for v in self.visuals))
        self._link_frames = [vehicle.frame_id(name) for name in self.links]
        self._data = vehicle.model.createData()
        x0, x1 = (float(x) for x in path_range)
        if not (math.isfinite(x0) and math.isfinite(x1) and x1 > x0):
            raise ValueError(
                f"path_range must be two finite numbers, increasing, got {path_range!r}"
            )
        self.path_range = (x0, x1)
        self.size = self._vehicle_size()
        self.camera_distance = (
            float(camera_distance) if camera_distance is not None else 0.75 * self.size + 0.3
        )
        self.arrow_length = 0.15 * self.size  # length of a thruster arrow at full thrust [m]
        self.los_length = 0.2 * self.size
        self.head_frame = (
            vehicle.frame_id("end_effector") if vehicle.model.existFrame("end_effector") else None
        )

    # ------------------------------------------------------------------ geometry
    def _visual_centres(self, q: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(self.vehicle.model, self._data, q)
        link_pose = {
            name: self._data.oMf[i].homogeneous
            for name, i in zip(self.links, self._link_frames, strict=True)
        }
        return np.array([(link_pose[v.link] @ v.placement)[:3, 3] for v in self.visuals])

    def _vehicle_size(self) -> float:
        centres = self._visual_centres(self.vehicle.neutral_configuration())
        extent = float(np.linalg.norm(centres.max(axis=0) - centres.min(axis=0)))
        radius = 0.0
        for v in self.visuals:
            g = v.geometry
            radius = max(
                radius,
                float(g.get("radiusTop", g.get("radius", 0.0))),
                0.5 * float(g.get("height", 0.0)),
            )
        return max(extent + 2.0 * radius, 0.1)

    @property
    def thrusters(self):
        """Thrusters drawn (those mounted on links that have visuals)."""
        return [t for t in self.vehicle.hydro.thrusters if t.link in self.links]

    def thruster_path(self, name: str) -> str:
        """Node path of a thruster's arrow (its scale is the thrust)."""
        link = next(t.link for t in self.vehicle.hydro.thrusters if t.name == name)
        return f"{LINKS}/{link}/thrusters/{name}/arrow"

    def static_commands(self) -> list[dict]:
        """Commands that build the scene (objects, fixed transforms, camera offset)."""
        commands: list[dict] = []
        for k, v in enumerate(self.visuals):
            path = f"{LINKS}/{v.link}/visual_{k}"
            commands.append(set_object(path, _mesh_object(v.geometry, v.color)))
            commands.append(set_transform(path, v.placement))
        shaft = 0.006 * self.size
        for t in self.thrusters:
            base = f"{LINKS}/{t.link}/thrusters/{t.name}"
            placement = np.eye(4)
            placement[:3, :3] = _rotation_y_to(t.direction)
            placement[:3, 3] = t.position
            commands.append(set_transform(base, placement))
            commands += _arrow_commands(
                f"{base}/arrow", _THRUST_COLOR, shaft_radius=shaft, head_fraction=0.25
            )
            commands.append(set_transform(f"{base}/arrow", np.diag([1.0, 1e-4, 1.0, 1.0])))
        if self.head_frame is not None:
            commands += _arrow_commands(
                f"{LOS}/arrow", _LOS_COLOR, shaft_radius=0.008 * self.size, head_fraction=0.2
            )
            commands.append(
                set_transform(f"{LOS}/arrow", np.diag([1.0, self.los_length, 1.0, 1.0]))
            )
            commands.append(set_property(LOS, "visible", False))
        commands.append(set_object(PATH, _line_object(self._path_points(), _PATH_COLOR)))
        commands.append(set_object(GRID, _line_object(self._grid_points(), _GRID_COLOR)))
        commands.append(set_property("/Grid", "visible", False))
        commands.append(set_property("/Axes", "visible", False))
        # camera: behind, to the side and above the centroid; offset in the rotated (y-up) frame
        direction = np.array([-0.25, -1.0, 0.45])
        offset_world = self.camera_distance * direction / np.linalg.norm(direction)
        offset_rotated = [offset_world[0], offset_world[2], -offset_world[1]]
        commands.append(set_property(CAMERA_OBJECT, "position", [float(x) for x in offset_rotated]))
        return commands

    def _path_points(self) -> np.ndarray:
        """Line segments of the path (in pieces between ticks) and of its ticks."""
        x0, x1 = self.path_range
        step = 10.0 ** math.ceil(math.log10((x1 - x0) / 2000.0)) if x1 - x0 > 2000 else 1.0
        ticks = np.arange(math.ceil(x0 / step) * step, x1 + 1e-9, step)
        tick = 0.04 * max(self.size, 1.0)
        points = []
        for x in ticks:
            points += [[x, -tick, 0.0], [x, tick, 0.0], [x, 0.0, -tick], [x, 0.0, tick]]
        # short pieces: some WebGL rasterisers (SwiftShader) drop a long line whose ends project far
        # outside the view
        stops = np.unique(np.concatenate(([x0], ticks, [x1])))
        for a, b in itertools.pairwise(stops):
            points += [[a, 0.0, 0.0], [b, 0.0, 0.0]]
        return np.array(points, dtype=float)

    def _grid_points(self, half_width: float = 5.0, depth: float = 1.0) -> np.ndarray:
        """Line segments of a grid of 1 m squares (coarser on long paths), ``depth`` below the path.

        Every line is cut at each crossing (see :meth:`_path_points` on long lines).
        """
        x0, x1 = self.path_range
        step = max(1, math.ceil((x1 - x0) / 1000))
        xs = np.arange(math.floor(x0), math.ceil(x1) + 1, step, dtype=float)
        ys = np.arange(-half_width, half_width + 1e-9, 1.0)
        segments = [((a, y), (b, y)) for y in ys for a, b in itertools.pairwise(xs)] + [
            ((x, a), (x, b)) for x in xs for a, b in itertools.pairwise(ys)
        ]
        points = np.array(segments, dtype=float).reshape(-1, 2)
        return np.column_stack((points, np.full(len(points), -depth)))

    # ------------------------------------------------------------------ motion
    def frame(self, q: np.ndarray, info: Mapping[str, object] | None = None) -> FrameState:
        """Poses and scales of the moving nodes for a configuration and controller diagnostics.

        Args:
            q: Configuration (nq,).
            info: Optional ``thrust`` (n_thrusters,) [N], ``x_ref`` (3,) LOS direction in the world,
                ``p`` (3,) end-effector position [m] (default: the ``end_effector`` frame).
        """
        q = np.asarray(q, dtype=float)
        if q.shape != (self.vehicle.nq,) or not np.all(np.isfinite(q)):
            raise ValueError(f"q must be {self.vehicle.nq} finite numbers, got shape {q.shape}")
        info = info or {}
        model, data = self.vehicle.model, self._data
        pin.framesForwardKinematics(model, data, q)
        state = FrameState()
        for name, i in zip(self.links, self._link_frames, strict=True):
            state.poses[f"{LINKS}/{name}"] = data.oMf[i].homogeneous
        centres = np.array(
            [(state.poses[f"{LINKS}/{v.link}"] @ v.placement)[:3, 3] for v in self.visuals]
        )
        state.centroid = centres.mean(axis=0)
        thrust = info.get("thrust")
        names = self.vehicle.thruster_names
        if thrust is not None:
            thrust = np.asarray(thrust, dtype=float).ravel()
            if thrust.shape != (len(names),):
                raise ValueError(
                    f"info['thrust'] must have {len(names)} entries, got {thrust.size}"
                )
        for t in self.thrusters:
            value = 0.0 if thrust is None else float(thrust[names.index(t.name)])
            if not math.isfinite(value):
                value = 0.0
            state.scales[self.thruster_path(t.name)] = _thrust_scale(
                value, t.max_thrust, self.arrow_length
            )
        x_ref = info.get("x_ref")
        if self.head_frame is not None:
            head = info.get("p")
            head = (
                data.oMf[self.head_frame].translation if head is None else np.asarray(head, float)
            )
            pose = np.eye(4)
            pose[:3, 3] = head
            if x_ref is not None and np.all(np.isfinite(x_ref)) and np.linalg.norm(x_ref) > 0:
                pose[:3, :3] = _rotation_y_to(np.asarray(x_ref, dtype=float))
            state.poses[LOS] = pose
        return state

    def has_los(self, info: Mapping[str, object] | None) -> bool:
        """Whether the LOS arrow is shown for these diagnostics."""
        return self.head_frame is not None and info is not None and info.get("x_ref") is not None


class _Command:
    """A command dict with the ``lower()`` method meshcat's ``ViewerWindow.send`` calls."""

    __slots__ = ("data",)

    def __init__(self, data: dict) -> None:
        self.data = data

    def lower(self) -> dict:
        return self.data


class MeshcatViewer:
    """A live meshcat view of a vehicle (browser tab or notebook cell).

    Args:
        vehicle: The vehicle.
        urdf: URDF with the visuals (see :func:`vehicle_visuals`).
        visualizer: A ``meshcat.Visualizer``; default starts meshcat's server in a subprocess.
        zmq_url: Connect to a running meshcat server instead of starting one.
        path_range: ``(x_start, x_end)`` of the path line [m].
        follow: Keep the vehicle in view (by moving ``/aiauv`` by minus its centroid).

    Example (notebook)::

        viewer = MeshcatViewer(vehicle)
        viewer.jupyter_cell()          # last line of the cell
        viewer.display(q, {"thrust": thrust, "x_ref": x_ref})
    """

    def __init__(
        self,
        vehicle: Vehicle,
        *,
        urdf: str | os.PathLike | None = None,
        visualizer=None,
        zmq_url: str | None = None,
        path_range: tuple[float, float] = (-5.0, 500.0),
        follow: bool = True,
    ) -> None:
        self.scene = VehicleScene(vehicle, urdf=urdf, path_range=path_range)
        if visualizer is None:
            import meshcat

            visualizer = meshcat.Visualizer(zmq_url=zmq_url)
        self.visualizer = visualizer
        self.follow = bool(follow)
        self._los_visible = False
        self.send(set_property(ROOT, "visible", True))
        for command in self.scene.static_commands():
            self.send(command)
        self.display(vehicle.neutral_configuration())

    def send(self, command: dict) -> None:
        """Send one meshcat command dict to the viewer."""
        self.visualizer.window.send(_Command(command))

    def display(self, q: np.ndarray, info: Mapping[str, object] | None = None) -> None:
        """Show a configuration, with thruster forces and the LOS direction if ``info`` has them."""
        state = self.scene.frame(q, info)
        for path, pose in state.poses.items():
            self.send(set_transform(path, pose))
        for path, scale in state.scales.items():
            self.send(set_transform(path, np.diag([*scale, 1.0])))
        if self.scene.has_los(info) != self._los_visible:
            self._los_visible = not self._los_visible
            self.send(set_property(LOS, "visible", self._los_visible))
        if self.follow:
            self.send(set_transform(ROOT, translation(-state.centroid)))

    def url(self) -> str:
        """URL of the viewer page."""
        return self.visualizer.url()

    def open(self) -> MeshcatViewer:
        """Open the viewer in a browser tab."""
        self.visualizer.open()
        return self

    def jupyter_cell(self, height: int = 400):
        """The viewer as a notebook cell output (make it the cell's last expression)."""
        return self.visualizer.jupyter_cell(height=height)


def live_view(
    vehicle: Vehicle,
    *,
    fps: float = 25.0,
    real_time: bool = True,
    open_browser: bool = True,
    viewer: MeshcatViewer | None = None,
) -> Callable[[float, np.ndarray, Mapping[str, object] | None], None]:
    """A callback ``show(t, q, info)`` that draws a running simulation in meshcat.

    Frames closer than ``1/fps`` in simulated time are skipped; with ``real_time`` the callback
    waits so that the simulation is not shown faster than real time.

    Args:
        vehicle: The vehicle.
        fps: Frames per simulated second to draw [1/s].
        real_time: Do not run ahead of the wall clock.
        open_browser: Open the viewer page in a browser tab (its URL is printed in any case).
        viewer: Reuse a viewer instead of starting one.
    """
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    if viewer is None:
        viewer = MeshcatViewer(vehicle)
        if open_browser:
            viewer.open()
    state = {"last": -math.inf, "t0": None, "wall0": 0.0}

    def show(t: float, q: np.ndarray, info: Mapping[str, object] | None = None) -> None:
        t = float(t)
        if t - state["last"] < 1.0 / fps:
            return
        state["last"] = t
        if state["t0"] is None:
            state["t0"], state["wall0"] = t, time.perf_counter()
        elif real_time:
            ahead = (t - state["t0"]) - (time.perf_counter() - state["wall0"])
            if ahead > 0:
                time.sleep(ahead)
        viewer.display(q, info)

    show.viewer = viewer  # type: ignore[attr-defined]
    return show
