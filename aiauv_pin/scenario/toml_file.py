"""Scenario files: one TOML file names the vehicle, path, start, current, controller and run.

The format (every key optional; without a file ``aiauv simulate`` runs the paper's scenario)::

    case = "uniform"             # bundled vehicle and its gains
    vehicle = "my.urdf"          # or your own URDF (relative to this file)
    fixed_base = false           # its root link fixed to the world (a 'world' root link: always)
    lenient = false              # repair what published files trip, each repair a warning
    package_path = ["packages"]  # folders searched first for ROS packages (relative to this file)
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
    velocity = [0.0, 0.0, 0.0]   # [m/s], world (type = "tidal" or "shear": see aiauv_hydro.currents)
    [waves]
    type = "regular"             # linear waves on the (constant) current: regular, jonswap or
    height = 1.0                 # pierson_moskowitz; H or H_s [m], T or T_p [s], heading [rad],
    period = 6.0                 # depth [m], surface_z [m] (docs/source/waves.md)
    [controller]
    type = "paper"               # or "none" (passive: thrusters and joints idle), or
                                 # "thruster_turning" (straight body, tunnel thrusters turn it)
    k_d = 12.0                   # gains as in sweep specs: u_d, k_e, alpha, k_p, k_d, k_qp, k_qd,
                                 # k_1p, k_1i, q_max, feedforward; beyond the paper:
                                 # current_compensation = "integral_los", turn_feedforward,
                                 # hydrostatic_compensation (README, "Beyond the paper")
    [intervention]               # controller type "intervention" or "transit_intervene"
    target_position = [3.3, 0.0, 0.2]  # end-effector target [m], world; target_rpy [rad]
    move_time = 8.0              # [s] minimum-jerk move; gains: stiffness, damping, integral, ...
    [output]
    csv_period = 0.04            # [s] between rows of timeseries.csv

The parameter names are those of sweep specs (:mod:`aiauv_pin.scenario.sweep_spec`): the run-level keys
are the same, ``[controller]`` holds the gains under their sweep names, ``start.position`` is the
sweep's ``initial_offset`` (with x), ``start.surge`` its ``initial_surge`` and
``current.velocity`` its ``current.x/y/z``; a sweep spec may name a scenario file as its ``base``.
A bad file (unknown key, wrong type, a value outside its plausible range, degenerate path) gets
one line naming the key path and what is expected, e.g. ``controller.k_d: expected a number in
(0, 1e4] (a bool is not a number), got True``; the schema is
:class:`aiauv_pin.scenario.file_schemas.ScenarioFile` (``aiauv schema scenario`` prints it).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, model_validator

from aiauv_control.path_following import PathFollowingGains
from aiauv_control.paths import PathError
from aiauv_control.paths import from_mapping as path_from_mapping
from aiauv_hydro.currents import current_from_mapping
from aiauv_hydro.spec import HydroError
from aiauv_hydro.waves.sea_state import Waves
from aiauv_pin._internal.schema_validation import given, validate
from aiauv_pin.controllers.gait_controller import Gait
from aiauv_pin.controllers.torpedo_controller import Torpedo
from aiauv_pin.errors import AiauvError
from aiauv_pin.scenario.definition import Scenario
from aiauv_pin.scenario.file_schemas import ScenarioFile
from aiauv_pin.scenario.parameters import TABLES, TOP_LEVEL
from aiauv_pin.wholebody.intervention_transit import InterventionSettings

__all__ = ["TABLES", "TOP_LEVEL", "ScenarioFileError", "load_scenario", "scenario_from_mapping"]

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


class ScenarioFileError(AiauvError, ValueError):
    """A scenario file that cannot be used (one line naming the key)."""


#: Largest scenario file read [bytes] (a scenario is a few hundred bytes).
MAX_FILE_BYTES = 1_000_000

_DEFAULTS = Scenario()


class _CheckedScenario(ScenarioFile):
    """:class:`ScenarioFile` with the checks between keys (against the scenario's defaults)."""

    @model_validator(mode="after")
    def _within_duration(self):
        duration = self.duration if self.duration is not None else _DEFAULTS.duration
        periods = {
            "dt": self.dt if self.dt is not None else _DEFAULTS.dt,
            "control_period": self.control_period,
            "output.csv_period": self.output.csv_period if self.output is not None else None,
        }
        for name, period in periods.items():
            if period is not None and period > duration:
                raise ValueError(
                    f"{name}: must not exceed the duration ({duration:g} s), got {period:g} s"
                )
        heading = self.start.heading if self.start is not None else None
        if heading is not None and not any(heading):
            raise ValueError("start.heading: zero vector")
        return self


def _plain(table: BaseModel | None) -> dict:
    return {k: list(v) if isinstance(v, tuple) else v for k, v in given(table).items()}


def scenario_from_mapping(table: Mapping[str, Any], base_dir: str | Path = ".") -> Scenario:
    """A :class:`aiauv_pin.scenario.definition.Scenario` from a parsed scenario file.

    The table is checked by the schema (:class:`aiauv_pin.scenario.file_schemas.ScenarioFile`: types,
    unknown keys, plausible ranges), then the path, the current and the gains are built by their
    own readers (degenerate geometry, non-physical combinations).

    Args:
        table: The file's content (nested tables).
        base_dir: Folder that a relative ``vehicle`` or ``package_path`` is taken from.

    Raises:
        ScenarioFileError: Unknown key, wrong type, implausible, non-physical or degenerate value
            (one line naming the key).
    """
    checked = validate(_CheckedScenario, table, ScenarioFileError, "scenario")
    top = given(checked)
    options: dict[str, Any] = {
        name: top[name]
        for name in ("case", "duration", "dt", "method", "control_period", "continuous_joints")
        if name in top
    }
    options.update(
        {k: top[k] for k in ("added_mass", "lagged_filter", "fixed_base", "lenient") if k in top}
    )
    case = top.get("case", _DEFAULTS.case)
    if "vehicle" in top:
        options["vehicle"] = str(Path(base_dir) / top["vehicle"])
    if "package_path" in top:
        options["package_path"] = tuple(str(Path(base_dir) / p) for p in top["package_path"])
    start = given(checked.start)
    for key, option in (("position", "start_position"), ("heading", "heading")):
        if key in start:
            options[option] = tuple(start[key])
    if "surge" in start:
        options["initial_surge"] = start["surge"]
    try:
        if "path" in top:
            options["path"] = path_from_mapping(_plain(checked.path), where="path")
        if "current" in top:
            options["current"] = current_from_mapping(_plain(checked.current), where="current")
        if checked.waves is not None:
            options["waves"] = Waves.from_mapping(_plain(checked.waves), where="waves")
    except (PathError, HydroError, ValueError) as exc:
        raise ScenarioFileError(" ".join(str(exc).split())) from None
    controller = _plain(checked.controller)
    options["controller"] = controller.pop("type", "paper")
    if "thrusts" in controller:
        options["thrusts"] = tuple(controller.pop("thrusts"))
    if controller:
        try:
            options["gains"] = PathFollowingGains.for_case(case, **controller)
        except (TypeError, ValueError) as exc:
            raise ScenarioFileError(f"controller: {' '.join(str(exc).split())}") from None
    if checked.gait is not None:
        try:
            options["gait"] = Gait(**_plain(checked.gait))
        except ValueError as exc:
            raise ScenarioFileError(" ".join(str(exc).split())) from None
    if checked.torpedo is not None:
        if options["controller"] != "torpedo":
            raise ScenarioFileError("torpedo: given, but controller.type is not 'torpedo'")
        table = _plain(checked.torpedo)
        if "thrust" in table and "speed" not in table:
            table["speed"] = None
        try:
            options["torpedo"] = Torpedo(**table)
        except ValueError as exc:
            raise ScenarioFileError(" ".join(str(exc).split())) from None
    for name in ("station", "velocity"):
        if getattr(checked, name) is not None:
            if options["controller"] != name:
                raise ScenarioFileError(f"{name}: given, but controller.type is not {name!r}")
            options["wholebody"] = _plain(getattr(checked, name))
    if checked.intervention is not None:
        try:
            options["intervention"] = InterventionSettings.from_mapping(
                _plain(checked.intervention)
            )
        except ValueError as exc:
            raise ScenarioFileError(f"intervention: {' '.join(str(exc).split())}") from None
    output = given(checked.output)
    if "csv_period" in output:
        options["csv_period"] = output["csv_period"]
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
