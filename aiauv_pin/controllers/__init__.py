"""Controllers wired to a vehicle: the compiled-controller record, the paper's, turning, gaits,
a torpedo AUV's (fins).

The laws themselves live in :mod:`aiauv_control`; here they get their measurements and actuators.
May import :mod:`aiauv_pin.dynamics` and the floors below it.
"""
