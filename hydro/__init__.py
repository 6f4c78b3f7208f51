"""Per-link hydrodynamics for underwater multibody vehicles (plain numpy).

Parameter records (:mod:`hydro.spec`), the slender-cylinder model (:mod:`hydro.slender_cylinder`),
batched crossflow drag (:mod:`hydro.crossflow`), the URDF ``<hydrodynamics>`` reader
(:mod:`hydro.urdf_block`) and the UUV Simulator block reader (:mod:`hydro.uuv_simulator`).
"""

from hydro.crossflow import DEFAULT_NODES, crossflow_wrench, gauss_legendre_unit
from hydro.slender_cylinder import (
    DEFAULT_COEFFICIENTS,
    SlenderCylinderCoefficients,
    added_mass_matrix,
    linear_damping_matrix,
    quadratic_damping_matrix,
    slender_cylinder_link,
)
from hydro.spatial import motion_transform, skew
from hydro.spec import CrossflowDrag, HydroError, HydroSpec, LinkHydrodynamics, Thruster
from hydro.urdf_block import CylinderGeometry, cylinder_frame, link_cylinders, read_hydrodynamics
from hydro.uuv_simulator import FRD_TO_FLU, convert_fossen_matrices, read_uuv_simulator

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
