"""Vehicles built from specifications: module chains from a TOML spec, and UVMS (hull + arm).

May import :mod:`aiauv_pin.model` and the floors below it.
"""
