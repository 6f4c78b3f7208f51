"""A vehicle: loading, assembly, validation, the :class:`~aiauv_pin.model.vehicle.Vehicle`, derivatives.

May import :mod:`aiauv_pin.kernels`, :mod:`aiauv_pin.description`, :mod:`aiauv_pin._internal`,
:mod:`aiauv_hydro`.
"""
