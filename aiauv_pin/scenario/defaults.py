"""The scenario's default integrator, step and table period, named once.

A module without imports, so that the command line's help (:mod:`aiauv_pin.app.cli`) states them
without loading the simulation; :class:`aiauv_pin.scenario.definition.Scenario` takes its defaults from here.
Why these values: :mod:`aiauv_pin.scenario.definition` (module docstring) and ``benchmarks/default_step.py``.
"""

#: Integrator of the scenario: semi-implicit Euler (``"euler"``), RK4-Munthe-Kaas (``"rk4"``) or the
#: midpoint method (``"midpoint"``).
DEFAULT_METHOD = "euler"
#: Integration step of the scenario [s]: the cheapest within 2 mm of the converged path whose
#: sampled attitude loop keeps a gain margin of 2 (:mod:`aiauv_pin.scenario.definition`).
DEFAULT_DT = 0.004
#: Time between rows of ``timeseries.csv`` [s] (every tenth step of :data:`DEFAULT_DT`).
DEFAULT_CSV_PERIOD = 0.04
