"""Parameter sweeps and Monte Carlo studies of the path-following scenario on Dask.

:func:`run_sweep` expands a spec (:mod:`aiauv_pin.scenario.sweep_spec`) into runs, skips those already in the
output folder, and runs the others on Dask: by default a ``LocalCluster`` of one worker process on
this machine with one thread per usable core (each run's simulation is the compiled loop of
:func:`aiauv_pin.simulate`, which releases the GIL, so the threads of one process use every core,
as :func:`aiauv_pin.rollout` does; one process loads the compiled code and the vehicle once instead
of once per core, and each thread keeps its own copy of the vehicle), or an existing cluster given
by its scheduler address. The output folder holds

* ``runs/<run_id>.json``: one record per finished run, written atomically by the client as soon as
  the run finishes; these files are the source of truth, so an interrupted sweep loses at most the
  runs in flight, and running the same spec again executes only the runs without a record;
* ``results.csv``: one row per run of the spec (parameters, final errors, settling times, thruster
  and joint work, wall time, status, message), rebuilt from the records and replaced atomically
  while the sweep runs (at most once a second) and at its end;
* ``sweep.json``: the run ids of the spec in order and the count of each status;
* ``spec.toml``: a copy of the spec file; ``figures/``: summary plots (:func:`plot_sweep`).

A run ends with one of :data:`STATUSES`: ``complete``; ``diverged`` (the state became non-finite;
the message names the time); ``error`` (the simulation raised; the message is the exception); or
``lost`` (the task could not run, or its worker died in each of :data:`MAX_ATTEMPTS` attempts: a
run whose worker dies is submitted again). ``lost`` runs are run again by the next invocation; the
other three are deterministic and kept.

Safety: the output folder is new, empty or one a sweep wrote (its manifest ``.aiauv-run.json``,
:func:`aiauv_pin._internal.result_folder.claim_folder`), and every file is written through
:mod:`aiauv_pin._internal.atomic` inside it, never through a link planted in it (``runs``, ``figures``); a
sweep holds an exclusive lock on its output folder (``.sweep.lock``, opened inside it with
``O_NOFOLLOW``; a second sweep on the same folder stops with one line); ``--workers`` is at most
:data:`MAX_WORKERS_PER_CORE` per usable core; workers load each vehicle from a private per-user
cache (:func:`vehicle_cache_folder`, mode 0700, owner and mode checked) whose files are used only if
their content has the expected SHA-256; ``aiauv sweep`` exits non-zero when every run failed (none
``complete``) or runs were lost.
"""

from __future__ import annotations

import contextlib
import csv
import datetime
import hashlib
import io
import json
import math
import os
import socket
import stat
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from aiauv_pin._internal.atomic import atomic_path, write_text
from aiauv_pin.errors import AiauvError, SimulationDiverged
from aiauv_pin.scenario.sweep_spec import (
    PARAMETERS,
    RESOLVED_NAMES,
    SweepPoint,
    SweepSpec,
    is_parameter_column,
    load_sweep_spec,
)
from aiauv_pin.scenario.sweep_spec import components as parameter_components

#: Every status a run record can have.
STATUSES = ("complete", "diverged", "error", "lost")
#: Statuses whose runs are executed again when the sweep is run again.
RETRIED_STATUSES = ("lost",)
#: At most this many local worker processes per usable core (``--workers``).
MAX_WORKERS_PER_CORE = 4
#: A run whose worker died is submitted again up to this many times in all before it is ``lost``.
MAX_ATTEMPTS = 3
#: Lock file in the output folder, held (``flock``) while a sweep runs on it.
LOCK_FILE = ".sweep.lock"
#: Metric columns of ``results.csv`` before the per-thruster and per-joint work.
METRIC_COLUMNS = (
    "final.p_y",
    "final.p_z",
    "final.cross_track_error",
    "final.u",
    "final.phi_tilde",
    "final.omega_tilde.0",
    "final.omega_tilde.1",
    "final.max_abs_u_error_last_30s",
    "final.max_phi_tilde_last_30s",
    "settling_time.p_y_5cm",
    "settling_time.p_z_5cm",
    "settling_time.cross_track_5cm",
    "settling_time.u_1cm_s",
    "settling_time.phi_tilde_0.02rad",
    "total_thruster_work",
    "total_joint_work",
    "simulated_time",
    "steps",
    "wall_time",
    "real_time_factor",
)
_LEADING_COLUMNS = ("run_id", "status", "message", "index", "sample", "vehicle")
_TRAILING_COLUMNS = ("worker", "started_at", "finished_at", "task_time")


