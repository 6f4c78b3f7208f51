"""Result files of a path-following run: ``timeseries.csv``, ``summary.json`` and ``figures/``."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from .atomic import atomic_path, write_text
from .scenario import ScenarioResult, summary


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


def write_timeseries(result: ScenarioResult, path: Path) -> Path:
    """Write ``timeseries.csv`` (one row per logged step, SI units, radians)."""
    columns = timeseries_columns(result)
    table = np.column_stack(list(columns.values()))
    buffer = io.StringIO()
    np.savetxt(buffer, table, delimiter=",", header=",".join(columns), comments="", fmt="%.9g")
    return write_text(path, buffer.getvalue())


def write_summary(result: ScenarioResult, path: Path, extra: dict | None = None) -> dict:
    """Write ``summary.json`` and return its content."""
    content = summary(result)
    if extra:
        content.update(extra)
    write_text(path, json.dumps(content, indent=2, allow_nan=False) + "\n")
    return content


def write_figures(result: ScenarioResult, folder: Path) -> list[Path]:
    """PNG figures mirroring the paper's Figs. 2-7, plus the 3-D path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = result.trajectory
    info, t = tr.info, tr.t
    case = result.scenario.case
    u_d = result.scenario.controller_gains.u_d
    written: list[Path] = []

    def save(fig, name: str) -> None:
        fig.tight_layout()
        with atomic_path(folder / name) as temporary:
            fig.savefig(temporary, dpi=110, format="png")
        plt.close(fig)
        written.append(folder / name)

    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.plot(t, info["p"][:, 1], label="$p_y$")
    ax.plot(t, info["p"][:, 2], label="$p_z$")
    ax.set(xlabel="t [s]", ylabel="cross-track error [m]", title=f"Cross-track errors ({case})")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.legend()
    save(fig, "fig2_cross_track.png")

    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.plot(t, info["u"], label="$u$")
    ax.axhline(u_d, color="k", ls="--", lw=0.8, label="$u_d$")
    ax.set(xlabel="t [s]", ylabel="surge velocity [m/s]", title=f"Surge velocity ({case})")
    ax.legend()
    save(fig, "fig3_surge.png")

    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.plot(t, info["phi_tilde"])
    ax.set(xlabel="t [s]", ylabel=r"$\tilde\phi$ [rad]", title=f"Pointing error ({case})")
    save(fig, "fig4_phi_tilde.png")

    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.plot(t, info["omega_tilde"][:, 0], label=r"$\tilde\omega_y$")
    ax.plot(t, info["omega_tilde"][:, 1], label=r"$\tilde\omega_z$")
    ax.set(xlabel="t [s]", ylabel="[rad/s]", title=f"Angular velocity error ({case})")
    ax.legend()
    save(fig, "fig5_omega_tilde.png")

    fig, ax = plt.subplots(figsize=(6, 3.2))
    ax.plot(t, info["base_angles"][:, 0], label="$q_{y,0}$")
    ax.plot(t, info["base_angles"][:, 1], label="$q_{z,0}$")
    ax.set(xlabel="t [s]", ylabel="[rad]", title=f"Base angles ({case})")
    ax.legend()
    save(fig, "fig6_base_angles.png")

    fig, axes = plt.subplots(3, 1, figsize=(6, 5), sharex=True)
    for k, axis in enumerate("xyz"):
        axes[k].plot(t, info["pointing"][:, k], label=f"$x^I_{axis}$")
        axes[k].plot(t, info["x_ref"][:, k], ls="--", label=rf"$x_{{ref,{axis}}}$")
        axes[k].legend(loc="right")
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(f"End-effector and reference pointing direction ({case})")
    save(fig, "fig7_pointing.png")

    fig = plt.figure(figsize=(6, 4.5))
    ax = fig.add_subplot(projection="3d")
    p = info["p"]
    ax.plot(p[:, 0], p[:, 1], p[:, 2], label="end-effector")
    ax.plot([p[0, 0], p[-1, 0]], [0, 0], [0, 0], "k--", lw=0.8, label="path")
    ax.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", title=f"Path ({case})")
    ax.legend()
    save(fig, "path_3d.png")
    return written


def write_results(result: ScenarioResult, out_dir: Path, extra: dict | None = None) -> dict:
    """Write every result file of a run into ``out_dir``; return the summary."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_timeseries(result, out_dir / "timeseries.csv")
    content = write_summary(result, out_dir / "summary.json", extra)
    write_figures(result, out_dir / "figures")
    return content
