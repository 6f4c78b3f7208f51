"""Running a vehicle in time: the fixed-step loop (Python and compiled), rollouts, step stability.

May import :mod:`aiauv_pin.controllers` and the floors below it.
"""
