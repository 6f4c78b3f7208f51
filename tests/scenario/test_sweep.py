"""Parameter sweeps on Dask: spec expansion and run keys, one-line spec errors, a sweep on a local
cluster and on a separately started scheduler with two workers, divergence recorded, resume."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from aiauv_pin.app import cli
from aiauv_pin.model.loading import bundled_urdf, load_vehicle
from aiauv_pin.scenario.definition import run_paper_scenario, summary
from aiauv_pin.scenario.sweep_runner import (
    flatten_summary,
    read_records,
    read_table,
    run_sweep,
    runs_folder,
    write_record,
)
from aiauv_pin.scenario.sweep_spec import (
    SweepSpecError,
    scenario_from_parameters,
    sweep_spec_from_toml,
)

pytest.importorskip("distributed")

# 2 complete runs of 4 s, and 2 with dt = 2 s that blow up at the second step (t = 4 s) with RK4
# (the duration is a whole number of both steps: an inconsistent duration and dt is refused)
SWEEP = """
duration = 4.0
method = "rk4"
[grid]
k_e = [0.05, 0.1]
dt = [0.01, 2.0]
"""


def _spec(tmp_path: Path, text: str = SWEEP) -> Path:
    path = tmp_path / "spec.toml"
    path.write_text(text, encoding="utf-8")
    return path


# --- spec expansion and run keys ---------------------------------------------------------------


def test_grid_times_random_uses_the_same_draws_on_every_grid_point():
    spec_text = """
        case = "stabilised"
        duration = 10
        [grid]
        k_p = [1.0, 2.0]
        "initial_offset.y" = { linspace = [1.0, 3.0, 3] }
        [random]
        samples = 4
        seed = 7
        "current.y" = { uniform = [-0.2, 0.2] }
        feedforward = { choice = ["exact", "paper"] }
        """
    points = sweep_spec_from_toml(spec_text).points()
    assert len(points) == 2 * 3 * 4
    assert {p.parameters["start.position.y"] for p in points} == {1.0, 2.0, 3.0}
    assert all(p.parameters["controller.k_d"] == 12.0 for p in points)  # the stabilised case's k_D
    draws = {}
    for p in points:
        draw = (p.parameters["current.velocity.y"], p.parameters["controller.feedforward"])
        assert -0.2 <= draw[0] <= 0.2
        draws.setdefault(p.sample, set()).add(draw)
    assert sorted(draws) == [0, 1, 2, 3]
    assert all(len(d) == 1 for d in draws.values())  # common random numbers across the grid
    more = sweep_spec_from_toml(spec_text.replace("samples = 4", "samples = 6")).points()
    assert {p.run_id for p in points} < {p.run_id for p in more}  # more samples keep the first ones


def test_run_id_depends_on_the_resolved_run_only(tmp_path):
    def ids(text: str, base=tmp_path) -> list[str]:
        return [p.run_id for p in sweep_spec_from_toml(text, base).points()]

    base = ids('case = "uniform"\nduration = 60.0')
    assert ids("duration = 60") == base  # int or float, default case
    assert ids("duration = 60.0\nk_d = 19.0\nk_e = [0.05, 0.05]\n") == base  # the defaults
    assert ids("duration = 60.0\nk_p = 2.5") != base
    assert ids('duration = 60.0\ncase = "stabilised"') != base
    # the vehicle enters through its content, not its name
    copy = tmp_path / "copy.urdf"
    shutil.copyfile(bundled_urdf("uniform"), copy)
    assert ids('duration = 60.0\nvehicle = "copy.urdf"') == base
    copy.write_text(copy.read_text(encoding="utf-8") + "\n<!-- changed -->\n", encoding="utf-8")
    assert ids('duration = 60.0\nvehicle = "copy.urdf"') != base
    # and it is the same in a fresh interpreter
    code = (
        "from aiauv_pin.scenario.sweep_spec import sweep_spec_from_toml as s;"
        "print(s('duration = 60.0').points()[0].run_id)"
    )
    fresh = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert fresh.stdout.strip() == base[0]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("[grid]\nk_x = [1.0]", "grid.k_x: unknown key"),
        ("[grid]\nk_p = []", "grid.k_p: expected a non-empty list of numbers"),
        ("[random]\nsamples = 3\nk_p = { uniform = [2.0, 1.0] }", "empty range"),
        ('dt = "fast"', "dt: expected a number in [1e-6, 10], got 'fast'"),
        ('[grid]\nmethod = ["rk4", "rk5"]', "grid.method[1]: expected one of rk4, euler"),
        (
            "[grid]\nk_p = { linspace = [1.0, 2.0, 0] }",
            "grid.k_p: count must be a whole number >= 1",
        ),
        ("[random]\nk_p = { normal = [1.0, 0.1] }", "'samples' (number of draws) is missing"),
        ("k_p = 1.0\n[grid]\nk_p = [1.0, 2.0]", "'k_p' is also set in fixed parameters"),
        ("current = [0.1, 0.2]", "current: expected a list of 3 numbers"),
        ("[grid]\nk_p = [1.0, -1.0]", "grid.k_p[1]: expected a number in (0, 1000], got -1.0"),
        ("[grid]\nk_p = [true]", "grid.k_p[0]: expected a number in (0, 1000] (a bool is not"),
        ('k_d = "19"', "k_d: expected a number in (0, 1e4], got '19'"),
        (
            "[random]\nsamples = 2\nk_p = { normal = [0.0, 1.0] }",
            "run 2 (k_p=-0.1321048632913019): controller.k_p: expected a number in (0, 1000]",
        ),
        ("[grid]\nk_p = { linspace = [1.0, 2.0, 1e9] }", "grid.k_p: count must be a whole"),
        ("[grid]\nk_p = { linspace = [1.0, 2.0, 1000000000] }", "<= 100000, got 1e9"),
        (
            "[grid]\nk_p = { linspace = [1.0, 2.0, 1000] }\nk_d = { linspace = [1.0, 2.0, 1000] }",
            "the spec expands to 1000000 runs, more than 100000",
        ),
        ("k_e = [0.1, 0.2, 0.3]", "k_e: expected a number in (0, 100] or a list of 2 numbers"),
        ('vehicle = "missing.urdf"', "cannot read"),
        ("duration = 1e6\ndt = 0.01", "duration: expected a number in (0, 1e5], got"),
        ("duration = 1e5\ndt = 0.01", "exceeds"),
        ("[grid\nk_p = 1", "invalid TOML"),
    ],
)
def test_bad_specs_raise_one_line_errors(tmp_path, text, expected):
    with pytest.raises(SweepSpecError) as error:
        sweep_spec_from_toml(text, tmp_path).points()
    message = str(error.value)
    assert "\n" not in message
    assert expected in message
    assert isinstance(error.value, ValueError)


def test_cli_reports_a_bad_spec_as_one_line(tmp_path, capsys):
    spec = _spec(tmp_path, "[grid]\nk_p = [1.0]\nalpah = [0.5]\n")
    status = cli.main(["sweep", str(spec), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert status == 1
    assert err.count("\n") == 1
    assert err.startswith(f"aiauv: error: {spec}: grid.alpah: unknown key")
    assert not (tmp_path / "out").exists()


# --- sweeps on Dask ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def local_sweep(tmp_path_factory):
    """The sweep run on the default local cluster (2 worker processes)."""
    folder = tmp_path_factory.mktemp("local")
    report = run_sweep(_spec(folder), folder / "out", workers=2, progress=False)
    return folder / "out", report


@pytest.fixture(scope="module")
def serial_metrics():
    """The two complete runs of the sweep, simulated here, by k_e."""
    spec = sweep_spec_from_toml(SWEEP)
    vehicle = load_vehicle(bundled_urdf("uniform"))
    metrics = {}
    for point in spec.points():
        if point.parameters["dt"] == 0.01:
            result = run_paper_scenario(vehicle, scenario_from_parameters(point.parameters))
            metrics[point.parameters["controller.k_e.y"]] = flatten_summary(summary(result))
    return metrics


@pytest.fixture(scope="module")
def external_scheduler(tmp_path_factory):
    """A scheduler and two single-threaded workers started as separate processes on loopback."""
    folder = tmp_path_factory.mktemp("dask")
    scheduler_file = folder / "scheduler.json"
    log = open(folder / "dask.log", "w")  # closed in the teardown
    processes: list[subprocess.Popen] = []

    def start(*args: str) -> subprocess.Popen:
        process = subprocess.Popen(
            [sys.executable, "-m", *args], stdout=log, stderr=subprocess.STDOUT, cwd=folder
        )
        processes.append(process)
        return process

    try:
        scheduler = start(
            "distributed.cli.dask_scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            "0",
            "--no-dashboard",
            "--scheduler-file",
            str(scheduler_file),
        )
        deadline = time.monotonic() + 60.0
        address = None
        while address is None:
            assert scheduler.poll() is None, "the scheduler exited"
            assert time.monotonic() < deadline, "no scheduler file within 60 s"
            try:
                address = json.loads(scheduler_file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        workers = [
            start(
                "distributed.cli.dask_worker",
                address,
                "--nthreads",
                "1",
                "--no-nanny",
                "--no-dashboard",
                "--name",
                f"worker-{k}",
                "--local-directory",
                str(folder),
            )
            for k in range(2)
        ]
        yield address, {w.pid for w in workers}
    finally:
        # workers first, each to its end, then the scheduler: a worker told to stop while the
        # scheduler closes its connection can hang in its own shutdown
        for process in reversed(processes):
            process.terminate()
            try:
                process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(timeout=10)
        log.close()


def _check_sweep(out: Path, report, serial: dict) -> dict[str, dict]:
    records = read_records(out)
    points = sweep_spec_from_toml(SWEEP).points()
    assert report.counts == {"complete": 2, "diverged": 2, "error": 0, "lost": 0, "pending": 0}
    assert sorted(records) == sorted(p.run_id for p in points)
    rows = read_table(out / "results.csv")
    assert [row["run_id"] for row in rows] == [p.run_id for p in points]
    for row, point in zip(rows, points, strict=True):
        record = records[point.run_id]
        assert float(row["controller.k_e.y"]) == point.parameters["controller.k_e.y"]
        assert float(row["dt"]) == point.parameters["dt"]
        assert record["worker"].split(":")[-1] != str(os.getpid())
        if point.parameters["dt"] == 2.0:
            # explicit RK4 with dt = 2 s is far outside its stability region
            assert row["status"] == "diverged"
            assert "non-finite at t = 4 s" in row["message"]
            assert float(row["simulated_time"]) == 4.0
            assert row["final.p_y"] == ""
        else:
            # a worker process computes exactly what this process computes
            assert row["status"] == "complete"
            expected = serial[point.parameters["controller.k_e.y"]]
            for key in ("final.p_y", "final.p_z", "final.u", "total_thruster_work"):
                assert math.isclose(float(row[key]), expected[key], rel_tol=1e-12)
            assert int(row["steps"]) == 400
    return records


def test_local_cluster_sweep_records_every_run(local_sweep, serial_metrics):
    out, report = local_sweep
    assert report.executed == 4 and report.skipped == 0
    records = _check_sweep(out, report, serial_metrics)
    assert len({r["worker"] for r in records.values()}) >= 1
    assert (out / "figures" / "settling_time_k_e_dt.png").stat().st_size > 0
    assert json.loads((out / "sweep.json").read_text())["counts"]["pending"] == 0


def test_external_scheduler_runs_the_same_sweep(
    tmp_path, external_scheduler, local_sweep, serial_metrics
):
    address, worker_pids = external_scheduler
    report = run_sweep(_spec(tmp_path), tmp_path / "out", scheduler=address, progress=False)
    records = _check_sweep(tmp_path / "out", report, serial_metrics)
    assert {int(r["worker"].split(":")[-1]) for r in records.values()} <= worker_pids
    local = read_records(local_sweep[0])
    for key, record in records.items():
        assert record["status"] == local[key]["status"]
        assert record["metrics"].get("final.p_y") == local[key]["metrics"].get("final.p_y")


def test_interrupted_sweep_resumes_with_the_missing_runs_only(tmp_path, external_scheduler):
    address, _ = external_scheduler
    out = tmp_path / "out"
    seen = []

    def interrupt(record):
        seen.append(record["run_id"])
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(_spec(tmp_path), out, scheduler=address, progress=False, on_record=interrupt)
    first = read_records(out)
    assert list(first) == seen  # the run that finished is on disk, the others were cancelled
    assert [row["run_id"] for row in read_table(out / "results.csv")] == seen
    assert json.loads((out / "sweep.json").read_text())["counts"]["pending"] == 3

    report = run_sweep(_spec(tmp_path), out, scheduler=address, progress=False, plots=False)
    assert report.skipped == 1
    assert sorted(report.executed_ids) == sorted(set(read_records(out)) - set(seen))
    assert read_records(out)[seen[0]] == first[seen[0]]  # not run again
    assert report.counts["complete"] == 2 and report.counts["diverged"] == 2

    # a deleted record and a lost run are executed again; the others are not
    records = read_records(out)
    deleted, lost, *_ = sorted(records)
    (runs_folder(out) / f"{deleted}.json").unlink()
    write_record(out, {**records[lost], "status": "lost", "metrics": {}})
    report = run_sweep(_spec(tmp_path), out, scheduler=address, progress=False, plots=False)
    assert sorted(report.executed_ids) == sorted([deleted, lost])
    assert report.skipped == 2
    after = read_records(out)
    assert after[lost]["status"] == records[lost]["status"]
    assert after[lost]["finished_at"] > records[lost]["finished_at"]
    for key in set(records) - {deleted, lost}:
        assert after[key] == records[key]
