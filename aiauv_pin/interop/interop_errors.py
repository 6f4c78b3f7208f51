"""The error of the interop commands."""

from __future__ import annotations

from aiauv_pin.errors import AiauvError


class InteropError(AiauvError, ValueError):
    """A model that cannot be imported or exported; the message is one line naming the problem."""
