"""Fins on a vehicle: the fin wrench on a single body against the closed form, the compiled
kernels against the Pinocchio reference (1e-9), the control vector, and the one-line refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import single_body_urdf

import aiauv_pin
from aiauv_pin.errors import ArgumentError

FIN_BLOCK = """
    <fin name="rudder" link="hull" xyz="-0.4 0.02 0.05" axis="0 0 1" chord="1 0 0" area="0.01"
         lift_slope="3.0" drag_zero="0.01" drag_slope="1.2" stall_angle="0.4" max_angle="0.5"/>
    <fin name="plane" link="hull" xyz="-0.4 0.1 0" axis="0 0.6 0.8" chord="1 0 0" area="0.02"
         lift_slope="2.5" drag_slope="0.8" max_angle="0.3"/>
    <thruster name="prop" link="hull" xyz="-0.5 0 0" direction="1 0 0" max_thrust="50"/>
  </hydrodynamics>"""


def _finned_body(tmp_path, with_fins: bool = True):
    text, params = single_body_urdf()
    if with_fins:
        text = text.replace("\n  </hydrodynamics>", FIN_BLOCK)
    else:
        text = text.replace(
            "\n  </hydrodynamics>",
            '<thruster name="prop" link="hull" xyz="-0.5 0 0" direction="1 0 0" '
            'max_thrust="50"/>\n  </hydrodynamics>',
        )
    path = tmp_path / ("finned.urdf" if with_fins else "plain.urdf")
    path.write_text(text)
    return path, params


def _rudder_force(angle, v_point, rho):
    """The rudder's force by hand: span z, chord x; lift 0.5 rho A C_La alpha U^2 along z x v_p,
    drag 0.5 rho A (C_D0 + C_Da2 alpha^2) U^2 against v_p, stall at 0.4 rad."""
    vp = np.array([v_point[0], v_point[1], 0.0])
    speed = np.linalg.norm(vp)
    alpha = angle - math.atan2(vp[1], vp[0])
    alpha = max(-0.4, min(0.4, alpha)) if abs(alpha) <= math.pi / 2 else alpha
    lift_dir = np.cross([0, 0, 1.0], vp) / speed
    q = 0.5 * rho * 0.01 * speed**2
    return q * 3.0 * alpha * lift_dir - q * (0.01 + 1.2 * alpha**2) * vp / speed


def test_fin_wrench_on_a_single_body_matches_the_closed_form(tmp_path):
    """M (a_with_fins - a_without) = the fins' wrench (F, r x F) about the body origin."""
    finned = aiauv_pin.load_vehicle(_finned_body(tmp_path)[0], backend="pinocchio")
    plain = aiauv_pin.load_vehicle(_finned_body(tmp_path, False)[0], backend="pinocchio")
    rho = finned.hydro.fluid_density
    q = finned.neutral_configuration()
    v = np.array([1.2, 0.1, 0.05, 0.0, 0.0, 0.3])
    angles = np.array([0.15, 0.0])
    tau = np.zeros(6)
    extra = finned.mass_matrix(q) @ (
        finned.acceleration(q, v, tau, fin_angles=angles) - plain.acceleration(q, v, tau)
    )
    r1 = np.array([-0.4, 0.02, 0.05])
    f1 = _rudder_force(0.15, v[:3] + np.cross(v[3:], r1), rho)
    # the second fin (plane at zero angle) by the law itself, in its own frame
    from aiauv_hydro.laws.lift import fin_force

    r2 = np.array([-0.4, 0.1, 0.0])
    axis = np.array([0.0, 0.6, 0.8])
    v2 = v[:3] + np.cross(v[3:], r2)
    f2 = np.array(fin_force(0.0, *axis, 1, 0, 0, *v2, 0.5 * rho * 0.02, 2.5, 0.0, 0.8, math.inf))
    expected = np.concatenate((f1 + f2, np.cross(r1, f1) + np.cross(r2, f2)))
    np.testing.assert_allclose(extra, expected, rtol=1e-9, atol=1e-9)
    # zero relative speed: no fin force at any angle (the body drifts with the current)
    current = np.array([0.3, -0.2, 0.1])
    still = np.concatenate((current, np.zeros(3)))
    np.testing.assert_allclose(
        finned.acceleration(q, still, tau, current, fin_angles=[0.4, -0.3]),
        plain.acceleration(q, still, tau, current),
        atol=1e-12,
    )


def test_compiled_matches_reference(tmp_path, rng):
    path = _finned_body(tmp_path)[0]
    fast = aiauv_pin.load_vehicle(path)
    reference = aiauv_pin.load_vehicle(path, backend="pinocchio")
    assert fast.active_backend == "numba"
    worst = 0.0
    for _ in range(20):
        q = fast.neutral_configuration()
        q[:3] = rng.normal(size=3)
        quaternion = rng.normal(size=4)
        q[3:7] = quaternion / np.linalg.norm(quaternion)
        v = rng.normal(size=6) * [1.5, 0.4, 0.4, 0.5, 0.5, 0.5]
        tau = rng.normal(size=6)
        angles = rng.uniform(-0.5, 0.5, size=2)
        current = rng.normal(size=3) * 0.3
        a = fast.acceleration(q, v, tau, current, fin_angles=angles)
        b = reference.acceleration(q, v, tau, current, fin_angles=angles)
        worst = max(worst, float(np.max(np.abs(a - b))))
    assert worst < 1e-9


