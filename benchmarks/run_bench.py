"""Reproduce the README's performance figures: ``python benchmarks/run_bench.py [--quick]``.

Same as ``aiauv bench``; writes ``benchmarks/results.json`` (or ``--out``).
"""

from __future__ import annotations

import sys

from aiauv_pin.app.cli import main
from aiauv_pin.tools import bench_command as bench  # noqa: F401  (registers the ``bench`` subcommand)

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
