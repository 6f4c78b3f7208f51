"""Compilation of the project's laws with numba, and the interpreted fallback without it.

Every control law and fluid term of the project is written once, as a plain Python function on
scalars and NumPy arrays, and decorated with :func:`compiled`:

* with numba installed, the decorator returns a numba dispatcher (``nopython`` mode, cached on
  disk, GIL released); the compiled simulation loop calls it from compiled code and the Python API
  calls it from Python. Its original Python function stays reachable as ``.py_func`` (tests run
  both and compare);
* without numba (or with ``NUMBA_DISABLE_JIT=1``) the decorator returns the function unchanged, so
  the same code runs interpreted.

The on-disk cache is keyed on content. numba's own cache keys each compiled function on its own
source file only, so a compiled loop that inlines a law from another file would keep serving stale
machine code after that file changed. :class:`ProjectCacheLocator` replaces the source stamp of
every function defined in this project's packages by one hash of all their compiled sources (read
once per process; :func:`compiled_sources`), so an edit to any file with compiled code recompiles
everything that may inline it, and no manual cache flush is ever needed. Compiled functions of the
project must therefore live in those files (a test checks this).

The cache is never written inside the installation or the checkout (numba's in-tree
``__pycache__`` folders, left behind in ``site-packages`` by an uninstall, would shadow a later
editable install as namespace packages). :class:`ProjectCacheLocator` is the only locator of the
project's functions; it keeps them in :func:`cache_folder`, a per-user folder
(``platformdirs.user_cache_dir("aiauv-pin")``, or ``$NUMBA_CACHE_DIR/aiauv-pin`` when that is set)
with one subfolder per package version, Python, CPU target and sources, so that two versions or
environments never serve each other stale code or overwrite each other's entries. Inside it, each
source file's functions are kept at that file's path relative to the registered packages
(:func:`compiled_sources`), e.g. ``pkg/sub`` for ``pkg/sub/module.py``, the same
names the shipped archives use.

The same locator unpacks the compiled kernels shipped with the package into that folder before
numba looks there (:mod:`aiauv_hydro.numerics.kernel_cache`), so a new installation needs no
compilation for them.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import warnings
from collections.abc import Callable
from functools import cache, lru_cache
from pathlib import Path, PurePosixPath
from typing import TypeVar

from aiauv_hydro.numerics import kernel_cache as prebuilt

F = TypeVar("F", bound=Callable)

#: The entry-point group through which installed packages declare where their compiled code lives
#: (``[project.entry-points."aiauv.compiled_sources"]`` in their ``pyproject.toml``): each entry's
#: value is a package or module, as a dotted import name. This floor names no package above it.
SOURCES_GROUP = "aiauv.compiled_sources"


@lru_cache(maxsize=1)
def compiled_sources() -> tuple[str, ...]:
    """The dotted names of every package or module declared in :data:`SOURCES_GROUP`, sorted: the
    stamp hashes exactly these sources, so editing e.g. the command line recompiles nothing."""
    entries = prebuilt.declared_entry_points().select(group=SOURCES_GROUP)
    return tuple(sorted({entry.value for entry in entries}))


def project_packages() -> tuple[str, ...]:
    """The top-level packages (import names) of :func:`compiled_sources`."""
    return tuple(sorted({source.partition(".")[0] for source in compiled_sources()}))


#: The distribution whose version keys the cache folder.
DISTRIBUTION = "aiauv-pin"

#: The application name of the per-user cache folder (platformdirs).
CACHE_APP_NAME = "aiauv-pin"

#: True when numba compiles for the portable x86-64-v3 level, so that the kernels shipped in
#: the declared archive folder can serve this process (see
#: :mod:`aiauv_hydro.numerics.kernel_cache`); set before numba loads.
PORTABLE_TARGET = os.environ.get("NUMBA_DISABLE_JIT", "0") in ("", "0") and (
    prebuilt.choose_portable_target()
)

try:  # pragma: no cover - exercised by the no-numba test in a subprocess
    import numba
    from numba.core import caching as _caching
except ImportError:  # numba missing: laws run interpreted
    numba = None
    _caching = None

#: True when laws are compiled (numba importable and not disabled by ``NUMBA_DISABLE_JIT``).
NUMBA_AVAILABLE = numba is not None and os.environ.get("NUMBA_DISABLE_JIT", "0") in ("", "0")


class CacheFolderWarning(UserWarning):
    """The per-user cache folder cannot be written: compiled code is not kept on disk."""


@lru_cache(maxsize=1)
def package_roots() -> dict[str, Path]:
    """Import name -> folder of each package of :func:`compiled_sources` that can be imported
    (found as ``import`` would find it, without importing it)."""
    roots = {}
    for name in sorted({source.partition(".")[0] for source in compiled_sources()}):
        module = sys.modules.get(name)
        spec = module.__spec__ if module is not None else importlib.util.find_spec(name)
        if spec is not None and spec.origin and spec.origin.endswith("__init__.py"):
            roots[name] = Path(spec.origin).resolve().parent
    return roots


def project_path(py_file: str | os.PathLike) -> PurePosixPath | None:
    """``py_file``'s path from the roots of :func:`compiled_sources` (e.g.
    ``pkg/sub/module.py``), or ``None`` if it is not in the project."""
    return _project_path(os.fspath(py_file))


@cache
def _project_path(py_file: str) -> PurePosixPath | None:
    """:func:`project_path`, once per file (every compiled function of a module asks for it)."""
    path = Path(py_file).resolve()
    for name, root in package_roots().items():
        if path.is_relative_to(root):
            return PurePosixPath(name, *path.relative_to(root).parts)
    return None


def is_project_function(function) -> bool:
    """Whether a compiled function is one of the project's own (its module is in its packages)."""
    module = getattr(function, "__module__", "") or ""
    return module.split(".")[0] in project_packages()


