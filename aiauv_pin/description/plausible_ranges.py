"""The plausibility ranges of vehicle parameters, in one table (:data:`PLAUSIBLE_RANGES`).

Read by the validation gate (:mod:`aiauv_pin.model.validation`), the URDF validation walk
(:mod:`aiauv_pin.description.urdf_validation`: geometry sizes, origins, mesh scales) and, for the numbers it
needs before computing anything from them, the hydrodynamics reader (:mod:`aiauv_hydro.urdf.block_reader`:
:data:`~aiauv_hydro.urdf.block_reader.LENGTH_RANGE`, :data:`~aiauv_hydro.urdf.block_reader.MAX_DIMENSIONLESS`,
:data:`~aiauv_hydro.urdf.block_reader.V_REF_RANGE`, which this table quotes).

Why these bounds: each is orders of magnitude beyond any underwater vehicle, and small enough that
every force the laws compute stays finite: with coefficients up to 1e9 SI, lengths up to 1e3 m and
speeds up to 100 m/s, a quadratic drag is at most ``1e9 * 1e2 * 1e2 = 1e13`` N, a moment ``1e16``
N m, and the products the kinematics, the viewer and the JSON writers form stay far below the
float64 limit (1.8e308). Without them, a visual origin of 1e308 would pass ``check`` and fail
writing JSON at the end of the run, ``C_dC = 1e20`` would run until it diverged, and a cylinder
length of 1e308 would raise ``OverflowError``.

=========================  =============  ======  =========================================
parameter                  range          unit    reason
=========================  =============  ======  =========================================
gravity                    [0, 100]       m/s^2   the Sun's surface has 274; Earth 9.81
fluid_density              [1e-3, 2e4]    kg/m^3  air 1.2, mercury 13 500
link mass                  [0, 1e6]       kg      a submarine hull section
principal inertia          [0, 1e8]       kg m^2  1e6 kg at 10 m
volume                     [0, 1e3]       m^3     1e6 kg of water
distance                   [0, 1e3]       m       origins, CG, CB, thruster, geometry
geometry size              [1e-4, 1e3]    m       box, cylinder, sphere sizes
mesh scale                 [1e-6, 1e3]    -       millimetre meshes are 1e-3
origin angle (rpy)         [-1e3, 1e3]    rad     any angle, a few hundred turns
added mass, damping        [-1e9, 1e9]    SI      drag at 100 m/s below 1e13 N
dimensionless coefficient  [0, 1e3]       -       drag coefficients are 0.1 to 2
reference speed v_ref      [1e-3, 1e3]    m/s     turns C_dL into a linear coefficient
strip coeff. x length      [0, 1e9]       kg/m    as a quadratic damping entry
max_thrust                 [0, 1e7]       N       the largest ship propellers
=========================  =============  ======  =========================================
"""

from __future__ import annotations

import math

from aiauv_hydro.urdf.block_reader import LENGTH_RANGE, MAX_DIMENSIONLESS, V_REF_RANGE
from aiauv_pin.errors import PhysicalParameterError

#: Largest gravitational acceleration [m/s^2] (the Sun's surface has 274; Earth 9.81).
MAX_GRAVITY = 100.0
#: Smallest and largest fluid density [kg/m^3] (air is 1.2; mercury 13 500).
MIN_FLUID_DENSITY = 1e-3
MAX_FLUID_DENSITY = 2e4
#: Largest mass of one link [kg].
MAX_LINK_MASS = 1e6
#: Largest principal moment of inertia of one link [kg m^2].
MAX_INERTIA = 1e8
#: Largest displaced volume of one link [m^3].
MAX_VOLUME = 1e3
#: Largest distance of a joint origin, centre of gravity or buoyancy or thruster from its link [m].
MAX_DISTANCE = 1e3
#: Largest magnitude of an added-mass or damping entry [SI].
MAX_COEFFICIENT = 1e9
#: Largest thrust limit [N].
MAX_THRUST = 1e7
#: Range of a geometry origin's angles (roll, pitch, yaw) [rad].
ANGLE_RANGE = (-1e3, 1e3)
#: Range of a mesh's scale factors [-].
MESH_SCALE_RANGE = (1e-6, 1e3)

#: The plausibility ranges of the module docstring's table: ``name -> (low, high, unit)``; the
#: constants above and :data:`aiauv_hydro.urdf.block_reader.LENGTH_RANGE`,
#: :data:`~aiauv_hydro.urdf.block_reader.MAX_DIMENSIONLESS`,
#: :data:`~aiauv_hydro.urdf.block_reader.V_REF_RANGE` hold the same numbers, where each check reads them.
PLAUSIBLE_RANGES: dict[str, tuple[float, float, str]] = {
    "gravity": (0.0, MAX_GRAVITY, "m/s^2"),
    "fluid_density": (MIN_FLUID_DENSITY, MAX_FLUID_DENSITY, "kg/m^3"),
    "mass": (0.0, MAX_LINK_MASS, "kg"),
    "moment of inertia": (0.0, MAX_INERTIA, "kg m^2"),
    "volume": (0.0, MAX_VOLUME, "m^3"),
    "distance": (0.0, MAX_DISTANCE, "m"),
    "geometry size": (*LENGTH_RANGE, "m"),
    "mesh scale": (*MESH_SCALE_RANGE, "-"),
    "origin angle": (*ANGLE_RANGE, "rad"),
    "added mass or damping entry": (-MAX_COEFFICIENT, MAX_COEFFICIENT, "SI"),
    "dimensionless coefficient": (0.0, MAX_DIMENSIONLESS, "-"),
    "v_ref": (*V_REF_RANGE, "m/s"),
    "strip coefficient x length": (0.0, MAX_COEFFICIENT, "kg/m"),
    "max_thrust": (0.0, MAX_THRUST, "N"),
}


def check_range(value: float, kind: str, what: str, where: str = "") -> float:
    """``value`` if within the plausibility range ``kind`` of :data:`PLAUSIBLE_RANGES`.

    Args:
        value: The number.
        kind: A key of :data:`PLAUSIBLE_RANGES`.
        what: The parameter and where it is (e.g. ``"link 'hull' <visual> cylinder size"``).
        where: Prefix of the message (the file).

    Raises:
        PhysicalParameterError: Outside the range (or not finite), one line naming ``what``.
    """
    low, high, unit = PLAUSIBLE_RANGES[kind]
    if not (math.isfinite(value) and low <= value <= high):
        message = f"{what} = {value:.4g} {unit} outside the plausible range [{low:g}, {high:g}]"
        raise PhysicalParameterError(f"{where}: {message}" if where else message)
    return value
