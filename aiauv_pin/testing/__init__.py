"""Pytest support: the dynamics-consistency suite for the user's own vehicles.

Installed with the package as the pytest plugin ``aiauv`` (entry point ``pytest11``):

    pytest --aiauv-vehicle my_aiauv.urdf [--aiauv-vehicle other.urdf ...] [--aiauv-seed N]

runs :mod:`aiauv_pin.testing.suite` (every check of :mod:`aiauv_pin.checks.consistency`) on each vehicle,
with test ids such as ``test_energy_conserved[my_aiauv]`` (the URDF's robot name, else the file
stem). Without ``--aiauv-vehicle`` the plugin does nothing. In your own tests, request the
``aiauv_vehicle`` fixture (parametrised over the ``--aiauv-vehicle`` files) or call the checks
directly and :func:`assert_check` their results.
"""

from __future__ import annotations

import warnings

from aiauv_pin.checks.consistency import CheckResult


class ConsistencyWarning(UserWarning):
    """A consistency check's warning (e.g. the vehicle is not neutrally buoyant)."""


def assert_check(result: CheckResult) -> CheckResult:
    """Fail (or skip) the calling pytest test as ``result`` says; emit its warnings.

    The failure message is one line with the measured figure and the tolerance.
    """
    import pytest

    for text in result.warnings:
        warnings.warn(ConsistencyWarning(f"{result.name}: {text}"), stacklevel=2)
    if result.skipped:
        pytest.skip(result.message())
    if not result.passed:
        pytest.fail(result.message(), pytrace=False)
    return result


__all__ = ["ConsistencyWarning", "assert_check"]
