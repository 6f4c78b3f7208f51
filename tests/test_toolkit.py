"""Toolkit core (issue 12): scenario files, any path, currents, disturbances, user controllers.

Physics is checked against closed forms and symmetries: a free body under a sinusoidal wrench, the
rotational symmetry of the paper scenario about the vertical, a passive vehicle carried by a
current, and both backends on time- and space-varying currents and on a crossflow cylinder whose
frame is rotated from its link frame.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import random_state

import aiauv_pin
from aiauv_control.paths import LinePath
from aiauv_hydro.currents import Current
from aiauv_hydro.numerics.jit import _project_files, compiled_sources, source_hash
from aiauv_hydro.waves import Waves
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.kernels.disturbances import Disturbance
from aiauv_pin.scenario.definition import Scenario, run_scenario
from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario, scenario_from_mapping

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))


# ---------------------------------------------------------------------- scenario files
@pytest.mark.parametrize(
    "path", [p for p in EXAMPLES if "sweep" not in p.name], ids=lambda p: p.stem
)
def test_example_scenarios_load(path):
    scenario = load_scenario(path)
    assert scenario.duration > 0 and scenario.path_to_follow is not None


def test_issue_keys_work_as_written():
    table = {
        "case": "uniform",
        "duration": 120.0,
        "dt": 0.01,
        "method": "rk4",
        "start": {"position": [0.0, 2.0, 2.0], "heading": [1.0, 0.0, 0.0]},
        "path": {"type": "line", "point": [0.0, 0.0, 0.0], "direction": [1.0, 0.0, 0.0]},
        "current": {"velocity": [0.0, 0.0, 0.0]},
        "controller": {"type": "paper", "k_d": 12.0},
    }
    scenario = scenario_from_mapping(table)
    assert scenario.on_x_axis and scenario.controller_gains.k_d == 12.0
    assert scenario.start.tolist() == [0.0, 2.0, 2.0] and scenario.water.is_zero


@pytest.mark.parametrize(
    "table, message",
    [
        ({"durations": 3.0}, "durations: unknown key"),
        ({"duration": "long"}, "duration: expected a number"),
        ({"duration": -1.0}, "duration: expected a number in (0, 1e5], got -1.0"),
        ({"method": "rk45"}, "method: expected one of rk4, euler"),
        (
            {"path": {"type": "line", "point": [0, 0, 0], "direction": [0, 0, 0]}},
            "path.line.direction: zero vector",
        ),
        ({"path": {"type": "line", "direction": [1, 0, 0]}}, "path.line.point: missing"),
        (
            {
                "path": {
                    "type": "helix",
                    "centre": [0, 0, 0],
                    "axis": [0, 0, 1],
                    "radius": 0.0,
                    "pitch": 1,
                }
            },
            "path.helix.radius",
        ),
        ({"path": {"type": "spiral"}}, "path.type"),
        ({"start": {"position": [0, 1]}}, "start.position: expected a list of 3 numbers"),
        ({"start": {"heading": [0, 0, 0]}}, "start.heading: zero vector"),
        ({"start": {"speed": 1.0}}, "start.speed: unknown key"),
        ({"current": {"velocity": [0, "a", 0]}}, "current.constant.velocity[1]: expected a number"),
        ({"controller": {"type": "pid"}}, "controller.type"),
        ({"controller": {"k_d": -1.0}}, "controller.k_d: expected a number in (0, 1e4]"),
        ({"controller": {"kd": 1.0}}, "controller.kd: unknown key"),
    ],
)
def test_bad_scenarios_get_one_line_naming_the_key(table, message):
    with pytest.raises(ScenarioFileError) as error:
        scenario_from_mapping(table)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_bad_toml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("duration = \n")
    with pytest.raises(ScenarioFileError, match="not valid TOML"):
        load_scenario(bad)
    with pytest.raises(ScenarioFileError, match="not a regular file"):
        load_scenario(tmp_path / "missing.toml")


# ---------------------------------------------------------------------- paths, symmetry
def _yawed(scenario: Scenario, angle: float) -> Scenario:
    c, s = math.cos(angle), math.sin(angle)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return dataclasses.replace(
        scenario,
        path=LinePath(point=(0.0, 0.0, 0.0), direction=tuple(rz @ [1.0, 0.0, 0.0])),
        start_position=tuple(rz @ scenario.start),
    )


def test_line_in_any_horizontal_direction_is_the_x_axis_rotated():
    """Gravity is vertical, so the paper's run rotated about z is the same run (to rounding)."""
    vehicle = aiauv_pin.load_vehicle()
    base = Scenario(duration=20.0)
    reference = run_scenario(vehicle, base).trajectory
    rotated = run_scenario(vehicle, _yawed(base, 2.1)).trajectory
    np.testing.assert_allclose(
        rotated.info["cross_track"], reference.info["cross_track"], rtol=0, atol=1e-6
    )
    np.testing.assert_allclose(rotated.info["phi_tilde"], reference.info["phi_tilde"], atol=1e-6)
    np.testing.assert_allclose(rotated.q[:, 7:], reference.q[:, 7:], atol=1e-6)


