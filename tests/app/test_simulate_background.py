"""What ``aiauv simulate`` does beside the compiled loop: on Linux a figure process, forked
before the simulation's modules are imported, imports matplotlib while a second thread formats the rows of
``timeseries.csv`` (once that process is warm); elsewhere that thread imports matplotlib when
figures are drawn (from before the loop is loaded) and formats the rows otherwise."""

from __future__ import annotations

import pytest

from aiauv_pin.app import cli
from aiauv_pin.model import loading
from aiauv_pin.results import outputs
from aiauv_pin.results.figure_workers import FigureWorkers
from aiauv_pin.simulation import fixed_step


@pytest.mark.parametrize("figures", [True, False])
def test_the_second_thread_starts_before_the_loop_is_loaded(tmp_path, monkeypatch, figures):
    """Where no figure process can be forked (not Linux): matplotlib is imported by a thread."""
    events = []
    monkeypatch.setattr(FigureWorkers, "start", classmethod(lambda cls: None))
    monkeypatch.setattr(outputs, "preload_plotting", lambda: events.append("preload"))
    simulate = fixed_step.simulate

    def recording(*arguments, compile_only=False, log_reader=None, **options):
        events.append("load" if compile_only else "run, streamed" if log_reader else "run")
        return simulate(*arguments, compile_only=compile_only, log_reader=log_reader, **options)

    monkeypatch.setattr(fixed_step, "simulate", recording)
    arguments = ["simulate", "--duration", "0.2", "--no-html", "--quiet"]
    arguments += ["--out", str(tmp_path / "run")] + ([] if figures else ["--no-figures"])
    assert cli.main(arguments) == 0
    assert events == (["preload", "load", "run"] if figures else ["load", "run, streamed"])
    assert (tmp_path / "run" / "figures").is_dir() is figures


@pytest.mark.skipif(not FigureWorkers.available(), reason="no figure process on this system")
def test_the_figure_process_is_forked_before_the_vehicle_is_read(tmp_path, monkeypatch):
    """On Linux: forked before the vehicle is read, the run logged into its shared log, the
    table formatted during the run once it is warm; no matplotlib import in this process."""
    events = []
    start, load, simulate = FigureWorkers.start.__func__, loading.load_vehicle, fixed_step.simulate
    started = []

    def starting(cls):
        events.append("fork")
        started.append(start(cls))
        return started[-1]

    def loading_vehicle(*arguments, **options):
        events.append("vehicle")
        return load(*arguments, **options)

    def recording(*arguments, compile_only=False, log_reader=None, log_memory=None, **options):
        if compile_only:
            events.append("load")
        else:
            events.append(f"run, streamed {log_reader is not None}")
            events.append(f"shared log {log_memory == started[-1].log.empty}")
        return simulate(
            *arguments,
            compile_only=compile_only,
            log_reader=log_reader,
            log_memory=log_memory,
            **options,
        )

    monkeypatch.setattr(FigureWorkers, "start", classmethod(starting))
    monkeypatch.setattr(loading, "load_vehicle", loading_vehicle)
    monkeypatch.setattr(fixed_step, "simulate", recording)
    monkeypatch.setattr(outputs, "preload_plotting", lambda: events.append("preload"))
    arguments = ["simulate", "--duration", "0.2", "--no-html", "--quiet"]
    assert cli.main([*arguments, "--out", str(tmp_path / "run")]) == 0
    assert events == ["fork", "vehicle", "load", "run, streamed True", "shared log True"]
    assert sorted(p.name for p in (tmp_path / "run" / "figures").iterdir()) == sorted(
        outputs.FIGURES
    )
    assert started[-1]._process.exitcode is not None  # stopped once the files were written


def test_a_run_the_compiled_loop_does_not_control_imports_nothing_beside_it(tmp_path, monkeypatch):
    """Lagged added mass runs the Python controller, which needs the GIL the whole run."""
    events = []
    monkeypatch.setattr(outputs, "preload_plotting", lambda: events.append("preload"))
    arguments = ["simulate", "--duration", "0.1", "--no-html", "--quiet", "--added-mass", "lagged"]
    assert cli.main([*arguments, "--out", str(tmp_path / "run")]) == 0
    assert events == []
