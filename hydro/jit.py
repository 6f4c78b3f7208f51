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
every function defined in this project's packages by one hash of all their ``.py`` files (read
once per process; :data:`COMPILED_SOURCES`), so an edit to any file with compiled code recompiles
everything that may inline it, and no manual cache flush is ever needed. Compiled functions of the
project must therefore live in those files (a test checks this).

The same locators unpack the compiled kernels shipped with the package into numba's cache before
numba looks there (:mod:`hydro.prebuilt`), so a new installation needs no compilation for them.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import TypeVar

from . import prebuilt

F = TypeVar("F", bound=Callable)

#: The packages whose compiled functions share one content-keyed cache stamp.
PROJECT_PACKAGES = ("hydro", "control", "aiauv_pin")

#: Where the project's compiled code lives (folders or files, relative to the project root): the
#: stamp hashes exactly these sources, so editing e.g. the CLI recompiles nothing.
COMPILED_SOURCES = ("hydro", "control", "aiauv_pin/fast", "aiauv_pin/disturbances.py")

_ROOT = Path(__file__).resolve().parent.parent

#: True when numba compiles for the portable x86-64-v3 level, so that the kernels shipped in
#: ``hydro/prebuilt`` can serve this process (see :mod:`hydro.prebuilt`); set before numba loads.
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


def _project_files() -> list[Path]:
    files: list[Path] = []
    for source in COMPILED_SOURCES:
        path = _ROOT / source
        if path.is_dir():
            files.extend(sorted(path.rglob("*.py")))
        elif path.is_file():
            files.append(path)
    return files


@lru_cache(maxsize=1)
def source_hash() -> str:
    """SHA-256 over the content of every ``.py`` file of :data:`COMPILED_SOURCES` (hex digest)."""
    digest = hashlib.sha256()
    for path in _project_files():
        digest.update(str(path.relative_to(_ROOT)).encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()


def _in_project(py_file: str) -> bool:
    try:
        relative = Path(py_file).resolve().relative_to(_ROOT)
    except ValueError:
        return False
    return relative.parts[:1] in tuple((p,) for p in PROJECT_PACKAGES)


def _numba_name(name: str):
    """A numba caching class by its public name (numba >= 0.61) or its older private one."""
    return getattr(_caching, name, None) or getattr(_caching, "_" + name)


if _caching is not None:

    class _ProjectStampMixin:
        """Source stamp = hash of the whole project's sources (see the module docstring)."""

        def get_source_stamp(self):
            return source_hash()

        @classmethod
        def from_function(cls, py_func, py_file):
            if not _in_project(py_file):
                return None
            locator = super().from_function(py_func, py_file)
            if locator is not None:  # the shipped kernels of this folder, unpacked once
                prebuilt.seed(locator.get_cache_path(), py_file, _ROOT, source_hash())
            return locator

    class ProjectCacheLocator(_ProjectStampMixin, _numba_name("InTreeCacheLocator")):
        """Cache next to the sources (``__pycache__``), keyed on the project's content."""

    class ProjectUserWideCacheLocator(_ProjectStampMixin, _numba_name("UserWideCacheLocator")):
        """Cache in the user's cache folder when the source tree is read-only."""

    class ProjectUserProvidedCacheLocator(
        _ProjectStampMixin, _numba_name("UserProvidedCacheLocator")
    ):
        """Cache in ``NUMBA_CACHE_DIR`` when it is set (numba's own rule)."""

    _locators = _numba_name("CacheImpl")._locator_classes
    # NUMBA_CACHE_DIR first, then in-tree, then user-wide, as numba orders its own locators
    for _locator in (
        ProjectUserWideCacheLocator,
        ProjectCacheLocator,
        ProjectUserProvidedCacheLocator,
    ):
        if _locator not in _locators:
            _locators.insert(0, _locator)


def compiled(function: F | None = None, *, fastmath: bool = False, borrows_only: bool = False) -> F:
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
            in it atomically, which took 22 % of one evaluation of the paper vehicle (measured
            with ``perf``, issue 15). numba refuses to compile such a function if it allocates.
    """

    def wrap(fn: F) -> F:
        if not NUMBA_AVAILABLE:
            return fn
        options = dict(cache=True, nogil=True, error_model="numpy")
        if fastmath:
            options["fastmath"] = {"reassoc", "contract", "arcp", "nsz"}
        if borrows_only:
            options["_nrt"] = False
        return numba.njit(**options)(fn)

    return wrap if function is None else wrap(function)


def interpreted(function: Callable) -> Callable:
    """The plain Python function behind a :func:`compiled` law (itself if it was not compiled)."""
    return getattr(function, "py_func", function)


def user_or_builtin(builtin: Callable) -> Callable:
    """A function ``select(user, kind, *args)`` that calls ``user(*args)`` when ``user`` is a
    function and ``builtin(kind, *args)`` when it is ``None``, resolved at compile time.

    numba's on-disk cache keys a compiled function on its argument types, and the type of a
    function passed as an argument carries that function's address, which differs in every process
    (numba issue 6251): a cached loop that took its path, current or controller as a function
    would be compiled again in every process (and numba's cache index eventually fails to save).
    Built-in laws are therefore chosen by a number (``kind``) inside ``builtin`` and passed as
    ``user = None``; only a user's own function is passed as an argument (and runs in an uncached
    copy of the loop, see :func:`aiauv_pin.fast.loop.loop_for`). Interpreted, the choice is made at
    run time.
    """

    def select(user, kind, *args):
        if user is None:
            return builtin(kind, *args)
        return user(*args)

    if NUMBA_AVAILABLE:
        from numba import types
        from numba.extending import overload

        @overload(select)
        def _select(user, kind, *args):
            if isinstance(user, (types.NoneType, types.Omitted)):

                def call_builtin(user, kind, *args):
                    return builtin(kind, *args)

                return call_builtin

            def call_user(user, kind, *args):
                return user(*args)

            return call_user

    select.__name__ = f"user_or_{getattr(builtin, '__name__', 'builtin')}"
    return select