@pytest.mark.slow
def test_inclined_line_converges_like_the_x_axis():
    scenario = load_scenario(ROOT / "examples" / "line_diagonal.toml")
    result = run_scenario(aiauv_pin.load_vehicle(), dataclasses.replace(scenario, duration=200.0))
    summary = aiauv_pin.scenario.definition.summary(result)
    assert summary["final"]["cross_track_error"] < 0.01
    assert summary["settling_time"]["cross_track_5cm"] < 150.0  # 112.3 s; the x-axis case 113.1 s


# ---------------------------------------------------------------------- currents
def _custom_vehicle(tmp_path) -> aiauv_pin.Vehicle:
    from aiauv_pin.builders.urdf_builder import build_urdf
    from aiauv_pin.builders.vehicle_spec import spec_from_dict

    table = {
        "name": "custom5",
        "radius": 0.07,
        "fluid_density": 1025.0,
        "module": [
            {"name": f"m{i}", "length": 0.4 + 0.1 * i, "mass": 8.0 + i, "joint": "zy"[i % 2]}
            for i in range(4)
        ]
        + [{"name": "head", "length": 0.3, "mass": 5.0}],
    }
    path = tmp_path / "custom.urdf"
    path.write_text(build_urdf(spec_from_dict(table)))
    return aiauv_pin.load_vehicle(path)


def test_passive_custom_vehicle_drifts_with_the_current(tmp_path):
    vehicle = _custom_vehicle(tmp_path)
    scenario = Scenario(
        duration=80.0, controller="none", current=(0.0, 0.2, 0.0), vehicle=str(vehicle.urdf_path)
    )
    trajectory = run_scenario(vehicle, scenario).trajectory
    q, v = trajectory.q[-1], trajectory.v[-1]
    rotation = vehicle.frame_placement(q, vehicle.model.frames[2].name).rotation
    velocity_in_world = vehicle.frame_placement(q, vehicle.model.frames[2].name).rotation @ v[:3]
    assert rotation is not None
    np.testing.assert_allclose(velocity_in_world, [0.0, 0.2, 0.0], atol=2e-3)
    drift = trajectory.info["p"][-1] - trajectory.info["p"][0]
    assert 0.2 * 80.0 * 0.8 < drift[1] < 0.2 * 80.0  # carried along, lagging during the start
    assert abs(drift[0]) < 0.5 and abs(drift[2]) < 0.5


@pytest.mark.parametrize(
    "current",
    [
        Current.tidal([0.1, -0.05, 0.0], [0.2, 0.1, 0.05], period=7.0, phase=0.3),
        Current.shear([0.1, 0.0, 0.0], [0.05, -0.02, 0.0], reference_z=-1.0),
        Current.waves(
            Waves(
                type="jonswap",
                height=1.5,
                period=8.0,
                spreading="cos_2s",
                components=20,
                depth=30.0,
                surface_z=3.0,
            ),
            velocity=(0.1, 0.0, 0.0),
        ),
    ],
    ids=["tidal", "shear", "waves"],
)
def test_varying_currents_agree_between_backends(current, rng):
    compiled = aiauv_pin.load_vehicle(backend="numba")
    reference = aiauv_pin.load_vehicle(backend="pinocchio")
    for _ in range(5):
        q, v = random_state(compiled.model, rng, speed=0.4)
        tau = rng.normal(size=compiled.nv)
        t = float(rng.uniform(0, 10))
        np.testing.assert_allclose(
            compiled.acceleration(q, v, tau, current, t=t),
            reference.acceleration(q, v, tau, current, t=t),
            rtol=1e-9,
            atol=1e-9,
        )


