"""aiauv_pin._internal.log_memory: large logs and trajectories in anonymous maps, small ones as
ordinary arrays."""

from __future__ import annotations

import itertools
import mmap

import numpy as np

from aiauv_pin._internal.log_memory import ALIGNMENT, MAPPED_FROM, empty_arrays, empty_log


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


def test_arrays_share_one_map_at_aligned_offsets_and_logs_for_a_reader_are_zero():
    shapes = [(MAPPED_FROM // 8,), (3, 5), (7,), (2, 2, 2)]
    arrays = empty_arrays(shapes)
    assert [a.shape for a in arrays] == shapes
    memory = arrays[0].base.base.obj
    assert isinstance(memory, mmap.mmap)
    addresses = [a.__array_interface__["data"][0] for a in arrays]
    assert all(a.base.base.obj is memory for a in arrays)
    assert all(address % ALIGNMENT == 0 for address in addresses)
    for a, b in itertools.pairwise(arrays):  # consecutive, not overlapping
        assert a.__array_interface__["data"][0] + a.nbytes <= b.__array_interface__["data"][0]
    assert all(np.count_nonzero(a) == 0 for a in arrays)  # an anonymous map is zero
    assert np.count_nonzero(empty_log((3, 4), zeroed=True)) == 0
    small = empty_arrays([(2, 3), (4,)])
    assert [a.shape for a in small] == [(2, 3), (4,)] and all(a.flags.owndata for a in small)
