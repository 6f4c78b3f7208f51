"""Generic machinery of the file schemas (pydantic v2, strict): typed numbers, keys, errors.

Knows no vehicle and no scenario. The file models are declared with it in
:mod:`aiauv_pin.builders.vehicle_spec_schema` (vehicle specs) and
:mod:`aiauv_pin.scenario.file_schemas` (scenario
files; sweep specs in :mod:`aiauv_pin.scenario.sweep_spec`). Validation is strict: a bool is not a number, a
string is not a number, an unknown key is an error (``extra="forbid"``), a number outside its
plausible range is an error.

:func:`one_line` turns pydantic's :class:`~pydantic.ValidationError` into one line naming the key
path and what is expected (``controller.k_d: expected a number in (0, 10000] (bool is not a
number), got True``), computed from the JSON Schema that ``aiauv schema`` prints, so the message
and the schema cannot disagree.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Annotated, Any, Optional, get_args

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from pydantic.json_schema import GenerateJsonSchema

#: The JSON Schema dialect pydantic emits.
DIALECT = "https://json-schema.org/draft/2020-12/schema"
#: Pattern of a name (links, joints, thrusters): letters, digits, ``_``, ``-``, ``.``.
NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_.\-]*$"
#: A name of :data:`NAME_PATTERN`.
Name = Annotated[str, Field(pattern=NAME_PATTERN, max_length=200)]


def strict_config(title: str | None = None) -> ConfigDict:
    """The configuration of every file model: strict, no unknown key, no inf/nan, frozen."""
    return ConfigDict(strict=True, extra="forbid", allow_inf_nan=False, frozen=True, title=title)


# --------------------------------------------------------------------------------------------------
# Typed numbers with their ranges


@dataclass(frozen=True)
class Bounds:
    """Plausible range of a number: ``[low, high]``, either end open."""

    low: float
    high: float
    low_open: bool = False
    high_open: bool = False

    def text(self) -> str:
        """``[0, 10]``, ``(0, 1e4]``, ... as the documentation and the messages print it."""
        return (
            f"{'(' if self.low_open else '['}{number_text(self.low)}, "
            f"{number_text(self.high)}{')' if self.high_open else ']'}"
        )


def number_text(x: float) -> str:
    """A bound as the messages print it: ``pi``, ``1e4``, ``0.5``."""
    if x == math.pi:
        return "pi"
    if x != 0.0 and math.isfinite(x) and not 1.0e-3 <= abs(x) < 1.0e4:
        mantissa, exponent = f"{x:e}".split("e")
        return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"
    return f"{x:g}"


def number(low: float, high: float, *, low_open: bool = False, high_open: bool = False):
    """A finite number in a range (an ``int`` is accepted, a ``bool`` or a string is not)."""
    bounds = Bounds(low, high, low_open, high_open)
    limits = {"gt" if low_open else "ge": low, "lt" if high_open else "le": high}
    return Annotated[float, Field(**limits), bounds]


def vector(low: float, high: float, length: int = 3):
    """A list of ``length`` numbers, each in ``[low, high]``."""
    return Annotated[list[number(low, high)], Field(min_length=length, max_length=length)]


def bounds_of(annotation) -> Bounds | None:
    for item in getattr(annotation, "__metadata__", ()):
        if isinstance(item, Bounds):
            return item
    for arg in get_args(annotation):
        found = bounds_of(arg)
        if found is not None:
            return found
    return None


def key(annotation, unit: str, meaning: str, default: Any = None, **extra):
    """The type of a key: ``annotation`` (optional when ``default`` is ``None``) with its meaning,
    unit in brackets and range in the description (``...`` as ``default``: required)."""
    bounds = bounds_of(annotation)
    each = "each " if str(annotation).startswith("typing.Annotated[list[") else ""
    where = f", {each}in {bounds.text()}" if bounds else ""
    info = Field(
        default, description=f"{meaning} [{unit}]{where}", json_schema_extra={"unit": unit}, **extra
    )
    return Annotated[Optional[annotation] if default is None else annotation, info]  # noqa: UP045


#: A direction (normalised by its reader); the bound keeps its square from overflowing.
Direction = vector(-1.0e6, 1.0e6)


# --------------------------------------------------------------------------------------------------
# JSON Schema


class _Generator(GenerateJsonSchema):
    """pydantic's JSON Schema, with optional keys shown as their type (TOML has no null)."""

    def nullable_schema(self, schema):
        return self.generate_inner(schema["schema"])

    def default_schema(self, schema):
        out = super().default_schema(schema)
        if out.get("default", 0) is None:
            del out["default"]
        return out


