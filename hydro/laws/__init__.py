"""The fluid terms of the equations of motion, written once for every backend.

May import :mod:`aiauv_hydro.numerics` and :mod:`aiauv_hydro.spec`, :mod:`aiauv_hydro.currents`.

Modules: :mod:`~aiauv_hydro.laws.fluid_terms` (the per-link walk: added mass, Coriolis, damping,
restoring, thrust, and their Jacobians), :mod:`~aiauv_hydro.laws.damping`,
:mod:`~aiauv_hydro.laws.crossflow`, :mod:`~aiauv_hydro.laws.kirchhoff` (batched over links),
:mod:`~aiauv_hydro.laws.lift` (fins: lift and drag), :mod:`~aiauv_hydro.laws.actuators` (how a
thrust or fin angle follows its command) and :mod:`~aiauv_hydro.laws.unsteady_flow` (the water's
acceleration: Froude-Krylov and the added mass's reaction, and their derivative).
"""
