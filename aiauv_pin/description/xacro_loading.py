"""Expanding ``.xacro`` vehicle descriptions without ROS (the ``xacro`` package from PyPI).

``$(find pkg)`` resolves through the package search path of :mod:`aiauv_pin.description.ros_packages`
(``--package-path`` folders, ``ROS_PACKAGE_PATH``, example-robot-data) instead of ROS 2's ament
index, which the PyPI package would otherwise need. ``$(arg NAME)`` takes the values given as
``xacro_args`` (``--arg NAME=VALUE``), else the ``<xacro:arg default>``.

A vehicle file is data: by default every ``${...}`` and ``$(eval ...)`` expression is evaluated by
the safe evaluator of :mod:`aiauv_pin.description.xacro_safe_eval` (arithmetic, comparisons and math functions
on properties; nothing that could reach Python's objects), never by xacro's Python ``eval``; only
``trust=True`` (``--trust-xacro``, ``load_vehicle(..., trust_xacro=True)``) expands with full xacro.

In both modes the expansion is bounded: every file xacro reads (the top file and each
``<xacro:include>``) goes through :func:`aiauv_pin.description.input_limits.read_bytes` (regular
files only, at
most :data:`~aiauv_pin.description.input_limits.MAX_FILE_BYTES` each, :data:`MAX_XACRO_TOTAL_BYTES` and
:data:`MAX_XACRO_FILES` in all, includes nested at most :data:`MAX_INCLUDE_DEPTH` deep) and is
parsed by defusedxml with DTDs forbidden before xacro's (minidom) parser sees it; the expansion
stops past :data:`MAX_MACRO_CALLS` macro calls or :data:`MAX_EXPANDED_ELEMENTS` elements evaluated
(macros that double at each level), :data:`MAX_EXPANDED_CHARACTERS` characters or
:data:`MAX_EXPANSION_SECONDS`. Any xacro failure
becomes one :class:`VehicleLoadError` line (:class:`InputLimitError` for a limit).
"""

from __future__ import annotations

import contextlib
import io
import os
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

from aiauv_pin.description.input_limits import read_bytes
from aiauv_pin.description.ros_packages import find_package, package_search_path
from aiauv_pin.description.xacro_safe_eval import (
    SAFE_CONSTANTS,
    SafeXacroEvaluator,
    UnsafeXacroExpression,
)
from aiauv_pin.errors import InputLimitError, VehicleLoadError

#: File suffixes expanded with xacro (``robot.urdf.xacro`` ends in ``.xacro`` too).
XACRO_SUFFIXES = (".xacro",)
#: Largest expanded description accepted [characters] (as plain URDFs: 50 MB).
MAX_EXPANDED_CHARACTERS = 50_000_000
#: Most elements one expansion evaluates (macro bodies and blocks included); xacro's minidom
#: inserts each expanded element by a linear search among its siblings, so time grows with the
#: square of the count: 50 000 took 3 s, 20 000 take about a second (the test minirov, 15 links,
#: evaluates 423; a vehicle of 128 links a few thousand).
MAX_EXPANDED_ELEMENTS = 20_000
#: Most macro calls one expansion makes (the test minirov makes 21, a vehicle of 128 links a few
#: hundred; xacro takes 0.2-0.4 ms a call: 5000 calls of a doubling macro took 1.4-2.2 s).
MAX_MACRO_CALLS = 2_000
#: Most files one expansion reads (the top file and its includes).
MAX_XACRO_FILES = 1000
#: Deepest nesting of ``<xacro:include>`` (a file including itself stops here).
MAX_INCLUDE_DEPTH = 32
#: Largest total of the files one expansion reads [bytes].
MAX_XACRO_TOTAL_BYTES = 50_000_000
#: Longest expansion [s]; a backstop: the counts above stop hostile files well before it.
MAX_EXPANSION_SECONDS = 10.0


def is_xacro(path: str | os.PathLike) -> bool:
    """Whether ``path`` names a xacro file (by its suffix)."""
    return Path(path).suffix.lower() in XACRO_SUFFIXES


#: Longest message of xacro's own errors we pass on [characters] (they quote whole expressions).
MAX_MESSAGE_CHARACTERS = 200


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split())
    if len(text) > MAX_MESSAGE_CHARACTERS:
        text = text[: MAX_MESSAGE_CHARACTERS - 3] + "..."
    return text or error.__class__.__name__


