"""Paths to follow: the closest point, a rotation-minimising path frame and its curvatures.

A path is a compiled function ``fn(position, params) -> PathPoint`` (same signature for every path,
so a compiled simulation loop takes any of them, or a user's own, as an argument) plus a flat
``float64`` parameter array. For an end-effector position ``p`` [m] (world frame) it returns the
closest point of the path, its arc length ``s`` [m] and the path frame there.

Frame convention
----------------
The frame ``(T, N1, N2)`` (tangent, two normals; world frame) is right-handed, ``T x N1 = N2``
(equivalently ``N1 x N2 = T``), and rotation-minimising (parallel transported; Bishop 1975):

    dT/ds = k1 N1 + k2 N2,    dN1/ds = -k1 T,    dN2/ds = -k2 T,

with the normal-development curvatures ``k1``, ``k2`` [1/m] (``k1^2 + k2^2`` is the squared Frenet
curvature) and their rates ``dk1/ds``, ``dk2/ds`` [1/m^2]. Unlike the Frenet frame it is defined on
straight pieces and never flips where the curvature vanishes or changes sign. The cross-track errors
are the components of ``p - point`` along ``N1`` and ``N2`` [m].

Built-in paths (Python classes wrap the compiled functions; :data:`PATH_TYPES` is the registry used
by :func:`from_mapping` for scenario files):

* :class:`LinePath` / :func:`line_point` - straight line; ``N2`` = world up projected onto the normal
  plane, so on the world x-axis ``(T, N1, N2) = (x, y, z)`` exactly and the cross-track errors are
  exactly ``(p_y, p_z)`` (the paper's eq. 21);
* :class:`HelixPath` / :func:`helix_point` - circular helix, closest point by safeguarded Newton;
* :class:`WaypointPath` / :func:`waypoints_point` - polyline with circular-arc corner fillets.

References:
    R. L. Bishop, "There is more than one way to frame a curve", Amer. Math. Monthly 82(3), 1975.
    W. Wang, B. Juettler, D. Zheng, Y. Liu, "Computation of rotation minimizing frames", ACM Trans.
    Graphics 27(1), 2008 (rotation-minimising frames on arcs and helices).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from aiauv_control.paths.base import (
    VERTICAL_TOLERANCE,
    Path,
    PathError,
    PathPoint,
    UserPath,
    Vector3,
)
from aiauv_control.paths.helix import HelixPath, helix_point
from aiauv_control.paths.line import LinePath, line_frame, line_point
from aiauv_control.paths.waypoints import WaypointPath, waypoints_point
from aiauv_hydro.numerics.jit import compiled, user_or_builtin

#: Path types of scenario files: ``type`` -> class. A new path type is a new module defining its
#: class (and compiled function), one line here and one branch in :func:`builtin_path_point`.
PATH_TYPES: dict[str, type[Path]] = {
    "line": LinePath,
    "helix": HelixPath,
    "waypoints": WaypointPath,
}


#: ``kind_code`` of each built-in path (numba freezes these module constants when compiling).
LINE, HELIX, WAYPOINTS = LinePath.kind_code, HelixPath.kind_code, WaypointPath.kind_code


@compiled
def builtin_path_point(kind, position, params) -> PathPoint:
    """The closest point on the built-in path number ``kind`` (its class's ``kind_code``)."""
    if kind == HELIX:
        return helix_point(position, params)
    if kind == WAYPOINTS:
        return waypoints_point(position, params)
    return line_point(position, params)


#: ``path_point_of(user, kind, position, params) -> PathPoint``: a user's path function (``user``)
#: or the built-in path ``kind`` (``user = None``), see :func:`aiauv_hydro.numerics.jit.user_or_builtin`.
path_point_of = user_or_builtin(builtin_path_point)

__all__ = [
    "PATH_TYPES",
    "VERTICAL_TOLERANCE",
    "HelixPath",
    "LinePath",
    "Path",
    "PathError",
    "PathPoint",
    "UserPath",
    "Vector3",
    "WaypointPath",
    "builtin_path_point",
    "from_mapping",
    "helix_point",
    "line_frame",
    "line_point",
    "path_point_of",
    "waypoints_point",
]


def from_mapping(table: Mapping[str, Any], where: str = "path") -> Path:
    """Build a path from a scenario-file table such as ``{"type": "line", "point": [0, 0, 0],
    "direction": [1, 0, 0]}``; the keys are the class's constructor arguments.

    Raises:
        ValueError: one line naming the key (``path.helix.radius: must be > 0, got 0``): not a
            table, missing or unknown ``type``, unknown or missing key, wrong type, degenerate
            geometry.
    """
    if not isinstance(table, Mapping):
        raise ValueError(f"{where}: expected a table, got {type(table).__name__}")
    if "type" not in table:
        raise ValueError(f"{where}.type: missing (one of {', '.join(PATH_TYPES)})")
    name = table["type"]
    if not isinstance(name, str) or name not in PATH_TYPES:
        raise ValueError(
            f"{where}.type: unknown path type {name!r} (one of {', '.join(PATH_TYPES)})"
        )
    cls = PATH_TYPES[name]
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    prefix = f"{where}.{name}"
    for key in table:
        if key != "type" and key not in fields:
            raise ValueError(f"{prefix}.{key}: unknown key (expected {', '.join(fields)})")
    for key, f in fields.items():
        if key not in table and f.default is dataclasses.MISSING:
            raise ValueError(f"{prefix}.{key}: missing")
    arguments = {key: value for key, value in table.items() if key != "type"}
    for key, value in arguments.items():
        if isinstance(value, str):
            raise ValueError(f"{prefix}.{key}: expected numbers, got the string {value!r}")
    try:
        return cls(**arguments)
    except PathError as error:
        raise PathError(error.key, error.problem, where=prefix) from None
