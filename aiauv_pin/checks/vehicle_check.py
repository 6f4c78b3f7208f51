"""``aiauv check``: validate a vehicle URDF and tabulate what the simulator will use.

A vehicle is *usable* when :func:`aiauv_pin.load_vehicle` accepts it (safe XML within the input
limits, a valid URDF tree, safe names, the physical and plausible parameters of the one validation
gate :mod:`aiauv_pin.model.validation`, 1-DOF joints) and its generalised mass matrix
``M(q) = M_RB(q) + M_A(q)`` is symmetric positive definite in the neutral configuration (otherwise
forward dynamics is undefined: a link with neither mass nor added mass, for instance). Anything else
that is unusual but simulable is a *warning*: the report lists it and the command still succeeds
(exit status 0). Warnings:

* the vehicle is not neutrally buoyant (net buoyancy ``(rho V - m) g`` beyond 1 % of its weight);
* a link has mass but no hydrodynamic parameters (no buoyancy, added mass or damping); a further warning
  suggests ``aiauv annotate``, which estimates them;
* the vehicle has no thrusters, or none along a link x-axis (the path-following controller needs
  them for surge), no ``end_effector`` frame, or joints other than equal numbers of y- and z-axis
  revolute joints (the path-following controller's layout);
* the playback cannot draw it as described: mesh files of its ``<visual>`` or ``<collision>``
  elements that are not found (those links are drawn without them), or a file or shape it cannot
  read (``aiauv simulate`` then needs ``--no-html``). The meshes are read as the playback reads
  them (:func:`aiauv_pin.results.viewer.vehicle_visuals`, through Pinocchio's geometry loader).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from aiauv_pin.description.urdf_validation import UrdfStructure
from aiauv_pin.model.loading import load_vehicle
from aiauv_pin.model.validation import validate_mass_matrix

#: Relative net buoyancy (fraction of the weight) above which a vehicle is "not neutrally buoyant".
BUOYANCY_TOLERANCE = 0.01


@dataclass(frozen=True)
class LinkRow:
    """One link of the report (link frame).

    Attributes:
        name: Link name.
        mass: Mass [kg].
        volume: Displaced volume [m^3].
        buoyancy_margin: Net upward hydrostatic force ``(rho V - m) g`` [N].
        center_of_gravity: In the link frame [m].
        center_of_buoyancy: In the link frame [m] (``None`` without hydrodynamics).
        added_mass_diagonal: Diagonal of ``M_A`` about the link origin (6,) [kg, kg m^2].
    """

    name: str
    mass: float
    volume: float
    buoyancy_margin: float
    center_of_gravity: np.ndarray
    center_of_buoyancy: np.ndarray | None
    added_mass_diagonal: np.ndarray


@dataclass(frozen=True)
class CheckReport:
    """Everything ``aiauv check`` prints.

    Attributes:
        path: The URDF file.
        structure: The validated URDF tree.
        links: Per-link rows, in URDF order.
        fluid_density: [kg/m^3].
        gravity: [m/s^2].
        total_mass: [kg].
        total_volume: [m^3].
        buoyancy_margin: Net upward hydrostatic force of the whole vehicle [N].
        center_of_gravity: Of the whole vehicle, root-link frame, neutral configuration [m].
        center_of_buoyancy: Of the whole vehicle, same frame [m] (``None`` with zero volume).
        thrusters: ``(name, link, position, direction, max_thrust)`` tuples.
        smallest_mass_eigenvalue: Smallest eigenvalue of ``M(q)`` at the neutral configuration.
        warnings: One-line warnings.
        fins: The vehicle's fins (:class:`aiauv_hydro.spec.Fin` records).
        fixed_base: The root link is fixed to the world.
    """

    path: Path
    structure: UrdfStructure
    links: tuple[LinkRow, ...]
    fluid_density: float
    gravity: float
    total_mass: float
    total_volume: float
    buoyancy_margin: float
    center_of_gravity: np.ndarray
    center_of_buoyancy: np.ndarray | None
    thrusters: tuple
    smallest_mass_eigenvalue: float
    warnings: tuple[str, ...]
    fins: tuple = ()
    fixed_base: bool = False


def check_vehicle(path: str | os.PathLike, **load_options) -> CheckReport:
    """Validate a vehicle URDF (or ``.xacro``) and collect its report.

    Args:
        path: The URDF or xacro file.
        load_options: ``xacro_args`` and ``package_path`` of :func:`aiauv_pin.load_vehicle`.

    Raises:
        VehicleLoadError: The vehicle is not usable; the message is one line naming the reason.
    """
    path = Path(path)
    vehicle = load_vehicle(
        path, **load_options
    )  # the validation gate of aiauv_pin.model.validation
    structure = vehicle.urdf_structure
    hydro = vehicle.hydro
    rho, g = hydro.fluid_density, hydro.gravity
    model = vehicle.model
    q = vehicle.neutral_configuration()
    smallest_eigenvalue = validate_mass_matrix(vehicle, str(path), reference=True)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    by_link = {link.link: link for link in hydro.links}
    rows = []
    warnings: list[str] = []
    weighted_cg = np.zeros(3)
    weighted_cb = np.zeros(3)
    for name in structure.links:
        inertial = structure.inertials.get(name)
        mass = inertial.mass if inertial is not None else 0.0
        cg = inertial.xyz.copy() if inertial is not None else np.zeros(3)
        link = by_link.get(name)
        volume = link.volume if link is not None else 0.0
        cb = None if link is None else np.array(link.center_of_buoyancy)
        placement = data.oMf[model.getFrameId(name, pin.FrameType.BODY)]
        weighted_cg += mass * placement.act(cg)
        if cb is not None:
            weighted_cb += volume * placement.act(cb)
        diagonal = np.diag(link.added_mass).copy() if link is not None else np.zeros(6)
        rows.append(LinkRow(name, mass, volume, _margin(rho * volume, mass, g), cg, cb, diagonal))
        if link is None and mass > 0.0:
            warnings.append(f"link '{name}' has mass but no hydrodynamic parameters")
    if any("no hydrodynamic parameters" in warning for warning in warnings):
        warnings.append(
            f"estimate the missing hydrodynamics with 'aiauv annotate {path} -o OUT.urdf'"
        )
    total_mass = sum(row.mass for row in rows)
    total_volume = sum(row.volume for row in rows)
    margin = _margin(rho * total_volume, total_mass, g)
    if abs(margin) > BUOYANCY_TOLERANCE * total_mass * g:
        state = "positively" if margin > 0 else "negatively"
        warnings.append(
            f"not neutrally buoyant: {state} buoyant by {margin:+.4g} N "
            f"({100 * margin / (total_mass * g):+.2f} % of the weight)"
        )
    if not hydro.thrusters:
        warnings.append("no thrusters")
    elif not any(abs(t.direction[0]) > 0.999 for t in hydro.thrusters):
        warnings.append("no thruster along a link x-axis (the path-following controller needs one)")
    if not model.existFrame("end_effector"):
        warnings.append("no 'end_effector' frame (the path-following controller needs one)")
    axes = _joint_axis_labels(structure)
    if axes is None or axes.count("y") != axes.count("z") or not axes:
        warnings.append(
            "joints are not equal numbers of y- and z-axis revolute joints "
            "(the path-following controller's layout)"
        )
    warnings += _playback_warnings(vehicle, load_options.get("package_path", ()))
    warnings += [f"SDF: {note}" for note in vehicle.description_notes]
    root_frame = data.oMf[model.getFrameId(structure.root, pin.FrameType.BODY)]
    cg_total = root_frame.actInv(weighted_cg / total_mass) if total_mass > 0 else np.zeros(3)
    cb_total = root_frame.actInv(weighted_cb / total_volume) if total_volume > 0 else None
    thrusters = tuple(
        (t.name, t.link, np.array(t.position), np.array(t.direction), t.max_thrust)
        for t in hydro.thrusters
    )
    return CheckReport(
        path=path,
        structure=structure,
        links=tuple(rows),
        fluid_density=rho,
        gravity=g,
        total_mass=total_mass,
        total_volume=total_volume,
        buoyancy_margin=margin,
        center_of_gravity=cg_total,
        center_of_buoyancy=cb_total,
        thrusters=thrusters,
        smallest_mass_eigenvalue=smallest_eigenvalue,
        warnings=tuple(warnings),
        fins=tuple(hydro.fins),
        fixed_base=vehicle.fixed_base,
    )


def _playback_warnings(vehicle, package_path) -> list[str]:
    """What the playback would say of the vehicle's shapes (its warnings, or why it cannot draw
    them), as one-line warnings."""
    import warnings as python_warnings

    from aiauv_pin.results.viewer import vehicle_visuals

    with python_warnings.catch_warnings(record=True) as caught:
        python_warnings.simplefilter("always")
        try:
            vehicle_visuals(vehicle, package_path=package_path)
        except ValueError as exc:
            reason = " ".join(str(exc).split())
            return [f"the playback cannot draw this vehicle: {reason} (simulate with --no-html)"]
    return [f"the playback: {' '.join(str(w.message).split())}" for w in caught]


def _margin(displaced: float, mass: float, gravity: float) -> float:
    """``(rho V - m) g`` [N], with round-off (below 1e-9 of the larger term) shown as zero."""
    margin = (displaced - mass) * gravity
    return 0.0 if abs(margin) <= 1e-9 * max(displaced, mass) * gravity else margin


def _joint_axis_labels(structure: UrdfStructure) -> list[str] | None:
    labels = []
    for joint in structure.joints:
        if joint.type == "fixed":
            continue
        if joint.type != "revolute" or np.any(joint.rpy != 0.0):
            return None
        k = int(np.argmax(np.abs(joint.axis)))
        if abs(abs(joint.axis[k]) - 1.0) > 1e-9:
            return None
        labels.append("xyz"[k])
    return labels


def _vector(values) -> str:
    return " ".join(f"{v:+.3f}" for v in values)


def _limit(value: float | None) -> str:
    return "-" if value is None else f"{value:+.4g}"


def format_report(report: CheckReport) -> str:
    """The report as a plain-text table (SI units)."""
    s = report.structure
    shown = str(report.path)
    shown = shown if shown.isprintable() else repr(shown)  # a path cannot print lines of its own
    lines = [
        f"vehicle '{s.name}' from {shown}",
        f"fluid density {report.fluid_density:g} kg/m^3, gravity {report.gravity:g} m/s^2, "
        f"root link '{s.root}'"
        + (" (fixed base: fixed to the world)" if report.fixed_base else ""),
        "",
        "links (link frame; margin = (rho V - m) g)",
        f"{'link':<20} {'mass kg':>9} {'V m^3':>10} {'margin N':>10} {'CG m':>22} {'CB m':>22}"
        f"  added-mass diagonal [kg, kg m^2]",
    ]
    for row in report.links:
        cb = _vector(row.center_of_buoyancy) if row.center_of_buoyancy is not None else "-"
        lines.append(
            f"{row.name:<20} {row.mass:>9.4g} {row.volume:>10.4g} {row.buoyancy_margin:>+10.4g} "
            f"{_vector(row.center_of_gravity):>22} {cb:>22}  "
            + " ".join(f"{v:.4g}" for v in row.added_mass_diagonal)
        )
    cb_total = _vector(report.center_of_buoyancy) if report.center_of_buoyancy is not None else "-"
    lines += [
        f"{'total':<20} {report.total_mass:>9.4g} {report.total_volume:>10.4g} "
        f"{report.buoyancy_margin:>+10.4g} {_vector(report.center_of_gravity):>22} "
        f"{cb_total:>22}  (CG, CB of the straight vehicle in the root frame)",
        "",
        f"joints ({len(s.joints)})",
        f"{'joint':<20} {'type':<10} {'parent -> child':<34} {'axis':>20} {'lower':>7} "
        f"{'upper':>7} {'effort':>8} {'velocity':>8}",
    ]
    for j in s.joints:
        lines.append(
            f"{j.name:<20} {j.type:<10} {j.parent + ' -> ' + j.child:<34} {_vector(j.axis):>20} "
            f"{_limit(j.lower):>7} {_limit(j.upper):>7} {_limit(j.effort):>8} "
            f"{_limit(j.velocity):>8}"
        )
    lines += [
        "",
        f"thrusters ({len(report.thrusters)})",
        f"{'thruster':<20} {'link':<20} {'position m':>22} {'direction':>22} {'max N':>7}",
    ]
    for name, link, position, direction, max_thrust in report.thrusters:
        lines.append(
            f"{name:<20} {link:<20} {_vector(position):>22} {_vector(direction):>22} "
            f"{max_thrust:>7.4g}"
        )
    if report.fins:
        lines += [
            "",
            f"fins ({len(report.fins)})",
            f"{'fin':<20} {'link':<20} {'position m':>22} {'axis':>22} {'area m^2':>9} "
            f"{'max deg':>7}",
        ]
        for fin in report.fins:
            lines.append(
                f"{fin.name:<20} {fin.link:<20} {_vector(fin.position):>22} "
                f"{_vector(fin.axis):>22} {fin.area:>9.4g} {math.degrees(fin.max_angle):>7.3g}"
            )
    lines.append("")
    lines.append(
        f"smallest eigenvalue of M(q) at q = neutral: {report.smallest_mass_eigenvalue:.4g}"
    )
    lines += [f"warning: {w}" for w in report.warnings]
    count = len(report.warnings)
    suffix = f" ({count} warning{'s' if count != 1 else ''})" if count else ""
    lines.append(f"OK: usable vehicle{suffix}")
    return "\n".join(lines)
