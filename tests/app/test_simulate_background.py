"""What ``aiauv simulate`` gives a second thread while the compiled loop is loaded and runs:
matplotlib's import when figures are drawn (from before the loop is loaded), the rows of
``timeseries.csv`` otherwise."""

from __future__ import annotations

import pytest

from aiauv_pin.app import cli
from aiauv_pin.results import outputs
from aiauv_pin.simulation import fixed_step


@pytest.mark.parametrize("figures", [True, False])
def test_the_second_thread_starts_before_the_loop_is_loaded(tmp_path, monkeypatch, figures):
    events = []
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


def test_a_run_the_compiled_loop_does_not_control_imports_nothing_beside_it(tmp_path, monkeypatch):
    """Lagged added mass runs the Python controller, which needs the GIL the whole run."""
    events = []
    monkeypatch.setattr(outputs, "preload_plotting", lambda: events.append("preload"))
    arguments = ["simulate", "--duration", "0.1", "--no-html", "--quiet", "--added-mass", "lagged"]
    assert cli.main([*arguments, "--out", str(tmp_path / "run")]) == 0
    assert events == []
