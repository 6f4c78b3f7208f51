"""Actuator dynamics: how the produced thrust or fin angle follows its command, written once.

UUV Simulator's actuators (uuvsimulator/uuv_simulator, commit bfb40cb,
uuv_gazebo_plugins/uuv_gazebo_plugins/src/Dynamics.cc) have ``ZeroOrder`` dynamics (lines 85-88:
the output is the command) and ``FirstOrder`` dynamics (lines 109-125: ``state = state alpha +
(1 - alpha) cmd`` with ``alpha = exp(-dt / tau)``, the exact response of ``tau x' = cmd - x`` to a
command held over ``dt``). :func:`actuator_response` is that update, followed by a slew-rate limit
(the largest change over ``dt`` is ``max_rate dt``) and preceded by the command's saturation
(UUV Simulator's fin plugin clips the command to the joint limits before its dynamics,
src/FinPlugin.cc lines 150-156; its thruster plugin clamps the command the same way).

A time constant of 0 and an infinite rate give the command itself (bit for bit), so actuators
without dynamics behave exactly as before these options existed.
"""

from __future__ import annotations

import math

from aiauv_hydro.numerics.jit import compiled


@compiled
def actuator_response(state, command, limit, time_constant, max_rate, dt):
    """The actuator's output after ``dt`` [s] with ``command`` held from output ``state``.

    ``c = clip(command, -limit, limit)``; first order ``x = c + (state - c) exp(-dt / tau)``
    (exact; ``tau = 0``: ``x = c``); then ``|x - state| <= max_rate dt``.

    Args:
        state: Output at the start [N or rad].
        command: Command held over the interval [N or rad].
        limit: Magnitude limit of the command (``inf``: none).
        time_constant: ``tau`` [s], >= 0.
        max_rate: Slew-rate limit [N/s or rad/s], > 0 (``inf``: none).
        dt: Interval [s], >= 0.

    Returns:
        The output at the end of the interval.
    """
    target = min(max(command, -limit), limit)
    if time_constant > 0.0:
        target = target + (state - target) * math.exp(-dt / time_constant)
    if max_rate == math.inf:
        return target
    step = max_rate * dt
    if target - state > step:
        return state + step
    if state - target > step:
        return state - step
    return target
