"""The one validation gate of vehicle parameters, shared by ``check``, ``simulate``, ``load_vehicle``,
``build`` and sweeps (all of them load through :func:`aiauv_pin.load_vehicle`, which calls
:func:`validate_parameters` and :func:`validate_mass_matrix`), so every command gives the same
verdict on the same file.

Refused (:class:`aiauv_pin.errors.PhysicalParameterError`, one line naming the parameter):

* non-finite numbers anywhere (also refused earlier by the URDF and hydrodynamics readers);
* a negative link mass, or a vehicle whose links all have zero mass;
* a rigid inertia that is not positive semi-definite or breaks the triangle inequality
  ``I_a + I_b >= I_c`` of its principal moments (relative tolerance :data:`TRIANGLE_TOLERANCE`):
  no real body has it;
* added mass, linear damping ``D_L`` or quadratic damping ``D_Q`` whose symmetric part is not
  positive semi-definite (relative tolerance :data:`PSD_TOLERANCE`): such damping feeds energy into
  the vehicle (the UUV Simulator reader refuses the same, :mod:`aiauv_hydro.urdf.uuv_simulator`);
* implausible magnitudes, far outside any underwater vehicle (thresholds in
  :mod:`aiauv_pin.description.plausible_ranges`, each orders of magnitude beyond real vehicles): gravity above
  :data:`MAX_GRAVITY`, fluid density outside ``[MIN_FLUID_DENSITY, MAX_FLUID_DENSITY]``, a link
  mass above :data:`MAX_LINK_MASS`, a principal moment of inertia above :data:`MAX_INERTIA`, a
  volume above :data:`MAX_VOLUME`, a distance (joint origin, centre of gravity or buoyancy,
  thruster position) above :data:`MAX_DISTANCE`, an added-mass or damping entry above
  :data:`MAX_COEFFICIENT`, a thrust limit above :data:`MAX_THRUST`;
* a thruster farther from its link's origin than ``THRUSTER_REACH * size + THRUSTER_MARGIN``, with
  ``size`` the link's extent (its geometry, centre of gravity and buoyancy, and the origins of the
  joints it carries);
* a mass matrix ``M(q)`` that is not positive definite at the neutral configuration (some body has
  neither mass nor added mass), or not finite (with a fixed base, its joints' block ``M_jj``);
* a crossflow (slender-cylinder) drag outside its range: cylinder length or radius outside
  :data:`aiauv_hydro.urdf.block_reader.LENGTH_RANGE`, a drag coefficient above
  :data:`aiauv_hydro.urdf.block_reader.MAX_DIMENSIONLESS`, or a strip coefficient times length above
  :data:`MAX_COEFFICIENT`.

The plausibility ranges (the magnitudes above, geometry, coefficients) are one table,
:data:`aiauv_pin.description.plausible_ranges.PLAUSIBLE_RANGES`, with its reasoning.

:func:`explain_divergence` names a suspect parameter when a run diverges: a damping time constant
shorter than the step, a thrust that accelerates the vehicle implausibly, or else the parameter
nearest the top of its range relative to that range (:func:`divergence_suspect`).
"""

from __future__ import annotations

import math

import numpy as np

from aiauv_hydro.spec import HydroSpec
from aiauv_hydro.urdf.block_reader import MAX_DIMENSIONLESS
from aiauv_pin.description.plausible_ranges import (  # noqa: F401  (re-exported: the gate's thresholds)
    MAX_COEFFICIENT,
    MAX_DISTANCE,
    MAX_FLUID_DENSITY,
    MAX_GRAVITY,
    MAX_INERTIA,
    MAX_LINK_MASS,
    MAX_THRUST,
    MAX_VOLUME,
    MIN_FLUID_DENSITY,
    PLAUSIBLE_RANGES,
    check_range,
)
from aiauv_pin.description.urdf_validation import UrdfStructure
from aiauv_pin.errors import PhysicalParameterError