class SweepError(AiauvError, RuntimeError):
    """A sweep that cannot run (no scheduler, no workers); the message is one line."""


def _one_line(text: str, limit: int = 500) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")


# --- the task (runs on a worker) -----------------------------------------------------------------

#: Loaded vehicles by (URDF SHA-256, thread): a vehicle holds scratch memory (Pinocchio's data, the
#: compiled workspace) that two simulations must not share, so each worker thread loads its own.
_VEHICLES: dict[tuple[str, int], object] = {}


def vehicle_cache_folder() -> Path:
    """This user's private folder of sweep vehicles: ``$TMPDIR/aiauv-sweep-vehicles-<uid>``.

    Created with mode 0700; an existing one must be a real folder (not a link) owned by this user
    with no access for others, else :class:`SweepError` (another user could plant files there).
    """
    uid = os.getuid() if hasattr(os, "getuid") else None
    suffix = f"-{uid}" if uid is not None else ""
    folder = Path(tempfile.gettempdir()) / f"aiauv-sweep-vehicles{suffix}"
    with contextlib.suppress(FileExistsError):
        folder.mkdir(mode=0o700)
    info = os.lstat(folder)
    if (
        not stat.S_ISDIR(info.st_mode)
        or (uid is not None and info.st_uid != uid)
        or (uid is not None and info.st_mode & 0o077)
    ):
        raise SweepError(
            f"{folder}: the vehicle cache must be a folder owned by this user with mode 0700 "
            f"(found owner {info.st_uid}, mode {stat.S_IMODE(info.st_mode):o}); remove it"
        )
    return folder


def _vehicle_from_text(urdf_text: str, sha256: str):
    """Load (once per worker thread) the vehicle of this URDF text.

    The text goes through the private cache (:func:`vehicle_cache_folder`) under the name of its
    own SHA-256; a cached file is used only if its content has that hash (else it is rewritten).
    """
    data = urdf_text.encode("utf-8")
    digest = hashlib.sha256(data).hexdigest()
    key = (digest, threading.get_ident())
    if key not in _VEHICLES:
        from aiauv_pin.description.input_limits import read_bytes
        from aiauv_pin.model.loading import load_vehicle

        path = vehicle_cache_folder() / f"{digest}.urdf"
        try:
            cached = hashlib.sha256(read_bytes(path, "URDF")).hexdigest()
        except AiauvError:
            cached = None
        if cached != digest:
            with atomic_path(path) as temporary:
                temporary.write_bytes(data)
        vehicle = load_vehicle(path)
        if hashlib.sha256(read_bytes(path, "URDF")).hexdigest() != digest:
            raise SweepError(f"{path}: cached vehicle changed while loaded")
        _VEHICLES[key] = vehicle
    return _VEHICLES[key]


def flatten_summary(summary: dict) -> dict:
    """The metrics of :func:`aiauv_pin.scenario.definition.summary` as flat ``a.b`` keys (no parameters).

    ``final.cross_track_error`` [m] and ``settling_time.cross_track_5cm`` [s] are there for every
    run that follows a path (not a passive one), ``final.p_y``, ``final.p_z`` and their settling
    times on the paper's x-axis only, the surge, pointing error and work when the paper's
    controller ran, the base's motion (``final.base_*``) for every run.
    """
    flat: dict = {}
    skip = {"parameters", "case", "status", "message", "dt", "method", "path", "controller"}

    def walk(prefix: str, value) -> None:
        if isinstance(value, dict):
            for key, item in value.items():
                walk(f"{prefix}.{key}" if prefix else str(key), item)
        elif isinstance(value, (list, tuple)):
            for k, item in enumerate(value):
                walk(f"{prefix}.{k}", item)
        else:
            flat[prefix] = value

    for key, value in summary.items():
        if key not in skip:
            walk(key, value)
    return flat


