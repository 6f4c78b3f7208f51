"""``timeseries.csv``'s rows formatted while the compiled loop is still running.

Formatting the table's numbers exactly (:func:`aiauv_pin.results.outputs.format_rows`) is about
0.03 s of the paper's 300 s run, a tenth of the loop. The compiled loop releases the GIL, so
a second core is free while it runs: :class:`TableStream` is handed the log before the loop starts
(``simulate(log_reader=...)``) and a background thread formats the table's rows among the rows
written so far with the same function as :func:`aiauv_pin.results.outputs.write_timeseries`
(:func:`~aiauv_pin.results.outputs.format_rows`), in blocks of :data:`BLOCK_ROWS` rows, each kept
with the numbers it formatted.

Which log column each column of the table is read from is not written down a second time: it is
found by building the table once (:func:`aiauv_pin.results.outputs.timeseries_content`) from a
probe log whose every cell holds its own position (:func:`log_columns_of_table`). A table with a
column that is not one of the log's (a quantity computed after the run, e.g. a passive run's
end-effector position) is not streamed.

Whatever the thread read, :func:`aiauv_pin.results.outputs.write_results` reuses a block's text
only where its numbers are, bit for bit, those of the final table's rows
(:meth:`StreamedTable.parts_for`);
the file is the same bytes as without streaming.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aiauv_pin.results import outputs
from aiauv_pin.scenario.definition import RunPlan, complete_diagnostics, result_of
from aiauv_pin.simulation.fixed_step import complete_rows, trajectory_of_log

#: Rows of the table formatted per block (one block holds the GIL for about 0.2 ms).
BLOCK_ROWS = 40

#: How long the thread waits before it looks for more complete rows [s].
POLL = 0.002


@dataclass(frozen=True)
class FormattedRows:
    """Consecutive rows of ``timeseries.csv``: the numbers (rows, columns) and their text."""

    values: np.ndarray
    text: str


@dataclass(frozen=True)
class StreamedTable:
    """What :class:`TableStream` formatted: its blocks in order."""

    blocks: tuple[FormattedRows, ...]

    def parts_for(self, table: np.ndarray) -> tuple[int, list[str]]:
        """How many leading rows of the final ``table`` the blocks hold, and their texts: the
        blocks in order while their numbers are bit for bit the table's rows (the texts are
        written one after the other, never joined)."""
        if table.ndim != 2:
            return 0, []
        done, parts = 0, []
        bits = np.ascontiguousarray(table).view(np.uint64)
        for block in self.blocks:
            n = block.values.shape[0]
            if block.values.shape[1] != table.shape[1] or done + n > table.shape[0]:
                break
            if not np.array_equal(block.values.view(np.uint64), bits[done : done + n]):
                break
            parts.append(block.text)
            done += n
        return done, parts


def log_columns_of_table(plan: RunPlan) -> np.ndarray | None:
    """For each column of the run's ``timeseries.csv``, the log column it is read from; ``None``
    when a column is computed after the run rather than read from the log.

    The diagnostics the run gets after it
    (:func:`aiauv_pin.scenario.definition.complete_diagnostics`) are first applied to a log at
    rest: where they add, remove or replace one, the table is not the log's alone. Otherwise the
    table is built from a probe log of two rows whose cells hold ``row * width + column`` (exact
    floats).
    """
    vehicle, controller = plan.vehicle, plan.arguments[5]
    nq, nv = vehicle.nq, vehicle.nv
    width = 1 + nq + 2 * nv + controller.info_width
    # what the pass after the run does to a log, on one at rest in the neutral configuration
    rest = np.zeros((2, width))
    rest[:, 1 : 1 + nq] = vehicle.neutral_configuration()
    trajectory = trajectory_of_log(rest, nq, nv, controller.unpack)
    logged = dict(trajectory.info)
    complete_diagnostics(vehicle, plan.scenario, trajectory)
    if trajectory.info.keys() != logged.keys() or any(
        trajectory.info[key] is not value for key, value in logged.items()
    ):
        return None
    # it leaves the log's diagnostics as they are: the table of a log of positions
    probe = np.arange(2.0 * width).reshape(2, width)
    result = result_of(plan, trajectory_of_log(probe, nq, nv, controller.unpack), 0.0)
    _, table = outputs.timeseries_content(result)
    if table.shape[0] != 2:
        return None
    columns = table[0]
    if not np.array_equal(table[1], columns + width) or np.any(columns % 1 != 0):
        return None
    if np.any(columns < 0) or np.any(columns >= width):
        return None
    return columns.astype(np.intp)


class TableStream:
    """A background thread that formats the rows of ``timeseries.csv`` as the loop logs them.

    Pass :meth:`read` as ``simulate``'s ``log_reader``: the thread looks for complete rows
    (:func:`aiauv_pin.simulation.fixed_step.complete_rows`) every :data:`POLL` seconds while the
    loop runs; :meth:`close` after the run stops it and returns the blocks formatted so far (the
    rest is formatted when the file is written).
    """

    def __init__(
        self,
        columns: np.ndarray,
        period: float | None,
        start_after: Callable[[float], bool] | None = None,
    ) -> None:
        self._columns = columns
        self._start_after = start_after
        self._period = period
        self._log: np.ndarray | None = None
        self._blocks: list[FormattedRows] = []
        self._closed = threading.Event()
        self._drain = False
        self._given = threading.Event()
        self._thread = threading.Thread(target=self._format, name="aiauv-table", daemon=True)
        self._thread.start()

    @classmethod
    def for_plan(
        cls, plan: RunPlan, start_after: Callable[[float], bool] | None = None
    ) -> TableStream | None:
        """A stream for ``plan``'s run, or ``None`` when its table is not the log's alone
        (:func:`log_columns_of_table`; also when that probe fails), or the loop is not
        compiled. With ``start_after``, the thread formats nothing before
        ``start_after(timeout [s])`` returned ``True`` (it is called until then, or until the
        stream is closed): e.g. until the figure process is ready, which uses the same core."""
        if not plan.compiled:
            return None
        try:
            found = log_columns_of_table(plan)
        except Exception:  # a probe that fails must not fail the run: the table is written after it
            return None
        if found is None:
            return None
        return cls(found, plan.scenario.csv_period, start_after)

    def read(self, log: np.ndarray) -> None:
        """The log of the run (``simulate``'s ``log_reader``), formatted as its rows are written."""
        self._log = log
        self._given.set()

    def close(self, *, drain: bool = False) -> StreamedTable:
        """Stop the thread (after the block it is formatting; with ``drain``, once it has
        formatted every complete row) and return what it formatted."""
        self._drain = drain
        self._closed.set()
        self._given.set()
        self._thread.join()
        return StreamedTable(tuple(self._blocks))

    def _format(self) -> None:
        self._given.wait()
        if self._start_after is not None:
            while not self._closed.is_set() and not self._start_after(POLL):
                pass
        log, stride, row = self._log, None, 0  # row: the log row of the table's next row
        while log is not None and (not self._closed.is_set() or self._drain):
            complete = complete_rows(log)
            if stride is None and complete >= 2:
                stride = outputs.csv_stride(self._period, float(log[1, 0] - log[0, 0]))
            if stride is None or row >= complete:
                if self._closed.is_set():
                    return  # (drained)
                self._closed.wait(POLL)
                continue
            picked = log[row : min(complete, row + BLOCK_ROWS * stride) : stride]
            values = picked[:, self._columns]
            self._blocks.append(FormattedRows(values, outputs.format_rows(values)))
            row += len(picked) * stride
