"""One object that carries a vehicle's records into compiled code from Python cheaply.

Calling a compiled kernel from Python costs numba a type check and an unboxing of every array it
is given; the kernels' records (:class:`~aiauv_pin.kernels.records.Model`,
:class:`~aiauv_pin.kernels.records.Workspace`) hold some 60 arrays, which cost more than one
evaluation itself. A :class:`Handle` is a numba structure reference holding both
records: it crosses the boundary as one pointer, and the entry points below unpack it in compiled
code. The records inside share their arrays with the ones :class:`~aiauv_pin.kernels.evaluation.FastModel`
holds (no copy).

Handles are made by :func:`new_handle`, compiled and cached like every kernel (numba's own
constructor of a structure reference would be compiled again in every process).

The entry points pass the records on to the kernels *borrowed* (:func:`_on_records`): reading
``handle.model`` in compiled code increments the reference count of every array in the record
(some 100 arrays for the model and the workspace, atomically) and decrements it again after the
call, and numba's pruning of such pairs does not see across a call that may raise: a large share
of one checked evaluation from Python (the figures are on the docs' performance page). The handle
holds a reference to each record for as long as it lives, and the caller holds the handle for the
whole call, so the kernel may use the records without counting.
"""

from __future__ import annotations

import math

from numba import types
from numba.experimental import structref
from numba.extending import intrinsic

from aiauv_hydro.numerics.jit import compiled
from aiauv_hydro.numerics.spatial import (
    QUATERNION_NOT_UNIT,
    QUATERNION_UNIT,
    unit_quaternion_check,
)
from aiauv_pin._internal.array_checks import EXACT_QUATERNION_DEVIATION, QUATERNION_TOLERANCE
from aiauv_pin.kernels import articulated_body as kernels


@structref.register
class HandleType(types.StructRef):
    """numba type of :class:`Handle` (fields ``model``, ``workspace``, ``still_water``, ``no_servo``)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class Handle(structref.StructRefProxy):
    """A vehicle's :class:`~aiauv_pin.kernels.records.Model`, its reusable workspace and its still-water
    :class:`~aiauv_pin.kernels.records.Environment` and empty :class:`~aiauv_pin.kernels.records.Servo`
    records, as one object."""

    def __new__(cls, model, workspace, still_water, no_servo):
        return structref.StructRefProxy.__new__(cls, model, workspace, still_water, no_servo)


structref.define_proxy(Handle, HandleType, ["model", "workspace", "still_water", "no_servo"])


@compiled
def new_handle(model, workspace, still_water, no_servo):
    """A :class:`Handle` of these records (compiled and cached)."""
    return Handle(model, workspace, still_water, no_servo)


def _on_records(typingctx, kernel, handle, own_types, layout):
    """``(signature, codegen)`` of an intrinsic that calls the compiled ``kernel`` with records of
    ``handle`` borrowed (no reference counting, see the module docstring) among its arguments.

    Args:
        typingctx: numba's typing context (the intrinsic's first argument).
        kernel: A compiled kernel (numba dispatcher) returning nothing or a scalar.
        handle: The :class:`HandleType` of the intrinsic's first argument.
        own_types: Types of the intrinsic's other arguments.
        layout: One entry per argument of ``kernel``: a field name of the handle (``"model"``,
            ``"workspace"``, ``"still_water"``, ``"no_servo"``), the index of one of the
            intrinsic's other arguments, or a float (a ``float64`` constant).
    """
    fields = handle.field_dict

    def type_of(item):
        if isinstance(item, str):
            return fields[item]
        if isinstance(item, int):
            return own_types[item]
        return types.float64

    function_type = typingctx.resolve_value_type(kernel)
    callee = typingctx.resolve_function_type(
        function_type, tuple(type_of(item) for item in layout), {}
    )
    signature = callee.return_type(handle, *own_types)

    def codegen(context, builder, signature, args):
        records = structref._Utils(context, builder, handle).get_data_struct(args[0])
        values = []
        for item, wanted in zip(layout, callee.args, strict=True):
            if isinstance(item, str):
                value, given = getattr(records, item), fields[item]
            elif isinstance(item, int):
                value, given = args[1 + item], own_types[item]
            else:
                value, given = context.get_constant(types.float64, item), types.float64
            values.append(context.cast(builder, value, given, wanted))
        return context.get_function(function_type, callee)(builder, values)

    return signature, codegen


def _records_or(argument, field: str):
    """``field`` when ``argument`` (a type) is ``None``: the handle's own record instead."""
    return field if isinstance(argument, (types.NoneType, types.Omitted)) else None


@intrinsic
def acceleration_into_records(typingctx, handle, env, servo, t, q, v, tau, out):
    """:func:`aiauv_pin.kernels.articulated_body.acceleration_into` on the model and workspace of
    ``handle`` (borrowed, :func:`_on_records`); ``env`` / ``servo`` ``None``: the handle's
    still-water and empty-servo records."""
    layout = (
        "model",
        _records_or(env, "still_water") or 0,
        _records_or(servo, "no_servo") or 1,
        2,
        3,
        4,
        5,
        "workspace",
        6,
        0.0,
    )
    return _on_records(
        typingctx, kernels.acceleration_into, handle, (env, servo, t, q, v, tau, out), layout
    )


