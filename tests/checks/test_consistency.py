"""The consistency checks of ``aiauv_pin.checks.consistency`` catch inconsistent models (issue 17).

Each deliberately broken model violates one law; the matching check must fail with a message that
names the figure and the tolerance, and the checks that do not concern the broken part still pass.
The checks' passing on the shipped vehicles is tested in ``test_dynamics.py`` and ``test_fast.py``.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import QUADRATIC_INJECTING

import aiauv_pin
from aiauv_pin.app.cli import main
from aiauv_pin.checks import consistency
from aiauv_pin.model.vehicle import Vehicle

DATA = Path(__file__).parents[1] / "data"


def test_every_check_is_in_the_pytest_suite():
    from aiauv_pin.testing import suite

    assert {f"test_{name}" for name in consistency.CHECKS} <= set(vars(suite))


def test_random_states_respect_joint_limits(paper_vehicle):
    rng = np.random.default_rng(1)
    limit = math.radians(65.0)
    joints = np.array([consistency.random_state(paper_vehicle, rng)[0][7:] for _ in range(200)])
    assert np.abs(joints).max() <= limit
    assert np.abs(joints).max() > 0.9 * limit  # the whole range is drawn


def test_mixed_error_is_allclose():
    expected = np.array([0.0, 1.0, -1000.0])
    got = expected + np.array([1e-9, 2e-9, 1.0005e-6])
    assert consistency.mixed_error(got, expected) == pytest.approx(1e-9, rel=1e-3)
    assert np.allclose(got, expected, rtol=1.001e-9, atol=1.001e-9)
    assert not np.allclose(got, expected, rtol=0.999e-9, atol=0.999e-9)


def test_run_checks_are_reproducible(paper_vehicle):
    first = consistency.check_invariance(paper_vehicle)
    assert consistency.check_invariance(paper_vehicle).figure == first.figure
    assert consistency.check_invariance(paper_vehicle, seed=3).figure != first.figure


# ---------------------------------------------------------------- broken models
def _asymmetric_added_mass(vehicle: Vehicle) -> Vehicle:
    """An added mass with a skew part on the first link, slipped past the loader's validation."""
    first = vehicle.hydro.links[0]
    skew = np.zeros((6, 6))
    skew[1, 5], skew[5, 1] = 0.5 * first.added_mass[1, 1], -0.5 * first.added_mass[1, 1]
    broken = dataclasses.replace(first)  # a valid copy, then overwritten behind the validation
    object.__setattr__(broken, "added_mass", first.added_mass + skew)
    hydro = dataclasses.replace(vehicle.hydro, links=(broken, *vehicle.hydro.links[1:]))
    return Vehicle(vehicle.model, hydro, name="broken", backend="pinocchio")


def test_asymmetric_added_mass_fails_symmetry(paper_vehicle):
    broken = _asymmetric_added_mass(paper_vehicle)
    result = consistency.check_mass_matrix_symmetric(broken)
    assert not result.passed
    assert result.figure > 1e-3
    message = result.message()
    assert message.startswith("mass_matrix_symmetric: FAIL: ")
    assert f"{result.figure:.3g} > tolerance 1e-12" in message and "\n" not in message


def test_indefinite_added_mass_fails(paper_vehicle):
    first = paper_vehicle.hydro.links[0]
    broken_link = dataclasses.replace(first)
    indefinite = first.added_mass.copy()
    indefinite[2, 2] = -indefinite[2, 2]  # heave added mass of the tail negative
    object.__setattr__(broken_link, "added_mass", indefinite)
    hydro = dataclasses.replace(
        paper_vehicle.hydro, links=(broken_link, *paper_vehicle.hydro.links[1:])
    )
    broken = Vehicle(paper_vehicle.model, hydro, backend="pinocchio")
    assert not consistency.check_added_mass_positive_semidefinite(broken).passed
    assert consistency.check_mass_matrix_symmetric(broken).passed


