"""The one output helper of every command that writes a file: a result file is either absent, the
old one, or complete; a path that is not a regular file is never written through or replaced.

Every writer (``build -o``, ``annotate -o``, ``export``, ``import-gz -o``, ``bench --out``, the files
of ``simulate --out`` and ``sweep --out``) goes through :func:`atomic_path` (or :func:`write_text`,
:func:`write_bytes`), which

* refuses an output path that exists and is not a regular file, with one line naming what it is
  (FIFO, character or block device, directory, symbolic link, socket): a FIFO is never opened (it
  would block), a device is never replaced by a regular file (``-o /dev/null`` run as root would
  otherwise replace the system's ``/dev/null``);
* refuses an existing **symbolic link** at the output path, whatever it points to, also a dangling
  one (the safe default: writing through it would change a file elsewhere, replacing it would
  silently turn the user's link into a file);
* writes a temporary file in the same folder (``mkstemp``: ``O_CREAT | O_EXCL``, which never follows
  a link) and puts it in place with ``os.replace``, which renames over the directory entry itself and
  never writes through anything; the kind of the output path is checked again just before;
* with ``root`` (a result folder), reaches the file's folder from ``root`` through real folders only
  (:func:`real_folder`): a ``runs`` or ``figures`` planted as a symbolic link to elsewhere is
  refused, not written through.

:func:`open_inside` opens (creating it) a file such as a lock file strictly inside a folder, with
``O_NOFOLLOW`` relative to the folder's descriptor.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from aiauv_pin.errors import AiauvError

#: What a non-regular file is, by ``stat`` test, for the one-line refusal.
_KINDS = (
    (stat.S_ISLNK, "a symbolic link"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISSOCK, "a socket"),
)


class OutputPathError(AiauvError, OSError):
    """An output path that must not be written (not a regular file, a link, a folder through a
    link); the message is one line."""


def kind_of(mode: int) -> str:
    """``"a FIFO"``, ``"a directory"``, ... for an ``st_mode``; ``"a regular file"`` for one."""
    if stat.S_ISREG(mode):
        return "a regular file"
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def check_output_file(path: str | os.PathLike) -> Path:
    """``path`` if it does not exist or is a regular file (not a link to one).

    Raises:
        OutputPathError: It is a FIFO, device, directory, symbolic link or socket, or cannot be
            examined.
    """
    path = Path(path)
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return path
    except OSError as exc:
        raise OutputPathError(f"cannot write to {path}: {exc.strerror}") from None
    if not stat.S_ISREG(mode):
        raise OutputPathError(
            f"refusing to write to {path}: it is {kind_of(mode)}, not a regular file; "
            "give a new path or a regular file"
        )
    return path


def real_folder(
    root: str | os.PathLike, folder: str | os.PathLike | None = None, *, create: bool = True
) -> Path:
    """``folder`` (default ``root``), a folder inside ``root`` reached through real folders only.

    ``root`` and every folder between it and ``folder`` must be a directory and not a symbolic
    link (checked with ``lstat``); missing ones are created (with ``create``; else only what
    exists is checked).

    Raises:
        OutputPathError: A folder on the way is a link or not a folder, or ``folder`` is outside
            ``root``.
    """
    root = Path(root)
    folder = root if folder is None else Path(folder)
    try:
        parts = folder.relative_to(root).parts
    except ValueError:
        raise OutputPathError(f"refusing to write to {folder}: it is outside {root}") from None
    if ".." in parts:
        raise OutputPathError(f"refusing to write to {folder}: it leaves {root}")
    current = root
    for step in (None, *parts):
        if step is not None:
            current = current / step
        if create:
            try:
                current.mkdir(parents=step is None)
            except FileExistsError:
                pass
            except OSError as exc:
                raise OutputPathError(f"cannot create {current}: {exc.strerror}") from None
        try:
            mode = os.lstat(current).st_mode
        except FileNotFoundError:
            return folder  # not created: nothing further down exists either
        if not stat.S_ISDIR(mode):
            raise OutputPathError(
                f"refusing to write into {current}: it is {kind_of(mode)}, not a folder"
            )
    return folder


def _new_file_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(
    path: str | os.PathLike, *, root: str | os.PathLike | None = None
) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` in one step.

    The temporary file sits in the same folder (same file system), so ``os.replace`` is atomic; if the
    body raises, the temporary file is removed and ``path`` is untouched. See the module docstring
    for what is refused.

    Args:
        path: The output file: new, or an existing regular file.
        root: A result folder holding ``path``: the folders between them must be real folders
            (created if missing). Without it, a missing folder of ``path`` is created.

    Raises:
        OutputPathError: ``path`` exists and is not a regular file, or a folder on the way is not
            a real folder.
    """
    path = check_output_file(path)
    if root is not None:
        real_folder(root, path.parent)
    else:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputPathError(f"cannot create the folder of {path}: {exc.strerror}") from None
    handle, temporary = tempfile.mkstemp(
        prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent
    )
    os.close(handle)
    temporary = Path(temporary)
    try:
        yield temporary
        os.chmod(temporary, _new_file_mode())  # mkstemp creates it owner-only
        check_output_file(path)  # again: nothing else took its place meanwhile
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_text(
    path: str | os.PathLike, text: str, *, root: str | os.PathLike | None = None
) -> Path:
    """Write a text file atomically (UTF-8); see :func:`atomic_path`."""
    with atomic_path(path, root=root) as temporary:
        temporary.write_text(text, encoding="utf-8")
    return Path(path)


