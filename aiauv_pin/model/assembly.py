"""The one builder of what a vehicle evaluates, from its description (a Pinocchio model and its
:class:`~aiauv_hydro.spec.HydroSpec`).

:func:`assemble` packs the description once into an :class:`Assembly`: the per-body and per-link
fluid records of :mod:`aiauv_hydro.laws.fluid_terms` (with and without the hydrostatics), the
thrusters as unit-thrust wrenches, the fins in their bodies' frames, and the displaced-water model
of the Pinocchio reference.
:func:`compiled_model` builds the compiled model (:class:`aiauv_pin.kernels.evaluation.FastModel`)
from the same Pinocchio model and assembly. Neither reads a :class:`aiauv_pin.model.vehicle.Vehicle`:
the vehicle holds what they build (``Vehicle.fast`` is :func:`compiled_model`'s result), so both
backends describe one set of equations and neither is built from the other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from aiauv_hydro.laws.crossflow import gauss_legendre_unit
from aiauv_hydro.laws.fluid_terms import CROSSFLOW_NODES, FluidModel
from aiauv_hydro.laws.lift import FinModel, no_fins
from aiauv_hydro.numerics.spatial import motion_transform
from aiauv_hydro.spec import HydroSpec
from aiauv_pin.kernels.records import Model, Thrusters, rigid_bodies, unsupported_reason


@dataclass(frozen=True)
class Assembly:
    """What :func:`assemble` packs of a description.

    Attributes:
        fluid_net: Fluid records with the hydrostatics (buoyancy minus weight), what the compiled
            kernels take.
        fluid_reference: The same without hydrostatics: the Pinocchio reference computes them with
            Pinocchio (:attr:`buoyancy_model`).
        thrusters: The thrusters as unit-thrust wrenches on bodies.
        fins: The fins in their bodies' frames (:func:`aiauv_hydro.laws.lift.add_fin_wrenches`
            takes them; on whatever the ``added_mass``, ``damping`` and ``restoring`` switches).
        buoyancy_model: A copy of the model carrying each body's displaced mass ``rho V`` at its
            centre of buoyancy (Fossen 2021, eq. (4.6)), for the reference's buoyancy.
        has_buoyancy: Whether any link displaces water.
        has_fluid: Whether any added mass or damped link is on.
        inertia_in_body: Rigid plus added inertia per body (nb, 6, 6), for the momentum.
        fixed_base: The root body is locked to the world (base velocity and acceleration zero).
    """

    fluid_net: FluidModel
    fluid_reference: FluidModel
    thrusters: Thrusters
    fins: FinModel
    buoyancy_model: pin.Model
    has_buoyancy: bool
    has_fluid: bool
    inertia_in_body: np.ndarray
    fixed_base: bool = False


def link_placement(model: pin.Model, link: str) -> tuple[int, pin.SE3]:
    """The Pinocchio joint carrying ``link`` (a body frame), and the link's placement in it."""
    frame_id = model.getFrameId(link, pin.FrameType.BODY)
    if frame_id >= len(model.frames):
        raise ValueError(f"unknown link '{link}'")
    frame = model.frames[frame_id]
    return int(frame.parentJoint), frame.placement


def body_of(model: pin.Model, link: str) -> tuple[int, pin.SE3]:
    """Index of the body (Pinocchio joint - 1) that carries ``link``, and its placement there."""
    joint, placement = link_placement(model, link)
    if joint < 1:
        raise ValueError(f"link '{link}' is fixed to the world, not to the vehicle")
    return joint - 1, placement


