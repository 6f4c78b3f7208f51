"""The ``aiauv`` pytest plugin: ``--aiauv-vehicle URDF`` (repeatable) and ``--aiauv-seed N``.

With at least one ``--aiauv-vehicle``, the tests of the consistency suite :mod:`aiauv_pin.testing.suite`
are added to the collection under the node id ``aiauv_pin/testing/suite.py`` (alone when no test
paths are given on the command line, else after the tests collected from them) and
every test that requests the ``aiauv_vehicle`` fixture is parametrised over the given vehicles, with
the URDF's robot name (else the file stem) as the id. Loading the plugin imports the ``aiauv_pin``
package (and with it Pinocchio, about 0.4 s, paid by every pytest run in an environment where
aiauv-pin is installed; ``-p no:aiauv`` disables it); numba kernels load only when a vehicle is.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SUITE = "aiauv_pin.testing.suite"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("aiauv", "aiauv-pin dynamics-consistency checks")
    group.addoption(
        "--aiauv-vehicle",
        action="append",
        default=[],
        metavar="URDF",
        help="run the dynamics-consistency suite on this vehicle URDF (repeatable)",
    )
    group.addoption(
        "--aiauv-seed",
        type=int,
        default=None,
        metavar="N",
        help="seed of the random states of the consistency checks (default: a fixed seed)",
    )


def _robot_name(path: Path) -> str:
    """The URDF's ``<robot name>``, or the file stem if it cannot be read."""
    from aiauv_hydro.spec import HydroError
    from aiauv_hydro.urdf.block_reader import parse_robot_text

    try:
        name = parse_robot_text(path.read_text(encoding="utf-8"), str(path)).get("name", "")
    except (HydroError, OSError, UnicodeDecodeError):
        name = ""
    name = "".join(c if c.isalnum() or c in "_-." else "_" for c in name.strip())
    return name or path.stem


def vehicle_ids(paths: list[Path]) -> list[str]:
    """Readable, unique test ids: robot names, numbered from the second repeat (``name-2``)."""
    ids: list[str] = []
    for path in paths:
        name = _robot_name(path)
        candidate, k = name, 1
        while candidate in ids:
            k += 1
            candidate = f"{name}-{k}"
        ids.append(candidate)
    return ids


_PATHS = pytest.StashKey[list]()
#: Node id of the suite's module: short and the same wherever the package is installed.
SUITE_NODEID = "aiauv_pin/testing/suite.py"


def pytest_configure(config: pytest.Config) -> None:
    paths = [Path(p) for p in config.getoption("aiauv_vehicle") or []]
    for path in paths:
        if not path.is_file():
            raise pytest.UsageError(f"--aiauv-vehicle {path}: no such file")
    config.stash[_PATHS] = paths
    if paths and config.args_source != pytest.Config.ArgsSource.ARGS:
        config.args[:] = []  # no test paths given: run the suite alone


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items) -> None:
    """Append the suite's tests (before ``-k``/``-m`` deselection, which runs after this hook)."""
    if not config.stash.get(_PATHS, []):
        return
    origin = importlib.util.find_spec(SUITE).origin
    module = pytest.Module.from_parent(session, path=Path(origin), nodeid=SUITE_NODEID)
    suite_items = [node for node in module.collect() if isinstance(node, pytest.Item)]
    for item in suite_items:
        config.hook.pytest_itemcollected(item=item)
    # counted in "collected N items" like any collected module
    config.hook.pytest_collectreport(
        report=pytest.CollectReport(SUITE_NODEID, "passed", None, suite_items)
    )
    items.extend(suite_items)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    if "aiauv_vehicle_path" in metafunc.fixturenames:
        paths = metafunc.config.stash.get(_PATHS, [])
        metafunc.parametrize("aiauv_vehicle_path", paths, ids=vehicle_ids(paths), scope="session")


@pytest.fixture(scope="session")
def aiauv_seed(request: pytest.FixtureRequest) -> int:
    """Seed of the consistency checks' random states (``--aiauv-seed``)."""
    from aiauv_pin.checks.consistency import SEED

    seed = request.config.getoption("aiauv_seed")
    return SEED if seed is None else seed


@pytest.fixture(scope="session")
def aiauv_vehicle(aiauv_vehicle_path: Path):
    """The vehicle loaded from one ``--aiauv-vehicle`` URDF (one load per file and session)."""
    from aiauv_pin.errors import AiauvError
    from aiauv_pin.model.loading import load_vehicle

    try:
        return load_vehicle(aiauv_vehicle_path)
    except AiauvError as exc:
        reason = str(exc)
    pytest.fail(f"cannot load the vehicle: {reason}", pytrace=False)
