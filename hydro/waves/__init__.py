"""Linear water waves: regular (Airy) waves and irregular seas, as compiled flow fields.

May import :mod:`aiauv_hydro.numerics` and :mod:`aiauv_hydro.spec` (stands on the floor of
:mod:`aiauv_hydro.currents`, which imports it for its ``"waves"`` current); never Pinocchio.

Modules: :mod:`~aiauv_hydro.waves.dispersion` (``omega^2 = g k tanh(k h)``),
:mod:`~aiauv_hydro.waves.spectra` (JONSWAP, Pierson-Moskowitz, spreading, the seeded
components), :mod:`~aiauv_hydro.waves.kinematics` (compiled elevation, velocity and acceleration
from one flat parameter array), :mod:`~aiauv_hydro.waves.sea_state` (:class:`Waves`: the checked
sea and its parameters). docs/source/waves.md has the formulas and sources.
"""

from aiauv_hydro.waves.dispersion import wavenumber
from aiauv_hydro.waves.kinematics import wave_acceleration, wave_elevation, wave_velocity
from aiauv_hydro.waves.sea_state import Waves

__all__ = ["Waves", "wave_acceleration", "wave_elevation", "wave_velocity", "wavenumber"]
