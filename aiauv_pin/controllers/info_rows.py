"""Where each field of a compiled controller's info row starts, from its one declaration.

A compiled controller logs its diagnostics into one row of floats laid out as its ``info_shapes``
declare (name -> shape, in order: :class:`aiauv_pin.controllers.compiled_controller.CompiledController`).
A built-in controller writes each field at the offset :func:`info_offsets` computes from that
declaration, held in a record of offsets named after the fields (``PaperInfo.phi_tilde``), which
travels with its parameters into the compiled loop: the layout is written once, in the
declaration, and the record is checked against it when it is built and before every run.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import TypeVar

from aiauv_pin.errors import ArgumentError

Offsets = TypeVar("Offsets", bound=tuple)


def field_spans(shapes: Mapping[str, tuple[int, ...]]) -> Iterator[tuple[str, int, int]]:
    """``(name, first float, number of floats)`` of each field of a row declared by ``shapes``,
    in order."""
    at = 0
    for name, shape in shapes.items():
        size = math.prod(shape)
        yield name, at, size
        at += size


def info_offsets(shapes: Mapping[str, tuple[int, ...]], record: type[Offsets]) -> Offsets:
    """The offsets of the fields declared by ``shapes`` as a ``record`` (a named tuple whose fields
    are the declared names, in the declared order).

    Raises:
        ArgumentError: ``record``'s fields are not the declared names in their order.
    """
    names = tuple(shapes)
    if names != record._fields:
        raise ArgumentError(
            f"{record.__name__} names the fields {record._fields} but the row declares {names}"
        )
    return record(*(at for _, at, _ in field_spans(shapes)))
