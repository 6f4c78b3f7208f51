"""The parameters of a scenario, named once for scenario files and sweep specs.

:data:`SCHEMA` lists every key a scenario file (:mod:`aiauv_pin.scenario.toml_file`) may hold, by its
dotted name (``duration``, ``start.position``, ``path.radius``, ``controller.k_d``), with its kind,
unit, plausible range and meaning. It is read off the pydantic model of scenario files
(:class:`aiauv_pin.scenario.file_schemas.ScenarioFile`), so the table, the JSON Schema (``aiauv schema
scenario``) and the checks are one declaration; the path and current keys are those of the path
and current tables (one per ``type``, the same keys as :data:`aiauv_control.paths.PATH_TYPES` and
:data:`aiauv_hydro.currents.CURRENT_KEYS`; ``tests/scenario/test_schemas.py`` checks that they agree).

Sweep specs (:mod:`aiauv_pin.scenario.sweep_spec`) use the same names: a scalar key is a sweep parameter as
it is (``path.radius``), a vector key either whole (``start.position = [x, y, z]``) or by component
(``start.position.y``; ``controller.k_e`` has components ``y`` and ``z``). The older sweep names
(``initial_offset.y``, ``initial_surge``, ``current.x``, ``k_e.y``, ``k_d``, ...) stay valid as
:data:`ALIASES` of these.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from typing import Any, Literal, NamedTuple

from pydantic import BaseModel

from aiauv_control.path_following import PathFollowingGains
from aiauv_pin._internal.schema_validation import bounds_of
from aiauv_pin.scenario.file_schemas import CURRENT_TABLES, METHODS, PATH_TABLES, ScenarioFile

__all__ = ["METHODS"]
#: Components of a vector in world axes.
XYZ = ("x", "y", "z")


class Parameter(NamedTuple):
    """One key of a scenario file.

    Attributes:
        name: Dotted name: ``key`` at the top level, ``table.key`` in a table.
        kind: ``"number"``, ``"bool"``, ``"file"``, ``"points"`` (a list of ``[x, y, z]``),
            ``("choice", options)`` or ``("vector", components)``.
        unit: SI unit of a number or of each component (``"-"``: none).
        meaning: What it is.
        applies_to: Path or current types the key belongs to (empty: always).
        sweepable: Whether a sweep spec may set it (the path and current ``type`` and the waypoint
            list come from the base scenario; outputs do not change a run's results).
        annotation: The key's type in the pydantic model (a value of the whole key).
        range: Plausible range of a number or of each component (``""``: none).
    """

    name: str
    kind: Any
    unit: str
    meaning: str
    applies_to: tuple[str, ...] = ()
    sweepable: bool = True
    annotation: Any = None
    range: str = ""

    @property
    def components(self) -> tuple[str, ...]:
        """Names of the components of a vector (``start.position.x``, ...); ``()`` otherwise."""
        if isinstance(self.kind, tuple) and self.kind[0] == "vector":
            return tuple(f"{self.name}.{c}" for c in self.kind[1])
        return ()

    @property
    def item(self) -> Any:
        """The type of one component of a vector (of the value itself for a scalar)."""
        if not self.components:
            return self.annotation
        for member in (self.annotation, *typing.get_args(self.annotation)):
            inner = typing.get_args(member)
            if inner and typing.get_origin(inner[0]) is list:
                return typing.get_args(inner[0])[0]
        return self.annotation


def _plain(annotation):
    """The annotation without ``| None``."""
    args = typing.get_args(annotation)
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        members = [a for a in args if a is not type(None)]
        if len(members) == 1:
            return members[0]
        return typing.Union[tuple(members)]  # noqa: UP007 - a runtime union of annotated types
    return annotation


def _kind(name: str, annotation) -> Any:
    text = str(annotation)
    if annotation is bool:
        return "bool"
    if typing.get_origin(annotation) is Literal:
        return ("choice", typing.get_args(annotation))
    if name == "controller.k_e":
        return ("vector", ("y", "z"))
    if text.startswith("typing.Annotated[list[typing.Annotated[list["):
        return "points"
    if text.startswith("typing.Annotated[list["):
        return ("vector", XYZ)
    if "str" in text and "float" not in text:
        return "file"
    return "number"


def _parameter(name: str, model: type[BaseModel], field: str, **options) -> Parameter:
    info = model.model_fields[field]
    unit = (info.json_schema_extra or {}).get("unit", "-")
    meaning = (info.description or "").rsplit(f" [{unit}]", 1)[0]
    annotation = _plain(info.rebuild_annotation())
    bounds = bounds_of(annotation)
    return Parameter(
        name,
        _kind(name, annotation),
        unit,
        meaning,
        annotation=annotation,
        range=bounds.text() if bounds else "",
        **options,
    )


def _table_keys(section: str, tables: dict[str, type[BaseModel]]) -> tuple[Parameter, ...]:
    """The keys of the path or current tables: each key once, with the types it applies to."""
    owners: dict[str, list[str]] = {}
    for type_name, model in tables.items():
        for field in model.model_fields:
            owners.setdefault(field, []).append(type_name)
    out = []
    for field, owned in owners.items():
        model = tables[owned[0]]
        applies = () if len(owned) == len(tables) or field == "type" else tuple(owned)
        parameter = _parameter(f"{section}.{field}", model, field, applies_to=applies)
        if field == "type":
            parameter = parameter._replace(kind=("choice", tuple(tables)), sweepable=False)
        elif parameter.kind == "points":
            parameter = parameter._replace(sweepable=False)
        out.append(parameter)
    return tuple(out)


def _schema() -> dict[str, Parameter]:
    out: list[Parameter] = []
    tables = {"path": PATH_TABLES, "current": CURRENT_TABLES}
    for name, info in ScenarioFile.model_fields.items():
        if name in tables:
            out.extend(_table_keys(name, tables[name]))
            continue
        annotation = _plain(info.annotation)
        if isinstance(annotation, type) and issubclass(annotation, BaseModel):
            for field in annotation.model_fields:
                sweepable = name not in ("output", "station", "velocity", "torpedo")
                out.append(_parameter(f"{name}.{field}", annotation, field, sweepable=sweepable))
            continue
        sweepable = name not in ("added_mass", "lagged_filter")
        out.append(_parameter(name, ScenarioFile, name, sweepable=sweepable))
    return {p.name: p for p in out}


#: Every key of a scenario file, in the order of the documentation.
SCHEMA: dict[str, Parameter] = _schema()

#: Keys of a scenario file's top level.
TOP_LEVEL: tuple[str, ...] = tuple(name for name in SCHEMA if "." not in name)
#: Tables of a scenario file and their keys (``None``: checked by the path or current reader).
TABLES: dict[str, tuple[str, ...] | None] = {
    "start": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("start.")),
    "path": None,
    "current": None,
    "controller": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("controller.")),
    "gait": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("gait.")),
    "station": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("station.")),
    "velocity": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("velocity.")),
    "waves": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("waves.")),
    "intervention": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("intervention.")),
    "torpedo": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("torpedo.")),
    "output": tuple(n.split(".", 1)[1] for n in SCHEMA if n.startswith("output.")),
}

#: Older sweep-spec names and the scenario names they stand for (a vector alias: its components).
ALIASES: dict[str, str | tuple[str, ...]] = {
    "initial_offset": ("start.position.y", "start.position.z"),
    "initial_offset.y": "start.position.y",
    "initial_offset.z": "start.position.z",
    "initial_surge": "start.surge",
    "current.x": "current.velocity.x",
    "current.y": "current.velocity.y",
    "current.z": "current.velocity.z",
    "k_e": ("controller.k_e.y", "controller.k_e.z"),
    "k_e.y": "controller.k_e.y",
    "k_e.z": "controller.k_e.z",
    **{
        f.name: f"controller.{f.name}"
        for f in dataclasses.fields(PathFollowingGains)
        if f.name != "k_e"
    },
}
ALIASES["current"] = ("current.velocity.x", "current.velocity.y", "current.velocity.z")


def scalar_parameters() -> dict[str, tuple[Parameter, str | None]]:
    """Every scalar a sweep may set, by name: its key and the component (``None`` for a scalar)."""
    out: dict[str, tuple[Parameter, str | None]] = {}
    for parameter in SCHEMA.values():
        if not parameter.sweepable:
            continue
        if parameter.components:
            for component in parameter.components:
                out[component] = (parameter, component.rsplit(".", 1)[1])
        else:
            out[parameter.name] = (parameter, None)
    return out


def describe_kind(parameter: Parameter) -> str:
    """The kind of a key as the documentation prints it."""
    kind = parameter.kind
    if isinstance(kind, tuple) and kind[0] == "choice":
        return "one of " + ", ".join(f"`{option}`" for option in kind[1])
    if isinstance(kind, tuple):
        return f"vector ({', '.join(kind[1])})"
    return {"file": "file name", "bool": "true/false", "points": "list of [x, y, z]"}.get(
        kind, kind
    )


def markdown_table() -> str:
    """The scenario keys as a Markdown table (for the documentation site)."""
    lines = ["| key | kind | unit | range | meaning |", "|---|---|---|---|---|"]
    for p in SCHEMA.values():
        meaning = p.meaning + (f" ({', '.join(p.applies_to)})" if p.applies_to else "")
        lines.append(
            f"| `{p.name}` | {describe_kind(p)} | {p.unit} | {p.range} "
            f"| {meaning.replace('|', '/')} |"
        )
    return "\n".join(lines) + "\n"