def test_controls_and_step(tmp_path):
    vehicle = aiauv_pin.load_vehicle(_finned_body(tmp_path)[0])
    assert vehicle.fin_names == ["rudder", "plane"]
    assert vehicle.n_controls == 1 + 2  # thrust, two fin angles, no joints
    np.testing.assert_array_equal(vehicle.max_fin_angle, [0.5, 0.3])
    q, v = vehicle.neutral_configuration(), np.array([1.0, 0, 0, 0, 0, 0])
    # the angle in a step is clipped to its limit: 0.9 rad acts as 0.5
    clipped = vehicle.step(q, v, [10.0, 0.9, 0.0], 0.01)
    limit = vehicle.step(q, v, [10.0, 0.5, 0.0], 0.01)
    np.testing.assert_array_equal(clipped[1], limit[1])
    # the step is the compiled RK4 of the acceleration with those angles held
    reference = aiauv_pin.load_vehicle(_finned_body(tmp_path)[0], backend="pinocchio")
    tau = vehicle.controls_to_forces(q, [10.0, 0.5, 0.0])
    dynamics = lambda qq, vv, tt: reference.acceleration(qq, vv, tau, fin_angles=[0.5, 0.0])  # noqa: E731
    q_ref, v_ref = aiauv_pin.rk4_step(reference.model, dynamics, q, v, 0.01, 0.0)
    np.testing.assert_allclose(limit[1], v_ref, atol=1e-9)
    np.testing.assert_allclose(limit[0], q_ref, atol=1e-9)


def test_refusals_are_one_line(tmp_path):
    vehicle = aiauv_pin.load_vehicle(_finned_body(tmp_path)[0])
    q, v = vehicle.neutral_configuration(), np.zeros(6)
    with pytest.raises(ArgumentError, match="fin"):
        vehicle.acceleration(q, v, np.zeros(6), fin_angles=[0.1])
    with pytest.raises(ArgumentError, match="no derivatives yet") as error:
        vehicle.acceleration_derivatives(q, v, np.zeros(6))
    assert "\n" not in str(error.value)
    # a Python controller cannot command the fins: they are held at zero angle (fixed surfaces)
    run = aiauv_pin.simulate(vehicle, q, v, 0.1, 0.01, lambda t, qq, vv: np.zeros(6))
    assert np.all(np.isfinite(run.q[-1]))
    plain = aiauv_pin.load_vehicle(_finned_body(tmp_path, False)[0])
    with pytest.raises(ArgumentError, match="fin_angles"):
        plain.acceleration(q, v, np.zeros(6), fin_angles=[0.1])


UUV_FIN_ON_ITS_LINK = """
  <link name="fin1"/>
  <joint name="fin1_joint" type="fixed">
    <origin xyz="-0.4 -0.04 0" rpy="1.5707963267948966 0 0"/>
    <parent link="hull"/><child link="fin1"/>
  </joint>
  <gazebo>
    <plugin name="fin1_model" filename="libuuv_fin_ros_plugin.so">
      <dynamics><type>FirstOrder</type><timeConstant>0.2</timeConstant></dynamics>
      <liftdrag><type>Quadratic</type><lift_constant>9.8688</lift_constant>
        <drag_constant>6.513408</drag_constant></liftdrag>
      <fin_id>1</fin_id><link_name>fin1</link_name><joint_name>fin1_joint</joint_name>
    </plugin>
  </gazebo>
</robot>"""


def test_uuv_fin_on_its_own_link_acts_as_the_same_fin_on_the_parent(tmp_path):
    """LAUV's fin 1 (lauv_gazebo actuators.xacro: origin -0.4 -0.04 0, rpy pi/2 0 0) on its own
    link behind a fixed joint equals our <fin> on the parent at the joint's pose: axis R z =
    (0, -1, 0), chord R x = (1, 0, 0)."""
    text, params = single_body_urdf()
    on_link = tmp_path / "on_link.urdf"
    on_link.write_text(text.replace("\n</robot>", UUV_FIN_ON_ITS_LINK))
    rho = params["rho"]
    on_parent = tmp_path / "on_parent.urdf"
    on_parent.write_text(
        text.replace(
            "\n  </hydrodynamics>",
            f'<fin name="fin1_model" link="hull" xyz="-0.4 -0.04 0" axis="0 -1 0" chord="1 0 0" '
            f'area="1" lift_slope="{2 * 9.8688 / rho!r}" drag_slope="{2 * 6.513408 / rho!r}" '
            f'max_angle="1.5707963267948966" time_constant="0.2"/>\n  </hydrodynamics>',
        )
    )
    a = aiauv_pin.load_vehicle(on_link)
    b = aiauv_pin.load_vehicle(on_parent)
    assert a.fin_names == b.fin_names == ["fin1_model"]
    q = a.neutral_configuration()
    v = np.array([1.0, 0.2, -0.3, 0.1, 0.2, -0.1])
    np.testing.assert_allclose(
        a.acceleration(q, v, np.zeros(6), fin_angles=[0.2]),
        b.acceleration(q, v, np.zeros(6), fin_angles=[0.2]),
        rtol=1e-12,
        atol=1e-12,
    )
