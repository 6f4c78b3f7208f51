"""The compiled path never makes Pinocchio's Data (issue 34: memory at 127 links); the mass
matrix check at load runs on the compiled accelerations and agrees with Pinocchio's."""

from __future__ import annotations

import numpy as np
import pytest

from aiauv_pin.errors import VehicleLoadError
from aiauv_pin.model import loading, validation
from aiauv_pin.model.validation import validate_mass_matrix

TWO_LINKS = """<robot name="two">
  <link name="a"><inertial><mass value="4"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="b"><inertial><mass value="{mass}"/>
    <inertia ixx="{inertia}" ixy="0" ixz="0" iyy="{inertia}" iyz="0" izz="{inertia}"/>
  </inertial></link>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit effort="10" velocity="1"/></joint>
</robot>"""


def test_compiled_load_and_run_make_no_pinocchio_data(monkeypatch):
    monkeypatch.setattr(validation, "COMPILED_CHECK_FROM", 1)  # the check of large vehicles
    vehicle = loading.load_vehicle()
    assert vehicle.active_backend == "numba"
    assert vehicle._pinocchio.data is None and vehicle._pinocchio.buoyancy_data is None
    vehicle.acceleration(
        vehicle.neutral_configuration(), np.zeros(vehicle.nv), np.zeros(vehicle.nv)
    )
    assert vehicle._pinocchio.data is None
    vehicle.mass_matrix(vehicle.neutral_configuration())  # the reference path makes it on use
    assert vehicle._pinocchio.data is not None


def test_compiled_mass_matrix_check_agrees_with_pinocchio():
    vehicle = loading.load_vehicle()
    compiled = validation._validate_inverse_mass_matrix(vehicle, "")
    reference = validate_mass_matrix(vehicle, reference=True)
    assert compiled == pytest.approx(reference, rel=1e-9)


@pytest.mark.parametrize("backend", ["numba", "pinocchio"])
def test_a_massless_leaf_link_is_refused_on_both_paths(tmp_path, backend, monkeypatch):
    monkeypatch.setattr(validation, "COMPILED_CHECK_FROM", 1)
    path = tmp_path / "two.urdf"
    path.write_text(TWO_LINKS.format(mass=0, inertia=0), encoding="utf-8")
    with pytest.raises(VehicleLoadError, match="singular"):
        loading.load_vehicle(path, backend=backend)
    path.write_text(TWO_LINKS.format(mass=1, inertia=0.01), encoding="utf-8")
    assert loading.load_vehicle(path, backend=backend).nv == 7
