"""Reading a MuJoCo MJCF vehicle: MuJoCo compiles it, we write the URDF it is.

A file whose root element is ``<mujoco>`` is compiled by MuJoCo itself (the ``mujoco`` package,
an optional dependency: ``pip install mujoco``), so that every MJCF rule (``<compiler angle
eulerseq inertiafromgeom>``, ``<default>`` classes, ``pos/quat/euler/axisangle/xyaxes/zaxis``,
``fromto``, the inertia inferred from geoms, ``<include>``) is MuJoCo's, not a second reading of
ours. The compiled ``mjModel`` is then written as a URDF with our ``<hydrodynamics>`` block, which
the vehicle loader reads like any other (:func:`aiauv_pin.model.loading.load_vehicle`):

* the moving body under ``<worldbody>`` with a free joint is the root link (a free-flying
  vehicle); without one, MuJoCo's world body becomes a massless root link ``world`` with the
  body's joint (or a weld) below it, and the vehicle has a fixed base (:attr:`MjcfVehicle.fixed_base`);
  every body below it is a link, on a ``revolute`` (hinge) or ``prismatic`` (slide) joint, or
  ``fixed`` without a joint. A joint's ``pos`` becomes the link origin (URDF joints turn about
  their child's origin): the link frame is the body frame moved by it, and everything in the body
  is written relative to it. Bodies welded to the world without a joint (scenery) are left out;
* each body's mass, centre of mass and full inertia (``body_mass``, ``body_ipos``,
  ``body_iquat``, ``body_inertia``, which hold MuJoCo's inferred inertias);
* primitive geoms (box, cylinder, sphere) as visuals, and the ones in the fluid as collisions
  (what ``aiauv export`` writes back as fluid geoms);
* the fluid (:mod:`aiauv_hydro.estimate.mujoco_fluid`): MuJoCo's ellipsoid model of the geoms with
  ``fluidshape="ellipsoid"``, else its inertia-box model of the body, with ``<option density
  viscosity>``, as ``model="fossen"`` links; gravity compensation ``gravcomp`` as buoyancy at the
  centre of mass (``V = gravcomp m / rho``);
* ``<motor>``/``<general>`` actuators on a site with a force ``gear`` as thrusters (direction the
  gear's force in the site frame, ``max_thrust`` from ``ctrlrange`` and ``forcerange``).

What our model cannot carry is refused with one line (ball joints, several joints in one body,
equality constraints and tendons: loops; actuators that are not forces at a site), and what it
drops is said in one :class:`MjcfDroppedWarning` each (the Kutta and Magnus lift, joint damping
and springs, wind, joint actuators).
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import Element, ParseError, SubElement, indent, tostring

import defusedxml.ElementTree as SafeElementTree
import numpy as np
import pinocchio as pin

from aiauv_hydro.spec import HydroError, LinkHydrodynamics
from aiauv_hydro.urdf.block_writer import format_number, format_numbers, fossen_link_element
from aiauv_pin.description.safe_names import check_name
from aiauv_pin.errors import VehicleLoadError

#: Root element of an MJCF file.
MJCF_ROOT = "mujoco"
#: MuJoCo's ``mjMINVAL``: bodies lighter than this get no fluid forces (``engine_passive.c``).
MUJOCO_MIN_VALUE = 1e-15
#: Fluid density written when ``<option density>`` is 0 (only ``rho V`` of gravcomp matters then).
DENSITY_WITHOUT_FLUID = 1000.0
#: Range given to a hinge without limits [rad] (URDF revolute joints need one; not enforced).
UNLIMITED_HINGE = math.pi
#: Range given to a slide without limits [m].
UNLIMITED_SLIDE = 1e3
#: Effort and velocity limits of joints MuJoCo does not limit (urdfdom needs both; not enforced).
UNLIMITED_EFFORT = 1e9
UNLIMITED_VELOCITY = 1e9
#: Smallest geometry size a URDF shape may have [m] (smaller geoms are not written as shapes).
MIN_SHAPE_SIZE = 1e-4
#: URDF primitives of MuJoCo's geom types.
URDF_PRIMITIVES = ("box", "cylinder", "sphere")


#: What is dropped, said once for all the elements it concerns.
GROUPED_DROPS = {
    "lift": "Kutta and Magnus lift (fluidcoef[3:5]) dropped: no form in our per-link model",
    "joint damping": "joint damping dropped",
    "joint armature": "joint armature dropped",
    "joint frictionloss": "joint frictionloss dropped",
    "joint stiffness": "joint stiffness dropped",
    "joint actuator": "actuators on joints left out: the joint torques are the vehicle's inputs",
    "scenery": "bodies welded to the world (scenery) left out",
    "asymmetric": "thrust limits made symmetric (the largest of |ctrlrange| kept)",
}


def _some(names: list[str]) -> str:
    """``'a', 'b', 'c' and 4 more``: the first names of a list, on one short line."""
    shown = ", ".join(f"'{name}'" for name in names[:3])
    return shown + (f" and {len(names) - 3} more" if len(names) > 3 else "")


class MjcfDroppedWarning(UserWarning):
    """Something in an MJCF file that our model does not carry (one line: what and where)."""


@dataclass(frozen=True)
class MjcfVehicle:
    """An MJCF vehicle written as a URDF.

    Attributes:
        urdf_text: The URDF with its ``<hydrodynamics>`` block.
        dropped: What the URDF does not carry, one line each (also issued as warnings).
        fixed_base: The vehicle's root body is not on a free joint: it is welded or jointed to
            MuJoCo's world body, written as the URDF's massless root link ``world``; the vehicle
            needs a fixed base.
    """

    urdf_text: str
    dropped: tuple[str, ...]
    fixed_base: bool = False


def is_mjcf_text(text: str) -> bool:
    """Whether XML text is an MJCF model (root ``<mujoco>``); False for text that is not XML."""
    try:
        root = SafeElementTree.fromstring(text)
    except (ParseError, ValueError):  # not XML, or unsafe XML (defusedxml): the URDF path says so
        return False
    return root.tag == MJCF_ROOT


def urdf_shape_size(kind: str, size) -> tuple[float, ...]:
    """URDF shape sizes of a MuJoCo geom's (half-)sizes: box edges, cylinder (radius, length)."""
    if kind == "box":
        return tuple(2.0 * float(s) for s in size[:3])
    if kind == "cylinder":
        return (float(size[0]), 2.0 * float(size[1]))
    return (float(size[0]),)