def json_schema(model: type[BaseModel]) -> dict:
    """The JSON Schema (draft 2020-12) of a file model."""
    out = model.model_json_schema(schema_generator=_Generator)
    return {"$schema": DIALECT, **out}


# --------------------------------------------------------------------------------------------------
# Errors: one line naming the key path and what is expected


def shown(value) -> str:
    """A value as a message shows it: its ``repr``, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _resolve(root: dict, node: dict) -> dict:
    while "$ref" in node:
        node = root["$defs"][node["$ref"].rsplit("/", 1)[1]]
    return node


def _variants(root: dict, node: dict) -> list[dict] | None:
    options = node.get("anyOf") or node.get("oneOf")
    if options is None:
        return None
    return [_resolve(root, v) for v in options if v.get("type") != "null"]


def _tag(node: dict) -> str | None:
    """The ``type`` of a table whose ``type`` key selects it (path and current tables)."""
    const = node.get("properties", {}).get("type", {}).get("const")
    return const if isinstance(const, str) else None


def describe(root: dict, node: dict) -> str:
    """What a JSON Schema node accepts, in words (``a number in [0, 10]``)."""
    node = _resolve(root, node)
    variants = _variants(root, node)
    if variants is not None:
        words = list(dict.fromkeys(describe(root, v) for v in variants))
        return " or ".join(words)
    if "const" in node:
        return repr(node["const"])
    if "enum" in node:
        return "one of " + ", ".join(str(v) for v in node["enum"])
    kind = node.get("type")
    if kind in ("number", "integer"):
        low = node.get("exclusiveMinimum", node.get("minimum"))
        high = node.get("exclusiveMaximum", node.get("maximum"))
        noun = "a number" if kind == "number" else "a whole number"
        if low is None and high is None:
            return noun
        bounds = Bounds(
            -math.inf if low is None else low,
            math.inf if high is None else high,
            "exclusiveMinimum" in node,
            "exclusiveMaximum" in node,
        )
        return f"{noun} in {bounds.text()}"
    if kind == "boolean":
        return "true or false"
    if kind == "string":
        if node.get("pattern") == NAME_PATTERN:
            return "a name of letters, digits, '_', '-', '.' (not starting with a digit)"
        return "a non-empty string" if node.get("minLength") else "a string"
    if kind == "array":
        low, high = node.get("minItems"), node.get("maxItems")
        item = describe(root, node.get("items", {})) if "items" in node else "a value"
        for one, many in _PLURALS:
            if item.startswith(one):
                item = many + item[len(one) :]
                break
        if item.startswith(("numbers in", "whole numbers in")):
            item = item.replace(" in ", ", each in ", 1)
        if low is not None and low == high:
            return f"a list of {low} {item}"
        if low is not None and high is not None:
            return f"a list of {low} to {high} {item}"
        if low == 1:
            return f"a non-empty list of {item}"
        if low:
            return f"a list of at least {low} {item}"
        return f"a list of {item}"
    if kind == "object":
        required = node.get("required", [])
        if len(node.get("properties", {})) == 1 and required:
            inner = describe(root, node["properties"][required[0]])
            return f"a table {{ {required[0]} = {inner} }}"
        return "a table"
    return "a value"


_PLURALS = (
    ("a list of", "lists of"),
    ("a number", "numbers"),
    ("a whole number", "whole numbers"),
    ("a table", "tables"),
    ("a string", "strings"),
    ("a name", "names"),
    ("a non-empty string", "non-empty strings"),
    ("a value", "values"),
    ("one of", "values, each one of"),
)


@dataclass
class _Place:
    key: str  # the key path as the file writes it
    node: dict | None  # schema where the walk stopped (None: a key the schema does not have)
    parent: dict | None  # the table schema holding the last key
    value: Any  # the input there
    complete: bool  # every part of the location walked


def _walk(root: dict, loc: tuple, data: Any) -> _Place:
    node: dict | None = root
    parent: dict | None = None
    key, value, index = "", data, 0
    while index < len(loc):
        part = loc[index]
        node = _resolve(root, node)
        variants = _variants(root, node)
        if variants is not None:
            if len(variants) == 1:
                node = variants[0]
                continue
            match = next((v for v in variants if v.get("title") == part), None)
            if match is None:  # a label of an untagged union: the value matched no member
                return _Place(key, node, parent, value, False)
            node = match
            if _tag(match) == part:
                key += f".{part}"
            index += 1
            continue
        if isinstance(part, int):
            item = value[part] if isinstance(value, list) and part < len(value) else None
            name = item.get("name") if isinstance(item, Mapping) else None
            named = isinstance(name, str) and re.fullmatch(NAME_PATTERN, name)
            key += f" '{name}'" if named else f"[{part}]"
            prefix = node.get("prefixItems")
            node = prefix[part] if prefix and part < len(prefix) else node.get("items", {})
            value = item
        else:
            parent = node
            key = f"{key}.{part}" if key else str(part)
            properties = node.get("properties", {})
            if part in properties:
                node = properties[part]
            elif isinstance(node.get("additionalProperties"), dict):
                node = node["additionalProperties"]
            else:
                return _Place(key, None, parent, None, index == len(loc) - 1)
            value = value.get(part) if isinstance(value, Mapping) else None
        index += 1
    return _Place(key, node, parent, value, True)


def problem_line(problem: Mapping, root: dict, data: Any, what: str) -> str:
    """One pydantic error (an item of ``ValidationError.errors()``) as one line."""
    kind = problem["type"]
    place = _walk(root, tuple(problem["loc"]), data)
    where = place.key or what
    if kind == "extra_forbidden":
        known = list((place.parent or {}).get("properties", {}))
        if len(known) <= 30:
            return f"{where}: unknown key (expected {', '.join(known)})"
        kind = what.split()[0]
        return f"{where}: unknown key ({len(known)} keys known: `aiauv schema {kind}` lists them)"
    if kind == "missing":
        return f"{where}: missing"
    if kind in ("value_error", "assertion_error"):
        message = str(problem.get("ctx", {}).get("error", problem["msg"]))
        return f"{place.key}: {message}" if place.key else message
    node = place.node or {}
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tags = [_tag(v) for v in _variants(root, _resolve(root, node)) or []]
        if tags and all(tags):
            got = problem.get("ctx", {}).get("tag")
            found = "missing" if got is None else f"got {shown(got)}"
            return f"{where}.type: expected one of {', '.join(tags)}, {found}"
    value = place.value if not place.complete else problem.get("input")
    if kind in ("too_short", "too_long") and place.complete and isinstance(value, list):
        got = f"{len(value)} {'entry' if len(value) == 1 else 'entries'}"
    else:
        got = shown(value)
    note = ""
    if isinstance(value, bool) and "number" in describe(root, node):
        note = " (a bool is not a number)"
    return f"{where}: expected {describe(root, node)}{note}, got {got}"


def one_line(error: ValidationError, root: dict, data: Any, what: str) -> str:
    """The first problem of a validation error as one line (and how many more there are)."""
    problems = error.errors(include_url=False)
    problems.sort(key=lambda p: p["type"] != "extra_forbidden")  # a misspelt key first
    lines = list(dict.fromkeys(problem_line(p, root, data, what) for p in problems))
    more = len(lines) - 1
    suffix = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
    return " ".join((lines[0] + suffix).split())


@cache
def _schema_of(model: type[BaseModel]) -> str:
    return json.dumps(json_schema(model))


def validate(model: type[BaseModel], data: Any, error: type[Exception], what: str) -> BaseModel:
    """``model.model_validate(data)``, a failure raised as ``error`` with one line.

    Args:
        model: A file model (:class:`ScenarioFile`, :class:`VehicleSpecFile`, a sweep model).
        data: The parsed file (nested tables).
        error: The project's error type to raise.
        what: What the file is, for a problem at its top level (``scenario``).
    """
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        root = json.loads(_schema_of(model))
        raise error(one_line(exc, root, data, what)) from None


def given(table: BaseModel | None) -> dict:
    """The keys a table gives (not ``None``), as plain Python values."""
    if table is None:
        return {}
    return {
        name: getattr(table, name)
        for name in table.model_fields_set
        if getattr(table, name) is not None
    }