def execute_run(run_id: str, parameters: dict, urdf_text: str, urdf_sha256: str) -> dict:
    """Simulate one run and return its record; never raises for a failing simulation.

    Args:
        run_id: Key of the run.
        parameters: Resolved parameters (:data:`aiauv_pin.scenario.sweep_spec.RESOLVED_NAMES`).
        urdf_text: The vehicle's URDF (sent to the worker, which may not share our files).
        urdf_sha256: Its SHA-256 (the worker loads each vehicle once).

    Returns:
        ``run_id``, ``status``, ``message``, ``parameters``, ``metrics`` (flat, SI units),
        ``worker`` (``host:pid``), ``started_at``, ``finished_at`` (ISO 8601, UTC), ``task_time``
        [s].
    """
    from aiauv_pin.scenario.definition import run_scenario, summary
    from aiauv_pin.scenario.sweep_spec import scenario_from_parameters

    started_at, start = _now(), time.perf_counter()
    metrics: dict = {}
    try:
        vehicle = _vehicle_from_text(urdf_text, urdf_sha256)
        scenario = scenario_from_parameters(parameters)
        simulation_start = time.perf_counter()
        try:
            result = run_scenario(vehicle, scenario)
        except SimulationDiverged as exc:
            from aiauv_pin.model.validation import explain_divergence

            status, message = (
                "diverged",
                _one_line(explain_divergence(vehicle, scenario.dt, str(exc))),
            )
            metrics = {
                "simulated_time": float(exc.time),
                "wall_time": time.perf_counter() - simulation_start,
            }
        else:
            status, message = "complete", ""
            metrics = flatten_summary(summary(result))
    except Exception as exc:
        status, message = "error", _one_line(f"{exc.__class__.__name__}: {exc}")
    return {
        "run_id": run_id,
        "status": status,
        "message": message,
        "parameters": dict(parameters),
        "metrics": metrics,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "started_at": started_at,
        "finished_at": _now(),
        "task_time": time.perf_counter() - start,
    }


# --- records and the table -----------------------------------------------------------------------


def runs_folder(out: str | os.PathLike) -> Path:
    """Folder of the per-run records of a sweep's output folder."""
    return Path(out) / "runs"


def write_record(out: str | os.PathLike, record: dict) -> Path:
    """Write one run record atomically to ``runs/<run_id>.json``."""
    path = runs_folder(out) / f"{record['run_id']}.json"
    write_text(path, json.dumps(record, indent=1, allow_nan=True) + "\n", root=out)
    return path


def read_records(out: str | os.PathLike) -> dict[str, dict]:
    """Every run record of an output folder, by run id (unreadable files are skipped)."""
    records: dict[str, dict] = {}
    folder = runs_folder(out)
    if not folder.is_dir():
        return records
    for path in sorted(folder.glob("*.json")):
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            continue
        if isinstance(record, dict) and record.get("run_id") == path.stem:
            records[path.stem] = record
    return records


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def table_rows(points: Sequence[SweepPoint], records: dict[str, dict]) -> list[dict]:
    """One flat row per point that has a record (in sweep order)."""
    rows = []
    for point in points:
        record = records.get(point.run_id)
        if record is None:
            continue
        row = {
            "run_id": point.run_id,
            "status": record["status"],
            "message": record["message"],
            "index": point.index,
            "sample": point.sample,
            "vehicle": str(point.vehicle),
            **point.parameters,
            **record.get("metrics", {}),
        }
        for key in _TRAILING_COLUMNS:
            row[key] = record.get(key)
        rows.append(row)
    return rows


def write_table(
    rows: Sequence[dict], path: str | os.PathLike, *, root: str | os.PathLike | None = None
) -> Path:
    """Write rows as CSV atomically: the run, its resolved parameters, the metrics present in some
    row (``final.p_y`` only on the x-axis path, ``final.u`` only with the paper's controller), then
    per-thruster and per-joint work."""
    keys = dict.fromkeys(key for row in rows for key in row)
    parameters = [name for name in RESOLVED_NAMES if name in keys or not rows]
    parameters += [k for k in keys if is_parameter_column(k) and k not in parameters]
    metrics = [name for name in METRIC_COLUMNS if name in keys]
    columns = [*_LEADING_COLUMNS, *parameters, *metrics]
    extra = [key for key in keys if key not in columns and key not in _TRAILING_COLUMNS]
    columns += [*extra, *_TRAILING_COLUMNS]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row.get(column)) for column in columns])
    return write_text(path, buffer.getvalue(), root=root)


