"""MJCF in: our export read back (the round trip keeps inertias and MuJoCo's fluid model to 1e-9),
and MuJoCo's own fluid test models (tests/data/mjcf, copied verbatim) loaded and run."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from aiauv_hydro.estimate.ellipsoid import Ellipsoid
from aiauv_hydro.estimate.mujoco_fluid import FluidEllipsoid, fluid_ellipsoid_hydrodynamics
from aiauv_pin import bundled_urdf, load_vehicle, simulate
from aiauv_pin.app.cli import main
from aiauv_pin.description.mjcf_reading import MjcfDroppedWarning
from aiauv_pin.interop.export_source import load_export_source, rpy_to_matrix
from aiauv_pin.interop.mjcf import WATER_VISCOSITY, export_mjcf

mujoco = pytest.importorskip("mujoco")

DATA = Path(__file__).resolve().parents[1] / "data" / "mjcf"


def _load(path, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MjcfDroppedWarning)
        return load_vehicle(path, backend="pinocchio", **options)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """The paper vehicle exported to MJCF, and that file exported again after reading it."""
    folder = tmp_path_factory.mktemp("mjcf")
    export_mjcf(bundled_urdf("uniform"), folder / "paper.xml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MjcfDroppedWarning)
        export_mjcf(folder / "paper.xml", folder / "again.xml")
    return folder / "paper.xml", folder / "again.xml"


def _relative(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b))) / max(1.0, float(np.max(np.abs(b))))


def test_round_trip_keeps_bodies_and_thrusters(exported):
    original = _load(bundled_urdf("uniform"))
    imported = _load(exported[0])
    a, b = original.model, imported.model
    assert list(a.names) == list(b.names)
    worst = 0.0
    for joint in range(1, a.njoints):
        ia, ib = a.inertias[joint], b.inertias[joint]
        worst = max(worst, _relative(ib.mass, ia.mass), _relative(ib.lever, ia.lever))
        worst = max(worst, _relative(ib.inertia, ia.inertia))
        worst = max(worst, _relative(b.jointPlacements[joint], a.jointPlacements[joint]))
    for ta, tb in zip(original.hydro.thrusters, imported.hydro.thrusters, strict=True):
        assert (ta.name, ta.link) == (tb.name, tb.link)
        worst = max(
            worst, _relative(tb.position, ta.position), _relative(tb.direction, ta.direction)
        )
        worst = max(worst, _relative(tb.max_thrust, ta.max_thrust))
    assert worst <= 1e-9


def test_round_trip_hydrodynamics_are_mujocos_ellipsoids(exported):
    """Each link gets MuJoCo's ellipsoid model of the shapes the export wrote (water, default
    fluidcoef), and its volume back from the gravity compensation, at the centre of mass."""
    source = load_export_source(bundled_urdf("uniform"))
    hydro = source.vehicle.hydro
    imported = _load(exported[0])
    links = {link.link: link for link in imported.hydro.links}
    assert imported.hydro.fluid_density == hydro.fluid_density
    assert set(links) == {link.link for link in hydro.links}
    worst = 0.0
    for link in hydro.links:
        (shape,) = [s for s in source.shapes[link.link] if s.kind == "collision"]
        radius, length = shape.size  # MuJoCo's cylinder ellipsoid: (r, r, L/2)
        ellipsoid = Ellipsoid(
            np.array([radius, radius, length / 2.0]), rpy_to_matrix(shape.rpy), shape.xyz
        )
        expected = fluid_ellipsoid_hydrodynamics(
            FluidEllipsoid(ellipsoid), hydro.fluid_density, WATER_VISCOSITY
        )
        got = links[link.link]
        worst = max(worst, _relative(got.added_mass, expected.added_mass))
        worst = max(worst, _relative(got.linear_damping, expected.linear_damping))
        worst = max(worst, _relative(got.quadratic_damping, np.diag(expected.quadratic_damping)))
        worst = max(worst, _relative(got.volume, link.volume))
        com = source.structure.inertials[link.link].xyz
        worst = max(worst, _relative(got.center_of_buoyancy, com))
    assert worst <= 1e-9


def _inertia(model, body: int) -> np.ndarray:
    rotation = np.array(pin.Quaternion(*model.body_iquat[body]).toRotationMatrix())
    return rotation @ np.diag(model.body_inertia[body]) @ rotation.T


def _rotations(quaternions) -> np.ndarray:
    return np.array([pin.Quaternion(*q).toRotationMatrix() for q in quaternions])


def test_export_of_the_import_is_the_export(exported):
    """paper.urdf -> MJCF -> vehicle -> MJCF: MuJoCo compiles both files to the same model."""
    first, second = (mujoco.MjModel.from_xml_path(str(path)) for path in exported)
    assert (first.nbody, first.ngeom, first.nu, first.nsite) == (
        second.nbody,
        second.ngeom,
        second.nu,
        second.nsite,
    )
    for body in range(first.nbody):
        assert first.body(body).name == second.body(body).name
    worst = max(
        _relative(second.body_mass, first.body_mass),
        _relative(second.body_ipos, first.body_ipos),
        _relative(second.body_pos, first.body_pos),
        _relative(_rotations(second.body_quat), _rotations(first.body_quat)),
        _relative(second.body_gravcomp, first.body_gravcomp),
        _relative(second.geom_size, first.geom_size),
        _relative(second.geom_pos, first.geom_pos),
        _relative(_rotations(second.geom_quat), _rotations(first.geom_quat)),
        _relative(second.geom_fluid, first.geom_fluid),
        _relative(second.site_pos, first.site_pos),
        _relative(second.actuator_gear, first.actuator_gear),
        _relative(second.actuator_ctrlrange, first.actuator_ctrlrange),
        _relative(second.jnt_range, first.jnt_range),
        _relative(second.jnt_axis, first.jnt_axis),
        _relative(
            [second.opt.density, second.opt.viscosity], [first.opt.density, first.opt.viscosity]
        ),
        _relative(second.opt.gravity, first.opt.gravity),
    )
    for body in range(first.nbody):
        worst = max(worst, _relative(_inertia(second, body), _inertia(first, body)))
    assert worst <= 1e-9


@pytest.mark.filterwarnings("ignore:.*Kutta and Magnus lift")
@pytest.mark.parametrize("name", ["tumbling_thin_object_ellipsoid", "tumbling_thin_object"])
def test_mujocos_fluid_test_models_load_and_fall(name):
    """MuJoCo's own fluid test models (a thin plate of two boxes in air, with the ellipsoid and
    the inertia-box model): loaded with MuJoCo's masses, they fall and the air slows them."""
    path = DATA / f"{name}.xml"
    with pytest.warns(MjcfDroppedWarning, match="wind 0 0 1.0 m/s"):
        vehicle = load_vehicle(path)
    mj = mujoco.MjModel.from_xml_path(str(path))
    assert sum(i.mass for i in vehicle.model.inertias) == pytest.approx(mj.body_mass.sum())
    assert vehicle.hydro.fluid_density == mj.opt.density
    assert vehicle.hydro.links
    q0, v0 = pin.neutral(vehicle.model), np.zeros(vehicle.model.nv)
    run = simulate(vehicle, q0, v0, 0.5, 0.001)
    assert np.all(np.isfinite(run.q)) and np.all(np.isfinite(run.v))
    drop = -run.q[-1, 2]
    assert 0.0 < drop < 0.5 * vehicle.hydro.gravity * 0.5**2  # slower than in a vacuum


@pytest.mark.filterwarnings("ignore:.*Kutta and Magnus lift")
def test_cli_checks_and_simulates_an_mjcf_vehicle(exported, tmp_path, capsys):
    """The paper vehicle, as MuJoCo reads it, under the paper's controller."""
    assert main(["check", str(exported[0])]) == 0
    out = capsys.readouterr().out
    assert "OK: usable vehicle" in out and "link5_x_port" in out
    command = ["simulate", "--vehicle", str(exported[0]), "--duration", "2", "--no-html"]
    assert main([*command, "--quiet", "--out", str(tmp_path / "run")]) == 0
    assert (tmp_path / "run" / "summary.json").is_file()
