"""Per-link hydrodynamics for underwater multibody vehicles (plain numpy).

Parameter records (:mod:`aiauv_hydro.spec`), the slender-cylinder model
(:mod:`aiauv_hydro.estimate.slender_cylinder`),
batched crossflow drag (:mod:`aiauv_hydro.laws.crossflow`), the URDF ``<hydrodynamics>`` reader
(:mod:`aiauv_hydro.urdf.block_reader`) and the UUV Simulator block reader
(:mod:`aiauv_hydro.urdf.uuv_simulator`).
"""

from aiauv_hydro.estimate.slender_cylinder import (
    DEFAULT_COEFFICIENTS,
    SlenderCylinderCoefficients,
    added_mass_matrix,
    linear_damping_matrix,
    quadratic_damping_matrix,
    slender_cylinder_link,
)
from aiauv_hydro.laws.crossflow import DEFAULT_NODES, crossflow_wrench, gauss_legendre_unit
from aiauv_hydro.numerics.spatial import motion_transform, skew
from aiauv_hydro.spec import CrossflowDrag, HydroError, HydroSpec, LinkHydrodynamics, Thruster
from aiauv_hydro.urdf.block_reader import (
    CylinderGeometry,
    cylinder_frame,
    link_cylinders,
    read_hydrodynamics,
)
from aiauv_hydro.urdf.uuv_simulator import FRD_TO_FLU, convert_fossen_matrices, read_uuv_simulator

__all__ = [
    "DEFAULT_COEFFICIENTS",
    "DEFAULT_NODES",
    "FRD_TO_FLU",
    "CrossflowDrag",
    "CylinderGeometry",
    "HydroError",
    "HydroSpec",
    "LinkHydrodynamics",
    "SlenderCylinderCoefficients",
    "Thruster",
    "added_mass_matrix",
    "convert_fossen_matrices",
    "crossflow_wrench",
    "cylinder_frame",
    "gauss_legendre_unit",
    "linear_damping_matrix",
    "link_cylinders",
    "motion_transform",
    "quadratic_damping_matrix",
    "read_hydrodynamics",
    "read_uuv_simulator",
    "skew",
    "slender_cylinder_link",
]