def assemble(
    model: pin.Model,
    hydro: HydroSpec,
    *,
    added_mass: bool,
    damping: bool,
    restoring: bool,
    fixed_base: bool = False,
) -> Assembly:
    """Pack a description once (see :class:`Assembly`).

    Args:
        model: The Pinocchio model, its gravity already set.
        hydro: The hydrodynamic parameters.
        added_mass, damping, restoring: Which fluid effects are on.
        fixed_base: The root body is locked to the world.
    """
    nb = model.njoints - 1
    gravity = hydro.gravity if restoring else 0.0
    rho = hydro.fluid_density
    added = np.zeros((nb, 6, 6))
    buoyancy = np.zeros((nb, 4))  # (B, B c_B) per body [N, N m]
    displaced = np.zeros((nb, 4))  # (rho V, rho V c_B) per body [kg, kg m]
    probe_moment = np.zeros((nb, 3))
    probe_volume = np.zeros(nb)
    link_body, link_from_body = [], []
    for link in hydro.links:
        b, placement = body_of(model, link.link)
        x = motion_transform(placement.rotation, placement.translation)  # nu_link = X nu_body
        link_body.append(b)
        link_from_body.append(x)
        if added_mass:
            added[b] += x.T @ link.added_mass @ x  # M_A moves as X^T M_A X
        if link.volume > 0.0:
            centre = placement.act(np.asarray(link.center_of_buoyancy, dtype=float))
            force = rho * link.volume * gravity  # Archimedes (Fossen 2021, eq. (4.5))
            buoyancy[b, 0] += force
            buoyancy[b, 1:] += force * centre
            probe_moment[b] += link.volume * centre
            displaced[b, 0] += rho * link.volume
            displaced[b, 1:] += rho * link.volume * centre
            probe_volume[b] += link.volume
    weight = np.zeros((nb, 4))  # (W, W c_G) per body
    for b in range(nb):
        inertia = model.inertias[b + 1]
        weight[b, 0] = inertia.mass * gravity
        weight[b, 1:] = inertia.mass * gravity * inertia.lever
    probe = np.zeros((nb, 3))
    has_volume = probe_volume > 0.0
    probe[has_volume] = probe_moment[has_volume] / probe_volume[has_volume, None]
    links = hydro.links if damping else ()
    nl = len(links)
    identity = np.eye(6)
    linear = np.array([link.linear_damping for link in links]).reshape(nl, 6, 6)
    quadratic = np.array([link.quadratic_damping for link in links]).reshape(nl, 6, 6)
    forward = np.array([link.forward_speed_damping for link in links]).reshape(nl, 6, 6)
    cylinder = np.tile(identity, (nl, 1, 1))
    length = np.zeros(nl)
    strip = np.zeros(nl)
    axial, roll = np.zeros(nl), np.zeros(nl)  # cylinder-frame axial / roll drag (off-axis)
    has_crossflow = np.zeros(nl, dtype=np.int64)
    for k, link in enumerate(links):
        if link.crossflow:
            c = link.crossflow
            cylinder[k] = motion_transform(c.rotation, c.translation)
            length[k], strip[k] = c.length, c.strip_coefficient
            axial[k], roll[k] = c.axial_coefficient, c.roll_coefficient
            has_crossflow[k] = 1
    link_from = np.array(link_from_body[:nl]).reshape(nl, 6, 6)
    nodes, weights = gauss_legendre_unit(CROSSFLOW_NODES)

    def pack(hydrostatics: np.ndarray) -> FluidModel:
        return FluidModel(
            added_mass=np.ascontiguousarray(added),
            hydrostatics=np.ascontiguousarray(hydrostatics),
            current_probe=probe,
            displaced=np.ascontiguousarray(displaced),
            link_body=np.array(link_body[:nl], dtype=np.int64),
            link_from_body=np.ascontiguousarray(link_from),
            link_is_body=np.array([np.array_equal(x, identity) for x in link_from], dtype=np.int64),
            linear_damping=np.ascontiguousarray(linear),
            quadratic_damping=np.ascontiguousarray(quadratic),
            quadratic_is_diagonal=np.array(
                [np.count_nonzero(d - np.diag(np.diag(d))) == 0 for d in quadratic],
                dtype=np.int64,
            ),
            forward_speed_damping=np.ascontiguousarray(forward),
            has_forward_speed_damping=np.array([np.any(d != 0.0) for d in forward], dtype=np.int64),
            has_crossflow=has_crossflow,
            cylinder_from_link=np.ascontiguousarray(cylinder),
            cylinder_is_link=np.array(
                [np.array_equal(x, identity) for x in cylinder], dtype=np.int64
            ),
            cylinder_length=length,
            strip_coefficient=strip,
            axial_coefficient=axial,
            roll_coefficient=roll,
            gauss_nodes=np.ascontiguousarray(nodes),
            gauss_weights=np.ascontiguousarray(weights),
        )

    # The kernels take weight and buoyancy through
    # aiauv_hydro.laws.fluid_terms.hydrostatic_wrench. The Pinocchio
    # reference computes both independently, as Pinocchio's generalised gravity of the rigid
    # model and of a copy carrying each body's displaced mass rho V at its centre of buoyancy
    # (Fossen 2021, eq. (4.6)), so its fluid model has no hydrostatics.
    return Assembly(
        fluid_net=pack(buoyancy - weight),
        fluid_reference=pack(np.zeros((nb, 4))),
        thrusters=_thrusters(model, hydro),
        fins=_fins(model, hydro),
        buoyancy_model=_buoyancy_model(model, hydro),
        has_buoyancy=any(link.volume != 0.0 for link in hydro.links),
        has_fluid=bool(added.any() or nl),
        # generalised inertia per Pinocchio body (rigid plus added), for the momentum
        inertia_in_body=np.array([model.inertias[b + 1].matrix() for b in range(nb)]) + added,
        fixed_base=bool(fixed_base),
    )


