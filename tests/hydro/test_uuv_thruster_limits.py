"""Thrust limits of UUV Simulator thruster plugins (aiauv_hydro.urdf.uuv_simulator.steady_thrust,
thrust_limits) against the plugin's own formula (ThrusterPlugin.cc, ``Update``, lines 213-236 of
uuv_gazebo_plugins at commit bfb40cb): RexROV's thrusters as published have no limit at all, with
the limit of UUV Simulator's thruster manager (2000 N) they reach it at a rotor speed of
sqrt(2000 / 0.00031) rad/s."""

from __future__ import annotations

import math
from xml.etree.ElementTree import fromstring

import numpy as np
import pytest

from aiauv_hydro import HydroError
from aiauv_hydro.urdf.uuv_simulator import steady_thrust, thrust_limits

#: RexROV's thruster plugin as its xacro expands it (uuv_descriptions/urdf/rexrov_actuators.xacro,
#: thruster_macro: rotor_constant 0.00031, dyn_time_constant 0.05; thruster_snippets.xacro).
REXROV_PLUGIN = """
<plugin name="rexrov_0_thruster_model" filename="libuuv_thruster_ros_plugin.so">
  <linkName>rexrov/thruster_0</linkName><jointName>rexrov/thruster_0_joint</jointName>
  <thrusterID>0</thrusterID>
  <dynamics><type>FirstOrder</type><timeConstant>0.05</timeConstant></dynamics>
  <conversion><type>Basic</type><rotorConstant>0.00031</rotorConstant></conversion>
  {extra}
</plugin>"""


def _plugin(extra: str = ""):
    return fromstring(REXROV_PLUGIN.format(extra=extra))


def _formula(
    command,
    k,
    gain=1.0,
    eta_p=1.0,
    eta_t=1.0,
    clamp=(-math.inf, math.inf),
    bounds=(-math.inf, math.inf),
):
    """ThrusterPlugin.cc l. 213-236 with the Basic conversion, written out by hand."""
    x = gain * min(max(command, clamp[0]), clamp[1]) * eta_p
    return min(max(eta_t * k * x * abs(x), bounds[0]), bounds[1])


def test_rexrov_as_published_has_no_limit():
    plugin = _plugin()
    assert thrust_limits(plugin, "rexrov") == (math.inf, math.inf)
    for w in (-3000.0, -10.0, 0.0, 25.0, 2540.0, 1e5):
        assert steady_thrust(plugin, w, "rexrov") == pytest.approx(_formula(w, 0.00031), rel=1e-15)


def test_rexrov_with_the_thruster_managers_limit():
    plugin = _plugin("<thrustMin>-2000.0</thrustMin><thrustMax>2000.0</thrustMax>")
    assert thrust_limits(plugin, "rexrov") == (2000.0, 2000.0)
    speed = math.sqrt(2000.0 / 0.00031)  # [rad/s] where the limit is reached: 2540 rad/s
    assert steady_thrust(plugin, speed, "rexrov") == pytest.approx(2000.0, rel=1e-12)
    assert steady_thrust(plugin, 2.0 * speed, "rexrov") == 2000.0
    assert steady_thrust(plugin, -2.0 * speed, "rexrov") == -2000.0
    assert steady_thrust(plugin, 0.5 * speed, "rexrov") == pytest.approx(500.0, rel=1e-12)


@pytest.mark.parametrize(
    ("extra", "options"),
    [
        # the clamp on the rotor command through gain and efficiencies
        (
            "<clampMin>-8</clampMin><clampMax>10</clampMax><gain>40</gain>"
            "<propeller_efficiency>0.9</propeller_efficiency>"
            "<thrust_efficiency>0.8</thrust_efficiency>",
            {"gain": 40.0, "eta_p": 0.9, "eta_t": 0.8, "clamp": (-8.0, 10.0)},
        ),
        # the clamp, then the thrust bounds below it
        (
            "<clampMin>-10</clampMin><clampMax>10</clampMax><gain>300</gain>"
            "<thrustMin>-20</thrustMin><thrustMax>30</thrustMax>",
            {"gain": 300.0, "clamp": (-10.0, 10.0), "bounds": (-20.0, 30.0)},
        ),
        # inverted pairs fall back to no bound (l. 117-122, 131-136); efficiencies outside
        # [0, 1] are 1 (l. 145-161)
        (
            "<clampMin>5</clampMin><clampMax>5</clampMax><thrustMin>-1</thrustMin>"
            "<thrustMax>40</thrustMax><thrust_efficiency>1.5</thrust_efficiency>",
            {"bounds": (-1.0, 40.0)},
        ),
    ],
)
def test_limits_are_the_plugins_extremes(extra, options):
    plugin = _plugin(extra)
    commands = np.linspace(-1e4, 1e4, 40001)
    thrusts = np.array([steady_thrust(plugin, c, "t") for c in commands])
    expected = np.array([_formula(c, 0.00031, **options) for c in commands])
    np.testing.assert_allclose(thrusts, expected, rtol=1e-14, atol=0.0)
    forward, backward = thrust_limits(plugin, "t")
    assert forward == pytest.approx(thrusts.max(), rel=1e-14)
    assert backward == pytest.approx(-thrusts.min(), rel=1e-14)


def test_a_missing_conversion_is_one_line():
    plugin = fromstring("<plugin><linkName>a</linkName><thrustMax>1</thrustMax></plugin>")
    with pytest.raises(HydroError, match="missing <conversion>") as caught:
        thrust_limits(plugin, "UUV Simulator thruster 'a'")
    assert "\n" not in str(caught.value)