#: A thruster may sit at most ``THRUSTER_REACH * size + THRUSTER_MARGIN`` [m] from its link origin.
THRUSTER_REACH = 2.0
THRUSTER_MARGIN = 1.0
#: Relative tolerance of the positive semi-definiteness checks (of the largest entry's magnitude).
PSD_TOLERANCE = 1e-9
#: Relative tolerance of the triangle inequality (of the largest principal moment).
TRIANGLE_TOLERANCE = 1e-6


def _refuse(where: str, message: str) -> PhysicalParameterError:
    return PhysicalParameterError(f"{where}: {message}" if where else message)


def _check_psd(matrix: np.ndarray, what: str, where: str) -> None:
    peak = float(np.max(np.abs(matrix)))
    if peak > MAX_COEFFICIENT:
        raise _refuse(where, f"{what} has an entry of {peak:.3g}, above {MAX_COEFFICIENT:g}")
    symmetric = 0.5 * (matrix + matrix.T)
    smallest = float(np.min(np.linalg.eigvalsh(symmetric))) if peak > 0 else 0.0
    if smallest < -PSD_TOLERANCE * peak:
        raise _refuse(
            where,
            f"{what} is not positive semi-definite (eigenvalue {smallest:.4g} of its symmetric "
            "part): it would feed energy into the vehicle",
        )


def link_sizes(structure: UrdfStructure, hydro: HydroSpec) -> dict[str, float]:
    """Extent of each link from its origin [m]: geometry, CG, CB, origins of its child joints."""
    sizes = dict.fromkeys(structure.links, 0.0)
    sizes.update(structure.geometry_extents)  # read in the validation walk
    for name, inertial in structure.inertials.items():
        sizes[name] = max(sizes[name], float(np.linalg.norm(inertial.xyz)))
    for joint in structure.joints:
        sizes[joint.parent] = max(sizes[joint.parent], float(np.linalg.norm(joint.xyz)))
    for link in hydro.links:
        if link.link in sizes:
            extent = float(np.linalg.norm(link.center_of_buoyancy))
            if link.crossflow is not None:
                extent += float(link.crossflow.length)
            sizes[link.link] = max(sizes[link.link], extent)
    return sizes


