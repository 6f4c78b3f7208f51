"""Estimates of a link's hydrodynamic coefficients from its shape (plain numpy).

May import :mod:`aiauv_hydro.numerics` and :mod:`aiauv_hydro.spec`.

Modules: :mod:`~aiauv_hydro.estimate.ellipsoid` (Lamb's coefficients of the equivalent ellipsoid),
:mod:`~aiauv_hydro.estimate.slender_cylinder` (strip theory of a slender cylinder),
:mod:`~aiauv_hydro.estimate.mujoco_fluid` (MuJoCo's fluid models as our per-link parameters).
"""
