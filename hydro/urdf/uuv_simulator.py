"""Reader of UUV Simulator per-link hydrodynamic blocks, converted to this package's conventions.

UUV Simulator (github.com/uuvsimulator/uuv_simulator, Apache-2.0) describes a vehicle's
hydrodynamics inside ``<gazebo><plugin filename="libunderwater_object_ros_plugin.so">``::

    <fluid_density>1028.0</fluid_density>
    <link name="rexrov/base_link">          <!-- the URDF link name, namespace prefix included -->
      <neutrally_buoyant>0</neutrally_buoyant>
      <volume>1.83826</volume>
      <center_of_buoyancy>0 0 0.3</center_of_buoyancy>
      <hydrodynamic_model>
        <type>fossen</type>
        <added_mass>36 numbers</added_mass>
        <linear_damping>6 or 36 numbers</linear_damping>
        <quadratic_damping>6 or 36 numbers</quadratic_damping>
      </hydrodynamic_model>
    </link>

What UUV Simulator's source does with them (uuv_gazebo_plugins ``HydrodynamicModel.cc``,
``BuoyantObject.cc``, ``UnderwaterObjectPlugin.cc``, checked for this module):

* ``HMFossen::ApplyHydrodynamicForces`` flips the link's (forward-left-up) velocity to the SNAME
  forward-right-down axes (``ToNEDConvention``: y and z of both the linear and angular parts change
  sign), evaluates ``tau = -M_A nu_dot - C_A(nu) nu - D(nu) nu`` there and flips the wrench back.
  So ``added_mass`` and the damping are in FRD axes about the link origin. With
  ``T = diag(1, -1, -1, 1, -1, -1)`` (``T = T^-1 = T^T``) our link-frame matrices are ``T M T``.
  (Early releases, before ``ToNEDConvention`` was added, used the Gazebo axes directly; the vehicle
  descriptions shipped with the current code, e.g. RexROV's SNAME data from Berg 2012, are FRD.)
* ``ComputeDampingMatrix`` builds ``D = -DLin - u DLinForwardSpeed - diag(DNonLin_ii |nu_i|)`` and
  applies ``-D nu``: the coefficients are hydrodynamic derivatives (``X_u``, ``X_|u|u``, ...),
  negative for a dissipative body. Ours (wrench ``-D nu``, positive = dissipative) are
  ``D_L = -T DLin T`` and ``D_Q = -diag(DNonLin)`` (only the diagonal of a 36-number quadratic
  damping is used, as UUV Simulator does; ``T`` leaves diagonals unchanged). Converted damping
  with a negative diagonal entry (a positive coefficient in the file, which would feed energy into
  the vehicle) is refused.
* ``center_of_buoyancy`` is NOT flipped: ``BuoyantObject::ApplyBuoyancyForce`` applies the buoyancy
  with ``AddForceAtRelativePosition(force, CoB)``, i.e. the CoB is in the Gazebo link frame, which
  is already forward-left-up (RexROV gives ``0 0 0.3``, above its centre of gravity).
* ``neutrally_buoyant`` true sets ``volume = link mass / fluid density``; we take the mass from the
  link's URDF ``<inertial>`` and use the vehicle's final fluid density.
* Link names are looked up verbatim (``model->GetLink(name)``); the vehicle descriptions use
  ``${namespace}/base_link``, so the expanded names carry the namespace prefix
  (``rexrov/base_link``), exactly as the URDF ``<link>`` names do. We match them verbatim too.
* ``fluid_density`` defaults to 1028 kg/m^3 when a plugin omits it.

Geometric models (``<type>`` ``sphere``, ``cylinder``, ``spheroid``, ``box``) are computed as the
plugin computes them (:func:`geometric_model`, with the deviations documented there).

Thrusters (``<gazebo><plugin filename="libuuv_thruster_ros_plugin.so">``, ThrusterPlugin.cc):
``linkName`` is the link the force acts on, along the axis of ``jointName`` (the joint's URDF
``<axis>``, expressed in the child link, i.e. the thruster link), at the link's centre of mass
(Gazebo's ``AddRelativeForce``). The steady-state thrust for a command ``x`` is
``thrust_efficiency * f(propeller_efficiency * gain * clamp(x, clampMin, clampMax))`` limited to
``[thrustMin, thrustMax]``, with ``f`` the conversion function (``Basic``: ``k x |x|``; ``Bessa``:
dead zone; ``LinearInterp``: table); our ``max_thrust`` is its value at ``clampMax`` (or
``thrustMax``), see :func:`uuv_thrusters`. The thruster's ``<dynamics>`` (Dynamics.cc) act on the
rotor command before the conversion: ``ZeroOrder`` becomes ``time_constant = 0`` and ``FirstOrder``
its ``timeConstant`` as our first-order lag of the thrust: exact for a linear conversion; for
``Basic``, ``T = k w |w|`` with ``tau w' = w_c - w`` gives ``tau T' = 2 k |w| (w_c - w) = (T_c - T) +
O((w_c - w)^2)`` near a steady state ``w_c != 0`` (the same time constant for small steps; a step
from rest is slower at first in UUV Simulator). The nonlinear ``Yoerger`` and ``Bessa`` rotor models
are read as zero order with a warning.

Fins (``<gazebo><plugin filename="libuuv_fin_ros_plugin.so">``, FinPlugin.cc) become our fins
(:func:`uuv_fins`) on the plugin's ``link_name``, at that link's centre of mass, span axis ``z`` and
chord ``x`` of that link (the plugin's lift-drag plane is normal to the link's z axis; its lift
direction is ``-z x v`` and its angle ``atan2(v_y, v_x)``, :mod:`aiauv_hydro.laws.lift`). The
``Quadratic`` lift-drag model's ``lift_constant`` and ``drag_constant`` are ``0.5 rho A C`` products:
they are carried with ``area = 1`` m^2 and ``lift_slope = 2 lift_constant / rho``, ``drag_slope = 2
drag_constant / rho`` (``rho`` our fluid density), so that the forces are the plugin's exactly;
``drag_zero = 0``, no stall. ``max_angle`` is the fin joint's limit (the plugin clips the command to
it), ``time_constant`` the ``FirstOrder`` dynamics' ``timeConstant``. ``TwoLines`` (drag linear in
the angle) has no form here and is left out with a warning.
The propeller joint (continuous) is made fixed for the
dynamics (:func:`freeze_thruster_joints`): UUV Simulator drives its speed kinematically and its
link is a placeholder of 1 g.

``linear_damping_forward_speed`` becomes our surge-proportional damping ``-u_r D_F nu_r``
(:func:`convert_forward_speed_damping`, :func:`aiauv_hydro.laws.fluid_terms.forward_speed_damping_wrench`).
Not representable here and therefore reported by a warning: off-diagonal quadratic damping (ignored
by UUV Simulator as well) and surface-vessel (metacentric) parameters. UUV Simulator applies the
hydrodynamic wrench with Gazebo's ``AddRelativeForce``, i.e. at the link's centre of mass; we read
the parameters as given about the link origin (as its velocities are), so a warning is issued when
the link's inertial origin is offset from it. A slightly asymmetric added mass (as RexROV's, 10.774
vs 10.775) is symmetrised with a warning; an asymmetry above 1e-3 of its norm is refused. A missing
``center_of_buoyancy`` is computed as UUV Simulator does (volume-weighted centroid of the collision
shapes) when all collision shapes are boxes, cylinders or spheres, and refused otherwise.
"""