class LeverlessThrusters(Vehicle):
    """Thrusters whose moments are dropped: each column keeps only the base's force."""

    def thrust_matrix(self, q):
        matrix = super().thrust_matrix(q)
        matrix[3:] = 0.0
        return matrix


def test_thrust_matrix_without_lever_arms_fails(paper_vehicle):
    broken = LeverlessThrusters(paper_vehicle.model, paper_vehicle.hydro, backend="pinocchio")
    result = consistency.check_thrusters(broken)
    assert not result.passed and result.figure > 0.01
    assert consistency.check_thrusters(
        Vehicle(paper_vehicle.model, paper_vehicle.hydro, backend="pinocchio")
    ).passed


class EnergyInjectingDamping(Vehicle):
    """The damping forces with their sign flipped: they push along the relative velocity."""

    def __init__(self, model, hydro, **options):
        super().__init__(model, hydro, **options)
        self._undamped = Vehicle(
            pin.Model(model),
            hydro,
            added_mass=self.added_mass,
            damping=False,
            restoring=self.restoring,
            backend="pinocchio",
        )

    def fluid_forces(self, q, v, current=None, **options):
        forces = super().fluid_forces(q, v, current, **options)
        if not self.damping:
            return forces
        undamped = self._undamped.fluid_forces(q, v, current, **options).bias
        return dataclasses.replace(forces, bias=2.0 * undamped - forces.bias)

    def acceleration(self, q, v, tau, current=None, **options):
        forces = self.fluid_forces(q, v, current, **options)
        return np.linalg.solve(forces.mass_matrix, np.asarray(tau) - forces.bias)


def test_energy_injecting_damping_fails_dissipation_and_decay():
    vehicle = aiauv_pin.load_vehicle()
    broken = EnergyInjectingDamping(vehicle.model, vehicle.hydro, backend="pinocchio")
    dissipation = consistency.check_damping_dissipates(broken)
    assert not dissipation.passed and dissipation.figure > 0.0
    assert "must be negative" in dissipation.message()
    assert not consistency.check_energy_decays(broken, duration=2.0).passed
    # the power balance still holds: the injected force is accounted as damping
    assert consistency.check_power_balance(broken).passed


class DriftingPinocchio(Vehicle):
    """The Pinocchio path's acceleration off by one part in a million."""

    def acceleration(self, q, v, tau, current=None, **options):
        dv = super().acceleration(q, v, tau, current, **options)
        return dv * (1.0 + 1e-6) if self.active_backend == "pinocchio" else dv


def test_backends_that_disagree_fail(paper_vehicle):
    pytest.importorskip("numba")
    broken = DriftingPinocchio(paper_vehicle.model, paper_vehicle.hydro)
    result = consistency.check_backends_agree(broken)
    assert not result.passed and 1e-8 < result.figure < 1e-5


class BuoyancyIgnored(Vehicle):
    """Restoring forces from the weight alone, as if every volume were zero."""

    def restoring_forces(self, q):
        return pin.computeGeneralizedGravity(self.model, self.model.createData(), q)


def test_restoring_forces_without_buoyancy_fail_hydrostatics(paper_vehicle):
    broken = BuoyancyIgnored(paper_vehicle.model, paper_vehicle.hydro, backend="pinocchio")
    result = consistency.check_hydrostatics(broken)
    assert not result.passed and result.figure > 1.0


class NotInvariant(Vehicle):
    """A damping force tied to the world x axis (not to the vehicle): breaks invariance."""

    def acceleration(self, q, v, tau, current=None, **options):
        tau = np.array(tau, dtype=float)
        tau[0] -= 3.0 * q[0]  # a spring to the world origin along the base x
        return super().acceleration(q, v, tau, current, **options)


def test_world_anchored_force_fails_invariance(paper_vehicle):
    broken = NotInvariant(paper_vehicle.model, paper_vehicle.hydro, backend="pinocchio")
    assert not consistency.check_invariance(broken).passed


