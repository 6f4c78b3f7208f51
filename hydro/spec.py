"""Parameter records for per-link hydrodynamics, thrusters and the fluid.

Every quantity of a :class:`LinkHydrodynamics` is expressed in the frame of its URDF link and taken
about that link's origin (Fossen 2021, Sec. 6.3 and 6.4: matrices about the body-frame origin ``o_b``),
with generalised velocities ordered ``nu = (u, v, w, p, q, r)``: linear first, then angular, the same
order as Pinocchio's ``Motion.vector``.

All records are frozen dataclasses whose array fields are read-only numpy arrays, so that a vehicle's
parameters cannot drift after it has been loaded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


class HydroError(ValueError):
    """Non-physical or malformed hydrodynamic parameters; the message is one line naming the problem."""


def _frozen_array(value, shape: tuple[int, ...], name: str) -> np.ndarray:
    array = np.array(value, dtype=float)
    if array.shape != shape:
        raise HydroError(f"{name}: expected shape {shape}, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise HydroError(f"{name}: contains NaN or infinite values")
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class CrossflowDrag:
    """Strip-theory crossflow drag of a circular cylinder (Fossen 2021, Sec. 6.4.3).

    The cylinder frame ``c`` has its x-axis on the cylinder axis and its origin at the cylinder's rear
    end; the strip integral runs over ``x`` in ``[0, length]`` of that frame.

    The axial and roll quadratic drag of a cylinder placed off the link axis ride along here, in
    the cylinder frame, where they are exact (:mod:`aiauv_hydro.laws.crossflow`); a cylinder on
    the link axis keeps them in its link's ``D_Q`` and leaves both at 0.

    Attributes:
        length: Cylinder length [m].
        radius: Cylinder radius [m].
        drag_coefficient: Crossflow drag coefficient ``C_dC`` [-].
        fluid_density: Water density [kg/m^3].
        rotation: Orientation of frame ``c`` in the link frame (3x3).
        translation: Origin of frame ``c`` in the link frame [m].
        axial_drag_coefficient: Axial quadratic drag coefficient ``C_d1`` applied in the cylinder
            frame [-] (0: none here).
        roll_drag_coefficient: Roll quadratic drag coefficient ``C_d4`` applied in the cylinder
            frame [-] (0: none here).
    """

    length: float
    radius: float
    drag_coefficient: float
    fluid_density: float
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axial_drag_coefficient: float = 0.0
    roll_drag_coefficient: float = 0.0

    def __post_init__(self) -> None:
        for name in ("length", "radius", "fluid_density"):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and value > 0.0):
                raise HydroError(f"crossflow {name} must be positive and finite, got {value}")
        if not (np.isfinite(self.drag_coefficient) and self.drag_coefficient >= 0.0):
            raise HydroError(
                f"crossflow drag coefficient must be >= 0, got {self.drag_coefficient}"
            )
        for name, label in (
            ("axial_drag_coefficient", "axial drag coefficient C_d1"),
            ("roll_drag_coefficient", "roll drag coefficient C_d4"),
        ):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and value >= 0.0):
                raise HydroError(f"crossflow {label} must be finite and >= 0, got {value}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "rotation", _frozen_array(self.rotation, (3, 3), "rotation"))
        object.__setattr__(
            self, "translation", _frozen_array(self.translation, (3,), "translation")
        )
        rotation = self.rotation
        if not (
            np.allclose(rotation.T @ rotation, np.eye(3), rtol=0.0, atol=1e-9)
            and np.linalg.det(rotation) > 0.0
        ):
            raise HydroError("crossflow rotation is not a proper rotation matrix")

    @property
    def strip_coefficient(self) -> float:
        """``rho * r * C_dC`` [kg/m^2]: drag per unit length is ``-strip_coefficient |v_n| v_n``."""
        return self.fluid_density * self.radius * self.drag_coefficient

    @property
    def axial_coefficient(self) -> float:
        """``1/2 rho pi r^2 C_d1`` [kg/m]: the axial force is ``-axial_coefficient |u_a| u_a``.

        The same coefficient as the ``D_Q[0, 0]`` of an on-axis cylinder
        (:func:`aiauv_hydro.estimate.slender_cylinder.quadratic_damping_matrix`; Schmidt-Didlaukies
        et al. 2018; Fossen 2021, Sec. 6.4).
        """
        return 0.5 * self.fluid_density * np.pi * self.radius**2 * self.axial_drag_coefficient

    @property
    def roll_coefficient(self) -> float:
        """``1/2 rho pi L r^4 C_d4`` [kg m^2]: the roll moment is ``-roll_coefficient |p_a| p_a``.

        The same coefficient as the ``D_Q[3, 3]`` of an on-axis cylinder
        (:func:`aiauv_hydro.estimate.slender_cylinder.quadratic_damping_matrix`; Schmidt-Didlaukies
        et al. 2018).
        """
        return (
            0.5
            * self.fluid_density
            * np.pi
            * self.length
            * self.radius**4
            * self.roll_drag_coefficient
        )


@dataclass(frozen=True)
class LinkHydrodynamics:
    """Hydrodynamic and hydrostatic parameters of one link, in the link frame about its origin.

    Attributes:
        link: Name of the URDF link.
        model: How the parameters were given: ``"fossen"`` (matrices) or ``"slender_cylinder"``.
        volume: Displaced volume [m^3].
        center_of_buoyancy: Centre of buoyancy in the link frame [m].
        added_mass: Added-mass matrix ``M_A`` (6x6, symmetric positive semi-definite)
            [kg, kg m, kg m^2].
        linear_damping: Linear damping ``D_L`` (6x6); wrench ``-D_L nu_r``.
        quadratic_damping: Quadratic damping ``D_Q`` (6x6); wrench ``-D_Q (|nu_r| * nu_r)``
            (element-wise absolute value and product).
        crossflow: Optional strip-theory crossflow drag, added to the quadratic damping.
        forward_speed_damping: Surge-proportional linear damping ``D_F`` (6x6); wrench
            ``-u_r D_F nu_r`` (:func:`aiauv_hydro.laws.fluid_terms.forward_speed_damping_wrench`);
            zero if omitted.
    """

    link: str
    model: str
    volume: float
    center_of_buoyancy: np.ndarray
    added_mass: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray
    crossflow: CrossflowDrag | None = None
    forward_speed_damping: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.volume) and self.volume >= 0.0):
            raise HydroError(
                f"link '{self.link}': volume must be >= 0 and finite, got {self.volume}"
            )
        object.__setattr__(self, "volume", float(self.volume))
        object.__setattr__(
            self,
            "center_of_buoyancy",
            _frozen_array(self.center_of_buoyancy, (3,), f"link '{self.link}': center_of_buoyancy"),
        )
        if self.forward_speed_damping is None:
            object.__setattr__(self, "forward_speed_damping", np.zeros((6, 6)))
        for name in ("added_mass", "linear_damping", "quadratic_damping", "forward_speed_damping"):
            matrix = _frozen_array(getattr(self, name), (6, 6), f"link '{self.link}': {name}")
            object.__setattr__(self, name, matrix)
        added_mass = self.added_mass
        scale = max(1.0, float(np.max(np.abs(added_mass))))
        if not np.allclose(added_mass, added_mass.T, rtol=0.0, atol=1e-9 * scale):
            raise HydroError(f"link '{self.link}': added_mass is not symmetric")
        if np.min(np.linalg.eigvalsh(added_mass)) < -1e-9 * scale:
            raise HydroError(f"link '{self.link}': added_mass is not positive semi-definite")


@dataclass(frozen=True)
class Thruster:
    """A fixed thruster producing a force along a unit direction.

    Attributes:
        name: Thruster name (unique within a vehicle).
        link: Name of the URDF link the thruster is mounted on.
        position: Point of action in the link frame [m].
        direction: Unit direction of positive thrust in the link frame.
        max_thrust: Thrust magnitude limit [N]; commands are saturated to ``[-max, max]``.
        time_constant: First-order lag of the produced thrust behind the command [s]; 0 (the
            default) is instantaneous (:func:`aiauv_hydro.laws.actuators.actuator_response`).
        max_rate: Slew-rate limit of the produced thrust [N/s]; ``inf`` (the default) is none.
    """

    name: str
    link: str
    position: np.ndarray
    direction: np.ndarray
    max_thrust: float
    time_constant: float = 0.0
    max_rate: float = math.inf

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "position", _frozen_array(self.position, (3,), f"thruster '{self.name}': xyz")
        )
        direction = np.array(self.direction, dtype=float)
        norm = float(np.linalg.norm(direction)) if direction.shape == (3,) else 0.0
        if not (np.isfinite(norm) and norm > 0.0):
            raise HydroError(f"thruster '{self.name}': direction must be a nonzero 3-vector")
        object.__setattr__(
            self,
            "direction",
            _frozen_array(direction / norm, (3,), f"thruster '{self.name}': direction"),
        )
        if not (np.isfinite(self.max_thrust) and self.max_thrust > 0.0):
            raise HydroError(
                f"thruster '{self.name}': max_thrust must be positive, got {self.max_thrust}"
            )
        object.__setattr__(self, "max_thrust", float(self.max_thrust))
        _check_dynamics(self, f"thruster '{self.name}'")


def _check_dynamics(record, what: str) -> None:
    """Refuse a negative or non-finite ``time_constant`` and a non-positive ``max_rate``."""
    time_constant = float(record.time_constant)
    if not (math.isfinite(time_constant) and time_constant >= 0.0):
        raise HydroError(f"{what}: time_constant must be >= 0 and finite, got {time_constant}")
    max_rate = float(record.max_rate)
    if not (max_rate > 0.0):  # inf allowed; NaN refused
        raise HydroError(f"{what}: max_rate must be positive, got {max_rate}")
    object.__setattr__(record, "time_constant", time_constant)
    object.__setattr__(record, "max_rate", max_rate)


#: Tolerance on ``|axis . chord|`` of a fin (both unit vectors): the chord must be perpendicular to
#: the span axis. URDF files write pi/2 as 1.5707963, so directions carry errors near 1e-8.
FIN_PERPENDICULAR_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Fin:
    """A control surface: lift and drag of a fin whose angle is an actuator (not a joint).

    The fin turns by its angle ``delta`` about ``axis`` (right-hand rule); at ``delta = 0`` its
    chord points along ``chord``. The law is :func:`aiauv_hydro.laws.lift.fin_force` (sign and stall
    conventions there and on the URDF-format page).

    Attributes:
        name: Fin name (unique within a vehicle).
        link: Name of the rigid URDF link that carries the fin.
        position: Centre of pressure in the link frame [m].
        axis: Unit rotation (span) axis in the link frame.
        chord: Unit chord direction (forward, leading edge) at zero angle, in the link frame,
            perpendicular to ``axis``.
        area: Planform area ``A`` [m^2].
        lift_slope: Lift-curve slope ``C_L_alpha`` [1/rad].
        drag_zero: Drag coefficient at zero angle of attack ``C_D0`` [-].
        drag_slope: Quadratic drag coefficient ``C_D_alpha2`` [1/rad^2].
        stall_angle: Angle of attack [rad] beyond which the lift coefficient stays at its stall
            value ``C_L_alpha * stall_angle`` (``inf``: no stall).
        max_angle: Angle limit [rad]: commands are clipped to ``[-max_angle, max_angle]``.
        max_rate: Rate limit of the fin angle [rad/s] (``inf``: none).
        time_constant: First-order lag of the angle behind the command [s] (0: none; UUV
            Simulator's fin ``FirstOrder`` dynamics).
    """

    name: str
    link: str
    position: np.ndarray
    axis: np.ndarray
    chord: np.ndarray
    area: float
    lift_slope: float
    drag_zero: float = 0.0
    drag_slope: float = 0.0
    stall_angle: float = math.inf
    max_angle: float = math.pi / 2
    max_rate: float = math.inf
    time_constant: float = 0.0

    def __post_init__(self) -> None:
        what = f"fin '{self.name}'"
        object.__setattr__(self, "position", _frozen_array(self.position, (3,), f"{what}: xyz"))
        for name in ("axis", "chord"):
            vector = np.array(getattr(self, name), dtype=float)
            norm = float(np.linalg.norm(vector)) if vector.shape == (3,) else 0.0
            if not (np.isfinite(norm) and norm > 0.0):
                raise HydroError(f"{what}: {name} must be a nonzero 3-vector")
            object.__setattr__(self, name, _frozen_array(vector / norm, (3,), f"{what}: {name}"))
        if abs(float(self.axis @ self.chord)) > FIN_PERPENDICULAR_TOLERANCE:
            raise HydroError(
                f"{what}: chord {self.chord.round(6).tolist()} is not perpendicular to axis "
                f"{self.axis.round(6).tolist()}"
            )
        # the exact perpendicular part, so that the law's frame is orthonormal
        chord = self.chord - (self.chord @ self.axis) * self.axis
        object.__setattr__(self, "chord", _frozen_array(chord / np.linalg.norm(chord), (3,), what))
        for name in ("area", "max_angle"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0.0):
                raise HydroError(f"{what}: {name} must be positive and finite, got {value}")
            object.__setattr__(self, name, value)
        for name in ("lift_slope", "drag_zero", "drag_slope"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value >= 0.0):
                raise HydroError(f"{what}: {name} must be >= 0 and finite, got {value}")
            object.__setattr__(self, name, value)
        stall = float(self.stall_angle)
        if not (stall > 0.0):
            raise HydroError(f"{what}: stall_angle must be positive, got {stall}")
        object.__setattr__(self, "stall_angle", stall)
        _check_dynamics(self, what)


@dataclass(frozen=True)
class HydroSpec:
    """Everything a vehicle's ``<hydrodynamics>`` block says.

    Attributes:
        fluid_density: Water density ``rho`` [kg/m^3].
        gravity: Magnitude of gravitational acceleration ``g`` [m/s^2] (acts along world -z).
        links: Per-link parameters; links not listed here have no fluid forces.
        thrusters: Thrusters, in the order of the thrust vector.
        fins: Fins (control surfaces), in the order of the fin angles, which follow the thrusts
            in a vehicle's actuator vector ``u = (thrusts, fin angles)``.
    """

    fluid_density: float = 1025.0
    gravity: float = 9.81
    links: tuple[LinkHydrodynamics, ...] = ()
    thrusters: tuple[Thruster, ...] = ()
    fins: tuple[Fin, ...] = ()

    def __post_init__(self) -> None:
        if not (np.isfinite(self.fluid_density) and self.fluid_density > 0.0):
            raise HydroError(f"fluid_density must be positive, got {self.fluid_density}")
        if not (np.isfinite(self.gravity) and self.gravity >= 0.0):
            raise HydroError(f"gravity must be >= 0, got {self.gravity}")
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "thrusters", tuple(self.thrusters))
        object.__setattr__(self, "fins", tuple(self.fins))
        fin_names = [f.name for f in self.fins]
        duplicate = {n for n in fin_names if fin_names.count(n) > 1}
        if duplicate:
            raise HydroError(f"fin name '{sorted(duplicate)[0]}' used twice")
        names = [link.link for link in self.links]
        duplicate = {n for n in names if names.count(n) > 1}
        if duplicate:
            raise HydroError(f"hydrodynamics given twice for link '{sorted(duplicate)[0]}'")
        thruster_names = [t.name for t in self.thrusters]
        duplicate = {n for n in thruster_names if thruster_names.count(n) > 1}
        if duplicate:
            raise HydroError(f"thruster name '{sorted(duplicate)[0]}' used twice")
