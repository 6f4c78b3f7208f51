"""Crash-consistent result folders: a folder is either absent, an earlier complete one, or the new
complete one; never a mix, never one that claims completeness it lacks.

:func:`staged_folder` yields a fresh hidden sibling ``.<name>.partial-<pid>-<random>`` of the output
folder; everything of a run is written there, and only when all of it is written is the sibling put
in place of the output folder: on Linux in one atomic ``renameat2(RENAME_EXCHANGE)`` (the old folder
is then deleted), elsewhere by two renames (a kill between them leaves no output folder, and the
old one as a hidden ``.<name>.old-...`` sibling). Files of an earlier run are never mixed into the
new folder (it starts empty), so no stale ``playback.html`` or figure survives a diverged or
``--no-html`` run. Hidden siblings left by killed runs (their process is gone) are removed the next
time the same output folder is written.

An existing output folder is only replaced if it is empty or holds a ``summary.json`` (a folder an
earlier run wrote); any other existing path is refused with one line, so that ``--out`` pointing at
a home directory or a file never deletes it.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import shutil
import tempfile
import uuid
from collections.abc import Iterator
from pathlib import Path

from .errors import AiauvError

#: The file that marks a folder as one written by a run (and so replaceable by the next run).
SUMMARY = "summary.json"

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


class ResultFolderError(AiauvError, OSError):
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


def _remove_leftovers(out: Path) -> None:
    """Delete hidden siblings of ``out`` left by runs whose process no longer exists."""
    for kind in ("partial", "old"):
        for path in out.parent.glob(f".{out.name}.{kind}-*"):
            try:
                pid = int(path.name[len(f".{out.name}.{kind}-") :].split("-")[0])
            except ValueError:
                continue
            if (
                pid != os.getpid()
                and not _pid_alive(pid)
                and path.is_dir()
                and not path.is_symlink()
            ):
                shutil.rmtree(path, ignore_errors=True)


def check_output_folder(out: str | os.PathLike) -> Path:
    """``out`` if it may be (re)written as a result folder.

    Raises:
        ResultFolderError: ``out`` exists and is not a folder, or is a folder of something else.
    """
    given = out
    out = Path(os.path.abspath(out))  # "." or "sub/.." get a real name and parent
    if not out.name:
        raise ResultFolderError(f"{given}: not a folder that can be replaced; give a named folder")
    if out.is_symlink():
        raise ResultFolderError(f"{out}: is a symbolic link; give a new or a result folder")
    if out.exists():
        if not out.is_dir():
            raise ResultFolderError(f"{out}: exists and is not a folder")
        entries = [p for p in out.iterdir() if not p.name.startswith(".")]
        if entries and not (out / SUMMARY).is_file():
            raise ResultFolderError(
                f"{out}: exists and is not a result folder (no {SUMMARY}); give a new or empty "
                "folder, or one an earlier run wrote"
            )
    return out


@contextlib.contextmanager
def staged_folder(out: str | os.PathLike) -> Iterator[Path]:
    """Yield an empty staging folder; on success it replaces ``out`` (see the module docstring).

    If the body raises, the staging folder is deleted and ``out`` is untouched.

    Raises:
        ResultFolderError: See :func:`check_output_folder`.
    """
    out = check_output_folder(out)
    parent = out.parent
    parent.mkdir(parents=True, exist_ok=True)
    _remove_leftovers(out)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-{os.getpid()}-", dir=parent))
    try:
        yield staging
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(staging, 0o777 & ~umask)
        out = check_output_folder(out)
        if not out.exists():
            os.rename(staging, out)
        elif _exchange(staging, out):
            shutil.rmtree(staging, ignore_errors=True)  # now the old folder
        else:
            old = parent / f".{out.name}.old-{os.getpid()}-{uuid.uuid4().hex[:8]}"
            os.rename(out, old)
            os.rename(staging, out)
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