class _Budget:
    """What one expansion has used so far, against the limits above."""

    def __init__(self, path: Path):
        self.path = path
        self.files = 0
        self.bytes = 0
        self.elements = 0
        self.characters = 0
        self.macro_calls = 0
        self.deadline = time.monotonic() + MAX_EXPANSION_SECONDS

    def charge(self, elements: int, characters: int) -> None:
        self.elements += elements
        self.characters += characters
        if self.elements > MAX_EXPANDED_ELEMENTS:
            raise InputLimitError(
                f"{self.path}: xacro expansion exceeds {MAX_EXPANDED_ELEMENTS} elements "
                "(macros that multiply?), not a vehicle"
            )
        if self.characters > MAX_EXPANDED_CHARACTERS:
            raise InputLimitError(
                f"{self.path}: xacro expansion exceeds {MAX_EXPANDED_CHARACTERS} characters, "
                "not a vehicle"
            )
        if time.monotonic() > self.deadline:
            raise InputLimitError(
                f"{self.path}: xacro expansion ran longer than {MAX_EXPANSION_SECONDS} s, "
                "not a vehicle"
            )

    def call(self) -> None:
        self.macro_calls += 1
        if self.macro_calls > MAX_MACRO_CALLS:
            raise InputLimitError(
                f"{self.path}: more than {MAX_MACRO_CALLS} xacro macro calls (macros that "
                "multiply?), not a vehicle"
            )

    def read(self, name: str) -> bytes:
        """The bytes of one file xacro reads (the top file or an include), within the limits."""
        self.files += 1
        if self.files > MAX_XACRO_FILES:
            raise InputLimitError(f"{self.path}: more than {MAX_XACRO_FILES} xacro files read")
        data = read_bytes(name, "xacro file")  # regular files only, at most MAX_FILE_BYTES
        self.bytes += len(data)
        if self.bytes > MAX_XACRO_TOTAL_BYTES:
            raise InputLimitError(
                f"{self.path}: xacro files together larger than {MAX_XACRO_TOTAL_BYTES} bytes"
            )
        return data


def _shown(expression: str) -> str:
    text = " ".join(expression.split())
    return text if len(text) <= 80 else text[:77] + "..."


@contextlib.contextmanager
def _patched_xacro(search_path: Sequence[Path], path: Path, trust: bool) -> Iterator[object]:
    """The xacro module with ``$(find)`` on our search path, limited file reads and expansion, and
    (unless ``trust``) the safe evaluator; everything restored afterwards."""
    try:
        import xacro
        from xacro import substitution_args
    except ImportError:
        raise VehicleLoadError(
            "reading .xacro files needs the xacro package (pip install xacro)"
        ) from None
    import defusedxml
    from defusedxml.ElementTree import fromstring as safe_fromstring

    budget = _Budget(path)

    def find(package: str) -> str:
        folder = find_package(package, search_path)
        if folder is None:
            raise VehicleLoadError(
                f"$(find {package}): package not found (give --package-path DIR or set "
                "ROS_PACKAGE_PATH)"
            )
        return str(folder)

    original = {
        "parse": xacro.parse,
        "eval_all": xacro.eval_all,
        "eval_text": xacro.eval_text,
        "handle_macro_call": xacro.handle_macro_call,
        "safe_eval": xacro.safe_eval,
        "_global_symbols": xacro._global_symbols,
    }
    original_substitution = {
        "_eval_find": substitution_args._eval_find,
        "_eval": substitution_args._eval,
    }
    saved_find = substitution_args._eval_dict.get("find")

    def checked_parse(inp, filename=None):
        if inp is None and filename is not None:
            name = os.path.join(getattr(xacro, "root_dir", os.curdir), filename)
            if len(xacro.filestack) > MAX_INCLUDE_DEPTH:
                raise InputLimitError(
                    f"{filename}: xacro includes nested deeper than {MAX_INCLUDE_DEPTH} levels "
                    "(a file including itself?)"
                )
            if not os.path.lexists(name):
                return original["parse"](inp, filename)  # xacro's own error (optional includes)
            data = budget.read(name)
            try:
                safe_fromstring(data, forbid_dtd=True)
            except defusedxml.DefusedXmlException:
                raise VehicleLoadError(f"{filename}: refused: XML with a DTD/entities") from None
            except Exception as exc:  # not well-formed: say so with the file's name
                raise VehicleLoadError(
                    f"{filename}: not well-formed XML: {_one_line(exc)}"
                ) from None
            inp = io.BytesIO(data)  # minidom reads it as xacro would have read the file
        return original["parse"](inp, filename)

    def counted_eval_all(node, macros, symbols):
        characters = 0
        if node.attributes:
            characters += sum(len(value) for _, value in node.attributes.items())
        for child in node.childNodes:
            if child.nodeType != child.ELEMENT_NODE:
                characters += len(getattr(child, "data", "") or "")
        budget.charge(1, characters)
        return original["eval_all"](node, macros, symbols)

    def counted_eval_text(text, symbols):
        result = original["eval_text"](text, symbols)
        if isinstance(result, str) and "$" in text:
            budget.charge(0, len(result))
        return result

    def counted_macro_call(node, macros, symbols):
        if node.tagName.startswith("xacro:"):  # every other xacro tag was handled before
            budget.call()
        return original["handle_macro_call"](node, macros, symbols)

    evaluator = SafeXacroEvaluator(namespace_type=xacro.NameSpace)

    def refused(expression: str, exc: UnsafeXacroExpression) -> UnsafeXacroExpression:
        where = xacro.filestack[-1] if xacro.filestack and xacro.filestack[-1] else path
        return UnsafeXacroExpression(
            f"{where}: xacro expression '{_shown(expression)}' refused: {exc} (the safe evaluator "
            "takes arithmetic, comparisons and math functions on properties; expand a file you "
            "trust with full xacro with --trust-xacro)"
        )

    def safe_eval(expression, symbols, locals=None):
        try:
            return evaluator.evaluate(expression, symbols)
        except UnsafeXacroExpression as exc:
            raise refused(expression, exc) from None

    def safe_substitution_eval(expression, context):
        arguments = context.get("arg", {})

        def argument(name):
            return substitution_args.convert_value(
                substitution_args._eval_arg(name, args=arguments), "auto"
            )

        names = {"true": True, "false": False, **SAFE_CONSTANTS}
        names.update(
            (key, substitution_args.convert_value(str(value), "auto"))
            for key, value in arguments.items()
        )
        evaluator.functions["arg"] = argument
        try:
            return str(evaluator.evaluate(expression, names))
        except UnsafeXacroExpression as exc:
            raise refused(f"$(eval {expression})", exc) from None
        finally:
            del evaluator.functions["arg"]

    substitution_args._eval_find = find
    substitution_args._eval_dict["find"] = find
    xacro.parse = checked_parse
    xacro.eval_all = counted_eval_all
    xacro.eval_text = counted_eval_text
    xacro.handle_macro_call = counted_macro_call
    if not trust:
        xacro.safe_eval = safe_eval
        xacro._global_symbols = dict(SAFE_CONSTANTS)
        substitution_args._eval = safe_substitution_eval
    try:
        yield xacro
    finally:
        for name, value in original.items():
            setattr(xacro, name, value)
        for name, value in original_substitution.items():
            setattr(substitution_args, name, value)
        substitution_args._eval_dict["find"] = saved_find


