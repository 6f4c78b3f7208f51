"""A user's compiled path and current may allocate arrays: the compiled loop runs without reference
counting, and calls a user's function from a reference-counted function
(:data:`aiauv_hydro.numerics.jit.USER_CALL_OPTIONS`); the run is the built-in one's."""

from __future__ import annotations

import dataclasses

import numba
import numpy as np
import pytest

from aiauv_control.paths import HelixPath, UserPath, helix_point
from aiauv_hydro.currents import Current
from aiauv_pin import load_vehicle
from aiauv_pin.scenario.definition import PaperScenario, plan_run
from aiauv_pin.simulation.fixed_step import simulate


@numba.njit
def helix_through_a_copy(position, params):
    """The built-in helix, from a copy of the position (an allocation)."""
    return helix_point(position.copy(), params)


@numba.njit
def current_as_an_array(t, x, y, z, parameters):
    """A uniform current returned as a new array."""
    velocity = np.empty(3)
    velocity[:] = parameters
    return velocity


def _run(scenario):
    plan = plan_run(load_vehicle(), scenario)
    assert plan.compiled
    return simulate(*plan.arguments, **plan.options)


@pytest.mark.slow  # compiles the loop for the user's functions: about 1.5 min of CPU
def test_a_user_path_and_current_that_allocate_run_as_the_built_in_ones():
    helix = HelixPath(centre=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0), radius=2.0, pitch=10.0)
    water = (0.1, -0.05, 0.02)
    built_in = PaperScenario(duration=0.4, path=helix, current=water)
    user = dataclasses.replace(
        built_in,
        path=UserPath(helix_through_a_copy, helix.params),
        current=Current(current_as_an_array, np.array(water), "user", unsteady=False),
    )
    expected, got = _run(built_in), _run(user)
    assert got.status == "complete"
    assert np.allclose(got.q, expected.q, rtol=0.0, atol=1e-12)
    assert np.allclose(got.v, expected.v, rtol=0.0, atol=1e-12)
