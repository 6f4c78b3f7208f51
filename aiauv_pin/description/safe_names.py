"""The character set of names (robot, links, joints, thrusters), checked when a vehicle is loaded.

Names end up in CSV headers (``q_<joint>``, ``thrust_<thruster>``), in ``aiauv check``'s table and in
error messages. A comma or a newline in a name would break or forge CSV rows, and a newline would let
a file print a line of its choosing (``aiauv: error: ...``) into the terminal. So every name must match
:data:`NAME_PATTERN`:

* 1 to :data:`MAX_NAME_LENGTH` characters;
* ASCII letters, digits, ``_``, ``-``, ``.`` and ``/`` (ROS-style prefixes such as ``rexrov/base_link``);
* starting with a letter, a digit or ``_``.

A name outside it is refused with :class:`aiauv_pin.errors.UnsafeNameError`, whose message shows the
name with :func:`repr` (so the message itself stays one printable line).
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from aiauv_pin.errors import UnsafeNameError

#: Longest name accepted.
MAX_NAME_LENGTH = 128
#: Safe names (see the module docstring).
NAME_PATTERN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-/]{0,127}")


def shown(name: object, limit: int = 60) -> str:
    """``repr`` of a name, cut to ``limit`` characters: safe to print on one line."""
    text = repr(name)
    return text if len(text) <= limit else text[: limit - 4] + "...'"


def is_safe_name(name: object) -> bool:
    """Whether ``name`` is a string matching :data:`NAME_PATTERN`."""
    return isinstance(name, str) and NAME_PATTERN.fullmatch(name) is not None


def check_name(name: object, what: str) -> str:
    """Return ``name`` if it is safe.

    Raises:
        UnsafeNameError: One line: what it names, the name (``repr``) and the allowed set.
    """
    if not is_safe_name(name):
        raise UnsafeNameError(
            f"{what} name {shown(name)} is not allowed: names are 1-{MAX_NAME_LENGTH} characters "
            "of letters, digits, '_', '-', '.', '/' starting with a letter, digit or '_'"
        )
    return name


def check_names(names: Iterable[tuple[str, object]]) -> None:
    """:func:`check_name` over ``(what, name)`` pairs."""
    for what, name in names:
        check_name(name, what)
