"""Child processes that end with their parent, also when the parent is killed with SIGKILL.

The figure worker (:mod:`aiauv_pin.results.outputs`) and the live view's meshcat server
(:mod:`aiauv_pin.results.meshcat_server`) call :func:`die_with_parent` first thing:

* on Linux, ``prctl(PR_SET_PDEATHSIG, signal)`` (through ctypes): the kernel sends the signal when
  the parent ends, however it ends. ``os.getppid()`` is checked right after: a parent that died
  before the call took effect (the child was already re-parented) ends the child at once, so there
  is no window. The kernel sends the signal when the *thread* that started the child ends, so
  children are started from the parent's main thread (as ``simulate`` and the figure worker do);
* elsewhere (macOS, BSD: no ``prctl``), a daemon watchdog thread polls ``os.getppid()`` every
  :data:`POLL_PERIOD` and sends the signal to its own process once the parent is gone (the child is
  then re-parented, so its parent id changes).

Windows (no re-parenting) is not covered.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time

#: ``PR_SET_PDEATHSIG`` of ``<linux/prctl.h>``.
PR_SET_PDEATHSIG = 1
#: How often the watchdog looks at the parent id [s].
POLL_PERIOD = 0.25
#: How long a signalled child may take to end before it exits regardless [s].
GRACE = 2.0


def _end(signum: int) -> None:
    """Send ``signum`` to this process; exit if it is still running ``GRACE`` seconds later."""
    os.kill(os.getpid(), signum)
    time.sleep(GRACE)
    os._exit(128 + signum)


def _prctl_death_signal(signum: int) -> bool:
    """Ask Linux to send ``signum`` when the parent ends; ``False`` if that is not possible."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent: int, signum: int, period: float) -> None:
    while os.getppid() == parent:
        time.sleep(period)
    _end(signum)


def die_with_parent(
    parent: int, signum: int = signal.SIGTERM, *, period: float = POLL_PERIOD
) -> str:
    """Make this (child) process end with ``signum`` when process ``parent`` ends.

    Args:
        parent: The parent's process id, as the parent saw it (``os.getpid()`` there).
        signum: The signal this process gets (default SIGTERM; its default action ends it).
        period: Watchdog polling period where ``prctl`` is unavailable [s].

    Returns:
        ``"prctl"`` or ``"watchdog"``: how the parent is watched.
    """
    how = "prctl" if _prctl_death_signal(signum) else "watchdog"
    if os.getppid() != parent:  # the parent is already gone (or never was ours)
        _end(signum)
    if how == "watchdog":
        threading.Thread(
            target=_watch, args=(parent, signum, period), name="aiauv-parent-watchdog", daemon=True
        ).start()
    return how
