"""The ``aiauv`` command line: one module per command group, the parser in :mod:`~aiauv_pin.app.cli`.

The top floor: it may import every package of the project.
"""
