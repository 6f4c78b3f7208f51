"""Lagged added mass (UUV Simulator / gz-sim) against its closed form, and against the exact scheme.

The closed form (:func:`aiauv_pin.dynamics.lagged_added_mass.growth_factors`): along a mode with
added-to-rigid mass
ratio ``mu`` under a state-independent force, the lagged acceleration's deviation from the exact
one is multiplied by ``lambda = 1 - alpha (1 + mu)`` every step, whatever ``dt``.
"""

from __future__ import annotations

import numpy as np
import pytest

import aiauv_pin
from aiauv_hydro.laws.fluid_terms import GZ_SIM_FILTER, UUV_SIMULATOR_FILTER
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.dynamics.lagged_added_mass import growth_factors, mass_ratios, slender_link_urdf
from aiauv_pin.errors import AiauvError, SimulationDiverged


def _rod(tmp_path, mass_ratio: float, **options) -> aiauv_pin.Vehicle:
    path = tmp_path / f"rod_{mass_ratio:g}.urdf"
    path.write_text(slender_link_urdf(mass_ratio), encoding="utf-8")
    return aiauv_pin.load_vehicle(path, damping=False, restoring=False, **options)


def test_the_rod_has_the_requested_sway_mass_ratio(tmp_path):
    rod = _rod(tmp_path, 1.25, backend="pinocchio")
    q = rod.neutral_configuration()
    mu = mass_ratios(rod, q)
    assert mu[-1] == pytest.approx(1.25, rel=1e-12)  # pure sway (and heave) at the centre
    assert mu[0] == pytest.approx(0.0, abs=1e-12)  # roll: a circular section has no added inertia


