"""Hostile output paths for every command that writes (issue 29): FIFOs, links, folders, planted
links in ``--out`` folders, foreign content. Everything lives in ``tmp_path`` (never ``/dev``).

Each case asserts a one-line error (no traceback), a non-zero exit, and that nothing in the scratch
folder changed: a FIFO is still a FIFO, a link still the same link, a file outside still the same
bytes, foreign files still there (:func:`snapshot` compares the whole tree before and after).
The cases are listed in a fixed order with a fixed-seed shuffle of the targets' names; the counts
(runs, refusals, files changed, tracebacks) are printed by :func:`test_campaign_counts`.
"""

from __future__ import annotations

import hashlib
import json
import os
import random
import stat
import sys
from pathlib import Path

import pytest

from aiauv_pin._internal.atomic import (
    OutputPathError,
    atomic_path,
    open_inside,
    real_folder,
    write_parts,
    write_text,
)
from aiauv_pin._internal.result_folder import (
    MARKER,
    ResultFolderError,
    check_output_folder,
    claim_folder,
    read_manifest,
    remove_ours,
    staged_folder,
)
from aiauv_pin.app.cli import main
from aiauv_pin.builders.urdf_builder import bundled_spec_path, bundled_urdf_path

pytestmark = pytest.mark.skipif(
    not hasattr(os, "mkfifo") or sys.platform == "win32", reason="POSIX FIFOs and links"
)

SEED = 20290029
#: What the campaign found, filled by the tests of this module (printed by the last one).
COUNTS = {"runs": 0, "refused": 0, "tracebacks": 0, "files_changed": 0}


def snapshot(root: Path) -> dict[str, tuple]:
    """Every entry under ``root`` (never following links): kind and content or link target."""
    found = {}
    for top, dirs, names in os.walk(root, followlinks=False):
        for name in dirs + names:
            path = Path(top) / name
            mode = os.lstat(path).st_mode
            key = str(path.relative_to(root))
            if stat.S_ISLNK(mode):
                found[key] = ("link", os.readlink(path))
            elif stat.S_ISREG(mode):
                found[key] = ("file", hashlib.sha256(path.read_bytes()).hexdigest())
            elif stat.S_ISFIFO(mode):
                found[key] = ("fifo",)
            elif stat.S_ISDIR(mode):
                found[key] = ("dir",)
            else:
                found[key] = ("other", stat.S_IFMT(mode))
    return found


def hostile_targets(tmp_path: Path, suffix: str) -> dict[str, Path]:
    """Output paths that must all be refused, in a fresh folder: a FIFO, a link to a file outside,
    a link to a FIFO, a folder, a dangling link, a link to a folder outside."""
    work = tmp_path / "work"
    outside = tmp_path / "outside"
    work.mkdir(exist_ok=True)
    outside.mkdir(exist_ok=True)
    precious = outside / f"precious{suffix}"
    precious.write_text("precious bytes\n")
    pipe = outside / "pipe"
    if not pipe.exists():
        os.mkfifo(pipe)
    targets = {
        "fifo": work / f"fifo{suffix}",
        "link_to_file": work / f"link_file{suffix}",
        "link_to_fifo": work / f"link_fifo{suffix}",
        "folder": work / f"folder{suffix}",
        "dangling_link": work / f"dangling{suffix}",
        "link_to_folder": work / f"link_folder{suffix}",
    }
    os.mkfifo(targets["fifo"])
    targets["link_to_file"].symlink_to(precious)
    targets["link_to_fifo"].symlink_to(pipe)
    targets["folder"].mkdir()
    (targets["folder"] / "inside.txt").write_text("kept\n")
    targets["dangling_link"].symlink_to(outside / f"nothing{suffix}")
    targets["link_to_folder"].symlink_to(outside)
    return targets


