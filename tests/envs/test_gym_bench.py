"""``aiauv bench --only gym``: the table and the physics it reports (nothing timed here)."""

from __future__ import annotations

import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("mujoco")

from aiauv_pin.tools.bench_command import WHOLE_RUN_PARTS
from aiauv_pin.tools.gym_benchmarks import format_gym, physics


def _spread(median, low, high):
    return {"median": median, "min": low, "max": high}


def test_gym_is_a_part_of_aiauv_bench():
    assert "gym" in WHOLE_RUN_PARTS


def test_physics_of_one_step_on_each_side():
    sides = physics()
    ours, theirs = sides["aiauv/Swimming-v0"], sides["Swimmer-v5"]
    assert (ours["links"], ours["dof"], ours["substeps"]) == (9, 14, 10)
    assert ours["fluid_terms_links"]["added_mass_6x6"] == 9
    assert (theirs["links"], theirs["dof"], theirs["substeps"]) == (3, 5, 4)
    assert ours["step_s"] == pytest.approx(theirs["step_s"])  # both 0.04 s per step


def test_format_gym_prints_medians_ranges_ratios_and_the_physics():
    single = {
        "aiauv/Swimming-v0": {
            **_spread(15000, 10000, 16000),
            "ratio_to_swimmer_v5": _spread(0.75, 0.7, 1.1),
        },
        "Swimmer-v5": _spread(17000, 14000, 22000),
    }
    row = {
        "env_steps_per_s": _spread(15000, 10000, 23000),
        "swimmer_v5_sync_env_steps_per_s": _spread(6600, 5500, 8800),
        "ratio_to_swimmer_v5_sync": _spread(2.4, 1.3, 3.7),
    }
    results = {
        "gym": {
            "single_steps_per_s": single,
            "vector": {"64": row},
            "physics": {
                "aiauv/Swimming-v0": {
                    "links": 9,
                    "dof": 14,
                    "integrator": "euler",
                    "substeps": 10,
                    "dt_s": 0.004,
                }
            },
            "load_before": [3.0, 0, 0],
            "load_after": [3.4, 0, 0],
        }
    }
    text = "\n".join(format_gym(results))
    assert "15000 /s (10000-16000)" in text
    assert "0.750x (0.700-1.100)" in text
    assert "N=64" in text and "9 links, 14 DOF" in text and "3.00, 3.40" in text
