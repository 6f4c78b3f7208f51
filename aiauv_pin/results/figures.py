"""A run's figures, drawn from plain data (:class:`FigureData`) with matplotlib alone.

This module imports numpy and the standard library only (matplotlib when a figure is drawn), so
that ``aiauv simulate``'s figure process, forked before the simulation's modules are imported
(:mod:`aiauv_pin.results.figure_workers`), draws the figures without importing numba, Pinocchio or
ours. :func:`aiauv_pin.results.outputs.figure_data` makes the data of a run;
:func:`aiauv_pin.results.outputs.write_figures` draws them.

Each figure is drawn on its own Agg canvas, without pyplot: matplotlib's backend, which a
notebook's plots use, is never changed. Long series are drawn as their min/max envelope
(:func:`envelope`). PNG files are written by pypng (:func:`write_png`).
"""

from __future__ import annotations

import functools
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aiauv_pin._internal.atomic import atomic_path

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
    "$e_1$ (horizontal)",
    "$e_2$ (vertical)",
    r"$\tilde\omega$ [rad/s]",
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


def import_plotting() -> None:
    """Import matplotlib (no backend selected) and warm it up (:func:`_warm_plotting`); errors
    are left for the figures to raise."""
    try:
        import matplotlib.backends.backend_agg
        import matplotlib.figure  # noqa: F401
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
    if _preload is None and "mpl_toolkits.mplot3d" not in sys.modules:
        _preload = threading.Thread(target=import_plotting, name="aiauv-preload", daemon=True)
        _preload.start()


def _wait_for_preload() -> None:
    if _preload is not None:
        _stop_warming.set()
        _preload.join()


#: Largest number of min/max buckets per plotted curve (each contributes two points).
PLOT_BUCKETS = 2000


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

#: zlib level of the PNG figures: 1, the same pixels as the default 6 in about half the
#: compression time (files about 20 % larger).
PNG_COMPRESSION = 1

#: Figures of a run that follows a path without the paper controller's diagnostics.
PATH_FIGURES = ("fig2_cross_track.png", "path_3d.png")
#: Figures of a run that follows no path (a passive run): the base's displacement from its start
#: and speed against time, and the 3-D trajectories of the base and the end-effector.
MOTION_FIGURES = ("base_motion.png", "motion_3d.png")
#: Figures added by station keeping and velocity control (:mod:`aiauv_pin.wholebody`): the pose
#: (or twist) errors of the held axes, and the thrusts with the residual wrench's size.
WHOLEBODY_FIGURES = ("pose_error.png", "thrusts.png")
#: Added for an intervention run (:mod:`aiauv_pin.wholebody`): the pose error to the reference
#: (position [mm], attitude [deg]), the thrusts [N] and the joint angles [rad] against time.
INTERVENTION_FIGURES = ("intervention.png",)
#: Figure added by a torpedo AUV's path following (:mod:`aiauv_pin.controllers.torpedo_controller`):
#: heading and pitch against their LOS references, the rudder and stern-plane deflections and the
#: fin angles reached.
TORPEDO_FIGURES = ("fins.png",)


@dataclass(frozen=True)
class FigureData:
    """What a run's figures draw: arrays, names and numbers, nothing of the simulation (so it
    pickles into a process that imported matplotlib alone).

    Attributes:
        names: The figures to draw (file names, of the tuples above).
        title: Name in the titles (``aiauv simulate``: its output folder's).
        t: Times of the samples (N,) [s].
        q: Configurations (N, nq) (Pinocchio's: base position [m], quaternion, joints).
        v: Velocities (N, nv) (base twist [m/s, rad/s] in the body frame, joint rates).
        info: The diagnostics drawn, by their ``Trajectory.info`` key (N rows each).
        u_d: The controller's desired surge speed [m/s] (the surge figure's reference).
        velocity_control: Whether the held axes' errors are twist errors (velocity control).
        thruster_names: Legend of the thrust curves.
        joint_names: Legend of the joint-angle curves.
        path_points: The path the 3-D path figure draws, (M, 3) world points [m], or ``None``.
        cross_track_axes: What the cross-track errors measure (a key of the legends' labels),
            or ``None`` for a run that follows no path.
    """

    names: tuple[str, ...]
    title: str
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    info: dict
    u_d: float
    velocity_control: bool
    thruster_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    path_points: np.ndarray | None
    cross_track_axes: tuple[str, str] | None