def validate_parameters(structure: UrdfStructure, hydro: HydroSpec, where: str = "") -> None:
    """Refuse non-physical or implausible parameters (see the module docstring).

    Args:
        structure: The validated URDF tree (with the links' geometry extents).
        hydro: The hydrodynamic parameters.
        where: Prefix of the error messages (the file).

    Raises:
        PhysicalParameterError: One line naming the parameter and the threshold.
    """
    if not (math.isfinite(hydro.gravity) and 0.0 <= hydro.gravity <= MAX_GRAVITY):
        raise _refuse(where, f"gravity {hydro.gravity:.4g} m/s^2 outside [0, {MAX_GRAVITY:g}]")
    rho = hydro.fluid_density
    if not (math.isfinite(rho) and MIN_FLUID_DENSITY <= rho <= MAX_FLUID_DENSITY):
        raise _refuse(
            where,
            f"fluid_density {rho:.4g} kg/m^3 outside [{MIN_FLUID_DENSITY:g}, {MAX_FLUID_DENSITY:g}]",
        )
    total_mass = 0.0
    for name, inertial in structure.inertials.items():
        what = f"link '{name}'"
        mass = inertial.mass
        if not (math.isfinite(mass) and 0.0 <= mass <= MAX_LINK_MASS):
            raise _refuse(where, f"{what}: mass {mass:.4g} kg outside [0, {MAX_LINK_MASS:g}]")
        total_mass += mass
        inertia = inertial.inertia
        if not np.all(np.isfinite(inertia)):
            raise _refuse(where, f"{what}: inertia is not finite")
        peak = float(np.max(np.abs(inertia)))
        if peak > MAX_INERTIA:
            raise _refuse(
                where, f"{what}: moment of inertia {peak:.4g} kg m^2 above {MAX_INERTIA:g}"
            )
        moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
        if moments[-1] > MAX_INERTIA:
            raise _refuse(
                where,
                f"{what}: moment of inertia {moments[-1]:.4g} kg m^2 above {MAX_INERTIA:g}",
            )
        if moments[0] + moments[1] < moments[2] - TRIANGLE_TOLERANCE * moments[2]:
            raise _refuse(
                where,
                f"{what}: inertia breaks the triangle inequality (principal moments "
                f"{moments[0]:.4g}, {moments[1]:.4g}, {moments[2]:.4g} kg m^2): no real body has it",
            )
        if float(np.linalg.norm(inertial.xyz)) > MAX_DISTANCE:
            raise _refuse(where, f"{what}: centre of gravity farther than {MAX_DISTANCE:g} m")
    if total_mass <= 0.0:
        raise _refuse(
            where, "every link has zero mass (no mass: the mass matrix would be singular)"
        )
    for joint in structure.joints:
        if float(np.linalg.norm(joint.xyz)) > MAX_DISTANCE:
            raise _refuse(
                where,
                f"joint '{joint.name}': origin farther than {MAX_DISTANCE:g} m from its parent",
            )
    for link in hydro.links:
        what = f"link '{link.link}'"
        if link.volume > MAX_VOLUME:
            raise _refuse(where, f"{what}: volume {link.volume:.4g} m^3 above {MAX_VOLUME:g}")
        if float(np.linalg.norm(link.center_of_buoyancy)) > MAX_DISTANCE:
            raise _refuse(where, f"{what}: centre of buoyancy farther than {MAX_DISTANCE:g} m")
        _check_psd(link.added_mass, f"{what}: added_mass", where)
        _check_psd(link.linear_damping, f"{what}: linear_damping", where)
        _check_psd(link.quadratic_damping, f"{what}: quadratic_damping", where)
        # dissipative in forward motion (u_r > 0), as UUV Simulator's coefficients are meant
        _check_psd(link.forward_speed_damping, f"{what}: linear_damping_forward_speed", where)
        crossflow = link.crossflow
        if crossflow is not None:
            check_range(crossflow.length, "geometry size", f"{what}: crossflow length", where)
            check_range(crossflow.radius, "geometry size", f"{what}: crossflow radius", where)
            for value, label in (
                (crossflow.drag_coefficient, "crossflow drag coefficient C_dC"),
                (crossflow.axial_drag_coefficient, "cylinder-frame axial drag coefficient C_d1"),
                (crossflow.roll_drag_coefficient, "cylinder-frame roll drag coefficient C_d4"),
            ):
                check_range(value, "dimensionless coefficient", f"{what}: {label}", where)
            check_range(
                crossflow.strip_coefficient * crossflow.length,
                "strip coefficient x length",
                f"{what}: crossflow rho r C_dC L",
                where,
            )
    sizes = link_sizes(structure, hydro)
    for thruster in hydro.thrusters:
        what = f"thruster '{thruster.name}'"
        if thruster.max_thrust > MAX_THRUST:
            raise _refuse(
                where, f"{what}: max_thrust {thruster.max_thrust:.4g} N above {MAX_THRUST:g}"
            )
        distance = float(np.linalg.norm(thruster.position))
        reach = THRUSTER_REACH * sizes.get(thruster.link, 0.0) + THRUSTER_MARGIN
        if distance > reach:
            raise _refuse(
                where,
                f"{what}: {distance:.4g} m from the origin of its link '{thruster.link}', farther "
                f"than {reach:.4g} m (= {THRUSTER_REACH:g} x the link's size + {THRUSTER_MARGIN:g} m)",
            )


#: From this many velocity coordinates on, a compiled vehicle's mass matrix is checked on the
#: compiled accelerations (:func:`validate_mass_matrix`): Pinocchio's ``Data`` is then 2 MB or more.
COMPILED_CHECK_FROM = 32


