"""Expanding ``.xacro`` vehicle descriptions without ROS (the ``xacro`` package from PyPI).

``$(find pkg)`` resolves through the package search path of :mod:`aiauv_pin.ros_packages`
(``--package-path`` folders, ``ROS_PACKAGE_PATH``, example-robot-data) instead of ROS 2's ament
index, which the PyPI package would otherwise need. ``$(arg NAME)`` takes the values given as
``xacro_args`` (``--arg NAME=VALUE``), else the ``<xacro:arg default>``.

Every file xacro reads (the top file and each ``<xacro:include>``) is first parsed by defusedxml
with DTDs forbidden, so an entity-expansion document is refused before xacro's own (minidom)
parser sees it, as for plain URDFs. Any xacro failure becomes one :class:`VehicleLoadError` line.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

from .errors import VehicleLoadError
from .ros_packages import find_package, package_search_path

#: File suffixes expanded with xacro (``robot.urdf.xacro`` ends in ``.xacro`` too).
XACRO_SUFFIXES = (".xacro",)
#: Largest expanded description accepted [characters] (as plain URDFs: 50 MB).
MAX_EXPANDED_CHARACTERS = 50_000_000


def is_xacro(path: str | os.PathLike) -> bool:
    """Whether ``path`` names a xacro file (by its suffix)."""
    return Path(path).suffix.lower() in XACRO_SUFFIXES


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split())
    return text or error.__class__.__name__


@contextlib.contextmanager
def _patched_xacro(search_path: Sequence[Path]) -> Iterator[object]:
    """The xacro module with ``$(find)`` on our search path and safe file parsing, then restored."""
    try:
        import xacro
        from xacro import substitution_args
    except ImportError:
        raise VehicleLoadError(
            "reading .xacro files needs the xacro package (pip install xacro)"
        ) from None
    import defusedxml
    from defusedxml.ElementTree import parse as safe_parse

    def find(package: str) -> str:
        folder = find_package(package, search_path)
        if folder is None:
            raise VehicleLoadError(
                f"$(find {package}): package not found (give --package-path DIR or set "
                "ROS_PACKAGE_PATH)"
            )
        return str(folder)

    original_parse = xacro.parse

    def checked_parse(inp, filename=None):
        if inp is None and filename is not None:
            name = os.path.join(getattr(xacro, "root_dir", os.curdir), filename)
            try:
                safe_parse(name, forbid_dtd=True)
            except defusedxml.DefusedXmlException:
                raise VehicleLoadError(f"{filename}: refused: XML with a DTD/entities") from None
            except OSError:
                pass  # xacro reports a missing file itself
            except Exception as exc:  # not well-formed: say so with the file's name
                raise VehicleLoadError(
                    f"{filename}: not well-formed XML: {_one_line(exc)}"
                ) from None
        return original_parse(inp, filename)

    saved = (substitution_args._eval_find, substitution_args._eval_dict.get("find"))
    substitution_args._eval_find = find
    substitution_args._eval_dict["find"] = find
    xacro.parse = checked_parse
    try:
        yield xacro
    finally:
        substitution_args._eval_find, substitution_args._eval_dict["find"] = saved
        xacro.parse = original_parse


def expand_xacro(
    path: str | os.PathLike,
    xacro_args: Mapping[str, str] | None = None,
    package_path: Sequence[str | os.PathLike] = (),
) -> str:
    """The URDF text a xacro file expands to.

    Args:
        path: The ``.xacro`` file.
        xacro_args: ``$(arg NAME)`` values.
        package_path: Folders searched for packages first (then ``ROS_PACKAGE_PATH``,
            example-robot-data).

    Raises:
        VehicleLoadError: The xacro package is missing, or the file does not expand (missing
            file, unknown macro or argument, package not found, unsafe XML, ...); one line.
    """
    path = Path(path)
    if not path.is_file():
        raise VehicleLoadError(f"{path}: no such file")
    search_path = package_search_path(package_path)
    mappings = {str(k): str(v) for k, v in (xacro_args or {}).items()}
    with _patched_xacro(search_path) as xacro:
        try:
            document = xacro.process_file(str(path), mappings=mappings)
        except VehicleLoadError:
            raise
        except Exception as exc:  # xacro raises XacroException, ArgException, NameError, ...
            cause = getattr(exc, "exc", None)  # XacroException wraps the original error
            if isinstance(cause, VehicleLoadError):  # ours, from $(find) or the safety check
                raise VehicleLoadError(f"{path}: {cause}") from None
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
) -> str | None:
    """URDF text of a ``.xacro`` file, or ``None`` for any other file (read it as a URDF).

    Raises:
        VehicleLoadError: As :func:`expand_xacro`; also when xacro arguments are given for a file
            that is not a xacro file.
    """
    if is_xacro(path):
        return expand_xacro(path, xacro_args, package_path)
    if xacro_args:
        raise VehicleLoadError(f"{path}: --arg is only for .xacro files")
    return None
