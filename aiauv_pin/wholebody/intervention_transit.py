"""Transit then intervene: follow a path by curving the body (the paper's controller), switch once at
the work site, then hold the end-effector at a target (:class:`InterventionControl`); and the
settings of both intervention controllers as scenario files give them.

The switch happens once, at the first controller sample where the end-effector is within
``switch_distance`` of the work site. The intervention then starts from the end-effector's pose at
the switch (the body curved as the transit left it: its posture in the null space) and moves to the
target along a minimum-jerk path of ``move_time``; the vehicle's speed at the switch is braked by
the pose PID (the reference starts at rest).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np

from aiauv_control.laws.intervention_laws import TASK_AXES
from aiauv_control.path_following import PathFollowingGains
from aiauv_control.paths import Path
from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle
from aiauv_pin.wholebody.intervention_controller import (
    InterventionControl,
    InterventionGains,
    rotation_from_rpy,
)


def _triple(value, name: str) -> tuple[float, float, float] | None:
    if value is None:
        return None
    out = tuple(float(x) for x in np.asarray(value, dtype=float).reshape(-1))
    if len(out) != 3 or not all(map(math.isfinite, out)):
        raise ArgumentError(f"intervention.{name} must be three finite numbers")
    return out


@dataclass(frozen=True)
class InterventionSettings:
    """What a scenario's ``[intervention]`` table sets (every field optional).

    Attributes:
        frame: The frame held.
        target_position: World [m] (``None``: where the frame is when the intervention starts).
        target_rpy: World roll, pitch, yaw [rad] of the target (``None``: as at the start).
        move_time: Minimum-jerk move from the start to the target [s].
        posture: Joint angles [rad] of the null-space posture, and of the start of a
            ``controller = "intervention"`` run (``None``: the joint angles at the start).
        shared_joints: Joint motors share the task (``False``: joints locked, thrusters alone).
        axes: Task axes (:data:`aiauv_control.laws.intervention_laws.TASK_AXES`).
        current_known: The model knows the scenario's current (``False``: the integral term
            takes it out).
        thrust_limit: Each thruster's largest thrust [N] (``None``: the vehicle's).
        joint_torque_limit: Each joint motor's largest torque [N m] (``None``: the URDF's).
        gains: :class:`InterventionGains`.
        site: Work site of ``controller = "transit_intervene"`` (world [m]).
        switch_distance: The end-effector's distance to the site at which transit ends [m].
    """

    frame: str = "end_effector"
    target_position: tuple[float, float, float] | None = None
    target_rpy: tuple[float, float, float] | None = None
    move_time: float = 0.0
    posture: tuple[float, ...] | None = None
    shared_joints: bool = True
    axes: tuple[str, ...] = TASK_AXES
    current_known: bool = False
    thrust_limit: float | None = None
    joint_torque_limit: float | None = None
    gains: InterventionGains = field(default_factory=InterventionGains)
    site: tuple[float, float, float] | None = None
    switch_distance: float = 0.5

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "target_position", _triple(self.target_position, "target_position"))
        set_(self, "target_rpy", _triple(self.target_rpy, "target_rpy"))
        set_(self, "site", _triple(self.site, "site"))
        if self.posture is not None:
            set_(self, "posture", tuple(float(x) for x in self.posture))
        set_(self, "axes", tuple(self.axes))
        if not (math.isfinite(self.switch_distance) and self.switch_distance > 0.0):
            raise ArgumentError(
                f"intervention.switch_distance must be positive, got {self.switch_distance!r}"
            )

    @classmethod
    def from_mapping(cls, table: dict) -> InterventionSettings:
        """Settings from a scenario file's ``[intervention]`` table (gains by their names)."""
        table = dict(table)
        gain_names = {f.name for f in fields(InterventionGains)}
        gains = InterventionGains(**{k: table.pop(k) for k in list(table) if k in gain_names})
        return cls(gains=gains, **table)

    def controller(self, vehicle: Vehicle, current=None) -> InterventionControl:
        """The :class:`InterventionControl` of these settings (``current``: the scenario's, used
        by the model if :attr:`current_known`)."""
        rotation = None if self.target_rpy is None else rotation_from_rpy(self.target_rpy)
        return InterventionControl(
            vehicle,
            self.target_position,
            rotation,
            frame=self.frame,
            gains=self.gains,
            posture=self.posture,
            shared_joints=self.shared_joints,
            axes=self.axes,
            move_time=self.move_time,
            current=current if self.current_known else None,
            thrust_limit=self.thrust_limit,
            joint_torque_limit=self.joint_torque_limit,
        )


class TransitThenIntervene:
    """Controller callback for :func:`aiauv_pin.simulate`: the paper's path following until the
    end-effector is within ``switch_distance`` of the site, then :class:`InterventionControl`
    (module docstring). Logs ``phase`` (0 transit, 1 intervention) with both controllers'
    diagnostics.

    The paper's joint PD runs as a continuous servo (:attr:`joint_servo`, to be given to
    :func:`aiauv_pin.simulate`); at the switch its gains are set to zero in place (the kernels
    read them from the shared buffers) and its hydrostatic compensation, which the intervention's
    model already holds, is taken off the intervention's output at each sample.

    Args:
        vehicle: The vehicle (with an ``end_effector`` frame).
        settings: The intervention and the site (:attr:`InterventionSettings.site` required).
        gains: The paper controller's gains.
        path: The path of the transit.
        current: The scenario's current (for :attr:`InterventionSettings.current_known`).
    """

    def __init__(
        self,
        vehicle: Vehicle,
        settings: InterventionSettings,
        gains: PathFollowingGains | None = None,
        *,
        path: Path | None = None,
        current=None,
    ) -> None:
        if settings.site is None:
            raise ArgumentError("transit_intervene needs intervention.site (the work site) [m]")
        self.settings = settings
        self.site = np.array(settings.site)
        self.vehicle = vehicle
        self.transit = VehiclePathFollowing(vehicle, gains, continuous_joints=True, path=path)
        self.joint_servo = self.transit.joint_servo
        self._servo_gains = (self.joint_servo.stiffness.copy(), self.joint_servo.damping.copy())
        self.intervention = settings.controller(vehicle, current)
        self.switched_at: float | None = None

    def reset(self) -> None:
        """Back to transit (the servo's gains restored)."""
        self.transit.reset()
        self.intervention.reset()
        self.joint_servo.stiffness[:], self.joint_servo.damping[:] = self._servo_gains
        self.switched_at = None

    def __call__(self, t: float, q: np.ndarray, v: np.ndarray):
        if self.switched_at is None:
            tau, info = self.transit(t, q, v)
            if np.linalg.norm(np.asarray(info["p"]) - self.site) > self.settings.switch_distance:
                return tau, {**info, "phase": 0.0}
            self.switched_at = float(t)
            self.joint_servo.stiffness[:] = 0.0
            self.joint_servo.damping[:] = 0.0
        tau, info = self.intervention(t, q, v)
        if self.joint_servo.compensate_restoring:
            tau[6:] -= self.vehicle.restoring_forces(q)[6:]
        return tau, {**info, "phase": 1.0}