@intrinsic
def step_into_records(typingctx, handle, env, servo, t, q, v, tau, dt, method, q_out, v_out):
    """:func:`aiauv_pin.kernels.articulated_body.step_into` on the model and workspace of
    ``handle`` (borrowed, :func:`_on_records`); ``env`` / ``servo`` ``None``: the handle's
    still-water and empty-servo records."""
    layout = (
        "model",
        _records_or(env, "still_water") or 0,
        _records_or(servo, "no_servo") or 1,
        2,
        3,
        4,
        5,
        6,
        7,
        "workspace",
        8,
        9,
    )
    own = (env, servo, t, q, v, tau, dt, method, q_out, v_out)
    return _on_records(typingctx, kernels.step_into, handle, own, layout)


@intrinsic
def thrust_matrix_records(typingctx, handle, q, out):
    """:func:`aiauv_pin.kernels.articulated_body.thrust_matrix` on the model and workspace of
    ``handle`` (borrowed, :func:`_on_records`)."""
    return _on_records(
        typingctx, kernels.thrust_matrix, handle, (q, out), ("model", 0, "workspace", 1)
    )


@intrinsic
def stage_sizes(typingctx, handle):
    """``(nq, nv)`` of ``handle``'s workspace (the sizes of ``q_stage`` and ``v_stage``), read
    without counting references."""
    fields = handle.field_dict
    workspace = fields["workspace"]
    q_index = workspace.fields.index("q_stage")
    v_index = workspace.fields.index("v_stage")

    def codegen(context, builder, signature, args):
        records = structref._Utils(context, builder, handle).get_data_struct(args[0])
        W = records.workspace
        sizes = []
        for index in (q_index, v_index):
            array_type = workspace.types[index]
            array = context.make_array(array_type)(
                context, builder, builder.extract_value(W, index)
            )
            sizes.append(builder.extract_value(array.shape, 0))
        return context.make_tuple(builder, signature.return_type, sizes)

    return types.UniTuple(types.intp, 2)(handle), codegen


@intrinsic
def q_stage_of(typingctx, handle):
    """``handle.workspace.q_stage`` (one reference counted, not the whole workspace's)."""
    workspace = handle.field_dict["workspace"]
    index = workspace.fields.index("q_stage")
    array_type = workspace.types[index]

    def codegen(context, builder, signature, args):
        records = structref._Utils(context, builder, handle).get_data_struct(args[0])
        array = builder.extract_value(records.workspace, index)
        context.nrt.incref(builder, array_type, array)
        return array

    return array_type(handle), codegen


#: :func:`checked_acceleration_of`'s verdicts: the state is usable, or which argument is not.
STATE_OK, STATE_Q_NOT_FINITE, STATE_V_NOT_FINITE, STATE_TAU_NOT_FINITE = 0, 1, 2, 3
STATE_QUATERNION_NOT_UNIT, STATE_T_NOT_FINITE, STATE_NOT_CONTIGUOUS = 4, 5, 6
STATE_WRONG_SIZE = 7
#: :func:`checked_step_of`'s verdict when the step itself gave a non-finite state (``dt`` far
#: beyond what the vehicle's dynamics allow, e.g. ``1e308`` s).
STATE_RESULT_NOT_FINITE = 8


@compiled
def state_verdict(t, q, v, tau, nq, nv, q_unit):
    """Check a state as :mod:`aiauv_pin._internal.array_checks` does, in compiled code: sizes
    ``nq`` and ``nv``, contiguous, all finite, and the base quaternion ``q[3:7]`` of unit norm
    within :data:`~aiauv_pin._internal.array_checks.QUATERNION_TOLERANCE` (normalised when it
    deviates by more than :data:`~aiauv_pin._internal.array_checks.EXACT_QUATERNION_DEVIATION`).

    Sizes and contiguity are checked here, from the shape and strides numba's unboxing copied
    from the arrays, before any element is read (cheaper than ``shape`` and ``flags`` in Python);
    the caller checks the dtype and that the arrays are 1-D, which the unboxing needs right (a 2-D
    array would overflow a 1-D record). The two tolerances are compile-time constants.

    The quaternion's rule is :func:`aiauv_hydro.numerics.spatial.unit_quaternion_check`, the one
    :func:`aiauv_pin._internal.array_checks.configuration` applies (not ``fastmath``: a normalised
    quaternion is bit-identical to the one it makes).

    Args:
        t: Time [s].
        q, v, tau: Configuration (nq,), velocity and generalised force (nv,).
        nq, nv: The vehicle's sizes.
        q_unit: Output (nq,): ``q`` with its quaternion normalised, written only when it needed it.

    Returns:
        ``(verdict, normalised)``: a ``STATE_*`` code, and whether ``q_unit`` holds the state.
    """
    if q.shape[0] != nq or v.shape[0] != nv or tau.shape[0] != nv:
        return STATE_WRONG_SIZE, False
    if q.strides[0] != 8 or v.strides[0] != 8 or tau.strides[0] != 8:
        return STATE_NOT_CONTIGUOUS, False
    if not math.isfinite(t):
        return STATE_T_NOT_FINITE, False
    for i in range(nq):
        if not math.isfinite(q[i]):
            return STATE_Q_NOT_FINITE, False
    for i in range(nv):
        if not math.isfinite(v[i]):
            return STATE_V_NOT_FINITE, False
    for i in range(nv):
        if not math.isfinite(tau[i]):
            return STATE_TAU_NOT_FINITE, False
    verdict, norm = unit_quaternion_check(
        q[3], q[4], q[5], q[6], QUATERNION_TOLERANCE, EXACT_QUATERNION_DEVIATION
    )
    if verdict == QUATERNION_NOT_UNIT:
        return STATE_QUATERNION_NOT_UNIT, False
    if verdict == QUATERNION_UNIT:
        return STATE_OK, False
    for i in range(nq):
        q_unit[i] = q[i]
    for i in range(3, 7):
        q_unit[i] = q[i] / norm
    return STATE_OK, True


