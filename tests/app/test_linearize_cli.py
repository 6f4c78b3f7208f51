"""``aiauv linearize SCENARIO.toml`` (issue 16): the modes table, and one-line errors for bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from aiauv_pin.app.cli import main

pytest.importorskip("numba")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "straight_stabilised.toml"


def test_prints_the_modes_of_the_stabilised_vehicle(capsys):
    assert main(["linearize", str(EXAMPLE)]) == 0
    out = capsys.readouterr().out
    assert "joint servo" in out and "eigenvalue" in out
    # the slow, lightly damped heave-pitch mode of the roll-stabilised vehicle
    assert "e-02 +2.98" in out


def test_open_loop_and_speed_flags(capsys):
    assert main(["linearize", str(EXAMPLE), "--open-loop", "--speed", "1.0"]) == 0
    out = capsys.readouterr().out
    assert "open loop" in out and "at 1 m/s" in out


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["linearize", "missing.toml"], "not a regular file"),
        (["linearize", "EXAMPLE", "--speed", "fast"], "is not a number"),
    ],
)
def test_bad_input_is_one_line(arguments, message, capsys):
    arguments = [str(EXAMPLE) if a == "EXAMPLE" else a for a in arguments]
    try:
        status = main(arguments)
    except SystemExit as exc:  # argparse usage errors
        status = exc.code
    err = capsys.readouterr().err
    assert status != 0 and message in err and len(err.strip().splitlines()) == 1


def test_non_uniform_current_is_one_line(tmp_path, capsys):
    scenario = tmp_path / "shear.toml"
    scenario.write_text(
        '[current]\ntype = "shear"\nvelocity = [0.1, 0.0, 0.0]\ngradient = [0.0, 0.0, 0.1]\n'
    )
    assert main(["linearize", str(scenario)]) != 0
    err = capsys.readouterr().err
    assert "uniform in space" in err and len(err.strip().splitlines()) == 1
