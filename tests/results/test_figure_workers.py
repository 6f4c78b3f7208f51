"""The figure process ``aiauv simulate`` forks before a run (:mod:`aiauv_pin.results.figure_workers`)
and the shared log it reads the run from (:class:`aiauv_pin._internal.log_memory.SharedLog`): the
same figures as drawn in one process, failures raised here, stopped with this process."""

from __future__ import annotations

import multiprocessing
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from PIL import Image

from aiauv_pin import load_vehicle
from aiauv_pin._internal.log_memory import SharedLog
from aiauv_pin.results import figures, outputs
from aiauv_pin.results.figure_workers import FigureWorkers
from aiauv_pin.scenario.definition import PaperScenario, finish_run, plan_run
from aiauv_pin.simulation.fixed_step import simulate
from aiauv_pin.testing.processes import wait_gone

linux_only = pytest.mark.skipif(
    not SharedLog.available() or sys.platform != "linux", reason="memfd and fork (Linux)"
)


@linux_only
def test_an_array_in_the_log_is_named_by_its_place_and_rebuilt_from_it():
    log_file = SharedLog()
    try:
        log = log_file.empty((50, 7))
        assert log.shape == (50, 7) and log.flags.c_contiguous and not log.any()
        log[:] = np.arange(350.0).reshape(50, 7)
        views = [log, log[:, 0], log[10:20, 2:5], log[::3, 1], log[::-2, 6], log[5], log[-1, -1:]]
        for view in views:
            reference = log_file.reference(view)
            assert reference is not None
            rebuilt = log_file.view(reference)
            assert np.array_equal(rebuilt, view) and np.shares_memory(rebuilt, log)
        # not in the log: a copy, other memory, another type, nothing at all
        for other in (log[:, 0].copy(), np.zeros(3), log.astype(np.float32), log[:0]):
            assert log_file.reference(other) is None
    finally:
        log_file.close()


def _sum_of_named(connection, log_file: SharedLog) -> None:
    connection.send(float(log_file.view(connection.recv()).sum()))


@linux_only
def test_a_process_forked_before_the_log_was_made_reads_what_was_written_after():
    log_file = SharedLog()
    context = multiprocessing.get_context("fork")
    here, there = context.Pipe()
    process = context.Process(target=_sum_of_named, args=(there, log_file))
    process.start()
    try:
        log = log_file.empty((1000, 4))  # sized, mapped and written after the fork
        log[:] = np.random.default_rng(1).normal(size=(1000, 4))
        here.send(log_file.reference(log[::7, 1:3]))
        assert here.recv() == float(log[::7, 1:3].sum())
    finally:
        process.join()
        log_file.close()


@pytest.fixture(scope="module")
def shared_run():
    """A short compiled paper run logged into a figure process's shared log, and the process."""
    if not SharedLog.available() or sys.platform != "linux":
        pytest.skip("memfd and fork (Linux)")
    scenario = PaperScenario(duration=2.0, dt=0.004)
    workers = FigureWorkers()
    plan = plan_run(load_vehicle(), scenario)
    assert plan.compiled
    trajectory = simulate(*plan.arguments, **plan.options, log_memory=workers.log.empty)
    result = finish_run(plan, trajectory, 0.0)
    assert workers.log.reference(result.trajectory.info["u"]) is not None  # the run's log
    yield workers, result
    workers.close()


