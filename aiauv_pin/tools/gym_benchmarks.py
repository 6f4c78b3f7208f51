"""``aiauv bench --only gym``: steps per second of the Gymnasium environments against MuJoCo's
``Swimmer-v5``, in the same process.

* single environment: ``env.step`` of ``aiauv/Swimming-v0`` and ``aiauv/PathFollowing-v0``
  against ``Swimmer-v5``, all made with :func:`gymnasium.make` (so the same wrappers), random
  actions drawn beforehand, an episode's end followed by ``reset`` (its cost counted), rounds
  interleaved (one block of each per round, so that load changes hit all alike); the ratio is
  taken per round;
* vector environment: ``gymnasium.make_vec("aiauv/Swimming-v0", num_envs=N)`` (one compiled call
  per thread, :class:`aiauv_pin.envs.vector.VehicleVectorEnv`) against ``Swimmer-v5`` in
  Gymnasium's ``SyncVectorEnv``, for N = 1, 8, 64, in environment steps per second
  (``N * calls / s``);
* the physics of one step on each side (links, degrees of freedom, fluid terms, integrator,
  substeps), read from the models, so the ratio is read with what each step computes.

Wall-clock time (:func:`time.perf_counter`): the vector environment runs on several threads.
Median, range (min to max) and the machine load before and after.
"""

from __future__ import annotations

import os
import statistics
import time

import numpy as np

#: Vector sizes measured.
VECTOR_SIZES = (1, 8, 64)


def _spread(values: list[float]) -> dict:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def _stepper(env, actions):
    """A block of ``len(actions)`` steps of ``env`` (reset at an episode's end); returns seconds."""

    def block() -> float:
        start = time.perf_counter()
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if np.any(terminated) or np.any(truncated):
                if getattr(env, "num_envs", None) is None:
                    env.reset()
        return time.perf_counter() - start

    return block


def physics() -> dict:
    """What one environment step computes, on each side."""
    import gymnasium
    import mujoco

    from aiauv_pin.envs import SwimmingEnv

    ours = SwimmingEnv()
    vehicle, sim = ours.vehicle, ours.sim
    links = vehicle.hydro.links
    terms = {
        "added_mass_6x6": sum(bool(link.added_mass.any()) for link in links),
        "linear_damping": sum(bool(link.linear_damping.any()) for link in links),
        "quadratic_damping": sum(bool(link.quadratic_damping.any()) for link in links),
        "crossflow_drag": sum(link.crossflow is not None for link in links),
        "buoyancy": sum(link.volume > 0 for link in links),
    }
    ours.close()
    swimmer = gymnasium.make("Swimmer-v5")
    model = swimmer.unwrapped.model
    result = {
        "aiauv/Swimming-v0": {
            "links": vehicle.model.njoints - 1,
            "dof": vehicle.nv,
            "fluid_terms_links": terms,
            "integrator": sim.method,
            "dt_s": sim.dt,
            "substeps": sim.substeps,
            "step_s": sim.dt * sim.substeps,
        },
        "Swimmer-v5": {
            "links": int(model.nbody - 1),
            "dof": int(model.nv),
            "fluid": f"MuJoCo's inertia-box model: viscous drag (viscosity "
            f"{model.opt.viscosity:g}) and quadratic drag (density {model.opt.density:g}) on "
            f"each body's equivalent box; no added mass, no buoyancy",
            "integrator": mujoco.mjtIntegrator(model.opt.integrator).name,
            "dt_s": float(model.opt.timestep),
            "substeps": int(swimmer.unwrapped.frame_skip),
            "step_s": float(model.opt.timestep * swimmer.unwrapped.frame_skip),
        },
    }
    swimmer.close()
    return result


