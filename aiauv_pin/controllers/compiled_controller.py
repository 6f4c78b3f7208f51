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

import numbers
import types
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aiauv_pin.controllers.gait_compiled import GaitInfo, gait_info_shapes, serpentine_gait
from aiauv_pin.controllers.info_rows import field_spans, info_offsets
from aiauv_pin.controllers.paper_compiled import (
    PaperInfo,
    ThrustInfo,
    constant_info_shapes,
    constant_parameters,
    constant_thrust,
    paper_info_shapes,
    paper_path_following,
    passive,
)
from aiauv_pin.controllers.torpedo_compiled import (
    TorpedoInfo,
    torpedo_info_shapes,
    torpedo_path_following,
)
from aiauv_pin.controllers.turning_compiled import (
    TurningInfo,
    thruster_turning,
    turning_info_shapes,
)
from aiauv_pin.errors import ArgumentError, RecordSizeError

#: The built-in compiled controllers: given to the compiled loop as ``None``, which chooses them by
#: their parameters' type (:func:`aiauv_pin.simulation.compiled_loop.run_controller`).
BUILTIN_CONTROLLERS = (
    passive,
    paper_path_following,
    thruster_turning,
    serpentine_gait,
    constant_thrust,
    torpedo_path_following,
)

_BOUNDS_CHECKED: dict = {}


def bounds_checked(function, _seen: dict | None = None):
    """A copy of a user's numba function compiled with ``boundscheck=True``, together with every
    user's (not the project's) numba function it calls by a global name, recursively.

    Why: the compiled loop gives the controller arrays allocated for what it declares (``info`` of
    :attr:`CompiledController.info_width` floats, ``tau`` of ``nv``) and its own records; numba
    does not check indices, so a controller that writes past them corrupts the heap.
    Checked indexing is the cheapest sound guard: a compare per access in the user's own code
    (the project's kernels it calls stay unchecked; they size their writes by the vehicle), where
    a guard zone after ``info`` would catch only writes that land in it, and a first sample only
    the branches that sample takes. A write out of bounds raises ``IndexError`` inside the loop,
    which :func:`aiauv_pin.errors.as_project_error` turns into a
    :class:`~aiauv_pin.errors.RecordSizeError`.

    The copy is not cached on its own (numba's disk cache does not key on ``boundscheck``, so a
    cached copy could load the unchecked code); it is named by its content instead
    (:func:`aiauv_hydro.numerics.function_identity.stable_uuid`: source, globals, options
    including ``boundscheck``), so that the compiled loop that calls it is cached across processes
    (:func:`aiauv_pin.simulation.compiled_loop.loop_for`). A function without readable source
    (defined in a REPL) gets no such name, and the loop calling it is compiled in every process.
    """
    checked = _BOUNDS_CHECKED.get(function)
    if checked is not None:
        return checked
    import numba

    from aiauv_hydro.numerics.function_identity import stable_uuid
    from aiauv_hydro.numerics.jit import is_project_function

    seen = {} if _seen is None else _seen
    if function in seen:  # recursion between a user's functions: the one being built
        return function
    seen[function] = None
    py_func = function.py_func
    names = set(py_func.__code__.co_names)
    namespace = py_func.__globals__
    replaced = {
        name: bounds_checked(value, seen)
        for name, value in namespace.items()
        if name in names
        and hasattr(value, "py_func")
        and not is_project_function(value)
        and value is not function
    }
    if replaced:
        namespace = {**namespace, **replaced}
    copy = types.FunctionType(
        py_func.__code__, namespace, py_func.__name__, py_func.__defaults__, py_func.__closure__
    )
    copy.__qualname__ = py_func.__qualname__
    copy.__module__ = py_func.__module__
    options = {
        key: value
        for key, value in getattr(function, "targetoptions", {}).items()
        if key in ("fastmath", "error_model", "nogil")
    }
    checked = numba.njit(boundscheck=True, cache=False, **options)(copy)
    stable_uuid(checked)  # before anything pickles it (numba's cache index)
    _BOUNDS_CHECKED[function] = checked
    return checked


