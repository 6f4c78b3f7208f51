"""Crash-consistent result folders that only ever delete what a run of ours wrote.

A folder is either absent, an earlier complete one, or the new complete one; never a mix, never one
that claims completeness it lacks.

**What is ours.** Every result folder a run writes holds a manifest :data:`MARKER`
(``.aiauv-run.json``) listing exactly the files and folders the run wrote. Nothing else decides: no
file name (an unrelated ``summary.json``), no guess from hidden entries (a ``.git``). An existing
``--out`` folder is replaced only if it is empty or everything in it is listed in its manifest
(listed files must be regular files, listed folders real folders, all inside it); a folder holding
anything else (foreign content, links, a manifest that does not list it) is **refused** with one
line naming the first foreign entry, and nothing in it is touched. We chose refusing over writing
into a foreign folder: scattering ``summary.json``, figures and a CSV among someone's files, and
then replacing them file by file, would give up the all-or-nothing guarantee below.

**Staging.** :func:`staged_folder` yields a fresh hidden sibling ``.<name>.partial-<pid>-<random>``
of the output folder (it holds :data:`STAGING_MARKER` while files are written); everything of a run
is written there, then the manifest, and only then is the sibling put in place of the output
folder: on Linux in one atomic ``renameat2(RENAME_EXCHANGE)``, elsewhere by two renames (a kill
between them leaves no output folder, and the old one as a hidden ``.<name>.old-...`` sibling).
The old folder is then emptied of the files its manifest lists and removed if that leaves it empty.
Hidden siblings left by killed runs (their process is gone) are removed the next time the same
output folder is written: a staging folder still marked as staging entirely (we created it, empty),
any other only as far as its manifest lists.

:func:`claim_folder` marks a folder that a command fills over several invocations (``sweep
--out``): it must be new, empty, or already carry the manifest of that command.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import json
import os
import shutil
import stat
import tempfile
import uuid
from collections.abc import Iterable, Iterator
from pathlib import Path, PurePosixPath

from aiauv_pin._internal.atomic import OutputPathError, kind_of, write_text

#: The manifest of a result folder: the files and folders the run that wrote it wrote.
MARKER = ".aiauv-run.json"
#: Present in a staging folder while its files are written (removed before it is put in place).
STAGING_MARKER = ".aiauv-staging"
#: ``written_by`` of a manifest.
WRITTEN_BY = "aiauv-pin"
#: Kept for callers: the summary file of a run.
SUMMARY = "summary.json"

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


class ResultFolderError(OutputPathError):
    """An output path that cannot be used as a result folder; one line."""


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2``); ``False`` if unsupported here."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_uint,
    ]
    result = renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    return result == 0


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _is(path: Path, test) -> bool:
    try:
        return test(os.lstat(path).st_mode)
    except OSError:
        return False


def _relative(entry: object) -> str | None:
    """A manifest entry as a safe relative POSIX path, or ``None`` (absolute, ``..``, empty)."""
    if not isinstance(entry, str) or not entry or "\\" in entry or "\x00" in entry:
        return None
    parts = PurePosixPath(entry).parts
    if not parts or entry.startswith("/") or any(p in ("..", ".") for p in parts):
        return None
    return "/".join(parts)


def read_manifest(folder: str | os.PathLike, kind: str | None = None) -> dict | None:
    """The manifest of ``folder`` (:data:`MARKER`), or ``None`` if it has none or a bad one.

    Only a regular file that is valid JSON written by us (of ``kind`` if given) counts; its
    ``files`` and ``folders`` are kept only as safe relative paths.
    """
    path = Path(folder) / MARKER
    if not _is(path, stat.S_ISREG):
        return None
    try:
        with open(path, "rb") as stream:  # a regular file (lstat above); small
            content = json.loads(stream.read(1 << 22).decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    if not isinstance(content, dict) or content.get("written_by") != WRITTEN_BY:
        return None
    if kind is not None and content.get("kind") != kind:
        return None
    for key in ("files", "folders"):
        entries = content.get(key, [])
        entries = entries if isinstance(entries, list) else []
        content[key] = sorted({r for r in map(_relative, entries) if r is not None})
    return content


def _entries(folder: Path) -> Iterator[tuple[str, str]]:
    """``(relative path, "file" | "folder" | "other")`` of everything under ``folder``, top-down,
    never following a link (a link is an ``"other"``)."""
    for top, dirs, names in os.walk(folder, followlinks=False):
        base = Path(top).relative_to(folder)
        for name in sorted(dirs + names):
            try:
                mode = os.lstat(Path(top) / name).st_mode
            except FileNotFoundError:
                continue
            kind = "folder" if stat.S_ISDIR(mode) else "file" if stat.S_ISREG(mode) else "other"
            yield (base / name).as_posix(), kind


def _listing(folder: Path) -> tuple[list[str], list[str], list[str]]:
    """Files, folders and other entries (links, FIFOs, ...) under ``folder``, relative."""
    found: dict[str, list[str]] = {"file": [], "folder": [], "other": []}
    for entry, kind in _entries(folder):
        found[kind].append(entry)
    return found["file"], found["folder"], found["other"]


def _foreign_entry(folder: Path) -> str | None:
    """The first entry of ``folder`` its manifest does not list (``None``: all ours); stops at
    the first one (``--out ~`` is refused at once, not after reading the whole tree)."""
    manifest = read_manifest(folder) or {"files": [], "folders": []}
    ours = {"file": set(manifest["files"]) | {MARKER}, "folder": set(manifest["folders"])}
    for entry, kind in _entries(folder):
        if entry not in ours.get(kind, ()):
            return entry
    return None


def remove_ours(folder: Path) -> bool:
    """Delete what the manifest of ``folder`` lists (regular files, then empty real folders), the
    manifest, and ``folder`` itself if that leaves it empty; never anything else.

    Returns:
        Whether ``folder`` is gone.
    """
    manifest = read_manifest(folder) or {"files": [], "folders": []}
    for entry in manifest["files"]:
        path = folder / entry
        if _is(path, stat.S_ISREG) and _inside_real(folder, path):
            path.unlink(missing_ok=True)
    for entry in sorted(manifest["folders"], key=lambda e: -e.count("/")):
        path = folder / entry
        if _is(path, stat.S_ISDIR) and _inside_real(folder, path):
            with contextlib.suppress(OSError):
                path.rmdir()
    for name in (MARKER, STAGING_MARKER):
        if _is(folder / name, stat.S_ISREG):
            (folder / name).unlink(missing_ok=True)
    try:
        folder.rmdir()
    except OSError:
        return False
    return True


def _inside_real(root: Path, path: Path) -> bool:
    """Whether every folder between ``root`` and ``path`` is a real folder (no link)."""
    current = root
    for part in path.relative_to(root).parts[:-1]:
        current = current / part
        if not _is(current, stat.S_ISDIR):
            return False
    return True


def _owned(path: Path) -> bool:
    """Whether ``path`` belongs to this user (always, where there are no user ids)."""
    return not hasattr(os, "getuid") or os.lstat(path).st_uid == os.getuid()


def _remove_leftovers(out: Path) -> None:
    """Delete hidden siblings of ``out`` left by runs whose process no longer exists: a staging
    folder still marked as such whole, any other as far as its manifest lists."""
    for kind in ("partial", "old"):
        for path in out.parent.glob(f".{out.name}.{kind}-*"):
            try:
                pid = int(path.name[len(f".{out.name}.{kind}-") :].split("-")[0])
            except ValueError:
                continue
            if pid == os.getpid() or _pid_alive(pid) or not _is(path, stat.S_ISDIR):
                continue
            if _is(path / STAGING_MARKER, stat.S_ISREG) and _owned(path):
                shutil.rmtree(path, ignore_errors=True)
            else:
                remove_ours(path)


def check_output_folder(out: str | os.PathLike) -> Path:
    """``out`` if it may be (re)written as a result folder: new, empty, or holding only what its
    manifest lists.

    Raises:
        ResultFolderError: ``out`` is a link or not a folder, or holds something not ours.
    """
    given = out
    out = Path(os.path.abspath(out))  # "." or "sub/.." get a real name and parent
    if not out.name:
        raise ResultFolderError(f"{given}: not a folder that can be replaced; give a named folder")
    try:
        mode = os.lstat(out).st_mode
    except FileNotFoundError:
        return out
    if not stat.S_ISDIR(mode):
        raise ResultFolderError(
            f"refusing to write results to {out}: it is {kind_of(mode)}; give a new folder or "
            "one an earlier run wrote"
        )
    foreign = _foreign_entry(out)
    if foreign is not None:
        raise ResultFolderError(
            f"refusing to write results to {out}: it holds {foreign}, which no earlier run "
            f"wrote (not listed in its {MARKER}); it is not a result folder; give a new or "
            "empty folder"
        )
    return out


def _write_manifest(folder: Path, kind: str) -> None:
    files, folders, others = _listing(folder)
    if others:
        raise ResultFolderError(f"{folder / others[0]}: not a regular file written by the run")
    content = {
        "written_by": WRITTEN_BY,
        "kind": kind,
        "files": [f for f in files if f not in (MARKER, STAGING_MARKER)],
        "folders": folders,
    }
    write_text(folder / MARKER, json.dumps(content, indent=1) + "\n", root=folder)


@contextlib.contextmanager
def staged_folder(out: str | os.PathLike, kind: str = "simulate") -> Iterator[Path]:
    """Yield an empty staging folder; on success it replaces ``out`` (see the module docstring).

    If the body raises, the staging folder is deleted and ``out`` is untouched.

    Args:
        out: The result folder.
        kind: Recorded in the manifest (the command that wrote the folder).

    Raises:
        ResultFolderError: See :func:`check_output_folder`.
    """
    out = check_output_folder(out)
    parent = out.parent
    parent.mkdir(parents=True, exist_ok=True)
    _remove_leftovers(out)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-{os.getpid()}-", dir=parent))
    (staging / STAGING_MARKER).touch()
    try:
        yield staging
        _write_manifest(staging, kind)
        (staging / STAGING_MARKER).unlink()
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(staging, 0o777 & ~umask)
        out = check_output_folder(out)
        if not os.path.lexists(out):
            os.rename(staging, out)
        elif _exchange(staging, out):
            remove_ours(staging)  # now the old folder: what its manifest lists
        else:
            old = parent / f".{out.name}.old-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            os.rename(out, old)
            os.rename(staging, out)
            remove_ours(old)
    finally:
        if _is(staging / STAGING_MARKER, stat.S_ISREG):  # the body failed: all of it is ours
            shutil.rmtree(staging, ignore_errors=True)
        elif _is(staging, stat.S_ISDIR) and read_manifest(staging) is not None:
            remove_ours(staging)


def claim_folder(out: str | os.PathLike, kind: str, allowed: Iterable[str] = ()) -> Path:
    """Make ``out`` a result folder of ``kind`` that later invocations add to (``sweep --out``).

    ``out`` must be new, empty (but for the names in ``allowed``, e.g. a lock file), or carry a
    manifest of the same ``kind``; it must be a real folder (not a link). A manifest is written
    if there is none; it lists nothing (the command never deletes; it writes only its own names).

    Raises:
        ResultFolderError: ``out`` is a link or not a folder, or holds foreign content.
    """
    out = Path(os.path.abspath(out))
    try:
        mode = os.lstat(out).st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and not stat.S_ISDIR(mode):
        raise ResultFolderError(
            f"refusing to write results to {out}: it is {kind_of(mode)}; give a new folder or "
            f"one an earlier {kind} wrote"
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ResultFolderError(f"cannot create {out}: {exc.strerror}") from None
    if read_manifest(out, kind) is not None:
        return out
    if read_manifest(out) is not None:
        raise ResultFolderError(
            f"refusing to write {kind} results to {out}: another command's result folder"
        )
    allowed = set(allowed)
    foreign = sorted(p.name for p in out.iterdir() if p.name not in allowed)
    if foreign:
        raise ResultFolderError(
            f"refusing to write {kind} results to {out}: it holds {foreign[0]}, which no earlier "
            f"{kind} wrote (no {MARKER}); give a new or empty folder"
        )
    content = {"written_by": WRITTEN_BY, "kind": kind, "files": [], "folders": []}
    write_text(out / MARKER, json.dumps(content, indent=1) + "\n", root=out)
    return out
