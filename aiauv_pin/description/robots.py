"""Locating robot descriptions shipped by other packages (example-robot-data)."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

from aiauv_pin.errors import VehicleLoadError


def example_robot_data_dir() -> Path:
    """Folder of example-robot-data's robot descriptions (``.../robots``).

    Recent releases ship the descriptions as data under a ``cmeel.prefix`` folder and no Python
    loader, so the folder is found through the installed distribution's file list.
    """
    try:
        distribution = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise VehicleLoadError("example-robot-data is not installed") from None
    for relative in ("cmeel.prefix/share/example-robot-data/robots",):
        folder = Path(str(distribution.locate_file(relative)))
        if folder.is_dir():
            return folder
    raise VehicleLoadError("example-robot-data is installed but its robots folder was not found")


def example_robot_urdf(relative: str) -> Path:
    """Path of one example-robot-data URDF, e.g. ``"ur_description/urdf/ur5_robot.urdf"``."""
    path = example_robot_data_dir() / relative
    if not path.is_file():
        raise VehicleLoadError(f"example-robot-data has no file '{relative}'")
    return path
