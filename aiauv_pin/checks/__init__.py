"""Checks of a vehicle model: ``aiauv check`` and the dynamics-consistency laws.

May import :mod:`aiauv_pin.results` and the floors below it.
"""
