"""Large simulation logs in plain anonymous memory, without numpy's huge-page advice.

NumPy asks Linux for transparent huge pages on every array of 4 MiB or more
(``madvise(MADV_HUGEPAGE)``; numpy's ``NUMPY_MADVISE_HUGEPAGE``). With the kernel's usual
``/sys/kernel/mm/transparent_hugepage/defrag = madvise``, a page fault in such an array may
compact memory synchronously to find a free 2 MiB page: the first write to a rollout's fresh
log then costs several times the system time of ordinary pages (the figures are on the docs'
performance page), and the huge pages buy nothing for a log written once, row by row.
:func:`empty_log` gives the same C-ordered float64 array in an anonymous memory map (Python's
:mod:`mmap`), which numpy does not advise: the values written, and so the results, are
unchanged (a compiled run's trajectory is read from its log, views of its rows).

The map's pages are made present when it is created (``MAP_POPULATE``, mmap(2), where Python
offers it: Linux, Python 3.10 and later): one call of the kernel instead of a page fault at the
first write to each 4 KiB page, about 13,000 for the paper run's log.
"""

from __future__ import annotations

import math
import mmap

import numpy as np

#: Below this size [bytes] a log is an ordinary ``np.empty`` (numpy advises huge pages from 4 MiB).
MAPPED_FROM = 4 << 20


def _anonymous_map(nbytes: int) -> mmap.mmap:
    """A private anonymous map of ``nbytes``, its pages present (``MAP_POPULATE``) where offered."""
    populate = getattr(mmap, "MAP_POPULATE", 0)
    if populate and hasattr(mmap, "MAP_PRIVATE") and hasattr(mmap, "MAP_ANONYMOUS"):
        return mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | populate)
    return mmap.mmap(-1, nbytes)


def empty_log(shape: tuple[int, ...], *, zeroed: bool = False) -> np.ndarray:
    """An uninitialised (or, with ``zeroed``, zero) C-ordered float64 array of ``shape``: an
    ordinary NumPy array below :data:`MAPPED_FROM` bytes, else a view of an anonymous memory map
    (zero; freed with the last view of the array)."""
    size = 8 * math.prod(shape)
    if size < MAPPED_FROM:
        return np.zeros(shape) if zeroed else np.empty(shape)
    memory = _anonymous_map(size)
    return np.frombuffer(memory, dtype=np.float64, count=size // 8).reshape(shape)
