"""Result files of a path-following run: ``timeseries.csv``, ``summary.json`` and ``figures/``.

The run is logged at every controller sample (every step by default) and ``summary.json``'s
integrals (work) and settling times use every logged sample. ``timeseries.csv`` holds every
``csv_period`` of the scenario (0.04 s by default, rounded to a whole number of logged samples;
the last sample is always included; ``None`` writes every sample). The figures draw, per curve,
the minimum and maximum of each of at most :data:`PLOT_BUCKETS` consecutive runs of samples (in
time order), which at their size is indistinguishable from drawing every sample.

Speed: pass :func:`preload_plotting` as ``after_first_chunk`` to
:func:`aiauv_pin.scenario.run_paper_scenario` and matplotlib (about 0.3 s of imports) is imported in a
background thread while the compiled scenario loop runs (its kernels release the GIL); no backend
is selected until figures are written (Agg). The figures are drawn by two processes on Linux.
"""

from __future__ import annotations

import functools
import json
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .atomic import atomic_path, write_text
from .scenario import ScenarioResult, summary

_preload: threading.Thread | None = None
_stop_warming = threading.Event()  # set when the figures are due: the warm-up stops early
_math_parser = None  # one math-text parser for every figure of this process (its cache shared)

#: Math text the figures write (legends, axis labels) and the log axes' tick labels: parsed while
#: the simulation runs (:func:`_warm_math`), so that drawing them in this process only looks them
#: up (a forked figure process parses its own, :func:`_forget_parsed_math`). A string missing here
#: is parsed when drawn, as before.
_MATH_TEXT = (
    "$p_y$",
    "$p_z$",
    "$e_1$",
    "$e_2$",
    "$u$",
    "$u_d$",
    r"$\tilde\phi$ [rad]",
    r"$|\tilde\phi|$ [rad]",
    r"$\tilde\omega_y$",
    r"$\tilde\omega_z$",
    "$q_{y,0}$",
    "$q_{z,0}$",
    *(f"$x^I_{axis}$" for axis in "xyz"),
    *(rf"$x_{{ref,{axis}}}$" for axis in "xyz"),
    *(rf"$\mathdefault{{10^{{{k}}}}}$" for k in range(0, -11, -1)),
)


def _import_plotting() -> None:
    try:
        import matplotlib.backends.backend_agg
        import matplotlib.pyplot  # noqa: F401
        import mpl_toolkits.mplot3d  # noqa: F401

        _warm_plotting()
    except Exception:
        pass