# ---------------------------------------------------------------- trim
def test_trim_of_the_stabilised_vehicle_is_level_and_neutral():
    balance = consistency.trim(aiauv_pin.load_vehicle(aiauv_pin.bundled_urdf("stabilised")))
    assert balance.roll == pytest.approx(0.0, abs=1e-12)
    assert balance.pitch == pytest.approx(0.0, abs=1e-12)
    assert abs(balance.net_buoyancy) < 1e-9 * balance.weight
    assert balance.warnings == ()
    # CB above CG by half a radius (PAPER_DATA: CG at -r/2 in every link)
    drop = balance.center_of_buoyancy - balance.center_of_gravity
    np.testing.assert_allclose(drop, [0.0, 0.0, 0.5 * 0.085], atol=1e-12)


def test_trim_of_a_heavy_tilted_vehicle(tmp_path):
    """A buoyant hull with CB ahead of and to port of the CG: pitch down, roll, positive net."""
    text = (DATA / "two_link_hydro.urdf").read_text()
    path = tmp_path / "two_link.urdf"
    path.write_text(text)
    vehicle = aiauv_pin.load_vehicle(path)
    balance = consistency.trim(vehicle)
    # independent: CG and CB of the straight vehicle from the URDF's numbers
    arm_volume = math.pi * 0.085**2 * 0.584
    cg = (30.0 * np.zeros(3) + 12.7 * np.array([0.692, 0, 0])) / 42.7
    cb = (0.0305 * np.array([0.05, 0, 0.02]) + arm_volume * np.array([0.692, 0, 0])) / (
        0.0305 + arm_volume
    )
    d = (cb - cg) / np.linalg.norm(cb - cg)
    assert balance.pitch == pytest.approx(-math.asin(d[0]), abs=1e-12)
    assert balance.roll == pytest.approx(math.atan2(d[1], d[2]), abs=1e-12)
    net = (1000.0 * (0.0305 + arm_volume) - 42.7) * 9.81
    assert balance.net_buoyancy == pytest.approx(net, rel=1e-12)
    assert any("positively buoyant" in w for w in balance.warnings)
    result = consistency.check_hydrostatics(vehicle)
    assert result.passed and result.warnings == balance.warnings


# ---------------------------------------------------------------- aiauv check --physics
def negative_damping_urdf(tmp_path) -> Path:
    """The two-link test vehicle with a hull whose quadratic damping injects energy.

    Its ``D_Q`` has a positive-definite symmetric part (so the validation gate, which checks that,
    accepts it) but a large antisymmetric surge-sway coupling: ``nu . D_Q (|nu| nu)`` is then
    negative for some velocities (e.g. ``u = 1, v = 0.5``), which only the dynamics checks see.
    """
    text = (DATA / "two_link_hydro.urdf").read_text()
    bad = text.replace(
        "<quadratic_damping>6 60 60 0.2 8 8</quadratic_damping>",
        QUADRATIC_INJECTING,
    )
    assert bad != text
    path = tmp_path / "negative_damping.urdf"
    path.write_text(bad)
    return path


def test_cli_physics_table_for_the_paper_vehicle(capfd):
    assert main(["check", "--physics", str(aiauv_pin.bundled_urdf("stabilised"))]) == 0
    out, err = capfd.readouterr()
    assert err == ""
    lines = out.splitlines()
    assert lines[1].split() == ["check", "figure", "tolerance", "verdict"]
    for name in consistency.CHECKS:
        row = next(line for line in lines if line.startswith(name + " "))
        assert row.split()[-1] == "pass", row
    assert lines[-1] == f"{len(consistency.CHECKS)} of {len(consistency.CHECKS)} checks passed"
    assert any(line.startswith("trim roll +0.00 deg, pitch +0.00 deg") for line in lines)