@compiled(fastmath=True)
def checked_acceleration_of(handle, t, q, v, tau, out):
    """:func:`aiauv_pin.kernels.articulated_body.acceleration_into` in still water without servo, after
    :func:`state_verdict`; returns its verdict (``out`` is written only when it is ``STATE_OK``).

    One compiled call with the arguments checked inside it: the checked ``Vehicle.acceleration``
    from Python costs about what the unchecked one does; the records are passed on borrowed
    (:func:`acceleration_into_records`).
    """
    nq, nv = stage_sizes(handle)
    if out.shape[0] != nv:
        return STATE_WRONG_SIZE
    q_stage = q_stage_of(handle)
    verdict, normalised = state_verdict(t, q, v, tau, nq, nv, q_stage)
    if verdict != STATE_OK:
        return verdict
    state = q_stage if normalised else q
    acceleration_into_records(handle, None, None, t, state, v, tau, out)
    return STATE_OK


@compiled(fastmath=True)
def checked_step_of(handle, t, q, v, tau, dt, method, q_unit, q_out, v_out):
    """:func:`aiauv_pin.kernels.articulated_body.step_into` in still water without servo, after
    :func:`state_verdict` (``q_unit`` (nq,): scratch for the normalised ``q``); returns its
    verdict (``q_out, v_out`` hold the step only when it is ``STATE_OK``;
    ``STATE_RESULT_NOT_FINITE`` when the step gave a non-finite state). ``dt`` and ``method`` are
    checked by the caller; the records are passed on borrowed (:func:`step_into_records`)."""
    nq, nv = stage_sizes(handle)
    if q_unit.shape[0] != nq or q_out.shape[0] != nq or v_out.shape[0] != nv:
        return STATE_WRONG_SIZE
    verdict, normalised = state_verdict(t, q, v, tau, nq, nv, q_unit)
    if verdict != STATE_OK:
        return verdict
    state = q_unit if normalised else q
    step_into_records(handle, None, None, t, state, v, tau, dt, method, q_out, v_out)
    if not kernels.is_finite_state(q_out, v_out):
        return STATE_RESULT_NOT_FINITE
    return STATE_OK


@compiled(fastmath=True)
def acceleration_of(handle, env, servo, t, q, v, tau, out):
    """:func:`aiauv_pin.kernels.articulated_body.acceleration_into` on the records of ``handle``
    (borrowed, :func:`acceleration_into_records`)."""
    acceleration_into_records(handle, env, servo, t, q, v, tau, out)


@compiled(fastmath=True)
def step_of(handle, env, servo, t, q, v, tau, dt, method, q_out, v_out):
    """:func:`aiauv_pin.kernels.articulated_body.step_into` on the records of ``handle``
    (borrowed, :func:`step_into_records`)."""
    step_into_records(handle, env, servo, t, q, v, tau, dt, method, q_out, v_out)


@compiled(fastmath=True)
def run_rows_of(
    handle,
    env,
    servo,
    rows_q,
    rows_v,
    times,
    controls,
    currents,
    dt,
    n_steps,
    method,
    tau,
    frame,
    frame_rotation,
    frame_position,
    frame_twist,
    centre,
    done,
    first,
    stop,
):
    """:func:`aiauv_pin.kernels.articulated_body.run_rows` on the model and workspace of
    ``handle`` (the environments' batched step, :mod:`aiauv_pin.envs.batch`)."""
    kernels.run_rows(
        handle.model,
        env,
        servo,
        rows_q,
        rows_v,
        times,
        controls,
        currents,
        dt,
        n_steps,
        method,
        handle.workspace,
        tau,
        frame,
        frame_rotation,
        frame_position,
        frame_twist,
        centre,
        done,
        first,
        stop,
    )


@compiled(fastmath=True)
def thrust_matrix_of(handle, q, out):
    """:func:`aiauv_pin.kernels.articulated_body.thrust_matrix` on the records of ``handle``
    (borrowed, :func:`thrust_matrix_records`)."""
    thrust_matrix_records(handle, q, out)
