"""Reading and writing the hydrodynamics of URDF files (plain numpy, no Pinocchio).

May import :mod:`aiauv_hydro.estimate`, :mod:`aiauv_hydro.numerics`, :mod:`aiauv_hydro.spec`.

Modules: :mod:`~aiauv_hydro.urdf.xml_reading` (safe parsing, numbers, origins),
:mod:`~aiauv_hydro.urdf.block_reader` and :mod:`~aiauv_hydro.urdf.block_writer` (our
``<hydrodynamics>`` block), :mod:`~aiauv_hydro.urdf.uuv_simulator` (UUV Simulator's blocks),
:mod:`~aiauv_hydro.urdf.annotate` (a block estimated for any URDF, ``aiauv annotate``).
"""