from __future__ import annotations

import math
import os
import warnings
from xml.etree.ElementTree import Element

import numpy as np

from aiauv_hydro.numerics.spatial import motion_transform
from aiauv_hydro.spec import Fin, HydroError, HydroSpec, LinkHydrodynamics, Thruster
from aiauv_hydro.urdf.xml_reading import (
    DEFAULT_GRAVITY,
    MATRIX_TOLERANCE,
    UrdfLink,
    check_added_mass,
    parse_bool,
    parse_numbers,
    parse_robot,
    parse_scalar,
    parse_vector,
    robot_links,
)

#: UUV Simulator's default fluid density (BuoyantObject / UnderwaterObjectPlugin) [kg/m^3].
UUV_DEFAULT_FLUID_DENSITY = 1028.0
#: Velocity/wrench axis flip between FRD (SNAME) and FLU link axes; its own inverse.
FRD_TO_FLU = np.diag([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])
#: Largest added-mass asymmetry (relative to its 2-norm) that is symmetrised with a warning.
MAX_SYMMETRISED_ASYMMETRY = 1e-3


def _is_hydro_plugin(plugin: Element) -> bool:
    if "underwater_object" in plugin.get("filename", ""):
        return True
    return any(link.find("hydrodynamic_model") is not None for link in plugin.findall("link"))


def uuv_plugins(root: Element) -> list[Element]:
    """The UUV Simulator underwater-object plugin elements of a ``<robot>``."""
    return [plugin for plugin in root.findall("gazebo/plugin") if _is_hydro_plugin(plugin)]


def uuv_fluid_density(root: Element) -> float | None:
    """Fluid density of the UUV Simulator plugins (1028 if omitted); ``None`` without plugins."""
    densities = set()
    for plugin in uuv_plugins(root):
        if not plugin.findall("link"):
            continue
        element = plugin.find("fluid_density")
        if element is None:
            densities.add(UUV_DEFAULT_FLUID_DENSITY)
        else:
            densities.add(parse_scalar(element.text, "UUV Simulator plugin fluid_density"))
    if not densities:
        return None
    if len(densities) > 1:
        raise HydroError(f"UUV Simulator plugins disagree on fluid_density: {sorted(densities)}")
    density = densities.pop()
    if not density > 0.0:
        raise HydroError(f"UUV Simulator fluid_density must be positive, got {density}")
    return density


