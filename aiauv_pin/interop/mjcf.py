"""MuJoCo interop: export of a vehicle URDF as an MJCF model.

What the MJCF carries exactly: the kinematic tree (one body per URDF link, the root on a free joint,
one hinge or slide joint per revolute or prismatic URDF joint, fixed joints welded), each link's
mass, centre of mass and full inertia, joint limits, and the thrusters as ``<general>`` actuators on
sites (gear = the thrust direction, control = thrust [N], limited to ``max_thrust``).

What it approximates (MuJoCo has no per-body added-mass or damping matrices): the fluid acts through
MuJoCo's ellipsoid model (``fluidshape="ellipsoid"``; google-deepmind/mujoco, ``engine_passive.c``,
``mj_ellipsoidFluidModel``; documentation "Computation / Fluid forces") on each link's collision
primitives (else its visual ones, else a sphere of the link's volume at its centre of buoyancy):
drag, lift and the velocity-dependent added-mass forces of the equivalent ellipsoid, with water's
density and viscosity. MuJoCo calls ``mj_addedMassForces`` there without accelerations, so its
added mass never enters the mass matrix. MuJoCo's fluid models apply no buoyancy; the buoyancy
force ``rho V g`` is given as gravity compensation (``gravcomp = rho V / m``), which MuJoCo applies
at the centre of mass: the restoring moment of a centre of buoyancy away from the centre of mass is
lost. Links without hydrodynamics get a zero-coefficient ellipsoid so that MuJoCo's inertia-box
fluid model does not act on them.

Frames: MuJoCo's free joint has ``qpos = (position, quaternion w x y z)`` and
``qvel = (linear velocity in the world frame, angular velocity in the body frame)``, both of the root
body's frame origin, which is the URDF root link frame.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement, indent, tostring

import numpy as np
import pinocchio as pin

from aiauv_hydro.estimate.mujoco_fluid import gravity_compensation
from aiauv_hydro.urdf.block_writer import format_number, format_numbers
from aiauv_pin._internal.atomic import write_text as atomic_write_text
from aiauv_pin.description.mjcf_reading import mujoco_geom_size
from aiauv_pin.interop.export_source import ExportSource, Shape, load_export_source, rpy_to_matrix
from aiauv_pin.interop.interop_errors import InteropError

#: Dynamic viscosity of water at 20 degC [Pa s] (MuJoCo's ``viscosity`` option).
WATER_VISCOSITY = 1.0e-3
#: Radius of the zero-coefficient fluid sphere of links without hydrodynamics [m].
INERT_FLUID_RADIUS = 1e-6


def _quaternion_wxyz(rotation: np.ndarray) -> np.ndarray:
    coeffs = pin.Quaternion(np.asarray(rotation, dtype=float)).coeffs()  # x, y, z, w
    return np.array([coeffs[3], coeffs[0], coeffs[1], coeffs[2]])


def _placement_attributes(xyz, rotation) -> dict[str, str]:
    attributes = {"pos": format_numbers(xyz)}
    if not np.allclose(rotation, np.eye(3), rtol=0.0, atol=0.0):
        attributes["quat"] = format_numbers(_quaternion_wxyz(rotation))
    return attributes


def _geom(body: Element, name: str, shape: Shape, fluid: bool) -> None:
    kind = shape.shape if shape.shape in ("box", "cylinder") else "sphere"
    size = mujoco_geom_size(kind, shape.size)
    attributes = {
        "name": name,
        "type": kind,
        "size": format_numbers(size),
        **_placement_attributes(shape.xyz, rpy_to_matrix(shape.rpy)),
        "contype": "0",
        "conaffinity": "0",
    }
    if fluid:
        attributes["fluidshape"] = "ellipsoid"
    SubElement(body, "geom", attributes)


def _header(source: ExportSource) -> str:
    hydro = source.vehicle.hydro
    lines = [
        f"MuJoCo model of {source.structure.name}, written by `aiauv export` from "
        f"{source.path.name}.",
        "Exact: kinematic tree, masses, centres of mass, inertias, joint limits, thrusters",
        "(<general> actuators on sites, control = thrust [N]). Root: free joint, qvel = (linear",
        "velocity in world, angular velocity in the body frame) of the root link frame.",
        "What MuJoCo drops: each link's 6x6 added-mass matrix (MuJoCo's ellipsoid fluid model",
        "applies only the velocity-dependent forces of its own ellipsoid added mass, none in the",
        "mass matrix), the linear, quadratic and forward-speed damping matrices and the",
        "crossflow strip drag",
        "(replaced by MuJoCo's ellipsoid drag and lift on the link geoms, water density",
        f"{format_number(hydro.fluid_density)} kg/m^3, viscosity {format_number(WATER_VISCOSITY)} "
        "Pa s), and the centre of buoyancy: buoyancy",
        "rho V g acts at each centre of mass (gravcomp = rho V / m), so the restoring moment of",
        'an offset centre of buoyancy is lost. Set <option density="0"> for rigid-body only.',
    ]
    return "\n  ".join(["", *lines]) + "\n"


def mjcf_text(source: ExportSource) -> str:
    """The MJCF model of a loaded vehicle (see the module docstring)."""
    structure = source.structure
    hydro = source.vehicle.hydro
    parameters = {link.link: link for link in hydro.links}
    children: dict[str, list] = {}
    for joint in structure.joints:
        children.setdefault(joint.parent, []).append(joint)
    parent_joint = {joint.child: joint for joint in structure.joints}
    for link in structure.links:
        joint = parent_joint.get(link)
        if link not in structure.inertials and (joint is None or joint.type != "fixed"):
            raise InteropError(
                f"{source.path}: link '{link}' has no <inertial> but moves; MuJoCo needs a "
                "positive mass and inertia for every moving body"
            )

    mujoco = Element("mujoco", {"model": structure.name})
    SubElement(
        mujoco, "compiler", {"angle": "radian", "inertiafromgeom": "false", "autolimits": "true"}
    )
    SubElement(
        mujoco,
        "option",
        {
            "density": format_number(hydro.fluid_density),
            "viscosity": format_number(WATER_VISCOSITY),
            "gravity": format_numbers([0.0, 0.0, -hydro.gravity]),
            "integrator": "implicitfast",
        },
    )
    worldbody = SubElement(mujoco, "worldbody")
    sites = []

    def add_body(parent: Element, link: str) -> None:
        joint = parent_joint.get(link)
        if joint is None:
            body = SubElement(parent, "body", {"name": link, "pos": "0 0 0"})
            SubElement(body, "freejoint", {"name": f"{link}_free"})
        else:
            body = SubElement(
                parent,
                "body",
                {"name": link, **_placement_attributes(joint.xyz, rpy_to_matrix(joint.rpy))},
            )
            if joint.type in ("revolute", "continuous", "prismatic"):
                attributes = {
                    "name": joint.name,
                    "type": "slide" if joint.type == "prismatic" else "hinge",
                    "axis": format_numbers(joint.axis),
                }
                if joint.type != "continuous" and joint.lower is not None:
                    attributes["range"] = format_numbers([joint.lower, joint.upper])
                SubElement(body, "joint", attributes)
        inertial = structure.inertials.get(link)
        link_hydro = parameters.get(link)
        if inertial is not None:
            rotation = rpy_to_matrix(inertial.rpy)
            inertia = rotation @ inertial.inertia @ rotation.T  # about the CoM, body axes
            full = [inertia[0, 0], inertia[1, 1], inertia[2, 2]]
            full += [inertia[0, 1], inertia[0, 2], inertia[1, 2]]
            SubElement(
                body,
                "inertial",
                {
                    "pos": format_numbers(inertial.xyz),
                    "mass": format_number(inertial.mass),
                    "fullinertia": format_numbers(full),
                },
            )
            if link_hydro is not None and link_hydro.volume > 0.0:
                buoyancy = gravity_compensation(
                    link_hydro.volume, inertial.mass, hydro.fluid_density
                )
                body.set("gravcomp", format_number(buoyancy))
        if link_hydro is not None:
            shapes = [s for s in source.shapes[link] if s.kind == "collision"]
            shapes = shapes or [s for s in source.shapes[link] if s.kind == "visual"]
            if not shapes and link_hydro.volume > 0.0:
                radius = (3.0 * link_hydro.volume / (4.0 * math.pi)) ** (1.0 / 3.0)
                centre = link_hydro.center_of_buoyancy
                shapes = [Shape("collision", "sphere", (radius,), centre, np.zeros(3))]
            for index, shape in enumerate(shapes):
                _geom(body, f"{link}_fluid_{index}", shape, fluid=True)
        else:
            SubElement(
                body,
                "geom",
                {
                    "name": f"{link}_no_fluid",
                    "type": "sphere",
                    "size": format_number(INERT_FLUID_RADIUS),
                    "contype": "0",
                    "conaffinity": "0",
                    "fluidshape": "ellipsoid",
                    "fluidcoef": "0 0 0 0 0",
                },
            )
        for thruster in hydro.thrusters:
            if thruster.link == link:
                SubElement(
                    body, "site", {"name": thruster.name, "pos": format_numbers(thruster.position)}
                )
                sites.append(thruster)
        for child in children.get(link, []):
            add_body(body, child.child)

    add_body(worldbody, structure.root)
    if sites:
        actuator = SubElement(mujoco, "actuator")
        for thruster in sites:
            limit = thruster.max_thrust
            SubElement(
                actuator,
                "general",
                {
                    "name": thruster.name,
                    "site": thruster.name,
                    "gear": format_numbers([*thruster.direction, 0.0, 0.0, 0.0]),
                    "ctrlrange": format_numbers([-limit, limit]),
                },
            )
    indent(mujoco, space="  ")
    return (
        "<!--"
        + _header(source).replace("--", "- -")
        + "-->\n"
        + tostring(mujoco, encoding="unicode")
        + "\n"
    )


def export_mjcf(urdf: str | os.PathLike, output: str | os.PathLike) -> list[str]:
    """Write the MJCF model of a vehicle URDF.

    Args:
        urdf: The vehicle URDF.
        output: The ``.xml`` file to write.

    Returns:
        Notes on what MuJoCo drops (one line each), for the command line to print.
    """
    source = load_export_source(urdf)
    atomic_write_text(Path(output), mjcf_text(source))
    notes = []
    if source.vehicle.hydro.links:
        notes.append(
            "added-mass and damping matrices replaced by MuJoCo's ellipsoid fluid model; "
            "buoyancy acts at the centres of mass (see the file's header)"
        )
    if source.vehicle.hydro.fins:
        notes.append(f"{len(source.vehicle.hydro.fins)} fin(s) not exported (MuJoCo has no lift)")
    return notes