#: The ``Trajectory.info`` keys the figures draw.
DRAWN_INFO = (
    "cross_track",
    "u",
    "phi_tilde",
    "omega_tilde",
    "base_angles",
    "pointing",
    "x_ref",
    "p",
    "error",
    "thrust",
    "residual",
    "heading",
    "pitch",
    "deflection",
    "fin_angle",
    "pose_error",
)


#: Legend labels of the cross-track errors by what they measure
#: (:func:`aiauv_pin.scenario.definition.cross_track_axes`).
_CROSS_TRACK_LABELS = {
    ("p_y", "p_z"): ("$p_y$", "$p_z$"),
    ("horizontal", "vertical"): ("$e_1$ (horizontal)", "$e_2$ (vertical)"),
    ("N1", "N2"): ("$e_1$ (along $N_1$)", "$e_2$ (along $N_2$)"),
}


def _new_figure(figsize: tuple[float, float]):
    """An empty figure of ``figsize`` [in] on its own Agg canvas (no pyplot: nothing to close,
    and its import, 0.03 s of a figure process, is saved)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    return fig


def _subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **options):
    """A figure (:func:`_new_figure`) and its axes, as ``pyplot.subplots`` makes them."""
    fig = _new_figure(figsize)
    return fig, fig.subplots(nrows, ncols, **options)


def _error_axes(title: str):
    """A figure with an error panel above its log-scale companion (``|error|``, shared time axis)."""
    fig, (ax, ax_log) = _subplots(
        2, 1, figsize=(6, 4.6), sharex=True, gridspec_kw={"height_ratios": (3, 2)}
    )
    ax.set_title(title)
    ax.axhline(0.0, color="k", lw=0.5)
    ax_log.set_yscale("log")
    # minor ticks (labelled over less than a decade) as plain numbers, "2e-02", not "2 x 10^-2":
    # narrow enough to leave the axis label in the figure
    from matplotlib.ticker import LogFormatter

    ax_log.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False, minor_thresholds=(1, 0.4)))
    ax_log.set_xlabel("t [s]")
    ax_log.grid(True, which="major", lw=0.3)
    return fig, ax, ax_log


def _plot_error(ax, ax_log, t, y, **kwargs) -> None:
    """``y`` on the linear panel and ``|y|`` on the log-scale one (zeros are not drawn there)."""
    _plot(ax, t, y, **kwargs)
    magnitude = np.abs(np.asarray(y, dtype=float))
    _plot(ax_log, t, np.where(magnitude > 0.0, magnitude, np.nan), **kwargs)


def _set_equal_axes(ax, points: np.ndarray) -> None:
    """Equal scales on the three axes of a 3-D plot, framing ``points`` (N, 3) [m]."""
    low, high = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
    centre = (low + high) / 2.0
    half = max(float(np.max(high - low)) / 2.0, 1e-3) * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # tick labels that do not run into each other
        axis.set_major_locator(MaxNLocator(5))


def _draw(name: str, data: FigureData):
    """The figure ``name`` (one of the tuples above) of a run's :class:`FigureData`."""
    info, t, case = data.info, data.t, data.title
    if name == "fig2_cross_track.png":
        fig, ax, ax_log = _error_axes(f"Cross-track errors ({case})")
        # on the paper's x-axis the path normals are y and z: e_1 = p_y, e_2 = p_z
        labels = _CROSS_TRACK_LABELS[data.cross_track_axes]
        _plot_error(ax, ax_log, t, info["cross_track"][:, 0], label=labels[0])
        _plot_error(ax, ax_log, t, info["cross_track"][:, 1], label=labels[1])
        ax.set_ylabel("cross-track error [m]")
        ax_log.set_ylabel("|error| [m]")
        ax.legend()
    elif name == "fig3_surge.png":
        fig, ax = _subplots(figsize=(6, 3.2))
        _plot(ax, t, info["u"], label="$u$")
        ax.axhline(data.u_d, color="k", ls="--", lw=0.8, label="$u_d$")
        ax.set(xlabel="t [s]", ylabel="surge velocity [m/s]", title=f"Surge velocity ({case})")
        ax.legend()
    elif name == "fig4_phi_tilde.png":
        fig, ax, ax_log = _error_axes(f"Pointing error ({case})")
        _plot_error(ax, ax_log, t, info["phi_tilde"])
        ax.set_ylabel(r"$\tilde\phi$ [rad]")
        ax_log.set_ylabel(r"$|\tilde\phi|$ [rad]")
    elif name == "fig5_omega_tilde.png":
        fig, ax, ax_log = _error_axes(f"Angular velocity error ({case})")
        _plot_error(ax, ax_log, t, info["omega_tilde"][:, 0], label=r"$\tilde\omega_y$")
        _plot_error(ax, ax_log, t, info["omega_tilde"][:, 1], label=r"$\tilde\omega_z$")
        ax.set_ylabel(r"$\tilde\omega$ [rad/s]")
        ax_log.set_ylabel("|error| [rad/s]")
        ax.legend()
    elif name == "fig6_base_angles.png":
        fig, ax = _subplots(figsize=(6, 3.2))
        _plot(ax, t, info["base_angles"][:, 0], label="$q_{y,0}$")
        _plot(ax, t, info["base_angles"][:, 1], label="$q_{z,0}$")
        ax.set(xlabel="t [s]", ylabel="base angle [rad]", title=f"Base angles ({case})")
        ax.legend()
    elif name == "fig7_pointing.png":
        fig, axes = _subplots(3, 1, figsize=(6, 5), sharex=True)
        for k, axis in enumerate("xyz"):
            _plot(axes[k], t, info["pointing"][:, k], label=f"$x^I_{axis}$")
            _plot(axes[k], t, info["x_ref"][:, k], ls="--", label=rf"$x_{{ref,{axis}}}$")
            axes[k].legend(loc="right")
            axes[k].set_ylabel(f"{axis} [-]")
        axes[-1].set_xlabel("t [s]")
        axes[0].set_title(f"End-effector and reference pointing direction ({case})")
    elif name == "path_3d.png":
        fig = _new_figure((6, 4.5))
        ax = fig.add_subplot(projection="3d")
        p = info["p"]
        stride = max(1, len(p) // (2 * PLOT_BUCKETS))  # a smooth space curve: every stride-th point
        path = np.concatenate((p[::stride], p[-1:]))
        ax.plot(path[:, 0], path[:, 1], path[:, 2], label="end-effector")
        drawn = np.asarray(data.path_points, dtype=float)
        if drawn.ndim != 2 or drawn.shape[1] != 3:
            raise ValueError(f"path_points must be an (N, 3) array, got shape {drawn.shape}")
        ax.plot(drawn[:, 0], drawn[:, 1], drawn[:, 2], "k--", lw=0.8, label="path")
        ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title=f"Path ({case})")
        _set_equal_axes(ax, np.concatenate((path, drawn)))
        ax.legend()
    elif name == "base_motion.png":
        fig, (ax, ax_speed) = _subplots(2, 1, figsize=(6, 4.6), sharex=True)
        q, v = data.q, data.v
        for k, axis in enumerate("xyz"):
            _plot(ax, t, q[:, k] - q[0, k], label=f"${axis}$")
        ax.set(ylabel="displacement [m]", title=f"Base motion from its start ({case})")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.legend()
        # the body-frame linear velocity's length is the world speed of the base origin
        _plot(ax_speed, t, np.linalg.norm(v[:, :3], axis=1))
        ax_speed.set(xlabel="t [s]", ylabel="speed [m/s]")
    elif name == "pose_error.png":
        velocity = data.velocity_control
        kind = "Twist" if velocity else "Pose"
        fig, ax, ax_log = _error_axes(f"{kind} errors of the held axes ({case})")
        error = np.asarray(info["error"])
        units = ("m/s", "rad/s") if velocity else ("m", "rad")
        for k, axis in enumerate(("surge", "sway", "heave", "roll", "pitch", "yaw")):
            if np.any(error[:, k]):
                _plot_error(ax, ax_log, t, error[:, k], label=axis, ls="-" if k < 3 else "--")
        ax.set_ylabel(f"error [{units[0]}, {units[1]}]")
        ax_log.set_ylabel("|error|")
        ax.legend(ncol=3, fontsize="small")
    elif name == "thrusts.png":
        fig, (ax, ax_res) = _subplots(2, 1, figsize=(6, 4.6), sharex=True)
        thrust = np.asarray(info["thrust"])
        for k, thruster in enumerate(data.thruster_names):
            _plot(ax, t, thrust[:, k], label=thruster)
        ax.set(ylabel="thrust [N]", title=f"Thrusts and residual wrench ({case})")
        ax.legend(ncol=4, fontsize="small")
        residual = np.asarray(info["residual"])
        _plot(ax_res, t, np.linalg.norm(residual[:, :3], axis=1), label="force [N]")
        _plot(ax_res, t, np.linalg.norm(residual[:, 3:], axis=1), label="moment [N m]")
        ax_res.set(xlabel="t [s]", ylabel="|residual|")
        ax_res.legend()
    elif name == "fins.png":
        fig, (ax_h, ax_p, ax_f) = _subplots(3, 1, figsize=(6, 6), sharex=True)
        for ax, key, label in ((ax_h, "heading", "heading"), (ax_p, "pitch", "pitch")):
            angles = np.asarray(info[key])
            _plot(ax, t, np.unwrap(angles[:, 0]), label=f"{label}")
            _plot(ax, t, np.unwrap(angles[:, 1]), label="LOS reference", ls="--")
            ax.set(ylabel=f"{label} [rad]")
            ax.legend(fontsize="small")
        ax_h.set_title(f"Heading, pitch and fins ({case})")
        deflection = np.asarray(info["deflection"])
        _plot(ax_f, t, deflection[:, 0], label="rudder $\\delta_r$")
        _plot(ax_f, t, deflection[:, 1], label="stern planes $\\delta_s$")
        reached = np.asarray(info["fin_angle"])
        for k in range(reached.shape[1]):
            _plot(ax_f, t, reached[:, k], lw=0.6, alpha=0.6, label=f"fin {k} reached")
        ax_f.set(xlabel="t [s]", ylabel="angle [rad]")
        ax_f.legend(ncol=3, fontsize="x-small")
    elif name == "motion_3d.png":
        fig = _new_figure((6, 4.5))
        ax = fig.add_subplot(projection="3d")
        drawn = []
        for label, points in (("base", data.q[:, :3]), ("end-effector", info["p"])):
            stride = max(1, len(points) // (2 * PLOT_BUCKETS))
            points = np.concatenate((points[::stride], points[-1:]))
            (line,) = ax.plot(points[:, 0], points[:, 1], points[:, 2], label=label)
            ax.scatter(*points[0], marker="o", s=12, color=line.get_color())  # the start
            drawn.append(points)
        ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title=f"Trajectory ({case})")
        _set_equal_axes(ax, np.concatenate(drawn))
        ax.legend()
    elif name == "intervention.png":
        fig, axes = _subplots(3, 1, figsize=(6, 6), sharex=True)
        error = np.asarray(info["pose_error"])
        for k, axis in enumerate("xyz"):
            (line,) = _plot(axes[0], t, 1000.0 * error[:, k], label=f"${axis}$ [mm]")
            _plot(
                axes[0],
                t,
                np.degrees(error[:, 3 + k]),
                ls="--",
                color=line.get_color(),
                label=f"$r_{axis}$ [deg]",
            )
        axes[0].set(
            ylabel="pose error", title=f"Intervention: pose error, thrusts, joints ({case})"
        )
        axes[0].legend(loc="upper right", fontsize="x-small", ncol=2)
        thrust = np.asarray(info["thrust"])
        for k, name_k in enumerate(data.thruster_names):
            _plot(axes[1], t, thrust[:, k], label=name_k)
        axes[1].set_ylabel("thrust [N]")
        axes[1].legend(loc="upper right", fontsize="x-small", ncol=2)
        q = data.q
        for k, name_k in enumerate(data.joint_names):
            _plot(axes[2], t, q[:, 7 + k], label=name_k)
        axes[2].set(xlabel="t [s]", ylabel="joint angle [rad]")
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
    "three": {"left": 0.13, "right": 0.97, "bottom": 0.09, "top": 0.94, "hspace": 0.1},
    "3d": {"left": 0.02, "right": 0.92, "bottom": 0.06, "top": 0.93},
}
_LAYOUT_OF = {
    "base_motion.png": "error",
    "pose_error.png": "error",
    "thrusts.png": "error",
    "fins.png": "three",
    "motion_3d.png": "3d",
    "fig2_cross_track.png": "error",
    "fig4_phi_tilde.png": "error",
    "fig5_omega_tilde.png": "error",
    "fig7_pointing.png": "three",
    "intervention.png": "three",
    "path_3d.png": "3d",
}