def mujoco_geom_size(kind: str, size) -> np.ndarray:
    """MuJoCo geom ``size`` of URDF shape sizes (the inverse of :func:`urdf_shape_size`)."""
    if kind == "box":
        return np.asarray(size, dtype=float) / 2.0
    if kind == "cylinder":
        return np.array([float(size[0]), float(size[1]) / 2.0])
    return np.array([float(size[0])])


def _rotation(quaternion_wxyz) -> np.ndarray:
    w, x, y, z = (float(c) for c in quaternion_wxyz)
    return np.asarray(pin.Quaternion(w, x, y, z).normalized().toRotationMatrix(), dtype=float)


def _origin(parent: Element, xyz, rotation) -> None:
    attributes = {"xyz": format_numbers(xyz)}
    rpy = np.asarray(pin.rpy.matrixToRpy(np.asarray(rotation, dtype=float)), dtype=float)
    attributes["rpy"] = format_numbers(rpy)
    SubElement(parent, "origin", attributes)


def _compile(path: Path):
    try:
        import mujoco
    except ImportError:
        raise VehicleLoadError(
            f"{path}: an MJCF file is compiled by MuJoCo: install it (pip install mujoco)"
        ) from None
    try:
        return mujoco, mujoco.MjModel.from_xml_path(str(path))
    except ValueError as exc:
        reason = " ".join(str(exc).split())
        raise VehicleLoadError(f"{path}: MuJoCo cannot compile it ({reason})") from None