def _project_sources() -> list[tuple[PurePosixPath, Path]]:
    """Every ``.py`` file of :func:`compiled_sources`: (project path, file), in a fixed order."""
    roots = package_roots()
    files: list[tuple[PurePosixPath, Path]] = []
    for source in compiled_sources():
        package, _, inside = source.partition(".")
        if package not in roots:
            continue
        path = roots[package].joinpath(*inside.split(".")) if inside else roots[package]
        if not path.is_dir():
            path = path.with_name(path.name + ".py")
        found = sorted(path.rglob("*.py")) if path.is_dir() else [path] if path.is_file() else []
        files.extend((project_path(file), file) for file in found)
    return files


def _project_files() -> list[Path]:
    """The files :func:`source_hash` hashes."""
    return [file for _, file in _project_sources()]


@lru_cache(maxsize=1)
def source_hash() -> str:
    """SHA-256 over the project path and content of every ``.py`` file of
    :func:`compiled_sources` (hex digest); the same for an installed copy and its checkout."""
    digest = hashlib.sha256()
    for name, path in _project_sources():
        digest.update(str(name).encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()


@lru_cache(maxsize=1)
def package_version() -> str:
    """The installed version of :data:`DISTRIBUTION` (``"unversioned"`` if it is not installed);
    looked up once per process (``importlib.metadata`` scans the path: 0.6 ms a call, and every
    compiled function asks for it at import, 0.08 s of each start)."""
    from importlib import metadata

    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return "unversioned"


def cpu_target_name() -> str:
    """The CPU numba compiles for: ``NUMBA_CPU_NAME`` (with a digest of ``NUMBA_CPU_FEATURES`` when
    they are set), or ``host-<the host CPU's name>``."""
    name = os.environ.get("NUMBA_CPU_NAME")
    features = os.environ.get("NUMBA_CPU_FEATURES", "")
    if not name:
        try:
            import llvmlite.binding as llvm

            name = f"host-{llvm.get_host_cpu_name()}"
        except Exception:  # no llvmlite: nothing is compiled anyway
            name = "host"
    if features:
        name += "-" + hashlib.sha256(features.encode()).hexdigest()[:8]
    return name


def cache_base() -> Path:
    """Where this project keeps compiled code for every version: ``$NUMBA_CACHE_DIR/aiauv-pin``
    when ``NUMBA_CACHE_DIR`` is set, else the per-user cache folder of the platform."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]) / CACHE_APP_NAME
    import platformdirs

    return Path(platformdirs.user_cache_dir(CACHE_APP_NAME, appauthor=False))


def cache_key() -> str:
    """The subfolder of :func:`cache_base` for this process: package version, Python tag, CPU
    target and the first 12 hex digits of :func:`source_hash`, e.g.
    ``0.1.0-py311-x86-64-v3-0123456789ab``."""
    parts = (package_version(), prebuilt.python_tag(), cpu_target_name(), source_hash()[:12])
    return "-".join(part.replace(os.sep, "_") for part in parts)


def cache_folder() -> Path:
    """The folder holding this process's compiled code of the project (see the module docstring)."""
    return cache_base() / cache_key()


@lru_cache(maxsize=1)
def disk_cache_usable() -> bool:
    """Whether :func:`cache_folder` can be created and written; warns once if not (the project's
    functions are then compiled in memory in every process)."""
    folder = cache_folder()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as error:
        warnings.warn(
            f"aiauv: cannot write the compiled-code cache {folder} ({error}); compiled code is "
            "not kept (set NUMBA_CACHE_DIR to a writable folder)",
            CacheFolderWarning,
            stacklevel=3,
        )
        return False
    return True


def _numba_name(name: str):
    """A numba caching class by its public name (numba >= 0.61) or its older private one."""
    return getattr(_caching, name, None) or getattr(_caching, "_" + name)


if _caching is not None:

    class ProjectCacheLocator(_numba_name("CacheLocator")):
        """numba's cache of a project function: in :func:`cache_folder`, at the function's source
        folder's project path, stamped with :func:`source_hash` (see the module docstring)."""

        def __init__(self, py_func, folder: PurePosixPath):
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = str(cache_folder().joinpath(*folder.parts))

        def get_cache_path(self):
            return self._cache_path

        def get_source_stamp(self):
            return source_hash()

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            path = project_path(py_file)
            if path is None:
                return None  # not the project's: numba's own locators
            folder = path.parent
            locator = cls(py_func, folder)
            _prepare_folder(
                locator, folder
            )  # an error here is an error: never numba's in-tree cache
            return locator

    _prepared: set[str] = set()

    def _prepare_folder(locator: ProjectCacheLocator, folder: PurePosixPath) -> None:
        """The locator's folder created and checked writable (numba's ``ensure_cache_path``), and
        the shipped kernels of its sources unpacked into it: once per folder and process (every
        compiled function of a module has the same folder)."""
        path = locator.get_cache_path()
        if path not in _prepared:
            locator.ensure_cache_path()
            prebuilt.seed(path, folder.as_posix(), source_hash())
            _prepared.add(path)

    _locators = _numba_name("CacheImpl")._locator_classes
    if ProjectCacheLocator not in _locators:
        _locators.insert(0, ProjectCacheLocator)


def compiled(
    function: F | None = None,
    *,
    fastmath: bool = False,
    borrows_only: bool = False,
    inline: bool = False,
) -> F:
    """Compile ``function`` with numba (``nopython``, cached, ``nogil``), or return it unchanged.

    Args:
        function: A function on scalars, NumPy arrays, tuples and named tuples.
        fastmath: Allow reassociation and FMA contraction (never NaN/infinity assumptions, so the
            divergence checks still see non-finite states). Laws whose branches must take exactly
            the decisions of their interpreted execution (saturations, anti-windup) keep the
            default ``False``.
        borrows_only: The function only reads and writes arrays its caller owns: it allocates
            none and returns none (scalars and tuples of scalars only). It is then compiled
            without numba's reference counting (``_nrt=False``): every field read from a record
            (a named tuple of arrays) otherwise increments and decrements the count of each array
            in it atomically, a large share of one evaluation. numba refuses to compile
            such a function if it allocates.
        inline: Inline the function into its compiled callers (numba's ``inline="always"``, at
            numba's IR level, so the caller's ``fastmath`` applies to the inlined body). For the
            small per-link helpers called tens of times per evaluation, where separate compiled
            calls cost a noticeable share of one evaluation. Called from Python, the
            function is compiled on its own as usual.
    """

    def wrap(fn: F) -> F:
        if not NUMBA_AVAILABLE:
            return fn
        options = dict(cache=disk_cache_usable(), nogil=True, error_model="numpy")
        if fastmath:
            options["fastmath"] = {"reassoc", "contract", "arcp", "nsz"}
        if borrows_only:
            options["_nrt"] = False
        if inline:
            options["inline"] = "always"
        return numba.njit(**options)(fn)

    return wrap if function is None else wrap(function)


def interpreted(function: Callable) -> Callable:
    """The plain Python function behind a :func:`compiled` law (itself if it was not compiled)."""
    return getattr(function, "py_func", function)


#: numba options of a function that calls a user's function: with reference counting, set
#: explicitly. A function compiled for a call from compiled code takes the caller's setting unless
#: it sets its own (numba's flags inheritance), and the project's kernels run without it
#: (``compiled(borrows_only=True)``): a user's function that allocates would not compile there.
USER_CALL_OPTIONS = {"_nrt": True}


def user_or_builtin(builtin: Callable) -> Callable:
    """A function ``select(user, kind, *args)`` that calls ``user(*args)`` when ``user`` is a
    function and ``builtin(kind, *args)`` when it is ``None``, resolved at compile time.

    numba's on-disk cache keys a compiled function on its argument types, and the type of a
    function passed as an argument names that function by a uuid random in every process (numba
    issue 6251): a cached loop that took its path, current or controller as a function would be
    compiled again in every process. Built-in laws are therefore chosen by a number (``kind``)
    inside ``builtin`` and passed as ``user = None``; only a user's own function is passed as an
    argument, named by its content (:mod:`aiauv_hydro.numerics.function_identity`) so that the code
    compiled for it is found again (see the compiled loop's ``loop_for``). Interpreted, the choice
    is made at run time.
    """

    def select(user, kind, *args):
        if user is None:
            return builtin(kind, *args)
        return user(*args)

    if NUMBA_AVAILABLE:
        from numba import types
        from numba.extending import overload

        def _is_user(user) -> bool:
            return not isinstance(user, (types.NoneType, types.Omitted))

        @overload(select)
        def _select_builtin(user, kind, *args):
            if _is_user(user):
                return None

            def call_builtin(user, kind, *args):
                return builtin(kind, *args)

            return call_builtin

        # reference-counted, said explicitly: the user's function, compiled for this call,
        # inherits the setting (numba's flags inheritance), and may allocate what it returns
        @overload(select, jit_options=USER_CALL_OPTIONS)
        def _select_user(user, kind, *args):
            if not _is_user(user):
                return None

            def call_user(user, kind, *args):
                return user(*args)

            return call_user

    select.__name__ = f"user_or_{getattr(builtin, '__name__', 'builtin')}"
    return select