def write_parts(
    path: str | os.PathLike,
    parts: Iterable[str | bytes],
    *,
    root: str | os.PathLike | None = None,
) -> Path:
    """Write the concatenation of ``parts`` (text, as UTF-8, or bytes) atomically, one part after
    the other: a large file made of many parts is never joined into one string first (each join of
    a 9 MB table is a copy into memory the kernel must first map); see :func:`atomic_path`."""
    with atomic_path(path, root=root) as temporary, open(temporary, "wb") as handle:
        for part in parts:
            handle.write(part.encode("utf-8") if isinstance(part, str) else part)
    return Path(path)


def write_bytes(
    path: str | os.PathLike, data: bytes, *, root: str | os.PathLike | None = None
) -> Path:
    """Write a binary file atomically; see :func:`atomic_path`."""
    with atomic_path(path, root=root) as temporary:
        temporary.write_bytes(data)
    return Path(path)


def open_inside(folder: str | os.PathLike, name: str, mode: int = 0o644) -> int:
    """A read-write descriptor of the regular file ``name`` directly inside ``folder`` (created).

    Opened relative to a descriptor of ``folder`` (itself opened with ``O_NOFOLLOW``), with
    ``O_NOFOLLOW | O_NONBLOCK``: a link at ``name`` or at ``folder`` is refused, a FIFO does not
    block and is refused after ``fstat``. Not ``O_EXCL``: a lock file stays between runs (removing
    it after a run would race with the next run's ``flock``). POSIX only.

    Raises:
        OutputPathError: ``name`` or ``folder`` is not what it should be.
    """
    folder = Path(folder)
    if "/" in name or name in ("", ".", ".."):
        raise OutputPathError(f"refusing to open {name!r}: not a plain file name")
    target = folder / name
    try:
        folder_fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError as exc:
        raise OutputPathError(
            f"refusing to write into {folder}: not a real folder ({exc.strerror})"
        ) from None
    try:
        check_output_file(target)
        flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
        try:
            descriptor = os.open(name, flags, mode, dir_fd=folder_fd)
        except OSError as exc:
            raise OutputPathError(f"refusing to write to {target}: {exc.strerror}") from None
    finally:
        os.close(folder_fd)
    file_mode = os.fstat(descriptor).st_mode
    if not stat.S_ISREG(file_mode):
        os.close(descriptor)
        raise OutputPathError(
            f"refusing to write to {target}: it is {kind_of(file_mode)}, not a regular file"
        )
    return descriptor