def gym_timings(quick: bool = False) -> dict:
    """Steps per second of the environments and of ``Swimmer-v5`` (see the module docstring)."""
    import gymnasium

    import aiauv_pin.envs  # noqa: F401  (registers the environments)

    rounds, steps = (3, 300) if quick else (9, 2000)
    load_before = os.getloadavg()
    rng = np.random.default_rng(0)
    envs = {
        name: gymnasium.make(name)
        for name in ("aiauv/Swimming-v0", "aiauv/PathFollowing-v0", "Swimmer-v5")
    }
    blocks = {}
    for name, env in envs.items():
        env.reset(seed=0)
        shape = env.action_space.shape
        blocks[name] = _stepper(env, rng.uniform(-1.0, 1.0, (steps, *shape)))
        blocks[name]()  # warm: compiled code loaded, first allocations
    per_round: dict = {name: [] for name in envs}
    for _ in range(rounds):
        for name, block in blocks.items():
            per_round[name].append(steps / block())
    for env in envs.values():
        env.close()
    single = {name: _spread(values) for name, values in per_round.items()}
    for name in ("aiauv/Swimming-v0", "aiauv/PathFollowing-v0"):
        ratios = [a / b for a, b in zip(per_round[name], per_round["Swimmer-v5"], strict=True)]
        single[name]["ratio_to_swimmer_v5"] = _spread(ratios)

    vector = {}
    for n in VECTOR_SIZES:
        calls = max(20, (steps // 4 if quick else steps) // n)
        pair = {
            "aiauv/Swimming-v0": gymnasium.make_vec("aiauv/Swimming-v0", num_envs=n),
            "Swimmer-v5 (SyncVectorEnv)": gymnasium.make_vec(
                "Swimmer-v5", num_envs=n, vectorization_mode="sync"
            ),
        }
        timed = {}
        for name, env in pair.items():
            env.reset(seed=0)
            timed[name] = _stepper(env, rng.uniform(-1.0, 1.0, (calls, *env.action_space.shape)))
            timed[name]()
        rates: dict = {name: [] for name in pair}
        for _ in range(rounds):
            for name, block in timed.items():
                rates[name].append(n * calls / block())
        for env in pair.values():
            env.close()
        ours, theirs = rates["aiauv/Swimming-v0"], rates["Swimmer-v5 (SyncVectorEnv)"]
        vector[str(n)] = {
            "env_steps_per_s": _spread(ours),
            "swimmer_v5_sync_env_steps_per_s": _spread(theirs),
            "ratio_to_swimmer_v5_sync": _spread([a / b for a, b in zip(ours, theirs, strict=True)]),
        }
    return {
        "rounds": rounds,
        "steps_per_round": steps,
        "cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "load_before": list(load_before),
        "load_after": list(os.getloadavg()),
        "physics": physics(),
        "single_steps_per_s": single,
        "vector": vector,
    }


def format_gym(results: dict) -> list[str]:
    """Lines of the table of ``aiauv bench`` for :func:`gym_timings`' results."""
    gym = results.get("gym")
    if not gym:
        return []
    lines = []

    def spread(label: str, s: dict, unit: str = "/s") -> None:
        lines.append(f"{label:<48} {s['median']:10.0f} {unit} ({s['min']:.0f}-{s['max']:.0f})")

    for name, s in gym["single_steps_per_s"].items():
        spread(f"env.step {name}", s)
        if "ratio_to_swimmer_v5" in s:
            r = s["ratio_to_swimmer_v5"]
            lines.append(
                f"{'  ratio to Swimmer-v5':<48} {r['median']:10.3f}x ({r['min']:.3f}-{r['max']:.3f})"
            )
    for n, row in gym["vector"].items():
        spread(f"vector Swimming-v0, N={n}: env steps", row["env_steps_per_s"])
        spread(f"  Swimmer-v5 SyncVectorEnv, N={n}", row["swimmer_v5_sync_env_steps_per_s"])
    for name, p in gym["physics"].items():
        lines.append(
            f"  {name}: {p['links']} links, {p['dof']} DOF, {p['integrator']} "
            f"{p['substeps']} x {p['dt_s']:g} s per step"
        )
    load = gym["load_before"][0], gym["load_after"][0]
    lines.append(f"{'  load (1 min) before, after':<48} {load[0]:.2f}, {load[1]:.2f}")
    return lines
