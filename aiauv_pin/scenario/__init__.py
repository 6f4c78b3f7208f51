"""Scenarios and sweeps: what to run (vehicle, path, current, controller), from files or Python.

May import :mod:`aiauv_pin.simulation` and the floors below it.
"""
