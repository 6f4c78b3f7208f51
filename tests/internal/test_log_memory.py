"""aiauv_pin._internal.log_memory: large logs in anonymous maps, small ones as ordinary arrays."""

from __future__ import annotations

import mmap

import numpy as np

from aiauv_pin._internal.log_memory import MAPPED_FROM, empty_log


def test_large_log_is_a_writable_c_ordered_map():
    rows = MAPPED_FROM // (8 * 10) + 1
    log = empty_log((2, rows, 10))
    assert log.shape == (2, rows, 10) and log.dtype == np.float64
    assert log.flags.c_contiguous and log.flags.writeable and log.flags.aligned
    assert isinstance(log.base.base.obj, mmap.mmap)  # reshape view -> frombuffer -> memoryview
    log[1, -1, -1] = 2.5
    view = log[1, :, 3:]  # views keep the map alive
    del log
    assert view[-1, -1] == 2.5


def test_small_log_is_an_ordinary_array():
    log = empty_log((3, 4))
    assert log.shape == (3, 4) and log.flags.owndata


def test_logs_for_a_reader_are_zero():
    large = empty_log((MAPPED_FROM // 8,))
    assert isinstance(large.base.base.obj, mmap.mmap)
    assert np.count_nonzero(large) == 0  # an anonymous map is zero
    assert np.count_nonzero(empty_log((MAPPED_FROM // 8,), zeroed=True)) == 0
    assert np.count_nonzero(empty_log((3, 4), zeroed=True)) == 0
