"""Argument types and the one-line-error parser shared by the ``aiauv`` commands.

Its own module so that subcommands defined elsewhere (:mod:`aiauv_pin.bench`) use them without
importing :mod:`aiauv_pin.cli`, which imports them (no import cycle).
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


def positive_seconds(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got '{text}'")
    return value


def finite_number(text: str) -> float:
    """argparse type for one component of a vector flag: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got '{text}'")
    return value