def _pixels(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGBA"))


def test_the_figure_process_draws_the_figures_drawn_here(shared_run, tmp_path):
    workers, result = shared_run
    assert workers.warm(60.0)
    workers.draw(outputs.figure_data(result, vehicle_name="shared"), tmp_path / "there")
    workers.wait()
    here = outputs.write_figures(result, tmp_path / "here", parallel=False, vehicle_name="shared")
    assert [p.name for p in here] == list(outputs.FIGURES)
    for path in here:
        assert np.array_equal(_pixels(tmp_path / "there" / path.name), _pixels(path)), path.name


@linux_only
def test_a_failure_in_the_figure_process_is_raised_here(tmp_path):
    scenario = PaperScenario(duration=1.0, dt=0.01)
    plan = plan_run(load_vehicle(), scenario)
    workers = FigureWorkers()
    try:
        trajectory = simulate(*plan.arguments, **plan.options, log_memory=workers.log.empty)
        blocked = tmp_path / "a file"
        blocked.write_text("not a folder")
        workers.draw(outputs.figure_data(finish_run(plan, trajectory, 0.0)), blocked / "figures")
        with pytest.raises(OSError):
            workers.wait()
        assert not workers._process.is_alive()
    finally:
        workers.close()
    with pytest.raises(ValueError, match="unknown figure format 'gif'"):
        FigureWorkers.draw(workers, None, tmp_path, figure_format="gif")


@pytest.mark.parametrize("failing", ["fig7_pointing.png", "fig6_base_angles.png"])
def test_a_figure_that_fails_is_raised_whichever_figure_process_drew_it(
    shared_run, tmp_path, monkeypatch, failing
):
    """The slowest figure is drawn first and the fastest last: by either process."""
    _, result = shared_run
    render = figures._render

    def failing_render(data, folder, names, *arguments):
        if failing in names:
            raise RuntimeError(f"cannot draw {failing}")
        return render(data, folder, names, *arguments)

    monkeypatch.setattr(figures, "_render", failing_render)  # before the processes fork
    workers = FigureWorkers()
    try:
        workers.draw(outputs.figure_data(result), tmp_path / "figures")
        with pytest.raises(RuntimeError, match=f"cannot draw {failing}"):
            workers.wait()
    finally:
        workers.close()


def test_without_a_second_process_the_first_draws_every_figure(shared_run, tmp_path, monkeypatch):
    from aiauv_pin.results import figure_workers

    def no_process_left(*arguments):
        raise BlockingIOError("fork: Resource temporarily unavailable")

    _, result = shared_run
    monkeypatch.setattr(figure_workers, "_fork_second", no_process_left)  # before the fork
    workers = FigureWorkers()
    try:
        assert workers.draw(outputs.figure_data(result), tmp_path / "figures")
        workers.wait()
    finally:
        workers.close()
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == sorted(outputs.FIGURES)


def test_a_failure_before_the_figures_are_asked_for_is_raised_when_they_are(
    shared_run, tmp_path, monkeypatch
):
    from aiauv_pin.results import figure_workers

    def broken(*arguments):
        raise RuntimeError("broken set-up")

    _, result = shared_run
    monkeypatch.setattr(figure_workers, "_fork_second", broken)
    workers = FigureWorkers()
    try:
        assert workers.warm(60.0)  # the table is not kept waiting
        workers.draw(outputs.figure_data(result), tmp_path / "figures")
        with pytest.raises(RuntimeError, match="broken set-up"):
            workers.wait()
    finally:
        workers.close()


def test_figure_data_that_does_not_pickle_is_drawn_here(shared_run, tmp_path):
    import dataclasses

    class LocalName(str):  # defined in a function: its instances do not pickle
        pass

    _, result = shared_run
    odd = dataclasses.replace(result, thruster_names=[LocalName(n) for n in result.thruster_names])
    workers = FigureWorkers()
    assert not workers.draw(outputs.figure_data(odd), tmp_path / "unsent")
    outputs.write_results(odd, tmp_path / "run", figure_workers=workers)
    assert workers._process.exitcode is not None
    assert sorted(p.name for p in (tmp_path / "run" / "figures").iterdir()) == sorted(
        outputs.FIGURES
    )


@linux_only
def test_a_figure_process_not_needed_any_more_is_stopped_at_once():
    workers = FigureWorkers()
    workers.close()  # still importing matplotlib, or waiting: killed, not waited for
    assert workers._process.exitcode == -signal.SIGKILL
    workers.close()  # twice is harmless


_ORPHAN = textwrap.dedent(
    """
    import sys, time
    from aiauv_pin.results.figure_workers import FigureWorkers
    workers = FigureWorkers()
    print(workers._process.pid, flush=True)
    time.sleep(60)
    """
)


@linux_only
def test_the_figure_process_dies_with_the_process_that_forked_it():
    parent = subprocess.Popen(
        [sys.executable, "-c", _ORPHAN], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL
    )
    try:
        child = int(parent.stdout.readline())
    finally:
        parent.send_signal(signal.SIGKILL)
        parent.wait()
    assert not wait_gone({child}, 10.0), "the figure process outlived its parent"


def test_figure_workers_are_not_started_where_they_cannot_run(monkeypatch):
    monkeypatch.setattr(sys, "platform", "darwin")
    assert not FigureWorkers.available()
    assert FigureWorkers.start() is None


def test_the_figure_process_is_forked_before_anything_heavy_is_imported():
    """``aiauv simulate`` forks it first thing: the package, the figure modules and the command
    line import neither numba, Pinocchio, matplotlib nor the project's compiled packages."""
    code = (
        "import sys, aiauv_pin, aiauv_pin.app.cli, aiauv_pin.results.figure_workers; "
        "print(sorted({m.split('.')[0] for m in sys.modules}"
        " & {'numba', 'pinocchio', 'matplotlib', 'scipy', 'aiauv_hydro', 'aiauv_control'}))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_png_figures_hold_the_pixels_and_resolution_savefig_writes(shared_run, tmp_path):
    _, result = shared_run
    for name in ("fig2_cross_track.png", "path_3d.png"):
        fig = figures._draw(name, outputs.figure_data(result))
        fig.set_dpi(outputs.FIGURE_DPI)
        fig.savefig(tmp_path / "savefig.png", dpi=outputs.FIGURE_DPI)
        outputs.write_png(fig, tmp_path / "ours.png")
        ours = Image.open(tmp_path / "ours.png")
        assert ours.mode == "RGBA" and ours.info["dpi"] == pytest.approx((200, 200), abs=1e-3)
        assert np.array_equal(_pixels(tmp_path / "ours.png"), _pixels(tmp_path / "savefig.png"))
