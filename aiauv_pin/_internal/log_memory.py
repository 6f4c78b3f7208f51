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
import os

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


class SharedLog:
    """A compiled run's log in memory that a process forked beforehand reads too (Linux).

    The memory is an anonymous file (``memfd_create(2)``) made before the fork, so that both
    processes hold it; :meth:`empty` sizes it and maps it shared (``MAP_SHARED``) in this process
    (give it as :func:`aiauv_pin.simulate`'s ``log_memory``), and the other process maps the
    same pages with :meth:`view` once the run is over: nothing of the log is copied between them.
    :meth:`reference` names an array that lies in the log by its place in the file, which
    :meth:`view` turns back into an array. One log per :class:`SharedLog`.
    """

    def __init__(self) -> None:
        self.fd = os.memfd_create("aiauv-log", getattr(os, "MFD_CLOEXEC", 0))
        self._map: mmap.mmap | None = None
        self._address = 0
        self._size = 0

    @staticmethod
    def available() -> bool:
        """Whether this system has anonymous files and shared maps (Linux)."""
        return hasattr(os, "memfd_create") and hasattr(mmap, "MAP_SHARED")

    def _mapped(self) -> np.ndarray:
        size = os.fstat(self.fd).st_size
        flags = mmap.MAP_SHARED | getattr(mmap, "MAP_POPULATE", 0)
        self._map = mmap.mmap(self.fd, size, flags=flags)
        array = np.frombuffer(self._map, dtype=np.float64, count=size // 8)
        self._address, self._size = array.__array_interface__["data"][0], size
        return array

    def empty(self, shape: tuple[int, ...]) -> np.ndarray:
        """The log: a zero C-ordered float64 array of ``shape`` in the shared file."""
        if self._map is not None:
            raise RuntimeError("a SharedLog holds one log")
        size = 8 * math.prod(shape)
        os.ftruncate(self.fd, max(size, 8))  # zero; a map needs at least one byte
        return self._mapped()[: math.prod(shape)].reshape(shape)

    def reference(self, array: np.ndarray) -> tuple | None:
        """``("log", offset [bytes], shape, strides)`` of a float64 ``array`` that lies in the
        log, else ``None``."""
        if self._map is None or type(array) is not np.ndarray or array.dtype != np.float64:
            return None
        start = array.__array_interface__["data"][0] - self._address
        if array.size == 0 or not 0 <= start < self._size:
            return None
        extent = [(n - 1) * stride for n, stride in zip(array.shape, array.strides, strict=True)]
        low = start + sum(e for e in extent if e < 0)
        high = start + sum(e for e in extent if e > 0) + array.itemsize
        if low < 0 or high > self._size:
            return None
        return ("log", start, array.shape, array.strides)

    def view(self, reference: tuple) -> np.ndarray:
        """The array :meth:`reference` named, in this process's map of the log (made at the
        first call, once the run that wrote it has sized the file)."""
        base = self._mapped() if self._map is None else np.frombuffer(self._map, np.float64)
        _, start, shape, strides = reference
        return np.ndarray(shape, np.float64, buffer=base, offset=start, strides=strides)

    def close(self) -> None:
        """Close the file (the maps, and so the arrays, stay valid)."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1