def test_constant_current_object_equals_velocity(rng):
    vehicle = aiauv_pin.load_vehicle()
    q, v = random_state(vehicle.model, rng)
    tau = np.zeros(vehicle.nv)
    velocity = np.array([0.1, 0.2, -0.05])
    np.testing.assert_array_equal(
        vehicle.acceleration(q, v, tau, velocity),
        vehicle.acceleration(q, v, tau, Current.constant(velocity)),
    )


# ---------------------------------------------------------------------- crossflow frame
def test_rotated_crossflow_cylinder_frame_agrees_between_backends(tmp_path, rng):
    text = aiauv_pin.bundled_urdf("uniform").read_text()
    # turn the collision cylinder of link 5 onto the link's y-axis (through the link origin, where
    # the slender-cylinder model stays exact): its crossflow frame is then rotated from the link's
    pattern = r'(<link name="link5">.*?<collision.*?<origin )xyz="[^"]*" rpy="[^"]*"'
    replacement = r'\g<1>xyz="0 0.363 0" rpy="1.5707963267948966 0 0"'
    tilted, count = re.subn(pattern, replacement, text, flags=re.S)
    assert count == 1
    path = tmp_path / "tilted.urdf"
    path.write_text(tilted)
    compiled = aiauv_pin.load_vehicle(path, backend="numba")
    reference = aiauv_pin.load_vehicle(path, backend="pinocchio")
    fluid = compiled.fluid_model()
    assert np.count_nonzero(fluid.has_crossflow & (fluid.cylinder_is_link == 0)) == 1
    for current in (None, np.array([0.2, -0.1, 0.05])):
        for _ in range(5):
            q, v = random_state(compiled.model, rng, speed=0.6)
            tau = rng.normal(size=compiled.nv)
            np.testing.assert_allclose(
                compiled.acceleration(q, v, tau, current),
                reference.acceleration(q, v, tau, current),
                rtol=1e-9,
                atol=1e-9,
            )


# ---------------------------------------------------------------------- disturbances
SPHERE = """<?xml version="1.0"?>
<robot name="free_body">
  <link name="body">
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="12.0"/>
      <inertia ixx="0.4" ixy="0" ixz="0" iyy="0.5" iyz="0" izz="0.6"/>
    </inertial>
  </link>
</robot>
"""


@pytest.mark.parametrize("backend", ["numba", "pinocchio"])
@pytest.mark.parametrize("form", ["compiled", "python"])
def test_free_body_under_a_sinusoidal_wrench_follows_the_closed_form(backend, form, tmp_path):
    """x(t) = F / (m w^2) (w t - sin w t) and yaw(t) = N / (I_zz w^2) (w t - sin w t) from rest."""
    path = tmp_path / "free_body.urdf"
    path.write_text(SPHERE)
    vehicle = aiauv_pin.load_vehicle(path, restoring=False, backend=backend)
    force, moment, omega = 3.0, 0.2, 2.0
    disturbance = Disturbance.base_wrench([force, 0.0, 0.0], [0.0, 0.0, moment], omega=omega)
    if form == "python":
        compiled = disturbance
        disturbance = lambda t, q, v: compiled.generalized_force(t, q, v)  # noqa: E731
    q0, v0 = vehicle.neutral_configuration(), np.zeros(vehicle.nv)
    trajectory = aiauv_pin.simulate(
        vehicle, q0, v0, 2.0, 0.01, disturbance=disturbance, log_every=50
    )
    t = trajectory.t
    x = force / (12.0 * omega**2) * (omega * t - np.sin(omega * t))
    yaw = moment / (0.6 * omega**2) * (omega * t - np.sin(omega * t))
    quaternion = trajectory.q[:, 3:7]
    yaw_got = 2.0 * np.arctan2(quaternion[:, 2], quaternion[:, 3])
    np.testing.assert_allclose(trajectory.q[:, 0], x, atol=1e-9)
    np.testing.assert_allclose(trajectory.q[:, 1:3], 0.0, atol=1e-9)  # RK4 error, as for x
    np.testing.assert_allclose(yaw_got, yaw, atol=1e-9)