def validate_mass_matrix(vehicle, where: str = "", *, reference: bool = False) -> float:
    """Refuse a vehicle whose ``M(q)`` at the neutral configuration is not finite and positive
    definite; return its smallest eigenvalue.

    A vehicle running compiled (:attr:`aiauv_pin.Vehicle.fast`) with at least
    :data:`COMPILED_CHECK_FROM` velocity coordinates is checked without Pinocchio's ``Data``
    (about 150 MB at 127 links, its size growing as ``nv^3``; the compiled path never needs it;
    below that size the ``Data`` is small and Pinocchio's check is cheaper than loading the
    compiled entry point, 30-40 ms of CPU once): the columns of ``M^-1`` are the compiled
    accelerations of unit generalised forces at rest, ``a(e_i) - a(0)`` (the equations of
    motion are linear in ``tau``), and ``M`` is positive definite exactly when ``M^-1`` is, with
    ``lambda_min(M) = 1 / lambda_max(M^-1)`` and the same ratio of extreme eigenvalues.
    ``reference=True`` (``aiauv check``, which prints the eigenvalue), smaller vehicles and the
    Pinocchio backend form ``M`` with Pinocchio (:meth:`aiauv_pin.Vehicle.mass_matrix`).

    Raises:
        PhysicalParameterError: One line.
    """
    if vehicle.fast is not None and vehicle.nv >= COMPILED_CHECK_FROM and not reference:
        return _validate_inverse_mass_matrix(vehicle, where)
    mass_matrix = vehicle.mass_matrix(vehicle.neutral_configuration())
    if getattr(vehicle, "fixed_base", False):  # the joints' block alone moves
        mass_matrix = mass_matrix[6:, 6:]
        if mass_matrix.size == 0:
            return float("inf")
    if not np.all(np.isfinite(mass_matrix)):
        raise _refuse(where, "mass matrix M(q) is not finite at the neutral configuration")
    eigenvalues = np.linalg.eigvalsh(0.5 * (mass_matrix + mass_matrix.T))
    scale = max(float(np.max(np.abs(eigenvalues))), 1e-300)
    if eigenvalues[0] <= 1e-12 * scale:
        raise _singular(where, eigenvalues[0])
    return float(eigenvalues[0])


def _singular(where: str, smallest: float) -> PhysicalParameterError:
    return _refuse(
        where,
        f"mass matrix M(q) is singular at the neutral configuration (smallest eigenvalue "
        f"{smallest:.3g}): some body has neither mass nor added mass",
    )


def _validate_inverse_mass_matrix(vehicle, where: str) -> float:
    """:func:`validate_mass_matrix` on ``M^-1`` from the compiled accelerations (see there)."""
    fast = vehicle.fast
    q = vehicle.neutral_configuration()
    rest = np.zeros(vehicle.nv)
    # a fixed base (locked base, FORMATS.md) has no base accelerations: its joints' block only
    free = np.arange(6 if getattr(vehicle, "fixed_base", False) else 0, vehicle.nv)
    unit = np.zeros(vehicle.nv)
    inverse = np.empty((free.size, free.size))
    with np.errstate(all="ignore"):
        base = fast.acceleration(q, rest, rest)
        for column, i in enumerate(free):
            unit[i] = 1.0
            inverse[:, column] = (fast.acceleration(q, rest, unit) - base)[free]
            unit[i] = 0.0
    if not np.all(np.isfinite(inverse)):
        raise _singular(where, 0.0)
    eigenvalues = np.linalg.eigvalsh(0.5 * (inverse + inverse.T))
    if eigenvalues[0] <= 1e-12 * max(float(np.max(np.abs(eigenvalues))), 1e-300):
        raise _singular(where, 0.0 if eigenvalues[-1] <= 0.0 else 1.0 / eigenvalues[-1])
    return float(1.0 / eigenvalues[-1])


