"""Station keeping and velocity control from a scenario file's ``[station]`` / ``[velocity]``
table (keys checked by :class:`aiauv_pin.scenario.file_schemas.StationTable` and
:class:`~aiauv_pin.scenario.file_schemas.VelocityTable`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from aiauv_control.laws.station_laws import AXIS_NAMES, pid_gains, rotation_from_rpy, velocity_gains
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.wholebody.station_controller import DEFAULT_OMEGA, StationKeeping
from aiauv_pin.wholebody.velocity_controller import DEFAULT_BANDWIDTH, VelocityControl


def controller_from_options(
    vehicle: Vehicle, kind: str, options: Mapping, current, q0=None, actuator_period=None
):
    """A :class:`StationKeeping` (``kind = "station"``) or :class:`VelocityControl`
    (``"velocity"``) from a table's keys; ``current`` is the scenario's (told to the model unless
    ``known_current = false``), ``q0`` the start (where the actuators are checked),
    ``actuator_period`` the control period [s] (thrusters with dynamics)."""
    table = dict(options)
    known = table.pop("known_current", True)
    model_current = current if known else None
    frame = table.pop("frame", None)
    axes = tuple(table.pop("axes", AXIS_NAMES))
    pole = table.pop("integral_pole", None)
    try:
        if kind == "station":
            gains = pid_gains(table.pop("omega", DEFAULT_OMEGA), table.pop("zeta", 1.0), pole)
            position = table.pop("position", None)
            rpy = table.pop("rpy", None)
            rotation = None if rpy is None else rotation_from_rpy(*rpy)
            built = StationKeeping(
                vehicle,
                position,
                rotation,
                frame=frame,
                gains=gains,
                axes=axes,
                current=model_current,
                q_check=q0,
                actuator_period=actuator_period,
            )
        elif kind == "velocity":
            if "twist" not in table:
                raise ArgumentError("velocity: needs a [velocity] table with a twist")
            gains = velocity_gains(table.pop("bandwidth", DEFAULT_BANDWIDTH), pole)
            built = VelocityControl(
                vehicle,
                np.asarray(table.pop("twist"), dtype=float),
                frame=frame,
                gains=gains,
                axes=axes,
                current=model_current,
                q_check=q0,
                actuator_period=actuator_period,
            )
        else:
            raise ArgumentError(f"unknown whole-body controller {kind!r:.40}")
    except ArgumentError:
        raise
    except ValueError as exc:
        raise ArgumentError(f"{kind}: {' '.join(str(exc).split())}") from None
    if table:
        raise ArgumentError(f"{kind}: unknown keys {sorted(table)}")
    return built
