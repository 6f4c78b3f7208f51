"""Time stepping and analysis of a vehicle: the joint servo, transitions, linear models, lagged mass.

May import :mod:`aiauv_pin.model` and the floors below it.
"""
