"""What a run leaves: result files and figures, the HTML playback, the live meshcat viewer.

May import :mod:`aiauv_pin.scenario` and the floors below it.
"""