def _warm_plotting() -> None:
    """Draw a small figure off screen with what the figures use first (log axis with math-text
    tick labels, a legend with a math-text label, a title, a 3-D axes), so that matplotlib's lazy
    one-time work (fonts, the math-text grammar, tick and marker set-up) is done, about 0.2 s per
    process, before the figure processes fork. No backend is selected and nothing is written."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2.0, 2.0), dpi=FIGURE_DPI)
    ax = fig.add_subplot(2, 1, 1)
    ax.set_yscale("log")
    ax.plot([0.0, 1.0], [1e-4, 1e-1], label="$u_d$")
    ax.legend()
    ax.set(title="warm-up", xlabel="t [s]")
    fig.add_subplot(2, 1, 2, projection="3d").plot([0.0, 1.0], [0.0, 1.0], [0.0, 1.0])
    FigureCanvasAgg(fig).draw()
    _warm_math()


def _shared_math_parser():
    """The math-text parser of this process's Agg figures (see :func:`_render`).

    It is the one an Agg renderer makes for itself, whose output type differs between matplotlib
    versions (``"agg"`` up to 3.10, ``"path"`` from 3.11, with 6 and 5 values per parse): a parser
    of the other type made every figure with math text fail on Python 3.10, where matplotlib 3.11
    is not available.
    """
    global _math_parser
    if _math_parser is None:
        from matplotlib.backends.backend_agg import RendererAgg

        _math_parser = RendererAgg(1, 1, FIGURE_DPI).mathtext_parser
    return _math_parser


def _math_cache_clear():
    """``cache_clear`` of matplotlib's math-text cache (``MathTextParser._parse_cached``, a private
    ``functools.lru_cache``), or ``None`` if this matplotlib has no such cache."""
    mathtext = sys.modules.get("matplotlib.mathtext")
    if mathtext is None:
        return None
    return getattr(getattr(mathtext.MathTextParser, "_parse_cached", None), "cache_clear", None)


def _warm_math() -> None:
    """Parse :data:`_MATH_TEXT` as the figures' 10-point labels at :data:`FIGURE_DPI`, until the
    figures are due (:data:`_stop_warming`). Only where a forked process can empty the cache again
    (:func:`_forget_parsed_math`): a matplotlib without that private cache gets no warm-up, so its
    figure processes never share parsed text."""
    import matplotlib as mpl
    import matplotlib.mathtext  # what _math_cache_clear looks in
    from matplotlib.font_manager import FontProperties

    if _math_cache_clear() is None:
        return
    parser = _shared_math_parser()
    for size in ("xtick.labelsize", "legend.fontsize", "axes.labelsize"):
        prop = FontProperties(size=mpl.rcParams[size])
        for text in _MATH_TEXT:
            if _stop_warming.is_set():
                return
            parser.parse(text, FIGURE_DPI, prop)


def preload_plotting() -> None:
    """Start importing matplotlib in a background thread, once (no backend is selected)."""
    global _preload
    if _preload is None and "matplotlib.pyplot" not in sys.modules:
        _preload = threading.Thread(target=_import_plotting, name="aiauv-preload", daemon=True)
        _preload.start()


def _wait_for_preload() -> None:
    if _preload is not None:
        _stop_warming.set()
        _preload.join()


def timeseries_columns(result: ScenarioResult) -> dict[str, np.ndarray]:
    """Columns of ``timeseries.csv`` by name, in order.

    Always: time, the end-effector's world position ``p_x, p_y, p_z``, the cross-track errors
    along the path's normals ``e_1, e_2`` and the path parameter ``s``, every joint angle and the base
    position. With the paper's controller also its diagnostics (surge, errors, base angles,
    reference and actual pointing direction, joint references and torques, thrusts).
    """
    tr = result.trajectory
    info = tr.info
    columns: dict[str, np.ndarray] = {
        "t": tr.t,
        "p_x": info["p"][:, 0],
        "p_y": info["p"][:, 1],
        "p_z": info["p"][:, 2],
        "e_1": info["cross_track"][:, 0],
        "e_2": info["cross_track"][:, 1],
        "s": info["path_s"],
    }
    paper = "u" in info
    if paper:
        columns.update(
            {
                "u": info["u"],
                "phi_tilde": info["phi_tilde"],
                "omega_tilde_y": info["omega_tilde"][:, 0],
                "omega_tilde_z": info["omega_tilde"][:, 1],
                "q_y0": info["base_angles"][:, 0],
                "q_z0": info["base_angles"][:, 1],
            }
        )
        for k, axis in enumerate("xyz"):
            columns[f"x_ref_{axis}"] = info["x_ref"][:, k]
        for k, axis in enumerate("xyz"):
            columns[f"pointing_{axis}"] = info["pointing"][:, k]
    for k, name in enumerate(result.joint_names):
        columns[f"q_{name}"] = tr.q[:, 7 + k]
    if paper:
        for k, name in enumerate(result.joint_names):
            columns[f"qref_{name}"] = info["joint_references"][:, k]
        for k, name in enumerate(result.joint_names):
            columns[f"tau_{name}"] = info["joint_torque"][:, k]
        for k, name in enumerate(result.thruster_names):
            columns[f"thrust_{name}"] = info["thrust"][:, k]
    base = tr.q[:, :3]
    for k, axis in enumerate("xyz"):
        columns[f"base_{axis}"] = base[:, k]
    return columns


#: Largest number of min/max buckets per plotted curve (each contributes two points).
PLOT_BUCKETS = 2000


def csv_rows(result: ScenarioResult) -> np.ndarray:
    """Indices of the logged samples written to ``timeseries.csv`` (every ``csv_period``)."""
    t = result.trajectory.t
    n = len(t)
    period = getattr(result.scenario, "csv_period", None)
    if period is None or n < 2:
        return np.arange(n)
    stride = max(1, round(period / float(t[1] - t[0])))
    rows = np.arange(0, n, stride)
    if rows[-1] != n - 1:
        rows = np.append(rows, n - 1)
    return rows


def format_table(header: list[str], table: np.ndarray, fmt: str = "%.9g") -> str:
    """CSV text of a 2-D float table (same text as ``np.savetxt(..., delimiter=",")``)."""
    n_rows, n_columns = table.shape
    line = ",".join([fmt] * n_columns) + "\n"
    body = (line * n_rows) % tuple(table.ravel().tolist()) if n_rows else ""
    return ",".join(header) + "\n" + body


def write_timeseries(result: ScenarioResult, path: Path) -> Path:
    """Write ``timeseries.csv`` (one row per ``csv_period``, see the module docstring; SI, rad)."""
    columns = timeseries_columns(result)
    rows = csv_rows(result)
    table = np.column_stack([column[rows] for column in columns.values()])
    return write_text(path, format_table(list(columns), table))


def envelope(t: np.ndarray, y: np.ndarray, buckets: int = PLOT_BUCKETS):
    """``(t, y)`` reduced to the minimum and maximum of each of ``buckets`` runs of samples.

    The points keep their time order, so a line through them covers the same pixels as one
    through every sample when a bucket is narrower than a pixel. Short series are returned as is.
    """
    n = len(y)
    if n <= 2 * buckets:
        return t, y
    size = -(-n // buckets)
    padded = size * buckets
    index = np.arange(padded).reshape(buckets, size)
    index = np.minimum(index, n - 1)
    values = y[index]
    low = index[np.arange(buckets), np.argmin(values, axis=1)]
    high = index[np.arange(buckets), np.argmax(values, axis=1)]
    keep = np.unique(np.concatenate((low, high, [0, n - 1])))
    return t[keep], y[keep]


def _plot(ax, t, y, *args, **kwargs):
    """``ax.plot`` of the :func:`envelope` of ``(t, y)``."""
    return ax.plot(*envelope(np.asarray(t), np.asarray(y)), *args, **kwargs)


def write_summary(result: ScenarioResult, path: Path, extra: dict | None = None) -> dict:
    """Write ``summary.json`` and return its content."""
    content = summary(result)
    if extra:
        content.update(extra)
    write_text(path, json.dumps(content, indent=2, allow_nan=False) + "\n")
    return content


#: Resolution of PNG figures [dots per inch].
FIGURE_DPI = 200
#: Figure formats: PNG (raster, :data:`FIGURE_DPI`), SVG and PDF (vector).
FIGURE_FORMATS = ("png", "svg", "pdf")

FIGURES = (
    "fig2_cross_track.png",
    "fig3_surge.png",
    "fig4_phi_tilde.png",
    "fig5_omega_tilde.png",
    "fig6_base_angles.png",
    "fig7_pointing.png",
    "path_3d.png",
)
"""File names of the figures, in drawing order."""

#: Extra ``savefig`` options per format: PNG with zlib level 1, the same pixels as the default
#: level 6 in about half the encoding time (files about 20 % larger).
_SAVE_OPTIONS = {"png": {"pil_kwargs": {"compress_level": 1}}}

#: Figures every run has (the others need the paper controller's diagnostics).
PATH_FIGURES = ("fig2_cross_track.png", "path_3d.png")


def figures_of(result: ScenarioResult) -> tuple[str, ...]:
    """The figures drawn for ``result``: all of :data:`FIGURES` with the paper's controller, else
    :data:`PATH_FIGURES`."""
    if "u" in result.trajectory.info:
        return FIGURES
    return PATH_FIGURES


def _error_axes(plt, title: str):
    """A figure with an error panel above its log-scale companion (``|error|``, shared time axis)."""
    fig, (ax, ax_log) = plt.subplots(
        2, 1, figsize=(6, 4.6), sharex=True, gridspec_kw={"height_ratios": (3, 2)}
    )
    ax.set_title(title)
    ax.axhline(0.0, color="k", lw=0.5)
    ax_log.set_yscale("log")
    ax_log.set_xlabel("t [s]")
    ax_log.grid(True, which="major", lw=0.3)
    return fig, ax, ax_log


def _plot_error(ax, ax_log, t, y, **kwargs) -> None:
    """``y`` on the linear panel and ``|y|`` on the log-scale one (zeros are not drawn there)."""
    _plot(ax, t, y, **kwargs)
    magnitude = np.abs(np.asarray(y, dtype=float))
    _plot(ax_log, t, np.where(magnitude > 0.0, magnitude, np.nan), **kwargs)


def default_path_points(result: ScenarioResult, n: int = 400) -> np.ndarray:
    """The drawn path when none is given: the scenario's path over the arc length the end-effector
    covered (its closest points' range, with a margin), (n, 3) world points [m]."""
    s = result.trajectory.info["path_s"]
    low, high = float(np.min(s)), float(np.max(s))
    margin = 0.05 * max(high - low, 1.0)
    return result.scenario.path_to_follow.sample((low - margin, high + margin), n)


def live_path_points(scenario, n: int = 400) -> np.ndarray:
    """The path to draw before a run: the scenario's path from 5 m behind the start's closest
    point to 20 % beyond the arc length covered at the desired speed, (n, 3) world points [m]."""
    path = scenario.path_to_follow
    s0 = path.closest(scenario.start).s
    speed = max(abs(float(scenario.controller_gains.u_d)), 0.1)
    return path.sample((s0 - 5.0, s0 + 1.2 * speed * scenario.duration + 5.0), n)


def _set_equal_axes(ax, points: np.ndarray) -> None:
    """Equal scales on the three axes of a 3-D plot, framing ``points`` (N, 3) [m]."""
    low, high = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
    centre = (low + high) / 2.0
    half = max(float(np.max(high - low)) / 2.0, 1e-3) * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))