def _render(data: FigureData, folder: Path, names, figure_format: str = "png") -> list[Path]:
    """Draw the figures ``names`` of ``data`` into ``folder``, each file written atomically."""
    written = []
    for name in names:
        fig = _draw(name, data)
        fig.subplots_adjust(**_MARGINS[_LAYOUT_OF.get(name, "single")])
        if figure_format == "png":  # the renderer savefig reuses, with the shared parser
            fig.set_dpi(FIGURE_DPI)
            fig.canvas.get_renderer().mathtext_parser = _shared_math_parser()
        path = figure_path(folder, name, figure_format)
        with atomic_path(path) as temporary:
            if figure_format == "png":
                write_png(fig, temporary)
            else:
                fig.savefig(temporary, dpi=FIGURE_DPI, format=figure_format)
        written.append(path)
    return written


def write_png(fig, path: Path) -> None:
    """``fig`` (an Agg figure) drawn at its dpi and written to ``path`` as an 8-bit RGBA PNG by
    pypng, with its resolution (``pHYs``): the pixels ``savefig`` writes.

    Pillow, which ``savefig`` writes PNG files with, tries three or four row filters on every row
    (``ZipEncode.c``; there is no option to turn that off) and takes 22-25 ms a figure at zlib
    level 1; pypng writes the rows unfiltered in 7 ms (files about 2 % larger). The file carries
    no ``Software`` text (``savefig`` names matplotlib there).
    """
    import png

    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    height, width = rgba.shape[:2]
    per_metre = round(fig.dpi / 0.0254)  # [pixels / m]
    writer = png.Writer(
        width,
        height,
        greyscale=False,
        alpha=True,
        bitdepth=8,
        compression=PNG_COMPRESSION,
        x_pixels_per_unit=per_metre,
        y_pixels_per_unit=per_metre,
        unit_is_meter=True,
    )
    with open(path, "wb") as file:
        writer.write_packed(file, rgba.reshape(height, 4 * width))


