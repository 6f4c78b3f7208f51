"""A user's compiled controller, written outside the project's packages, for ``aiauv bench``.

It is the paper's path following (Section 3 of Wrzos-Kaminska, Pettersen and Gravdahl, IFAC CAMS
2019) put together the way a user would: a plain ``numba.njit`` function (no on-disk cache, so the
compiled loop runs it in its uncached copy, :func:`aiauv_pin.simulation.compiled_loop.loop_for`)
that measures the
end-effector with the public kernels (:func:`aiauv_pin.kernels.articulated_body.kinematics`,
:func:`~aiauv_pin.kernels.articulated_body.frame_of_body_into`,
:func:`~aiauv_pin.kernels.articulated_body.restoring_into`),
calls the public law :func:`aiauv_control.laws.paper_laws.path_following_command` (eqs. 21-25) and acts with
:func:`~aiauv_pin.kernels.articulated_body.thrust_into` (eq. 20). Its parameters and state are the built-in
controller's records (:meth:`aiauv_pin.controllers.paper_controller.VehiclePathFollowing.compiled`), so both
run the same scenario with the same gains; it logs fewer diagnostics (end-effector position, surge
speed, cross-track errors, path parameter).

``aiauv bench`` times it against the built-in
:func:`aiauv_pin.controllers.paper_compiled.paper_path_following`
on the 300 s paper scenario (issue 12: a user's compiled controller within 1.5x of the built-in's
speed); tests/tools/test_bench.py checks that both give the same trajectory.

Run as a script, it measures what a user's second process pays before its first result (issues 28
and 34): ``python benchmarks/user_controller.py --runs 5`` starts one process that compiles the loop
for :func:`user_path_following` (if the cache does not hold it yet), then ``--runs`` fresh processes
that each time their first 1 s run of the paper scenario with it (set-up: loading or compiling,
plus the 1 s run) and count numba's compilations (:class:`aiauv_pin.simulation.compilation.CompilationWatch`).
``--uncached`` runs the loop the way it ran before it was cached by content (the uncached copy,
compiled in every process), for comparison. Prints and writes ``benchmarks/user_setup.json``
(median and range, with the load average before and after).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numba

from aiauv_control.laws.paper_laws import path_following_command
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.kernels.articulated_body import (
    frame_of_body_into,
    kinematics,
    restoring_into,
    thrust_into,
)

#: The diagnostics :func:`user_path_following` logs, in the order of its info row.
USER_INFO_SHAPES = {"p": (3,), "u": (), "cross_track": (2,), "path_s": ()}


@numba.njit
def user_path_following(t, q, v, model, workspace, parameters, state, tau, info):
    """Paper path following from the public laws (see the module docstring).

    ``parameters`` is :class:`aiauv_pin.controllers.paper_compiled.PaperParameters`, ``state``
    :class:`~aiauv_pin.controllers.paper_compiled.PaperState`.
    """
    kinematics(model.bodies, q, v, workspace)
    m = state.measurement  # buffers (FrameMeasurement): nothing is allocated per sample
    R, p, twist = m.rotation, m.position, m.twist
    frame_of_body_into(
        workspace,
        parameters.frame_body,
        parameters.frame_rotation,
        parameters.frame_translation,
        R,
        p,
        twist,
    )
    velocity, omega, acceleration = m.velocity, m.omega, m.acceleration
    for i in range(3):
        velocity[i] = R[i, 0] * twist[0] + R[i, 1] * twist[1] + R[i, 2] * twist[2]  # world [m/s]
        omega[i] = twist[3 + i]  # end-effector axes [rad/s]
        acceleration[i] = 0.0
    # acceleration: finite difference of the velocity since the previous sample (zero at the first)
    history = m.history  # has previous, time [s], previous velocity (3) [m/s]
    if history[0] != 0.0 and t > history[1]:
        for i in range(3):
            acceleration[i] = (velocity[i] - history[2 + i]) / (t - history[1])
    history[0] = 1.0
    history[1] = t
    history[2:] = velocity
    restoring_into(model, workspace, workspace.restoring)  # g(q), left-hand side
    out = state.command
    path_following_command(  # eqs. (21)-(25)
        parameters.gains,
        parameters.path_function,
        parameters.path_kind,
        parameters.path_parameters,
        parameters.axis_index,
        parameters.reference_scale,
        parameters.surge_mask,
        state.surge,
        state.guidance,
        t,
        R,
        p,
        velocity,
        acceleration,
        omega,
        twist[0],
        q[7:],
        v[6:],
        workspace.restoring[6:],
        (0.0, 0.0, 0.0),  # restoring moment: only the hydrostatic compensation (off here) reads it
        out,
    )
    thrust_into(model, workspace, out.thrusts, tau)  # tau = B(q) thrusts, eq. (20)
    if parameters.continuous_joints:  # eq. (24) runs as the servo at every stage
        parameters.servo_references[:] = out.joint_references
    else:  # eq. (24) sampled with the rest
        tau[6:] += out.joint_torques
    info[:3] = p
    info[3] = twist[0]
    info[4:6] = out.cross_track
    info[6] = out.path_s[0]


def user_controller(built_in: CompiledController) -> CompiledController:
    """:func:`user_path_following` with the parameters, state, servo and reset of ``built_in``
    (the paper's controller for the same scenario, :meth:`VehiclePathFollowing.compiled`)."""
    return CompiledController(
        user_path_following,
        built_in.parameters,
        built_in.state,
        USER_INFO_SHAPES,
        built_in.servo,
        built_in.reset,
    )


def _second_process(uncached: bool) -> dict:
    """In this process: the set-up time [s] of a 1 s paper run with the user's controller, and the
    functions numba compiled for it."""
    from aiauv_pin.simulation.compilation import CompilationWatch

    start = time.perf_counter()
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.model import loading
    from aiauv_pin.scenario.definition import Scenario, initial_state
    from aiauv_pin.simulation import compiled_loop
    from aiauv_pin.simulation.fixed_step import simulate

    if uncached:  # the loop as it ran before: compiled in memory for a user's function
        compiled_loop._run_chunk_for = lambda uuids: compiled_loop._run_chunk_uncached()
    scenario = Scenario()
    vehicle = loading.load_vehicle(loading.bundled_urdf(scenario.case))
    q0, v0 = initial_state(vehicle, scenario)
    adapter = VehiclePathFollowing(
        vehicle,
        scenario.controller_gains,
        continuous_joints=scenario.continuous_joints,
        path=scenario.path_to_follow,
    )
    controller = user_controller(adapter.compiled())
    ready = time.perf_counter()
    with CompilationWatch(notice=False) as watch:
        simulate(
            vehicle,
            q0,
            v0,
            1.0,
            scenario.dt,
            controller,
            method=scenario.method,
            current=scenario.water,
            control_period=scenario.control_period,
            log_every=scenario.steps_per_control,
        )
    done = time.perf_counter()
    return {"first_run_s": done - ready, "imports_and_vehicle_s": ready - start,
            "compiled": len(watch.compiled)}  # fmt: skip


def _measure(runs: int, uncached: bool) -> dict:
    """``runs`` fresh processes after one that fills the cache (see the module docstring)."""
    command = [sys.executable, __file__, "--child"] + (["--uncached"] if uncached else [])

    def child() -> dict:
        done = subprocess.run(command, capture_output=True, text=True, check=True)
        return json.loads(done.stdout.strip().splitlines()[-1])

    warm = child()
    load_before = os.getloadavg()
    samples = [child() for _ in range(runs)]
    load_after = os.getloadavg()
    first = [s["first_run_s"] for s in samples]
    return {
        "loop": "uncached copy (before)" if uncached else "cached by content",
        "runs": runs,
        "warm_up_process": warm,
        "first_run_s_median": statistics.median(first),
        "first_run_s_range": [min(first), max(first)],
        "compiled_per_process": [s["compiled"] for s in samples],
        "imports_and_vehicle_s_median": statistics.median(
            s["imports_and_vehicle_s"] for s in samples
        ),
        "load_average_before_after": [load_before, load_after],
    }


if __name__ == "__main__":
    if "--child" in sys.argv:
        print(json.dumps(_second_process("--uncached" in sys.argv)))
    else:
        runs = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else 3
        result = _measure(runs, "--uncached" in sys.argv)
        print(json.dumps(result, indent=2))
        out = Path(__file__).with_name("user_setup.json")
        previous = json.loads(out.read_text()) if out.is_file() else {}
        previous[result["loop"]] = result
        out.write_text(json.dumps(previous, indent=2) + "\n")
