"""The derivatives' section of ``aiauv bench``: cost of the exact Jacobians against one evaluation.

Measured in compiled code (no Python call in the timed loops), interleaved rounds on the same random
state of the paper vehicle with a current, best of the rounds (CPU time):

* one forward-dynamics evaluation (:func:`aiauv_pin.kernels.articulated_body.time_accelerations`);
* ``dv`` with all its Jacobians ``da_dq, da_dv, da_dtau, da_dcurrent``
  (:func:`aiauv_pin.kernels.step_jacobians.time_acceleration_derivatives`); target <= 8x one evaluation;
* one RK4 step with its transition Jacobians ``A, B``; target <= 40x one evaluation;
* one semi-implicit Euler step with its transition Jacobians.
"""

from __future__ import annotations

import time

import numpy as np

#: The targets of the derivatives' cost, as ratios to one evaluation.
TARGETS = {"all_jacobians": 8.0, "rk4_transition": 40.0}


def _clock() -> float:
    return time.process_time()


def derivative_timings(vehicle, quick: bool = False, rounds: int | None = None) -> dict:
    """Microseconds per evaluation, per derivative evaluation and per transition; their ratios."""
    import pinocchio as pin

    from aiauv_pin.model.derivatives import compiled_derivatives

    if vehicle.fast is None:
        return {"note": f"numba backend unavailable: {vehicle.fallback_reason}"}
    from aiauv_pin.kernels import articulated_body as kernels
    from aiauv_pin.kernels import step_jacobians as tr

    rng = np.random.default_rng(16)
    q = pin.neutral(vehicle.model)
    quaternion = rng.normal(size=4)
    q[3:7] = quaternion / np.linalg.norm(quaternion)
    q[7:] = rng.uniform(-0.5, 0.5, vehicle.nq - 7)
    v = 0.3 * rng.normal(size=vehicle.nv)
    tau = rng.normal(size=vehicle.nv)
    nv, m = vehicle.nv, len(vehicle.thruster_names)
    thrusts = rng.uniform(-10, 10, m)
    fast = vehicle.fast
    derivatives = compiled_derivatives(vehicle)
    env = fast.environment(np.array([0.2, -0.1, 0.05]))
    model, W, D = fast.model, fast.workspace, derivatives.workspace
    out = np.empty(nv)
    outputs = (
        np.empty(nv),
        np.empty((nv, nv)),
        np.empty((nv, nv)),
        np.empty((nv, nv)),
        np.empty((nv, 3)),
        np.empty((nv, 0)),
    )
    state = (np.empty(vehicle.nq), np.empty(nv))
    a_matrix, b_matrix = np.empty((2 * nv, 2 * nv)), np.empty((2 * nv, m + nv - 6))
    scale = 1 if quick else 5
    n_eval, n_deriv, n_step = 400 * scale, 40 * scale, 10 * scale

    def evaluation():
        kernels.time_accelerations(model, env, fast.no_servo, q, v, tau, n_eval, W, out)

    def jacobians():
        tr.time_acceleration_derivatives(model, env, q, v, tau, n_deriv, W, D, outputs)

    def transition(method):
        tr.time_transitions(
            model, env, q, v, tau, thrusts, 0.01, method, n_step, W, D, state, a_matrix, b_matrix
        )

    functions = {
        "evaluation": (evaluation, n_eval),
        "all_jacobians": (jacobians, n_deriv),
        "rk4_transition": (lambda: transition(kernels.RK4), n_step),
        "euler_transition": (lambda: transition(kernels.EULER), n_step),
    }
    for function, _ in functions.values():
        function()
    best = {name: float("inf") for name in functions}
    for _ in range(rounds or (5 if quick else 15)):
        for name, (function, units) in functions.items():
            start = _clock()
            function()
            best[name] = min(best[name], (_clock() - start) / units)
    us = {name: value * 1e6 for name, value in best.items()}
    results = {f"{name}_us": value for name, value in us.items()}
    for name in ("all_jacobians", "rk4_transition", "euler_transition"):
        results[f"ratio_{name}_to_evaluation"] = us[name] / us["evaluation"]
    results["targets"] = dict(TARGETS)
    results["state"] = "paper vehicle, random state, uniform current (0.2, -0.1, 0.05) m/s"
    return results


def format_rows(results: dict) -> list[str]:
    """Lines of the bench table for :func:`derivative_timings`' results."""
    if "note" in results:
        return [f"derivatives: {results['note']}"]
    lines = []
    labels = {
        "evaluation": "one evaluation (compiled)",
        "all_jacobians": "dv and da_dq, da_dv, da_dtau, da_dcurrent",
        "rk4_transition": "RK4 step with transition Jacobians A, B",
        "euler_transition": "Euler step with transition Jacobians A, B",
    }
    for name, label in labels.items():
        lines.append(f"{label:<48} {results[f'{name}_us']:10.2f} us")
        if name != "evaluation":
            ratio = results[f"ratio_{name}_to_evaluation"]
            target = results["targets"].get(name)
            suffix = f" (target <= {target:g}x)" if target else ""
            lines.append(f"{'  ratio to one evaluation':<48} {ratio:10.2f} x{suffix}")
    return lines
