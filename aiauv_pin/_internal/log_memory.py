"""Large simulation logs in plain anonymous memory, without numpy's huge-page advice.

NumPy asks Linux for transparent huge pages on every array of 4 MiB or more
(``madvise(MADV_HUGEPAGE)``; numpy's ``NUMPY_MADVISE_HUGEPAGE``). With the kernel's usual
``/sys/kernel/mm/transparent_hugepage/defrag = madvise``, a page fault in such an array may
compact memory synchronously to find a free 2 MiB page: the first write to a rollout's fresh
log then costs several times the system time of ordinary pages (the figures are on the docs'
performance page), and the huge pages buy nothing for a log written once, row by row.
:func:`empty_log` gives the same C-ordered float64 array in an anonymous memory map (Python's
:mod:`mmap`), which numpy does not advise: the values written, and so the results, are
unchanged.
"""

from __future__ import annotations

import math
import mmap

import numpy as np

#: Below this size [bytes] a log is an ordinary ``np.empty`` (numpy advises huge pages from 4 MiB).
MAPPED_FROM = 4 << 20


def empty_log(shape: tuple[int, ...]) -> np.ndarray:
    """An uninitialised C-ordered float64 array of ``shape``, in an anonymous memory map when it
    is at least :data:`MAPPED_FROM` bytes (the map is freed with the last view of the array)."""
    nbytes = 8 * math.prod(shape)
    if nbytes < MAPPED_FROM:
        return np.empty(shape)
    return np.frombuffer(mmap.mmap(-1, nbytes), dtype=np.float64).reshape(shape)
