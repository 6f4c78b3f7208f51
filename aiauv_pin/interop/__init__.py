"""Exchange with other simulators: Gazebo (gz-sim) SDF models and MuJoCo MJCF.

- :mod:`aiauv_pin.interop.gz`: ``aiauv import-gz`` (gz Hydrodynamics plugin parameters and SDF
  ``<fluid_added_mass>`` onto a URDF's ``<hydrodynamics>`` block) and ``aiauv export ... -o X.sdf``.
- :mod:`aiauv_pin.interop.mjcf`: ``aiauv export ... -o X.xml`` (a MuJoCo model).
"""

from aiauv_pin.interop.interop_errors import InteropError

__all__ = ["InteropError"]