# ---------------------------------------------------------------------- user controllers
def test_user_compiled_controller_runs_in_the_loop_and_equals_python():
    numba = pytest.importorskip("numba")
    from aiauv_pin.kernels.articulated_body import kinematics, thrust_into

    @numba.njit
    def straight_and_forward(t, q, v, model, workspace, parameters, state, tau, info):
        kinematics(model.bodies, q, v, workspace)
        thrust_into(model, workspace, parameters[2:], tau)
        for j in range(q.shape[0] - 7):
            tau[6 + j] += -parameters[0] * q[7 + j] - parameters[1] * v[6 + j]
        info[0] = v[0]

    vehicle = aiauv_pin.load_vehicle()
    thrusts = np.array([0.0, 0.0, 20.0, 20.0, 0.0, 0.0, 0.0])
    parameters = np.concatenate(([30.0, 50.0], thrusts))
    controller = CompiledController(straight_and_forward, parameters, info_shapes={"u": ()})

    def python(t, q, v):
        tau = vehicle.thrust_matrix(q) @ thrusts
        tau[6:] += -30.0 * q[7:] - 50.0 * v[6:]
        return tau, {"u": v[0]}

    q0 = vehicle.neutral_configuration()
    q0[7:] = 0.1
    v0 = np.zeros(vehicle.nv)
    got = aiauv_pin.simulate(vehicle, q0, v0, 5.0, 0.01, controller)
    expected = aiauv_pin.simulate(vehicle, q0, v0, 5.0, 0.01, python)
    np.testing.assert_allclose(got.q, expected.q, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(got.info["u"], expected.info["u"], rtol=1e-9, atol=1e-10)
    assert got.v[-1, 0] > 0.2  # it does push forward


# ---------------------------------------------------------------------- compilation cache
def test_every_compiled_function_lives_in_a_hashed_source():
    hashed = {p.resolve() for p in _project_files()}
    for package in ("hydro", "control", "aiauv_pin"):
        for path in (ROOT / package).rglob("*.py"):
            if "@compiled" in path.read_text() and path.name != "jit.py":
                assert path.resolve() in hashed, (
                    f"{path} has compiled code outside {compiled_sources()}"
                )
    assert len(source_hash()) == 64


def test_no_numba_fallback_runs_the_same_laws_interpreted(rng):
    """With numba disabled, the laws run as plain Python on the Pinocchio path: same numbers."""
    q, v = random_state(aiauv_pin.load_vehicle().model, rng, speed=0.5)
    tau = rng.normal(size=q.size - 1)
    vehicle = aiauv_pin.load_vehicle(backend="pinocchio")
    expected = vehicle.acceleration(q, v, tau, np.array([0.1, 0.0, -0.1]))
    code = (
        "import sys, numpy as np, aiauv_pin\n"
        "q, v, tau = (np.array(eval(line)) for line in sys.stdin.read().splitlines())\n"
        "vehicle = aiauv_pin.load_vehicle()\n"
        "assert vehicle.active_backend == 'pinocchio', vehicle.active_backend\n"
        "print(repr(vehicle.acceleration(q, v, tau, np.array([0.1, 0.0, -0.1])).tolist()))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code],
        input="\n".join(repr(a.tolist()) for a in (q, v, tau)),
        capture_output=True,
        text=True,
        env={**os.environ, "NUMBA_DISABLE_JIT": "1"},
        timeout=300,
        check=True,
    )
    np.testing.assert_allclose(eval(result.stdout), expected, rtol=1e-9, atol=1e-9)