def _buoyancy_model(model: pin.Model, hydro: HydroSpec) -> pin.Model:
    """A copy of ``model`` whose bodies carry only their displaced water (``rho V`` at the centre
    of buoyancy), with ``model``'s gravity: its generalised gravity is the buoyancy."""
    buoyancy_model = pin.Model(model)
    for joint in range(model.njoints):
        buoyancy_model.inertias[joint] = pin.Inertia.Zero()
    rho = hydro.fluid_density
    for link in hydro.links:
        if link.volume == 0.0:
            continue
        joint, placement = link_placement(model, link.link)
        displaced = pin.Inertia(
            rho * link.volume, placement.act(link.center_of_buoyancy), np.zeros((3, 3))
        )
        buoyancy_model.inertias[joint] = buoyancy_model.inertias[joint] + displaced
    buoyancy_model.gravity = model.gravity
    return buoyancy_model


def _thrusters(model: pin.Model, hydro: HydroSpec) -> Thrusters:
    """The thrusters as wrenches of 1 N of thrust about their body's origin, in its axes."""
    body, wrenches = [], []
    for thruster in hydro.thrusters:
        b, placement = body_of(model, thruster.link)
        direction = placement.rotation @ thruster.direction
        position = placement.act(thruster.position)
        body.append(b)
        wrenches.append(np.concatenate((direction, np.cross(position, direction))))
    thrusters = hydro.thrusters
    return Thrusters(
        body=np.array(body, dtype=np.int64),
        unit_wrench=np.array(wrenches).reshape(-1, 6),
        max_thrust=np.array([t.max_thrust for t in thrusters], dtype=float),
        time_constant=np.array([t.time_constant for t in thrusters], dtype=float),
        max_rate=np.array([t.max_rate for t in thrusters], dtype=float),
        dynamic=any(t.time_constant > 0.0 or t.max_rate != np.inf for t in thrusters),
    )


def _fins(model: pin.Model, hydro: HydroSpec) -> FinModel:
    """The fins with their centre of pressure, span axis and chord in their body's frame."""
    if not hydro.fins:
        return no_fins()
    body, position, axis, chord = [], [], [], []
    for fin in hydro.fins:
        b, placement = body_of(model, fin.link)
        body.append(b)
        position.append(placement.act(fin.position))
        axis.append(placement.rotation @ fin.axis)
        chord.append(placement.rotation @ fin.chord)
    rho = hydro.fluid_density

    def column(name: str) -> np.ndarray:
        return np.array([float(getattr(fin, name)) for fin in hydro.fins])

    return FinModel(
        body=np.array(body, dtype=np.int64),
        position=np.ascontiguousarray(position, dtype=float),
        axis=np.ascontiguousarray(axis, dtype=float),
        chord=np.ascontiguousarray(chord, dtype=float),
        half_rho_area=0.5 * rho * column("area"),
        lift_slope=column("lift_slope"),
        drag_zero=column("drag_zero"),
        drag_slope=column("drag_slope"),
        stall_angle=column("stall_angle"),
        max_angle=column("max_angle"),
        max_rate=column("max_rate"),
        time_constant=column("time_constant"),
    )


def packed_records(model: pin.Model, assembly: Assembly) -> Model:
    """The vehicle as the flat records of :mod:`aiauv_pin.kernels.articulated_body`: rigid data from
    the Pinocchio model (joint placements, axes and inertias), fluid data and thrusters from the
    assembly.

    Raises:
        ValueError: A joint the kernels do not support (see
            :func:`aiauv_pin.kernels.records.unsupported_reason`).
    """
    reason = unsupported_reason(model)
    if reason is not None:
        raise ValueError(f"fast backend: {reason}")
    fluid = assembly.fluid_net
    return Model(
        bodies=rigid_bodies(model, fluid.added_mass, assembly.fixed_base),
        fluid=fluid,
        thrusters=assembly.thrusters,
        fins=assembly.fins,
    )


def frame_records(model: pin.Model) -> tuple[tuple[int, np.ndarray, np.ndarray], ...]:
    """``(body, rotation, translation)`` of every Pinocchio frame, by frame index: the body
    (Pinocchio joint - 1) carrying it and its placement there, as the kernels take a frame."""
    return tuple(
        (
            int(frame.parentJoint) - 1,
            np.ascontiguousarray(frame.placement.rotation),
            np.ascontiguousarray(frame.placement.translation),
        )
        for frame in model.frames
    )


def compiled_model(model: pin.Model, assembly: Assembly, records: Model | None = None):
    """The compiled model (:class:`aiauv_pin.kernels.evaluation.FastModel`) of a description.

    Args:
        model: The Pinocchio model.
        assembly: Its :func:`assemble` result.
        records: Its :func:`packed_records` when already made.

    Raises:
        ImportError: numba is not installed (or cannot be imported).
        ValueError: The model is not supported (:func:`packed_records`).
    """
    from aiauv_pin.kernels import load_fast_model

    fast_model = load_fast_model()
    if records is None:
        records = packed_records(model, assembly)
    return fast_model(records, model.nq, model.nv, frame_records(model))
