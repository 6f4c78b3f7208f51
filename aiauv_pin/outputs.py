"""Result files of a path-following run: ``timeseries.csv``, ``summary.json`` and ``figures/``.

The run is logged at every controller sample (every step by default) and ``summary.json``'s
integrals (work) and settling times use every logged sample. ``timeseries.csv`` holds every
``csv_period`` of the scenario (0.05 s by default, rounded to a whole number of logged samples;
the last sample is always included; ``None`` writes every sample). The figures draw, per curve,
the minimum and maximum of each of at most :data:`PLOT_BUCKETS` consecutive runs of samples (in
time order), which at their size is indistinguishable from drawing every sample.

Speed: pass :func:`preload_plotting` as ``after_first_chunk`` to
:func:`aiauv_pin.scenario.run_paper_scenario` and matplotlib (about 0.3 s of imports) is imported in a
background thread while the compiled scenario loop runs (its kernels release the GIL); no backend
is selected until figures are written (Agg). The figures are drawn by two processes on Linux.
"""

from __future__ import annotations

import json
import sys
import threading
from pathlib import Path

import numpy as np

from .atomic import atomic_path, write_text
from .scenario import ScenarioResult, summary

_preload: threading.Thread | None = None


def _import_plotting() -> None:
    try:
        import matplotlib.backends.backend_agg
        import matplotlib.pyplot  # noqa: F401
        import mpl_toolkits.mplot3d  # noqa: F401
    except Exception:
        pass


def preload_plotting() -> None:
    """Start importing matplotlib in a background thread, once (no backend is selected)."""
    global _preload
    if _preload is None and "matplotlib.pyplot" not in sys.modules:
        _preload = threading.Thread(target=_import_plotting, name="aiauv-preload", daemon=True)
        _preload.start()


def _wait_for_preload() -> None:
    if _preload is not None:
        _preload.join()


def timeseries_columns(result: ScenarioResult) -> dict[str, np.ndarray]:
    """Columns of ``timeseries.csv`` by name, in order."""
    tr = result.trajectory
    info = tr.info
    columns: dict[str, np.ndarray] = {
        "t": tr.t,
        "p_x": info["p"][:, 0],
        "p_y": info["p"][:, 1],
        "p_z": info["p"][:, 2],
        "u": info["u"],
        "phi_tilde": info["phi_tilde"],
        "omega_tilde_y": info["omega_tilde"][:, 0],
        "omega_tilde_z": info["omega_tilde"][:, 1],
        "q_y0": info["base_angles"][:, 0],
        "q_z0": info["base_angles"][:, 1],
    }
    for k, axis in enumerate("xyz"):
        columns[f"x_ref_{axis}"] = info["x_ref"][:, k]
    for k, axis in enumerate("xyz"):
        columns[f"pointing_{axis}"] = info["pointing"][:, k]
    for k, name in enumerate(result.joint_names):
        columns[f"q_{name}"] = tr.q[:, 7 + k]
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


def _draw(name: str, result: ScenarioResult, plt):
    """The figure ``name`` of :data:`FIGURES`."""
    tr = result.trajectory
    info, t = tr.info, tr.t
    case = result.scenario.case
    if name == "fig2_cross_track.png":
        fig, ax = plt.subplots(figsize=(6, 3.2))
        _plot(ax, t, info["p"][:, 1], label="$p_y$")
        _plot(ax, t, info["p"][:, 2], label="$p_z$")
        ax.set(xlabel="t [s]", ylabel="cross-track error [m]", title=f"Cross-track errors ({case})")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.legend()
    elif name == "fig3_surge.png":
        fig, ax = plt.subplots(figsize=(6, 3.2))
        _plot(ax, t, info["u"], label="$u$")
        u_d = result.scenario.controller_gains.u_d
        ax.axhline(u_d, color="k", ls="--", lw=0.8, label="$u_d$")
        ax.set(xlabel="t [s]", ylabel="surge velocity [m/s]", title=f"Surge velocity ({case})")
        ax.legend()
    elif name == "fig4_phi_tilde.png":
        fig, ax = plt.subplots(figsize=(6, 3.2))
        _plot(ax, t, info["phi_tilde"])
        ax.set(xlabel="t [s]", ylabel=r"$\tilde\phi$ [rad]", title=f"Pointing error ({case})")
    elif name == "fig5_omega_tilde.png":
        fig, ax = plt.subplots(figsize=(6, 3.2))
        _plot(ax, t, info["omega_tilde"][:, 0], label=r"$\tilde\omega_y$")
        _plot(ax, t, info["omega_tilde"][:, 1], label=r"$\tilde\omega_z$")
        ax.set(xlabel="t [s]", ylabel="[rad/s]", title=f"Angular velocity error ({case})")
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
        ax.plot([p[0, 0], p[-1, 0]], [0, 0], [0, 0], "k--", lw=0.8, label="path")
        ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title=f"Path ({case})")
        ax.legend()
    else:
        raise ValueError(f"unknown figure {name!r}")
    return fig


def _render(result: ScenarioResult, folder: Path, names) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for name in names:
        fig = _draw(name, result, plt)
        fig.tight_layout()
        with atomic_path(folder / name) as temporary:
            fig.savefig(temporary, dpi=110, format="png")
        plt.close(fig)
        written.append(folder / name)
    return written


def _fork_context():
    """A ``fork`` multiprocessing context on Linux (cheap: the child shares the result), else None."""
    import multiprocessing
    import sys

    if sys.platform != "linux" or "fork" not in multiprocessing.get_all_start_methods():
        return None
    return multiprocessing.get_context("fork")


def _die_with_parent(parent: int) -> None:
    """Initializer of the figure worker: it is killed when the process that forked it dies.

    Linux ``prctl(PR_SET_PDEATHSIG, SIGKILL)``; if the parent is already gone, exit at once.
    """
    import ctypes
    import ctypes.util
    import os
    import signal

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(1)


def write_figures(result: ScenarioResult, folder: Path, *, parallel: bool = True) -> list[Path]:
    """PNG figures mirroring the paper's Figs. 2-7, plus the 3-D path (:data:`FIGURES`).

    With ``parallel`` (on Linux, with more than one CPU) a forked process draws half of them
    while this one draws the rest; that process is killed if this one dies
    (:func:`_die_with_parent`).
    """
    import os

    _wait_for_preload()  # no import may be in progress in another thread when forking
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot
    import mpl_toolkits.mplot3d  # noqa: F401

    folder = Path(folder)
    context = _fork_context() if parallel and (os.cpu_count() or 1) > 1 else None
    if context is None:
        return _render(result, folder, FIGURES)
    from concurrent.futures import ProcessPoolExecutor

    # the 3-D path and the 3-panel figure are the slowest: split the work about evenly
    mine = ("fig7_pointing.png", "fig2_cross_track.png", "fig4_phi_tilde.png")
    theirs = tuple(name for name in FIGURES if name not in mine)
    with ProcessPoolExecutor(
        max_workers=1,
        mp_context=context,
        initializer=_die_with_parent,
        initargs=(os.getpid(),),
    ) as pool:
        future = pool.submit(_render, result, folder, theirs)
        _render(result, folder, mine)
        future.result()
    return [folder / name for name in FIGURES]


def write_results(result: ScenarioResult, out_dir: Path, extra: dict | None = None) -> dict:
    """Write every result file of a run into ``out_dir``; return the summary."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_timeseries(result, out_dir / "timeseries.csv")
    content = write_summary(result, out_dir / "summary.json", extra)
    write_figures(result, out_dir / "figures")
    return content
