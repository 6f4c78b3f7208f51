"""Path following of a torpedo AUV (:mod:`aiauv_control.laws.torpedo_laws`) wired to a vehicle.

:class:`Torpedo` holds the controller's options (checked on their own, one line per bad value);
:class:`VehicleTorpedo` checks them against a vehicle (one rigid hull, propellers along its axis,
fins that turn it in yaw and in pitch) and builds the compiled controller
(:func:`aiauv_pin.controllers.torpedo_compiled.torpedo_path_following`). Each fin's shares of the
rudder and stern-plane deflections come from its geometry (:func:`fin_moments`,
:func:`aiauv_control.laws.torpedo_laws.fin_share`).

A run in Python::

    import numpy as np, aiauv_pin
    from aiauv_control.paths import HelixPath
    from aiauv_pin.controllers.torpedo_controller import Torpedo, VehicleTorpedo

    vehicle = aiauv_pin.load_vehicle("examples/vehicles/torpedo.urdf")
    path = HelixPath(centre=(0, 0, 0), axis=(0, 0, 1), radius=20.0, pitch=15.0)
    torpedo = VehicleTorpedo(vehicle, Torpedo(speed=2.0), path=path)
    q0 = vehicle.neutral_configuration(); q0[0] = 20.0
    trajectory = aiauv_pin.simulate(vehicle, q0, np.zeros(6), 120.0, 0.01, torpedo.compiled())
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aiauv_control.guidance import X_AXIS
from aiauv_control.laws.paper_laws import new_guidance_state, new_surge_state
from aiauv_control.laws.torpedo_laws import (
    TorpedoGains,
    fin_share,
    new_autopilot_state,
    new_torpedo_buffers,
    torpedo_command,
)
from aiauv_control.path_following import DEFAULT_LOS_INTEGRAL_GAIN
from aiauv_control.paths import Path
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.controllers.info_rows import info_offsets
from aiauv_pin.controllers.torpedo_compiled import (
    TorpedoInfo,
    TorpedoParameters,
    TorpedoState,
    torpedo_info_shapes,
    torpedo_path_following,
)
from aiauv_pin.errors import ArgumentError
from aiauv_pin.model.vehicle import Vehicle

#: Smallest share of the yaw (pitch) moment that counts a fin as steering in yaw (pitch) [-].
STEERING_SHARE = 1e-3


def _number(name: str, value, *, positive: bool = False) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ArgumentError(f"torpedo.{name} must be a number, got {value!r:.40}") from None
    ok = math.isfinite(value) and (value > 0.0 if positive else value >= 0.0)
    if not ok:
        relation = "> 0" if positive else ">= 0"
        raise ArgumentError(f"torpedo.{name} must be a finite number {relation}, got {value!r}")
    return value


@dataclass(frozen=True)
class Torpedo:
    """Options of a torpedo AUV's path following (:mod:`aiauv_control.laws.torpedo_laws`).

    Attributes:
        speed: Desired speed along the hull's axis [m/s], held by the propeller's PI (the
            paper's eq. 25); ``None`` with ``thrust`` given: constant thrust instead.
        thrust: Constant thrust per propeller [N] (only without ``speed``).
        speed_kp, speed_ki: Gains of the speed PI [N s/m], [N/m].
        lookahead: LOS lookahead distance ``Delta`` [m] (> 0).
        integral_los: Integral LOS (Borhaug et al. 2008) against the crab angles of a turning,
            climbing hull and against currents.
        los_integral_gain: ``sigma`` of the integral LOS [-] (> 0).
        yaw_kp, yaw_kd, yaw_ki: Heading PID, rudder angle per heading error [rad/rad], [s],
            [1/s].
        pitch_kp, pitch_kd, pitch_ki: Pitch PID, stern-plane angle per pitch error, the same
            units.
        max_deflection: Saturation of the rudder and stern-plane deflections [rad] (> 0;
            ``None``: the smallest fin limit).
    """

    speed: float | None = 2.0
    thrust: float | None = None
    speed_kp: float = 40.0
    speed_ki: float = 10.0
    lookahead: float = 8.0
    integral_los: bool = True
    los_integral_gain: float = DEFAULT_LOS_INTEGRAL_GAIN
    yaw_kp: float = 1.0
    yaw_kd: float = 0.6
    yaw_ki: float = 0.05
    pitch_kp: float = 1.0
    pitch_kd: float = 0.6
    pitch_ki: float = 0.05
    max_deflection: float | None = None

    def __post_init__(self) -> None:
        if self.speed is None and self.thrust is None:
            raise ArgumentError("torpedo: give a speed [m/s] or a constant thrust [N]")
        if self.speed is not None and self.thrust is not None:
            raise ArgumentError("torpedo: give a speed or a thrust, not both")
        if self.speed is not None:
            object.__setattr__(self, "speed", _number("speed", self.speed, positive=True))
        else:
            object.__setattr__(self, "thrust", _number("thrust", self.thrust, positive=True))
        for name in ("lookahead", "los_integral_gain"):
            object.__setattr__(self, name, _number(name, getattr(self, name), positive=True))
        for name in ("speed_kp", "speed_ki", "yaw_kd", "yaw_ki", "pitch_kd", "pitch_ki"):
            object.__setattr__(self, name, _number(name, getattr(self, name)))
        for name in ("yaw_kp", "pitch_kp"):
            object.__setattr__(self, name, _number(name, getattr(self, name), positive=True))
        if not isinstance(self.integral_los, bool):
            raise ArgumentError(
                f"torpedo.integral_los must be true or false, got {self.integral_los!r:.40}"
            )
        if self.max_deflection is not None:
            value = _number("max_deflection", self.max_deflection, positive=True)
            object.__setattr__(self, "max_deflection", value)


def fin_moments(vehicle: Vehicle) -> np.ndarray:
    """Moment per unit angle of each fin about the vehicle's centre of mass (nf, 3), base axes,
    at forward motion of the neutral configuration, up to the positive factor ``0.5 rho A
    C_L_alpha U^2``: ``r x (a x e_x)`` with ``r`` the fin's centre of pressure from the centre of
    mass and ``a`` its span axis (at a positive angle a fin moving forward lifts along ``a x
    e_x``, :mod:`aiauv_hydro.laws.lift`)."""
    import pinocchio as pin

    q = vehicle.neutral_configuration()
    centre = pin.centerOfMass(vehicle.model, vehicle.data, q).copy()
    out = np.zeros((vehicle.n_fins, 3))
    for k, fin in enumerate(vehicle.hydro.fins):
        placement = vehicle.frame_placement(q, fin.link)
        rotation = np.asarray(placement.rotation)
        r = np.asarray(placement.translation) + rotation @ np.asarray(fin.position) - centre
        lift = np.cross(rotation @ np.asarray(fin.axis), np.array([1.0, 0.0, 0.0]))
        out[k] = np.cross(r, lift)
    return out


def propeller_signs(vehicle: Vehicle) -> np.ndarray:
    """Per thruster (m,): +1 (-1) if it pushes the hull along its +x (-x) axis, 0 for the others
    (from ``B(q)`` at the neutral configuration; e.g. LAUV's propeller, UUV Simulator's
    lauv_description, is mounted to push along -x, and goes ahead with negative thrust)."""
    B = vehicle.thrust_matrix(vehicle.neutral_configuration())[:3]
    along = B[0]
    return np.where(np.abs(along) > 0.999, np.sign(along), 0.0)


class VehicleTorpedo:
    """Controller for :func:`aiauv_pin.simulate`: a torpedo AUV's path following (compiled).

    Args:
        vehicle: One rigid hull (no joints), at least one propeller along the hull's axis, fins
            that turn it in yaw and in pitch; the numba backend.
        options: :class:`Torpedo` (``None``: its defaults).
        path: The path (default: the world x-axis).

    Raises:
        ArgumentError: One line naming what the vehicle lacks.
    """

    continuous_joints = True
    joint_servo = None

    def __init__(
        self, vehicle: Vehicle, options: Torpedo | None = None, *, path: Path | None = None
    ) -> None:
        options = Torpedo() if options is None else options
        if not isinstance(options, Torpedo):
            raise ArgumentError(
                f"torpedo: options must be a Torpedo, got {type(options).__name__:.40}"
            )
        if vehicle.fast is None:
            raise ArgumentError(
                f"torpedo: runs compiled only; the vehicle runs on {vehicle.active_backend}"
            )
        if vehicle.nv != 6:
            raise ArgumentError(
                f"torpedo: the vehicle must be one rigid hull, it has {vehicle.nv - 6} joints"
            )
        surge = propeller_signs(vehicle)
        if not np.any(surge):
            raise ArgumentError("torpedo: the vehicle has no propeller along its x-axis")
        if vehicle.n_fins == 0:
            raise ArgumentError("torpedo: the vehicle has no fins (<fin> in <hydrodynamics>)")
        rudder, stern = fin_share(fin_moments(vehicle))
        for share, what in ((rudder, "yaw (rudders)"), (stern, "pitch (stern planes)")):
            if not np.any(np.abs(share) > STEERING_SHARE):
                raise ArgumentError(
                    f"torpedo: no fin turns the vehicle in {what} (fins: "
                    f"{', '.join(vehicle.fin_names)[:120]})"
                )
        self.vehicle = vehicle
        self.options = options
        self.path = path if path is not None else X_AXIS
        self.surge_mask = surge
        self.rudder_share, self.stern_share = rudder, stern
        self.fin_limit = np.ascontiguousarray(vehicle.max_fin_angle, dtype=float)
        max_thrust = float(np.min(vehicle.max_thrust[surge != 0.0]))
        limit = options.max_deflection
        if limit is None:
            limit = float(np.min(self.fin_limit))
        if options.thrust is not None and options.thrust > max_thrust:
            raise ArgumentError(
                f"torpedo.thrust {options.thrust:g} N exceeds the propeller's limit "
                f"{max_thrust:g} N"
            )
        o = options
        self.gains = TorpedoGains(
            lookahead=o.lookahead,
            integral=o.integral_los,
            sigma=o.los_integral_gain,
            speed_control=o.speed is not None,
            u_d=o.speed if o.speed is not None else 0.0,
            thrust=o.thrust if o.thrust is not None else 0.0,
            k_1p=o.speed_kp,
            k_1i=o.speed_ki,
            max_thrust=max_thrust,
            yaw_kp=o.yaw_kp,
            yaw_kd=o.yaw_kd,
            yaw_ki=o.yaw_ki,
            pitch_kp=o.pitch_kp,
            pitch_kd=o.pitch_kd,
            pitch_ki=o.pitch_ki,
            max_deflection=float(limit),
        )
        self.law = torpedo_command  # the law, for readers: aiauv_control.laws.torpedo_laws

    def info_shapes(self) -> dict[str, tuple[int, ...]]:
        """Keys and shapes of the logged diagnostics."""
        return torpedo_info_shapes(len(self.vehicle.hydro.thrusters), self.vehicle.n_fins)

    def compiled(self) -> CompiledController:
        """This controller for the compiled loop (a fresh state)."""
        parameters = TorpedoParameters(
            gains=self.gains,
            path_function=self.path.user_function,
            path_kind=self.path.kind_code,
            path_parameters=self.path.params,
            surge_mask=self.surge_mask,
            rudder_share=np.ascontiguousarray(self.rudder_share, dtype=float),
            stern_share=np.ascontiguousarray(self.stern_share, dtype=float),
            fin_limit=self.fin_limit,
            info=info_offsets(self.info_shapes(), TorpedoInfo),
        )
        state = TorpedoState(
            surge=new_surge_state(),
            guidance=new_guidance_state(),
            autopilot=new_autopilot_state(),
            command=new_torpedo_buffers(len(self.vehicle.hydro.thrusters), self.vehicle.n_fins),
        )

        def reset() -> None:
            for record in (state.surge, state.guidance, state.autopilot, state.command):
                for array in record:
                    array[:] = 0.0

        return CompiledController(
            torpedo_path_following, parameters, state, self.info_shapes(), None, reset
        )
