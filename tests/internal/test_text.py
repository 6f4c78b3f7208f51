"""Numbers as the command line prints them (:mod:`aiauv_pin._internal.text`)."""

from __future__ import annotations

import pytest

from aiauv_pin._internal.text import signed


@pytest.mark.parametrize(
    ("value", "digits", "text"),
    [
        (-1e-5, 4, "+0.0000"),  # a converged cross-track error of either sign: "-0.0000" before
        (-0.0, 2, "+0.00"),
        (4e-18, 2, "+0.00"),
        (-0.00006, 4, "-0.0001"),
        (0.5, 2, "+0.50"),
        (-1.236, 2, "-1.24"),
    ],
)
def test_signed_prints_what_rounds_to_zero_as_plus_zero(value, digits, text):
    assert signed(value, digits) == text
