"""The numba machinery: compilation of the laws, the on-disk cache, shipped kernels, spatial algebra.

The lowest floor of the project: it imports no package of the project. Packages with compiled code
register their source roots with :func:`aiauv_hydro.numerics.jit.register_compiled_sources`, so
that this package never names them.

Modules: :mod:`~aiauv_hydro.numerics.jit` (the ``compiled`` decorator and the content-keyed cache),
:mod:`~aiauv_hydro.numerics.kernel_cache` (unpacking shipped kernels into the user cache),
:mod:`~aiauv_hydro.numerics.spatial` (6-D vector algebra: cross products, motion transforms).
"""
