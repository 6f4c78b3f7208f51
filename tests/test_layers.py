"""The package layout: no import cycles, and ``hydro``/``control`` stay below ``aiauv_pin``.

Read from the sources with :mod:`ast` (nothing is imported), so a deferred import inside a
function counts too: a cycle that only a lazy import keeps from failing today is still a cycle.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("hydro", "control", "aiauv_pin")


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package ``__init__``)."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
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


def test_no_import_cycles():
    graph, _ = _import_graph()
    assert len(graph) > 50  # the walk found the packages
    assert graph["aiauv_pin.fast.thruster_turning"] >= {"control.laws", "hydro.jit"}
    assert _cycles(graph) == []


def test_cycle_finder_sees_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_hydro_and_control_never_import_aiauv_pin_or_pinocchio():
    graph, external = _import_graph()
    for name in graph:
        if name.split(".")[0] in ("hydro", "control"):
            assert not {t for t in graph[name] if t.startswith("aiauv_pin")}, name
            assert not external[name] & {"pinocchio", "pin"}, name


def test_a_vehicle_load_reads_each_link_once(monkeypatch):
    """One URDF reader: the validation walk reads every link for hydro too (no second walk)."""
    import aiauv_pin
    import hydro.urdf_block
    import hydro.uuv_simulator
    from aiauv_pin import urdf_validation

    read = []
    original = urdf_validation.read_link

    def counted(element):
        read.append(element.get("name"))
        return original(element)

    def second_walk(root):
        raise AssertionError("the links were walked a second time")

    monkeypatch.setattr(urdf_validation, "read_link", counted)
    monkeypatch.setattr(hydro.urdf_block, "robot_links", second_walk)
    monkeypatch.setattr(hydro.uuv_simulator, "robot_links", second_walk)
    vehicle = aiauv_pin.load_vehicle(backend="pinocchio")
    assert sorted(read) == sorted(vehicle.urdf_structure.links)  # each link read exactly once
    assert len(vehicle.hydro.links) == 9
