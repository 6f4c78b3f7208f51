"""Whole-body controllers for any vehicle: intervention (hold a frame's pose with thrusters and
joints), station keeping and velocity control.

The laws live in :mod:`aiauv_control.laws`; here they get their measurements (Pinocchio through
:mod:`aiauv_pin.model`) and actuators. May import :mod:`aiauv_pin.controllers` and the floors below.
"""
