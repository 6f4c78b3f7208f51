"""Lenient loading of published vehicles (aiauv_pin.model.lenient_repairs): the gate keeps its
verdicts without ``lenient``; with it, each known refusal becomes one LenientRepairWarning naming
whose data is wrong, and the repaired vehicles load and run."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.errors import (
    LenientRepairWarning,
    PhysicalParameterError,
    UnsafeNameError,
    VehicleLoadError,
)
from aiauv_pin.model.lenient_repairs import nearest_valid_inertia, thruster_manager_limit

DATA = Path(__file__).parents[1] / "data"
PACKAGES = DATA / "uuv_simulator_packages"
PUBLISHED = {
    "rexrov": PACKAGES / "uuv_descriptions" / "robots" / "rexrov_default.xacro",
    "rexrov_oberon7": PACKAGES / "uuv_descriptions" / "robots" / "rexrov_oberon7.xacro",
    "lauv": PACKAGES / "lauv_description" / "robots" / "default.xacro",
    "eca_a9": PACKAGES / "eca_a9_description" / "robots" / "eca_a9_default.urdf.xacro",
    "oberon7": PACKAGES / "oberon7_description" / "robots" / "oberon7_standalone.xacro",
}


def _load(path, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vehicle = aiauv_pin.load_vehicle(path, package_path=[PACKAGES], **options)
    repairs = [str(w.message) for w in caught if issubclass(w.category, LenientRepairWarning)]
    return vehicle, repairs


def _refused(path, error=VehicleLoadError) -> str:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(error) as caught:
            aiauv_pin.load_vehicle(path, package_path=[PACKAGES])
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_nearest_valid_inertia(rng):
    published = np.diag([0.6, 30.0, 35.0])  # ECA A9
    d = (35.0 - 30.6) / 3.0
    np.testing.assert_allclose(
        np.linalg.eigvalsh(nearest_valid_inertia(published)), [0.6 + d, 30.0 + d, 35.0 - d]
    )
    for _ in range(50):
        axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        broken = axes @ np.diag(rng.uniform(-0.1, 1.0, 3) * [1, 1, 3]) @ axes.T
        repaired = nearest_valid_inertia(broken)
        a, b, c = np.linalg.eigvalsh(repaired)
        assert a >= -1e-12 and a + b >= c - 1e-12
        np.testing.assert_allclose(nearest_valid_inertia(repaired), repaired, atol=1e-12)
        # nearest: no valid tensor sampled around it is closer to the broken one
        distance = np.linalg.norm(repaired - broken)
        for _ in range(20):
            step = rng.normal(scale=0.05, size=(3, 3))
            other = nearest_valid_inertia(repaired + 0.5 * (step + step.T))
            assert np.linalg.norm(other - broken) >= distance - 1e-12


def test_eca_a9_inertia_is_projected_with_the_change_printed():
    assert "triangle inequality" in _refused(DATA / "eca_a9_uuv_simulator.urdf")
    assert "plausible range" in _refused(PUBLISHED["eca_a9"])  # the first refusal of its xacro
    for path in (DATA / "eca_a9_uuv_simulator.urdf", PUBLISHED["eca_a9"]):
        vehicle, repairs = _load(path, lenient=True)
        (line,) = [r for r in repairs if "triangle" in r]
        assert "the source file's data" in line and "0.6, 30, 35" in line
        assert "2.067, 31.47, 33.53" in line
        old, new = vehicle.lenient_repairs.projected_inertias["eca_a9/base_link"]
        np.testing.assert_allclose(old, [0.6, 30, 35])
        assert new[0] + new[1] == pytest.approx(new[2], rel=1e-12)


def test_lauv_fins_merge_into_the_hull():
    assert "singular" in _refused(PUBLISHED["lauv"], PhysicalParameterError)
    vehicle, repairs = _load(PUBLISHED["lauv"], lenient=True)
    assert vehicle.nv == 6 and not vehicle.fixed_base
    fins = {f"lauv/fin{k}": "lauv/base_link" for k in range(4)}
    assert vehicle.merged_links == fins
    merged = [r for r in repairs if "merged into 'lauv/base_link'" in r]
    assert len(merged) == 4 and all("actuated surface" in r for r in merged)
    assert all("the source file's data" in r for r in repairs)


@pytest.mark.parametrize("path", [DATA / "oberon7_uuv_simulator.urdf", PUBLISHED["oberon7"]])
def test_oberon7_arm_on_a_fixed_base(path):
    assert "'/base' is not allowed" in _refused(path, UnsafeNameError)
    vehicle, repairs = _load(path, lenient=True)
    assert vehicle.fixed_base  # its massless 'world' root, once 'anchor' (limits [0, 0]) is fixed
    assert vehicle.joint_names[:5] == ["azimuth", "shoulder", "elbow", "roll", "pitch"]
    assert vehicle.lenient_repairs.renamed["/base"] == "base"
    assert "anchor" in vehicle.lenient_repairs.locked_joints
    assert any("renamed '/base' -> 'base'" in r for r in repairs)
    trajectory = aiauv_pin.simulate(
        vehicle, vehicle.neutral_configuration(), np.zeros(vehicle.nv), 1.0, 0.005
    )
    assert np.all(np.isfinite(trajectory.q))
    np.testing.assert_array_equal(trajectory.q[-1, :7], vehicle.neutral_configuration()[:7])


def test_rexrov_with_and_without_the_arm():
    for name in ("rexrov", "rexrov_oberon7"):
        assert "plausible range" in _refused(PUBLISHED[name])
    plain, _ = _load(PUBLISHED["rexrov"], lenient=True)
    armed, repairs = _load(PUBLISHED["rexrov_oberon7"], lenient=True)
    assert plain.nv == 6 and armed.nv == 14 and not armed.fixed_base
    for vehicle in (plain, armed):  # the thruster manager's limit (test_rexrov_thrusters_...)
        np.testing.assert_array_equal(vehicle.max_thrust, np.full(8, 2000.0))
    (line,) = [r for r in repairs if "center_of_buoyancy" in r]
    assert "'oberon7/base'" in line and "link origin" in line
    base = {link.link: link for link in armed.hydro.links}["oberon7/base"]
    np.testing.assert_array_equal(base.center_of_buoyancy, np.zeros(3))
    # RexROV alone: slightly buoyant (rho V = 1889.7 kg against 1862.87 kg), it drifts slowly
    trajectory = aiauv_pin.simulate(
        plain, plain.neutral_configuration(), np.zeros(plain.nv), 5.0, 0.005
    )
    assert np.all(np.isfinite(trajectory.q))
    rise = trajectory.q[-1, 2] - trajectory.q[0, 2]
    assert 0.05 < rise < 1.0 and np.linalg.norm(trajectory.v[-1, :3]) < 0.3


def test_without_lenient_nothing_is_repaired(tmp_path):
    vehicle, repairs = _load(DATA / "rexrov_uuv_simulator.urdf")
    assert vehicle.lenient_repairs is None and vehicle.merged_links == {} and repairs == []
    vehicle, repairs = _load(DATA / "rexrov_uuv_simulator.urdf", lenient=True)
    assert repairs == [] and vehicle.lenient_repairs.messages == []


def test_example_robot_data_inertias():
    from aiauv_pin.description.robots import example_robot_data_dir

    try:
        robots = example_robot_data_dir()
    except VehicleLoadError:
        pytest.skip("example-robot-data is not installed")
    for relative in (
        "go1_description/urdf/go1.urdf",
        "allegro_hand_description/urdf/allegro_right_hand.urdf",
    ):
        assert "triangle inequality" in _refused(robots / relative, PhysicalParameterError)
        _, repairs = _load(robots / relative, lenient=True)
        assert repairs and all("projected to the nearest valid tensor" in r for r in repairs)
    z1, repairs = _load(robots / "z1_description/urdf/z1.urdf")
    assert z1.fixed_base and repairs == []  # a massless 'world' root fixed to the arm


def _tam(path: Path) -> np.ndarray:
    """UUV Simulator's thruster allocation matrix (6 x m, base_link axes, about its origin) from
    its TAM.yaml (``tam:`` then one ``- [...]`` list per row)."""
    rows = path.read_text().split("- [")[1:]
    return np.array([[float(x) for x in row.split("]")[0].split(",")] for row in rows])


def test_rexrov_thrusters_get_uuv_simulators_own_limit(tmp_path):
    """RexROV's eight thrusters are unlimited as published (no clamp or thrust bound: UUV
    Simulator's ThrusterPlugin.cc leaves them unbounded); with ``lenient`` they get the 2000 N its
    thruster manager clips them to (uuv_thruster_manager/config/rexrov/thruster_manager.yaml), and
    their thrust matrix is UUV Simulator's own (its TAM.yaml, computed by its allocator from the
    same xacro in Gazebo; single precision there)."""
    vehicle, repairs = _load(PUBLISHED["rexrov"], lenient=True)
    (line,) = [r for r in repairs if "thrust limit" in r]
    assert "8 UUV Simulator thrusters" in line and "+-2000 N" in line
    assert "uuv_thruster_manager/config/rexrov/thruster_manager.yaml" in line
    assert "the source file's data" in line and "ThrusterPlugin.cc" in line
    assert [t.name for t in vehicle.hydro.thrusters] == [
        f"rexrov_{k}_thruster_model" for k in range(8)
    ]
    assert all(t.time_constant == 0.05 for t in vehicle.hydro.thrusters)  # FirstOrder, 0.05 s
    np.testing.assert_array_equal(vehicle.max_thrust, np.full(8, 2000.0))
    B = vehicle.thrust_matrix(vehicle.neutral_configuration())
    tam = _tam(PACKAGES / "uuv_thruster_manager" / "config" / "rexrov" / "TAM.yaml")
    assert tam.shape == (6, 8)
    np.testing.assert_allclose(B, tam, rtol=0.0, atol=2e-6)
    # without the thruster manager on the package path they stay out, as without lenient
    for name in PUBLISHED_PACKAGES_BUT_THE_MANAGER:
        (tmp_path / name).symlink_to(PACKAGES / name, target_is_directory=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        bare = aiauv_pin.load_vehicle(PUBLISHED["rexrov"], package_path=[tmp_path], lenient=True)
    assert bare.hydro.thrusters == ()
    left_out = [
        str(w.message) for w in caught if "no finite positive thrust limit" in str(w.message)
    ]
    assert len(left_out) == 8 and all("thruster manager" in m for m in left_out)


PUBLISHED_PACKAGES_BUT_THE_MANAGER = (
    "uuv_descriptions",
    "uuv_sensor_ros_plugins",
    "uuv_gazebo_ros_plugins",
)


def test_thruster_manager_limit(tmp_path):
    config = tmp_path / "thruster_manager.yaml"
    config.write_text(
        "thruster_manager:\n  tf_prefix: x\n  max_thrust: [10, 20.5] # per thruster\n"
    )
    assert thruster_manager_limit(config) == [10.0, 20.5]
    config.write_text("other:\n  max_thrust: 5\nthruster_manager:\n  max_thrust: 1.5e3\n")
    assert thruster_manager_limit(config) == 1500.0
    for bad in ("  max_thrust: -1", "  max_thrust: inf", "  max_thrust: lots", "  timeout: -1"):
        config.write_text(f"thruster_manager:\n{bad}\n")
        assert thruster_manager_limit(config) is None
