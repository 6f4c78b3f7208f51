"""The control laws, written once for every backend (compiled and interpreted).

May import :mod:`aiauv_control.paths` and :mod:`aiauv_hydro.numerics` only.

Modules: :mod:`~aiauv_control.laws.paper_laws` (guidance, reduced attitude, joint references, joint
PD, surge PI of Wrzos-Kaminska et al. 2019), :mod:`~aiauv_control.laws.turning_laws` (the
thruster-turning baseline), :mod:`~aiauv_control.laws.gait_laws` (serpentine gaits and their
steering, Kelasidi et al. 2017).
"""
