"""SDF in: gz-sim's LRAUV world (auv_controls.sdf) with the Tethys model from a local model path,
its hydrodynamics, buoyancy and thruster, and a propelled run."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from aiauv_pin import load_vehicle
from aiauv_pin.app.cli import main
from aiauv_pin.scenario.definition import run_scenario
from aiauv_pin.scenario.toml_file import load_scenario

EXAMPLES = Path(__file__).parents[2] / "examples"
WORLD = EXAMPLES / "gz" / "auv_controls.sdf"
MODELS = EXAMPLES / "gz" / "models"
TETHYS = MODELS / "MBARI Tethys LRAUV" / "model.sdf"


def _load(path=WORLD, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vehicle = load_vehicle(path, **options)
    return vehicle, [str(w.message) for w in caught]


def test_world_loads_hydrodynamics_buoyancy_and_thruster():
    vehicle, said = _load(model_path=[MODELS], backend="pinocchio")
    assert vehicle.name == "my_lrauv" and vehicle.nv == 6  # fins and propeller held rigid
    hydro = vehicle.hydro
    assert hydro.fluid_density == 1000.0 and hydro.gravity == 9.8  # Buoyancy; SDF's gravity
    links = {link.link: link for link in hydro.links}
    base = links["base_link"]
    # the Hydrodynamics plugin inside the <include>: Fossen's signs to ours (interop/gz.py)
    np.testing.assert_array_equal(
        np.diag(base.added_mass), [4.876161, 126.324739, 126.324739, 0.0, 33.46, 33.46]
    )
    np.testing.assert_array_equal(
        np.diag(base.quadratic_damping), [6.2282, 601.27, 601.27, 0.1916, 632.698957, 632.698957]
    )
    # gz's Buoyancy: each link's collision boxes, at 1000 kg/m^3 neutral link by link
    assert math.isclose(base.volume, 2 * 0.3 * 0.2464451666666667, rel_tol=1e-12)
    assert sorted(links) == ["base_link", "horizontal_fins", "propeller", "vertical_fins"]
    total_mass = sum(inertia.mass for inertia in vehicle.model.inertias)
    total_volume = sum(link.volume for link in hydro.links)
    assert math.isclose(total_volume * 1000.0, total_mass, rel_tol=1e-12)
    (thruster,) = hydro.thrusters
    assert (thruster.name, thruster.link, thruster.max_thrust) == (
        "propeller_joint",
        "propeller",
        1000.0,
    )
    np.testing.assert_array_equal(thruster.direction, [1.0, 0.0, 0.0])
    # gz's LiftDrag systems are our fins (aiauv_hydro.spec.Fin), on the links they name
    assert [fin.link for fin in hydro.fins] == ["vertical_fins", "horizontal_fins"]
    assert any("JointPositionController not simulated here" in s for s in said)
    assert any("propeller_joint (Thruster)" in note for note in vehicle.description_notes)


def test_model_file_alone_loads():
    vehicle, _ = _load(TETHYS, backend="pinocchio")
    assert vehicle.name == "my_lrauv"
    assert sorted(vehicle.joint_names) == [
        "horizontal_fins_joint",
        "propeller_joint",
        "vertical_fins_joint",
    ]
    assert vehicle.hydro.links == () and vehicle.hydro.thrusters == ()  # no systems in the file
    assert any("no Buoyancy system" in note for note in vehicle.description_notes)


def test_check_command(capsys):
    assert main(["check", str(WORLD), "--model-path", str(MODELS)]) == 0
    out = capsys.readouterr().out
    assert "vehicle 'my_lrauv'" in out and "propeller_joint" in out
    assert main(["check", str(WORLD), "--model", "nothing", "--model-path", str(MODELS)]) == 1
    err = capsys.readouterr().err
    assert "no model named 'nothing'" in err and len(err.strip().splitlines()) == 1


def test_propelled_at_300_rpm_reaches_gz_speed():
    """examples/tethys_propelled.toml: 300 rpm of thrust (6.983 N by gz's Thruster law) for
    45 s from rest, as osrf/lrauv's test_hydrodynamics.cc, which expects 1.01 +- 0.1 m/s."""
    scenario = load_scenario(EXAMPLES / "tethys_propelled.toml")
    assert scenario.controller == "constant"
    vehicle, _ = _load(scenario.vehicle, model_path=[MODELS])
    if vehicle.fast is None:
        pytest.skip("the constant-thrust controller runs in the compiled loop")
    result = run_scenario(vehicle, scenario)
    v = np.asarray(result.trajectory.v)
    speed = float(np.linalg.norm(v[-1, :3]))
    assert abs(speed - 1.01) < 0.1
    assert v[-1, 0] < 0.0  # forward is -x for this model
    thrust = np.asarray(result.trajectory.info["thrust"])
    np.testing.assert_array_equal(thrust[-1], [-6.982942505858744])
    # straight-line terminal speed of the surge law: sqrt(T / X_u|u|) = 1.0589 m/s, not yet reached
    assert speed < math.sqrt(6.982942505858744 / 6.2282)


def test_import_gz_reads_undeclared_prefixes(tmp_path):
    """`aiauv import-gz` read SDF with the same parser: a `gz:` element no longer stops it."""
    from aiauv_pin.interop.gz import read_gz_model

    path = tmp_path / "m.sdf"
    path.write_text(
        '<sdf version="1.9"><model name="m"><link name="hull"><gz:extra gz:a="1"/></link>'
        '<plugin name="gz::sim::systems::Hydrodynamics" filename="gz-sim-hydrodynamics-system">'
        "<link_name>hull</link_name><xUabsU>-2</xUabsU></plugin></model></sdf>",
        encoding="utf-8",
    )
    (link,) = read_gz_model(path).links
    assert link.quadratic_damping[0, 0] == 2.0