def convert_fossen_matrices(
    added_mass: np.ndarray,
    linear_damping: np.ndarray,
    quadratic_damping: np.ndarray,
    what: str = "UUV Simulator link",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """UUV Simulator (FRD axes, negative damping) matrices to ours (FLU axes, positive damping).

    Args:
        added_mass: ``M_A`` as given (6x6, FRD); symmetrised with a warning if slightly asymmetric.
        linear_damping: ``DLin`` as given (6x6, FRD, negative = dissipative).
        quadratic_damping: ``DNonLin`` as given (6x6, FRD); only its diagonal is used.
        what: Name used in messages.

    Returns:
        ``(M_A, D_L, D_Q)`` in the link's FLU axes with ``M_A = T M T``, ``D_L = -T DLin T`` and
        ``D_Q = -diag(DNonLin)``, ``T = diag(1, -1, -1, 1, -1, -1)``.
    """
    added_mass = np.array(added_mass, dtype=float)
    scale = float(np.linalg.norm(added_mass, 2))
    asymmetry = float(np.max(np.abs(added_mass - added_mass.T)))
    if asymmetry > MATRIX_TOLERANCE * scale:
        if asymmetry > MAX_SYMMETRISED_ASYMMETRY * scale:
            raise HydroError(
                f"{what} added_mass is not symmetric (largest difference {asymmetry:.6g})"
            )
        warnings.warn(
            f"{what} added_mass is slightly asymmetric (largest difference {asymmetry:.6g}); "
            "using (M + M^T) / 2",
            stacklevel=3,
        )
        added_mass = 0.5 * (added_mass + added_mass.T)
    # M_ours = T M_frd T: nu_frd = T nu_flu and wrench_flu = T wrench_frd.
    added_mass = FRD_TO_FLU @ added_mass @ FRD_TO_FLU
    check_added_mass(added_mass, f"{what} added_mass")

    # UUV Simulator's damping wrench is +DLin nu (D = -DLin, tau = -D nu); ours is -D_L nu.
    linear = -(FRD_TO_FLU @ np.asarray(linear_damping, dtype=float) @ FRD_TO_FLU)
    quadratic_given = np.asarray(quadratic_damping, dtype=float)
    off_diagonal = quadratic_given - np.diag(np.diag(quadratic_given))
    if np.any(off_diagonal != 0.0):
        warnings.warn(
            f"{what} quadratic_damping has off-diagonal entries; UUV Simulator ignores them and so "
            "does this reader",
            stacklevel=3,
        )
    quadratic = -np.diag(np.diag(quadratic_given))
    for name, matrix in (("linear_damping", linear), ("quadratic_damping", quadratic)):
        diagonal = np.diag(matrix)
        if np.any(diagonal < 0.0):
            index = int(np.argmin(diagonal))
            raise HydroError(
                f"{what} {name}[{index}] is positive in the file; UUV Simulator expects negative "
                "(dissipative) damping coefficients"
            )
    return added_mass, linear, quadratic


def convert_forward_speed_damping(forward: np.ndarray) -> np.ndarray:
    """UUV Simulator's ``linear_damping_forward_speed`` in our axes and sign.

    ``HMFossen::ComputeDampingMatrix`` has ``D(nu) = -DLin - u DLinForwardSpeed - ...`` and applies
    ``-D nu``: a wrench ``u DLinForwardSpeed nu`` in FRD axes, with ``u`` the relative surge speed
    (the same in FRD and FLU). In FLU axes with positive-dissipative sign that is a wrench
    ``-u D_F nu`` with ``D_F = -T DLinForwardSpeed T``, ``T = diag(1, -1, -1, 1, -1, -1)``.

    Args:
        forward: ``DLinForwardSpeed`` as given (6x6, FRD) [per m/s].

    Returns:
        ``D_F`` (6x6, FLU).
    """
    return -(FRD_TO_FLU @ np.asarray(forward, dtype=float) @ FRD_TO_FLU)


def _uuv_matrix(element: Element | None, what: str, allow_diagonal: bool) -> np.ndarray:
    if element is None:
        return np.zeros((6, 6))
    values = parse_numbers(element.text, what)
    if values.size == 36:
        return values.reshape(6, 6)
    if values.size == 6 and allow_diagonal:
        return np.diag(values)
    expected = "6 or 36" if allow_diagonal else "36"
    raise HydroError(f"{what}: expected {expected} numbers, got {values.size}")


def _collision_centroid(link: Element, name: str, what: str) -> np.ndarray:
    """Volume-weighted centroid of primitive collision shapes (UUV Simulator's CoB estimate)."""
    total, moment = 0.0, np.zeros(3)
    for collision in link.findall("collision"):
        geometry = collision.find("geometry")
        shape = None if geometry is None else next(iter(geometry), None)
        if shape is None or shape.tag not in ("box", "cylinder", "sphere"):
            raise HydroError(
                f"{what}: no center_of_buoyancy and a non-primitive collision shape to estimate it"
            )
        if shape.tag == "box":
            volume = float(np.prod(parse_vector(shape.get("size"), 3, f"{what} box size")))
        elif shape.tag == "cylinder":
            radius = parse_scalar(shape.get("radius"), f"{what} cylinder radius")
            volume = (
                math.pi * radius**2 * parse_scalar(shape.get("length"), f"{what} cylinder length")
            )
        else:
            volume = (
                4.0
                / 3.0
                * math.pi
                * parse_scalar(shape.get("radius"), f"{what} sphere radius") ** 3
            )
        origin = collision.find("origin")
        centre = (
            np.zeros(3)
            if origin is None
            else parse_vector(origin.get("xyz", "0 0 0"), 3, f"{what} collision origin xyz")
        )
        total += volume
        moment += volume * centre
    if total <= 0.0:
        raise HydroError(f"{what}: no center_of_buoyancy and no collision volume to estimate it")
    return moment / total


def collision_centroid_or_none(link: Element, what: str) -> np.ndarray | None:
    """Our estimate of a missing ``center_of_buoyancy`` (:func:`_collision_centroid`), or ``None``
    where it is refused (a non-primitive collision shape, no collision volume): there UUV
    Simulator keeps its default, the link origin (``BuoyantObject.cc``, line 33, and
    ``HydrodynamicModel.cc``, lines 61-66, of uuv_gazebo_plugins), which a lenient load takes
    (:mod:`aiauv_pin.model.lenient_repairs`)."""
    try:
        return _collision_centroid(link, link.get("name", ""), what)
    except HydroError:
        return None


#: ``<hydrodynamic_model><type>`` values read (UUV Simulator's HydrodynamicModel.cc registers these).
UUV_MODEL_TYPES = ("fossen", "sphere", "cylinder", "spheroid", "box")
#: Sphere drag coefficient of UUV Simulator's ``HMSphere`` (subcritical flow) [-].
UUV_SPHERE_DRAG = 0.5
#: ``HMCylinder``'s drag coefficients by aspect ratio ``L / (2 r)``: upper bounds and values, for
#: the flow along the axis (circular face) and across it (rectangular profile) [-].
UUV_CYLINDER_AXIAL_DRAG = ((1.0, 0.91), (2.0, 0.85), (4.0, 0.87), (7.0, 0.99))
UUV_CYLINDER_CROSS_DRAG = ((1.0, 0.63), (2.0, 0.68), (5.0, 0.74), (10.0, 0.82), (40.0, 0.98))


def _model_scalar(model: Element, tag: str, what: str) -> float | None:
    element = model.find(tag)
    if element is None:
        return None
    value = parse_scalar(element.text, f"{what} {tag}")
    if not value > 0.0:
        raise HydroError(f"{what}: {tag} must be positive, got {value}")
    return value


def _bounding_box(element: Element, what: str) -> np.ndarray | None:
    """``(x, y, z)`` extents from the plugin link's ``<box>``: width, length, height [m].

    ``HydrodynamicModel``'s constructor builds the box from ``-width/2, -length/2, -height/2`` to
    ``+...``: width along x, length along y, height along z.
    """
    box = element.find("box")
    if box is None:
        return None
    extents = np.array(
        [
            parse_scalar(box.findtext(tag), f"{what} box {tag}")
            for tag in ("width", "length", "height")
        ]
    )
    if not np.all(extents > 0.0):
        raise HydroError(f"{what}: box extents must be positive, got {extents}")
    return extents


def _table(ratio: float, table) -> float:
    for bound, value in table:
        if ratio <= bound:
            return value
    return table[-1][1]


def geometric_model(
    kind: str,
    model: Element,
    element: Element,
    mass: float | None,
    fluid_density: float,
    added_mass: np.ndarray,
    quadratic: np.ndarray,
    what: str,
) -> None:
    """Set the entries a UUV Simulator geometric model writes over its ``fossen`` matrices.

    The result is about the link's centre of mass, where the plugin applies its wrench; the reader
    then moves added mass and linear damping to the link origin.

    As in uuv_gazebo_plugins ``HydrodynamicModel.cc`` (repository uuvsimulator/uuv_simulator,
    commit bfb40cb, classes ``HMSphere``, ``HMCylinder``, ``HMSpheroid``, ``HMBox``): each derives
    from ``HMFossen``, so the file's ``added_mass``/damping matrices are read first and the model
    then overwrites some diagonal entries, in the FRD axes and sign convention of the file
    (added mass positive, damping coefficients negative). ``rho`` is the fluid density. Missing
    ``radius``/``length`` come from the plugin link's ``<box>`` (UUV Simulator otherwise takes
    Gazebo's bounding box of the link, which this reader cannot compute): radius the smallest
    extent, length the largest, as the plugin does (note: full extents, not half).

    * ``sphere`` (radius ``r``): ``M_A,ii = 2/3 rho pi r^3`` (``= rho V / 2``) and
      ``D_ii = -1/2 rho C_D pi r^2`` with ``C_D = 0.5`` for ``i`` = surge, sway, heave.
    * ``cylinder`` (radius ``r``, length ``L``, ``axis`` ``i``/``j``/``k``, default the longest box
      extent): along the axis ``M_A = rho pi r^2`` (sic: per unit length, as the plugin has it) and
      ``D = -1/2 C_circ pi r^2 rho``; across it ``M_A = rho pi r^2 L`` and ``D = -1/2 C_len r L rho``;
      rotation across it ``M_A = rho pi r^2 L^3 / 12`` (Schjolberg 1994, cited by the plugin); drag
      coefficients by ``L / (2 r)`` from the plugin's table (:data:`UUV_CYLINDER_AXIAL_DRAG`; the
      plugin leaves the axial one unset above 7, where we keep its last value, 0.99).
    * ``spheroid`` (radius ``r``, length ``L``, axis along x): the plugin (marked "still in
      development") evaluates Lamb's prolate-spheroid coefficients with eccentricity
      ``e = sqrt(1 - (r/L)^2)``, i.e. semi-axes ``(L, r, r)``, but multiplies them by the link's
      mass where Lamb has the displaced mass and misplaces a parenthesis in ``beta_0``. We use the
      formulas it intends (Lamb 1932, Sec. 115,
      :func:`aiauv_hydro.estimate.ellipsoid.ellipsoid_added_mass`) for
      semi-axes ``(L, r, r)`` and the displaced mass ``rho 4/3 pi L r^2``.
    * ``box`` (``length``, ``width``, ``height``, ``cd`` default 1; also "still in development"):
      drag ``D_11 = -1/2 C_D width height rho``, ``D_22 = -1/2 C_D length height rho``,
      ``D_33 = -1/2 C_D width length rho``. The plugin computes these but stores them where its
      damping does not read them; we apply them, as intended. No added mass.

    Args:
        kind: ``sphere``, ``cylinder``, ``spheroid`` or ``box``.
        model: The ``<hydrodynamic_model>`` element.
        element: The plugin's ``<link>`` element (for ``<box>``).
        mass: The link's mass [kg] (unused; kept for the record of what the plugin reads).
        fluid_density: ``rho`` [kg/m^3].
        added_mass: FRD added mass, changed in place.
        quadratic: FRD quadratic damping (negative coefficients), changed in place.
        what: Name used in messages.
    """
    del mass
    rho = fluid_density
    box = _bounding_box(element, what)
    if kind == "box":
        dims = {
            tag: _model_scalar(model, tag, f"{what} box model")
            for tag in ("length", "width", "height")
        }
        missing = [tag for tag, value in dims.items() if value is None]
        if missing:
            raise HydroError(f"{what}: box model needs <{'>, <'.join(missing)}>")
        drag = _model_scalar(model, "cd", what)
        drag = 1.0 if drag is None else drag
        length, width, height = dims["length"], dims["width"], dims["height"]
        quadratic[0, 0] = -0.5 * drag * width * height * rho
        quadratic[1, 1] = -0.5 * drag * length * height * rho
        quadratic[2, 2] = -0.5 * drag * width * length * rho
        return
    radius = _model_scalar(model, "radius", what)
    if radius is None:
        if box is None:
            raise HydroError(f"{what}: {kind} model needs <radius> or a <box> bounding box")
        radius = float(np.min(box))
    if kind == "sphere":
        for i in range(3):
            added_mass[i, i] = 2.0 / 3.0 * rho * math.pi * radius**3
            quadratic[i, i] = -0.5 * rho * UUV_SPHERE_DRAG * math.pi * radius**2
        return
    length = _model_scalar(model, "length", what)
    if length is None:
        if box is None:
            raise HydroError(f"{what}: {kind} model needs <length> or a <box> bounding box")
        length = float(np.max(box))
    if kind == "spheroid":
        from aiauv_hydro.estimate.ellipsoid import ellipsoid_added_mass

        if not length > radius:
            raise HydroError(f"{what}: spheroid length must exceed its radius (prolate)")
        diagonal = ellipsoid_added_mass([length, radius, radius], rho)
        for i in range(6):
            added_mass[i, i] = diagonal[i]
        return
    axis_text = (model.findtext("axis") or "").strip()
    if axis_text:
        if axis_text not in ("i", "j", "k"):
            raise HydroError(f"{what}: cylinder axis must be i, j or k, got '{axis_text}'")
        axis = "ijk".index(axis_text)
    elif box is not None:
        axis = int(np.argmax(box))  # first of equal extents, as the plugin's comparisons
    else:
        raise HydroError(f"{what}: cylinder model needs <axis> or a <box> bounding box")
    ratio = length / (2.0 * radius)
    axial_drag = _table(ratio, UUV_CYLINDER_AXIAL_DRAG)
    cross_drag = _table(ratio, UUV_CYLINDER_CROSS_DRAG)
    area = math.pi * radius**2
    for i in range(3):
        if i == axis:
            added_mass[i, i] = rho * area  # as the plugin: no length factor
            quadratic[i, i] = -0.5 * axial_drag * area * rho
        else:
            added_mass[i, i] = rho * area * length
            quadratic[i, i] = -0.5 * cross_drag * radius * length * rho
            added_mass[3 + i, 3 + i] = rho * area * length**3 / 12.0


def _uuv_link(
    element: Element, urdf_link: UrdfLink, link_element: Element, fluid_density: float
) -> LinkHydrodynamics:
    name = urdf_link.name
    what = f"UUV Simulator link '{name}'"
    model = element.find("hydrodynamic_model")
    if model is None:
        raise HydroError(f"{what}: missing <hydrodynamic_model>")
    kind = (model.findtext("type") or "").strip()
    if kind not in UUV_MODEL_TYPES:
        raise HydroError(
            f"{what}: hydrodynamic_model type '{kind}' is not supported "
            f"(expected one of {', '.join(UUV_MODEL_TYPES)})"
        )
    added_mass = _uuv_matrix(model.find("added_mass"), f"{what} added_mass", allow_diagonal=False)
    linear = _uuv_matrix(model.find("linear_damping"), f"{what} linear_damping", True)
    quadratic = _uuv_matrix(model.find("quadratic_damping"), f"{what} quadratic_damping", True)
    forward = _uuv_matrix(
        model.find("linear_damping_forward_speed"), f"{what} linear_damping_forward_speed", True
    )
    if kind != "fossen":
        geometric_model(
            kind, model, element, urdf_link.mass, fluid_density, added_mass, quadratic, what
        )
    if (
        element.find("metacentric_width") is not None
        or element.find("metacentric_length") is not None
    ):
        warnings.warn(
            f"{what}: surface-vessel (metacentric) parameters unsupported; treated as submerged",
            stacklevel=4,
        )
    added_mass, linear, quadratic = convert_fossen_matrices(added_mass, linear, quadratic, what)
    forward = convert_forward_speed_damping(forward)

    neutral_element = element.find("neutrally_buoyant")
    neutral = neutral_element is not None and parse_bool(
        neutral_element.text, f"{what} neutrally_buoyant"
    )
    if neutral:
        if urdf_link.mass is None:
            raise HydroError(f"{what}: neutrally_buoyant needs the link's <inertial> mass")
        volume = urdf_link.mass / fluid_density  # buoyancy rho V g equals weight m g
    else:
        volume_element = element.find("volume")
        if volume_element is None:
            raise HydroError(f"{what}: missing <volume> (and not neutrally_buoyant)")
        volume = parse_scalar(volume_element.text, f"{what} volume")
        if volume < 0.0:
            raise HydroError(f"{what}: volume must be >= 0, got {volume}")

    cob_element = element.find("center_of_buoyancy")
    if cob_element is None:
        center = _collision_centroid(link_element, name, what)
    else:
        # Gazebo link frame (forward-left-up) already: no axis flip (BuoyantObject.cc).
        center = parse_vector(cob_element.text, 3, f"{what} center_of_buoyancy")

    offset = np.any(urdf_link.inertial_origin != 0.0)
    if kind != "fossen" and offset:
        # a geometric model is a shape centred where UUV Simulator applies its wrench, the centre
        # of mass: move added mass and linear damping to the link origin, M_o = X^T M_c X
        # (Fossen 2021, eq. (6.71)); the diagonal quadratic damping keeps no lever arm
        transform = motion_transform(np.eye(3), urdf_link.inertial_origin)
        added_mass = transform.T @ added_mass @ transform
        added_mass = 0.5 * (added_mass + added_mass.T)
        linear = transform.T @ linear @ transform
        forward = transform.T @ forward @ transform  # with u_r at the link origin
    elif offset and (np.any(added_mass) or np.any(linear) or np.any(quadratic) or np.any(forward)):
        warnings.warn(
            f"{what}: inertial origin is offset from the link origin; the matrices are read about "
            "the link origin, whereas UUV Simulator applies its wrench at the centre of mass",
            stacklevel=4,
        )
    return LinkHydrodynamics(
        link=name,
        model="fossen",
        volume=volume,
        center_of_buoyancy=center,
        added_mass=added_mass,
        linear_damping=linear,
        quadratic_damping=quadratic,
        forward_speed_damping=forward,
    )


def uuv_links(
    root: Element,
    links: dict[str, UrdfLink],
    fluid_density: float,
    skip: set[str] | frozenset[str] = frozenset(),
) -> list[LinkHydrodynamics]:
    """Converted parameters of every link named in the UUV Simulator plugins.

    Args:
        root: The ``<robot>`` element.
        links: The robot's links (:func:`aiauv_hydro.urdf.block_reader.robot_links`).
        fluid_density: Density used for ``neutrally_buoyant`` links [kg/m^3].
        skip: Link names to leave out (given elsewhere).

    Returns:
        One ``fossen`` :class:`LinkHydrodynamics` per UUV Simulator link, in file order.
    """
    result: list[LinkHydrodynamics] = []
    seen: set[str] = set()
    for plugin in uuv_plugins(root):
        for element in plugin.findall("link"):
            name = element.get("name")
            if not name:
                raise HydroError("UUV Simulator plugin <link> without a name")
            if name in seen:
                raise HydroError(f"UUV Simulator link '{name}' given twice")
            seen.add(name)
            if name in skip:
                continue
            if name not in links:
                raise HydroError(f"UUV Simulator link '{name}' is not a <link> of the robot")
            result.append(_uuv_link(element, links[name], links[name].element, fluid_density))
    return result


def read_uuv_simulator(source: str | os.PathLike | Element) -> HydroSpec:
    """Read only the UUV Simulator blocks of a URDF.

    Args:
        source: URDF path, text or parsed ``<robot>`` element.

    Returns:
        The converted parameters, with the plugins' fluid density (1028 if absent) and gravity 9.81.
        :func:`aiauv_hydro.urdf.block_reader.read_hydrodynamics` reads these blocks too, merged with ours.
    """
    root = parse_robot(source)
    links = robot_links(root)
    density = uuv_fluid_density(root)
    if density is None:
        density = UUV_DEFAULT_FLUID_DENSITY
    return HydroSpec(
        fluid_density=density,
        gravity=DEFAULT_GRAVITY,
        links=tuple(uuv_links(root, links, density)),
    )


# --------------------------------------------------------------------------------------------------
# Thrusters
# --------------------------------------------------------------------------------------------------


def thruster_plugins(root: Element) -> list[Element]:
    """The UUV Simulator thruster plugin elements of a ``<robot>``."""
    return [
        plugin
        for plugin in root.findall("gazebo/plugin")
        if "thruster" in plugin.get("filename", "") and plugin.find("linkName") is not None
    ]


def _conversion_thrust(conversion: Element | None, command: float, what: str) -> float:
    """Steady-state thrust of the conversion function at rotor command ``command``."""
    if conversion is None:
        raise HydroError(f"{what}: missing <conversion>")
    kind = (conversion.findtext("type") or "").strip()
    if kind == "Basic":
        constant = parse_scalar(conversion.findtext("rotorConstant"), f"{what} rotorConstant")
        return constant * command * abs(command)
    if kind == "Bessa":
        value = command * abs(command)
        names = ("rotorConstantL", "rotorConstantR", "deltaL", "deltaR")
        k_left, k_right, delta_left, delta_right = (
            parse_scalar(conversion.findtext(name), f"{what} {name}") for name in names
        )
        if value <= delta_left:
            return k_left * (value - delta_left)
        if value >= delta_right:
            return k_right * (value - delta_right)
        return 0.0
    if kind == "LinearInterp":
        inputs = parse_numbers(conversion.findtext("inputValues"), f"{what} inputValues")
        outputs = parse_numbers(conversion.findtext("outputValues"), f"{what} outputValues")
        if inputs.size < 2 or inputs.size != outputs.size or np.any(np.diff(inputs) <= 0):
            raise HydroError(
                f"{what}: LinearInterp needs increasing inputValues matching outputValues"
            )
        return float(np.interp(command, inputs, outputs))
    raise HydroError(
        f"{what}: conversion type '{kind}' is not supported (Basic, Bessa, LinearInterp)"
    )


def _optional(plugin: Element, tag: str, what: str) -> float | None:
    element = plugin.find(tag)
    return None if element is None else parse_scalar(element.text, f"{what} {tag}")


def _efficiency(plugin: Element, tag: str, what: str) -> float:
    value = _optional(plugin, tag, what)
    if value is None or not 0.0 <= value <= 1.0:  # the plugin resets invalid values to 1
        return 1.0
    return value


def steady_thrust(plugin: Element, command: float, what: str) -> float:
    """Thrust [N] of a UUV Simulator thruster plugin held at rotor command ``command``, once its
    dynamics settled (their fixed point is their input).

    ThrusterPlugin.cc (uuv_gazebo_plugins, commit bfb40cb), ``Update``, lines 213-236: the command
    clamped to ``[clampMin, clampMax]`` (l. 213-215), times ``gain`` (l. 217) and
    ``propeller_efficiency`` (l. 225), through the conversion function (l. 230-231, ``Basic``: ``k x
    |x|``, ThrusterConversionFcn.cc), times ``thrust_efficiency``, clamped to ``[thrustMin,
    thrustMax]`` (l. 235-236). Unset bounds are the doubles' extremes (l. 44-47); inverted ones fall
    back to them (l. 117-122, 131-136); efficiencies outside [0, 1] are 1 (l. 145-161).
    """
    clamp_min, clamp_max, thrust_min, thrust_max = _bounds(plugin, what)
    gain = _optional(plugin, "gain", what)
    rotor = (1.0 if gain is None else gain) * min(max(command, clamp_min), clamp_max)
    rotor *= _efficiency(plugin, "propeller_efficiency", what)
    thrust = _efficiency(plugin, "thrust_efficiency", what) * _conversion_thrust(
        plugin.find("conversion"), rotor, what
    )
    return min(max(thrust, thrust_min), thrust_max)


def _bounds(plugin: Element, what: str) -> tuple[float, float, float, float]:
    """``clampMin, clampMax, thrustMin, thrustMax`` as ThrusterPlugin.cc takes them (l. 44-47,
    110-136): unset is unbounded, an inverted pair falls back to unbounded."""
    values = [
        _optional(plugin, tag, what) for tag in ("clampMin", "clampMax", "thrustMin", "thrustMax")
    ]
    bounds = [
        -math.inf if v is None and k % 2 == 0 else math.inf if v is None else v
        for k, v in enumerate(values)
    ]
    for low in (0, 2):
        if bounds[low] >= bounds[low + 1]:
            bounds[low], bounds[low + 1] = -math.inf, math.inf
    return tuple(bounds)


def thrust_limits(plugin: Element, what: str) -> tuple[float, float]:
    """Largest forward and reverse thrust [N] (both positive; ``inf``: unlimited) that a UUV
    Simulator thruster plugin produces, :func:`steady_thrust` at its extreme commands.

    The conversion functions are monotonic in the command (``Basic``, ``Bessa``; ``LinearInterp``
    as the tables are published), so the extremes are at the clamps; with no clamp, the thrust
    bounds (``thrustMax``, ``-thrustMin``) or nothing at all.
    """
    clamp_min, clamp_max, thrust_min, thrust_max = _bounds(plugin, what)
    _conversion_thrust(plugin.find("conversion"), 0.0, what)  # a known, well-formed conversion
    forward = steady_thrust(plugin, clamp_max, what) if math.isfinite(clamp_max) else thrust_max
    backward = -steady_thrust(plugin, clamp_min, what) if math.isfinite(clamp_min) else -thrust_min
    return forward, backward


def uuv_thrusters(root: Element, links: dict[str, UrdfLink]) -> list[Thruster]:
    """Thrusters of the UUV Simulator thruster plugins, as this package's thrusters.

    ``max_thrust`` is the steady-state thrust at the largest command ``clampMax`` (positive
    direction), capped by ``thrustMax`` (:func:`thrust_limits`); a plugin with neither gives no
    finite limit and is left out with a warning (add ``<thrustMax>``, or describe the thruster in
    our ``<hydrodynamics>`` block), so that the vehicle still loads. A
    negative-direction limit that differs by more than 1 % is reported by a warning, since ours is
    symmetric.

    Raises:
        HydroError: Unknown link or joint, missing or unsupported conversion.
    """
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    result = []
    for plugin in thruster_plugins(root):
        link = (plugin.findtext("linkName") or "").strip()
        identifier = (plugin.findtext("thrusterID") or "").strip()
        name = plugin.get("name") or f"thruster_{identifier or link}"
        what = f"UUV Simulator thruster '{name}'"
        if link not in links:
            raise HydroError(f"{what}: linkName '{link}' is not a <link> of the robot")
        joint_name = (plugin.findtext("jointName") or "").strip()
        joint = joints.get(joint_name)
        if joint is None:
            raise HydroError(f"{what}: jointName '{joint_name}' is not a <joint> of the robot")
        if (joint.find("child").get("link") if joint.find("child") is not None else None) != link:
            raise HydroError(f"{what}: joint '{joint_name}' does not move link '{link}'")
        axis_element = joint.find("axis")
        axis = parse_vector(
            "1 0 0" if axis_element is None else axis_element.get("xyz", "1 0 0"),
            3,
            f"{what} joint axis",
        )
        forward, backward = thrust_limits(plugin, what)
        if not (math.isfinite(forward) and forward > 0.0):
            # as shipped for RexROV and ECA A9: UUV Simulator applies no limit at all
            warnings.warn(
                f"{what}: no finite positive thrust limit, left out (give <thrustMax> or "
                "<clampMax>, or describe the thruster in the <hydrodynamics> block; --lenient "
                "takes the limit of UUV Simulator's thruster manager on the package path)",
                stacklevel=3,
            )
            continue
        if math.isfinite(backward) and abs(backward - forward) > 0.01 * forward:
            warnings.warn(
                f"{what}: reverse thrust limit {backward:.4g} N differs from forward {forward:.4g} N; "
                f"using +-{forward:.4g} N",
                stacklevel=3,
            )
        result.append(
            Thruster(
                name=name,
                link=link,
                position=links[link].inertial_origin,
                direction=axis,
                max_thrust=forward,
                time_constant=thruster_time_constant(plugin.find("dynamics"), what),
            )
        )
    return result


def thruster_time_constant(dynamics: Element | None, what: str) -> float:
    """Our first-order time constant [s] of a UUV Simulator ``<dynamics>`` element.

    ``ZeroOrder`` (or none) is 0; ``FirstOrder`` is its ``timeConstant`` (Dynamics.cc line 104 reads
    ``timeConstant``; ``time_constant``, the name its error message gives, is accepted too). For a
    thruster the plugin's dynamics filter the rotor command, not the thrust: see the module
    docstring for how far the two agree. ``Yoerger`` and ``Bessa`` are read as 0 with a warning.

    Raises:
        HydroError: An unknown type, or a missing or negative time constant.
    """
    if dynamics is None:
        return 0.0
    kind = (dynamics.findtext("type") or "").strip()
    if kind == "ZeroOrder":
        return 0.0
    if kind == "FirstOrder":
        text = dynamics.findtext("timeConstant")
        if text is None:
            text = dynamics.findtext("time_constant")
        if text is None:
            raise HydroError(f"{what}: FirstOrder dynamics without <timeConstant>")
        value = parse_scalar(text, f"{what} timeConstant")
        if value < 0.0:
            raise HydroError(f"{what}: timeConstant must be >= 0, got {value}")
        return value
    if kind in ("Yoerger", "Bessa"):
        warnings.warn(
            f"{what}: {kind} rotor dynamics have no form here; read as zero order (no lag)",
            stacklevel=4,
        )
        return 0.0
    raise HydroError(
        f"{what}: dynamics type '{kind}' is not supported (ZeroOrder, FirstOrder, Yoerger, Bessa)"
    )


# Fins
# --------------------------------------------------------------------------------------------------


def fin_plugins(root: Element) -> list[Element]:
    """The UUV Simulator fin plugin elements of a ``<robot>`` (``<liftdrag>`` and ``<link_name>``)."""
    return [
        plugin
        for plugin in root.findall("gazebo/plugin")
        if plugin.find("liftdrag") is not None and plugin.find("link_name") is not None
    ]


def _fin_limit(joint: Element | None, what: str) -> float:
    """The symmetric angle limit [rad] of a fin joint's ``<limit>`` (``pi/2`` without one)."""
    limit = None if joint is None else joint.find("limit")
    if limit is None or ("lower" not in limit.attrib and "upper" not in limit.attrib):
        return 0.5 * math.pi
    lower = parse_scalar(limit.get("lower", "0"), f"{what} joint lower limit")
    upper = parse_scalar(limit.get("upper", "0"), f"{what} joint upper limit")
    bound = min(-lower, upper)
    if not bound > 0.0:
        raise HydroError(f"{what}: joint limits [{lower}, {upper}] do not contain zero")
    if abs(-lower - upper) > 1e-9 * max(1.0, bound):
        warnings.warn(
            f"{what}: joint limits [{lower:.4g}, {upper:.4g}] are not symmetric; using +-{bound:.4g}",
            stacklevel=4,
        )
    return min(bound, math.pi)


def uuv_fins(root: Element, links: dict[str, UrdfLink], fluid_density: float) -> list[Fin]:
    """Fins of the UUV Simulator fin plugins, as this package's fins (see the module docstring).

    Args:
        root: The ``<robot>`` element.
        links: Its links (:func:`robot_links`).
        fluid_density: The vehicle's fluid density [kg/m^3] (the constants are divided by it).

    Raises:
        HydroError: Unknown link, missing constants, bad joint limits or dynamics.
    """
    joints = {joint.get("name"): joint for joint in root.findall("joint")}
    result = []
    for plugin in fin_plugins(root):
        link = (plugin.findtext("link_name") or "").strip()
        identifier = (plugin.findtext("fin_id") or "").strip()
        name = plugin.get("name") or f"fin{identifier or link}"
        what = f"UUV Simulator fin '{name}'"
        if link not in links:
            raise HydroError(f"{what}: link_name '{link}' is not a <link> of the robot")
        liftdrag = plugin.find("liftdrag")
        kind = (liftdrag.findtext("type") or "").strip()
        if kind != "Quadratic":
            warnings.warn(
                f"{what}: liftdrag type '{kind}' has no form here (Quadratic only); left out",
                stacklevel=3,
            )
            continue
        constants = {}
        for tag in ("lift_constant", "drag_constant"):
            text = liftdrag.findtext(tag)
            if text is None:
                raise HydroError(f"{what}: Quadratic liftdrag needs <{tag}>")
            constants[tag] = parse_scalar(text, f"{what} {tag}")
            if constants[tag] < 0.0:
                raise HydroError(f"{what}: {tag} must be >= 0, got {constants[tag]}")
        joint_name = (plugin.findtext("joint_name") or "").strip()
        joint = joints.get(joint_name)
        if joint_name and joint is None:
            raise HydroError(f"{what}: joint_name '{joint_name}' is not a <joint> of the robot")
        result.append(
            Fin(
                name=name,
                link=link,
                position=links[link].inertial_origin,
                axis=(0.0, 0.0, 1.0),
                chord=(1.0, 0.0, 0.0),
                area=1.0,
                lift_slope=2.0 * constants["lift_constant"] / fluid_density,
                drag_slope=2.0 * constants["drag_constant"] / fluid_density,
                max_angle=_fin_limit(joint, what),
                time_constant=thruster_time_constant(plugin.find("dynamics"), what),
            )
        )
    return result


def freeze_thruster_joints(root: Element) -> list[str]:
    """Make the propeller joints of UUV Simulator thrusters fixed, in place.

    Returns:
        The names of the joints changed (``continuous`` or ``revolute`` joints named by a thruster
        plugin's ``jointName``).
    """
    names = {(plugin.findtext("jointName") or "").strip() for plugin in thruster_plugins(root)}
    changed = []
    for joint in root.findall("joint"):
        if joint.get("name") in names and joint.get("type") in ("continuous", "revolute"):
            joint.set("type", "fixed")
            for tag in ("limit", "dynamics", "safety_controller", "mimic"):
                for child in joint.findall(tag):
                    joint.remove(child)
            changed.append(joint.get("name"))
    return changed