def _draw(
    name: str,
    result: ScenarioResult,
    plt,
    *,
    vehicle_name: str | None = None,
    path_points: np.ndarray | None = None,
):
    """The figure ``name`` of :data:`FIGURES`, titled with the vehicle's name.

    Args:
        name: One of :data:`FIGURES`.
        result: The run.
        plt: ``matplotlib.pyplot``.
        vehicle_name: Name in the titles (default: the scenario's case).
        path_points: World points of the path the 3-D figure draws, (N, 3) [m] (default:
            :func:`default_path_points`).
    """
    tr = result.trajectory
    info, t = tr.info, tr.t
    case = vehicle_name if vehicle_name else result.scenario.case
    if name == "fig2_cross_track.png":
        fig, ax, ax_log = _error_axes(plt, f"Cross-track errors ({case})")
        # on the paper's x-axis the path normals are y and z: e_1 = p_y, e_2 = p_z
        labels = ("$p_y$", "$p_z$") if result.scenario.on_x_axis else ("$e_1$", "$e_2$")
        _plot_error(ax, ax_log, t, info["cross_track"][:, 0], label=labels[0])
        _plot_error(ax, ax_log, t, info["cross_track"][:, 1], label=labels[1])
        ax.set_ylabel("cross-track error [m]")
        ax_log.set_ylabel("|error| [m]")
        ax.legend()
    elif name == "fig3_surge.png":
        fig, ax = plt.subplots(figsize=(6, 3.2))
        _plot(ax, t, info["u"], label="$u$")
        u_d = result.scenario.controller_gains.u_d
        ax.axhline(u_d, color="k", ls="--", lw=0.8, label="$u_d$")
        ax.set(xlabel="t [s]", ylabel="surge velocity [m/s]", title=f"Surge velocity ({case})")
        ax.legend()
    elif name == "fig4_phi_tilde.png":
        fig, ax, ax_log = _error_axes(plt, f"Pointing error ({case})")
        _plot_error(ax, ax_log, t, info["phi_tilde"])
        ax.set_ylabel(r"$\tilde\phi$ [rad]")
        ax_log.set_ylabel(r"$|\tilde\phi|$ [rad]")
    elif name == "fig5_omega_tilde.png":
        fig, ax, ax_log = _error_axes(plt, f"Angular velocity error ({case})")
        _plot_error(ax, ax_log, t, info["omega_tilde"][:, 0], label=r"$\tilde\omega_y$")
        _plot_error(ax, ax_log, t, info["omega_tilde"][:, 1], label=r"$\tilde\omega_z$")
        ax.set_ylabel("[rad/s]")
        ax_log.set_ylabel("|error| [rad/s]")
        ax.legend()
    elif name == "fig6_base_angles.png":
        fig, ax = plt.subplots(figsize=(6, 3.2))
        _plot(ax, t, info["base_angles"][:, 0], label="$q_{y,0}$")
        _plot(ax, t, info["base_angles"][:, 1], label="$q_{z,0}$")
        ax.set(xlabel="t [s]", ylabel="[rad]", title=f"Base angles ({case})")
        ax.legend()
    elif name == "fig7_pointing.png":
        fig, axes = plt.subplots(3, 1, figsize=(6, 5), sharex=True)
        for k, axis in enumerate("xyz"):
            _plot(axes[k], t, info["pointing"][:, k], label=f"$x^I_{axis}$")
            _plot(axes[k], t, info["x_ref"][:, k], ls="--", label=rf"$x_{{ref,{axis}}}$")
            axes[k].legend(loc="right")
        axes[-1].set_xlabel("t [s]")
        axes[0].set_title(f"End-effector and reference pointing direction ({case})")
    elif name == "path_3d.png":
        fig = plt.figure(figsize=(6, 4.5))
        ax = fig.add_subplot(projection="3d")
        p = info["p"]
        stride = max(1, len(p) // (2 * PLOT_BUCKETS))  # a smooth space curve: every stride-th point
        path = np.concatenate((p[::stride], p[-1:]))
        ax.plot(path[:, 0], path[:, 1], path[:, 2], label="end-effector")
        drawn = default_path_points(result) if path_points is None else path_points
        drawn = np.asarray(drawn, dtype=float)
        if drawn.ndim != 2 or drawn.shape[1] != 3:
            raise ValueError(f"path_points must be an (N, 3) array, got shape {drawn.shape}")
        ax.plot(drawn[:, 0], drawn[:, 1], drawn[:, 2], "k--", lw=0.8, label="path")
        ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title=f"Path ({case})")
        _set_equal_axes(ax, np.concatenate((path, drawn)))
        ax.legend()
    else:
        raise ValueError(f"unknown figure {name!r}")
    return fig


