"""The result files' task runner (:func:`aiauv_pin.results.outputs._run_tasks`) and its forked process.

Every task runs exactly once whichever process takes it; a failure in either process is raised
and leaves no process behind; the forked process starts with an empty math-text cache (its entries
hold the parent's fonts, whose files the two processes would otherwise read through one shared
file offset: garbled glyphs, ``FT_Load_Glyph ... failed``).
"""

from __future__ import annotations

import os
import sys
from functools import partial
from pathlib import Path

import pytest

from aiauv_pin.results import figures, outputs

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="fork")


def _write(folder: Path, name: str) -> None:
    (folder / name).write_text(str(os.getpid()))


def _fail(message: str) -> None:
    raise ValueError(message)


def _math_cache_size(folder: Path) -> None:
    from matplotlib.mathtext import MathTextParser

    info = MathTextParser._parse_cached.cache_info()
    (folder / f"math-{os.getpid()}").write_text(str(info.currsize))


@pytest.mark.parametrize("parallel", [True, False])
def test_every_task_runs_once(tmp_path, parallel):
    tasks = [partial(_write, tmp_path, f"task{k}") for k in range(9)]
    value = outputs._run_tasks(tasks, parallel, here_first=lambda: "summary")
    assert value == "summary"
    assert sorted(p.name for p in tmp_path.iterdir()) == [f"task{k}" for k in range(9)]
    writers = {p.read_text() for p in tmp_path.iterdir()}
    if not parallel:
        assert writers == {str(os.getpid())}


@pytest.mark.parametrize("where", range(3))
def test_a_failed_task_is_raised_whichever_process_ran_it(tmp_path, where):
    tasks = [partial(_write, tmp_path, f"task{k}") for k in range(4)]
    tasks.insert(where, partial(_fail, "bad figure"))
    with pytest.raises(ValueError, match="bad figure"):
        outputs._run_tasks(tasks, True)
    assert not [p for p in outputs._fork_context().active_children() if p.name == "aiauv-figures"]


def test_the_forked_process_parses_its_own_math_text(tmp_path):
    from matplotlib.mathtext import MathTextParser

    figures._prepare_figures("png")
    figures._stop_warming.clear()  # an earlier run in this process may have stopped the warm-up
    figures._warm_math()
    assert MathTextParser._parse_cached.cache_info().currsize > 0
    tasks = [partial(_math_cache_size, tmp_path) for _ in range(2)]
    # the first task is taken by one process, the second by the other or the same: both must
    # see an empty cache if they are the forked process
    tasks.insert(1, partial(_write, tmp_path, "slow"))
    outputs._run_tasks(tasks, True, here_first=partial(_write, tmp_path, "here"))
    sizes = {
        p.name.split("-")[1]: int(p.read_text()) for p in tmp_path.iterdir() if "math" in p.name
    }
    for pid, size in sizes.items():
        if pid != str(os.getpid()):
            assert size == 0
        else:
            assert size > 0


def test_a_matplotlib_without_the_private_math_cache_gets_no_warm_up(tmp_path, monkeypatch):
    """The shared math-text cache rests on matplotlib's private ``_parse_cached``: without it
    nothing is warmed (so nothing is shared with a forked process), and the forked process's
    emptying of the cache is a no-op instead of an AttributeError."""
    from matplotlib.mathtext import MathTextParser

    figures._prepare_figures("png")
    MathTextParser._parse_cached.cache_clear()
    monkeypatch.delattr(MathTextParser, "_parse_cached")
    assert figures._math_cache_clear() is None
    figures._stop_warming.clear()
    figures._warm_math()  # a no-op
    figures._forget_parsed_math()  # no AttributeError
    monkeypatch.undo()
    assert MathTextParser._parse_cached.cache_info().currsize == 0


def test_the_shared_math_parser_is_the_kind_an_agg_renderer_makes():
    """Its parse results must be what the Agg renderer unpacks: 6 values up to matplotlib 3.10,
    5 from 3.11 (a parser of the other kind broke every figure on Python 3.10)."""
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    own = RendererAgg(10, 10, outputs.FIGURE_DPI).mathtext_parser
    shared = figures._shared_math_parser()
    prop = FontProperties(size=10)
    assert len(shared.parse("$u_d$", outputs.FIGURE_DPI, prop)) == len(
        own.parse("$u_d$", outputs.FIGURE_DPI, prop)
    )
    renderer = RendererAgg(50, 50, outputs.FIGURE_DPI)
    renderer.mathtext_parser = shared  # as _render installs it
    width, height, descent = renderer.get_text_width_height_descent("$u_d$", prop, ismath=True)
    assert width > 0 and height > 0 and descent >= 0


def _result_of(n: int):
    """A passive-run result of ``n`` logged samples (every one written: no ``csv_period``)."""
    import dataclasses

    import numpy as np

    from aiauv_pin.scenario.definition import Scenario, ScenarioResult
    from aiauv_pin.simulation.fixed_step import Trajectory

    rng = np.random.default_rng(3)
    t = np.arange(n) * 0.01
    q = rng.normal(size=(n, 9))
    trajectory = Trajectory(
        t=t, q=q, v=rng.normal(size=(n, 8)), tau=np.zeros((n, 8)), info={"p": q[:, :3] * 1e-7}
    )
    scenario = dataclasses.replace(Scenario(), controller="none", csv_period=None)
    return ScenarioResult(scenario, trajectory, 0.0, ["j1", "j2"], [])


@pytest.mark.parametrize("parallel", [True, False])
def test_write_results_writes_the_same_table_with_one_or_two_processes(tmp_path, parallel):
    result = _result_of(2005)
    outputs.write_results(result, tmp_path, parallel=parallel, figures=False)
    outputs.write_timeseries(result, tmp_path / "once.csv")
    assert (tmp_path / "timeseries.csv").read_bytes() == (tmp_path / "once.csv").read_bytes()
