"""Time stepping and analysis of a vehicle: integrators, the joint servo, transitions, linear models.

May import :mod:`aiauv_pin.model` and the floors below it.
"""