def figure_path(folder: Path, name: str, figure_format: str = "png") -> Path:
    """File of figure ``name`` (of :data:`FIGURES`) in ``figure_format``."""
    return Path(folder) / Path(name).with_suffix(f".{figure_format}")


#: Fixed margins (fractions of the figure) of each kind of figure: they fit the labels
#: :func:`_draw` writes, and cost nothing, where ``tight_layout`` drew every text once more to
#: measure it (about 40 % of the drawing time).
_MARGINS = {
    "error": {"left": 0.13, "right": 0.97, "bottom": 0.1, "top": 0.93, "hspace": 0.08},
    "single": {"left": 0.12, "right": 0.97, "bottom": 0.15, "top": 0.9},
    "three": {"left": 0.1, "right": 0.97, "bottom": 0.09, "top": 0.94, "hspace": 0.1},
    "3d": {"left": 0.02, "right": 0.92, "bottom": 0.06, "top": 0.93},
}
_LAYOUT_OF = {
    "fig2_cross_track.png": "error",
    "fig4_phi_tilde.png": "error",
    "fig5_omega_tilde.png": "error",
    "fig7_pointing.png": "three",
    "path_3d.png": "3d",
}


def _render(
    result: ScenarioResult, folder: Path, names, figure_format: str = "png", **drawing
) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for name in names:
        fig = _draw(name, result, plt, **drawing)
        fig.subplots_adjust(**_MARGINS[_LAYOUT_OF.get(name, "single")])
        if figure_format == "png":  # the renderer savefig reuses, with the shared parser
            fig.set_dpi(FIGURE_DPI)
            fig.canvas.get_renderer().mathtext_parser = _shared_math_parser()
        path = figure_path(folder, name, figure_format)
        with atomic_path(path) as temporary:
            fig.savefig(
                temporary,
                dpi=FIGURE_DPI,
                format=figure_format,
                **_SAVE_OPTIONS.get(figure_format, {}),
            )
        plt.close(fig)
        written.append(path)
    return written


