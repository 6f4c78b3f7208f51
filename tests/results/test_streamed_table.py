"""``timeseries.csv`` formatted while the compiled loop runs: the same bytes, whatever the thread
read, and the chunks that hand it the rows."""

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
from aiauv_pin.simulation.fixed_step import shrinking_chunks, simulate


@pytest.fixture(scope="module")
def vehicle():
    return aiauv_pin.load_vehicle()


def _streamed_run(vehicle, scenario):
    """The run of ``scenario`` with a :class:`TableStream`: its result, what the stream formatted
    and the row counts ``on_chunk`` saw."""
    plan = plan_run(vehicle, scenario)
    stream = TableStream.for_plan(plan)
    assert stream is not None
    seen = []

    def on_chunk(rows):
        seen.append(len(rows))
        stream.on_chunk(rows)

    try:
        trajectory = simulate(*plan.arguments, **plan.options, on_chunk=on_chunk)
    finally:
        streamed = stream.close()
    return finish_run(plan, trajectory, 1.0), streamed, seen


@pytest.mark.parametrize("n_steps", [1, 2, 5, 79, 80, 81, 1000, 75_000])
def test_shrinking_chunks_cover_the_run_in_a_few_chunks_that_shrink(n_steps):
    stops, k = [], 0
    while k < n_steps:
        k = shrinking_chunks(k, n_steps)
        stops.append(k)
    assert stops[-1] == n_steps and stops == sorted(set(stops))
    sizes = np.diff([0, *stops])
    assert len(sizes) <= 8
    assert np.all(np.diff(sizes[:-1]) <= 0)  # never growing, but for the last
    assert sizes[-1] <= 2 * max(1, -(-n_steps // 40))  # the rest waits for at most 5 %


def test_the_streamed_table_is_the_file_without_streaming(vehicle, tmp_path):
    result, streamed, seen = _streamed_run(vehicle, Scenario(duration=20.0))
    assert seen == sorted(seen) and seen[-1] == len(result.trajectory.t) and len(seen) >= 5
    rows = len(outputs.csv_rows(result))
    _, table, formats = outputs.timeseries_content(result)
    done, _ = streamed.text_for(table, formats)
    assert done > rows // 2  # most of it formatted during the run (all, on an idle machine)
    outputs.write_timeseries(result, tmp_path / "plain.csv")
    outputs.write_timeseries(result, tmp_path / "streamed.csv", streamed)
    assert (tmp_path / "streamed.csv").read_bytes() == (tmp_path / "plain.csv").read_bytes()
    for parallel in (True, False):  # in blocks shared by two processes, and in one
        outputs.write_results(
            result, tmp_path / str(parallel), figures=False, parallel=parallel, streamed=streamed
        )
        written = (tmp_path / str(parallel) / "timeseries.csv").read_bytes()
        assert written == (tmp_path / "plain.csv").read_bytes()


def test_rows_whose_numbers_differ_by_one_bit_are_formatted_again(vehicle, tmp_path):
    result, streamed, _ = _streamed_run(vehicle, Scenario(duration=4.0))
    _, table, formats = outputs.timeseries_content(result)
    blocks = list(streamed.blocks)
    assert len(blocks) >= 3
    changed = blocks[1].values.copy()
    changed.view(np.uint64)[0, 1] ^= 1  # the last bit of one number
    blocks[1] = FormattedRows(changed, outputs.format_rows(changed, formats))
    tampered = StreamedTable(tuple(blocks), streamed.formats)
    done, text = tampered.text_for(table, formats)
    assert done == blocks[0].values.shape[0] and text == blocks[0].text
    assert tampered.text_for(table, ["%r"] * len(formats)) == (0, "")
    outputs.write_timeseries(result, tmp_path / "plain.csv")
    outputs.write_timeseries(result, tmp_path / "tampered.csv", tampered)
    assert (tmp_path / "tampered.csv").read_bytes() == (tmp_path / "plain.csv").read_bytes()


def test_the_probe_finds_each_column_of_the_table_in_the_log(vehicle):
    plan = plan_run(vehicle, Scenario(duration=1.0))
    columns, formats = log_columns_of_table(plan)
    result = finish_run(plan, simulate(*plan.arguments, **plan.options), 1.0)
    _, table, expected_formats = outputs.timeseries_content(result)
    assert formats == expected_formats and len(columns) == table.shape[1]
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
