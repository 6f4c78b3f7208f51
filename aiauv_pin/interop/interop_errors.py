"""The error of the interop commands (defined in :mod:`aiauv_pin.errors`, which the SDF reader of
:mod:`aiauv_pin.description.sdf_reading` raises too)."""

from __future__ import annotations

from aiauv_pin.errors import InteropError

__all__ = ["InteropError"]
