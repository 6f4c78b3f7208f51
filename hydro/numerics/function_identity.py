"""Content identities of a user's numba functions, so that compiled code taking them is cached.

numba's on-disk cache finds a compiled specialisation by its signature. When an argument is a
numba function (a controller, a path, a current or a disturbance passed as a first-class function),
the signature names that function's dispatcher object, which numba pickles through a random
per-process ``_uuid`` (numba issue 6251): a later process never finds the entry and compiles again.
The dispatcher's ``_uuid`` is however only a name: numba's ``Dispatcher._rebuild`` (pickling, used
for the cache index) returns the live dispatcher registered under that uuid (``_MemoMixin._memo``),
and numba lets it be set once, before first use (``_MemoMixin._set_uuid``; read in numba 0.68.1's
source, and of the same form in much older releases; where the private attribute is missing
:func:`stable_uuid` names nothing and the caller falls back). :func:`stable_uuid` therefore names
a user's dispatcher by a digest of what numba compiles from it (:func:`content_identity`), so the
same function in a new process has the same name and its cached specialisations are found again; a
changed function gets a new name and is compiled again.

What the digest covers (numba freezes globals and closure variables at compile time, so their
values are part of the compiled code):

* numba's version, the function's module, qualified name, source text (``inspect.getsource``) and
  bytecode, its compile options (``boundscheck``, ``fastmath``, ...) and ``locals``;
* every global it reads, found in its bytecode with the attribute chains read from modules
  (``mod.CONST``): numbers, strings, bytes, ``None``, NumPy scalars and arrays (dtype, shape and
  bytes), tuples and named tuples of these, enumeration members, classes (by name); the other numba
  functions it calls, recursively (a project function by its name only: the project's compiled code
  is keyed on all its sources, :func:`aiauv_hydro.numerics.jit.source_hash`); plain Python
  functions of the user's by source, recursively; a library's functions and modules (NumPy, math)
  by name and the library's version;
* its closure variables and defaults, as globals.

A function whose source cannot be read (defined in a REPL), or that reads a global of another kind
(a dictionary, a jitclass instance), has no identity: :func:`stable_uuid` returns ``None`` and the
caller compiles it in memory as before, once per process. So does a dispatcher whose uuid numba
already set (it was pickled before), or a second live dispatcher with the same content.
"""

from __future__ import annotations

import builtins
import dis
import enum
import hashlib
import inspect
import pickle
import sys
import sysconfig
import threading
import types
from functools import lru_cache
from pathlib import Path

from aiauv_hydro.numerics.jit import is_project_function

try:  # pragma: no cover - exercised by the no-numba test in a subprocess
    import numba
except ImportError:
    numba = None

#: Prefix of the uuids :func:`stable_uuid` gives (numba's own are ``uuid4`` strings).
UUID_PREFIX = "aiauv-content-"

_SCALARS = (type(None), bool, int, float, complex, str, bytes)

#: Held while a uuid is given (numba lets it be set once; threads may name the same function).
_NAMING = threading.Lock()


class _NoIdentity(Exception):
    """Something the digest cannot describe by content: the function has no identity."""


@lru_cache(maxsize=1)
def _library_roots() -> tuple[Path, ...]:
    """The installation folders of the standard library and of installed packages."""
    names = ("stdlib", "platstdlib", "purelib", "platlib")
    return tuple(Path(p).resolve() for p in {sysconfig.get_path(n) for n in names} if p)


def _is_library(module_name: str) -> bool:
    """Whether a module is the standard library's or an installed package's (not the user's)."""
    if module_name in sys.builtin_module_names:
        return True
    module = sys.modules.get(module_name)
    file = getattr(module, "__file__", None)
    if file is None:
        return module is not None  # a built-in or namespace module
    path = Path(file).resolve()
    return any(path.is_relative_to(root) for root in _library_roots())


def _library_name(value) -> str:
    """A library's object by its module, name and the version of its top-level package."""
    module = getattr(value, "__module__", None) or getattr(value, "__name__", "")
    top = sys.modules.get(str(module).partition(".")[0])
    version = getattr(top, "__version__", "")
    name = getattr(value, "__qualname__", None) or getattr(value, "__name__", repr(value))
    return f"library:{module}:{name}:{version}"


