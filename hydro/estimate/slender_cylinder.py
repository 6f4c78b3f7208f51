"""Hydrodynamic matrices of one slender circular cylinder (strip theory).

The cylinder frame ``c`` has its x-axis on the cylinder axis and its origin at the rear end, so the
cylinder occupies ``x`` in ``[0, L]``. All matrices below are in frame ``c`` about its origin, with
velocities ordered ``nu = (u, v, w, p, q, r)`` (linear first, as in Pinocchio).

The model and its coefficients are those of the NTNU articulated-AUV simulation model
(Schmidt-Didlaukies, Sorensen and Pettersen 2018, "Modeling of articulated underwater robots for
simulation and control"), as summarised in the project's PAPER_DATA.md, section "Hydrodynamics of
one slender cylindrical link". Every transverse term is a strip integral over the length: a section
at ``x`` moving with normal velocity ``v_n(x) = (v + r x, w - q x)`` carries the added mass or
damping per unit length of a 2-D circle (Fossen 2021, Sec. 6.3 for added mass, Sec. 6.4 for
damping). The transverse quadratic (crossflow) drag is not a constant matrix; it lives in
:mod:`aiauv_hydro.laws.crossflow`.

When the cylinder frame is not the link frame, :func:`slender_cylinder_link` moves the matrices to
the link frame exactly with the spatial motion transform ``X`` (``nu_c = X nu_link``):
``M_link = X^T M_c X`` (kinetic energy ``1/2 nu^T M nu`` is frame independent; Featherstone 2008,
Ch. 2, and Fossen 2021, Sec. 3.3, for the same rule with ``H(r)``). The axial and roll quadratic
drag keep a constant link-frame ``D_Q`` only when the cylinder's axis is a link axis
(:func:`exact_axial_and_roll`); otherwise they are evaluated in the cylinder frame with the
crossflow term, where they are exact (:class:`aiauv_hydro.spec.CrossflowDrag`
``axial_drag_coefficient`` / ``roll_drag_coefficient``, :mod:`aiauv_hydro.laws.crossflow`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from aiauv_hydro.numerics.spatial import motion_transform
from aiauv_hydro.spec import CrossflowDrag, HydroError, LinkHydrodynamics

#: Tolerance used to decide whether a transformed axial/roll quadratic damping is still diagonal.
_EXACT_TOLERANCE = 1e-9


@dataclass(frozen=True)
class SlenderCylinderCoefficients:
    """Dimensionless coefficients of the slender-cylinder model (PAPER_DATA.md defaults).

    Attributes:
        C_a: Transverse added-mass coefficient (1 = the 2-D circle's displaced mass) [-].
        alpha: Ratio of axial to transverse added mass [-].
        C_d1: Axial quadratic drag coefficient [-].
        C_d4: Roll quadratic drag coefficient [-].
        C_dC: Crossflow (transverse quadratic) drag coefficient [-].
        C_dL: Linear (skin friction) damping coefficient [-].
        beta: Axial factor of the linear damping [-].
        gamma: Roll factor of the linear damping [-].
        v_ref: Reference speed that turns ``C_dL`` into a linear coefficient [m/s].
    """

    C_a: float = 1.0
    alpha: float = 0.2
    C_d1: float = 0.2
    C_d4: float = 0.1
    C_dC: float = 0.8
    C_dL: float = 0.1
    beta: float = 0.1
    gamma: float = 0.1
    v_ref: float = 1.0

    def __post_init__(self) -> None:
        for item in fields(self):
            try:
                value = float(getattr(self, item.name))
            except (TypeError, ValueError):
                raise HydroError(
                    f"slender-cylinder coefficient {item.name} is not a number: "
                    f"{getattr(self, item.name)!r}"
                ) from None
            if not math.isfinite(value) or value < 0.0:
                raise HydroError(
                    f"slender-cylinder coefficient {item.name} must be finite and >= 0, got {value}"
                )
            object.__setattr__(self, item.name, value)
        if self.v_ref <= 0.0:
            raise HydroError(f"slender-cylinder coefficient v_ref must be > 0, got {self.v_ref}")


DEFAULT_COEFFICIENTS = SlenderCylinderCoefficients()


def _check_dimensions(length: float, radius: float, fluid_density: float) -> None:
    for name, value in (("length", length), ("radius", radius), ("fluid_density", fluid_density)):
        if not (math.isfinite(value) and value > 0.0):
            raise HydroError(f"slender cylinder {name} must be positive and finite, got {value}")


def added_mass_matrix(
    length: float,
    radius: float,
    fluid_density: float,
    coefficients: SlenderCylinderCoefficients = DEFAULT_COEFFICIENTS,
) -> np.ndarray:
    """Added-mass matrix of the cylinder about its rear end, in the cylinder frame.

    Args:
        length: Cylinder length ``L`` [m].
        radius: Cylinder radius ``r`` [m].
        fluid_density: Water density ``rho`` [kg/m^3].
        coefficients: Model coefficients (uses ``C_a`` and ``alpha``).

    Returns:
        ``M_A`` (6x6, symmetric positive semi-definite) [kg, kg m, kg m^2].
    """
    _check_dimensions(length, radius, fluid_density)
    L = float(length)
    # Added mass per unit length of a circular section: m_a = rho pi r^2 C_a
    # (PAPER_DATA "Hydrodynamics of one slender cylindrical link"; Fossen 2021, Sec. 6.3).
    m_a = fluid_density * math.pi * radius**2 * coefficients.C_a
    matrix = np.zeros((6, 6))
    # Strip integrals int_0^L m_a (v + r x)^2 dx and int_0^L m_a (w - q x)^2 dx give
    # m_a diag(alpha L, L, L, 0, L^3/3, L^3/3) with (2,6) = (6,2) = +L^2/2, (3,5) = (5,3) = -L^2/2
    # (PAPER_DATA, M_A about the rear end; Schmidt-Didlaukies et al. 2018).
    matrix[0, 0] = coefficients.alpha * L  # axial added mass, alpha times the transverse one
    matrix[1, 1] = L
    matrix[2, 2] = L
    matrix[4, 4] = L**3 / 3.0
    matrix[5, 5] = L**3 / 3.0
    matrix[1, 5] = matrix[5, 1] = L**2 / 2.0
    matrix[2, 4] = matrix[4, 2] = -(L**2) / 2.0
    return m_a * matrix


def linear_damping_matrix(
    length: float,
    radius: float,
    fluid_density: float,
    coefficients: SlenderCylinderCoefficients = DEFAULT_COEFFICIENTS,
) -> np.ndarray:
    """Linear damping matrix of the cylinder about its rear end; wrench ``-D_L nu``.

    Args:
        length: Cylinder length ``L`` [m].
        radius: Cylinder radius ``r`` [m].
        fluid_density: Water density ``rho`` [kg/m^3].
        coefficients: Model coefficients (uses ``C_dL``, ``v_ref``, ``beta``, ``gamma``).

    Returns:
        ``D_L`` (6x6, symmetric positive semi-definite) [kg/s, kg m/s, kg m^2/s].
    """
    _check_dimensions(length, radius, fluid_density)
    L = float(length)
    # k_L = rho r L C_dL v_ref (PAPER_DATA, linear damping; Schmidt-Didlaukies et al. 2018).
    k_L = fluid_density * radius * L * coefficients.C_dL * coefficients.v_ref
    matrix = np.zeros((6, 6))
    # D_L = k_L diag(beta, 1, 1, gamma r^2, L^2/3, L^2/3) with (2,6) = (6,2) = +L/2 and
    # (3,5) = (5,3) = -L/2: the strip integral of (k_L / L) (v + r x) and (k_L / L) (w - q x)
    # with its moment about the rear end (PAPER_DATA; Fossen 2021, Sec. 6.4).
    matrix[0, 0] = coefficients.beta
    matrix[1, 1] = 1.0
    matrix[2, 2] = 1.0
    matrix[3, 3] = coefficients.gamma * radius**2
    matrix[4, 4] = L**2 / 3.0
    matrix[5, 5] = L**2 / 3.0
    matrix[1, 5] = matrix[5, 1] = L / 2.0
    matrix[2, 4] = matrix[4, 2] = -L / 2.0
    return k_L * matrix


def quadratic_damping_matrix(
    length: float,
    radius: float,
    fluid_density: float,
    coefficients: SlenderCylinderCoefficients = DEFAULT_COEFFICIENTS,
) -> np.ndarray:
    """Axial and roll quadratic damping; wrench ``-D_Q (|nu| * nu)`` (element-wise).

    The transverse quadratic drag is the crossflow strip integral (:mod:`aiauv_hydro.laws.crossflow`), so the
    transverse entries here are zero.

    Args:
        length: Cylinder length ``L`` [m].
        radius: Cylinder radius ``r`` [m].
        fluid_density: Water density ``rho`` [kg/m^3].
        coefficients: Model coefficients (uses ``C_d1`` and ``C_d4``).

    Returns:
        ``D_Q`` (6x6, diagonal) [kg/m, kg m].
    """
    _check_dimensions(length, radius, fluid_density)
    matrix = np.zeros((6, 6))
    # Axial force -1/2 rho pi r^2 C_d1 |u| u (PAPER_DATA; Fossen 2021, Sec. 6.4).
    matrix[0, 0] = 0.5 * fluid_density * math.pi * radius**2 * coefficients.C_d1
    # Roll moment -1/2 rho pi L r^4 C_d4 |p| p (PAPER_DATA; Schmidt-Didlaukies et al. 2018).
    matrix[3, 3] = 0.5 * fluid_density * math.pi * float(length) * radius**4 * coefficients.C_d4
    return matrix


def _is_signed_unit_row(row: np.ndarray) -> bool:
    magnitudes = np.abs(row)
    big = magnitudes > _EXACT_TOLERANCE
    return int(np.count_nonzero(big)) == 1 and abs(float(magnitudes[big][0]) - 1.0) < 1e-9


def exact_axial_and_roll(rotation: np.ndarray, translation: np.ndarray) -> tuple[bool, bool]:
    """Whether the axial (``C_d1``) and the roll (``C_d4``) quadratic drag of a cylinder placed by
    ``rotation``/``translation`` in a link keep an exact diagonal form in the link frame.

    ``-D_Q |nu_c| nu_c`` stays of that form only where the cylinder's axial speed ``u_c`` (roll
    rate ``p_c``) is plus or minus one link velocity component: the axis parallel to a link axis
    and through the link origin (parallel to a link axis). Where it is not, the term is evaluated
    in the cylinder frame with the crossflow strip integral (:mod:`aiauv_hydro.laws.crossflow`),
    where it is exact for any placement.
    """
    transform = motion_transform(np.asarray(rotation, float), np.asarray(translation, float))
    return _is_signed_unit_row(transform[0]), _is_signed_unit_row(transform[3])


def slender_cylinder_link(
    name: str,
    length: float,
    radius: float,
    fluid_density: float,
    volume: float | None = None,
    center_of_buoyancy: np.ndarray | None = None,
    coefficients: SlenderCylinderCoefficients = DEFAULT_COEFFICIENTS,
    rotation: np.ndarray | None = None,
    translation: np.ndarray | None = None,
) -> LinkHydrodynamics:
    """Per-link hydrodynamics of a link shaped as one slender cylinder.

    Args:
        name: URDF link name.
        length: Cylinder length ``L`` [m].
        radius: Cylinder radius ``r`` [m].
        fluid_density: Water density ``rho`` [kg/m^3].
        volume: Displaced volume [m^3]; default the cylinder's ``pi r^2 L``.
        center_of_buoyancy: Centre of buoyancy in the link frame [m]; default the cylinder centre.
        coefficients: Model coefficients.
        rotation: Orientation of the cylinder frame (x on the axis) in the link frame; default I.
        translation: Cylinder rear-end position in the link frame [m]; default 0.

    Returns:
        The link's parameters in the link frame about its origin, with the crossflow drag placed by
        ``rotation``/``translation``. The axial (``C_d1``) and roll (``C_d4``) quadratic drag are
        in ``D_Q`` where they have an exact link-frame form (:func:`exact_axial_and_roll`), else
        carried by the crossflow record and evaluated in the cylinder frame.

    Raises:
        HydroError: Bad dimensions or a rotation that is not a rotation.
    """
    _check_dimensions(length, radius, fluid_density)
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    translation = np.zeros(3) if translation is None else np.asarray(translation, dtype=float)
    if rotation.shape != (3, 3) or translation.shape != (3,):
        raise HydroError(f"link '{name}': cylinder placement must be a 3x3 rotation and a 3-vector")
    if not (np.all(np.isfinite(rotation)) and np.all(np.isfinite(translation))):
        raise HydroError(f"link '{name}': cylinder placement contains NaN or infinite values")
    if not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-9) or np.linalg.det(rotation) < 0:
        raise HydroError(f"link '{name}': cylinder rotation is not a proper rotation matrix")

    added_mass = added_mass_matrix(length, radius, fluid_density, coefficients)
    linear = linear_damping_matrix(length, radius, fluid_density, coefficients)
    quadratic = quadratic_damping_matrix(length, radius, fluid_density, coefficients)

    transform = motion_transform(rotation, translation)
    in_cylinder_frame = {"axial_drag_coefficient": 0.0, "roll_drag_coefficient": 0.0}
    if not np.array_equal(transform, np.eye(6)):
        # M_link = X^T M_c X and D_link = X^T D_c X: same power / kinetic energy in both frames
        # (Featherstone 2008, Ch. 2; Fossen 2021, Sec. 3.3).
        added_mass = transform.T @ added_mass @ transform
        added_mass = 0.5 * (added_mass + added_mass.T)
        linear = transform.T @ linear @ transform
        linear = 0.5 * (linear + linear.T)
        # -D_Q (|nu_c| * nu_c) only stays of that form in link coordinates when the axial speed u_c
        # and the roll rate p_c are each +- one link velocity component; otherwise the term moves
        # to the cylinder frame, evaluated with the crossflow drag (exact there for any placement)
        for index, field_name, value in (
            (0, "axial_drag_coefficient", coefficients.C_d1),
            (3, "roll_drag_coefficient", coefficients.C_d4),
        ):
            if quadratic[index, index] != 0.0 and not _is_signed_unit_row(transform[index]):
                in_cylinder_frame[field_name] = value
                quadratic[index, index] = 0.0
        quadratic = transform.T @ quadratic @ transform
        quadratic[
            np.abs(quadratic) < _EXACT_TOLERANCE * max(1.0, float(np.abs(quadratic).max()))
        ] = 0.0

    if volume is None:
        volume = math.pi * radius**2 * length  # solid cylinder volume
    if center_of_buoyancy is None:
        # Centroid of a uniform cylinder: its mid-point on the axis, R (L/2, 0, 0) + p.
        center_of_buoyancy = translation + rotation @ np.array([0.5 * length, 0.0, 0.0])

    crossflow = CrossflowDrag(
        length=float(length),
        radius=float(radius),
        drag_coefficient=coefficients.C_dC,
        fluid_density=float(fluid_density),
        rotation=rotation,
        translation=translation,
        **in_cylinder_frame,
    )
    return LinkHydrodynamics(
        link=name,
        model="slender_cylinder",
        volume=volume,
        center_of_buoyancy=center_of_buoyancy,
        added_mass=added_mass,
        linear_damping=linear,
        quadratic_damping=quadratic,
        crossflow=crossflow,
    )