def run_refused(capfd, argv: list, root: Path, *fragments: str) -> str:
    """Run ``aiauv argv``; assert a one-line error, a non-zero exit, nothing changed under root."""
    before = snapshot(root)
    capfd.readouterr()
    code = main([str(a) for a in argv])
    _, err = capfd.readouterr()
    after = snapshot(root)
    COUNTS["runs"] += 1
    COUNTS["tracebacks"] += "Traceback" in err
    COUNTS["files_changed"] += sum(before.get(k) != after.get(k) for k in before.keys() | after)
    lines = err.strip().splitlines()
    assert code not in (0, None), argv
    assert len(lines) == 1 and lines[0].startswith("aiauv: error:"), err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    changed = {k: (before.get(k), after.get(k)) for k in before.keys() | after}
    assert after == before, {k: v for k, v in changed.items() if v[0] != v[1]}
    COUNTS["refused"] += 1
    return lines[0]


def _shuffled(targets: dict[str, Path]) -> list[tuple[str, Path]]:
    items = sorted(targets.items())
    random.Random(SEED).shuffle(items)
    return items


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A vehicle URDF, its spec and its SDF (written once, outside every test's scratch)."""
    from aiauv_pin.interop.gz import export_sdf

    folder = tmp_path_factory.mktemp("inputs")
    sdf = folder / "paper.sdf"
    export_sdf(bundled_urdf_path("uniform"), sdf)
    return {"urdf": bundled_urdf_path("uniform"), "spec": bundled_spec_path("uniform"), "sdf": sdf}


WRITERS = {
    "build": (".urdf", lambda i, out: ["build", i["spec"], "-o", out]),
    "annotate": (".urdf", lambda i, out: ["annotate", i["urdf"], "-o", out]),
    "export-sdf": (".sdf", lambda i, out: ["export", i["urdf"], "-o", out]),
    "export-mjcf": (".xml", lambda i, out: ["export", i["urdf"], "-o", out]),
    "import-gz": (".urdf", lambda i, out: ["import-gz", i["sdf"], "--urdf", i["urdf"], "-o", out]),
    "bench": (".json", lambda i, out: ["bench", "--quick", "--out", out]),
}
EXPECTED = {
    "fifo": "a FIFO",
    "link_to_file": "a symbolic link",
    "link_to_fifo": "a symbolic link",
    "folder": "a directory",
    "dangling_link": "a symbolic link",
    "link_to_folder": "a symbolic link",
}


@pytest.mark.parametrize("writer", sorted(WRITERS))
def test_file_writers_refuse_special_outputs(tmp_path, capfd, inputs, writer):
    suffix, argv = WRITERS[writer]
    targets = hostile_targets(tmp_path, suffix)
    for kind, target in _shuffled(targets):
        line = run_refused(capfd, argv(inputs, target), tmp_path, "refusing", EXPECTED[kind])
        assert str(target) in line
    assert stat.S_ISFIFO(os.lstat(targets["fifo"]).st_mode)
    assert (tmp_path / "outside" / f"precious{suffix}").read_text() == "precious bytes\n"
    assert not (tmp_path / "outside" / f"nothing{suffix}").exists()


@pytest.mark.parametrize("writer", ["build", "export-sdf", "import-gz"])
def test_file_writers_still_replace_a_regular_file(tmp_path, capfd, inputs, writer):
    suffix, argv = WRITERS[writer]
    target = tmp_path / f"out{suffix}"
    target.write_text("old")
    other = tmp_path / f"hard{suffix}"
    os.link(target, other)  # a second name of the old file: replaced, never written through
    assert main([str(a) for a in argv(inputs, target)]) == 0
    assert target.read_text() != "old" and other.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([target.name, other.name])


# --- the helper itself ----------------------------------------------------------------------------


def test_atomic_helper_refuses_every_special_path(tmp_path):
    targets = hostile_targets(tmp_path, ".txt")
    before = snapshot(tmp_path)
    for kind, target in _shuffled(targets):
        with pytest.raises(OutputPathError, match=EXPECTED[kind]):
            write_text(target, "x")
        with pytest.raises(OutputPathError), atomic_path(target) as temporary:
            temporary.write_text("x")
    assert snapshot(tmp_path) == before
    # a folder reached through a link is refused under a root, created when missing
    root = tmp_path / "root"
    root.mkdir()
    (root / "runs").symlink_to(tmp_path / "outside")
    with pytest.raises(OutputPathError, match="symbolic link"):
        write_text(root / "runs" / "a.json", "{}", root=root)
    with pytest.raises(OutputPathError, match="outside"):
        real_folder(root, tmp_path / "outside")
    assert write_text(root / "new" / "deep" / "a.txt", "ok", root=root).read_text() == "ok"
    assert snapshot(tmp_path / "outside") == {
        k[len("outside/") :]: v for k, v in before.items() if k.startswith("outside/")
    }


def test_parts_are_written_one_after_the_other_and_atomically(tmp_path):
    target = tmp_path / "table.csv"
    parts = ["t [s],x [m]\n", "0.0,1.5\n", b"0.1,2.5\n", "0.2,\u00e9\n"]
    assert write_parts(target, iter(parts)) == target
    assert target.read_bytes() == "t [s],x [m]\n0.0,1.5\n0.1,2.5\n0.2,\u00e9\n".encode()

    def failing():
        yield "new text\n"
        raise RuntimeError("a part that cannot be made")

    with pytest.raises(RuntimeError, match="cannot be made"):
        write_parts(target, failing())
    assert target.read_bytes().startswith(b"t [s],x [m]\n")  # the old file, whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]  # no temporary left
    (tmp_path / "hostile").mkdir()
    for kind, hostile in _shuffled(hostile_targets(tmp_path / "hostile", ".csv")):
        with pytest.raises(OutputPathError, match=EXPECTED[kind]):
            write_parts(hostile, ["x"])


def test_lock_file_is_opened_inside_the_folder_only(tmp_path):
    targets = hostile_targets(tmp_path, ".lock")
    before = snapshot(tmp_path)
    for _kind, target in _shuffled(targets):
        with pytest.raises(OutputPathError):
            open_inside(target.parent, target.name)
    with pytest.raises(OutputPathError, match="real folder"):
        open_inside(targets["link_to_folder"], "x.lock")
    assert snapshot(tmp_path) == before
    descriptor = open_inside(tmp_path / "work", "ok.lock")
    os.close(descriptor)
    assert (tmp_path / "work" / "ok.lock").is_file()


# --- result folders -------------------------------------------------------------------------------


def _stage(out: Path, files: dict[str, str]) -> None:
    with staged_folder(out) as staging:
        for name, text in files.items():
            (staging / name).parent.mkdir(parents=True, exist_ok=True)
            (staging / name).write_text(text)


def test_rerun_removes_only_listed_files(tmp_path):
    out = tmp_path / "run"
    _stage(out, {"summary.json": "{}", "figures/a.png": "a", "playback.html": "old"})
    manifest = read_manifest(out)
    assert manifest["files"] == ["figures/a.png", "playback.html", "summary.json"]
    assert manifest["folders"] == ["figures"]
    _stage(out, {"summary.json": '{"new": 1}'})
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "summary.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # the old folder is gone
    # something not ours added to a result folder: the folder is refused, the file kept
    (out / "notes.txt").write_text("mine")
    with pytest.raises(ResultFolderError, match=r"notes\.txt"):
        check_output_folder(out)
    with pytest.raises(ResultFolderError), staged_folder(out):
        pass
    assert (out / "notes.txt").read_text() == "mine"


def test_forged_manifest_deletes_nothing_outside(tmp_path):
    outside = tmp_path / "outside"
    (outside / "sub").mkdir(parents=True)
    precious = outside / "precious.txt"
    precious.write_text("precious")
    (outside / "sub" / "x").write_text("x")
    folder = tmp_path / "forged"
    folder.mkdir()
    (folder / "link").symlink_to(precious)
    (folder / "sub").symlink_to(outside / "sub")
    forged = {
        "written_by": "aiauv-pin",
        "kind": "simulate",
        "files": [str(precious), "../outside/precious.txt", "link", "sub/x", "./link", 7],
        "folders": ["..", "sub", "/"],
    }
    (folder / MARKER).write_text(json.dumps(forged))
    before = snapshot(outside)
    with pytest.raises(ResultFolderError):  # links inside: not ours
        check_output_folder(folder)
    assert not remove_ours(folder)
    assert snapshot(outside) == before
    assert os.path.islink(folder / "link") and os.path.islink(folder / "sub")


def simulate_argv(out: Path) -> list:
    return ["simulate", "--duration", "0.1", "--no-html", "--quiet", "--out", out]


def test_simulate_out_refuses_special_and_foreign_folders(tmp_path, capfd):
    targets = hostile_targets(tmp_path, "")
    work = tmp_path / "work"
    regular = work / "file"
    regular.write_text("a file\n")
    git = work / "repo"
    (git / ".git").mkdir(parents=True)
    (git / ".git" / "HEAD").write_text("ref: refs/heads/main\n")
    foreign = work / "foreign"
    foreign.mkdir()
    (foreign / "summary.json").write_text('{"status": "complete"}')
    cases = {
        **{k: v for k, v in targets.items() if k != "folder"},
        "file": regular,
        "git": git,
        "foreign_summary": foreign,
    }
    for kind, target in _shuffled(cases):
        line = run_refused(capfd, simulate_argv(target), tmp_path, "refusing")
        assert str(target.name) in line, (kind, line)
    assert (git / ".git" / "HEAD").read_text() == "ref: refs/heads/main\n"
    assert (foreign / "summary.json").read_text() == '{"status": "complete"}'


def test_simulate_out_planted_links_in_a_result_folder(tmp_path, capfd):
    out = (
        tmp_path / "run"
    )  # a result folder as a run leaves it (tests/results/test_kill.py: a real one)
    _stage(out, {"summary.json": "{}", "timeseries.csv": "t\n0\n", "figures/a.png": "a"})
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.png").write_text("keep")
    for entry in sorted((out / "figures").iterdir()):
        entry.unlink()
    (out / "figures").rmdir()
    (out / "figures").symlink_to(outside)  # a link where our folder was
    run_refused(capfd, simulate_argv(out), tmp_path, "refusing", "figures")
    (out / "figures").unlink()
    (out / "summary.json").unlink()
    (out / "summary.json").symlink_to(outside / "keep.png")  # a link where our file was
    run_refused(capfd, simulate_argv(out), tmp_path, "refusing", "summary.json")
    assert (outside / "keep.png").read_text() == "keep"


def sweep_argv(spec: Path, out: Path) -> list:
    return ["sweep", spec, "--out", out, "--workers", "1", "--quiet"]


SWEEP = """duration = 0.1
dt = 0.01
[grid]
k_e = [0.05, 0.08]
"""


def test_sweep_out_refuses_links_and_foreign_content(tmp_path, capfd):
    spec = tmp_path / "s.toml"
    spec.write_text(SWEEP)
    targets = hostile_targets(tmp_path, "")
    work = tmp_path / "work"
    git = work / "repo"
    (git / ".git").mkdir(parents=True)
    foreign = work / "foreign"
    foreign.mkdir()
    (foreign / "results.csv").write_text("mine\n")
    cases = {**{k: v for k, v in targets.items() if k != "folder"}, "git": git, "foreign": foreign}
    for _kind, target in _shuffled(cases):
        run_refused(capfd, sweep_argv(spec, target), tmp_path, "refusing")
    outside = tmp_path / "outside"
    for planted in ("runs", "figures", ".sweep.lock"):
        ours = work / f"ours_{planted.strip('.')}"
        claim_folder(ours, "sweep")  # the folder a sweep made
        (ours / planted).symlink_to(outside if planted != ".sweep.lock" else outside / "pipe")
        run_refused(capfd, sweep_argv(spec, ours), tmp_path, "refusing", planted)
    fifo_lock = work / "ours_fifo_lock"
    claim_folder(fifo_lock, "sweep")
    os.mkfifo(fifo_lock / ".sweep.lock")
    run_refused(capfd, sweep_argv(spec, fifo_lock), tmp_path, "refusing", "FIFO")
    assert not list(outside.glob("*.json")) and not (outside / "runs").exists()


def test_campaign_counts():
    """The figures of this module's campaign (run last, in file order)."""
    print(f"\noutput campaign: {COUNTS}")
    assert COUNTS["runs"] == 0 or (
        COUNTS["tracebacks"] == 0
        and COUNTS["files_changed"] == 0
        and COUNTS["refused"] == COUNTS["runs"]
    )