def _code_text(code: types.CodeType) -> str:
    """A code object's bytecode, names and constants (nested code objects included) as text."""

    def text(constant) -> str:
        if isinstance(constant, types.CodeType):
            return _code_text(constant)
        if isinstance(constant, frozenset):  # its order follows string hashing, per process
            return f"frozenset:{sorted(map(repr, constant))}"
        return f"{type(constant).__name__}:{constant!r}"

    consts = ",".join(map(text, code.co_consts))
    return f"{code.co_code.hex()}|{code.co_names}|{code.co_varnames}|{code.co_freevars}|{consts}"


class _Digest:
    """The description of one function's content, with the functions it reaches."""

    def __init__(self, is_project):
        self._is_project = is_project
        self._seen: dict[int, str] = {}

    def function(self, function) -> str:
        """A user's numba or plain Python function: its source, options, globals and closure."""
        key = id(function)
        if key in self._seen:  # recursion: named, described once
            return self._seen[key]
        py_func = getattr(function, "py_func", function)
        name = f"{py_func.__module__}:{py_func.__qualname__}"
        self._seen[key] = f"cycle:{name}"
        try:
            source = inspect.getsource(py_func)
        except (OSError, TypeError) as error:
            raise _NoIdentity(f"no source for {name}") from error
        # the bytecode too: a file edited after import gives the new source to the old function
        parts = [f"function:{name}", source, _code_text(py_func.__code__)]
        if hasattr(function, "py_func"):
            options = getattr(function, "targetoptions", {})
            parts.append(repr(sorted((k, self._option(v)) for k, v in options.items())))
            parts.append(
                repr(sorted((k, str(v)) for k, v in getattr(function, "locals", {}).items()))
            )
        parts.extend(self._globals(py_func))
        for cell in py_func.__closure__ or ():
            try:
                parts.append(self.value(cell.cell_contents))
            except ValueError as error:  # an empty cell
                raise _NoIdentity(f"empty closure cell in {name}") from error
        parts.extend(self.value(v) for v in py_func.__defaults__ or ())
        parts.extend(self.value(v) for v in (py_func.__kwdefaults__ or {}).values())
        described = hashlib.sha256("\0".join(parts).encode()).hexdigest()
        self._seen[key] = described
        return described

    @staticmethod
    def _option(value) -> str:
        if isinstance(value, (set, frozenset)):
            return repr(sorted(map(str, value)))
        return repr(value)

    def _globals(self, py_func) -> list[str]:
        """The globals (and attribute chains on modules) read by ``py_func``'s bytecode."""
        namespace = py_func.__globals__
        parts = []
        codes = [py_func.__code__]
        while codes:
            code = codes.pop()
            codes.extend(c for c in code.co_consts if isinstance(c, types.CodeType))
            chain: list[str] = []
            for instruction in [*dis.get_instructions(code), None]:
                op = instruction.opname if instruction is not None else ""
                if chain and op in ("LOAD_ATTR", "LOAD_METHOD"):
                    chain.append(instruction.argval)
                    continue
                if chain:
                    parts.append(self._chain(namespace, chain))
                    chain = []
                if op in ("LOAD_GLOBAL", "LOAD_NAME"):
                    chain = [instruction.argval]
        return parts

    def _chain(self, namespace, chain: list[str]) -> str:
        """``a.b.c`` read from the globals: resolved through modules, then described."""
        name = chain[0]
        if name in namespace:
            value = namespace[name]
        elif hasattr(builtins, name):
            return f"builtin:{name}"
        else:
            return f"missing:{name}"
        read = [name]
        for attribute in chain[1:]:
            if not isinstance(value, types.ModuleType):
                break
            value = getattr(value, attribute, None)
            read.append(attribute)
        return ".".join(read) + "=" + self.value(value)

    def value(self, value) -> str:
        """A global's or closure variable's value, as numba freezes it."""
        if isinstance(value, _SCALARS):
            return f"{type(value).__name__}:{value!r}"
        if isinstance(value, enum.Enum):
            return f"enum:{self.value(type(value))}:{self.value(value.value)}"
        if isinstance(value, tuple):
            items = ",".join(self.value(item) for item in value)
            return f"tuple:{type(value).__module__}.{type(value).__qualname__}({items})"
        if isinstance(value, types.ModuleType):
            if _is_library(value.__name__):
                return _library_name(value)
            return f"module:{value.__name__}"
        if isinstance(value, type):
            if _is_library(value.__module__):
                return _library_name(value)
            return f"class:{value.__module__}.{value.__qualname__}"
        np = sys.modules.get("numpy")
        if np is not None:
            if isinstance(value, np.ndarray):
                if value.dtype.hasobject:  # its bytes are addresses
                    raise _NoIdentity("an array of objects")
                data = np.ascontiguousarray(value).tobytes()
                return f"array:{value.dtype.str}:{value.shape}:{hashlib.sha256(data).hexdigest()}"
            if isinstance(value, np.generic):
                return f"scalar:{value.dtype.str}:{value!r}"
        if hasattr(value, "py_func"):  # a numba function
            if self._is_project(value):
                return f"project:{value.py_func.__module__}.{value.py_func.__qualname__}"
            return self.function(value)
        if isinstance(value, types.FunctionType):
            if _is_library(value.__module__ or ""):
                return _library_name(value)
            if self._is_project(value):
                return f"project:{value.__module__}.{value.__qualname__}"
            return self.function(value)
        if isinstance(value, (types.BuiltinFunctionType, getattr(np, "ufunc", ()))):
            return _library_name(value)
        if numba is not None and isinstance(value, numba.core.types.Type):
            return f"numba-type:{value}"
        raise _NoIdentity(f"a global of type {type(value).__name__}")


