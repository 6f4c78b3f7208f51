"""The README and the documentation's getting-started page stay true: every code block runs as written.

Every fenced block of ``README.md`` and ``docs/source/getting_started.md`` is accounted for, and how is
said by the HTML comment on the line before it (a block without one is run if it is bash or Python,
and is an error otherwise, so that no block is skipped silently):

* ``<!-- test: run -->`` (or no comment): run, bash with ``bash -e -o pipefail``, Python with this
  interpreter;
* ``<!-- test: file NAME -->``: written to ``NAME`` for the blocks after it;
* ``<!-- ci:test -->``: the test command ``.ci/run`` reads from the README and runs (checked here to
  be the command it extracts);
* ``<!-- test: ci -->``: commands that ``.ci/run`` runs as they are (each line must be one of its
  lines);
* ``<!-- test: install -->``: an installation command (it must contain ``pip install``), not run
  here: a test cannot install the package again; reported as a skip with that reason.

The blocks of one document run in order in one scratch folder, so a later block finds the files an
earlier one wrote. Commands run from that folder with ``aiauv`` (and ``.venv/bin/aiauv``,
``.venv/bin/python``) calling this interpreter, whose ``aiauv_pin`` must be this checkout's
(``test_examples_run_against_this_checkout``). The other pages of the documentation site may opt
blocks in with the same comments (``run`` and ``file``); their other blocks are not run.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GETTING_STARTED = ROOT / "docs" / "source" / "getting_started.md"
CI_RUN = ROOT / ".ci" / "run"
#: Documents whose every block must be accounted for.
WHOLE = (README, GETTING_STARTED)
#: Pages of the documentation site whose marked blocks run too.
OPT_IN = tuple(
    sorted(path for path in (ROOT / "docs" / "source").glob("*.md") if path != GETTING_STARTED)
)
RUNNABLE = ("bash", "python")
TIMEOUT = 600  # [s] per block

_FENCE = re.compile(r"^```(\S*)")
_MARKER = re.compile(r"^<!--\s*(ci:test|test:\s*(run|install|ci|file\s+(\S+)))\s*-->$")


@dataclass(frozen=True)
class Block:
    """One fenced block of a document."""

    document: Path
    line: int  # 1-based line of its opening fence
    language: str
    text: str
    kind: str  # run | file | ci-test | ci | install | unaccounted
    file_name: str | None = None

    @property
    def id(self) -> str:
        return f"{self.document.name}:{self.line}:{self.language or 'plain'}"


def _kind(marker_line: str, language: str) -> tuple[str, str | None]:
    match = _MARKER.match(marker_line.strip())
    if match is None:
        return ("run" if language in RUNNABLE else "unaccounted"), None
    if match.group(1) == "ci:test":
        return "ci-test", None
    word = match.group(2).split()[0]
    return word, match.group(3)


def blocks(document: Path) -> list[Block]:
    """Every fenced code block of ``document`` (MyST directives such as ```` ```{image} ```` aside)."""
    lines = document.read_text(encoding="utf-8").split("\n")
    found, index = [], 0
    while index < len(lines):
        opening = _FENCE.match(lines[index])
        if opening is None:
            index += 1
            continue
        language = opening.group(1)
        end = index + 1
        while end < len(lines) and lines[end].rstrip() != "```":
            end += 1
        if end == len(lines):
            raise AssertionError(f"{document.name}:{index + 1}: code block never closed")
        if not language.startswith("{"):
            previous = next((line for line in reversed(lines[:index]) if line.strip()), "")
            kind, file_name = _kind(previous, language)
            text = "\n".join(lines[index + 1 : end]) + "\n"
            found.append(Block(document, index + 1, language, text, kind, file_name))
        index = end + 1
    return found


def _collected() -> list[Block]:
    collected = [block for document in WHOLE for block in blocks(document)]
    for document in OPT_IN:
        collected += [
            block
            for block in blocks(document)
            if block.kind in ("run", "file") and _MARKER.match(_line_before(block))
        ]
    return collected


def _line_before(block: Block) -> str:
    lines = block.document.read_text(encoding="utf-8").split("\n")[: block.line - 1]
    return next((line.strip() for line in reversed(lines) if line.strip()), "")


def _ci_test_command() -> str:
    """The command ``.ci/run`` extracts from the README (its own awk line, run as it is)."""
    extraction = (
        CI_RUN.read_text()
        .split("test_command=", 1)[1]
        .split("\n", 1)[0]
        .removeprefix("$(")
        .removesuffix(")")
    )
    return subprocess.run(
        ["bash", "-c", extraction], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()


@dataclass
class _Session:
    """The blocks of one document, run in order in one scratch folder (each at most once)."""

    folder: Path
    order: list[Block]
    results: dict[int, subprocess.CompletedProcess] = field(default_factory=dict)

    def environment(self) -> dict[str, str]:
        bin_folder = self.folder / ".venv" / "bin"
        return {**os.environ, "PATH": f"{bin_folder}{os.pathsep}{os.environ.get('PATH', '')}"}

    def run_through(self, target: Block) -> subprocess.CompletedProcess:
        for block in self.order:
            if block.line not in self.results:
                self.results[block.line] = self._execute(block)
            if block == target:
                return self.results[block.line]
        raise AssertionError(f"{target.id} is not a block of this session")

    def _execute(self, block: Block) -> subprocess.CompletedProcess:
        if block.kind == "file":
            (self.folder / block.file_name).write_text(block.text, encoding="utf-8")
            return subprocess.CompletedProcess([], 0, "", "")
        if block.language == "python":
            command = [sys.executable, "-c", block.text]
        else:
            command = ["bash", "-e", "-o", "pipefail", "-c", block.text]
        return subprocess.run(
            command,
            cwd=self.folder,
            env=self.environment(),
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
        )


def _new_session(folder: Path, document: Path, collected: list[Block]) -> _Session:
    """A scratch folder whose ``.venv/bin`` runs this interpreter (so ``aiauv`` is this checkout's)."""
    bin_folder = folder / ".venv" / "bin"
    bin_folder.mkdir(parents=True)
    wrappers = {
        "python": f'exec "{sys.executable}" "$@"',
        "python3": f'exec "{sys.executable}" "$@"',
        "aiauv": f'exec "{sys.executable}" -m aiauv_pin "$@"',
    }
    for name, body in wrappers.items():
        script = bin_folder / name
        script.write_text(f"#!/bin/sh\n{body}\n", encoding="utf-8")
        script.chmod(0o755)
    order = [b for b in collected if b.document == document and b.kind in ("run", "file")]
    return _Session(folder, order)


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    collected = _collected()
    made: dict[Path, _Session] = {}

    def session_of(document: Path) -> _Session:
        if document not in made:
            folder = tmp_path_factory.mktemp(document.stem)
            made[document] = _new_session(folder, document, collected)
        return made[document]

    return session_of


@pytest.mark.parametrize("block", _collected(), ids=lambda block: block.id)
def test_code_block(block, sessions):
    where = f"{block.id} ({block.document.relative_to(ROOT)})"
    if block.kind == "unaccounted":
        pytest.fail(
            f"{where}: a {block.language or 'plain'} block with no test comment before it; "
            "say how it runs (<!-- test: run|file NAME|ci|install -->)"
        )
    if block.kind == "ci-test":
        assert block.document == README, f"{where}: only the README holds CI's test command"
        assert block.text.strip() == _ci_test_command(), f"{where}: not what .ci/run runs"
        return
    if block.kind == "ci":
        ci_lines = {line.strip() for line in CI_RUN.read_text().split("\n")}
        missing = [line for line in block.text.strip().split("\n") if line.strip() not in ci_lines]
        assert not missing, f"{where}: .ci/run does not run {missing}"
        return
    if block.kind == "install":
        assert "pip install" in block.text, f"{where}: marked as an installation, but is not one"
        pytest.skip(f"{where}: an installation command, which a test cannot run again")
    completed = sessions(block.document).run_through(block)
    assert completed.returncode == 0, (
        f"{where} failed (exit {completed.returncode}):\n{block.text}\n"
        f"--- stdout\n{completed.stdout[-2000:]}\n--- stderr\n{completed.stderr[-3000:]}"
    )


def test_every_fence_is_seen():
    """The block parser finds every fence of the two documents (none indented or left open)."""
    for document in WHOLE:
        text = document.read_text(encoding="utf-8")
        fences = re.findall(r"^[ \t]*```", text, flags=re.M)
        directives = re.findall(r"^```\{", text, flags=re.M)
        assert len(fences) == 2 * (len(blocks(document)) + len(directives)), document.name
        assert not re.search(r"^[ \t]+```", text, flags=re.M), f"{document.name}: indented fence"


def test_only_the_install_commands_are_not_run():
    """What does not run here is the README's two quick-start commands (one of them CI's test
    command) and the getting-started page's installation and site build (which ``.ci/run`` runs)."""
    not_run = {
        document.name: [b.kind for b in blocks(document) if b.kind not in ("run", "file")]
        for document in WHOLE
    }
    assert not_run == {"README.md": ["install", "ci-test"], GETTING_STARTED.name: ["install", "ci"]}


def test_ci_runs_the_readme_test_command():
    """``.ci/run`` extracts the command after the ``ci:test`` marker; it must be the quick start's."""
    text = README.read_text()
    marker = text.index("<!-- ci:test -->")
    command = re.search(r"```bash\n(.*?)\n```", text[marker:], flags=re.S).group(1)
    assert "pytest" in command and "pip install" in command
    assert _ci_test_command() == command


def test_examples_run_against_this_checkout(tmp_path):
    """The blocks run ``aiauv_pin`` from a scratch folder: it must be this checkout's, not a copy."""
    completed = subprocess.run(
        [sys.executable, "-c", "import aiauv_pin; print(aiauv_pin.__file__)"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=True,
    )
    assert Path(completed.stdout.strip()).resolve().is_relative_to(ROOT)


@pytest.mark.parametrize("document", WHOLE, ids=lambda document: document.name)
def test_own_vehicle_example_suits_the_paper_controller(document, tmp_path):
    """The "your own vehicle" spec builds a usable vehicle that the paper's controller accepts."""
    from aiauv_pin import load_vehicle
    from aiauv_pin.builders.urdf_builder import write_urdf
    from aiauv_pin.builders.vehicle_spec import spec_from_toml
    from aiauv_pin.checks.vehicle_check import check_vehicle
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing, joint_axis_labels

    (spec,) = [b for b in blocks(document) if b.kind == "file" and b.file_name == "my_aiauv.toml"]
    path = write_urdf(spec_from_toml(spec.text), tmp_path / "vehicle.urdf")
    report = check_vehicle(path)  # raises for an unusable vehicle
    assert report.total_mass == pytest.approx(50.0)
    assert report.smallest_mass_eigenvalue > 0.0
    vehicle = load_vehicle(path)
    labels = joint_axis_labels(vehicle)
    assert labels == ("+z", "+y", "+z", "+y")
    VehiclePathFollowing(vehicle)  # raises for a joint layout the paper's law cannot steer