#: The figures from the slowest to draw to the fastest (their drawing times are on the docs'
#: performance page), the order in which the figure processes take them.
_SLOWEST_FIRST = (
    "intervention.png",
    "fig7_pointing.png",
    "fig2_cross_track.png",
    "fig4_phi_tilde.png",
    "fig5_omega_tilde.png",
    "path_3d.png",
    "fig3_surge.png",
    "fig6_base_angles.png",
    "motion_3d.png",
    "base_motion.png",
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


def check_figure_format(figure_format: str) -> None:
    """Raise ``ValueError`` (one line) unless ``figure_format`` is one of :data:`FIGURE_FORMATS`."""
    if figure_format not in FIGURE_FORMATS:
        raise ValueError(
            f"unknown figure format '{figure_format}' (expected {', '.join(FIGURE_FORMATS)})"
        )


def _prepare_figures(figure_format: str) -> None:
    """Check the format and import matplotlib (Agg) here, before a figure process forks."""
    check_figure_format(figure_format)
    _wait_for_preload()  # no import may be in progress in another thread when forking
    import matplotlib.backends.backend_agg
    import matplotlib.figure  # noqa: F401
    import mpl_toolkits.mplot3d  # noqa: F401


def _figure_tasks(data: FigureData, folder: Path, figure_format: str):
    """One task per figure of ``data``, slowest first."""
    ordered = [name for name in _SLOWEST_FIRST if name in data.names]
    ordered += [name for name in data.names if name not in ordered]
    return [functools.partial(_render, data, folder, (name,), figure_format) for name in ordered]