def _fork_context():
    """A ``fork`` multiprocessing context on Linux (cheap: the child shares the result), else None."""
    import multiprocessing
    import sys

    if sys.platform != "linux" or "fork" not in multiprocessing.get_all_start_methods():
        return None
    return multiprocessing.get_context("fork")


def _die_with_parent(parent: int) -> None:
    """Initializer of the figure worker: it is killed (SIGKILL) when the process that forked it
    dies, however it dies (:func:`aiauv_pin.parent_death.die_with_parent`)."""
    import signal

    from .parent_death import die_with_parent

    die_with_parent(parent, signal.SIGKILL)


#: The figures from the slowest to draw to the fastest (measured, 2026-11), the order in which
#: :func:`_run_tasks` hands them out.
_SLOWEST_FIRST = (
    "fig7_pointing.png",
    "fig2_cross_track.png",
    "fig4_phi_tilde.png",
    "fig5_omega_tilde.png",
    "path_3d.png",
    "fig3_surge.png",
    "fig6_base_angles.png",
)


def _take_tasks(tasks, taken) -> None:
    """Run the tasks no process has taken yet, one at a time (``taken``: shared next index)."""
    while True:
        with taken.get_lock():
            index = taken.value
            taken.value += 1
        if index >= len(tasks):
            return
        tasks[index]()


