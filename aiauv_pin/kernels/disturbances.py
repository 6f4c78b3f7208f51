"""External disturbances: generalised forces evaluated at every integrator stage.

A disturbance adds a generalised force [N, N m] (nv,) to the equations of motion at the stage's own
time, configuration and velocity: a tether, waves, a test wrench. Two forms are accepted by
:func:`aiauv_pin.simulate`:

* a :class:`Disturbance`: a compiled function ``fn(t, q, v, parameters, tau)`` that *adds* its force
  to ``tau`` in place, with its parameter array; it runs inside the compiled loop (no Python per
  step). :func:`base_wrench_in_world` is built in; a user's own is any numba function with that
  signature, e.g.::

      @numba.njit
      def tether(t, q, v, parameters, tau):
          # spring from the base origin to an anchor, in the world: f = k (anchor - p)
          ...

* a plain Python callable ``fn(t, q, v) -> (nv,)``: it works with either backend, at Python speed
  (every integrator stage calls back into Python).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aiauv_hydro.numerics.function_identity import stable_uuid
from aiauv_hydro.numerics.jit import compiled, user_or_builtin
from aiauv_pin.errors import AiauvError
from aiauv_pin.kernels.rotations import quaternion_rotation


@compiled
def no_disturbance(t, q, v, parameters, tau):
    """Adds nothing."""
    return


@compiled
def base_wrench_in_world(t, q, v, parameters, tau):
    """A sinusoidal wrench on the base, given in world axes, applied at the base origin.

    ``w(t) = (f, n) sin(omega t + phi)`` with parameters ``(f (3) [N], n (3) [N m], omega [rad/s],
    phi [rad])``; ``omega = 0, phi = pi/2`` gives a constant wrench. The base's generalised force is
    the wrench in base axes, ``(R^T f, R^T n)`` (the free flyer's velocity is the base twist in base
    axes).
    """
    s = math.sin(parameters[6] * t + parameters[7])
    x, y, z, w = q[3], q[4], q[5], q[6]
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = quaternion_rotation(x, y, z, w)
    for k in range(2):
        a0 = parameters[3 * k] * s
        a1 = parameters[3 * k + 1] * s
        a2 = parameters[3 * k + 2] * s
        tau[3 * k] += r00 * a0 + r10 * a1 + r20 * a2
        tau[3 * k + 1] += r01 * a0 + r11 * a1 + r21 * a2
        tau[3 * k + 2] += r02 * a0 + r12 * a1 + r22 * a2


#: ``kind`` numbers of the built-in disturbances (a user's own function has none: ``-1``).
NONE, BASE_WRENCH = 0, 1


@compiled
def builtin_disturbance(kind, t, q, v, parameters, tau):
    """The built-in disturbance number ``kind`` (:data:`NONE`, :data:`BASE_WRENCH`)."""
    if kind == BASE_WRENCH:
        base_wrench_in_world(t, q, v, parameters, tau)


#: ``apply_disturbance(user, kind, t, q, v, parameters, tau)``: a user's function (``user``) or the
#: built-in ``kind`` (``user = None``); see :func:`aiauv_hydro.numerics.jit.user_or_builtin`.
apply_disturbance = user_or_builtin(builtin_disturbance)


@dataclass(frozen=True)
class Disturbance:
    """A compiled disturbance and its parameters (see the module docstring).

    Attributes:
        function: ``fn(t, q, v, parameters, tau)``, adding its generalised force to ``tau``.
        parameters: Its parameter array.
    """

    function: Callable
    parameters: np.ndarray

    def __post_init__(self) -> None:
        parameters = np.ascontiguousarray(self.parameters, dtype=float).reshape(-1)
        if not np.all(np.isfinite(parameters)):
            raise AiauvError("disturbance parameters must be finite")
        object.__setattr__(self, "parameters", parameters)
        if self.kind_code < 0 and hasattr(self.function, "py_func"):
            # named by content before any compiled call, so that the compiled code taking it is
            # found again by later processes (aiauv_hydro.numerics.function_identity)
            stable_uuid(self.function)

    @classmethod
    def none(cls) -> Disturbance:
        """No disturbance."""
        return cls(no_disturbance, np.zeros(0))

    @classmethod
    def base_wrench(cls, force, moment=(0.0, 0.0, 0.0), omega: float = 0.0, phase=None):
        """Wrench ``(force [N], moment [N m]) sin(omega t + phase)`` on the base, world axes.

        With ``omega = 0`` and no ``phase`` the wrench is constant.
        """
        if phase is None:
            phase = math.pi / 2 if omega == 0.0 else 0.0
        values = np.concatenate(
            (np.asarray(force, dtype=float).reshape(3), np.asarray(moment, dtype=float).reshape(3))
        )
        return cls(base_wrench_in_world, np.concatenate((values, [float(omega), float(phase)])))

    @property
    def kind_code(self) -> int:
        """``kind`` of :func:`builtin_disturbance` (-1 for a user's function)."""
        return {no_disturbance: NONE, base_wrench_in_world: BASE_WRENCH}.get(self.function, -1)

    @property
    def user_function(self):
        """The function to pass to compiled code: ``None`` for a built-in disturbance."""
        return None if self.kind_code >= 0 else self.function

    def generalized_force(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The disturbance's generalised force (nv,) at ``(t, q, v)``."""
        tau = np.zeros(np.asarray(v).shape[0])
        self.function(
            float(t), np.asarray(q, dtype=float), np.asarray(v, dtype=float), self.parameters, tau
        )
        return tau
