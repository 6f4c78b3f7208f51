"""``--fixed-base`` and ``--lenient`` on ``aiauv check`` and ``aiauv simulate``, and the scenario
keys ``fixed_base`` and ``lenient`` (issue 32)."""

from __future__ import annotations

import csv
from pathlib import Path

import aiauv_pin
from aiauv_pin.app.cli import main

DATA = Path(__file__).parents[1] / "data"
OBERON7 = DATA / "oberon7_uuv_simulator.urdf"


def test_check_refuses_then_repairs_and_says_fixed_base(capfd):
    assert main(["check", str(OBERON7)]) != 0
    _, err = capfd.readouterr()
    assert "'/base' is not allowed" in err and len(err.splitlines()) == 1
    assert main(["check", str(OBERON7), "--lenient"]) == 0
    out, err = capfd.readouterr()
    assert "root link 'world' (fixed base" in out
    repairs = [line for line in err.splitlines() if "lenient repair" in line]
    assert repairs and all(line.startswith("aiauv: warning:") for line in repairs)


def test_check_fixed_base_flag(capfd):
    path = aiauv_pin.bundled_urdf("uniform")
    assert main(["check", str(path), "--fixed-base"]) == 0
    out, _ = capfd.readouterr()
    assert "(fixed base" in out


def test_scenario_keys_fix_the_base_and_repair(tmp_path, capfd):
    scenario = tmp_path / "arm.toml"
    scenario.write_text(
        f'vehicle = "{OBERON7}"\nlenient = true\nfixed_base = true\nduration = 0.5\n'
        'dt = 0.005\n[controller]\ntype = "none"\n',
        encoding="utf-8",
    )
    out_dir = tmp_path / "out"
    assert main(["simulate", str(scenario), "--no-html", "--quiet", "--out", str(out_dir)]) == 0
    with (out_dir / "timeseries.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    first, last = rows[0], rows[-1]
    for key in ("base_x [m]", "base_y [m]", "base_z [m]", "base_quat_w [-]"):
        assert float(first[key]) == float(last[key])
    assert float(last["base_u [m/s]"]) == 0.0
    assert float(first["q_shoulder [rad]"]) != float(last["q_shoulder [rad]"])
