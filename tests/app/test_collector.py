"""The garbage collector: paused while the package is imported and while ``aiauv simulate`` runs,
and left as it was found."""

from __future__ import annotations

import gc
import subprocess
import sys

import pytest

from aiauv_pin.app import cli


@pytest.mark.parametrize("enabled", [True, False])
def test_importing_the_package_leaves_the_collector_as_it_was(enabled):
    code = (
        "import gc\n"
        f"{'' if enabled else 'gc.disable()'}\n"
        "import aiauv_pin\n"
        "aiauv_pin.load_vehicle  # the simulation's modules, imported on first use\n"
        "print(gc.isenabled(), len(gc.get_objects()) > 10_000)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == [str(enabled), "True"]  # (its objects reachable: not frozen)


@pytest.mark.parametrize("enabled", [True, False])
def test_a_simulate_command_leaves_the_collector_as_it_was(tmp_path, enabled):
    was = gc.isenabled()
    try:
        gc.enable() if enabled else gc.disable()
        arguments = ["simulate", "--duration", "0.2", "--no-html", "--no-figures", "--quiet"]
        assert cli.main([*arguments, "--out", str(tmp_path / "run")]) == 0
        assert gc.isenabled() is enabled
        missing = str(tmp_path / "missing.urdf")
        assert cli.main([*arguments, "--vehicle", missing, "--out", str(tmp_path / "bad")]) != 0
        assert gc.isenabled() is enabled  # after a refused run too
    finally:
        gc.enable() if was else gc.disable()


def test_the_console_script_ends_a_simulate_command_with_the_collector_paused(tmp_path):
    """Enabling the collector again at the end would let the next allocation start a collection
    of everything the run made (about 0.07 s after the paper run) just before the process exits."""
    code = (
        "import atexit, gc, sys\n"
        "from aiauv_pin.app import cli\n"
        "started = []\n"
        "gc.callbacks.append(lambda phase, info: phase == 'start' and started.append(info))\n"
        "atexit.register(lambda: print('enabled', gc.isenabled(), 'collections', len(started)))\n"
        "sys.argv = ['aiauv', 'simulate', '--duration', '0.2', '--no-html', '--no-figures',\n"
        f"            '--quiet', '--out', {str(tmp_path / 'run')!r}]\n"
        "cli.console_main()\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split()[-4:] == ["enabled", "False", "collections", "0"]
    assert (tmp_path / "run" / "summary.json").is_file()
