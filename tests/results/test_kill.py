"""Kill tests (issue 11): SIGKILL ``aiauv simulate`` and ``aiauv sweep`` at random moments.

* ``simulate`` into a folder an earlier (shorter) run wrote: after each kill the folder is either the
  earlier complete run or the new complete run, every file of it present and of that run (the
  summary's duration matches the CSV's last time); no process of the killed run survives it (the
  figure worker dies with its parent).
* ``sweep``: killed while it runs, then run again: the table is complete and every run's metrics
  equal those computed in this process (nothing lost, nothing counted twice, nothing stale).

The kill moments come from a seeded generator, so CI tries the same ones each time. A few tens of
seconds in all.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from aiauv_pin.results.outputs import FIGURES
from aiauv_pin.testing.processes import descendants, wait_gone

SEED = 20261122
#: Kills of ``simulate`` (``AIAUV_KILLS`` for a longer campaign) and of the sweep.
SIMULATE_KILLS = int(os.environ.get("AIAUV_KILLS", "3"))
SWEEP_KILLS = int(os.environ.get("AIAUV_SWEEP_KILLS", "1"))


def _aiauv(*args: str) -> list[str]:
    return [
        sys.executable,
        "-c",
        "from aiauv_pin.app.cli import console_main; console_main()",
        *args,
    ]


def _assert_complete_run(out: Path) -> float:
    """The folder holds every file of one complete run; return its simulated time."""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete"
    for name in FIGURES:
        assert (out / "figures" / name).stat().st_size > 0, name
    assert (out / "playback.html").stat().st_size > 0
    with open(out / "timeseries.csv", newline="") as handle:
        rows = list(csv.reader(handle))
    assert all(len(row) == len(rows[0]) for row in rows)
    last_time = float(rows[-1][0])
    assert last_time == pytest.approx(summary["simulated_time"], abs=1e-9)
    # the manifest lists exactly the files of the folder: what a later run may delete
    from aiauv_pin._internal.result_folder import MARKER, read_manifest

    written = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert set(read_manifest(out)["files"]) == written - {MARKER}
    return last_time


@pytest.mark.skipif(sys.platform != "linux", reason="uses /proc and SIGKILL")
def test_killed_simulate_never_leaves_a_folder_claiming_what_it_lacks(tmp_path):
    out = tmp_path / "run"
    start = time.monotonic()
    subprocess.run(
        _aiauv("simulate", "--duration", "0.5", "--out", str(out), "--quiet"),
        check=True,
        capture_output=True,
    )
    full = time.monotonic() - start
    assert _assert_complete_run(out) == pytest.approx(0.5)
    rng = np.random.default_rng(SEED)
    outcomes = []
    for _ in range(SIMULATE_KILLS):
        delay = float(rng.uniform(0.4, 1.0)) * full
        process = subprocess.Popen(
            _aiauv("simulate", "--duration", "1", "--out", str(out), "--quiet"),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        time.sleep(delay)
        family = descendants(process.pid)
        process.send_signal(signal.SIGKILL)
        process.wait()
        assert not wait_gone(family, 5.0), "a child of the killed simulate survived it"
        if out.exists():
            outcomes.append(_assert_complete_run(out))
        else:
            outcomes.append(None)
    assert set(outcomes) <= {0.5, 1.0}, outcomes
    # a later run cleans up what the killed ones left and replaces the folder whole
    subprocess.run(
        _aiauv("simulate", "--duration", "0.5", "--out", str(out), "--quiet", "--no-html"),
        check=True,
        capture_output=True,
    )
    assert not (out / "playback.html").exists()  # nothing stale of an earlier run
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


SWEEP = """duration = 0.5
dt = 0.01
method = "rk4"
[grid]
k_e = [0.05, 0.08, 0.1]
"""
_IDENTITY = ("worker", "started_at", "finished_at", "task_time")


@pytest.mark.skipif(sys.platform != "linux", reason="uses /proc and SIGKILL")
def test_killed_sweep_resumes_to_exactly_the_full_table(tmp_path):
    pytest.importorskip("distributed")
    from aiauv_pin.scenario.sweep_runner import execute_run, read_records, read_table
    from aiauv_pin.scenario.sweep_spec import load_sweep_spec

    spec = tmp_path / "s.toml"
    spec.write_text(SWEEP)
    out = tmp_path / "out"
    command = _aiauv(
        "sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet", "--no-plots"
    )
    rng = np.random.default_rng(SEED)
    partial: dict = {}
    for _ in range(SWEEP_KILLS):
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(float(rng.uniform(3.0, 8.0)))
        family = descendants(process.pid)
        process.send_signal(signal.SIGKILL)
        process.wait()
        survivors = wait_gone(family, 10.0)
        for pid in survivors:  # reported by the assertion below; not left running
            os.kill(pid, signal.SIGKILL)
        assert not survivors, "a worker of the killed sweep survived it"
        records = read_records(out)
        for run_id, record in partial.items():  # a finished run is never run again
            assert records[run_id] == record
        partial = records
        if (out / "results.csv").exists():
            for row in read_table(out / "results.csv"):
                assert row["run_id"] in partial and row["status"] == "complete"
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    records = read_records(out)
    points = load_sweep_spec(spec).points()
    assert sorted(records) == sorted(p.run_id for p in points)
    rows = read_table(out / "results.csv")
    assert [row["run_id"] for row in rows] == [p.run_id for p in points]
    text = spec.read_text()
    vehicle = points[0].vehicle.read_text()
    for point in points:
        expected = execute_run(
            point.run_id, point.parameters, vehicle, point.parameters["vehicle_sha256"]
        )
        record = records[point.run_id]
        assert record["status"] == expected["status"] == "complete"
        for key, value in expected["metrics"].items():
            if key not in ("wall_time", "real_time_factor"):
                # the same run in another process: equal to the last digit or two only, because
                # numba compiles a caller differently when its callees come from the disk cache
                # (no inlining, so fast-math contracts differently); every bookkeeping check above
                # and below stays exact
                got = record["metrics"][key]
                if isinstance(value, float):
                    assert got == pytest.approx(value, rel=1e-12, abs=1e-15), key
                else:
                    assert got == value, key
        if point.run_id in partial:  # a run finished before the kill was not run again
            assert partial[point.run_id] == record
    assert text == (out / "spec.toml").read_text()


@pytest.mark.skipif(sys.platform != "linux", reason="uses /proc and SIGKILL")
def test_runs_of_a_killed_worker_are_run_again_not_lost(tmp_path):
    pytest.importorskip("distributed")
    from aiauv_pin.scenario.sweep_runner import read_records

    spec = tmp_path / "s.toml"
    # each run takes ~1.5 s once compiled (30,000 steps), so the worker is killed mid-sweep: with
    # 5 s runs it finished all five in the 0.1 s between a first record and the kill (CI, 2026-11-22)
    spec.write_text("duration = 60.0\ndt = 0.002\n[grid]\nk_e = [0.05, 0.06, 0.07, 0.08, 0.09]\n")
    out = tmp_path / "out"
    command = _aiauv(
        "sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet", "--no-plots"
    )
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    runs = out / "runs"
    deadline = time.monotonic() + 300  # a cold numba cache compiles first
    while not (runs.is_dir() and any(runs.glob("*.json"))) and time.monotonic() < deadline:
        time.sleep(0.1)
    killed = 0
    for pid in descendants(process.pid):
        try:
            command_line = Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:
            continue
        if b"spawn_main" in command_line:  # the worker process (not the resource tracker)
            os.kill(pid, signal.SIGKILL)
            killed += 1
    assert killed == 1
    assert len(list(runs.glob("*.json"))) < 5, "the worker finished before the kill: runs too short"
    _, err = process.communicate(timeout=300)
    assert process.returncode == 0, err
    records = read_records(out)
    assert len(records) == 5
    assert {record["status"] for record in records.values()} == {"complete"}
    assert len({record["worker"] for record in records.values()}) == 2  # a new worker took over


# --- child processes end with their parent, also on SIGKILL (issue 29) ------------------------------


def _kill_parent_and_wait(code: str) -> tuple[int, set[int]]:
    """Run ``code`` in a helper process that prints a child's pid; SIGKILL the helper; return the
    child's pid and whatever of it is still alive 10 s later (polled)."""
    parent = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        line = parent.stdout.readline()
        if not line.strip():
            pytest.fail(f"the helper printed no pid: {parent.stderr.read()[-500:]}")
        child = int(line)
        family = descendants(parent.pid)
        assert child in family
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    survivors = wait_gone(family, 10.0)
    for pid in survivors:  # reported by the caller's assertion; not left running
        os.kill(pid, signal.SIGKILL)
    return child, survivors


