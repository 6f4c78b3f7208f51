"""Processes that draw a run's figures, started before the run (Linux, two or more CPUs).

``aiauv simulate`` draws seven figures after a paper run, about 0.5 s of CPU, nearly all of it
matplotlib's, which also takes 0.4-0.5 s to import and warm up. :class:`FigureWorkers` forks a
process first thing (from ``aiauv``'s main thread, when no other thread runs), before the
simulation's modules are imported: this module and :mod:`aiauv_pin.results.figures` import numpy
alone. The process imports and warms up matplotlib on the second core, which is idle while this
process imports numba and Pinocchio, reads the vehicle and loads the compiled loop, forks a second
figure process and waits. The run logs into a :class:`SharedLog` that both hold too, so that after
the run they are sent only the figures' data (:class:`~aiauv_pin.results.figures.FigureData`,
pickled; every array in the log named by its place in it), then draw the figures, each taking the
next one nobody took (slowest first, as :func:`aiauv_pin.results.outputs.write_figures` does),
while this process writes the table, the summary and the playback page.

The processes end with this one, however this one ends (SIGKILL,
:func:`aiauv_pin._internal.parent_death.die_with_parent`); it ignores SIGINT (Ctrl-C, sent to the
whole process group): this process stops it (:meth:`FigureWorkers.close`).
"""

from __future__ import annotations

import io
import os
import pickle
import signal
from pathlib import Path

import numpy as np

from aiauv_pin._internal.log_memory import SharedLog
from aiauv_pin.results import figures


class _Pickler(pickle.Pickler):
    """Pickles the figures' data without the arrays that lie in the shared log (named by their
    place in it)."""

    def __init__(self, file, log: SharedLog) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._log = log

    def persistent_id(self, obj):
        if type(obj) is np.ndarray:
            return self._log.reference(obj)
        return None


class _Unpickler(pickle.Unpickler):
    def __init__(self, file, log: SharedLog) -> None:
        super().__init__(file)
        self._log = log

    def persistent_load(self, pid):
        return self._log.view(pid)


def _draw_share(message: bytes, log: SharedLog, taken) -> None:
    """Draw the figures of ``message`` (pickled figure data, folder and format) that the other
    figure process has not taken (``taken``: the shared index of the next)."""
    data, folder, figure_format = _Unpickler(io.BytesIO(message), log).load()
    figures._prepare_figures(figure_format)
    figures._take_tasks(figures._figure_tasks(data, folder, figure_format), taken)


def _answer(connection, failure: BaseException | None) -> None:
    try:
        connection.send(failure)
    except Exception:  # an exception that does not pickle
        connection.send(RuntimeError(f"{failure.__class__.__name__}: {failure}"))


def _second(connection, taken, log: SharedLog, first: int) -> None:
    """The second figure process, forked by the first once matplotlib is warm: it waits for what
    the first is sent, parses its own math text
    (:func:`aiauv_pin.results.figures._forget_parsed_math`), draws its share, answers the first."""
    from aiauv_pin._internal.parent_death import die_with_parent

    die_with_parent(first, signal.SIGKILL)
    try:
        message = connection.recv_bytes()
    except EOFError:  # no figures wanted after all
        return
    failure = None
    try:
        figures._forget_parsed_math()
        _draw_share(message, log, taken)
    except BaseException as exc:  # reported to the first, which reports it
        failure = exc
    _answer(connection, failure)


def _fork_second(context, taken, log: SharedLog):
    """The second figure process (started) and the first's end of the pipe between them."""
    partner, partner_end = context.Pipe()
    second = context.Process(
        target=_second,
        args=(partner_end, taken, log, os.getpid()),
        name="aiauv-figures-2",
        daemon=True,
    )
    second.start()
    partner_end.close()
    return second, partner


