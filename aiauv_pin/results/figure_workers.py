"""Processes that draw a run's figures, started before the run (Linux, two or more CPUs).

``aiauv simulate`` draws seven figures after a paper run, about 0.5 s of CPU, nearly all of it
matplotlib's, which also takes 0.4-0.5 s to import and warm up. :class:`FigureWorkers` forks a
process before the vehicle is read (from ``aiauv``'s main thread, when no other thread runs):
it imports and warms up matplotlib on the second core, which is idle while this process reads the
vehicle and loads the compiled loop, forks a second figure process and waits. The run logs into a
:class:`SharedLog` that both hold too, so that after the run they are sent only the result's small
parts (pickled; the scenario is their own copy from the fork and every array in the log is named by
its place in it), then draw the figures, each taking the next one nobody took (slowest first, as
:func:`aiauv_pin.results.outputs.write_figures` does), while this process writes the table, the
summary and the playback page.

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
from aiauv_pin.results import outputs

#: The persistent id of the run's scenario in what the figure process is sent.
_SCENARIO = ("scenario",)


class _Pickler(pickle.Pickler):
    """Pickles a result without its scenario (the other process has its own copy from the fork)
    and without the arrays that lie in the shared log (named by their place in it)."""

    def __init__(self, file, log: SharedLog, scenario) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self._log, self._scenario = log, scenario

    def persistent_id(self, obj):
        if obj is self._scenario:
            return _SCENARIO
        if type(obj) is np.ndarray:
            return self._log.reference(obj)
        return None


class _Unpickler(pickle.Unpickler):
    def __init__(self, file, log: SharedLog, scenario) -> None:
        super().__init__(file)
        self._log, self._scenario = log, scenario

    def persistent_load(self, pid):
        if pid == _SCENARIO:
            return self._scenario
        return self._log.view(pid)


def _draw_share(message: bytes, log: SharedLog, scenario, taken) -> None:
    """Draw the figures of ``message`` (a pickled result, folder and options) that the other
    figure process has not taken (``taken``: the shared index of the next)."""
    result, folder, options = _Unpickler(io.BytesIO(message), log, scenario).load()
    figure_format = options.pop("figure_format")
    outputs._prepare_figures(figure_format)
    outputs._take_tasks(outputs._figure_tasks(result, folder, figure_format, options), taken)


def _answer(connection, failure: BaseException | None) -> None:
    try:
        connection.send(failure)
    except Exception:  # an exception that does not pickle
        connection.send(RuntimeError(f"{failure.__class__.__name__}: {failure}"))


def _second(connection, taken, log: SharedLog, scenario, first: int) -> None:
    """The second figure process, forked by the first once matplotlib is warm: it waits for what
    the first is sent, parses its own math text
    (:func:`aiauv_pin.results.outputs._forget_parsed_math`), draws its share, answers the first."""
    from aiauv_pin._internal.parent_death import die_with_parent

    die_with_parent(first, signal.SIGKILL)
    try:
        message = connection.recv_bytes()
    except EOFError:  # no figures wanted after all
        return
    failure = None
    try:
        outputs._forget_parsed_math()
        _draw_share(message, log, scenario, taken)
    except BaseException as exc:  # reported to the first, which reports it
        failure = exc
    _answer(connection, failure)


def _fork_second(context, taken, log: SharedLog, scenario):
    """The second figure process (started) and the first's end of the pipe between them."""
    partner, partner_end = context.Pipe()
    second = context.Process(
        target=_second,
        args=(partner_end, taken, log, scenario, os.getpid()),
        name="aiauv-figures-2",
        daemon=True,
    )
    second.start()
    partner_end.close()
    return second, partner


def _serve(connection, warm, log: SharedLog, scenario, parent: int) -> None:
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
        outputs.import_plotting()
        context = multiprocessing.get_context("fork")
        taken = context.Value("i", 0)
        try:  # forked before the run ends, so that its start is not on the way of the figures
            second, partner = _fork_second(context, taken, log, scenario)
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
            _draw_share(message, log, scenario, taken)
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

    def __init__(self, scenario) -> None:
        import multiprocessing

        self.log = SharedLog()
        self._scenario = scenario
        context = multiprocessing.get_context("fork")
        self._connection, child = context.Pipe()
        self._warm = context.Event()
        self._process = context.Process(
            target=_serve,
            args=(child, self._warm, self.log, scenario, os.getpid()),
            name="aiauv-figures",
        )
        self._process.start()
        child.close()

    @classmethod
    def start(cls, scenario) -> FigureWorkers | None:
        """Fork the figure process for a run of ``scenario``; ``None`` where it cannot be done
        (not Linux, one CPU, no anonymous files): the figures are then drawn after the run by
        :func:`aiauv_pin.results.outputs.write_figures` as usual. Call it from the main thread
        while no other thread runs."""
        return cls(scenario) if cls.available() else None

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

    def draw(
        self,
        result,
        folder: Path,
        *,
        figure_format: str = "png",
        vehicle_name: str | None = None,
        path_points: np.ndarray | None = None,
        cross_track_axes: tuple[str, str] | None = None,
    ) -> bool:
        """Send the figure process ``result`` (run with :attr:`log` as its log memory) to draw
        into ``folder`` (arguments of :func:`aiauv_pin.results.outputs.write_figures`); ``False``
        (nothing sent) if ``result`` does not pickle: draw it here then."""
        outputs.check_figure_format(figure_format)
        options = {
            "figure_format": figure_format,
            "vehicle_name": vehicle_name,
            "path_points": path_points,
            "cross_track_axes": cross_track_axes,
        }
        buffer = io.BytesIO()
        try:
            _Pickler(buffer, self.log, self._scenario).dump((result, Path(folder), options))
        except Exception:  # e.g. a diagnostic that holds a function: drawn by the caller
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
