"""Controllers that run inside the compiled loop (no Python call per step).

:func:`aiauv_pin.simulate` takes either a plain Python callable ``controller(t, q, v) -> tau |
(tau, info)`` (any backend, Python speed) or a :class:`CompiledController`: a numba function with
the signature of :mod:`aiauv_pin.controllers.paper_compiled`, its parameters and state, and the layout of the
diagnostics it logs. The whole run then executes in compiled code.

A user's controller in about twenty lines: hold the body straight with a joint PD and push with
the two longitudinal thrusters::

    import numba, numpy as np
    import aiauv_pin
    from aiauv_pin.controllers.compiled_controller import CompiledController
    from aiauv_pin.kernels.articulated_body import kinematics, thrust_into

    @numba.njit
    def straight_and_forward(t, q, v, model, workspace, parameters, state, tau, info):
        kinematics(model.bodies, q, v, workspace)           # poses for B(q)
        thrust_into(model, workspace, parameters[2:], tau)  # tau = B(q) thrusts  (eq. 20)
        for j in range(q.shape[0] - 7):                     # joint PD to zero
            tau[6 + j] += -parameters[0] * q[7 + j] - parameters[1] * v[6 + j]
        info[0] = v[0]                                      # log the surge speed

    vehicle = aiauv_pin.load_vehicle()
    thrusts = np.array([0, 0, 20.0, 20.0, 0, 0, 0])        # the two X thrusters [N]
    controller = CompiledController(
        straight_and_forward, np.concatenate(([30.0, 50.0], thrusts)), info_shapes={"u": ()}
    )
    trajectory = aiauv_pin.simulate(vehicle, vehicle.neutral_configuration(),
                                    np.zeros(vehicle.nv), 60.0, 0.01, controller)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aiauv_pin.controllers.paper_compiled import passive


@dataclass(frozen=True)
class CompiledController:
    """A compiled controller for :func:`aiauv_pin.simulate`.

    Attributes:
        function: ``fn(t, q, v, model, workspace, parameters, state, tau, info)`` compiled with
            numba (see :mod:`aiauv_pin.controllers.paper_compiled`).
        parameters: Passed unchanged to every call (an array or a named tuple of arrays/floats).
        state: Passed to every call and updated in place by the controller.
        info_shapes: Name and shape of each logged diagnostic, in the order of the info row.
        servo: A :class:`aiauv_pin.dynamics.joint_servo.JointServo` run at every integrator stage (its
            references may be updated by the controller), or ``None``.
        reset: Called before a run to clear ``state`` (``None``: nothing to clear).
    """

    function: Callable
    parameters: Any = field(default_factory=lambda: np.zeros(0))
    state: Any = field(default_factory=lambda: np.zeros(0))
    info_shapes: Mapping[str, tuple[int, ...]] = field(default_factory=dict)
    servo: Any = None
    reset: Callable[[], None] | None = None

    @classmethod
    def passive(cls) -> CompiledController:
        """No input at all: thrusters and joints idle."""
        return cls(passive)

    @property
    def loop_function(self):
        """What the compiled loop is given: ``None`` for a built-in controller (chosen there by its
        parameters, so that the cached loop's signature holds no function), else the function."""
        from aiauv_pin.controllers.dispatch import BUILTIN_CONTROLLERS

        return None if self.function in BUILTIN_CONTROLLERS else self.function

    @property
    def info_width(self) -> int:
        """Number of floats in one info row."""
        return sum(int(np.prod(shape, dtype=int)) for shape in self.info_shapes.values())

    def unpack(self, block: np.ndarray, *, copy: bool = True) -> dict[str, np.ndarray]:
        """Split info rows ``(..., info_width)`` into the named diagnostics: copies, or with
        ``copy=False`` views into ``block`` (no memory of their own)."""
        out = {}
        offset = 0
        for key, shape in self.info_shapes.items():
            size = int(np.prod(shape, dtype=int))
            part = block[..., offset : offset + size].reshape(block.shape[:-1] + tuple(shape))
            out[key] = np.array(part) if copy else part
            offset += size
        return out
