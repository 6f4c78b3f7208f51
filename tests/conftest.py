"""Shared fixtures: the bundled vehicle, a single rigid body with a full Fossen block, random states."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import aiauv_pin


def random_state(model: pin.Model, rng: np.random.Generator, speed: float = 0.5):
    """A random configuration (joints within +-0.6 rad) and velocity."""
    q = pin.neutral(model)
    q[:3] = rng.uniform(-2.0, 2.0, 3)
    quaternion = rng.normal(size=4)
    q[3:7] = quaternion / np.linalg.norm(quaternion)
    q[7:] = rng.uniform(-0.6, 0.6, model.nq - 7)
    v = speed * rng.normal(size=model.nv)
    return q, v


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


@pytest.fixture(params=["auto", "pinocchio"])
def backend(request, monkeypatch) -> str:
    """Run a test on the default (compiled when numba is present) and on the Pinocchio reference."""
    monkeypatch.setenv("AIAUV_BACKEND", request.param)
    return request.param


@pytest.fixture
def paper_vehicle() -> aiauv_pin.Vehicle:
    return aiauv_pin.load_vehicle()


SINGLE_BODY = dict(
    mass=30.0,
    r_g=np.array([0.02, -0.01, -0.03]),
    inertia_cg=np.array([[1.2, 0.05, -0.02], [0.05, 2.1, 0.03], [-0.02, 0.03, 2.4]]),
    volume=0.0305,
    r_b=np.array([0.05, 0.0, 0.02]),
    rho=1000.0,
    g=9.81,
)


def generated_vehicle_table(n_modules: int, seed: int, side_thruster: bool = False) -> dict:
    """Vehicle-spec table of a random chain of ``n_modules`` cylinders (lengths, radii, masses, low
    centres of gravity, joint axes drawn from ``seed``), with longitudinal thrusters on the end
    modules and, with ``side_thruster``, an oblique one on module 1."""
    rng = np.random.default_rng(seed)
    modules = []
    for i in range(n_modules):
        length = float(rng.uniform(0.1, 0.8))
        radius = float(rng.uniform(0.03, 0.12))
        module = {
            "name": f"m{i}",
            "length": length,
            "radius": radius,
            "mass": float(rng.uniform(0.5, 20.0)),
            "cg_offset": [0.0, 0.0, float(-rng.uniform(0.0, 0.5) * radius)],
        }
        if i < n_modules - 1:
            module["joint"] = "xyz"[int(rng.integers(3))]
        if i in (0, n_modules - 1):
            module["thruster"] = [{"name": f"t{i}", "x": length / 2, "direction": [1.0, 0.0, 0.0]}]
        if side_thruster and i == 1:
            module["thruster"] = [{"name": "t_side", "x": length / 3, "direction": [0.0, 3.0, 4.0]}]
        modules.append(module)
    return {"name": f"generated_{n_modules}", "module": modules}


def _single_body_matrices(rng_seed: int = 7):
    rng = np.random.default_rng(rng_seed)
    a = rng.normal(size=(6, 6))
    added = a @ a.T + np.diag([5.0, 20.0, 25.0, 0.5, 3.0, 3.5])  # full, symmetric positive definite
    linear = np.diag([4.0, 12.0, 14.0, 0.8, 2.5, 2.7]) + 0.3 * rng.normal(size=(6, 6))
    quadratic = np.diag([8.0, 30.0, 35.0, 1.0, 4.0, 4.5]) + 0.5 * rng.normal(size=(6, 6))
    return added, linear, quadratic


def single_body_urdf() -> tuple[str, dict]:
    """URDF text of one rigid body with a full 36-number Fossen block, and its parameters."""
    p = dict(SINGLE_BODY)
    added, linear, quadratic = _single_body_matrices()
    p.update(added_mass=added, linear_damping=linear, quadratic_damping=quadratic)
    i = p["inertia_cg"].tolist()

    def numbers(a):
        return " ".join(repr(float(x)) for x in np.ravel(a))

    text = f"""<?xml version="1.0"?>
<robot name="single_body">
  <link name="hull">
    <inertial>
      <origin xyz="{numbers(p["r_g"])}" rpy="0 0 0"/>
      <mass value="{float(p["mass"])!r}"/>
      <inertia ixx="{i[0][0]!r}" ixy="{i[0][1]!r}" ixz="{i[0][2]!r}" iyy="{i[1][1]!r}"
               iyz="{i[1][2]!r}" izz="{i[2][2]!r}"/>
    </inertial>
  </link>
  <hydrodynamics fluid_density="{p["rho"]!r}" gravity="{p["g"]!r}">
    <link name="hull" model="fossen">
      <volume>{p["volume"]!r}</volume>
      <center_of_buoyancy>{numbers(p["r_b"])}</center_of_buoyancy>
      <added_mass>{numbers(added)}</added_mass>
      <linear_damping>{numbers(linear)}</linear_damping>
      <quadratic_damping>{numbers(quadratic)}</quadratic_damping>
    </link>
  </hydrodynamics>
</robot>
"""
    return text, p


@pytest.fixture
def single_body(tmp_path):
    """(path of the URDF, parameters) of one rigid body with a full Fossen block."""
    text, params = single_body_urdf()
    path = tmp_path / "single_body.urdf"
    path.write_text(text)
    return path, params


#: ``D_Q`` with a positive-definite symmetric part and an energy-injecting antisymmetric coupling.
QUADRATIC_INJECTING = (
    "<quadratic_damping>"
    "6.0 400.0 0.0 0.0 0.0 0.0 "
    "-400.0 60.0 0.0 0.0 0.0 0.0 "
    "0.0 0.0 60.0 0.0 0.0 0.0 "
    "0.0 0.0 0.0 0.2 0.0 0.0 "
    "0.0 0.0 0.0 0.0 8.0 0.0 "
    "0.0 0.0 0.0 0.0 0.0 8.0 "
    "</quadratic_damping>"
)