@pytest.mark.skipif(sys.platform != "linux", reason="uses /proc and SIGKILL")
def test_meshcat_server_dies_with_a_killed_parent():
    pytest.importorskip("meshcat")
    # the real code path of ``simulate --view``: viewer.MeshcatViewer starts it with start_server;
    # the server takes the first free ports from 6000/7000 (meshcat's search), no fixed port here
    code = (
        "import time\n"
        "from aiauv_pin.results.meshcat_server import start_server\n"
        "server = start_server()\n"
        "print(server.process.pid, flush=True)\n"
        "time.sleep(120)\n"
    )
    child, survivors = _kill_parent_and_wait(code)
    assert not survivors, f"the meshcat server {child} outlived its killed parent"


@pytest.mark.skipif(sys.platform != "linux", reason="uses /proc and SIGKILL")
@pytest.mark.parametrize("how", ["prctl", "watchdog"])
def test_parent_death_helper_ends_the_child(how):
    # the watchdog is what runs where prctl is unavailable: forced here by turning prctl off
    code = (
        "import os, time\n"
        "from aiauv_pin._internal import parent_death\n"
        f"if {how == 'watchdog'}:\n"
        "    parent_death._prctl_death_signal = lambda signum: False\n"
        "parent = os.getpid()\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        f"    assert parent_death.die_with_parent(parent) == {how!r}\n"
        "    time.sleep(120)\n"
        "    os._exit(0)\n"
        "print(pid, flush=True)\n"
        "time.sleep(120)\n"
    )
    child, survivors = _kill_parent_and_wait(code)
    assert not survivors, f"the child {child} outlived its killed parent ({how})"
