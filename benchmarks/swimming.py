"""Swimming: gait speeds, cost of transport, and path following by serpentine gaits.

Writes ``benchmarks/swimming.json`` and the figures of ``docs/source/swimming.md`` into
``docs/figures/swimming/``:

1. average forward speed of the Mamba-like snake (``urdf/mamba_like.toml``) against the gait's
   frequency, amplitude and phase offset, lateral undulation and eel-like motion (no steering);
2. cost of transport on the paper's vehicle (uniform case) along the world x-axis at equal
   average speed: swimming by lateral undulation (thrusters idle), by the X thrusters with the
   body held straight (surge PI at that speed) and combined (half the amplitude, the X thrusters
   holding that speed);
3. cross-track errors of ``examples/gait_line.toml``, ``gait_waypoints.toml`` and
   ``gait_circle.toml``.

    .venv/bin/python benchmarks/swimming.py

Cost of transport (Gabrielli and von Karman, "What price speed?", Mechanical Engineering 72(10),
1950): ``CoT = E / (m g d)`` [-], electrical energy ``E`` [J] (the project's energy model,
:mod:`aiauv_pin.simulation.energy`) over the distance ``d`` [m] the centre of mass advances along
the path, per weight ``m g`` [N] of the (neutrally buoyant) vehicle; also ``E / d`` [J/m]. Both over
the last ``WINDOW`` seconds (120 s: 9.5 to 28.6 gait periods). Also the mechanical
work delivered, ``max(tau q_dot, 0)`` per joint and ``max(T u_axis, 0)`` per thruster, per weight and
distance: without the motors' copper losses and the propellers' losses.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

import aiauv_pin
from aiauv_control.path_following import PathFollowingGains
from aiauv_pin.controllers.gait_controller import Gait, VehicleGait
from aiauv_pin.model.loading import bundled_urdf
from aiauv_pin.results.outputs import default_path_points
from aiauv_pin.scenario.definition import Scenario, run_scenario
from aiauv_pin.scenario.toml_file import load_scenario
from aiauv_pin.simulation.energy import EnergyParameters, exact_sum, run_energy

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
OUT = HERE / "swimming.json"
FIGURES = ROOT / "docs" / "figures" / "swimming"

#: Mamba-like servo gains [N m/rad], [N m s/rad] (the examples' values).
MAMBA_SERVO = PathFollowingGains(k_qp=10.0, k_qd=0.3)
#: The sweeps' base gait on the Mamba-like snake: 30 deg, 2 rad/s, 40 deg.
MAMBA_BASE = dict(amplitude=math.radians(30.0), omega=2.0, delta=math.radians(40.0))
#: Paper vehicle: servo gains stiff enough to track a gait of about 1 rad/s (the paper's k_qp =
#: 30 N m/rad is set for slow body curving), and the gait of the energy comparison.
PAPER_SERVO = dict(k_qp=300.0, k_qd=60.0)
PAPER_GAIT = dict(amplitude=0.6, delta=0.7, k_theta=0.5, max_offset=0.2)
PAPER_OMEGAS = (0.5, 0.75, 1.0, 1.25, 1.5)
DURATION, WINDOW, DT = 240.0, 120.0, 0.01
#: The path-following examples whose cross-track errors are drawn.
EXAMPLES = ("gait_line", "gait_waypoints", "gait_circle")


def mamba_speed(vehicle, kind: str, duration: float = 60.0, **gait) -> float:
    """Average speed [m/s] of the centre of mass over the whole periods of the run's second half
    (the gait open loop: no steering)."""
    options = {**MAMBA_BASE, **gait}
    law = VehicleGait(vehicle, Gait(kind, k_theta=0.0, max_offset=0.0, **options), MAMBA_SERVO)
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    tr = aiauv_pin.simulate(
        vehicle, q0, v0, duration, DT, law.compiled(), servo=law.joint_servo, method="euler"
    )
    return average_speed(np.asarray(tr.t), tr.info["centre"], options["omega"], duration / 2)


def average_speed(t, centre, omega: float, window: float) -> float:
    """Horizontal distance over time of the centre of mass over the whole gait periods within the
    last ``window`` seconds [m/s]."""
    period = 2.0 * math.pi / omega
    k0 = int(np.searchsorted(t, t[-1] - (window // period) * period - 1e-9))
    return float(np.linalg.norm(centre[-1, :2] - centre[k0, :2]) / (t[-1] - t[k0]))


def window_energy(result, mass: float) -> dict:
    """Energy, distance along the path and cost of transport over the last ``WINDOW`` seconds."""
    tr = result.trajectory
    t = np.asarray(tr.t)
    k0 = int(np.searchsorted(t, t[-1] - WINDOW - 1e-9))
    info = tr.info
    e = run_energy(
        t[k0:],
        np.asarray(info["thrust"])[k0:],
        np.asarray(info["joint_torque"])[k0:],
        np.asarray(tr.v)[k0:, 6:],
        np.asarray(info["path_s"])[k0:],
        EnergyParameters(),
    )
    cross = np.hypot(info["cross_track"][k0:, 0], info["cross_track"][k0:, 1])
    step = np.diff(t[k0:])
    # mechanical work delivered: joints max(tau q_dot, 0), thrusters max(T u_axis, 0)
    joint_mech = np.maximum(
        np.asarray(info["joint_torque"])[k0:-1] * np.asarray(tr.v)[k0:-1, 6:], 0.0
    )
    thruster_mech = np.maximum(np.asarray(info["thruster_power"])[k0:-1], 0.0)
    mechanical = exact_sum(joint_mech * step[:, None]) + exact_sum(thruster_mech * step[:, None])
    return {
        "speed": e.distance / (t[-1] - t[k0]),
        "thrusters_J": e.thrusters,
        "joints_J": e.joints,
        "total_J": e.total,
        "distance_m": e.distance,
        "per_metre_J_per_m": e.per_metre,
        "cost_of_transport": e.total / (mass * 9.81 * e.distance),
        "mechanical_J": mechanical,
        "mechanical_cost_of_transport": mechanical / (mass * 9.81 * e.distance),
        "max_cross_track_m": float(cross.max()),
    }


def paper_runs(vehicle) -> list[dict]:
    """For each gait frequency: undulation alone, then the thrusters alone (straight body) and
    combined (half the amplitude) at its average speed."""
    mass = sum(inertia.mass for inertia in list(vehicle.model.inertias)[1:])
    start = dict(start_position=(0.0, 0.0, 0.0), heading=(1.0, 0.0, 0.0), dt=DT)
    rows = []
    for omega in PAPER_OMEGAS:
        gait = Gait("lateral_undulation", omega=omega, **PAPER_GAIT)
        swim = Scenario(duration=DURATION, controller="gait", gait=gait, **start)
        swim = _with_gains(swim, **PAPER_SERVO)
        swam = window_energy(run_scenario(vehicle, swim), mass)
        u = swam["speed"]
        # the straight body pushed by the X thrusters: the gait with zero amplitude and no offset
        # (on a straight line in still water from a start on it, nothing needs steering)
        straight = Gait(amplitude=0.0, k_theta=0.0, max_offset=0.0, thrust="surge")
        thrusters = Scenario(duration=DURATION, controller="gait", gait=straight, **start)
        thrusters = _with_gains(thrusters, u_d=u, **PAPER_SERVO)
        options = {**PAPER_GAIT, "amplitude": PAPER_GAIT["amplitude"] / 2}
        half = Gait("lateral_undulation", omega=omega, thrust="surge", **options)
        both = Scenario(duration=DURATION, controller="gait", gait=half, **start)
        both = _with_gains(both, u_d=u, **PAPER_SERVO)
        for mode, scenario in (("thrusters", thrusters), ("combined", both)):
            row = window_energy(run_scenario(vehicle, scenario), mass)
            rows.append({"omega": omega, "mode": mode, **row})
        rows.insert(len(rows) - 2, {"omega": omega, "mode": "undulation", **swam})
        for row in rows[-3:]:
            print({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()})
    return rows


def _with_gains(scenario: Scenario, **gains) -> Scenario:
    import dataclasses

    return dataclasses.replace(scenario, gains=PathFollowingGains.for_case("uniform", **gains))


def mamba_sweeps(vehicle) -> dict:
    out: dict = {"base": MAMBA_BASE, "servo": {"k_qp": 10.0, "k_qd": 0.3}}
    kinds = ("lateral_undulation", "eel_like")
    omegas = (1.0, 2.0, 3.0, 4.0)
    amplitudes = [math.radians(a) for a in (10, 20, 30, 40, 50, 60, 70, 80)]
    deltas = [math.radians(d) for d in (10, 20, 30, 40, 60, 80)]
    for kind in kinds:
        out[kind] = {
            "omega": [(w, mamba_speed(vehicle, kind, omega=w)) for w in omegas],
            "amplitude": [(a, mamba_speed(vehicle, kind, amplitude=a)) for a in amplitudes],
            "delta": [(d, mamba_speed(vehicle, kind, delta=d)) for d in deltas],
        }
    return out


def cross_track_runs() -> dict:
    out = {}
    for name in EXAMPLES:
        scenario = load_scenario(ROOT / "examples" / f"{name}.toml")
        vehicle = aiauv_pin.load_vehicle(scenario.vehicle)
        result = run_scenario(vehicle, scenario)
        info = result.trajectory.info
        out[name] = {
            # every 0.25 s (dt = 5 ms), to 0.1 mm
            "t": _rounded(np.asarray(result.trajectory.t)[::50]),
            "cross_track": _rounded(info["cross_track"][::50, 0]),
            "centre": _rounded(info["centre"][::50, :2]),
            "final_cross_track_m": float(info["cross_track"][-1, 0]),
            "max_abs_cross_track_last_30s_m": float(
                np.abs(
                    info["cross_track"][result.trajectory.t >= result.trajectory.t[-1] - 30, 0]
                ).max()
            ),
            "path": _rounded(default_path_points(result, 100)[:, :2]),
        }
    return out


def _rounded(values) -> list:
    return np.round(np.asarray(values, dtype=float), 4).tolist()


def figures(data: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    FIGURES.mkdir(parents=True, exist_ok=True)
    sweeps = data["mamba"]
    fig, axes = plt.subplots(1, 3, figsize=(10, 3.2), sharey=True)
    for kind, style in (("lateral_undulation", "o-"), ("eel_like", "s--")):
        for ax, key, scale, label in (
            (axes[0], "omega", 1.0, r"$\omega$ [rad/s]"),
            (axes[1], "amplitude", 180 / math.pi, r"$\alpha$ [deg]"),
            (axes[2], "delta", 180 / math.pi, r"$\delta$ [deg]"),
        ):
            x, y = np.array(sweeps[kind][key]).T
            ax.plot(x * scale, y, style, label=kind.replace("_", " "))
            ax.set_xlabel(label)
    axes[0].set_ylabel("average speed [m/s]")
    axes[0].legend()
    fig.suptitle("Mamba-like snake: average forward speed of the gaits")
    fig.tight_layout()
    fig.savefig(FIGURES / "gait_speeds.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 3.4))
    for mode, style in (("undulation", "o-"), ("thrusters", "s-"), ("combined", "^-")):
        rows = [r for r in data["paper_vehicle"] if r["mode"] == mode]
        ax.plot(
            [r["speed"] for r in rows], [r["cost_of_transport"] for r in rows], style, label=mode
        )
    ax.set(
        xlabel="average speed [m/s]",
        ylabel="cost of transport E/(m g d) [-]",
        title="Paper vehicle: cost of transport",
    )
    ax.legend()
    fig.tight_layout()
    fig.savefig(FIGURES / "cost_of_transport.png", dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(4, 1, figsize=(6, 10.5))
    for ax, name in zip(axes, EXAMPLES, strict=False):
        run = data["cross_track"][name]
        ax.plot(run["t"], run["cross_track"])
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set(
            xlabel="t [s]",
            ylabel="cross-track error [m]",
            title=f"examples/{name}.toml (centre of mass)",
        )
    run = data["cross_track"]["gait_waypoints"]
    path, centre = np.array(run["path"]), np.array(run["centre"])
    axes[3].plot(path[:, 0], path[:, 1], "k--", lw=0.8, label="path")
    axes[3].plot(centre[:, 0], centre[:, 1], label="centre of mass")
    axes[3].set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="gait_waypoints: plan view")
    axes[3].legend()
    fig.tight_layout()
    fig.savefig(FIGURES / "gait_cross_track.png", dpi=110)
    plt.close(fig)


def main() -> None:
    data: dict = {}
    mamba = aiauv_pin.load_vehicle(str(ROOT / "urdf" / "mamba_like.urdf"))
    data["mamba"] = mamba_sweeps(mamba)
    _write(data)
    data["paper_vehicle"] = paper_runs(aiauv_pin.load_vehicle(bundled_urdf("uniform")))
    _write(data)
    data["cross_track"] = cross_track_runs()
    _write(data)
    figures(data)


def _write(data: dict) -> None:
    tmp = OUT.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, OUT)


if __name__ == "__main__":
    main()