def read_table(path: str | os.PathLike) -> list[dict[str, str]]:
    """The rows of a ``results.csv`` (values as strings; empty for none)."""
    with open(path, newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


# --- plots ---------------------------------------------------------------------------------------

_PLOTTED = (
    ("settling_time.cross_track_5cm", "cross-track settling time (5 cm) [s]"),
    ("final.cross_track_error", "final cross-track error [m]"),
    ("total_thruster_work", "thruster work [J]"),
)


def _number(value) -> float:
    return (
        float(value)
        if isinstance(value, (int, float)) and not isinstance(value, bool)
        else math.nan
    )


def _plot_axes(spec: SweepSpec, rows: Sequence[dict]) -> list[tuple[str, str, bool]]:
    """Swept numeric quantities that vary across ``rows``: (column, label, from the grid).

    A vector swept as a scalar (``k_e = [...]``, every component equal in every row) is one
    quantity, the column of its first component labelled with the vector's name.
    """
    found: list[tuple[str, str, bool]] = []
    sections = [(name, True) for name in spec.grid_names]
    sections += [(name, False) for name in spec.random_names]
    for name, in_grid in sections:
        components = parameter_components(name)
        if PARAMETERS.get(components[0], ("",))[0] != "number":
            continue
        if len(components) > 1 and all(len({row.get(c) for c in components}) == 1 for row in rows):
            candidates = [(components[0], name)]
        else:
            candidates = [(c, c if len(components) > 1 else name) for c in components]
        for column, label in candidates:
            if len({row.get(column) for row in rows}) > 1 and column not in (f[0] for f in found):
                found.append((column, label, in_grid))
    return found


def plot_sweep(
    spec: SweepSpec,
    rows: Sequence[dict],
    folder: str | os.PathLike,
    *,
    figure_format: str = "png",
    root: str | os.PathLike | None = None,
) -> list[Path]:
    """Summary plots of a sweep (matplotlib, Agg; each file written atomically).

    * ``metrics_vs_parameters.png``: settling time, final cross-track error and thruster work
      against each swept numeric parameter (runs that never settle drawn at the duration as open
      triangles, diverged and failed runs as red crosses on the axis);
    * ``settling_time_<a>_<b>.png`` and ``cross_track_error_<a>_<b>.png`` for the first two swept
      numeric grid parameters: the mean over the other parameters in each cell of the plane (grey:
      no value), each cell labelled ``k/n``: k of its n runs have a value (settled, for the
      settling time), and ``D`` if a run diverged or failed there.

    Figures are PNG at 200 dpi, or SVG or PDF with ``figure_format``.

    Returns:
        The files written.
    """
    from matplotlib.figure import Figure

    folder = Path(folder)
    written: list[Path] = []

    def save(fig, name: str) -> None:
        path = folder / Path(name).with_suffix(f".{figure_format}")
        with atomic_path(path, root=root) as temporary:  # root: the sweep's --out
            fig.savefig(temporary, dpi=200, format=figure_format)
        written.append(path)

    axes_of = _plot_axes(spec, rows)
    numeric = [key for key, _, _ in axes_of]
    labels = {key: label for key, label, _ in axes_of}
    if not rows or not numeric:
        return written
    failed = [row["status"] not in ("complete",) for row in rows]

    fig = Figure(figsize=(3.6 * len(numeric), 2.8 * len(_PLOTTED)), layout="constrained")
    axes = fig.subplots(len(_PLOTTED), len(numeric), squeeze=False)
    for j, name in enumerate(numeric):
        x = np.array([_number(row.get(name)) for row in rows])
        for i, (metric, label) in enumerate(_PLOTTED):
            ax = axes[i, j]
            y = np.array([_number(row.get(metric)) for row in rows])
            ok = ~np.array(failed) & np.isfinite(y)
            ax.plot(x[ok], y[ok], "o", ms=4, alpha=0.7, color="C0")
            if metric.startswith("settling_time"):
                never = ~np.array(failed) & ~np.isfinite(y)
                durations = np.array([_number(row.get("duration")) for row in rows])
                ax.plot(
                    x[never], durations[never], "^", mfc="none", color="C1", label="not settled"
                )
            bad = np.array(failed)
            if bad.any():
                bottom = np.nanmin(y[ok]) if ok.any() else 0.0
                ax.plot(
                    x[bad], np.full(bad.sum(), bottom), "x", color="red", label="diverged/error"
                )
            if i == len(_PLOTTED) - 1:
                ax.set_xlabel(labels[name])
            if j == 0:
                ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
            if i == 0 and j == 0 and ax.get_legend_handles_labels()[0]:
                ax.legend(fontsize=7)
    counts = {s: sum(row["status"] == s for row in rows) for s in STATUSES}
    fig.suptitle(", ".join(f"{n} {s}" for s, n in counts.items() if n))
    save(fig, "metrics_vs_parameters.png")

    grid_numeric = [key for key, _, in_grid in axes_of if in_grid]
    if len(grid_numeric) >= 2:
        a, b = grid_numeric[:2]
        xs = sorted({row[a] for row in rows})
        ys = sorted({row[b] for row in rows})
        for metric, label, name in (
            ("settling_time.cross_track_5cm", _PLOTTED[0][1], "settling_time"),
            ("final.cross_track_error", _PLOTTED[1][1], "cross_track_error"),
        ):
            values = np.full((len(ys), len(xs)), math.nan)
            diverged = np.zeros((len(ys), len(xs)), dtype=bool)
            cells: dict[tuple[int, int], list[float]] = {}
            for row, bad in zip(rows, failed, strict=True):
                key = (ys.index(row[b]), xs.index(row[a]))
                if bad:
                    diverged[key] = True
                else:
                    cells.setdefault(key, []).append(_number(row.get(metric)))
            for key, items in cells.items():
                finite = [x for x in items if math.isfinite(x)]
                if finite:
                    values[key] = float(np.mean(finite))
            fig = Figure(figsize=(6.0, 4.6), layout="constrained")
            ax = fig.subplots()
            ax.set_facecolor("0.8")
            mesh = ax.pcolormesh(np.arange(len(xs)), np.arange(len(ys)), values, shading="nearest")
            fig.colorbar(mesh, ax=ax, label=f"{label} (mean)")
            for (r, c), flag in np.ndenumerate(diverged):
                items = cells.get((r, c), [])
                finite = sum(math.isfinite(x) for x in items)
                text = f"{finite}/{len(items)}" if items else ""
                text = f"{text} D" if flag else text
                if text:
                    colour = "red" if flag or finite < len(items) else "white"
                    ax.text(c, r, text.strip(), ha="center", va="center", color=colour, fontsize=8)
            ax.set_xticks(range(len(xs)), [f"{v:.4g}" for v in xs])
            ax.set_yticks(range(len(ys)), [f"{v:.4g}" for v in ys])
            ax.set_xlabel(labels[a])
            ax.set_ylabel(labels[b])
            counted = "settled" if name == "settling_time" else "with a value"
            ax.set_title(
                f"{label} over ({labels[a]}, {labels[b]}); cells: runs {counted}/runs", fontsize=9
            )
            save(fig, f"{name}_{labels[a]}_{labels[b]}.png")
    return written


# --- running -------------------------------------------------------------------------------------


@dataclass
class SweepReport:
    """What :func:`run_sweep` did.

    Attributes:
        out: Output folder.
        total: Runs of the spec.
        skipped: Runs that already had a record and were not executed again.
        executed: Runs executed by this call (records written).
        counts: Runs of the spec per status (after this call).
        table: The ``results.csv`` written.
        figures: Plots written.
        executed_ids: Run ids executed by this call, in order of completion.
    """

    out: Path
    total: int
    skipped: int
    executed: int
    counts: dict[str, int]
    table: Path
    figures: list[Path] = field(default_factory=list)
    executed_ids: list[str] = field(default_factory=list)


@contextlib.contextmanager
def dask_client(
    scheduler: str | None = None, workers: int | None = None, worker_timeout: float = 60.0
):
    """A Dask client: on an existing scheduler, or on a new ``LocalCluster`` of one worker process.

    The local worker runs ``workers`` simulations at once on as many threads: the compiled loop
    releases the GIL, so they share no core (only each run's set-up and summary hold the GIL), and
    a worker process that dies still has its runs submitted again (to the one the nanny restarts).

    Args:
        scheduler: Scheduler address (``tcp://host:8786``); ``None`` starts a ``LocalCluster``.
        workers: Threads of the local worker process, i.e. runs at once (default: the usable cores).
        worker_timeout: How long to wait for a first worker on an existing scheduler [s].

    Raises:
        SweepError: The scheduler cannot be reached or no worker joins it in time.
    """
    import logging

    from dask.distributed import Client, LocalCluster

    if scheduler is None:
        cores = usable_cores()
        count = workers if workers is not None else cores
        if isinstance(count, bool) or not (isinstance(count, int) and count >= 1):
            raise SweepError(f"workers must be a whole number >= 1, got {count!r}")
        if count > MAX_WORKERS_PER_CORE * cores:
            raise SweepError(
                f"workers must be at most {MAX_WORKERS_PER_CORE * cores} "
                f"({MAX_WORKERS_PER_CORE} per usable core), got {count}"
            )
        cluster = LocalCluster(
            n_workers=1,
            threads_per_worker=count,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
        try:
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()
        return
    try:
        client = Client(scheduler, timeout="15s")
    except (OSError, ValueError, TypeError) as exc:
        raise SweepError(
            f"cannot reach the Dask scheduler at {scheduler}: {_one_line(exc)}"
        ) from None
    try:
        try:
            client.wait_for_workers(1, timeout=worker_timeout)
        except (TimeoutError, OSError):
            raise SweepError(
                f"no Dask worker joined the scheduler at {scheduler} within {worker_timeout:g} s"
            ) from None
        yield client
    finally:
        client.close()


def usable_cores() -> int:
    """CPU cores this process may run on (at least 1)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def output_lock(out: Path):
    """Hold an exclusive ``flock`` on ``out/.sweep.lock`` (released when the process dies).

    Raises:
        SweepError: Another sweep holds it.
    """
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    from aiauv_pin._internal.atomic import open_inside

    handle = open_inside(out, LOCK_FILE)  # inside out, never through a link
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SweepError(
                f"{out}: another sweep is running on this output folder; wait for it or use "
                "another --out"
            ) from None
        yield
    finally:
        os.close(handle)


def _lost_record(point: SweepPoint, reason: str) -> dict:
    return {
        "run_id": point.run_id,
        "status": "lost",
        "message": _one_line(reason),
        "parameters": point.parameters,
        "metrics": {},
        "worker": None,
        "started_at": None,
        "finished_at": _now(),
        "task_time": None,
    }


def _write_outputs(out: Path, points, spec_text: str | None) -> tuple[Path, dict[str, int]]:
    records = read_records(out)
    rows = table_rows(points, records)
    table = write_table(rows, out / "results.csv", root=out)
    counts = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
    counts["pending"] = len(points) - len(rows)
    manifest = {"runs": [p.run_id for p in points], "counts": counts}
    write_text(out / "sweep.json", json.dumps(manifest, indent=1) + "\n", root=out)
    if spec_text is not None:
        write_text(out / "spec.toml", spec_text, root=out)
    return table, counts


def run_sweep(
    spec: SweepSpec | str | os.PathLike,
    out: str | os.PathLike,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    plots: bool = True,
    on_record: Callable[[dict], None] | None = None,
    figure_format: str = "png",
) -> SweepReport:
    """Run every run of a spec that has no record in ``out`` yet, on Dask.

    Records are written as runs finish, and ``results.csv`` is rewritten (atomically) at most once a
    second and at the end, also when interrupted; interrupting loses only the runs in flight.

    Args:
        spec: A parsed spec, or the path of a spec TOML file (copied to ``out/spec.toml``).
        out: Output folder: new (created), empty, or one a sweep wrote (it carries the manifest
            of :func:`aiauv_pin._internal.result_folder.claim_folder`); a real folder, and so are its
            ``runs`` and ``figures`` (links are refused, never written through).
        scheduler: Address of an existing Dask scheduler; ``None`` starts a local cluster.
        workers: Runs at once on the local cluster (threads of its worker process; default: the
            usable cores).
        progress: Show a progress bar over the runs (tqdm, on standard error).
        plots: Write the summary plots into ``out/figures``.
        on_record: Called with each record after it is written (in the client process).
        figure_format: Format of the summary plots: ``"png"`` (200 dpi), ``"svg"`` or ``"pdf"``.

    Returns:
        What was done.

    Raises:
        SweepSpecError: A bad spec (one line).
        VehicleLoadError: A vehicle that cannot be loaded.
        SweepError: No scheduler or no worker.
        OutputPathError: ``out`` holds foreign content or links (one line).
    """

    spec_text = None
    if not isinstance(spec, SweepSpec):
        from aiauv_pin.description.input_limits import read_text

        source = spec
        spec = load_sweep_spec(source)
        spec_text = read_text(source, "sweep spec")
    from aiauv_pin._internal.atomic import real_folder
    from aiauv_pin._internal.result_folder import claim_folder

    out = Path(out)
    points = spec.points()
    claim_folder(out, "sweep", allowed=(LOCK_FILE,))  # new, empty, or a sweep's: never foreign
    for folder in (runs_folder(out), out / "figures"):  # a planted link: refused, never followed
        real_folder(out, folder, create=False)
    with output_lock(out):
        return _run_locked(
            spec,
            spec_text,
            points,
            out,
            scheduler,
            workers,
            progress,
            plots,
            on_record,
            figure_format,
        )


def _run_locked(
    spec, spec_text, points, out, scheduler, workers, progress, plots, on_record, figure_format
):
    from aiauv_pin.description.input_limits import read_text
    from aiauv_pin.model.loading import load_vehicle

    existing = read_records(out)
    done = {key for key, record in existing.items() if record.get("status") not in RETRIED_STATUSES}
    todo = [p for p in points if p.run_id not in done]
    executed: list[str] = []
    try:
        if todo:
            texts: dict[str, str] = {}
            for point in todo:
                sha = point.parameters["vehicle_sha256"]
                if sha not in texts:
                    load_vehicle(point.vehicle)  # one-line error here, not on every worker
                    texts[sha] = read_text(point.vehicle, "URDF")
            _run_points(
                todo,
                texts,
                out,
                scheduler,
                workers,
                progress,
                len(points),
                on_record,
                executed,
                lambda: _write_outputs(out, points, None),
            )
    finally:
        table, counts = _write_outputs(out, points, spec_text)
    figures: list[Path] = []
    if plots:
        figures = plot_sweep(
            spec,
            table_rows(points, read_records(out)),
            out / "figures",
            figure_format=figure_format,
            root=out,
        )
    return SweepReport(
        out=out,
        total=len(points),
        skipped=len(points) - len(todo),
        executed=len(executed),
        counts=counts,
        table=table,
        figures=figures,
        executed_ids=executed,
    )


def _run_points(
    todo: Sequence[SweepPoint],
    texts: dict[str, str],
    out: Path,
    scheduler: str | None,
    workers: int | None,
    progress: bool,
    total: int,
    on_record,
    executed: list[str],
    write_index: Callable[[], object],
) -> None:
    from dask.distributed import as_completed
    from tqdm import tqdm

    token = uuid.uuid4().hex[:8]  # fresh task keys: a cancelled earlier attempt cannot collide
    with dask_client(scheduler, workers) as client:
        # the URDF text travels with each task (a few kB, capped by input_limits): no scattered
        # data that a dying worker could take with it
        by_key = {}
        futures = []
        attempts: dict[str, int] = {}

        def submit(point: SweepPoint):
            attempt = attempts.get(point.run_id, 0) + 1
            attempts[point.run_id] = attempt
            sha = point.parameters["vehicle_sha256"]
            future = client.submit(
                execute_run,
                point.run_id,
                point.parameters,
                texts[sha],
                sha,
                key=f"aiauv-run-{point.run_id}-{token}-{attempt}",
                pure=False,
            )
            by_key[future.key] = point
            futures.append(future)
            return future

        for point in todo:
            submit(point)
        bar = tqdm(
            total=total,
            initial=total - len(todo),
            unit="run",
            desc="sweep",
            disable=not progress,
            file=sys.stderr,
        )
        last_table = time.monotonic()
        try:
            completed = as_completed(list(futures))
            for future in completed:
                point = by_key[future.key]
                record = None
                if future.status == "finished":
                    try:
                        record = future.result()
                    except Exception as exc:
                        reason = f"{exc.__class__.__name__}: {exc}"
                elif future.status == "cancelled":
                    reason = "cancelled"
                else:
                    exc = future.exception()
                    reason = f"{exc.__class__.__name__}: {exc}"
                if record is None:
                    if attempts[point.run_id] < MAX_ATTEMPTS:  # worker died: run it again
                        completed.add(submit(point))
                        continue
                    record = _lost_record(
                        point, f"{reason} (after {attempts[point.run_id]} attempts)"
                    )
                write_record(out, record)
                executed.append(point.run_id)
                bar.update(1)
                if time.monotonic() - last_table > 1.0:
                    write_index()
                    last_table = time.monotonic()
                if on_record is not None:
                    on_record(record)
        finally:
            bar.close()
            client.cancel(futures)


# --- command line --------------------------------------------------------------------------------


def _worker_count(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    bound = MAX_WORKERS_PER_CORE * usable_cores()
    if value > bound:
        raise argparse.ArgumentTypeError(
            f"must be at most {bound} ({MAX_WORKERS_PER_CORE} per usable core), got {value}"
        )
    return value


def add_sweep_subcommand(subparsers) -> None:
    """Register ``aiauv sweep SPEC [--scheduler ADDRESS] [--out DIR]`` on ``add_subparsers()``."""
    parser = subparsers.add_parser(
        "sweep",
        help="run a parameter sweep / Monte Carlo study on Dask",
        description="Run every point of a sweep spec (grid and/or random sample over scenario and "
        "controller parameters) on a Dask cluster: by default a local cluster of worker processes "
        "on this machine's cores, or an existing one with --scheduler. Writes runs/<run_id>.json "
        "as runs finish, results.csv (one row per run), sweep.json and figures/ into the output "
        "folder. Running the same spec again executes only the runs not yet recorded.",
    )
    parser.add_argument("spec", type=Path, help="sweep spec (TOML)")
    parser.add_argument(
        "--scheduler", metavar="ADDRESS", help="existing Dask scheduler, e.g. tcp://host:8786"
    )
    parser.add_argument(
        "--workers",
        type=_worker_count,
        help="runs at once on the local cluster (threads of one worker process; default: all "
        "cores; at most 4 per core)",
    )
    parser.add_argument("--out", type=Path, help="output folder (results/sweeps/<spec name>/)")
    parser.add_argument("--no-plots", action="store_true", help="do not write figures/")
    parser.add_argument(
        "--figure-format",
        choices=("png", "svg", "pdf"),
        default="png",
        help="figures as PNG at 200 dpi, or vector SVG or PDF (png)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=run_sweep_command)


def run_sweep_command(args) -> int:
    """Handler of ``aiauv sweep``: run the sweep, print one summary line.

    Raises:
        SweepError: ``--workers`` with ``--scheduler``, or runs lost (after writing the results).
    """
    if args.scheduler is not None and args.workers is not None:
        raise SweepError("--workers applies to the local cluster only, not with --scheduler")
    out = args.out if args.out is not None else Path("results") / "sweeps" / args.spec.stem
    report = run_sweep(
        args.spec,
        out,
        scheduler=args.scheduler,
        workers=args.workers,
        progress=not args.quiet,
        plots=not args.no_plots,
        figure_format=args.figure_format,
    )
    counts = ", ".join(f"{n} {s}" for s, n in report.counts.items() if n)
    print(
        f"{report.total} runs ({counts}); {report.executed} executed, {report.skipped} already "
        f"done -> {report.table}"
    )
    lost = report.counts["lost"]
    if lost:
        raise SweepError(
            f"{lost} run(s) lost (worker died or task failed to run); run the same command again "
            "to retry them"
        )
    if report.total and report.counts["complete"] == 0:
        raise SweepError(f"every run failed ({counts}); the messages are in {report.table}")
    return 0
