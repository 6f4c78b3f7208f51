"""Process trees read from ``/proc`` (Linux), for tests that kill a command and check what is left.

Used by the kill tests (``tests/results/test_kill.py``) and the hostile-user campaign
(``benchmarks/hostile_campaign.py``): a killed ``aiauv simulate`` or sweep must leave no child
process running.
"""

from __future__ import annotations

import time
from pathlib import Path


def descendants(pid: int) -> set[int]:
    """Every process whose chain of parents reaches ``pid`` (from ``/proc/*/stat``)."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                parents[int(entry.name)] = int(fields[1])
            except (OSError, IndexError, ValueError):
                continue
    found: set[int] = set()
    frontier = {pid}
    while frontier:
        children = {p for p, parent in parents.items() if parent in frontier} - found
        found |= children
        frontier = children
    return found


def alive(pid: int) -> bool:
    """Whether process ``pid`` exists and is neither a zombie nor dead."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


def wait_gone(pids: set[int], timeout: float) -> set[int]:
    """Wait up to ``timeout`` [s] for ``pids`` to end; return those still alive."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        pids = {pid for pid in pids if alive(pid)}
        if not pids:
            return pids
        time.sleep(0.1)
    return {pid for pid in pids if alive(pid)}
