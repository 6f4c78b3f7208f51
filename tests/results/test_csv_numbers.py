"""The numbers of ``timeseries.csv`` (:func:`aiauv_pin.results.outputs.format_rows`): each the
shortest text that reads back to the same float, checked against Python's ``repr`` on random bit
patterns of every exponent, the extremes, and values that are not finite."""

import numpy as np
import pytest

from aiauv_pin.results import outputs


def _digits(text: str) -> str:
    """The significant digits of a number's text (no sign, point, exponent or outer zeros)."""
    mantissa = text.partition("e")[0].lstrip("-").replace(".", "")
    return mantissa.strip("0") or "0"


def _cells(text: str) -> list[str]:
    assert text.endswith("\n")
    return [cell for line in text[:-1].split("\n") for cell in line.split(",")]


def _random_finite(rng, shape) -> np.ndarray:
    """Finite doubles drawn as random 64-bit patterns (every exponent, subnormals, both signs)."""
    values = rng.integers(0, 2**64, size=shape, dtype=np.uint64, endpoint=False).view(np.float64)
    return np.where(np.isfinite(values), values, 1.0)


@pytest.mark.parametrize("seed", range(3))
def test_every_number_reads_back_bit_for_bit_with_the_digits_of_repr(seed):
    rng = np.random.default_rng(seed)
    table = _random_finite(rng, (4000, 13))
    # and the magnitudes a simulation logs, where the style of the text changes
    scale = 10.0 ** rng.integers(-12, 18, size=(4000, 13))
    table = np.concatenate([table, rng.uniform(-10.0, 10.0, size=(4000, 13)) * scale])
    cells = _cells(outputs.format_rows(table))
    values = table.ravel().tolist()
    assert len(cells) == len(values)
    read = np.array([float(cell) for cell in cells])
    np.testing.assert_array_equal(read.view(np.uint64), table.ravel().view(np.uint64))
    assert [_digits(cell) for cell in cells] == [_digits(repr(x)) for x in values]


def test_the_extremes_and_zeros():
    extremes = [
        0.0,
        -0.0,
        5e-324,
        -5e-324,
        2.2250738585072014e-308,
        1.7976931348623157e308,
        -1.7976931348623157e308,
        1e-5,
        9.999999999999999e-05,
        1e16,
        9007199254740993.0,
        0.1,
        1.0,
        300.0,
    ]
    cells = _cells(outputs.format_rows(np.array([extremes])))
    assert cells[:2] == ["0.0", "-0.0"]
    assert [float(cell) for cell in cells] == extremes
    assert np.signbit(float(cells[1]))
    assert cells[-4:] == ["9007199254740992.0", "0.1", "1.0", "300.0"]


def test_values_that_are_not_finite_are_written_as_python_reads_them():
    table = np.array([[0.5, 1e-7], [np.nan, 2.0], [np.inf, -np.inf], [0.25, 3e-300]])
    text = outputs.format_rows(table)
    assert text.split("\n")[1:3] == ["nan,2.0", "inf,-inf"]
    read = np.array([[float(cell) for cell in line.split(",")] for line in text.split()])
    np.testing.assert_array_equal(read, table)
    # the finite rows around them are the text of those rows alone
    assert text.split("\n")[0] + "\n" == outputs.format_rows(table[:1])
    assert text.split("\n")[3] + "\n" == outputs.format_rows(table[3:])


def test_blocks_of_rows_joined_are_the_whole_table():
    rng = np.random.default_rng(7)
    table = rng.normal(size=(50, 6)) * 1e-6
    table[20, 3] = np.nan
    whole = outputs.format_rows(table)
    assert whole == "".join(outputs.format_rows(table[k : k + 7]) for k in range(0, 50, 7))
    assert whole.count("\n") == 50


def test_shapes_at_the_boundary():
    assert outputs.format_rows(np.zeros((0, 4))) == ""
    assert outputs.format_rows(np.zeros((2, 0))) == "\n\n"
    assert outputs.format_rows(np.arange(6).reshape(2, 3)) == "0.0,1.0,2.0\n3.0,4.0,5.0\n"
    strided = np.arange(12.0).reshape(3, 4)[:, ::2]  # not C-ordered
    assert outputs.format_rows(strided) == "0.0,2.0\n4.0,6.0\n8.0,10.0\n"
    with pytest.raises(ValueError, match="2-D table"):
        outputs.format_rows(np.zeros(3))
