"""Plumbing shared by the commands: atomic files, result folders, argument types, number text.

Nothing here knows vehicles or physics. May import :mod:`aiauv_pin.errors` only.
"""
