"""Limits on input files, enforced before any parser sees them.

Every file the toolkit reads on a user's behalf (URDF, vehicle spec, sweep spec) goes through
:func:`read_text`, and every URDF text through :func:`check_xml_text` before any XML tree is built
and before Pinocchio's parser
(urdfdom, which is slow on pathological input: 83 s for 200 000 attributes on one element) runs:

* only **regular files** are read: a FIFO (which would block forever), a device node (``/dev/zero``,
  which never ends), a socket or a directory is refused without being opened for reading (the
  file is opened with ``O_NONBLOCK`` and checked with ``fstat`` on the opened descriptor, so a
  path swapped between check and open cannot slip through);
* at most :data:`MAX_FILE_BYTES` bytes are read; the cap is enforced while reading (a file that
  grows while read is cut off and refused, not read to the end);
* the text must be UTF-8;
* a URDF tree may have at most :data:`MAX_XML_ELEMENTS` elements, :data:`MAX_XML_ATTRIBUTES`
  attributes on any one element and :data:`MAX_LINKS` ``<link>`` elements under ``<robot>`` (a
  1000-module vehicle is refused here, with one line, instead of running the machine out of memory:
  Pinocchio's model data alone grows faster than the square of the number of bodies).

Each violation raises :class:`aiauv_pin.errors.InputLimitError` with one line naming the file and
the limit; each check takes well under a second at the limits.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from xml.parsers import expat

from aiauv_pin.errors import InputLimitError, VehicleLoadError

#: Largest input file read [bytes] (the bundled URDF is 20 kB; a detailed vehicle a few hundred kB).
MAX_FILE_BYTES = 10_000_000
#: Most XML elements in one URDF.
MAX_XML_ELEMENTS = 200_000
#: Most attributes on one XML element (URDF elements have at most 8).
MAX_XML_ATTRIBUTES = 64
#: Most ``<link>`` elements in one URDF (and modules in one vehicle spec, minus the end effector).
#: Pinocchio's ``Data`` grows faster than the square of the number of bodies (a vehicle holds two:
#: 200 links take 1.5 GB and 5 s to set up, 511 links 13 GB and a minute); 128 links stay below
#: 0.5 GB.
MAX_LINKS = 128

_READ_CHUNK = 1 << 20


def looks_like_xml_text(value: object) -> bool:
    """Whether a "path" is in fact XML or TOML-like text (starts with ``<``, or has tags and lines)."""
    if not isinstance(value, str):
        return False
    return value.lstrip().startswith("<") or ("<" in value and ">" in value and "\n" in value)


def read_bytes(path: str | os.PathLike, what: str = "file", limit: int = MAX_FILE_BYTES) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes.

    Raises:
        VehicleLoadError: Missing or unreadable file (one line).
        InputLimitError: Not a regular file, or larger than ``limit``.
    """
    if looks_like_xml_text(path):
        raise VehicleLoadError(
            f"got {what} text where a file path was expected (pass the path of the file)"
        )
    shown = str(path)
    if len(shown) > 200:
        shown = shown[:197] + "..."
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise VehicleLoadError(f"{shown}: no such file") from None
    except IsADirectoryError:
        raise VehicleLoadError(f"{shown}: is a directory, not a {what}") from None
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise VehicleLoadError(f"{shown}: file name too long") from None
        reason = exc.strerror or exc.__class__.__name__
        raise VehicleLoadError(f"{shown}: cannot open ({reason})") from None
    except (TypeError, ValueError) as exc:
        raise VehicleLoadError(f"not a valid file path ({exc.__class__.__name__})") from None
    try:
        info = os.fstat(descriptor)
        if stat.S_ISDIR(info.st_mode):
            raise VehicleLoadError(f"{shown}: is a directory, not a {what}")
        if not stat.S_ISREG(info.st_mode):
            raise InputLimitError(
                f"{shown}: not a regular file (FIFO, device or socket); only regular files are read"
            )
        if info.st_size > limit:
            raise InputLimitError(f"{shown}: larger than {limit} bytes, not a {what}")
        os.set_blocking(descriptor, True)
        chunks: list[bytes] = []
        size = 0
        while True:
            chunk = os.read(descriptor, min(_READ_CHUNK, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
            if size > limit:
                raise InputLimitError(f"{shown}: larger than {limit} bytes, not a {what}")
        return b"".join(chunks)
    except OSError as exc:
        reason = exc.strerror or exc.__class__.__name__
        raise VehicleLoadError(f"{shown}: cannot read ({reason})") from None
    finally:
        os.close(descriptor)


def read_text(path: str | os.PathLike, what: str = "file", limit: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes (a leading BOM removed).

    Raises:
        VehicleLoadError: Missing, unreadable or not UTF-8 (one line).
        InputLimitError: Not a regular file, or too large.
    """
    data = read_bytes(path, what, limit)
    try:
        return data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError:
        raise VehicleLoadError(f"{Path(path)}: not a text file (not UTF-8), not a {what}") from None


class _StopScan(Exception):
    """Ends :func:`check_xml_text`'s scan early (a DTD: the real parser refuses it in one line)."""


def check_xml_text(text: str, where: str) -> None:
    """Refuse XML text beyond :data:`MAX_XML_ELEMENTS`, :data:`MAX_XML_ATTRIBUTES` or
    :data:`MAX_LINKS`, counting while expat scans it, before any tree is built.

    Building the tree first cost 3.4 s for 250 000 empty elements (Python-level callbacks of
    ``ElementTree``'s builder per element); this scan stops at the first element over a limit. It
    does not judge well-formedness or DTDs: at the first XML error or DTD it stops, and the safe
    parser (:func:`aiauv_hydro.urdf.xml_reading.parse_robot_text`) reports the problem in one line.

    Raises:
        InputLimitError: One line naming the limit.
    """
    parser = expat.ParserCreate()
    count = 0
    depth = 0
    links = 0

    def start(tag: str, attributes: dict) -> None:
        nonlocal count, depth, links
        count += 1
        if count > MAX_XML_ELEMENTS:
            raise InputLimitError(f"{where}: more than {MAX_XML_ELEMENTS} XML elements")
        if len(attributes) > MAX_XML_ATTRIBUTES:
            raise InputLimitError(
                f"{where}: an element <{tag[:40]}> has {len(attributes)} "
                f"attributes (at most {MAX_XML_ATTRIBUTES})"
            )
        if depth == 1 and tag == "link":
            links += 1
        depth += 1

    def end(tag: str) -> None:
        nonlocal depth
        depth -= 1

    def doctype(*_) -> None:
        raise _StopScan

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = doctype
    try:
        parser.Parse(text, True)
    except (_StopScan, expat.ExpatError):
        return
    if links > MAX_LINKS:
        raise InputLimitError(f"{where}: {links} links, more than the {MAX_LINKS} supported")
