"""The compiled exact sum (aiauv_pin.kernels.summation) against math.fsum, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_pin.errors import ArgumentError
from aiauv_pin.kernels.summation import PARTIALS, exact_partials, exact_sum_compiled
from aiauv_pin.simulation.energy import exact_column_sums, exact_sum


def cases():
    rng = np.random.default_rng(11)
    yield rng.normal(size=75_000)  # a log's integrand
    yield rng.normal(size=10_000) * 10.0 ** rng.integers(-300, 300, size=10_000)  # all exponents
    # cancellation: the naive sum is 0, the exact one 2
    yield np.array([1e16, 1.0, -1e16, 1.0] * 1000)
    # halfway cases of the final rounding (math.fsum's correction step)
    yield np.array([1.0, 1e-16, 1e-16 * 0.5**53] * 500)
    yield np.concatenate((np.full(500, 0.1), np.full(500, -0.1), [2.0**-1074] * 100))
    yield np.array([1e308, 1e308, -1e308] * 30)  # finite total, overflowing intermediate: fallback


@pytest.mark.parametrize("index", range(6))
def test_compiled_sum_is_math_fsum_bit_for_bit(index):
    values = list(cases())[index]
    try:
        expected = math.fsum(values.tolist())
    except OverflowError:
        with pytest.raises(OverflowError):
            exact_sum_compiled(values)
        return
    got = exact_sum_compiled(values)
    assert got == expected and math.copysign(1.0, got) == math.copysign(1.0, expected)
    assert exact_sum(values) == expected
    assert exact_sum(values.reshape(-1, 2) if values.size % 2 == 0 else values) == expected


def test_the_partials_sum_exactly_to_the_values():
    values = np.array([3.0, 1e-30, -3.0, 2.0**60, 1.0, -(2.0**60)])
    partials = np.empty(PARTIALS)
    n = exact_partials(values, partials)
    assert 0 < n <= PARTIALS
    assert math.fsum(partials[:n].tolist()) == 1.0 + 1e-30 == math.fsum(values.tolist())


@pytest.mark.parametrize(
    ("values", "expected"), [([1.0, math.inf], math.inf), ([math.nan, 1.0], math.nan)]
)
def test_non_finite_values_give_what_fsum_gives(values, expected):
    array = np.array(values * 100)
    got = exact_sum_compiled(array)
    assert (math.isnan(got) and math.isnan(expected)) or got == expected
    with pytest.raises(ValueError):  # inf - inf: math.fsum's own error
        exact_sum_compiled(np.array([math.inf, -math.inf] * 100))


@pytest.mark.parametrize("index", range(6))
@pytest.mark.parametrize("columns", [1, 3, 8])
def test_column_sums_are_the_exact_sums_of_the_columns_and_of_the_whole(index, columns):
    values = list(cases())[index]
    rows = values.size // columns
    table = values[: rows * columns].reshape(rows, columns)
    try:
        expected_total = math.fsum(table.ravel().tolist())
    except OverflowError:
        with pytest.raises(OverflowError):
            exact_column_sums(table)
        return
    each, total = exact_column_sums(table)
    assert total == expected_total and math.copysign(1.0, total) == math.copysign(
        1.0, expected_total
    )
    assert each == [math.fsum(table[:, k].tolist()) for k in range(columns)]


def test_column_sums_of_a_table_with_a_non_finite_value_follow_math_fsum():
    table = np.ones((100, 3))
    table[50, 1] = np.inf
    each, total = exact_column_sums(table)
    assert each == [100.0, math.inf, 100.0] and total == math.inf
    with pytest.raises(ArgumentError, match="2-D"):
        exact_column_sums(np.ones(5))
