"""The dynamics-consistency suite: one test per check of :mod:`aiauv_pin.checks.consistency`.

Collected by the ``aiauv`` pytest plugin when ``--aiauv-vehicle`` is given; each test is
parametrised over the vehicles (``test_energy_conserved[my_aiauv]``) and fails with one line giving
the measured figure and the tolerance.
"""

from __future__ import annotations

import pytest

from aiauv_pin.checks import consistency as checks
from aiauv_pin.testing import assert_check


@pytest.fixture(scope="session")
def aiauv_ideal_fluid_run(aiauv_vehicle, aiauv_seed):
    """The ideal-fluid run shared by the two conservation tests."""
    return checks.ideal_fluid_run(aiauv_vehicle, seed=aiauv_seed)


def test_mass_matrix_symmetric(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_mass_matrix_symmetric(aiauv_vehicle, seed=aiauv_seed))


def test_mass_matrix_positive_definite(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_mass_matrix_positive_definite(aiauv_vehicle, seed=aiauv_seed))


def test_added_mass_positive_semidefinite(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_added_mass_positive_semidefinite(aiauv_vehicle, seed=aiauv_seed))


def test_kinetic_energy(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_kinetic_energy(aiauv_vehicle, seed=aiauv_seed))


def test_aba_without_fluid(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_aba_without_fluid(aiauv_vehicle, seed=aiauv_seed))


def test_energy_conserved(aiauv_vehicle, aiauv_ideal_fluid_run, aiauv_seed):
    assert_check(
        checks.check_energy_conserved(aiauv_vehicle, run=aiauv_ideal_fluid_run, seed=aiauv_seed)
    )


def test_impulse_conserved(aiauv_vehicle, aiauv_ideal_fluid_run, aiauv_seed):
    assert_check(
        checks.check_impulse_conserved(aiauv_vehicle, run=aiauv_ideal_fluid_run, seed=aiauv_seed)
    )


def test_damping_dissipates(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_damping_dissipates(aiauv_vehicle, seed=aiauv_seed))


def test_energy_decays(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_energy_decays(aiauv_vehicle, seed=aiauv_seed))


def test_power_balance(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_power_balance(aiauv_vehicle, seed=aiauv_seed))


def test_hydrostatics(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_hydrostatics(aiauv_vehicle, seed=aiauv_seed))


def test_invariance(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_invariance(aiauv_vehicle, seed=aiauv_seed))


def test_backends_agree(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_backends_agree(aiauv_vehicle, seed=aiauv_seed))


def test_thrusters(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_thrusters(aiauv_vehicle, seed=aiauv_seed))


def test_unsteady_flow(aiauv_vehicle, aiauv_seed):
    assert_check(checks.check_unsteady_flow(aiauv_vehicle, seed=aiauv_seed))