def divergence_suspect(vehicle, dt: float) -> str | None:
    """The parameter most likely to make a fixed-step run diverge at step ``dt``, or ``None``.

    Looks at, per link, the damping rates ``D_ii / M_ii`` (``M_ii`` the rigid inertia of the link's
    body plus the link's added mass; quadratic damping and the crossflow drag ``rho r C_dC L`` at
    1 m/s or 1 rad/s), and at the largest thrust over the vehicle's mass;
    a rate ``r`` with ``r dt > 1`` (explicit Runge-Kutta schemes lose stability near ``r dt = 2.8``)
    or a thrust accelerating the vehicle by more than ``1000 m/s^2`` is named. Failing those, the
    added-mass, damping or crossflow coefficient largest relative to the top of its plausible range
    (:data:`PLAUSIBLE_RANGES`) is named when it is above :data:`SUSPECT_SHARE` of it.
    """
    try:
        total_mass = sum(float(i.mass) for i in vehicle.model.inertias[1:])
        worst: tuple[float, str] | None = None
        by_link = {}
        for frame in vehicle.model.frames:
            by_link.setdefault(frame.name, frame)
        for link in vehicle.hydro.links:
            frame = by_link.get(link.link)
            inertia = (
                vehicle.model.inertias[int(frame.parentJoint)].matrix()
                if frame is not None
                else None
            )
            diagonal = np.diag(link.added_mass).copy()
            if inertia is not None:
                diagonal += np.diag(inertia)
            crossflow = np.zeros((6, 6))
            if link.crossflow is not None:  # transverse drag per (m/s)^2 over the whole length
                drag = link.crossflow.strip_coefficient * link.crossflow.length
                crossflow[1, 1] = crossflow[2, 2] = drag
            for label, matrix in (
                ("linear_damping", link.linear_damping),
                ("quadratic_damping", link.quadratic_damping),
                ("crossflow drag rho r C_dC L", crossflow),
            ):
                for i in range(6):
                    if diagonal[i] <= 0.0:
                        continue
                    rate = float(matrix[i, i]) / float(diagonal[i])
                    if rate * dt > 1.0 and (worst is None or rate > worst[0]):
                        worst = (
                            rate,
                            f"link '{link.link}' {label}[{i}][{i}] = {matrix[i, i]:.4g} gives a "
                            f"time constant of {1.0 / rate:.3g} s, shorter than dt = {dt:g} s",
                        )
        if worst is not None:
            return worst[1]
        if total_mass > 0 and vehicle.hydro.thrusters:
            thrust = float(np.max(vehicle.max_thrust))
            if thrust / total_mass > 1e3:
                name = vehicle.hydro.thrusters[int(np.argmax(vehicle.max_thrust))].name
                return (
                    f"thruster '{name}' max_thrust = {thrust:.4g} N accelerates the "
                    f"{total_mass:.4g} kg vehicle by {thrust / total_mass:.3g} m/s^2"
                )
        return _largest_relative_coefficient(vehicle.hydro)
    except Exception:  # a hint must never hide the divergence itself
        return None
    return None


#: Share of the top of its range above which a coefficient is named as a divergence suspect.
SUSPECT_SHARE = 1e-3


def _largest_relative_coefficient(hydro: HydroSpec) -> str | None:
    """The added-mass, damping or crossflow coefficient largest relative to the top of its range
    (:data:`PLAUSIBLE_RANGES`), when above :data:`SUSPECT_SHARE` of it; else ``None``."""
    best: tuple[float, str] | None = None
    for link in hydro.links:
        candidates = [
            (float(np.max(np.abs(getattr(link, name)))), name, MAX_COEFFICIENT)
            for name in (
                "added_mass",
                "linear_damping",
                "quadratic_damping",
                "forward_speed_damping",
            )
        ]
        if link.crossflow is not None:
            c = link.crossflow
            candidates.append((c.drag_coefficient, "crossflow C_dC", MAX_DIMENSIONLESS))
            candidates.append((c.axial_drag_coefficient, "crossflow C_d1", MAX_DIMENSIONLESS))
            candidates.append((c.roll_drag_coefficient, "crossflow C_d4", MAX_DIMENSIONLESS))
            candidates.append(
                (c.strip_coefficient * c.length, "crossflow rho r C_dC L", MAX_COEFFICIENT)
            )
        for value, name, top in candidates:
            share = value / top
            if share > SUSPECT_SHARE and (best is None or share > best[0]):
                best = (
                    share,
                    f"link '{link.link}' {name} = {value:.4g}, {share:.2g} of the top of its "
                    f"plausible range ({top:g})",
                )
    return None if best is None else best[1]


def explain_divergence(vehicle, dt: float, message: str) -> str:
    """A divergence message naming a suspect parameter when one exists (else ``message``)."""
    suspect = divergence_suspect(vehicle, dt)
    if suspect is None:
        return message
    head = message.split("; try a smaller step")[0]
    return f"{head}; suspect parameter: {suspect}"