def _sizes_of_builtin(function, n_joints: int, n_thrusters: int, n_fins: int = 0):
    """``(info shapes, record of their offsets, {parameter field: expected length})`` of a
    built-in controller for these sizes, or ``None`` (a user's controller)."""
    if function is passive:
        return {}, None, {}
    if function is constant_thrust:
        return constant_info_shapes(n_thrusters), ThrustInfo, {"thrusts": n_thrusters}
    if function is torpedo_path_following:
        shapes, record = torpedo_info_shapes(n_thrusters, n_fins), TorpedoInfo
        fields = {"surge_mask": n_thrusters}
        fields.update(dict.fromkeys(("rudder_share", "stern_share", "fin_limit"), n_fins))
    elif function is paper_path_following:
        shapes, record = paper_info_shapes(n_joints, n_thrusters), PaperInfo
        fields = {
            "axis_index": n_joints,
            "reference_scale": n_joints,
            "servo_references": n_joints,
            "surge_mask": n_thrusters,
        }
    elif function is thruster_turning:
        shapes, record = turning_info_shapes(n_joints, n_thrusters), TurningInfo
        fields = dict.fromkeys(("plane", "force_coeff", "moment_coeff", "surge_mask"), n_thrusters)
        fields.update(dict.fromkeys(("joint_stiffness", "joint_damping"), n_joints))
    elif function is serpentine_gait:
        shapes, record = gait_info_shapes(n_joints, n_thrusters), GaitInfo
        fields = dict.fromkeys(
            ("tail_index", "joint_sign", "servo_references", "joint_stiffness", "joint_damping"),
            n_joints,
        )
        fields["surge_mask"] = n_thrusters
        fields["link_mass"] = n_joints + 1
    else:
        return None
    return shapes, record, fields


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

    @classmethod
    def constant(cls, vehicle, thrusts) -> CompiledController:
        """Constant thrusts [N], one per thruster of ``vehicle`` in its order, each saturated to
        its thruster's ``max_thrust`` (as the thrusters saturate commands); joints idle.

        Raises:
            ArgumentError: Not one finite thrust per thruster.
        """
        limits = np.array([t.max_thrust for t in vehicle.hydro.thrusters], dtype=float)
        values = np.asarray(thrusts, dtype=float).reshape(-1)
        if values.shape != limits.shape or not np.all(np.isfinite(values)):
            raise ArgumentError(
                f"constant thrusts: expected {limits.size} finite numbers (one per thruster), "
                f"got {np.asarray(thrusts).size}"
            )
        parameters = constant_parameters(np.clip(values, -limits, limits))
        return cls(constant_thrust, parameters, info_shapes=constant_info_shapes(limits.size))

    @property
    def loop_function(self):
        """What the compiled loop is given: ``None`` for a built-in controller (chosen there by its
        parameters, so that the cached loop's signature holds no function), else the user's
        function compiled bounds-checked (:func:`bounds_checked`)."""
        if self.function in BUILTIN_CONTROLLERS:
            return None
        return bounds_checked(self.function)

    def check_records(self, nq: int, nv: int, n_thrusters: int, n_fins: int = 0) -> None:
        """Refuse records the compiled loop would write or read past, for a vehicle of these sizes.

        ``function`` must be a numba function; ``info_shapes`` a mapping of names to shapes of
        non-negative whole numbers. A built-in controller writes a known info row and reads
        parameter arrays of known lengths (the vehicle's joints and thrusters): a declared row
        shorter than what it writes, or a record built for another vehicle, is refused. A user's
        function runs bounds-checked (:attr:`loop_function`).

        Raises:
            ArgumentError: Not a numba function, or malformed ``info_shapes``.
            RecordSizeError: A record smaller than what the controller writes or reads.
        """
        if not hasattr(self.function, "py_func"):
            raise ArgumentError(
                f"CompiledController.function must be a numba-compiled function, got "
                f"{type(self.function).__name__:.40}"
            )
        if not isinstance(self.info_shapes, Mapping):
            raise ArgumentError("CompiledController.info_shapes must be a mapping name -> shape")
        for key, shape in self.info_shapes.items():
            if (
                not isinstance(key, str)
                or not isinstance(shape, tuple)
                or not all(
                    isinstance(n, numbers.Integral) and not isinstance(n, bool) and 0 <= n <= 2**20
                    for n in shape
                )
            ):
                raise ArgumentError(
                    f"CompiledController.info_shapes[{key!r:.40}] must be a tuple of whole "
                    f"numbers in [0, {2**20}], got {shape!r:.40}"
                )
        sizes = _sizes_of_builtin(self.function, nv - 6, n_thrusters, n_fins)
        if sizes is None:
            return
        shapes, record, fields = sizes
        width = sum(size for _, _, size in field_spans(shapes))
        if self.info_width < width:
            raise RecordSizeError(
                f"CompiledController.info_shapes declare {self.info_width} floats per info row; "
                f"{self.function.__name__} writes {width} for this vehicle"
            )
        for name, length in fields.items():
            array = getattr(self.parameters, name, None)
            if not isinstance(array, np.ndarray) or array.shape != (length,):
                got = array.shape if isinstance(array, np.ndarray) else type(array).__name__
                raise RecordSizeError(
                    f"CompiledController.parameters.{name} must have shape ({length},) for this "
                    f"vehicle ({nv - 6} joints, {n_thrusters} thrusters, {n_fins} fins), got {got}"
                )
        if record is not None and getattr(self.parameters, "info", None) != info_offsets(
            shapes, record
        ):
            raise RecordSizeError(
                f"CompiledController.parameters.info must be the offsets of "
                f"{self.function.__name__}'s info row for this vehicle "
                f"({info_offsets(shapes, record)}), got {getattr(self.parameters, 'info', None)!r:.200}"
            )

    @property
    def info_width(self) -> int:
        """Number of floats in one info row."""
        return sum(size for _, _, size in field_spans(self.info_shapes))

    def unpack(self, block: np.ndarray, *, copy: bool = True) -> dict[str, np.ndarray]:
        """Split info rows ``(..., info_width)`` into the named diagnostics: copies, or with
        ``copy=False`` views into ``block`` (no memory of their own)."""
        out = {}
        for key, offset, size in field_spans(self.info_shapes):
            shape = self.info_shapes[key]
            part = block[..., offset : offset + size].reshape(block.shape[:-1] + tuple(shape))
            out[key] = np.array(part) if copy else part
        return out


def check_compiled_controller(controller, nq: int, nv: int, n_thrusters: int, n_fins: int = 0):
    """``controller`` (a :class:`~aiauv_pin.controllers.compiled_controller.CompiledController`)
    checked before the
    compiled loop runs it: its declared ``info_shapes`` at least what a built-in controller writes
    for this vehicle, and its records for this vehicle's sizes
    (:meth:`~aiauv_pin.controllers.compiled_controller.CompiledController.check_records`). A user's
    function is run
    bounds-checked
    (:attr:`~aiauv_pin.controllers.compiled_controller.CompiledController.loop_function`), so it cannot
    write past what was allocated either.

    Raises:
        ArgumentError: Not a compiled controller.
        RecordSizeError: A record smaller than what the controller writes or reads.
    """
    if not isinstance(controller, CompiledController):
        raise ArgumentError(
            f"controller must be a CompiledController, got {type(controller).__name__:.40}"
        )
    controller.check_records(nq, nv, n_thrusters, n_fins)
    return controller
