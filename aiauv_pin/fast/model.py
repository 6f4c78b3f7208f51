"""Flat arrays of a :class:`aiauv_pin.Vehicle` for the numba kernels, and thin Python wrappers.

The arrays are built from the same per-body data the Pinocchio path uses (the model's joint
placements and inertias, :class:`~aiauv_pin.Vehicle`'s added mass per body, link transforms,
damping matrices, crossflow cylinders, buoyancy and thrusters), so both paths describe one set of
equations.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from hydro.crossflow import DEFAULT_NODES, gauss_legendre_unit

from . import kernels

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}

#: ``(method name -> code)`` understood by :func:`kernels.run_steps`.
METHOD_CODES = {"rk4": 0, "euler": 1}


def unsupported_reason(model: pin.Model) -> str | None:
    """Why the kernels cannot run this model (``None`` if they can).

    Supported: a free-flyer root (identity placement) and 1-DOF revolute or prismatic joints below
    it.
    """
    if model.njoints < 2 or model.joints[1].shortname() != "JointModelFreeFlyer":
        return "the root joint is not a free flyer"
    if not model.jointPlacements[1].isIdentity():
        return "the free flyer has a non-identity placement"
    for j in range(2, model.njoints):
        name = model.joints[j].shortname()
        if _joint_kind_axis(model.joints[j]) is None:
            return f"joint '{model.names[j]}' has unsupported type {name}"
        if model.parents[j] < 1:
            return f"joint '{model.names[j]}' is not below the free flyer"
    return None


def _joint_kind_axis(joint) -> tuple[int, np.ndarray] | None:
    name = joint.shortname().removeprefix("JointModel")
    if name in ("RX", "RY", "RZ"):
        return kernels.REVOLUTE, np.array(_AXES[name[1]])
    if name in ("PX", "PY", "PZ"):
        return kernels.PRISMATIC, np.array(_AXES[name[1]])
    if name in ("RevoluteUnaligned", "PrismaticUnaligned"):
        axis = np.asarray(joint.extract().axis, dtype=float)
        if abs(np.linalg.norm(axis) - 1.0) > 1e-12:
            return None
        kind = kernels.REVOLUTE if name.startswith("Revolute") else kernels.PRISMATIC
        return kind, axis
    return None


class FastModel:
    """A vehicle's equations of motion as flat arrays, with compiled evaluation.

    Args:
        vehicle: The vehicle (its ``added_mass``, ``damping`` and ``restoring`` switches are
            honoured; they are read once, here).

    Raises:
        ValueError: The model is not supported (see :func:`unsupported_reason`).
    """

    def __init__(self, vehicle) -> None:
        model = vehicle.model
        reason = unsupported_reason(model)
        if reason is not None:
            raise ValueError(f"fast backend: {reason}")
        nb = model.njoints - 1
        self.nq, self.nv, self.n_bodies = model.nq, model.nv, nb
        ints = np.zeros((nb, 4), dtype=np.int64)
        place = np.zeros((nb, 4, 3))
        axis = np.zeros((nb, 6))
        inertia = np.zeros((nb, 3, 6, 6))
        restore = np.zeros((nb, 4))
        gravity = vehicle.hydro.gravity if vehicle.restoring else 0.0
        for j in range(1, model.njoints):
            b = j - 1
            ints[b] = (model.parents[j] - 1, 0, model.idx_qs[j], model.idx_vs[j])
            placement = model.jointPlacements[j]
            place[b, :3] = placement.rotation
            place[b, 3] = placement.translation
            if j >= 2:
                kind, unit = _joint_kind_axis(model.joints[j])
                ints[b, 1] = kind
                if kind == kernels.REVOLUTE:
                    axis[b, 3:] = unit
                else:
                    axis[b, :3] = unit
            rigid = model.inertias[j]
            inertia[b, 2] = rigid.matrix()
            weight = rigid.mass * gravity
            restore[b, 0] = -weight
            restore[b, 1:] = -weight * rigid.lever
        if vehicle.added_mass:
            for k, joint in enumerate(vehicle._bodies):
                inertia[joint - 1, 1] = vehicle._added_mass_in_body[k]
        inertia[:, 0] = inertia[:, 2] + inertia[:, 1]
        if vehicle.restoring:
            # the displaced mass rho V of each body at its centre of buoyancy, as the vehicle's
            # buoyancy model holds it (Fossen 2021, eq. (4.6))
            for j in range(1, model.njoints):
                displaced = vehicle._buoyancy_model.inertias[j]
                buoyancy = displaced.mass * gravity
                restore[j - 1, 0] += buoyancy
                restore[j - 1, 1:] += buoyancy * displaced.lever
        links = vehicle.hydro.links if vehicle.damping else ()
        nl = len(links)
        link_i = np.zeros((nl, 5), dtype=np.int64)
        link_m = np.zeros((nl, 4, 6, 6))
        link_f = np.zeros((nl, 2))
        crossflow_index = {int(k): n for n, k in enumerate(vehicle._crossflow_links)}
        identity = np.eye(6)
        for k in range(nl):
            link_i[k, 0] = vehicle._bodies[vehicle._body_of_link[k]] - 1
            link_m[k, 0] = vehicle._link_from_body[k]
            link_m[k, 1] = vehicle._linear_damping[k]
            link_m[k, 2] = vehicle._quadratic_damping[k]
            if k in crossflow_index:
                n = crossflow_index[k]
                link_i[k, 1] = 1
                link_m[k, 3] = vehicle._cylinder_from_link[n]
                link_f[k] = (vehicle._crossflow_length[n], vehicle._crossflow_coefficient[n])
            # shortcuts that leave the arithmetic exact: identity transforms, diagonal D_Q
            link_i[k, 2] = int(np.array_equal(link_m[k, 0], identity))
            link_i[k, 3] = int(np.array_equal(link_m[k, 3], identity))
            link_i[k, 4] = int(np.count_nonzero(link_m[k, 2] - np.diag(np.diag(link_m[k, 2]))) == 0)
        gauss = np.array(gauss_legendre_unit(DEFAULT_NODES))
        thrust = np.zeros((len(vehicle.hydro.thrusters), 7))
        for k in range(thrust.shape[0]):
            thrust[k, 0] = vehicle._thruster_bodies[vehicle._thruster_body_of[k]] - 1
            thrust[k, 1:] = vehicle._thruster_wrench[k]
        meta = np.array([model.nq, model.nv], dtype=np.int64)
        self.arrays = (
            ints,
            place,
            axis,
            inertia,
            restore,
            link_i,
            link_m,
            link_f,
            gauss,
            thrust,
            meta,
        )
        self.no_servo = np.zeros((5, 0))
        self.zero_current = np.zeros(3)
        self._frames: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}
        self._model = model

    # ------------------------------------------------------------------ helpers
    def _current(self, current) -> np.ndarray:
        if current is None:
            return self.zero_current
        return np.ascontiguousarray(current, dtype=float).reshape(3)

    def _servo(self, servo) -> np.ndarray:
        return self.no_servo if servo is None else servo

    # ------------------------------------------------------------------ evaluation
    def acceleration(self, q, v, tau, current=None, servo: np.ndarray | None = None) -> np.ndarray:
        """``dv`` (nv,), as :meth:`aiauv_pin.Vehicle.acceleration` (plus an optional servo)."""
        out = np.empty(self.nv)
        kernels.acceleration(
            self.arrays,
            np.ascontiguousarray(q, dtype=float),
            np.ascontiguousarray(v, dtype=float),
            np.ascontiguousarray(tau, dtype=float),
            self._current(current),
            self._servo(servo),
            out,
        )
        return out

    def restoring_forces(self, q) -> np.ndarray:
        """``g(q)`` (nv,) on the left-hand side, as :meth:`aiauv_pin.Vehicle.restoring_forces`."""
        return kernels.restoring_forces(self.arrays, np.ascontiguousarray(q, dtype=float))

    def thrust_matrix(self, q) -> np.ndarray:
        """``B(q)`` (nv x m), as :meth:`aiauv_pin.Vehicle.thrust_matrix`."""
        return kernels.thrust_matrix(self.arrays, np.ascontiguousarray(q, dtype=float))

    def frame_motion(self, q, v, frame_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World rotation, world position and twist in its own axes of a Pinocchio frame."""
        if frame_id not in self._frames:
            frame = self._model.frames[frame_id]
            self._frames[frame_id] = (
                int(frame.parentJoint) - 1,
                np.ascontiguousarray(frame.placement.rotation),
                np.ascontiguousarray(frame.placement.translation),
            )
        body, rotation, translation = self._frames[frame_id]
        return kernels.frame_kinematics(
            self.arrays,
            np.ascontiguousarray(q, dtype=float),
            np.ascontiguousarray(v, dtype=float),
            body,
            rotation,
            translation,
        )

    def step(self, q, v, tau, dt: float, *, method: str = "rk4", current=None, servo=None):
        """One integrator step; returns new ``(q, v)`` (as :mod:`aiauv_pin.integrators`)."""
        q_out = np.empty(self.nq)
        v_out = np.empty(self.nv)
        kernels.step(
            self.arrays,
            np.ascontiguousarray(q, dtype=float),
            np.ascontiguousarray(v, dtype=float),
            np.ascontiguousarray(tau, dtype=float),
            self._current(current),
            self._servo(servo),
            float(dt),
            METHOD_CODES[method],
            q_out,
            v_out,
        )
        return q_out, v_out

    def run(self, q, v, tau, dt: float, n_steps: int, *, method="rk4", current=None, servo=None):
        """Advance contiguous float arrays ``q, v`` in place; returns the number of finite steps."""
        return kernels.run_steps(
            self.arrays,
            q,
            v,
            tau,
            self._current(current),
            self._servo(servo),
            float(dt),
            int(n_steps),
            METHOD_CODES[method],
        )
