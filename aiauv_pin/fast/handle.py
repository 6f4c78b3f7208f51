"""One object that carries a vehicle's records into compiled code from Python cheaply.

Calling a compiled kernel from Python costs numba a type check and an unboxing of every array it
is given; the kernels' records (:class:`~aiauv_pin.fast.records.Model`,
:class:`~aiauv_pin.fast.records.Workspace`) hold some 60 arrays, which cost more than one
evaluation itself (issue 15). A :class:`Handle` is a numba structure reference holding both
records: it crosses the boundary as one pointer, and the entry points below unpack it in compiled
code. The records inside share their arrays with the ones :class:`~aiauv_pin.fast.model.FastModel`
holds (no copy).

Handles are made by :func:`new_handle`, compiled and cached like every kernel (numba's own
constructor of a structure reference would be compiled again in every process).
"""

from __future__ import annotations

from numba import types
from numba.experimental import structref

from hydro.jit import compiled

from . import kernels


@structref.register
class HandleType(types.StructRef):
    """numba type of :class:`Handle` (fields ``model``, ``workspace``)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class Handle(structref.StructRefProxy):
    """A vehicle's :class:`~aiauv_pin.fast.records.Model` and its reusable workspace, as one object."""

    def __new__(cls, model, workspace):
        return structref.StructRefProxy.__new__(cls, model, workspace)


structref.define_proxy(Handle, HandleType, ["model", "workspace"])


@compiled
def new_handle(model, workspace):
    """A :class:`Handle` of ``model`` and ``workspace`` (compiled and cached)."""
    return Handle(model, workspace)


@compiled(fastmath=True)
def acceleration_of(handle, env, servo, t, q, v, tau, out):
    """:func:`aiauv_pin.fast.kernels.acceleration_into` on the records of ``handle``."""
    kernels.acceleration_into(handle.model, env, servo, t, q, v, tau, handle.workspace, out)


@compiled(fastmath=True)
def step_of(handle, env, servo, t, q, v, tau, dt, method, q_out, v_out):
    """:func:`aiauv_pin.fast.kernels.step_into` on the records of ``handle``."""
    kernels.step_into(
        handle.model, env, servo, t, q, v, tau, dt, method, handle.workspace, q_out, v_out
    )
