"""Argument types and the one-line-error parser shared by the ``aiauv`` commands.

Its own module so that subcommands defined elsewhere (:mod:`aiauv_pin.tools.bench_command`) use them without
importing :mod:`aiauv_pin.app.cli`, which imports them (no import cycle).
"""

from __future__ import annotations

import argparse
import math

EXIT_USAGE = 2
EXIT_FAILED = 1


class OneLineArgumentParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on standard error (exit status 2)."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {' '.join(message.split())}\n")


def positive(what: str):
    """An argparse type accepting a finite number > 0; ``what`` names it in the error."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"must be a positive {what}, got '{text}'")
        return value

    parse.__name__ = f"positive {what}"
    return parse


#: argparse type: a duration or step [s] (a finite number > 0).
positive_seconds = positive("number of seconds")
#: argparse type: a fluid density [kg/m^3] (a finite number > 0).
positive_density = positive("density in kg/m^3")


def finite_number(text: str) -> float:
    """argparse type for one component of a vector flag: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got '{text}'")
    return value


def filter_coefficient(text: str) -> float:
    """argparse type for a first-order filter's coefficient: a number in ``(0, 1]``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(value) and 0.0 < value <= 1.0):
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got '{text}'")
    return value