def _forget_parsed_math() -> None:
    """Empty the math-text cache in a forked process: its entries hold the parent's fonts, whose
    font files the two processes would read through one shared file offset (matplotlib itself
    empties its font cache on fork for the same reason)."""
    global _math_parser
    _math_parser = None
    clear = _math_cache_clear()
    if clear is not None:  # without it, _warm_math parsed nothing to share
        clear()


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
    import os

    context = _fork_context() if parallel and (os.cpu_count() or 1) > 1 else None
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


def _prepare_figures(figure_format: str) -> None:
    """Check the format and import matplotlib (Agg) here, before a figure process forks."""
    if figure_format not in FIGURE_FORMATS:
        raise ValueError(
            f"unknown figure format '{figure_format}' (expected {', '.join(FIGURE_FORMATS)})"
        )
    _wait_for_preload()  # no import may be in progress in another thread when forking
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot
    import mpl_toolkits.mplot3d  # noqa: F401


def _figure_tasks(result: ScenarioResult, folder: Path, figure_format: str, drawing: dict):
    """One task per figure of ``result``, slowest first."""
    names = figures_of(result)
    ordered = [name for name in _SLOWEST_FIRST if name in names]
    ordered += [name for name in names if name not in ordered]
    return [
        functools.partial(_render, result, folder, (name,), figure_format, **drawing)
        for name in ordered
    ]


def write_figures(
    result: ScenarioResult,
    folder: Path,
    *,
    parallel: bool = True,
    figure_format: str = "png",
    vehicle_name: str | None = None,
    path_points: np.ndarray | None = None,
) -> list[Path]:
    """Figures mirroring the paper's Figs. 2-7, plus the 3-D path (:data:`FIGURES`).

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
        path_points: The path drawn in the 3-D figure, world points (N, 3) [m] (default: the
            x-axis over the run's x-range).

    Returns:
        The files written, in the order of :data:`FIGURES`.
    """
    _prepare_figures(figure_format)
    folder = Path(folder)
    drawing = {"vehicle_name": vehicle_name, "path_points": path_points}
    _run_tasks(_figure_tasks(result, folder, figure_format, drawing), parallel)
    return [figure_path(folder, name, figure_format) for name in figures_of(result)]


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
) -> dict:
    """Write every result file of a run into ``out_dir``; return the summary.

    The files are written by two processes where possible (see :func:`_run_tasks`), ``also``
    first (the slowest, e.g. the playback page), then the figures and ``timeseries.csv``;
    ``summary.json`` is written here meanwhile.

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
    """
    _prepare_figures(figure_format)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if vehicle_name is None and extra and extra.get("vehicle"):
        vehicle_name = Path(str(extra["vehicle"])).stem
    drawing = {"vehicle_name": vehicle_name, "path_points": path_points}
    tasks = [
        *also,
        *_figure_tasks(result, out_dir / "figures", figure_format, drawing),
        functools.partial(write_timeseries, result, out_dir / "timeseries.csv"),
    ]
    return _run_tasks(
        tasks,
        parallel,
        here_first=functools.partial(write_summary, result, out_dir / "summary.json", extra),
    )
