"""The numba compilations of a run: seen as they happen, announced, and kept out of timed runs.

numba compiles the project's kernels on their first use and caches them in the per-user cache
folder (:func:`aiauv_hydro.numerics.jit.cache_folder`); later processes load them in well under a
second. Where the package ships them (:mod:`aiauv_hydro.numerics.kernel_cache`) and the installed
numba is the one they were built with, they are unpacked into that folder instead and nothing is
compiled. Otherwise they are compiled once (about a minute of CPU time on a 2-core machine).

Whether a run compiled is not guessed from files: :class:`CompilationWatch` listens to numba's
``numba:compile`` event, which numba sends only when it compiles a function (not when it loads one
from the cache), prints :data:`COMPILE_NOTICE` at the first and counts them. The command line also
loads (or compiles) the run's compiled loop before the timed run, without taking a step
(:func:`aiauv_pin.scenario.definition.warm_up`), so that the real-time factor in ``summary.json``
measures the simulation and not the compilation.
"""

from __future__ import annotations

import os
import sys

#: Printed (to standard error) when numba starts compiling the project's kernels in a run.
COMPILE_NOTICE = "aiauv: compiling kernels once for this installation (about a minute of CPU time)"


#: The settings that choose numba's CPU target or the shipped kernels
#: (:mod:`aiauv_hydro.numerics.kernel_cache`).
TARGET_SETTINGS = (
    "NUMBA_CPU_NAME",
    "NUMBA_CPU_FEATURES",
    "AIAUV_NATIVE_CPU",
    "AIAUV_PREBUILT_KERNELS",
)


def default_target_environment(environ=None) -> dict[str, str]:
    """``environ`` (default: this process's) without :data:`TARGET_SETTINGS`: what a new user's
    process has, for child processes that must choose the target as a new installation does."""
    environ = os.environ if environ is None else environ
    return {k: v for k, v in environ.items() if k not in TARGET_SETTINGS}


class CompilationWatch:
    """numba's compilations while the watch is on (a context manager; nothing without numba).

    Attributes:
        compiled: Qualified names of the functions compiled, in order (one entry per signature).
    """

    def __init__(self, stream=None, notice: bool = True):
        """
        Args:
            stream: Where :data:`COMPILE_NOTICE` goes (standard error by default).
            notice: Whether to print it at the first compilation.
        """
        self.compiled: list[str] = []
        self._stream = stream
        self._notice = notice
        self._listener = None

    @property
    def compiled_now(self) -> bool:
        """Whether anything was compiled while the watch was on."""
        return bool(self.compiled)

    def _started(self, dispatcher) -> None:
        if not self.compiled and self._notice:
            stream = self._stream if self._stream is not None else sys.stderr
            print(COMPILE_NOTICE, file=stream, flush=True)
        function = getattr(dispatcher, "py_func", None)
        self.compiled.append(getattr(function, "__qualname__", repr(dispatcher)))

    def __enter__(self) -> CompilationWatch:
        from aiauv_hydro.numerics.jit import NUMBA_AVAILABLE

        if NUMBA_AVAILABLE:
            from numba.core import event

            watch = self

            class _Listener(event.Listener):
                def on_start(self, started):
                    watch._started((started.data or {}).get("dispatcher"))

                def on_end(self, ended):
                    pass

            self._listener = _Listener()
            event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc_info) -> None:
        if self._listener is not None:
            from numba.core import event

            event.unregister("numba:compile", self._listener)
            self._listener = None
