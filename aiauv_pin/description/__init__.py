"""Reading vehicle description files safely: URDF structure, xacro, MJCF, SDF, ROS packages, limits,
names.

Vehicle files are data, never code. May import :mod:`aiauv_pin._internal`, :mod:`aiauv_pin.errors`
and :mod:`aiauv_hydro`.
"""
