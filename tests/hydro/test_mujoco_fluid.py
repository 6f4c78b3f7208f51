"""MuJoCo's fluid models as our per-link parameters (aiauv_hydro.estimate.mujoco_fluid), checked
against MuJoCo's own engine: its compiled virtual masses and its fluid forces (``qfrc_fluid``)."""

from __future__ import annotations

import numpy as np
import pytest

from aiauv_hydro.estimate.ellipsoid import Ellipsoid, ellipsoid_added_mass
from aiauv_hydro.estimate.mujoco_fluid import (
    DEFAULT_FLUID_COEFFICIENTS,
    FluidEllipsoid,
    buoyant_volume,
    fluid_ellipsoid_hydrodynamics,
    geom_semi_axes,
    gravity_compensation,
    inertia_box_hydrodynamics,
)

mujoco = pytest.importorskip("mujoco")

GEOMS = [
    ("ellipsoid", "0.3 0.12 0.05"),
    ("box", "0.2 0.05 0.1"),
    ("capsule", "0.06 0.25"),
    ("cylinder", "0.085 0.31"),
    ("sphere", "0.1"),
]


def _kind(model, geom: int) -> str:
    return mujoco.mjtGeom(int(model.geom_type[geom])).name[len("mjGEOM_") :].lower()


def _body(geom: str, density: float = 1000.0, viscosity: float = 1e-3, fluid: str = "") -> str:
    return f"""<mujoco>
      <option density="{density}" viscosity="{viscosity}" gravity="0 0 0"/>
      <worldbody><body><freejoint/>
        <inertial pos="0 0 0" mass="3" diaginertia="0.2 0.3 0.4"/>
        <geom {geom} {fluid} contype="0" conaffinity="0" mass="0"/>
      </body></worldbody></mujoco>"""


@pytest.mark.parametrize("kind,size", GEOMS)
def test_virtual_mass_is_lambs_added_mass(kind, size):
    """MuJoCo's compiled virtual masses and inertias (``geom_fluid[6:12]``, per unit density) are
    Lamb's, which MuJoCo integrates numerically: they agree to its quadrature (measured 6e-7)."""
    model = mujoco.MjModel.from_xml_string(
        _body(f'type="{kind}" size="{size}"', fluid='fluidshape="ellipsoid"')
    )
    ours = ellipsoid_added_mass(geom_semi_axes(kind, model.geom_size[0]), 1.0)
    np.testing.assert_allclose(ours, model.geom_fluid[0][6:12], rtol=1e-6, atol=1e-15)


def _fluid_force(model, velocity: np.ndarray) -> np.ndarray:
    """MuJoCo's fluid wrench (force, torque) at the identity pose for the twist (v, omega)."""
    data = mujoco.MjData(model)
    data.qvel[:3], data.qvel[3:6] = velocity[:3], velocity[3:6]
    mujoco.mj_forward(model, data)
    return np.array(data.qfrc_fluid)


def _ours(hydro, velocity: np.ndarray) -> np.ndarray:
    # the quadratic damping of an ellipsoid estimate is its diagonal
    return -hydro.linear_damping @ velocity - hydro.quadratic_damping * np.abs(velocity) * velocity


AXES = [np.eye(6)[i] * s for i in range(6) for s in (0.3, -0.7)]


@pytest.mark.parametrize("quat", ["1 0 0 0", "0.7071067811865476 0 0 0.7071067811865476"])
@pytest.mark.parametrize("coefficients", [None, "0.9 0.1 2.0 0 0"])
def test_ellipsoid_model_along_principal_axes_matches_mujoco(quat, coefficients):
    """Motion along one principal axis: MuJoCo's drag, Stokes resistance and (vanishing) lift and
    added-mass forces equal our -D_L nu - D_Q |nu| nu to round-off."""
    fluid = 'fluidshape="ellipsoid"' + (f' fluidcoef="{coefficients}"' if coefficients else "")
    model = mujoco.MjModel.from_xml_string(
        _body(f'type="ellipsoid" size="0.3 0.12 0.05" quat="{quat}"', fluid=fluid)
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rotation = np.array(data.geom_xmat[0]).reshape(3, 3)
    coefficients = (
        DEFAULT_FLUID_COEFFICIENTS
        if coefficients is None
        else tuple(float(c) for c in coefficients.split())
    )
    hydro = fluid_ellipsoid_hydrodynamics(
        FluidEllipsoid(Ellipsoid(np.array([0.3, 0.12, 0.05]), rotation, np.zeros(3)), coefficients),
        1000.0,
        1e-3,
    )
    for velocity in AXES:
        theirs = _fluid_force(model, velocity)
        scale = max(1e-3, float(np.max(np.abs(theirs))))
        np.testing.assert_allclose(_ours(hydro, velocity), theirs, rtol=0, atol=1e-12 * scale)


def test_inertia_box_model_matches_mujoco():
    """A body without fluid geoms: MuJoCo's inertia-box model, one axis at a time."""
    model = mujoco.MjModel.from_xml_string(_body('type="box" size="0.2 0.05 0.1"'))
    hydro = inertia_box_hydrodynamics(
        3.0, model.body_inertia[1], np.eye(3), np.zeros(3), 1000.0, 1e-3
    )
    for velocity in AXES:
        theirs = _fluid_force(model, velocity)
        scale = max(1e-3, float(np.max(np.abs(theirs))))
        np.testing.assert_allclose(_ours(hydro, velocity), theirs, rtol=0, atol=1e-12 * scale)


def test_gravity_compensation_is_buoyancy():
    gravcomp = gravity_compensation(0.0143, 14.3, 1000.0)
    assert gravcomp == pytest.approx(1.0, rel=1e-15)
    assert buoyant_volume(gravcomp, 14.3, 1000.0) == pytest.approx(0.0143, rel=1e-15)


def test_semi_axes_follow_mujoco():
    assert list(geom_semi_axes("capsule", [0.1, 0.3, 0.0])) == [0.1, 0.1, 0.4]
    assert list(geom_semi_axes("cylinder", [0.1, 0.3, 0.0])) == [0.1, 0.1, 0.3]
    assert list(geom_semi_axes("sphere", [0.2, 0.0, 0.0])) == [0.2, 0.2, 0.2]
    assert list(geom_semi_axes("box", [0.1, 0.2, 0.3])) == [0.1, 0.2, 0.3]


def test_viscous_resistance_of_an_offset_geom_is_exact():
    """With density 0 MuJoCo's ellipsoid model is Stokes' resistance alone, linear in the geom's
    twist: moved to the body origin it is our -D_L nu for any twist, lever arms included."""
    model = mujoco.MjModel.from_xml_string(
        _body(
            'type="ellipsoid" size="0.3 0.12 0.05" pos="0.4 -0.1 0.2" euler="0.3 -0.5 1.1"',
            density=0.0,
            viscosity=0.5,
            fluid='fluidshape="ellipsoid"',
        )
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ellipsoid = Ellipsoid(
        np.array([0.3, 0.12, 0.05]),
        np.array(data.geom_xmat[0]).reshape(3, 3),
        np.array(data.geom_xpos[0]),
    )
    hydro = fluid_ellipsoid_hydrodynamics(FluidEllipsoid(ellipsoid), 0.0, 0.5)
    rng = np.random.default_rng(11)
    for _ in range(10):
        velocity = rng.normal(size=6)
        theirs = _fluid_force(model, velocity)
        np.testing.assert_allclose(-hydro.linear_damping @ velocity, theirs, rtol=0, atol=1e-12)
