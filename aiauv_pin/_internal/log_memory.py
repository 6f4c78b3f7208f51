"""Large simulation logs in plain anonymous memory, without numpy's huge-page advice.

NumPy asks Linux for transparent huge pages on every array of 4 MiB or more
(``madvise(MADV_HUGEPAGE)``; numpy's ``NUMPY_MADVISE_HUGEPAGE``). With the kernel's usual
``/sys/kernel/mm/transparent_hugepage/defrag = madvise``, a page fault in such an array may
compact memory synchronously to find a free 2 MiB page: the first write to a rollout's fresh
log then costs several times the system time of ordinary pages (the figures are on the docs'
performance page), and the huge pages buy nothing for a log written once, row by row.
:func:`empty_log` gives the same C-ordered float64 array in an anonymous memory map (Python's
:mod:`mmap`), which numpy does not advise: the values written, and so the results, are
unchanged. :func:`empty_arrays` carves several such arrays out of one map (a run's trajectory,
copied out of its log).

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


#: Offsets of :func:`empty_arrays`' arrays in their map are multiples of this [bytes] (a cache line).
ALIGNMENT = 64


def _anonymous_map(nbytes: int) -> mmap.mmap:
    """A private anonymous map of ``nbytes``, its pages present (``MAP_POPULATE``) where offered."""
    populate = getattr(mmap, "MAP_POPULATE", 0)
    if populate and hasattr(mmap, "MAP_PRIVATE") and hasattr(mmap, "MAP_ANONYMOUS"):
        return mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | populate)
    return mmap.mmap(-1, nbytes)


def empty_log(shape: tuple[int, ...], *, zeroed: bool = False) -> np.ndarray:
    """An uninitialised (or, with ``zeroed``, zero) C-ordered float64 array of ``shape``, in an
    anonymous memory map when it is at least :data:`MAPPED_FROM` bytes (the map is freed with the
    last view of the array)."""
    return empty_arrays([shape], zeroed=zeroed)[0]


def empty_arrays(shapes: list[tuple[int, ...]], *, zeroed: bool = False) -> list[np.ndarray]:
    """Uninitialised C-ordered float64 arrays of ``shapes`` (zero with ``zeroed``): ordinary
    NumPy arrays when they hold less than :data:`MAPPED_FROM` bytes together, else consecutive
    parts of one anonymous memory map (zero, at offsets that are multiples of
    :data:`ALIGNMENT`; the map is freed with the last view of any of them)."""
    sizes = [8 * math.prod(shape) for shape in shapes]
    if sum(sizes) < MAPPED_FROM:
        return [np.zeros(shape) if zeroed else np.empty(shape) for shape in shapes]
    offsets, end = [], 0
    for size in sizes:
        offsets.append(end)
        end += -(-size // ALIGNMENT) * ALIGNMENT
    memory = _anonymous_map(max(end, 1))
    return [
        np.frombuffer(memory, dtype=np.float64, count=size // 8, offset=offset).reshape(shape)
        for shape, size, offset in zip(shapes, sizes, offsets, strict=True)
    ]
