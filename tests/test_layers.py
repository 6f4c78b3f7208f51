"""The package layout: floors that import only downwards, no cycles, a house a newcomer can read.

Read from the sources with :mod:`ast` (nothing is imported), so a deferred import inside a
function counts too: a cycle that only a lazy import keeps from failing today is still a cycle.
Module names are the installed ones (``hydro/`` installs as ``aiauv_hydro``, ``control/`` as
``aiauv_control``).
"""

from __future__ import annotations

import ast
import collections
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: folder -> installed name
PACKAGES = {"hydro": "aiauv_hydro", "control": "aiauv_control", "aiauv_pin": "aiauv_pin"}

#: The floors of the project, bottom first: a module may import its own floor and those below.
#: A floor is a package, a module, or a package's top-level modules ("<package>:top").
FLOORS = [
    ["aiauv_hydro.numerics"],
    ["aiauv_hydro:top", "aiauv_hydro.waves"],  # spec, currents; the waves currents import
    ["aiauv_hydro.laws", "aiauv_hydro.estimate"],
    ["aiauv_hydro.urdf"],
    ["aiauv_hydro"],  # the package's __init__ (its public names)
    ["aiauv_control.paths"],
    ["aiauv_control.laws"],
    ["aiauv_control.allocation"],  # thrust allocation: numerics only
    ["aiauv_control:top"],
    ["aiauv_control"],
    ["aiauv_pin.errors"],
    ["aiauv_pin._internal"],
    ["aiauv_pin.description"],
    ["aiauv_pin.kernels"],
    ["aiauv_pin.model"],
    ["aiauv_pin.builders"],
    ["aiauv_pin.dynamics", "aiauv_pin.reference"],
    ["aiauv_pin.controllers"],
    ["aiauv_pin.wholebody"],  # whole-body controllers: intervention, station keeping, velocity
    ["aiauv_pin.simulation"],
    ["aiauv_pin.scenario"],
    ["aiauv_pin.results"],
    ["aiauv_pin.checks"],
    ["aiauv_pin.interop"],
    ["aiauv_pin.testing"],
    ["aiauv_pin.envs"],  # Gymnasium environments (optional gymnasium)
    ["aiauv_pin"],  # the package's __init__: the public entry points
    ["aiauv_pin.tools"],
    ["aiauv_pin.app", "aiauv_pin.__main__"],
]

#: Modules named for their plumbing role alone live in an internal subpackage only.
PLUMBING_NAMES = {"text", "atomic", "cli_types", "utils", "helpers", "misc", "common", "util"}