def expand_xacro(
    path: str | os.PathLike,
    xacro_args: Mapping[str, str] | None = None,
    package_path: Sequence[str | os.PathLike] = (),
    *,
    trust: bool = False,
) -> str:
    """The URDF text a xacro file expands to.

    Args:
        path: The ``.xacro`` file.
        xacro_args: ``$(arg NAME)`` values.
        package_path: Folders searched for packages first (then ``ROS_PACKAGE_PATH``,
            example-robot-data).
        trust: Evaluate expressions with xacro's Python ``eval`` (only for a file you trust: it
            can run code); by default the safe evaluator of :mod:`aiauv_pin.description.xacro_safe_eval`.

    Raises:
        VehicleLoadError: The xacro package is missing, or the file does not expand (missing
            file, unknown macro or argument, package not found, unsafe XML, an expression the
            safe evaluator refuses, ...); one line.
        InputLimitError: A file or the expansion beyond the limits of this module.
    """
    path = Path(path)
    if not os.path.lexists(path):
        raise VehicleLoadError(f"{path}: no such file")
    search_path = package_search_path(package_path)
    mappings = {str(k): str(v) for k, v in (xacro_args or {}).items()}
    with _patched_xacro(search_path, path, trust) as xacro:
        try:
            document = xacro.process_file(str(path), mappings=mappings)
        except VehicleLoadError:
            raise
        except RecursionError:
            raise InputLimitError(
                f"{path}: xacro macros or properties nested too deeply (recursive?)"
            ) from None
        except Exception as exc:  # xacro raises XacroException, ArgException, NameError, ...
            cause = getattr(exc, "exc", None)  # XacroException wraps the original error
            while getattr(cause, "exc", None) is not None:  # (lazy properties wrap it again)
                cause = cause.exc
            if isinstance(cause, (UnsafeXacroExpression, InputLimitError)):  # name their file
                raise cause from None
            if isinstance(cause, VehicleLoadError):  # ours, from $(find) or the safety check
                raise VehicleLoadError(f"{path}: {cause}") from None
            if isinstance(cause, RecursionError):
                raise InputLimitError(
                    f"{path}: xacro macros or properties nested too deeply (recursive?)"
                ) from None
            if "ArgException" in (exc.__class__.__name__, cause.__class__.__name__):
                name = cause if cause is not None else exc
                message = f"undefined xacro argument '{name}' (give --arg {name}=VALUE)"
            else:
                message = _one_line(exc)
            raise VehicleLoadError(f"{path}: xacro: {message}") from None
    text = document.toxml()
    if len(text) > MAX_EXPANDED_CHARACTERS:
        raise VehicleLoadError(
            f"{path}: expands to more than {MAX_EXPANDED_CHARACTERS} characters, not a vehicle"
        )
    return text


def read_description(
    path: str | os.PathLike,
    xacro_args: Mapping[str, str] | None = None,
    package_path: Sequence[str | os.PathLike] = (),
    *,
    trust_xacro: bool = False,
) -> str | None:
    """URDF text of a ``.xacro`` file, or ``None`` for any other file (read it as a URDF).

    ``trust_xacro`` expands with full xacro (Python ``eval``); see :func:`expand_xacro`.

    Raises:
        VehicleLoadError: As :func:`expand_xacro`; also when xacro arguments are given for a file
            that is not a xacro file.
    """
    if is_xacro(path):
        return expand_xacro(path, xacro_args, package_path, trust=trust_xacro)
    if xacro_args:
        raise VehicleLoadError(f"{path}: --arg is only for .xacro files")
    return None
