"""Whole-vehicle controllers for any vehicle: station keeping, velocity control (and intervention).

May import :mod:`aiauv_pin.dynamics` and the floors below it (the floor of
:mod:`aiauv_pin.controllers`).
"""