def _modules() -> dict[str, tuple[Path, bool]]:
    """Installed dotted module name -> (file, is a package ``__init__``)."""
    modules = {}
    for folder, name in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = [name, *path.relative_to(ROOT / folder).with_suffix("").parts]
            is_package = parts[-1] == "__init__"
            modules[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return modules


def _imported_names(tree: ast.AST, package: str) -> list[str]:
    """Every module name imported anywhere in ``tree`` (relative imports resolved)."""
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.extend(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(anchor + ([node.module] if node.module else []))
            names.extend(f"{base}.{alias.name}" for alias in node.names)
            names.append(base)
    return names


def _import_graph() -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    """Edges between the project's modules, and the external top-level packages each imports."""
    modules = _modules()
    graph: dict[str, set[str]] = {name: set() for name in modules}
    external: dict[str, set[str]] = {name: set() for name in modules}
    for name, (path, is_package) in modules.items():
        package = name if is_package else name.rpartition(".")[0]
        for imported in _imported_names(ast.parse(path.read_text()), package):
            target = imported
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if not target:
                external[name].add(imported.split(".")[0])
            # a module needs its parent packages anyway: that is no cycle
            elif target != name and not name.startswith(target + "."):
                graph[name].add(target)
    return graph, external


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in sorted(graph[node]):
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def floor_of(module: str, packages: set[str]) -> int:
    """Index in :data:`FLOORS` of the floor ``module`` stands on."""
    floors = {unit: level for level, units in enumerate(FLOORS) for unit in units}
    candidates = []
    for unit, level in floors.items():
        if unit.endswith(":top"):
            package = unit[: -len(":top")]
            if module.rpartition(".")[0] == package and module not in packages:
                candidates.append((len(package) + 1, level))
        elif module == unit or module.startswith(unit + "."):
            candidates.append((len(unit), level))
    if not candidates:
        raise AssertionError(f"{module} stands on no floor: add it to FLOORS")
    return max(candidates)[1]


def test_no_import_cycles():
    graph, _ = _import_graph()
    assert len(graph) > 50  # the walk found the packages
    assert graph["aiauv_pin.controllers.turning_compiled"] >= {
        "aiauv_control.laws.turning_laws",
        "aiauv_hydro.numerics.jit",
    }
    assert _cycles(graph) == []


def test_cycle_finder_sees_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_every_import_goes_down_the_floors():
    graph, _ = _import_graph()
    packages = {name for name, (_, is_package) in _modules().items() if is_package}
    upward = []
    for module, targets in graph.items():
        here = floor_of(module, packages)
        upward.extend(
            f"{module} (floor {here}) imports {target} (floor {floor_of(target, packages)})"
            for target in sorted(targets)
            if floor_of(target, packages) > here
        )
    assert upward == []


def test_floor_finder_places_modules():
    packages = {"aiauv_hydro", "aiauv_hydro.laws", "aiauv_pin", "aiauv_pin.model"}
    assert floor_of("aiauv_hydro.spec", packages) == 1
    assert floor_of("aiauv_hydro.laws.damping", packages) == 2
    assert floor_of("aiauv_hydro", packages) == 4
    assert floor_of("aiauv_pin.model.vehicle", packages) > floor_of(
        "aiauv_pin.kernels.records", packages
    )


def test_hydro_and_control_never_import_aiauv_pin_or_pinocchio():
    graph, external = _import_graph()
    for name in graph:
        if name.split(".")[0] in ("aiauv_hydro", "aiauv_control"):
            assert not {t for t in graph[name] if t.startswith("aiauv_pin")}, name
            assert not external[name] & {"pinocchio", "pin"}, name


def test_the_numerics_floor_knows_no_package_of_the_project():
    """The numba machinery is told about compiled sources; it never names a package above it."""
    graph, _ = _import_graph()
    for name, targets in graph.items():
        if name.startswith("aiauv_hydro.numerics"):
            assert all(t.startswith("aiauv_hydro.numerics") for t in targets), name
    for path in (ROOT / "hydro" / "numerics").glob("*.py"):
        text = path.read_text()
        for other in ("aiauv_pin", "aiauv_control"):
            assert other not in text, f"{path.name} names {other}"


def test_nothing_in_the_library_imports_the_maintainers_tools():
    graph, _ = _import_graph()
    users = sorted(
        name
        for name, targets in graph.items()
        if any(t.startswith("aiauv_pin.tools") for t in targets)
        and not name.startswith("aiauv_pin.tools")
    )
    assert users == ["aiauv_pin.app.cli"]  # the thin ``aiauv bench`` entry point


def test_at_most_ten_modules_per_package_and_unique_file_names():
    names = collections.Counter()
    crowded = []
    for folder in PACKAGES:
        for package in [ROOT / folder, *(ROOT / folder).rglob("*")]:
            if not (package / "__init__.py").is_file():
                continue
            modules = [
                p for p in package.glob("*.py") if p.name not in ("__init__.py", "__main__.py")
            ]
            if len(modules) > 10:
                crowded.append(f"{package.relative_to(ROOT)}: {len(modules)}")
            names.update(p.name for p in modules)
    assert crowded == []
    assert sorted(name for name, count in names.items() if count > 1) == []


def test_plumbing_names_live_in_an_internal_package():
    misplaced = [
        str(path.relative_to(ROOT))
        for folder in PACKAGES
        for path in (ROOT / folder).rglob("*.py")
        if path.stem in PLUMBING_NAMES and not path.parent.name.startswith("_")
    ]
    assert misplaced == []


def test_every_package_says_what_it_holds():
    silent = [
        str(init.relative_to(ROOT))
        for folder in PACKAGES
        for init in (ROOT / folder).rglob("__init__.py")
        if not ast.get_docstring(ast.parse(init.read_text()))
    ]
    assert silent == []


def test_a_vehicle_load_reads_each_link_once(monkeypatch):
    """One URDF reader: the validation walk reads every link for hydro too (no second walk)."""
    import aiauv_hydro.urdf.block_reader
    import aiauv_hydro.urdf.uuv_simulator
    import aiauv_pin
    from aiauv_pin.description import urdf_validation

    read = []
    original = urdf_validation.read_link

    def counted(element):
        read.append(element.get("name"))
        return original(element)

    def second_walk(root):
        raise AssertionError("the links were walked a second time")

    monkeypatch.setattr(urdf_validation, "read_link", counted)
    monkeypatch.setattr(aiauv_hydro.urdf.block_reader, "robot_links", second_walk)
    monkeypatch.setattr(aiauv_hydro.urdf.uuv_simulator, "robot_links", second_walk)
    vehicle = aiauv_pin.load_vehicle(backend="pinocchio")
    assert sorted(read) == sorted(vehicle.urdf_structure.links)  # each link read exactly once
    assert len(vehicle.hydro.links) == 9


#: One step of ``aiauv simulate`` (docs/source/architecture.md), as measured by
#: ``tests/walk_of_one_step.py``: the files on the call stack at the step's deepest calls (the
#: fluid terms, the controller's laws), from the command line down, and the file that writes the
#: results once the run returned. At most 8 (issue 30).
WALK = [
    "aiauv_pin/app/cli.py",
    "aiauv_pin/simulation/fixed_step.py",
    "aiauv_pin/simulation/compiled_loop.py",
    "aiauv_pin/controllers/paper_compiled.py",
    "control/laws/paper_laws.py",
    "aiauv_pin/kernels/articulated_body.py",
    "hydro/laws/fluid_terms.py",
    "aiauv_pin/results/outputs.py",
]

#: What those files call during the step and that calls nothing of the project back: the
#: numerics (cross products), the rotation of a quaternion, the disturbance, the path and the
#: fins' sum (none on this vehicle); the still water is copied to the probes without a call.
LEAVES = [
    "aiauv_pin/kernels/disturbances.py",
    "aiauv_pin/kernels/rotations.py",
    "control/paths/__init__.py",
    "control/paths/line.py",
    "hydro/laws/lift.py",
    "hydro/numerics/spatial.py",
]


def _module_of(file: str) -> str:
    """``hydro/laws/fluid_terms.py`` -> ``aiauv_hydro.laws.fluid_terms``."""
    folder, _, rest = file.removesuffix(".py").removesuffix("/__init__").partition("/")
    return ".".join([PACKAGES[folder], *rest.split("/")])


def test_the_walk_of_one_step_goes_down_through_eight_files(tmp_path):
    """One step of ``aiauv simulate``, traced with the kernels interpreted: every call between two
    files goes down the floors or stays on one, the step's spine is :data:`WALK` (8 files, the
    results written by the command once the run returned), the rest are :data:`LEAVES`; the walk is
    the one docs/source/architecture.md describes."""
    script = Path(__file__).with_name("walk_of_one_step.py")
    done = subprocess.run(
        [sys.executable, str(script), "--out", str(tmp_path / "run"), "--no-figures"],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=tmp_path,
        env={**os.environ, "NUMBA_DISABLE_JIT": "1"},
    )
    assert done.returncode == 0, done.stderr[-2000:]
    trace = json.loads(done.stdout.strip().splitlines()[-1])
    assert trace["code"] == 0
    graph, _ = _import_graph()
    packages = {name for name, (_, is_package) in _modules().items() if is_package}
    for caller, callee in trace["edges"]:
        caller, callee = _module_of(caller), _module_of(callee)
        assert callee in graph[caller], f"{caller} calls {callee} without importing it"
        assert floor_of(callee, packages) <= floor_of(caller, packages), (caller, callee)
    assert (trace["caller"], trace["writer"]) == ("aiauv_pin/app/cli.py", WALK[-1])
    assert sorted([*trace["spine"], trace["writer"]]) == sorted(WALK)
    called = {file for edge in trace["edges"] for file in edge}
    assert sorted(called - set(WALK)) == LEAVES
    text = (ROOT / "docs" / "source" / "architecture.md").read_text()
    walk = text[text.index("## One step of `aiauv simulate`") :]
    walk = walk[: walk.index("\n## ", 1)]
    for file in WALK + LEAVES:
        assert f"`{file}`" in walk, file


#: Tests of the project as a whole (install, packaging, layout, README, notebooks, robustness
#: across every layer) stay at the top of ``tests/``; every other test lives in the folder of the
#: package it tests.
PROJECT_WIDE_TESTS = {
    "test_install_names",
    "test_layers",
    "test_notebooks_clean",
    "test_packaging",
    "test_readme",
    "test_reliability",
    "test_toolkit",
    "test_wheel_metadata",
}


def _test_folders() -> set[str]:
    """The folders of ``tests/`` that mirror a package: ``hydro``, ``control`` and each
    subpackage of ``aiauv_pin`` (``_internal`` as ``internal``)."""
    folders = {"hydro", "control"}
    for path in (ROOT / "aiauv_pin").iterdir():
        if (path / "__init__.py").is_file():
            folders.add(path.name.lstrip("_"))
    return folders


def test_tests_mirror_the_packages():
    folders = _test_folders()
    misplaced = []
    for path in sorted((ROOT / "tests").rglob("test_*.py")):
        parts = path.relative_to(ROOT / "tests").parts
        if len(parts) == 1:
            if path.stem not in PROJECT_WIDE_TESTS:
                misplaced.append(f"{path.name} (top level, not a project-wide test)")
        elif len(parts) != 2 or parts[0] not in folders:
            misplaced.append(f"{'/'.join(parts)} (no package {parts[0]!r})")
    assert not misplaced, "tests not in their package's folder: " + ", ".join(misplaced)
    assert folders - {"data"} >= {"hydro", "control", "kernels", "model", "simulation"}


def test_the_map_lists_every_package_and_module():
    """docs/source/architecture.md's table of packages names each package of the tree with its
    modules, no more and no fewer."""
    text = (ROOT / "docs" / "source" / "architecture.md").read_text()
    listed = {}
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0].startswith("`aiauv_"):
            listed[cells[0].strip("`")] = sorted(
                name.strip("`") for name in cells[2].split(", ") if name
            )
    real = {}
    for name, (path, is_package) in _modules().items():
        if is_package:
            real[name] = sorted(p.stem for p in path.parent.glob("*.py") if p.stem != "__init__")
    assert listed == real
