"""The one-time numba compilation: a notice while it runs, and a warm-up outside timed runs.

numba compiles :mod:`aiauv_pin.fast`'s kernels on their first use in an installation (about a
minute of CPU time on a 2-core machine, numba 0.68, 2026-11) and caches them on disk
(``cache=True``); later processes load them in well under a second. Where the package ships them
(:mod:`hydro.prebuilt`), they are unpacked into that cache instead and nothing is compiled. The
command line prints :data:`COMPILE_NOTICE` when no cache of the compiled scenario loop is found,
and runs a few steps of the scenario before the timed run (:func:`warm_up`), so that the real-time
factor in ``summary.json`` measures the simulation and not the compilation.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import os
import sys
from pathlib import Path

#: Printed (to standard error) before the first compilation in an installation.
COMPILE_NOTICE = "aiauv: compiling kernels once for this installation (about a minute of CPU time)"


#: The settings that choose numba's CPU target or the shipped kernels (:mod:`hydro.prebuilt`).
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


def _cache_folders() -> list[Path]:
    """Where numba may keep this package's cache (its locators, in order)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return [Path(os.environ["NUMBA_CACHE_DIR"])]  # numba then uses this folder only
    folders = []
    spec = importlib.util.find_spec("aiauv_pin.fast")
    if spec is not None and spec.submodule_search_locations:
        folders.extend(Path(p) / "__pycache__" for p in spec.submodule_search_locations)
    folders.append(Path.home() / ".cache" / "numba")
    return folders


def _index_is_current(index: Path) -> bool:
    """Whether a numba cache index was written for the current sources and holds code for this
    process's CPU target (numba keys each entry on its code generator's magic tuple: triple, CPU
    name and features; :func:`hydro.prebuilt.read_index`)."""
    from numba.core.registry import cpu_target

    from hydro.jit import source_hash
    from hydro.prebuilt import read_index

    read = read_index(index)
    if read is None or read[0] != source_hash():
        return False
    target = cpu_target.target_context.codegen().magic_tuple()
    return any(isinstance(key, tuple) and key[1:2] == (target,) for key in read[1])


def kernels_cached() -> bool:
    """Whether numba's on-disk cache holds the compiled simulation loop for the current sources.

    Defining the loop unpacks the kernels shipped with the package (:mod:`hydro.prebuilt`), so
    the loop's module is imported first.
    """
    import aiauv_pin.fast.loop  # noqa: F401  (its definition seeds the cache)

    for folder in _cache_folders():
        if not folder.is_dir():
            continue
        for index in folder.rglob("loop.run_chunk-*.nbi"):
            if _index_is_current(index):
                return True
    return False


def announce_compilation(stream=None) -> bool:
    """Print :data:`COMPILE_NOTICE` if the kernels will be compiled now; return whether they will.

    Args:
        stream: Where to print (standard error by default).
    """
    if importlib.util.find_spec("numba") is None or kernels_cached():
        return False
    print(COMPILE_NOTICE, file=stream if stream is not None else sys.stderr, flush=True)
    return True


def warm_up(vehicle, scenario) -> None:
    """Run two controller samples of ``scenario`` so that its compiled code is built or loaded.

    Does nothing on the Pinocchio backend (nothing to compile).

    Args:
        vehicle: The :class:`~aiauv_pin.Vehicle` of the run.
        scenario: The :class:`~aiauv_pin.scenario.PaperScenario` about to run.
    """
    if vehicle.active_backend != "numba":
        return
    from .arguments import check_timing
    from .errors import SimulationDiverged
    from .scenario import run_paper_scenario

    check_timing(scenario.duration, scenario.dt)  # the whole run's error before the short one runs

    short = dataclasses.replace(
        scenario, duration=min(scenario.duration, 2 * scenario.steps_per_control * scenario.dt)
    )
    try:
        run_paper_scenario(vehicle, short, progress=False)
    except SimulationDiverged:
        pass  # the compiled code is built all the same; the timed run reports the divergence
