"""Result files of a run: ``timeseries.csv``, ``summary.json`` and ``figures/``.

What they hold fits the run: path errors, named in the path's frame, only for a run that follows
a path (:func:`aiauv_pin.scenario.definition.followed_path`), the motion of the base for one that does not
(:func:`figures_of`, :func:`aiauv_pin.scenario.definition.summary`); ``timeseries.csv`` has a unit in every
header cell and the whole state, written so that it reads back exactly
(:func:`timeseries_table`, :func:`read_timeseries`, :func:`timeseries_trajectory`).

The run is logged at every controller sample (every step by default) and ``summary.json``'s
integrals (work) and settling times use every logged sample. ``timeseries.csv`` holds every
``csv_period`` of the scenario (0.04 s by default, rounded to a whole number of logged samples;
the last sample is always included; ``None`` writes every sample). The figures draw, per curve,
the minimum and maximum of each of at most :data:`PLOT_BUCKETS` consecutive runs of samples (in
time order), which at their size is indistinguishable from drawing every sample.

The figures themselves are drawn from plain data (:func:`figure_data`) by
:mod:`aiauv_pin.results.figures`, which imports numpy and matplotlib alone.

Speed: on Linux, ``aiauv simulate`` forks a figure process before the simulation's modules are
imported, which imports matplotlib meanwhile and draws the figures after the run
(:mod:`aiauv_pin.results.figure_workers`, ``write_results(figure_workers=...)``). Elsewhere, call
:func:`preload_plotting` before a compiled run (``aiauv simulate`` calls it once the vehicle is
loaded, before the compiled loop is), or pass it as ``after_first_chunk`` to
:func:`aiauv_pin.scenario.definition.run_paper_scenario`, and matplotlib (about 0.3 s of imports)
is imported in a background thread while the compiled loop is loaded and runs (its kernels release
the GIL). The figures are drawn by two processes on Linux.
"""

from __future__ import annotations

import functools
import json
import math
import os
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import orjson

from aiauv_pin._internal.atomic import write_parts, write_text
from aiauv_pin._internal.text import signed
from aiauv_pin.results.figures import (  # noqa: F401  (the figures' names, where they were)
    DRAWN_INFO,
    FIGURE_DPI,
    FIGURE_FORMATS,
    FIGURES,
    INTERVENTION_FIGURES,
    MOTION_FIGURES,
    PATH_FIGURES,
    PLOT_BUCKETS,
    PNG_COMPRESSION,
    TORPEDO_FIGURES,
    WHOLEBODY_FIGURES,
    FigureData,
    _figure_tasks,
    _forget_parsed_math,
    _prepare_figures,
    _take_tasks,
    check_figure_format,
    envelope,
    figure_path,
    import_plotting,
    preload_plotting,
    write_png,
)
from aiauv_pin.scenario.definition import ScenarioResult, cross_track_axes, summary
from aiauv_pin.simulation.energy import energy_summary
from aiauv_pin.simulation.fixed_step import Trajectory


@dataclass(frozen=True)
class TimeseriesColumn:
    """One column of ``timeseries.csv``: its name, unit and values (one per logged sample)."""

    name: str
    unit: str
    values: np.ndarray


#: Diagnostics the controllers log, as columns: ``(info key, column names, unit)``; the paper's
#: controller logs all of them, every run ``p``, a run that follows a path also ``cross_track``
#: and ``path_s`` (:func:`aiauv_pin.scenario.definition.add_path_errors`).
_INFO_COLUMNS = (
    ("p", ("p_x", "p_y", "p_z"), "m"),
    ("cross_track", ("e_1", "e_2"), "m"),
    ("path_s", ("s",), "m"),
    ("u", ("u",), "m/s"),
    ("phi_tilde", ("phi_tilde",), "rad"),
    ("omega_tilde", ("omega_tilde_y", "omega_tilde_z"), "rad/s"),
    ("base_angles", ("q_y0", "q_z0"), "rad"),
    ("x_ref", ("x_ref_x", "x_ref_y", "x_ref_z"), "-"),
    ("pointing", ("pointing_x", "pointing_y", "pointing_z"), "-"),
)
#: Per-joint and per-thruster diagnostics of the paper's controller: ``(info key, column prefix)``
#: (joint references in the joint's unit, torques [N m] or [N], thrusts [N]).
_NAMED_COLUMNS = (
    ("joint_references", "qref_"),
    ("joint_torque", "tau_"),
    ("thrust", "thrust_"),
)
#: The base's configuration and twist (Pinocchio's free flyer: ``q[:7]`` = position [m] and
#: quaternion ``(x, y, z, w)``, ``v[:6]`` = linear [m/s] and angular [rad/s] velocity in the body
#: frame) as columns: ``(name, unit)``.
BASE_CONFIGURATION = (
    ("base_x", "m"),
    ("base_y", "m"),
    ("base_z", "m"),
    ("base_quat_x", "-"),
    ("base_quat_y", "-"),
    ("base_quat_z", "-"),
    ("base_quat_w", "-"),
)
BASE_TWIST = (
    ("base_u", "m/s"),
    ("base_v", "m/s"),
    ("base_w", "m/s"),
    ("base_p", "rad/s"),
    ("base_q", "rad/s"),
    ("base_r", "rad/s"),
)


