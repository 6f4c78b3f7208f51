"""``timeseries.csv`` formatted while the compiled loop runs: the same bytes, whatever the thread
read, and how it finds the rows written."""

from __future__ import annotations

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.results import outputs
from aiauv_pin.results.streamed_table import (
    FormattedRows,
    StreamedTable,
    TableStream,
    log_columns_of_table,
)
from aiauv_pin.scenario.definition import Scenario, finish_run, plan_run
from aiauv_pin.simulation.fixed_step import complete_rows, simulate


@pytest.fixture(scope="module")
def vehicle():
    return aiauv_pin.load_vehicle()


def _streamed_run(vehicle, scenario):
    """The run of ``scenario`` with a :class:`TableStream`: its result and what the stream
    formatted."""
    plan = plan_run(vehicle, scenario)
    stream = TableStream.for_plan(plan)
    assert stream is not None
    try:
        trajectory = simulate(*plan.arguments, **plan.options, log_reader=stream.read)
    finally:
        streamed = stream.close()
    return finish_run(plan, trajectory, 1.0), streamed


def _drained_run(vehicle, scenario):
    """The run of ``scenario``, and what a :class:`TableStream` formats of its finished log
    (every row but the last, whatever the machine's load)."""
    plan = plan_run(vehicle, scenario)
    logs = []
    trajectory = simulate(*plan.arguments, **plan.options, log_reader=logs.append)
    stream = TableStream.for_plan(plan)
    stream.read(logs[0])  # a log written to its end: every row but the last is complete
    return finish_run(plan, trajectory, 1.0), stream.close(drain=True)


@pytest.mark.parametrize("rows", [1, 2, 3, 10, 1000])
def test_complete_rows_are_those_before_the_last_row_written(rows):
    log = np.zeros((rows, 5))
    assert complete_rows(log) == 0
    for written in range(1, rows + 1):
        log[written - 1, 0] = 0.01 * (written - 1)  # the time of row 0 is 0
        assert complete_rows(log) == max(0, written - 1)


def test_the_loop_hands_the_reader_a_zero_log_it_then_fills(vehicle):
    plan = plan_run(vehicle, Scenario(duration=0.2))  # a small log, not a mapped one
    seen = []

    def reader(log):
        seen.append((log, np.count_nonzero(log)))

    trajectory = simulate(*plan.arguments, **plan.options, log_reader=reader)
    [(log, nonzero)] = seen
    assert nonzero == 0 and complete_rows(log) == len(trajectory.t) - 1
    np.testing.assert_array_equal(log[:, 0], trajectory.t)


def test_the_streamed_table_is_the_file_without_streaming(vehicle, tmp_path):
    result, streamed = _streamed_run(vehicle, Scenario(duration=20.0))  # whatever it formatted
    outputs.write_timeseries(result, tmp_path / "plain.csv")
    outputs.write_timeseries(result, tmp_path / "streamed.csv", streamed)
    assert (tmp_path / "streamed.csv").read_bytes() == (tmp_path / "plain.csv").read_bytes()
    for parallel in (True, False):  # in blocks shared by two processes, and in one
        outputs.write_results(
            result, tmp_path / str(parallel), figures=False, parallel=parallel, streamed=streamed
        )
        written = (tmp_path / str(parallel) / "timeseries.csv").read_bytes()
        assert written == (tmp_path / "plain.csv").read_bytes()


def test_a_streamed_runs_summary_is_the_one_computed_in_one_thread(vehicle, tmp_path):
    """With a streamed table, the energy block is computed by a second thread beside the table's
    last rows (:func:`aiauv_pin.results.outputs.write_results`): the same ``summary.json``."""
    result, streamed = _drained_run(vehicle, Scenario(duration=20.0))
    expected = outputs.write_summary(result, tmp_path / "plain.json")
    assert "energy" in expected
    for parallel in (True, False):
        got = outputs.write_results(
            result, tmp_path / str(parallel), figures=False, parallel=parallel, streamed=streamed
        )
        assert got == expected
        summary = (tmp_path / str(parallel) / "summary.json").read_bytes()
        assert summary == (tmp_path / "plain.json").read_bytes()


def test_the_energy_threads_failure_is_raised_and_leaves_no_summary(vehicle, tmp_path, monkeypatch):
    result, streamed = _drained_run(vehicle, Scenario(duration=2.0))

    def failing(result):
        raise ArithmeticError("energy model failed")

    monkeypatch.setattr(outputs, "energy_summary", failing)
    with pytest.raises(ArithmeticError, match="energy model failed"):
        outputs.write_results(result, tmp_path / "run", figures=False, streamed=streamed)
    assert not (tmp_path / "run" / "summary.json").exists()


def test_rows_whose_numbers_differ_by_one_bit_are_formatted_again(vehicle, tmp_path):
    result, streamed = _drained_run(vehicle, Scenario(duration=4.0))
    _, table = outputs.timeseries_content(result)
    blocks = list(streamed.blocks)
    assert len(blocks) >= 3
    changed = blocks[1].values.copy()
    changed.view(np.uint64)[0, 1] ^= 1  # the last bit of one number
    blocks[1] = FormattedRows(changed, outputs.format_rows(changed))
    tampered = StreamedTable(tuple(blocks))
    done, parts = tampered.parts_for(table)
    text = "".join(parts)
    assert done == blocks[0].values.shape[0] and text == blocks[0].text
    outputs.write_timeseries(result, tmp_path / "plain.csv")
    outputs.write_timeseries(result, tmp_path / "tampered.csv", tampered)
    assert (tmp_path / "tampered.csv").read_bytes() == (tmp_path / "plain.csv").read_bytes()


def test_the_probe_finds_each_column_of_the_table_in_the_log(vehicle):
    plan = plan_run(vehicle, Scenario(duration=1.0))
    columns = log_columns_of_table(plan)
    result = finish_run(plan, simulate(*plan.arguments, **plan.options), 1.0)
    _, table = outputs.timeseries_content(result)
    assert len(columns) == table.shape[1]
    t, q = result.trajectory.t, result.trajectory.q
    nq = q.shape[1]
    log_t = np.column_stack([t, q])  # the log's first 1 + nq columns
    rows = outputs.csv_rows(result)
    for k, column in enumerate(columns):
        if column < 1 + nq:
            np.testing.assert_array_equal(table[:, k], log_t[rows, column])


def test_a_run_whose_table_is_computed_after_it_is_not_streamed(vehicle):
    # a passive run's end-effector position is computed from its configurations after the run
    plan = plan_run(vehicle, Scenario(duration=1.0, controller="none"))
    assert log_columns_of_table(plan) is None and TableStream.for_plan(plan) is None


def test_the_stream_formats_every_row_before_the_last_one_written(vehicle):
    result, streamed = _drained_run(vehicle, Scenario(duration=20.0))
    _, table = outputs.timeseries_content(result)
    done, parts = streamed.parts_for(table)
    text = "".join(parts)
    assert done == len(table) - 1 and len(streamed.blocks) >= 3  # all but the last row, in blocks
    assert text == outputs.format_rows(table[:done])


def test_a_probe_that_fails_leaves_the_run_unstreamed(vehicle, monkeypatch):
    from aiauv_pin.results import streamed_table

    def failing(plan):
        raise ArithmeticError("probe")

    monkeypatch.setattr(streamed_table, "log_columns_of_table", failing)
    assert TableStream.for_plan(plan_run(vehicle, Scenario(duration=1.0))) is None
