"""Maintainers' tools, imported by nothing in the library: ``aiauv bench`` and the shipped-kernel builder.

May import every package but :mod:`aiauv_pin.app` (which imports it for the ``bench`` command).
"""