def _rate_unit(unit: str) -> str:
    return f"{unit}/s"


def _effort_unit(unit: str) -> str:
    return "N" if unit == "m" else "N m"


def timeseries_table(result: ScenarioResult) -> list[TimeseriesColumn]:
    """The columns of ``timeseries.csv``, in order, with their units.

    Every run: time ``t`` [s], the end-effector's world position ``p_x, p_y, p_z`` [m], every joint
    angle ``q_<joint>`` [rad] (or [m] for a prismatic joint), the base's position ``base_x, base_y,
    base_z`` [m] and quaternion ``base_quat_x, _y, _z, _w`` [-] (Pinocchio's order), its twist in
    the body frame ``base_u, base_v, base_w`` [m/s] and ``base_p, base_q, base_r`` [rad/s], and
    every joint rate ``v_<joint>`` [rad/s] (or [m/s]): the whole state ``(q, v)``
    (:func:`timeseries_trajectory` reads it back). A run that follows a path adds the cross-track
    errors ``e_1, e_2`` [m] along the path frame's normals (named in ``summary.json``'s
    ``cross_track_axes``) and the path parameter ``s`` [m]; the paper's controller adds its
    diagnostics (surge ``u`` [m/s], pointing error ``phi_tilde`` [rad], ``omega_tilde_y, _z``
    [rad/s], base angles ``q_y0, q_z0`` [rad], reference and actual pointing directions [-], joint
    references ``qref_<joint>``, torques ``tau_<joint>`` [N m] and thrusts ``thrust_<name>`` [N]).
    """
    tr = result.trajectory
    info = tr.info
    q, v = np.asarray(tr.q), np.asarray(tr.v)
    units = result.position_units
    table = [TimeseriesColumn("t", "s", np.asarray(tr.t))]

    def add_info(key: str, names, unit: str) -> None:
        values = np.asarray(info[key]).reshape(len(tr.t), -1)
        table.extend(TimeseriesColumn(name, unit, values[:, k]) for k, name in enumerate(names))

    paper = "u" in info
    for key, names, unit in _INFO_COLUMNS:
        if key in info and (paper or key in ("p", "cross_track", "path_s")):
            add_info(key, names, unit)
    table.extend(
        TimeseriesColumn(f"q_{name}", unit, q[:, 7 + k])
        for k, (name, unit) in enumerate(zip(result.joint_names, units, strict=True))
    )
    if paper:
        for key, prefix in _NAMED_COLUMNS:
            values = np.asarray(info[key])
            if key == "thrust":
                owners = [(name, "N") for name in result.thruster_names]
            else:
                effort = key == "joint_torque"
                owners = [
                    (name, _effort_unit(unit) if effort else unit)
                    for name, unit in zip(result.joint_names, units, strict=True)
                ]
            table.extend(
                TimeseriesColumn(f"{prefix}{name}", unit, values[:, k])
                for k, (name, unit) in enumerate(owners)
            )
    if "residual" in info and not paper:  # station keeping, velocity control
        velocity = result.scenario.controller == "velocity"
        error_units = ("m/s", "rad/s") if velocity else ("m", "rad")
        for k, axis in enumerate(("surge", "sway", "heave", "roll", "pitch", "yaw")):
            unit = error_units[k // 3]
            table.append(TimeseriesColumn(f"error_{axis}", unit, np.asarray(info["error"])[:, k]))
        for k, axis in enumerate(("surge", "sway", "heave", "roll", "pitch", "yaw")):
            unit = "N" if k < 3 else "N m"
            values = np.asarray(info["residual"])[:, k]
            table.append(TimeseriesColumn(f"residual_{axis}", unit, values))
        thrust = np.asarray(info["thrust"])
        table.extend(
            TimeseriesColumn(f"thrust_{name}", "N", thrust[:, k])
            for k, name in enumerate(result.thruster_names)
        )
    if "pose_error" in info:  # intervention mode (aiauv_pin.wholebody.intervention_controller)
        _add_intervention_columns(result, table, paper)
    table.extend(
        TimeseriesColumn(name, unit, q[:, k]) for k, (name, unit) in enumerate(BASE_CONFIGURATION)
    )
    table.extend(TimeseriesColumn(name, unit, v[:, k]) for k, (name, unit) in enumerate(BASE_TWIST))
    table.extend(
        TimeseriesColumn(f"v_{name}", _rate_unit(unit), v[:, 6 + k])
        for k, (name, unit) in enumerate(zip(result.joint_names, units, strict=True))
    )
    seen: set[str] = set()
    for column in table:
        if column.name in seen:
            raise ValueError(
                f"timeseries.csv: two columns named '{column.name}' (rename the joint or thruster)"
            )
        seen.add(column.name)
    return table


#: The intervention's pose error ``(p_d - p, log(R_d R^T))`` to its reference (the point of the
#: move at the row's time), world axes: ``(column, unit)``.
POSE_ERROR_COLUMNS = (
    ("pose_error_x", "m"),
    ("pose_error_y", "m"),
    ("pose_error_z", "m"),
    ("pose_error_rx", "rad"),
    ("pose_error_ry", "rad"),
    ("pose_error_rz", "rad"),
)


def _add_intervention_columns(result: ScenarioResult, table: list, paper: bool) -> None:
    """The intervention's columns: the pose error, the phase of a transit-then-intervene run
    (0 transit, 1 intervention) and, unless the paper's controller wrote them, the thrusts
    ``thrust_<name>`` [N] and the sharing joint motors' torques ``tau_<joint>`` [N m]."""
    info, n = result.trajectory.info, len(result.trajectory.t)
    error = np.asarray(info["pose_error"]).reshape(n, -1)
    table.extend(
        TimeseriesColumn(name, unit, error[:, k])
        for k, (name, unit) in enumerate(POSE_ERROR_COLUMNS)
    )
    if "phase" in info:
        table.append(TimeseriesColumn("phase", "-", np.asarray(info["phase"]).reshape(n)))
    if paper:
        return
    thrust = np.asarray(info["thrust"]).reshape(n, -1)
    table.extend(
        TimeseriesColumn(f"thrust_{name}", "N", thrust[:, k])
        for k, name in enumerate(result.thruster_names)
    )
    if "joint_torque" in info:
        torque = np.asarray(info["joint_torque"]).reshape(n, -1)
        units = result.position_units
        table.extend(
            TimeseriesColumn(f"tau_{name}", _effort_unit(unit), torque[:, k])
            for k, (name, unit) in enumerate(zip(result.joint_names, units, strict=True))
        )


def timeseries_columns(result: ScenarioResult) -> dict[str, np.ndarray]:
    """Columns of ``timeseries.csv`` by name, in order (:func:`timeseries_table` without units)."""
    return {column.name: column.values for column in timeseries_table(result)}


def column_header(name: str, unit: str) -> str:
    """Header cell of a column: ``"name [unit]"`` (``[-]`` for a dimensionless one)."""
    return f"{name} [{unit}]"


def parse_header(cell: str) -> tuple[str, str]:
    """``(name, unit)`` of a header cell written by :func:`column_header` (unit ``""`` if none)."""
    cell = cell.strip()
    if cell.endswith("]") and " [" in cell:
        name, unit = cell[:-1].rsplit(" [", 1)
        return name, unit
    return cell, ""


def csv_stride(period: float | None, logged_step: float) -> int:
    """Logged samples per row of ``timeseries.csv``: ``csv_period`` over the time between two
    logged samples [s], rounded, at least 1 (1 when ``period`` is ``None``: every sample)."""
    if period is None:
        return 1
    return max(1, round(period / logged_step))


def csv_rows(result: ScenarioResult) -> np.ndarray:
    """Indices of the logged samples written to ``timeseries.csv`` (every ``csv_period``)."""
    t = result.trajectory.t
    n = len(t)
    period = getattr(result.scenario, "csv_period", None)
    if period is None or n < 2:
        return np.arange(n)
    rows = np.arange(0, n, csv_stride(period, float(t[1] - t[0])))
    if rows[-1] != n - 1:
        rows = np.append(rows, n - 1)
    return rows


def format_rows(table: np.ndarray) -> str:
    """The rows of a 2-D float table as CSV text (a line per row, no header), each number the
    shortest text that reads back to the same float (``float(text)``, ``np.loadtxt``, a C
    ``strtod``): the digits of Python's ``repr``, written as JSON numbers are by orjson
    (``1e-7``, ``0.00001``, ``1e+16``), and ``nan``, ``inf``, ``-inf`` where a value is not
    finite. A row's text depends on that row alone, so the texts of consecutive blocks of rows,
    joined, are the text of the whole table.

    orjson writes the numbers in compiled code (about 0.03 s for the paper run's 5,221 x 71
    table, where Python's ``%`` formatting of 17 digits took 0.12-0.2 s); rows with a value that
    is not finite, which JSON has no number for, are written a number at a time."""
    table = np.ascontiguousarray(table, dtype=np.float64)
    if table.ndim != 2:
        raise ValueError(f"format_rows needs a 2-D table, got shape {table.shape}")
    if table.size == 0:
        return "\n" * table.shape[0] if table.shape[1] == 0 else ""
    finite = np.isfinite(table).all(axis=1)
    if finite.all():
        return _finite_rows(table)
    parts, start = [], 0
    for row in np.flatnonzero(~finite):
        if row > start:
            parts.append(_finite_rows(table[start:row]))
        parts.append(",".join(_number_text(x) for x in table[row].tolist()) + "\n")
        start = row + 1
    if start < table.shape[0]:
        parts.append(_finite_rows(table[start:]))
    return "".join(parts)


def _finite_rows(table: np.ndarray) -> str:
    """:func:`format_rows` of a C-ordered table of finite numbers (at least one): orjson's
    nested list ``[[a,b],[c,d]]`` made into lines."""
    text = orjson.dumps(table, option=orjson.OPT_SERIALIZE_NUMPY)
    return text[2:-2].replace(b"],[", b"\n").decode("ascii") + "\n"


def _number_text(x: float) -> str:
    """One number as :func:`format_rows` writes it."""
    if math.isfinite(x):
        return orjson.dumps(x).decode("ascii")
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def write_timeseries(result: ScenarioResult, path: Path, streamed=None) -> Path:
    """Write ``timeseries.csv``: one row per ``csv_period`` (see the module docstring), a header
    of ``name [unit]`` cells (:func:`timeseries_table`), numbers that read back exactly
    (:func:`format_rows`).

    ``streamed``: rows formatted while the run was computed
    (:class:`aiauv_pin.results.streamed_table.StreamedTable`); their text is used where their
    numbers are the table's, bit for bit (the file is the same bytes)."""
    return _write_table(path, *_table_parts(result, streamed))


def _write_table(path: Path, head: list[str], rest: np.ndarray) -> Path:
    """Write the text ``head`` and the rows ``rest`` formatted (:func:`_table_parts`) to ``path``,
    part after part (:func:`~aiauv_pin._internal.atomic.write_parts`)."""
    return write_parts(path, [*head, format_rows(rest)])


def _table_parts(result: ScenarioResult, streamed=None) -> tuple[list[str], np.ndarray]:
    """``timeseries.csv``'s text so far, in parts (the header line and the blocks of rows
    ``streamed`` formatted,
    :meth:`~aiauv_pin.results.streamed_table.StreamedTable.parts_for`), and the rows left to
    format."""
    header, table = timeseries_content(result)
    done, parts = (0, []) if streamed is None else streamed.parts_for(table)
    return [",".join(header) + "\n", *parts], table[done:]


def timeseries_content(result: ScenarioResult) -> tuple[list[str], np.ndarray]:
    """``timeseries.csv``'s header cells and rows (a float table)."""
    columns = timeseries_table(result)
    rows = csv_rows(result)
    table = np.column_stack([np.asarray(column.values, dtype=float)[rows] for column in columns])
    header = [column_header(column.name, column.unit) for column in columns]
    return header, table


@dataclass(frozen=True)
class Timeseries:
    """A ``timeseries.csv`` read back (:func:`read_timeseries`).

    Attributes:
        columns: Values by column name (without the unit), in the file's order.
        units: Unit of each column (``"-"``: dimensionless; ``""``: none given).
    """

    columns: dict[str, np.ndarray]
    units: dict[str, str]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    @property
    def joint_names(self) -> list[str]:
        """Joints with both an angle ``q_<joint>`` and a rate ``v_<joint>`` column, in order."""
        return [
            name[2:]
            for name in self.columns
            if name.startswith("v_") and f"q_{name[2:]}" in self.columns
        ]


def read_timeseries(path: str | os.PathLike) -> Timeseries:
    """Read a ``timeseries.csv`` written by :func:`write_timeseries`: every value exactly as logged.

    Raises:
        ValueError: Not such a file (no header, a ragged row, a cell that is not a number), one line
            naming the file and the row.
    """
    import csv

    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    if not rows or not rows[0]:
        raise ValueError(f"{path}: empty, expected a header of 'name [unit]' cells")
    header = [parse_header(cell) for cell in rows[0]]
    values = np.empty((len(rows) - 1, len(header)))
    for k, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ValueError(f"{path}: row {k + 2} has {len(row)} cells, the header {len(header)}")
        try:
            values[k] = [float(cell) for cell in row]
        except ValueError:
            raise ValueError(f"{path}: row {k + 2} holds a cell that is not a number") from None
    return Timeseries(
        columns={name: values[:, j] for j, (name, _) in enumerate(header)},
        units={name: unit for name, unit in header},
    )


#: Diagnostics :func:`timeseries_trajectory` puts back into ``info`` (the playback draws ``p``,
#: ``thrust`` and ``x_ref``).
_INFO_READ_BACK = {key: names for key, names, _ in _INFO_COLUMNS}


def timeseries_trajectory(path: str | os.PathLike | Timeseries) -> Trajectory:
    """The run of a ``timeseries.csv`` as a :class:`aiauv_pin.simulation.fixed_step.Trajectory`: times, the
    configurations ``q`` (base position, quaternion ``x, y, z, w``, joint angles) and velocities
    ``v`` (base twist in the body frame, joint rates) of its rows, exactly as logged, and the
    diagnostics it holds (``p``, ``cross_track``, ``path_s``, the paper controller's, ``thrust``)
    in ``info``. The generalised forces are not in the file: ``tau`` is NaN.

    Raises:
        ValueError: A file without the state columns (one line naming the first one missing).
    """
    series = path if isinstance(path, Timeseries) else read_timeseries(path)
    joints = series.joint_names
    names = (
        ["t"]
        + [name for name, _ in BASE_CONFIGURATION]
        + [f"q_{joint}" for joint in joints]
        + [name for name, _ in BASE_TWIST]
        + [f"v_{joint}" for joint in joints]
    )
    for name in names:
        if name not in series.columns:
            where = path if not isinstance(path, Timeseries) else "timeseries"
            raise ValueError(f"{where}: no column '{name}', so no state to rebuild the run from")
    t = series["t"]
    q = np.column_stack([series[name] for name in names[1 : 8 + len(joints)]])
    v = np.column_stack([series[name] for name in names[8 + len(joints) :]])
    info: dict[str, np.ndarray] = {}
    for key, columns in _INFO_READ_BACK.items():
        if all(name in series.columns for name in columns):
            stacked = np.column_stack([series[name] for name in columns])
            info[key] = stacked[:, 0] if len(columns) == 1 else stacked
    for key, prefix in _NAMED_COLUMNS:
        columns = [name for name in series.columns if name.startswith(prefix)]
        if columns:
            info[key] = np.column_stack([series[name] for name in columns])
    return Trajectory(t=t, q=q, v=v, tau=np.full(v.shape, np.nan), info=info)


def write_summary(
    result: ScenarioResult,
    path: Path,
    extra: dict | None = None,
    energy: Callable[[], dict | None] | None = None,
) -> dict:
    """Write ``summary.json`` and return its content (``energy``: see
    :func:`aiauv_pin.scenario.definition.summary`)."""
    content = summary(result, energy)
    if extra:
        content.update(extra)
    write_text(path, json.dumps(content, indent=2, allow_nan=False) + "\n")
    return content


def figures_of(result: ScenarioResult) -> tuple[str, ...]:
    """The figures drawn for ``result``: all of :data:`FIGURES` with the paper's controller's
    diagnostics, :data:`PATH_FIGURES` for another run that follows a path, else
    :data:`MOTION_FIGURES`; and :data:`INTERVENTION_FIGURES` for an intervention run."""
    extra = INTERVENTION_FIGURES if "pose_error" in result.trajectory.info else ()
    if result.followed_path is None:
        if "residual" in result.trajectory.info:  # station keeping, velocity control
            return MOTION_FIGURES + WHOLEBODY_FIGURES + extra
        return MOTION_FIGURES + extra
    if "u" in result.trajectory.info:
        return FIGURES + extra
    if "fin_angle" in result.trajectory.info:  # a torpedo AUV
        return PATH_FIGURES + TORPEDO_FIGURES + extra
    return PATH_FIGURES + extra


def run_cross_track_axes(result: ScenarioResult) -> tuple[str, str]:
    """What a path-following run's cross-track errors are, over the arc length it covered
    (:func:`aiauv_pin.scenario.definition.cross_track_axes`)."""
    s = result.trajectory.info["path_s"]
    return cross_track_axes(result.scenario, (float(np.min(s)), float(np.max(s))))


def default_path_points(result: ScenarioResult, n: int = 400) -> np.ndarray | None:
    """The drawn path when none is given: the path the run followed over the arc length the
    end-effector covered (its closest points' range, with a margin), (n, 3) world points [m];
    ``None`` for a run that follows no path (a passive run)."""
    path = result.followed_path
    if path is None:
        return None
    s = result.trajectory.info["path_s"]
    low, high = float(np.min(s)), float(np.max(s))
    margin = 0.05 * max(high - low, 1.0)
    return path.sample((low - margin, high + margin), n)


def final_line(content: dict) -> str:
    """What ``aiauv simulate`` prints of a run's final state, from its ``summary.json`` content:
    the errors from the path it followed, in the path's frame (``p_y``, ``p_z`` on the paper's
    x-axis; else the distance and its components named by ``cross_track_axes``, and the arc
    length reached), or for a run that follows no path the base's position, its distance from its
    start and its speed; the paper controller's surge and pointing error when it ran."""
    final = content["final"]
    axes = content.get("cross_track_axes")
    if axes is None:
        x, y, z = final["base_position"]
        text = (
            f"final base position = ({signed(x, 3)}, {signed(y, 3)}, {signed(z, 3)}) m, "
            f"{final['base_distance']:.4f} m from its start, speed {final['base_speed']:.4f} m/s"
        )
    elif "p_y" in final:
        text = f"final p_y = {signed(final['p_y'], 4)} m, p_z = {signed(final['p_z'], 4)} m"
    else:
        e_1, e_2 = final["cross_track"]
        text = (
            f"final cross-track error = {final['cross_track_error']:.4f} m "
            f"({axes[0]} {signed(e_1, 4)} m, {axes[1]} {signed(e_2, 4)} m) "
            f"at along-track s = {final['along_track']:.2f} m"
        )
    if "u" in final:
        text += f", u = {final['u']:.4f} m/s, phi_tilde = {final['phi_tilde']:.4f} rad"
    return text


def live_path_points(scenario, n: int = 400) -> np.ndarray:
    """The path to draw before a run: the scenario's path from 5 m behind the start's closest
    point to 20 % beyond the arc length covered at the desired speed, (n, 3) world points [m]."""
    path = scenario.path_to_follow
    s0 = path.closest(scenario.start).s
    speed = max(abs(float(scenario.controller_gains.u_d)), 0.1)
    return path.sample((s0 - 5.0, s0 + 1.2 * speed * scenario.duration + 5.0), n)


def _fork_context():
    """A ``fork`` multiprocessing context on Linux (cheap: the child shares the result), else None."""
    import multiprocessing

    if sys.platform != "linux" or "fork" not in multiprocessing.get_all_start_methods():
        return None
    return multiprocessing.get_context("fork")


def _second_process(parallel: bool):
    """The fork context :func:`_run_tasks` draws with, or None where the tasks run here in order."""
    return _fork_context() if parallel and (os.cpu_count() or 1) > 1 else None


def _die_with_parent(parent: int) -> None:
    """Initializer of the figure worker: it is killed (SIGKILL) when the process that forked it
    dies, however it dies (:func:`aiauv_pin._internal.parent_death.die_with_parent`)."""
    import signal

    from aiauv_pin._internal.parent_death import die_with_parent

    die_with_parent(parent, signal.SIGKILL)


def _task_worker(tasks, taken, sender, parent: int) -> None:
    """The forked process of :func:`_run_tasks`: take tasks, then send ``None`` or the exception."""
    _die_with_parent(parent)
    _forget_parsed_math()
    failure = None
    try:
        _take_tasks(tasks, taken)
    except BaseException as exc:  # reported to the parent, which raises it
        failure = exc
    try:
        sender.send(failure)
    except Exception:  # an exception that does not pickle
        sender.send(RuntimeError(f"{failure.__class__.__name__}: {failure}"))


def _run_tasks(tasks, parallel: bool = True, here_first=None):
    """Run zero-argument ``tasks`` (slowest first) in this process and one forked process.

    Each process takes the next task nobody has taken, so both finish about together whatever
    each task costs. The forked process (Linux, more than one CPU, ``parallel``) shares the run
    without copying it, and is killed if this one dies (:func:`_die_with_parent`). Otherwise the
    tasks run here, in order.

    Args:
        tasks: What to run; only side effects (files) count.
        parallel: Use a second process where possible.
        here_first: Run in this process before it takes tasks (while the other process starts on
            them); its value is returned.

    Raises:
        The exception of a failed task: at once (the forked process is stopped) if it failed
        here; once this process has run the tasks left, if it failed in the forked process.
    """
    context = _second_process(parallel)
    if context is None or len(tasks) < 2:
        value = here_first() if here_first is not None else None
        for task in tasks:
            task()
        return value
    taken = context.Value("i", 0)
    receiver, sender = context.Pipe(duplex=False)
    worker = context.Process(
        target=_task_worker, args=(tasks, taken, sender, os.getpid()), name="aiauv-figures"
    )
    worker.start()
    sender.close()
    try:
        value = here_first() if here_first is not None else None
        _take_tasks(tasks, taken)
    except BaseException:
        worker.kill()
        worker.join()
        raise
    try:
        failure = receiver.recv()
    except EOFError:  # died without a word (killed)
        worker.join()
        failure = RuntimeError(f"the figure process died (exit status {worker.exitcode})")
    worker.join()
    receiver.close()
    if failure is not None:
        raise failure
    return value


def write_figures(
    result: ScenarioResult,
    folder: Path,
    *,
    parallel: bool = True,
    figure_format: str = "png",
    vehicle_name: str | None = None,
    path_points: np.ndarray | None = None,
    cross_track_axes: tuple[str, str] | None = None,
) -> list[Path]:
    """The figures of ``result`` (:func:`figures_of`): the paper's Figs. 2-7 and the 3-D path
    (:data:`FIGURES`) with its controller, the cross-track errors and the 3-D path for another run
    that follows a path, the base's motion and the 3-D trajectories for a run that follows none.
    Every axis is labelled with its unit.

    Error figures (cross-track, ``phi_tilde``, ``omega_tilde``) have a log-scale panel of the
    error's magnitude under the linear one, so that final errors of 1e-5 are visible; the 3-D path
    has equal axes. With ``parallel`` (on Linux, with more than one CPU) a forked process draws
    some of them while this one draws the others (:func:`_run_tasks`); that process is killed if
    this one dies (:func:`_die_with_parent`).

    Args:
        result: The run.
        folder: Where to write.
        parallel: Draw in two processes where possible.
        figure_format: ``"png"`` (:data:`FIGURE_DPI` dpi), ``"svg"`` or ``"pdf"``.
        vehicle_name: Name in the titles (default: the scenario's case).
        path_points: The path drawn in the 3-D figure, world points (N, 3) [m] (default:
            :func:`default_path_points`).
        cross_track_axes: What the cross-track errors are (default:
            :func:`run_cross_track_axes`).

    Returns:
        The files written, in the order of :func:`figures_of`.
    """
    _prepare_figures(figure_format)
    folder = Path(folder)
    data = figure_data(
        result,
        vehicle_name=vehicle_name,
        path_points=path_points,
        cross_track_axes=cross_track_axes,
    )
    _run_tasks(_figure_tasks(data, folder, figure_format), parallel)
    return [figure_path(folder, name, figure_format) for name in data.names]


def figure_data(
    result: ScenarioResult,
    *,
    vehicle_name: str | None = None,
    path_points: np.ndarray | None = None,
    cross_track_axes: tuple[str, str] | None = None,
) -> FigureData:
    """What the figures of ``result`` draw (:func:`figures_of`), with the arguments of
    :func:`write_figures` (the path and the cross-track axes found here when not given: a user's
    path runs its own code, which a figure process need not load)."""
    trajectory = result.trajectory
    info = trajectory.info
    followed = result.followed_path is not None
    if path_points is None and followed:
        path_points = default_path_points(result)
    if cross_track_axes is None and followed:
        cross_track_axes = run_cross_track_axes(result)
    return FigureData(
        names=figures_of(result),
        title=vehicle_name if vehicle_name else result.scenario.case,
        t=np.asarray(trajectory.t),
        q=np.asarray(trajectory.q),
        v=np.asarray(trajectory.v),
        info={key: np.asarray(info[key]) for key in DRAWN_INFO if key in info},
        u_d=float(result.scenario.controller_gains.u_d),
        velocity_control=result.scenario.controller == "velocity",
        thruster_names=tuple(result.thruster_names),
        joint_names=tuple(result.joint_names),
        path_points=path_points,
        cross_track_axes=None if cross_track_axes is None else tuple(cross_track_axes),
    )


def write_results(
    result: ScenarioResult,
    out_dir: Path,
    extra: dict | None = None,
    *,
    figure_format: str = "png",
    vehicle_name: str | None = None,
    path_points: np.ndarray | None = None,
    also: Sequence[Callable[[], object]] = (),
    parallel: bool = True,
    figures: bool = True,
    streamed=None,
    figure_workers=None,
) -> dict:
    """Write every result file of a run into ``out_dir``; return the summary.

    The files are written by two processes where possible (see :func:`_run_tasks`), ``also``
    first (the slowest, e.g. the playback page), then the figures; ``timeseries.csv`` and
    ``summary.json`` are written here meanwhile.

    Args:
        result: The run.
        out_dir: The output folder.
        extra: Entries added to ``summary.json``.
        figure_format: See :func:`write_figures`.
        vehicle_name: Name in the figure titles (default: the stem of ``extra["vehicle"]``, else
            the scenario's case).
        path_points: See :func:`write_figures`.
        also: More tasks that write files (zero-argument callables), run beside the figures,
            in this process or in the forked one (so only their files count).
        parallel: See :func:`write_figures`.
        figures: Draw ``figures/`` (``False``: only the data files and ``also``; matplotlib is
            then not imported).
        streamed: Rows of ``timeseries.csv`` formatted during the run (see
            :func:`write_timeseries`).
        figure_workers: The :class:`aiauv_pin.results.figure_workers.FigureWorkers` started
            before the run (it logged into their shared log): they draw the figures while this
            process writes the other files alone (matplotlib is then not imported here). They
            are stopped once the files are written, or writing failed.
    """
    out_dir = Path(out_dir)
    if vehicle_name is None and extra and extra.get("vehicle"):
        vehicle_name = Path(str(extra["vehicle"])).stem
    files = functools.partial(
        _write_files,
        result,
        out_dir,
        extra,
        figure_format=figure_format,
        drawing={"vehicle_name": vehicle_name, "path_points": path_points},
        also=also,
        streamed=streamed,
    )
    if figure_workers is None:
        return files(figures=figures, parallel=parallel)
    try:
        if not figures:
            return files(figures=False, parallel=parallel)
        out_dir.mkdir(parents=True, exist_ok=True)
        data = figure_data(result, vehicle_name=vehicle_name, path_points=path_points)
        sent = figure_workers.draw(data, out_dir / "figures", figure_format=figure_format)
        if not sent:  # data that does not pickle: drawn here
            figure_workers.close()
            return files(figures=True, parallel=parallel)
        # the figure processes take both cores: the rest is written here
        content = files(figures=False, parallel=False)
        figure_workers.wait()
        return content
    finally:
        figure_workers.close()


def _write_files(
    result: ScenarioResult,
    out_dir: Path,
    extra: dict | None,
    *,
    figure_format: str,
    drawing: dict,
    also: Sequence[Callable[[], object]],
    streamed,
    figures: bool,
    parallel: bool,
) -> dict:
    """:func:`write_results` with the figures drawn here (and by a process forked now)."""
    if figures:
        _prepare_figures(figure_format)
    out_dir.mkdir(parents=True, exist_ok=True)
    tasks = [
        *also,
        *(
            _figure_tasks(figure_data(result, **drawing), out_dir / "figures", figure_format)
            if figures
            else ()
        ),
    ]
    head, rest = _table_parts(result, streamed)
    # the data files alone: the summary's energy (array arithmetic and compiled sums, which
    # release the GIL) in a thread beside the table's last rows; never beside a fork (a thread's
    # locks are not the child's)
    energy = None
    if not tasks:
        energy = ThreadPoolExecutor(max_workers=1, thread_name_prefix="aiauv-energy")
    given = None if energy is None else energy.submit(energy_summary, result).result
    try:

        def here_first():
            _write_table(out_dir / "timeseries.csv", head, rest)
            return write_summary(result, out_dir / "summary.json", extra, given)

        return _run_tasks(tasks, parallel, here_first=here_first)
    finally:
        if energy is not None:
            energy.shutdown()