class _Reader:
    """One MJCF model being written as a URDF."""

    def __init__(self, path: Path):
        self.path = path
        self.mujoco, self.model = _compile(path)
        self.dropped: list[str] = []
        self.grouped: dict[str, list[str]] = {}  # what is dropped -> where (one line each)
        self.fixed_base = False

    def fail(self, message: str) -> VehicleLoadError:
        return VehicleLoadError(f"{self.path}: {message}")

    def drop(self, message: str) -> None:
        self.dropped.append(message)

    def name(self, kind, index: int, fallback: str) -> str:
        return self.mujoco.mj_id2name(self.model, kind, index) or f"{fallback}{index}"

    def body_name(self, body: int) -> str:
        return self.name(self.mujoco.mjtObj.mjOBJ_BODY, body, "body")

    def body_joints(self, body: int) -> list[int]:
        start = int(self.model.body_jntadr[body])
        return list(range(start, start + int(self.model.body_jntnum[body])))

    def subtree(self, body: int) -> list[int]:
        parents = self.model.body_parentid
        found = [body]
        for other in range(body + 1, self.model.nbody):  # MuJoCo numbers bodies depth first
            if int(parents[other]) in found:
                found.append(other)
        return found

    # -- the tree --------------------------------------------------------------------------------
    def root(self) -> int:
        model, mj = self.model, self.mujoco
        if model.neq:
            raise self.fail(
                f"{model.neq} equality constraint(s) (closed loops or welds): not supported; "
                "a vehicle is a tree"
            )
        if model.ntendon:
            raise self.fail(f"{model.ntendon} tendon(s): not supported")
        moving = [
            body
            for body in range(1, model.nbody)
            if int(model.body_parentid[body]) == 0
            and any(self.body_joints(b) for b in self.subtree(body))
        ]
        if not moving:
            raise self.fail("no moving body under <worldbody>: nothing to simulate")
        if len(moving) > 1:
            names = ", ".join(f"'{self.body_name(b)}'" for b in moving)
            raise self.fail(
                f"several moving bodies under <worldbody> ({names}): one vehicle a file"
            )
        root = moving[0]
        joints = self.body_joints(root)
        free = [j for j in joints if int(model.jnt_type[j]) == mj.mjtJoint.mjJNT_FREE]
        self.fixed_base = not free
        if free and len(joints) > 1:
            raise self.fail(f"body '{self.body_name(root)}' has a free joint and others")
        for other in range(1, model.nbody):
            if int(model.body_parentid[other]) == 0 and other != root:
                self.grouped.setdefault("scenery", []).append(self.body_name(other))
        return root

    def joint_of(self, body: int) -> int | None:
        model, mj = self.model, self.mujoco
        joints = self.body_joints(body)
        if len(joints) > 1:
            raise self.fail(
                f"body '{self.body_name(body)}' has {len(joints)} joints: one joint a body is "
                "supported"
            )
        if not joints:
            return None
        joint = joints[0]
        kind = int(model.jnt_type[joint])
        name = self.name(mj.mjtObj.mjOBJ_JOINT, joint, "joint")
        if kind == mj.mjtJoint.mjJNT_BALL:
            raise self.fail(f"ball joint '{name}': not supported (hinge, slide, free root)")
        if kind == mj.mjtJoint.mjJNT_FREE:
            raise self.fail(f"free joint '{name}' below the root: not supported")
        dof = int(model.jnt_dofadr[joint])
        for values, what in (
            (model.dof_damping, "damping"),
            (model.dof_armature, "armature"),
            (model.dof_frictionloss, "frictionloss"),
            (model.jnt_stiffness, "stiffness"),
        ):
            if float(values[joint if what == "stiffness" else dof]) != 0.0:
                self.grouped.setdefault(f"joint {what}", []).append(name)
        return joint

    # -- writing -----------------------------------------------------------------------------------
    def write(self) -> MjcfVehicle:
        model = self.model
        gravity = np.asarray(model.opt.gravity, dtype=float)
        if gravity[0] != 0.0 or gravity[1] != 0.0 or gravity[2] > 0.0:
            raise self.fail(f"gravity {format_numbers(gravity)} is not along -z: not supported")
        density, viscosity = float(model.opt.density), float(model.opt.viscosity)
        if np.any(np.asarray(model.opt.wind) != 0.0):
            self.drop(
                f"wind {format_numbers(model.opt.wind)} m/s: give it as the scenario's current"
            )
        root = self.root()
        bodies = self.subtree(root)
        if self.fixed_base:  # MuJoCo's world body is the URDF's massless root link `world`
            bodies = [0, *bodies]
        name = bytes(model.names).split(b"\0", 1)[0].decode()
        try:
            check_name(name, "robot")
        except VehicleLoadError:  # MuJoCo's default "MuJoCo Model" has a space
            name = self.path.stem
        robot = Element("robot", {"name": str(name)})
        shift: dict[int, np.ndarray] = {}
        links: list[LinkHydrodynamics] = []
        for body in bodies:
            if body == 0:
                shift[0] = np.zeros(3)
                SubElement(robot, "link", {"name": self.body_name(0)})
                continue
            joint = self.joint_of(body) if body != root or self.fixed_base else None
            shift[body] = np.zeros(3) if joint is None else np.array(model.jnt_pos[joint])
            link = SubElement(robot, "link", {"name": self.body_name(body)})
            self.inertial(link, body, shift[body])
            self.shapes(link, body, shift[body])
            hydro = self.hydrodynamics(body, shift[body], density, viscosity)
            if hydro is not None:
                links.append(hydro)
            if body != root or self.fixed_base:
                self.joint(robot, body, joint, shift)
        block = SubElement(
            robot,
            "hydrodynamics",
            {
                "fluid_density": format_number(density if density > 0.0 else DENSITY_WITHOUT_FLUID),
                "gravity": format_number(-gravity[2]),
            },
        )
        for hydro in links:
            block.append(fossen_link_element(hydro))
        for element in self.thrusters(set(bodies), shift):
            block.append(element)
        for what, names in self.grouped.items():
            self.drop(f"{GROUPED_DROPS[what]}: {_some(names)}")
        indent(robot, space="  ")
        for line in self.dropped:
            warnings.warn(MjcfDroppedWarning(f"{self.path}: {line}"), stacklevel=4)
        return MjcfVehicle(
            tostring(robot, encoding="unicode") + "\n", tuple(self.dropped), self.fixed_base
        )

    def inertial(self, link: Element, body: int, shift: np.ndarray) -> None:
        model = self.model
        mass = float(model.body_mass[body])
        if mass == 0.0:
            return
        rotation = _rotation(model.body_iquat[body])
        inertia = rotation @ np.diag(np.asarray(model.body_inertia[body], dtype=float)) @ rotation.T
        element = SubElement(link, "inertial")
        _origin(element, np.asarray(model.body_ipos[body]) - shift, np.eye(3))
        SubElement(element, "mass", {"value": format_number(mass)})
        SubElement(
            element,
            "inertia",
            {
                key: format_number(inertia[i, j])
                for key, (i, j) in {
                    "ixx": (0, 0),
                    "ixy": (0, 1),
                    "ixz": (0, 2),
                    "iyy": (1, 1),
                    "iyz": (1, 2),
                    "izz": (2, 2),
                }.items()
            },
        )

    def geom_kind(self, geom: int) -> str:
        return self.mujoco.mjtGeom(int(self.model.geom_type[geom])).name[len("mjGEOM_") :].lower()

    def geoms(self, body: int) -> range:
        start = int(self.model.body_geomadr[body])
        return range(start, start + int(self.model.body_geomnum[body]))

    def in_fluid(self, geom: int) -> bool:
        """A geom of MuJoCo's ellipsoid model with a non-zero coefficient."""
        fluid = self.model.geom_fluid[geom]
        return bool(fluid[0] > 0.0 and np.any(fluid[1:6] != 0.0))

    def shapes(self, link: Element, body: int, shift: np.ndarray) -> None:
        model = self.model
        for geom in self.geoms(body):
            kind = self.geom_kind(geom)
            if kind not in URDF_PRIMITIVES:
                continue
            size = urdf_shape_size(kind, model.geom_size[geom])
            if min(size) < MIN_SHAPE_SIZE:
                continue
            tags = ("visual", "collision") if self.in_fluid(geom) else ("visual",)
            for tag in tags:
                element = SubElement(link, tag)
                _origin(
                    element,
                    np.asarray(model.geom_pos[geom]) - shift,
                    _rotation(model.geom_quat[geom]),
                )
                geometry = SubElement(element, "geometry")
                if kind == "box":
                    SubElement(geometry, "box", {"size": format_numbers(size)})
                elif kind == "cylinder":
                    SubElement(
                        geometry,
                        "cylinder",
                        {"radius": format_number(size[0]), "length": format_number(size[1])},
                    )
                else:
                    SubElement(geometry, "sphere", {"radius": format_number(size[0])})

    def hydrodynamics(
        self, body: int, shift: np.ndarray, density: float, viscosity: float
    ) -> LinkHydrodynamics | None:
        # imported here: the ellipsoid's scipy.special costs every load_vehicle ~0.2 s otherwise
        from aiauv_hydro.estimate.ellipsoid import Ellipsoid
        from aiauv_hydro.estimate.mujoco_fluid import (
            FluidEllipsoid,
            buoyant_volume,
            fluid_ellipsoid_hydrodynamics,
            geom_semi_axes,
            inertia_box_hydrodynamics,
        )

        model, mj = self.model, self.mujoco
        mass = float(model.body_mass[body])
        name = self.body_name(body)
        volume, centre = 0.0, np.asarray(model.body_ipos[body]) - shift
        gravcomp = float(model.body_gravcomp[body])
        if gravcomp < 0.0:
            raise self.fail(f"body '{name}': gravcomp {gravcomp:g} < 0 is no buoyancy")
        if gravcomp > 0.0:
            volume = buoyant_volume(
                gravcomp, mass, density if density > 0.0 else DENSITY_WITHOUT_FLUID
            )
        parts = []
        if (density > 0.0 or viscosity > 0.0) and mass >= MUJOCO_MIN_VALUE:
            fluid_geoms = [g for g in self.geoms(body) if model.geom_fluid[g][0] > 0.0]
            for geom in fluid_geoms:
                coefficients = tuple(float(c) for c in model.geom_fluid[geom][1:6])
                if not any(coefficients):
                    continue  # the export's marker of a link without hydrodynamics
                ellipsoid = Ellipsoid(
                    geom_semi_axes(self.geom_kind(geom), model.geom_size[geom]),
                    _rotation(model.geom_quat[geom]),
                    np.asarray(model.geom_pos[geom], dtype=float) - shift,
                )
                parts.append(
                    fluid_ellipsoid_hydrodynamics(
                        FluidEllipsoid(ellipsoid, coefficients), density, viscosity
                    )
                )
                if density > 0.0 and any(coefficients[3:]):
                    geom_name = self.name(mj.mjtObj.mjOBJ_GEOM, geom, "geom")
                    self.grouped.setdefault("lift", []).append(geom_name)
            if not fluid_geoms:
                parts.append(
                    inertia_box_hydrodynamics(
                        mass,
                        model.body_inertia[body],
                        _rotation(model.body_iquat[body]),
                        centre,
                        density,
                        viscosity,
                    )
                )
        if not parts and volume == 0.0:
            return None
        try:
            return LinkHydrodynamics(
                link=name,
                model="fossen",
                volume=volume,
                center_of_buoyancy=centre,
                added_mass=sum((p.added_mass for p in parts), np.zeros((6, 6))),
                linear_damping=sum((p.linear_damping for p in parts), np.zeros((6, 6))),
                quadratic_damping=sum(
                    (np.diag(p.quadratic_damping) for p in parts), np.zeros((6, 6))
                ),
            )
        except HydroError as exc:
            raise self.fail(str(exc)) from None

    def joint(self, robot: Element, body: int, joint: int | None, shift: dict) -> None:
        model, mj = self.model, self.mujoco
        parent = int(model.body_parentid[body])
        rotation = _rotation(model.body_quat[body])
        # child link frame in the parent link frame: undo the parent's shift, body pose, shift
        xyz = np.asarray(model.body_pos[body]) - shift[parent] + rotation @ shift[body]
        if joint is None:
            kind, name = "fixed", f"{self.body_name(body)}_weld"
        else:
            hinge = int(model.jnt_type[joint]) == mj.mjtJoint.mjJNT_HINGE
            kind = "revolute" if hinge else "prismatic"
            name = self.name(mj.mjtObj.mjOBJ_JOINT, joint, "joint")
        element = SubElement(robot, "joint", {"name": name, "type": kind})
        SubElement(element, "parent", {"link": self.body_name(parent)})
        SubElement(element, "child", {"link": self.body_name(body)})
        _origin(element, xyz, rotation)
        if joint is None:
            return
        SubElement(element, "axis", {"xyz": format_numbers(model.jnt_axis[joint])})
        if bool(model.jnt_limited[joint]):
            lower, upper = (float(v) for v in model.jnt_range[joint])
        else:
            bound = UNLIMITED_HINGE if kind == "revolute" else UNLIMITED_SLIDE
            lower, upper = -bound, bound
        effort = UNLIMITED_EFFORT
        if bool(model.jnt_actfrclimited[joint]):
            effort = float(np.max(np.abs(model.jnt_actfrcrange[joint])))
        SubElement(
            element,
            "limit",
            {
                "lower": format_number(lower),
                "upper": format_number(upper),
                "effort": format_number(effort),
                "velocity": format_number(UNLIMITED_VELOCITY),
            },
        )

    def thrusters(self, bodies: set[int], shift: dict) -> list[Element]:
        model, mj = self.model, self.mujoco
        found = []
        for actuator in range(model.nu):
            name = self.name(mj.mjtObj.mjOBJ_ACTUATOR, actuator, "actuator")
            transmission = int(model.actuator_trntype[actuator])
            if transmission in (mj.mjtTrn.mjTRN_JOINT, mj.mjtTrn.mjTRN_JOINTINPARENT):
                self.grouped.setdefault("joint actuator", []).append(name)
                continue
            if transmission != mj.mjtTrn.mjTRN_SITE:
                kind = mj.mjtTrn(transmission).name[len("mjTRN_") :].lower()
                raise self.fail(f"actuator '{name}' acts through a {kind}: not a thruster")
            site = int(model.actuator_trnid[actuator][0])
            if int(model.actuator_trnid[actuator][1]) != -1:
                raise self.fail(f"actuator '{name}' has a refsite: not a thruster")
            gear = np.asarray(model.actuator_gear[actuator], dtype=float)
            if np.any(gear[3:] != 0.0):
                raise self.fail(f"actuator '{name}' has a torque gear: not a thruster")
            if int(model.actuator_dyntype[actuator]) != mj.mjtDyn.mjDYN_NONE:
                raise self.fail(f"actuator '{name}' has activation dynamics: not supported")
            gain = float(model.actuator_gainprm[actuator][0])
            if int(model.actuator_gaintype[actuator]) != mj.mjtGain.mjGAIN_FIXED or np.any(
                model.actuator_biasprm[actuator] != 0.0
            ):
                raise self.fail(
                    f"actuator '{name}' is not a force proportional to its control "
                    "(gain not fixed, or a bias): not a thruster"
                )
            body = int(model.site_bodyid[site])
            if body not in bodies:
                raise self.fail(f"actuator '{name}' acts on a body outside the vehicle")
            # force = gain ctrl (clamped to forcerange) along gear; thrust [N] = |gear| force
            strength = float(np.linalg.norm(gear[:3]))
            if strength == 0.0 or gain == 0.0:
                raise self.fail(f"actuator '{name}' has a zero gear or gain: not a thruster")
            limits = [math.inf]
            if bool(model.actuator_ctrllimited[actuator]):
                limits.append(abs(gain) * float(np.max(np.abs(model.actuator_ctrlrange[actuator]))))
                if model.actuator_ctrlrange[actuator][0] != -model.actuator_ctrlrange[actuator][1]:
                    self.grouped.setdefault("asymmetric", []).append(name)
            if bool(model.actuator_forcelimited[actuator]):
                limits.append(float(np.max(np.abs(model.actuator_forcerange[actuator]))))
            if min(limits) == math.inf:
                raise self.fail(
                    f"actuator '{name}' has neither ctrlrange nor forcerange: no thrust limit"
                )
            direction = _rotation(model.site_quat[site]) @ gear[:3] * math.copysign(1.0, gain)
            position = np.asarray(model.site_pos[site]) - shift[body]
            found.append(
                Element(
                    "thruster",
                    {
                        "name": name,
                        "link": self.body_name(body),
                        "xyz": format_numbers(position),
                        "direction": format_numbers(direction / strength),
                        "max_thrust": format_number(strength * min(limits)),
                    },
                )
            )
        return found


def read_mjcf(path: str | os.PathLike) -> MjcfVehicle:
    """The URDF of an MJCF vehicle (see the module docstring).

    Args:
        path: The ``.xml`` file (relative ``<include>`` and asset files resolve from its folder).

    Raises:
        VehicleLoadError: One line: MuJoCo missing or refusing the file, or what we cannot carry.
    """
    return _Reader(Path(path)).write()
