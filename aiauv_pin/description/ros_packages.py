"""Finding ROS packages without ROS: ``$(find pkg)`` in xacro and ``package://pkg/...`` in URDFs.

A *package search path* is a list of folders. A package ``pkg`` is found as the first of:

1. a folder ``pkg`` directly in, or a folder holding a ``package.xml`` whose ``<name>`` is ``pkg``
   anywhere below (at most :data:`MAX_DEPTH` levels), one of the search-path folders, in order;
   the search path is the ``--package-path`` folders, then those of ``ROS_PACKAGE_PATH``
   (``os.pathsep``-separated, as ROS 1 sets it);
2. example-robot-data itself (package ``example-robot-data``, as its URDFs name their meshes:
   ``package://example-robot-data/robots/...``) and its description packages
   (``panda_description``, ``ur_description``, ...), so that its meshes resolve with no search
   path at all.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from urllib.parse import unquote, urlparse

from defusedxml.ElementTree import parse as safe_parse

#: Deepest folder level searched below a search-path folder for ``package.xml`` files.
MAX_DEPTH = 4


def package_search_path(extra: Iterable[str | os.PathLike] = ()) -> tuple[Path, ...]:
    """``extra`` folders, then those of ``ROS_PACKAGE_PATH`` (existing folders only, no repeats)."""
    folders: list[Path] = [Path(folder) for folder in extra]
    folders += [Path(f) for f in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if f]
    seen: set[Path] = set()
    result = []
    for folder in folders:
        resolved = folder.expanduser().resolve()
        if resolved.is_dir() and resolved not in seen:
            seen.add(resolved)
            result.append(resolved)
    return tuple(result)


def _package_name(manifest: Path) -> str | None:
    try:
        name = safe_parse(str(manifest), forbid_dtd=True).getroot().findtext("name")
    except Exception:  # an unreadable manifest names no package
        return None
    return name.strip() if name else None


def _walk_manifests(folder: Path, depth: int) -> Iterable[Path]:
    try:
        entries = sorted(folder.iterdir())
    except OSError:
        return
    for entry in entries:
        if entry.name == "package.xml" and entry.is_file():
            yield entry
    if depth <= 0:
        return
    for entry in entries:
        if entry.is_dir() and not entry.name.startswith("."):
            yield from _walk_manifests(entry, depth - 1)


def find_package(name: str, search_path: Sequence[Path] = ()) -> Path | None:
    """Folder of ROS package ``name``, or ``None`` (see the module docstring for the order)."""
    if not name or "/" in name or name in (".", ".."):
        return None
    for folder in search_path:
        candidate = folder / name
        if candidate.is_dir():
            return candidate
        for manifest in _walk_manifests(folder, MAX_DEPTH):
            if _package_name(manifest) == name:
                return manifest.parent
    try:
        from aiauv_pin.description.robots import example_robot_data_dir

        robots = example_robot_data_dir()
    except Exception:  # example-robot-data missing: no fallback
        return None
    candidate = robots.parent if name == "example-robot-data" else robots / name
    return candidate if candidate.is_dir() else None


def resolve_uri(
    uri: str, search_path: Sequence[Path] = (), base: Path | None = None
) -> Path | None:
    """File named by a URDF ``filename``: ``package://pkg/rel``, ``file:///abs`` or a path.

    Args:
        uri: The ``filename`` attribute.
        search_path: Package search path (:func:`package_search_path`).
        base: Folder that relative paths are relative to (the URDF's folder).

    Returns:
        An existing file, or ``None``.
    """
    if uri.startswith("package://"):
        package, _, relative = uri[len("package://") :].partition("/")
        folder = find_package(package, search_path)
        path = None if folder is None else folder / unquote(relative)
    elif uri.startswith("file://"):
        path = Path(unquote(urlparse(uri).path))
    elif "://" in uri:
        return None
    else:
        path = Path(uri)
        if not path.is_absolute() and base is not None:
            path = base / path
    return path if path is not None and path.is_file() else None