def test_trim_line_prints_what_rounds_to_zero_as_plus_zero():
    # the paper vehicle's trim is zero up to rounding errors whose sign differs between platforms
    # (pitch 5.2e-15 rad with Python 3.11's wheels, -0.0 with 3.13's, printed "-0.00 deg")
    tiny = consistency.Trim(
        roll=-1e-17,
        pitch=-1e-18,
        net_buoyancy=-1e-13,
        weight=900.0,
        center_of_gravity=np.zeros(3),
        center_of_buoyancy=np.array([0.0, 0.0, 0.01]),
        warnings=(),
    )
    assert tiny.describe() == (
        "trim roll +0.00 deg, pitch +0.00 deg; net buoyancy -1e-13 N (+0.00 % of the weight)"
    )
    tilted = tiny._replace(roll=math.radians(-1.236), pitch=math.radians(2.0), net_buoyancy=-9.0)
    assert tilted.describe() == (
        "trim roll -1.24 deg, pitch +2.00 deg; net buoyancy -9 N (-1.00 % of the weight)"
    )


def test_cli_physics_fails_on_negative_damping(tmp_path, capfd):
    assert main(["check", "--physics", str(negative_damping_urdf(tmp_path))]) == 1
    out, err = capfd.readouterr()
    row = next(line for line in out.splitlines() if line.startswith("damping_dissipates "))
    assert row.split()[-1] == "FAIL"
    assert "failed: damping_dissipates: FAIL: " in out and ">= tolerance 0 (" in out
    assert "warning: hydrostatics: not neutrally buoyant" in out
    assert err.count("\n") == 1
    assert err.startswith("aiauv: error: ") and "damping_dissipates" in err


def test_cli_physics_bad_input_is_one_line(tmp_path, capfd):
    assert main(["check", "--physics", str(tmp_path / "missing.urdf")]) == 1
    out, err = capfd.readouterr()
    assert out == "" and err == f"aiauv: error: {tmp_path / 'missing.urdf'}: no such file\n"


def test_cli_physics_unusable_vehicle_is_one_line(tmp_path, capfd):
    path = tmp_path / "ghost.urdf"
    path.write_text(
        '<robot name="ghost"><link name="a"><inertial><mass value="0"/>'
        '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link></robot>'
    )
    assert main(["check", "--physics", str(path)]) == 1
    out, err = capfd.readouterr()
    assert out == "" and err.count("\n") == 1 and "singular" in err


def test_table_counts_skipped_checks(tmp_path):
    """A single body without thrusters: the thruster check is skipped, and said to be."""
    from conftest import single_body_urdf

    path = tmp_path / "single_body.urdf"
    path.write_text(single_body_urdf()[0])
    results = consistency.run_checks(aiauv_pin.load_vehicle(path))
    skipped = [r for r in results if r.skipped]
    assert [r.name for r in skipped] == ["thrusters"]
    assert skipped[0].message() == "thrusters: skipped (the vehicle has no thrusters)"
    table = consistency.format_results(results)
    assert table.endswith(f"{len(results) - 1} of {len(results)} checks passed, 1 skipped")


def test_bad_sample_count_is_a_clear_error(paper_vehicle):
    with pytest.raises(ValueError, match="samples must be a positive whole number, got 0"):
        consistency.check_thrusters(paper_vehicle, samples=0)


class QuasiSteadyOnly(Vehicle):
    """A model that neglects the water's acceleration whatever the current says (issue 33)."""

    def acceleration(self, q, v, tau, current=None, *, t=0.0):
        if current is not None and hasattr(current, "quasi_steady"):
            current = current.quasi_steady()
        return super().acceleration(q, v, tau, current, t=t)


def test_unsteady_flow_check_passes_and_catches_a_quasi_steady_model(paper_vehicle):
    result = consistency.check_unsteady_flow(paper_vehicle)
    assert result.passed, result.message()
    assert result.measurements["backends"] <= 1e-9
    broken = QuasiSteadyOnly(paper_vehicle.model, paper_vehicle.hydro, backend="pinocchio")
    failed = consistency.check_unsteady_flow(broken)
    assert not failed.passed and failed.figure > 1e-3
    assert "Morison inertia force" in failed.message()