def _serve(connection, warm, log: SharedLog, parent: int) -> None:
    """The figure process: warm matplotlib up, fork the second figure process, draw the figures
    it is sent with that one (each takes the next figure nobody took), answer ``None`` or the
    first exception (or nothing, if the run ended without sending any). Whatever fails is
    answered, never printed; without a second process (its fork failed) it draws them alone."""
    import multiprocessing

    from aiauv_pin._internal.parent_death import die_with_parent

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # stopped by the parent (close), not by Ctrl-C
    die_with_parent(parent, signal.SIGKILL)
    failure = second = partner = None
    try:
        figures.import_plotting()
        context = multiprocessing.get_context("fork")
        taken = context.Value("i", 0)
        try:  # forked before the run ends, so that its start is not on the way of the figures
            second, partner = _fork_second(context, taken, log)
        except OSError:  # (no process left to fork): the figures drawn here alone
            pass
    except BaseException as exc:  # answered when the figures are asked for
        failure = exc
    warm.set()
    try:
        message = connection.recv_bytes()
    except EOFError:  # no figures wanted after all (the run failed)
        return
    if failure is None:
        if partner is not None:
            partner.send_bytes(message)
        try:
            _draw_share(message, log, taken)
        except BaseException as exc:  # reported to the parent, which raises it
            failure = exc
            if second is not None:
                second.kill()
    if failure is None and partner is not None:
        try:
            failure = partner.recv()
        except EOFError:  # died without a word (killed)
            second.join()
            failure = RuntimeError(f"a figure process died (exit status {second.exitcode})")
    if second is not None:
        second.join()
    _answer(connection, failure)


class FigureWorkers:
    """The figure processes, forked before a run, that draw its figures after it (see the
    module).

    Start it with :meth:`start` (``None`` where it cannot run), give :attr:`log`'s
    :meth:`~SharedLog.empty` to the run as ``log_memory``, hand it the result with :meth:`draw`,
    collect the files with :meth:`wait`; :meth:`close` stops it in any case.
    """

    def __init__(self) -> None:
        import multiprocessing

        self.log = SharedLog()
        context = multiprocessing.get_context("fork")
        self._connection, child = context.Pipe()
        self._warm = context.Event()
        self._process = context.Process(
            target=_serve,
            args=(child, self._warm, self.log, os.getpid()),
            name="aiauv-figures",
        )
        self._process.start()
        child.close()

    @classmethod
    def start(cls) -> FigureWorkers | None:
        """Fork the figure process for a run; ``None`` where it cannot be done
        (not Linux, one CPU, no anonymous files): the figures are then drawn after the run by
        :func:`aiauv_pin.results.outputs.write_figures` as usual. Call it from the main thread
        while no other thread runs."""
        return cls() if cls.available() else None

    @staticmethod
    def available() -> bool:
        """Whether :meth:`start` forks a figure process here: Linux (``fork``, anonymous files)
        with two or more CPUs."""
        import multiprocessing
        import sys

        return (
            sys.platform == "linux"
            and (os.cpu_count() or 1) >= 2
            and "fork" in multiprocessing.get_all_start_methods()
            and SharedLog.available()
        )

    def warm(self, timeout: float | None = None) -> bool:
        """Whether the figure process has imported and warmed up matplotlib (waiting at most
        ``timeout`` [s] for it)."""
        return self._warm.wait(timeout)

    def draw(self, data: figures.FigureData, folder: Path, *, figure_format: str = "png") -> bool:
        """Send the figure process ``data`` (of a run with :attr:`log` as its log memory,
        :func:`aiauv_pin.results.outputs.figure_data`) to draw into ``folder``; ``False``
        (nothing sent) if ``data`` does not pickle: draw it here then."""
        figures.check_figure_format(figure_format)
        buffer = io.BytesIO()
        try:
            _Pickler(buffer, self.log).dump((data, Path(folder), figure_format))
        except Exception:  # e.g. a user's name that is not a string: drawn by the caller
            return False
        self._connection.send_bytes(buffer.getbuffer())
        return True

    def wait(self) -> None:
        """Wait for the figures sent with :meth:`draw`; raise the figure process's failure."""
        try:
            failure = self._connection.recv()
        except EOFError:  # died without a word (killed)
            self._process.join()
            failure = RuntimeError(
                f"the figure process died (exit status {self._process.exitcode})"
            )
        self.close()
        if failure is not None:
            raise failure

    def close(self) -> None:
        """Stop the figure process (if it still runs: it has answered, or is not wanted any
        more) and release the log's file."""
        if self._process.is_alive():
            self._process.kill()  # its own figure process dies with it
        self._process.join()
        self._connection.close()
        self.log.close()
