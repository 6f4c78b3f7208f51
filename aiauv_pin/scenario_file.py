"""Scenario files: one TOML file names the vehicle, path, start, current, controller and run.

The format (every key optional; without a file ``aiauv simulate`` runs the paper's scenario)::

    case = "uniform"             # bundled vehicle and its gains
    vehicle = "my.urdf"          # or your own URDF (relative to this file)
    duration = 120.0             # [s]
    dt = 0.004                   # [s]
    method = "euler"             # semi-implicit Euler, "rk4" or "midpoint"
    control_period = 0.02        # [s], a whole multiple of dt (default: every step)
    continuous_joints = true     # joint PD (eq. 24) as a servo at every stage
    added_mass = "exact"         # or "lagged" (UUV Simulator / gz-sim scheme; Python controller)
    lagged_filter = 0.3          # its filter coefficient in (0, 1]: 0.3 UUV Simulator, 1 gz-sim
    [start]
    position = [0.0, 2.0, 2.0]   # end-effector [m], world; vehicle straight, at rest
    heading = [1.0, 0.0, 0.0]    # direction the vehicle points (default: along the path)
    surge = 0.0                  # initial forward speed [m/s]
    [path]
    type = "line"                # line: point, direction | helix: centre, axis, radius, pitch
                                 # | waypoints: points, corner_radius
    point = [0.0, 0.0, 0.0]
    direction = [1.0, 0.0, 0.0]
    [current]
    velocity = [0.0, 0.0, 0.0]   # [m/s], world (type = "tidal" or "shear": see hydro.currents)
    [controller]
    type = "paper"               # or "none" (passive: thrusters and joints idle), or
                                 # "thruster_turning" (straight body, tunnel thrusters turn it)
    k_d = 12.0                   # gains as in sweep specs: u_d, k_e, alpha, k_p, k_d, k_qp, k_qd,
                                 # k_1p, k_1i, q_max, feedforward; beyond the paper:
                                 # current_compensation = "integral_los", turn_feedforward,
                                 # hydrostatic_compensation (README, "Beyond the paper")
    [output]
    csv_period = 0.04            # [s] between rows of timeseries.csv

The parameter names are those of sweep specs (:mod:`aiauv_pin.sweep_spec`): the run-level keys
are the same, ``[controller]`` holds the gains under their sweep names, ``start.position`` is the
sweep's ``initial_offset`` (with x), ``start.surge`` its ``initial_surge`` and
``current.velocity`` its ``current.x/y/z``; a sweep spec may name a scenario file as its ``base``.
A bad file (unknown key, wrong type, degenerate path) gets one line naming the key and the problem.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from control.path_following import CASES, PathFollowingGains
from control.paths import PathError
from control.paths import from_mapping as path_from_mapping
from hydro.currents import current_from_mapping
from hydro.spec import HydroError

from .errors import AiauvError
from .lagged import ADDED_MASS_SCHEMES
from .scenario import CONTROLLERS, Scenario
from .scenario_schema import METHODS, TABLES, TOP_LEVEL

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


class ScenarioFileError(AiauvError, ValueError):
    """A scenario file that cannot be used (one line naming the key)."""


# Keys of the top level, and the tables with their keys: one schema for scenario files and sweep
# specs (path and current tables are checked by control.paths and hydro.currents).

#: Largest scenario file read [bytes] (a scenario is a few hundred bytes).
MAX_FILE_BYTES = 1_000_000


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _number(value, key: str, *, positive: bool = False, minimum: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioFileError(f"{key}: expected a number, got {_shown(value)}")
    number = float(value)
    if not math.isfinite(number):
        raise ScenarioFileError(f"{key}: expected a finite number, got {_shown(value)}")
    if positive and number <= 0.0:
        raise ScenarioFileError(f"{key}: must be > 0, got {_shown(value)}")
    if minimum is not None and number < minimum:
        raise ScenarioFileError(f"{key}: must be >= {minimum:g}, got {_shown(value)}")
    return number


def _vector3(value, key: str) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise ScenarioFileError(f"{key}: expected a list of 3 numbers, got {_shown(value)}")
    return tuple(_number(v, key) for v in value)


def _choice(value, key: str, options) -> str:
    if value not in options:
        raise ScenarioFileError(f"{key}: expected one of {', '.join(options)}, got {_shown(value)}")
    return value


def scenario_from_mapping(table: Mapping[str, Any], base_dir: str | Path = ".") -> Scenario:
    """A :class:`aiauv_pin.scenario.Scenario` from a parsed scenario file.

    Args:
        table: The file's content (nested tables).
        base_dir: Folder that a relative ``vehicle`` path is taken from.

    Raises:
        ScenarioFileError: Unknown key, wrong type, non-physical or degenerate value (one line).
    """
    if not isinstance(table, Mapping):
        raise ScenarioFileError(f"scenario: expected a table, got {type(table).__name__}")
    for key, value in table.items():
        if key in TABLES:
            if not isinstance(value, Mapping):
                raise ScenarioFileError(f"{key}: expected a table [{key}], got {_shown(value)}")
            allowed = TABLES[key]
            if allowed is not None:
                for sub in value:
                    if sub not in allowed:
                        raise ScenarioFileError(
                            f"{key}.{sub}: unknown key (expected one of {', '.join(allowed)})"
                        )
        elif key not in TOP_LEVEL:
            known = ", ".join([*TOP_LEVEL, *(f"[{t}]" for t in TABLES)])
            raise ScenarioFileError(f"{key}: unknown key (expected one of {known})")
    options: dict[str, Any] = {}
    case = _choice(table.get("case", "uniform"), "case", CASES)
    options["case"] = case
    if "vehicle" in table:
        vehicle = table["vehicle"]
        if not isinstance(vehicle, str) or not vehicle:
            raise ScenarioFileError(f"vehicle: expected a file name, got {_shown(vehicle)}")
        options["vehicle"] = str(Path(base_dir) / vehicle)
    for key in ("duration", "dt"):
        if key in table:
            options[key] = _number(table[key], key, positive=True)
    if "method" in table:
        options["method"] = _choice(table["method"], "method", METHODS)
    if "control_period" in table:
        options["control_period"] = _number(
            table["control_period"], "control_period", positive=True
        )
    if "added_mass" in table:
        options["added_mass"] = _choice(table["added_mass"], "added_mass", ADDED_MASS_SCHEMES)
    if "lagged_filter" in table:
        alpha = _number(table["lagged_filter"], "lagged_filter", positive=True)
        if alpha > 1.0:
            raise ScenarioFileError(f"lagged_filter: must be <= 1, got {_shown(alpha)}")
        options["lagged_filter"] = alpha
    if "continuous_joints" in table:
        if not isinstance(table["continuous_joints"], bool):
            raise ScenarioFileError(
                f"continuous_joints: expected true or false, got {_shown(table['continuous_joints'])}"
            )
        options["continuous_joints"] = table["continuous_joints"]
    start = table.get("start", {})
    if "position" in start:
        options["start_position"] = _vector3(start["position"], "start.position")
    if "heading" in start:
        heading = _vector3(start["heading"], "start.heading")
        if math.hypot(*heading) == 0.0:
            raise ScenarioFileError("start.heading: zero vector")
        options["heading"] = heading
    if "surge" in start:
        options["initial_surge"] = _number(start["surge"], "start.surge")
    if "path" in table:
        try:
            options["path"] = path_from_mapping(table["path"], where="path")
        except (PathError, ValueError) as exc:
            raise ScenarioFileError(str(exc)) from None
    if "current" in table:
        try:
            options["current"] = current_from_mapping(table["current"], where="current")
        except HydroError as exc:
            raise ScenarioFileError(str(exc)) from None
    controller = dict(table.get("controller", {}))
    options["controller"] = _choice(controller.pop("type", "paper"), "controller.type", CONTROLLERS)
    if controller:
        try:
            options["gains"] = PathFollowingGains.for_case(case, **controller)
        except (TypeError, ValueError) as exc:
            raise ScenarioFileError(f"controller: {' '.join(str(exc).split())}") from None
    output = table.get("output", {})
    if "csv_period" in output:
        options["csv_period"] = _number(output["csv_period"], "output.csv_period", positive=True)
    try:
        return Scenario(**options)
    except ValueError as exc:
        raise ScenarioFileError(" ".join(str(exc).split())) from None


def read_scenario_text(path: str | Path) -> str:
    """A scenario file's text: a regular file of at most :data:`MAX_FILE_BYTES` bytes, UTF-8."""
    path = Path(path)
    try:
        if not path.is_file():
            raise ScenarioFileError(f"scenario file {path}: not a regular file")
        with path.open("rb") as stream:
            data = stream.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ScenarioFileError(f"scenario file {path}: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:
        raise ScenarioFileError(f"scenario file {path}: larger than {MAX_FILE_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ScenarioFileError(f"scenario file {path}: not UTF-8 text") from None


def parse_scenario_text(text: str, where: str = "scenario") -> dict:
    """The nested tables of a scenario file's TOML text."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioFileError(f"{where}: not valid TOML ({' '.join(str(exc).split())})") from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and check a scenario file (a relative ``vehicle`` is taken from the file's folder)."""
    path = Path(path)
    table = parse_scenario_text(read_scenario_text(path), str(path))
    return scenario_from_mapping(table, path.parent)