@pytest.mark.parametrize(
    ("mass_ratio", "alpha"),
    [(1.0, UUV_SIMULATOR_FILTER), (1.0, GZ_SIM_FILTER), (1.2, GZ_SIM_FILTER), (0.5, 0.6)],
)
@pytest.mark.parametrize("dt", [0.01, 0.002])
def test_sway_acceleration_follows_the_closed_form_recursion(tmp_path, mass_ratio, alpha, dt):
    rod = _rod(tmp_path, mass_ratio, backend="pinocchio")
    mass = rod.model.inertias[1].mass
    force = np.zeros(rod.nv)
    force[1], force[5] = mass, mass * 0.5  # a sway force of m N at the centre (L = 1 m)
    steps = 12
    run = aiauv_pin.simulate(
        rod,
        rod.neutral_configuration(),
        np.zeros(rod.nv),
        steps * dt,
        dt,
        lambda t, q, v: force,
        added_mass="lagged",
        lagged_filter=alpha,
    )
    acceleration = np.diff(run.v[:, 1]) / dt  # mean sway acceleration of each step [m/s^2]
    exact = 1.0 / (1.0 + mass_ratio)  # F / (m + mu m)
    deviation = acceleration - exact
    assert deviation[0] == pytest.approx(1.0 - exact, rel=1e-12)  # first step: rigid mass only
    factor = growth_factors(alpha, mass_ratio)
    np.testing.assert_allclose(deviation[1:], factor * deviation[:-1], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(run.v[:, 5], 0.0, atol=1e-12)  # no yaw: a pure sway mode


def test_gz_sim_scheme_diverges_for_a_light_rod_and_the_exact_one_does_not(tmp_path):
    rod = _rod(tmp_path, 1.5, backend="pinocchio")
    q0, v0 = rod.neutral_configuration(), np.array([0.5, 0.3, 0.0, 0.0, 0.0, 0.4])
    try:  # |lambda| = 1.5: the start-up deviation grows 1.5^100 = 4e17 times in 100 steps
        run = aiauv_pin.simulate(rod, q0, v0, 1.0, 0.01, added_mass="lagged", lagged_filter=1.0)
        assert np.abs(run.v[-1]).max() > 1e6
    except SimulationDiverged:
        pass
    run = aiauv_pin.simulate(rod, q0, v0, 1.0, 0.01)
    energy = [rod.kinetic_energy(q, v) for q, v in zip(run.q, run.v, strict=True)]
    np.testing.assert_allclose(energy, energy[0], rtol=1e-9)


def test_exact_scheme_conserves_energy_and_impulse_the_lagged_ones_do_not(tmp_path):
    """A tumbling neutral rod in an ideal fluid: the Munk moment couples sway, surge and yaw."""
    rod = _rod(tmp_path, 1.0, backend="pinocchio")
    q0, v0 = rod.neutral_configuration(), np.array([0.5, 0.3, 0.0, 0.0, 0.0, 0.4])

    def drifts(**options):
        run = aiauv_pin.simulate(rod, q0, v0, 2.0, 0.01, **options)
        energy = np.array([rod.kinetic_energy(q, v) for q, v in zip(run.q, run.v, strict=True)])
        impulse = np.array([rod.momentum_in_world(q, v) for q, v in zip(run.q, run.v, strict=True)])
        return (
            np.abs(energy / energy[0] - 1.0).max(),
            np.abs(impulse - impulse[0]).max() / np.linalg.norm(impulse[0]),
        )

    energy, impulse = drifts()
    assert energy < 1e-9 and impulse < 1e-8  # RK4 truncation at dt = 0.01 s
    for alpha in (UUV_SIMULATOR_FILTER, GZ_SIM_FILTER):
        energy, impulse = drifts(added_mass="lagged", lagged_filter=alpha)
        assert energy > 1e-3 and impulse > 1e-3


def test_lagged_runs_with_the_compiled_dynamics_too(tmp_path):
    pytest.importorskip("numba")
    runs = []
    for backend in ("pinocchio", "numba"):
        rod = _rod(tmp_path, 1.0, backend=backend)
        q0, v0 = rod.neutral_configuration(), np.array([0.5, 0.3, 0.0, 0.0, 0.0, 0.4])
        runs.append(aiauv_pin.simulate(rod, q0, v0, 0.5, 0.01, added_mass="lagged"))
    np.testing.assert_allclose(runs[0].v, runs[1].v, rtol=1e-9, atol=1e-12)


def test_bad_lagged_arguments_get_one_line(tmp_path):
    rod = _rod(tmp_path, 1.0, backend="pinocchio")
    q0, v0 = rod.neutral_configuration(), np.zeros(rod.nv)
    cases = [
        ({"added_mass": "filtered"}, "added_mass must be one of exact, lagged"),
        ({"added_mass": "lagged", "lagged_filter": 0.0}, "lagged_filter must be in (0, 1]"),
        ({"added_mass": "lagged", "lagged_filter": "0.3"}, "lagged_filter must be a number"),
        (
            {"added_mass": "lagged", "controller": CompiledController.passive()},
            "not a compiled one",
        ),
    ]
    for options, message in cases:
        with pytest.raises(AiauvError) as error:
            aiauv_pin.simulate(rod, q0, v0, 0.1, 0.01, **options)
        assert message in str(error.value) and "\n" not in str(error.value)


def test_scenario_files_select_the_lagged_scheme_and_sweeps_keep_it(tmp_path):
    from aiauv_pin.scenario.definition import Scenario, run_scenario, summary
    from aiauv_pin.scenario.sweep_spec import scenario_from_parameters, scenario_parameters
    from aiauv_pin.scenario.toml_file import ScenarioFileError, load_scenario

    path = tmp_path / "lagged.toml"
    path.write_text('duration = 0.05\ndt = 0.005\nadded_mass = "lagged"\nlagged_filter = 1.0\n')
    scenario = load_scenario(path)
    assert (scenario.added_mass, scenario.lagged_filter) == ("lagged", 1.0)
    result = run_scenario(aiauv_pin.load_vehicle(), scenario)
    assert result.extra["compiled_controller"] is False  # the Python controller ran
    assert summary(result)["parameters"]["added_mass"] == "lagged"
    resolved = scenario_parameters(scenario)
    rebuilt = scenario_from_parameters(resolved)  # what a sweep's worker runs
    assert (rebuilt.added_mass, rebuilt.lagged_filter) == ("lagged", 1.0)
    assert "added_mass" not in scenario_parameters(Scenario())  # exact runs keep their keys
    for line, message in (
        ('added_mass = "implicit"', "added_mass: expected one of exact, lagged"),
        ("lagged_filter = 1.5", r"lagged_filter: expected a number in \(0, 1\], got 1.5"),
        ("lagged_filter = 0", r"lagged_filter: expected a number in \(0, 1\], got 0"),
    ):
        path.write_text(line + "\n")
        with pytest.raises(ScenarioFileError, match=message):
            load_scenario(path)
    with pytest.raises(ValueError, match="not with added_mass = 'lagged'"):
        run_scenario(
            aiauv_pin.load_vehicle(),
            Scenario(duration=0.05, controller="thruster_turning", added_mass="lagged"),
        )


def test_lagged_law_compiled_equals_interpreted_and_matches_its_formula(paper_vehicle, rng):
    from aiauv_hydro.laws.fluid_terms import add_lagged_added_mass_bias, coriolis_wrench
    from aiauv_hydro.numerics.jit import interpreted

    added = paper_vehicle.fluid_model().added_mass
    nb = added.shape[0]
    relative, previous, filtered = (rng.normal(size=(nb, 6)) for _ in range(3))
    dt, alpha = 0.01, 0.3
    expected_filtered = (1 - alpha) * filtered + alpha * (relative - previous) / dt
    coriolis = interpreted(coriolis_wrench)
    expected = np.einsum("nij,nj->ni", added, expected_filtered)
    expected += np.array([coriolis(added[b], relative[b]) for b in range(nb)])
    for function in (add_lagged_added_mass_bias, interpreted(add_lagged_added_mass_bias)):
        state = (previous.copy(), filtered.copy())
        bias = np.zeros((nb, 6))
        function(added, relative, state[0], state[1], dt, alpha, bias)
        np.testing.assert_allclose(state[1], expected_filtered, rtol=1e-12, atol=1e-9)
        np.testing.assert_array_equal(state[0], relative)  # the previous twists move on
        np.testing.assert_allclose(bias, expected, rtol=1e-11, atol=1e-8)
