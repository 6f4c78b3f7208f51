"""The energy model (aiauv_pin.simulation.energy): closed forms and a hand-computed run."""

import math

import numpy as np
import pytest

from aiauv_pin.errors import ArgumentError
from aiauv_pin.simulation.energy import EnergyParameters, joint_power, run_energy, thruster_power


def test_thruster_power_closed_form():
    p = EnergyParameters(fluid_density=1000.0, propeller_diameter=0.1, thruster_efficiency=0.5)
    area = math.pi * 0.1**2 / 4.0
    for thrust in (1.0, 20.0, 50.0):
        expected = thrust**1.5 / math.sqrt(2.0 * 1000.0 * area) / 0.5
        assert thruster_power(thrust, p) == pytest.approx(expected, rel=1e-14)
        assert thruster_power(-thrust, p) == pytest.approx(expected, rel=1e-14)  # reverse thrust
    assert thruster_power(0.0, p) == 0.0


def test_default_thruster_matches_its_source():
    """T200-like defaults: about 50 N for about 390 W (the docstring's source)."""
    assert thruster_power(50.0) == pytest.approx(390.0, rel=0.01)


def test_joint_power_closed_form():
    p = EnergyParameters(
        joint_torque_constant=0.05, joint_gear_ratio=50.0, joint_winding_resistance=2.0
    )
    # driving: tau q_dot > 0 counts, plus R i^2 with i = 10 / (0.05 * 50) = 4 A
    assert joint_power(10.0, 0.3, p) == pytest.approx(3.0 + 2.0 * 16.0, rel=1e-14)
    # driven by the water (tau q_dot < 0): copper losses only
    assert joint_power(10.0, -0.3, p) == pytest.approx(32.0, rel=1e-14)
    assert joint_power(0.0, 1.0, p) == 0.0


def test_run_energy_hand_computed():
    """Two thrusters and one joint, three samples 0.5 s apart, each held over its step."""
    p = EnergyParameters(
        fluid_density=1000.0,
        propeller_diameter=math.sqrt(4.0 / (math.pi * 2000.0)),  # 2 rho A = 1
        thruster_efficiency=1.0,
        joint_torque_constant=1.0,
        joint_gear_ratio=1.0,
        joint_winding_resistance=1.0,
    )
    t = [0.0, 0.5, 1.0]
    thrust = [[4.0, 0.0], [1.0, -9.0], [100.0, 100.0]]  # the last sample is not held
    torque = [[2.0], [1.0], [5.0]]
    rate = [[1.0], [-3.0], [5.0]]
    s = [0.0, 0.2, 0.5]
    e = run_energy(t, thrust, torque, rate, s, p)
    assert e.thrusters == pytest.approx(0.5 * 8.0 + 0.5 * (1.0 + 27.0), rel=1e-14)
    assert e.joints == pytest.approx(0.5 * (2.0 + 4.0) + 0.5 * (0.0 + 1.0), rel=1e-14)
    assert e.total == pytest.approx(e.thrusters + e.joints)
    assert e.distance == pytest.approx(0.5)
    assert e.per_metre == pytest.approx(e.total / 0.5)


def test_zero_input_zero_energy_and_no_progress():
    e = run_energy(np.arange(4.0), np.zeros((4, 7)), np.zeros((4, 8)), np.ones((4, 8)), np.zeros(4))
    assert e.total == 0.0 and e.per_metre is None


@pytest.mark.parametrize("name", ["fluid_density", "propeller_diameter", "thruster_efficiency"])
def test_non_physical_parameters(name):
    with pytest.raises(ArgumentError, match=name):  # (a ValueError too)
        EnergyParameters(**{name: 0.0})
    with pytest.raises(ArgumentError, match="thruster_efficiency"):
        EnergyParameters(thruster_efficiency=1.5)
    with pytest.raises(ArgumentError, match="joint_winding_resistance"):
        EnergyParameters(joint_winding_resistance=-1.0)
