"""Numbers as the command line prints them."""

from __future__ import annotations


def signed(value: float, digits: int = 2) -> str:
    """``value`` with its sign and ``digits`` decimals, ``+0.00`` for whatever rounds to zero.

    A quantity that is zero up to rounding errors (a symmetric vehicle's trim, a converged
    cross-track error) would otherwise print as ``-0.00`` or ``+0.00`` by the sign of an error of
    1e-15, which depends on the platform's libraries (the paper vehicle's pitch is 5.2e-15 rad with
    the wheels of Python 3.11, ``-0.0`` with those of 3.13). Python 3.11's ``z`` format option does
    the same, but 3.10 is supported.
    """
    return f"{round(value, digits) + 0.0:+.{digits}f}"
