"""Surge-proportional damping ``-u_r D_F nu_r`` (UUV Simulator's ``linear_damping_forward_speed``)
through the whole chain: our ``<hydrodynamics>`` block, the UUV Simulator reader, the validation
gate, both backends, and the URDF writer."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.errors import AiauvError

DATA = Path(__file__).parents[1] / "data"

HULL = """<robot name="torpedo">
  <link name="hull">
    <inertial><mass value="30.0"/><origin xyz="0 0 0"/>
      <inertia ixx="0.2" ixy="0" ixz="0" iyy="1.0" iyz="0" izz="1.0"/></inertial>
  </link>
  <hydrodynamics fluid_density="1000" gravity="9.81">
    <link name="hull" model="fossen">
      <volume>0.03</volume>
      <added_mass>3 25 25 0.1 2 2</added_mass>
      {forward}
    </link>
  </hydrodynamics>
</robot>
"""

# a PSD D_F with lift-like couplings sway-yaw and heave-pitch [N s^2/m^2, N s^2/m, N m s^2/m]
FORWARD = np.array(
    [
        [8.0, 0, 0, 0, 0, 0],
        [0, 162.0, 0, 0, 0, -150.0],
        [0, 0, 108.0, 0, 100.0, 0],
        [0, 0, 0, 13.0, 0, 0],
        [0, 0, -37.0, 0, 20.0, 0],
        [0, 34.0, 0, 0, 0, 32.0],
    ]
)


def _write(tmp_path, matrix) -> Path:
    forward = (
        ""
        if matrix is None
        else (
            "<linear_damping_forward_speed>"
            + " ".join(repr(float(x)) for x in np.ravel(matrix))
            + "</linear_damping_forward_speed>"
        )
    )
    path = tmp_path / "torpedo.urdf"
    path.write_text(HULL.format(forward=forward))
    return path


@pytest.mark.parametrize("backend", ["pinocchio", "numba"])
def test_single_body_bias_is_the_closed_form(tmp_path, backend, rng):
    """Free single body at the identity pose with no current: the bias difference made by ``D_F``
    is exactly ``u D_F nu`` (body axes, the body is its link)."""
    with_term = aiauv_pin.load_vehicle(_write(tmp_path, FORWARD), backend=backend)
    without = aiauv_pin.load_vehicle(_write(tmp_path, None), backend=backend)
    q = np.array([0, 0, 0, 0, 0, 0, 1.0])
    for _ in range(5):
        v = rng.normal(size=6)
        tau = rng.normal(size=6)
        a_with = with_term.acceleration(q, v, tau)
        a_without = without.acceleration(q, v, tau)
        mass = without.mass_matrix(q)
        # M (a_with - a_without) = -(bias_with - bias_without) = -u D_F nu
        np.testing.assert_allclose(
            mass @ (a_with - a_without), -v[0] * FORWARD @ v, rtol=1e-10, atol=1e-10
        )


def test_backends_agree_on_a_uuv_torpedo_with_forward_speed_damping(tmp_path, rng):
    """LAUV-like UUV Simulator file with its forward-speed block filled in (UUV Simulator's sign:
    negative = dissipative, FRD axes): read as ``D_F`` in our axes, and Pinocchio and the compiled
    backend agree at random states."""
    text = (DATA / "lauv_uuv_simulator.urdf").read_text()
    empty = "<linear_damping_forward_speed>0 0 0 0 0 0</linear_damping_forward_speed>"
    assert empty in text
    path = tmp_path / "lauv.urdf"
    path.write_text(
        text.replace(
            empty,
            "<linear_damping_forward_speed>-2 -30 -30 -1 -5 -5</linear_damping_forward_speed>",
        )
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reference = aiauv_pin.load_vehicle(path, backend="pinocchio")
        compiled = aiauv_pin.load_vehicle(path, backend="numba")
    (link,) = [link for link in reference.hydro.links if np.any(link.forward_speed_damping)]
    np.testing.assert_allclose(np.diag(link.forward_speed_damping), [2, 30, 30, 1, 5, 5])
    for _ in range(5):
        q = reference.neutral_configuration()
        quaternion = rng.normal(size=4)
        q[3:7] = quaternion / np.linalg.norm(quaternion)
        v = rng.normal(size=reference.nv)
        v[0] = abs(v[0]) + 0.5
        tau = rng.normal(size=reference.nv)
        np.testing.assert_allclose(
            compiled.acceleration(q, v, tau),
            reference.acceleration(q, v, tau),
            rtol=1e-9,
            atol=1e-9,
        )


def test_energy_injecting_forward_speed_damping_is_refused(tmp_path):
    with pytest.raises(AiauvError, match="linear_damping_forward_speed is not positive semi"):
        aiauv_pin.load_vehicle(_write(tmp_path, -np.eye(6)))


def test_writer_round_trip(tmp_path):
    from aiauv_hydro.urdf.block_reader import read_hydrodynamics
    from aiauv_hydro.urdf.block_writer import fossen_link_element

    (link,) = read_hydrodynamics(_write(tmp_path, FORWARD)).links
    np.testing.assert_array_equal(link.forward_speed_damping, FORWARD)
    element = fossen_link_element(link)
    assert element.find("linear_damping_forward_speed") is not None
