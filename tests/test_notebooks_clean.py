"""The committed notebooks are stripped and parametrisable.

Every ``notebooks/*.ipynb`` must be committed without outputs, execution counts or execution
timestamps (they are executed in CI with nbmake, and outputs in the repository only bloat diffs),
and must have exactly one code cell tagged ``parameters`` that holds only literal assignments, so
that a user (or papermill) can raise the short CI durations for a full run.

Clean a notebook after running it with ``jupyter nbconvert --clear-output --inplace FILE`` (and
drop ``metadata.execution`` from its cells) or with ``nbstripout FILE``.
"""

from __future__ import annotations

import ast
import copy
import json
from pathlib import Path

import pytest

NOTEBOOKS_DIR = Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOKS_DIR.glob("*.ipynb"))


def _source(cell: dict) -> str:
    source = cell.get("source", "")
    return "".join(source) if isinstance(source, list) else source


def _literal_assignment_problem(source: str) -> str | None:
    """Why ``source`` is not a block of ``NAME = literal`` statements, or ``None`` if it is."""
    try:
        tree = ast.parse(source)
    except SyntaxError as exc:
        return f"does not parse ({exc.msg})"
    if not tree.body:
        return "is empty"
    for statement in tree.body:
        if not (
            isinstance(statement, ast.Assign)
            and len(statement.targets) == 1
            and isinstance(statement.targets[0], ast.Name)
        ):
            return f"line {statement.lineno} is not a plain 'NAME = value' assignment"
        try:
            ast.literal_eval(statement.value)
        except ValueError:
            return f"line {statement.lineno} assigns a value that is not a literal"
    return None


def notebook_problems(notebook: dict) -> list[str]:
    """Everything that makes a notebook unfit for committing (empty list if it is clean)."""
    problems = []
    if notebook.get("nbformat") != 4:
        problems.append(f"nbformat is {notebook.get('nbformat')!r}, expected 4")
    cells = notebook.get("cells", [])
    parameter_cells = []
    for index, cell in enumerate(cells):
        where = f"cell {index}"
        metadata = cell.get("metadata", {})
        if "execution" in metadata:
            problems.append(f"{where} has execution timestamps (metadata.execution)")
        if cell.get("cell_type") != "code":
            if "outputs" in cell or "execution_count" in cell:
                problems.append(f"{where} is {cell.get('cell_type')} but has outputs")
            if "parameters" in metadata.get("tags", []):
                problems.append(f"{where} is tagged 'parameters' but is not a code cell")
            continue
        if cell.get("outputs"):
            problems.append(f"{where} has {len(cell['outputs'])} output(s)")
        if cell.get("execution_count") is not None:
            problems.append(f"{where} has execution_count {cell['execution_count']!r}")
        if "parameters" in metadata.get("tags", []):
            parameter_cells.append(index)
    if len(parameter_cells) != 1:
        problems.append(
            f"expected exactly one code cell tagged 'parameters', found {len(parameter_cells)}"
        )
    else:
        index = parameter_cells[0]
        code_cells = [i for i, cell in enumerate(cells) if cell.get("cell_type") == "code"]
        if index != code_cells[0]:
            problems.append(f"the 'parameters' cell (cell {index}) is not the first code cell")
        why = _literal_assignment_problem(_source(cells[index]))
        if why:
            problems.append(f"the 'parameters' cell {why}")
    return problems


def test_there_are_notebooks():
    names = {path.name for path in NOTEBOOKS}
    assert {
        "01_reduced_attitude_rigid_body.ipynb",
        "02_path_following_reproduction.ipynb",
        "03_bring_your_own_vehicle.ipynb",
    } <= names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[path.name for path in NOTEBOOKS])
def test_committed_notebook_is_clean(path: Path):
    notebook = json.loads(path.read_text(encoding="utf-8"))
    assert notebook_problems(notebook) == []


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[path.name for path in NOTEBOOKS])
def test_short_ci_duration_is_a_parameter(path: Path):
    """Each notebook's simulated time is set in its parameters cell (short for CI)."""
    notebook = json.loads(path.read_text(encoding="utf-8"))
    (cell,) = [
        cell
        for cell in notebook["cells"]
        if "parameters" in cell.get("metadata", {}).get("tags", [])
    ]
    values = {}
    for statement in ast.parse(_source(cell)).body:
        values[statement.targets[0].id] = ast.literal_eval(statement.value)
    assert 0 < values["DURATION"] <= 60.0


def test_the_check_catches_an_executed_notebook():
    """The check is not vacuous: outputs, counts, timestamps and a bad parameters cell are found."""
    notebook = json.loads(NOTEBOOKS[0].read_text(encoding="utf-8"))
    executed = copy.deepcopy(notebook)
    code = [cell for cell in executed["cells"] if cell["cell_type"] == "code"]
    code[-1]["outputs"] = [{"output_type": "stream", "name": "stdout", "text": ["1\n"]}]
    code[-1]["execution_count"] = 7
    code[-1]["metadata"]["execution"] = {"iopub.status.busy": "2025-01-01T00:00:00Z"}
    problems = notebook_problems(executed)
    assert len(problems) == 3, problems

    untagged = copy.deepcopy(notebook)
    for cell in untagged["cells"]:
        cell.get("metadata", {}).pop("tags", None)
    assert notebook_problems(untagged) == [
        "expected exactly one code cell tagged 'parameters', found 0"
    ]

    computed = copy.deepcopy(notebook)
    first_code = next(cell for cell in computed["cells"] if cell["cell_type"] == "code")
    first_code["source"] = "import numpy as np\nDURATION = np.float64(20.0)\n"
    assert notebook_problems(computed) == [
        "the 'parameters' cell line 1 is not a plain 'NAME = value' assignment"
    ]