def content_identity(function, is_project=is_project_function) -> str | None:
    """A digest (hex) of what numba compiles from ``function`` (a numba function), or ``None``
    when it cannot be described by content (see the module docstring).

    Args:
        function: A numba dispatcher.
        is_project: Whether a function is the project's own (then named, not described; the
            project's compiled code is keyed on all its sources).
    """
    if numba is None or not hasattr(function, "py_func"):
        return None
    try:
        if is_project(function):
            py_func = function.py_func
            described = f"project:{py_func.__module__}.{py_func.__qualname__}"
        else:
            described = _Digest(is_project).function(function)
    except (_NoIdentity, AttributeError, TypeError, ValueError, RecursionError):
        return None  # not described by content (or an object the digest did not foresee)
    return hashlib.sha256(f"numba {numba.__version__}\0{described}".encode()).hexdigest()


def stable_uuid(function, is_project=is_project_function) -> str | None:
    """Give the numba dispatcher ``function`` the uuid ``UUID_PREFIX +`` its
    :func:`content_identity` (numba pickles a dispatcher by its uuid; see the module docstring)
    and return it, or ``None`` when that is not possible: no identity, a uuid numba already set
    (the dispatcher was pickled before), or another live dispatcher holding the same one.

    Args:
        function: A numba dispatcher.
        is_project: As for :func:`content_identity`.
    """
    if not hasattr(function, "_set_uuid"):
        return None
    current = getattr(function, "_MemoMixin__uuid", False)
    if isinstance(current, str) and current.startswith(UUID_PREFIX):
        return current  # given before: functions and their globals are frozen once compiled
    if current is not None:  # set by numba, or an unknown numba
        return None
    identity = content_identity(function, is_project)
    if identity is None:
        return None
    wanted = UUID_PREFIX + identity
    with _NAMING:
        current = getattr(function, "_MemoMixin__uuid", False)
        if current is not None:  # named meanwhile by another thread (or by numba)
            return current if current == wanted else None
        holder = function._memo.get(wanted)
        if holder is not None and holder is not function:
            return None
        function._set_uuid(wanted)
    return wanted


def saving_only_what_pickles(dispatcher):
    """``dispatcher`` (numba, cached on disk), made to skip saving a specialisation whose
    signature numba cannot pickle into its cache index, instead of failing the call that compiled
    it: numba pickles a user's function in the signature by value, with every global it names.
    Returns ``dispatcher``."""
    cache = getattr(dispatcher, "_cache", None)
    save = getattr(cache, "save_overload", None)
    if save is None:
        return dispatcher

    def save_overload(sig, data):
        try:
            save(sig, data)
        except (pickle.PicklingError, TypeError, AttributeError, RecursionError):
            pass  # not kept: compiled again by the next process, as without the cache

    cache.save_overload = save_overload
    return dispatcher
