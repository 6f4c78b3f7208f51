"""Sweep specifications: TOML files naming a grid and/or a random sample of scenario parameters.

A spec is a TOML table with an optional ``base`` scenario file, fixed parameters, a ``[grid]`` and a
``[random]`` sample; the format is documented in ``docs/source/sweep.md`` ("Sweep spec" on the
documentation site). The runs are the cartesian product of the grid with the random samples (the
same draws for every grid point); draws come from ``numpy.random.default_rng(seed)`` sample by
sample, in the sorted order of the random parameter names, so raising ``samples`` keeps the earlier
draws.

``base = "scenario.toml"`` (relative to the spec) names a scenario file
(:mod:`aiauv_pin.scenario.toml_file`) that supplies everything the spec does not set: vehicle, path,
start, current, controller type and gains, run settings. Parameter names (:data:`PARAMETERS`) are
those of scenario files (:data:`aiauv_pin.scenario.parameters.SCHEMA`), one schema for both: top-level
keys as they are (``duration``), keys of a table with its name (``start.surge``, ``path.radius``,
``controller.k_d``), and vectors whole or by component (``start.position = [x, y, z]`` or
``start.position.y``). The older names (``initial_offset.y``, ``initial_surge``, ``current.x``,
``k_e.y``, ``k_d``, ...: :data:`aiauv_pin.scenario.parameters.ALIASES`) stay valid; one spec may not give
two names of the same quantity.

Every run is keyed by :func:`run_id`: the SHA-256 of the canonical JSON of its fully resolved
parameters (:func:`scenario_parameters`: the whole scenario after the base and the spec are
applied, defaults filled in, ``k_d`` of the case, ``k_e = u_d / 10``, path and current as their
readers normalise them, every number a float) and of the vehicle file's SHA-256. The key is the
same in every process; a point spelled differently but meaning the same run (``k_d = 19`` for the
uniform case, ``duration = 60`` or ``60.0``, an old or a new name) has the same key; and a change of
the base file that changes the scenario changes the keys of its runs.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from functools import cache, lru_cache
from pathlib import Path
from typing import Annotated, Any, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    create_model,
    model_validator,
)
from pydantic.json_schema import SkipJsonSchema
from typing_extensions import TypeAliasType

from aiauv_control.path_following import PathFollowingGains
from aiauv_hydro.currents import as_current
from aiauv_pin._internal.schema_validation import number_text, shown, validate
from aiauv_pin.errors import AiauvError
from aiauv_pin.model.loading import BUNDLED_CASES, bundled_urdf
from aiauv_pin.scenario.definition import PaperScenario, Scenario
from aiauv_pin.scenario.parameters import ALIASES, SCHEMA, XYZ, Parameter, scalar_parameters
from aiauv_pin.scenario.parameters import METHODS as METHODS
from aiauv_pin.scenario.toml_file import (
    ScenarioFileError,
    parse_scenario_text,
    read_scenario_text,
    scenario_from_mapping,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib


class SweepSpecError(AiauvError, ValueError):
    """Malformed sweep spec; the message is one line naming the entry."""


#: Format tag hashed into every run id (bump it when the meaning of a parameter changes).
RUN_KEY_VERSION = "aiauv-sweep-run/2"
#: Largest number of runs a spec may expand to.
MAX_RUNS = 100_000
#: Largest number of integration steps of one run (``duration / dt``).
MAX_STEPS_PER_RUN = 5_000_000

#: Every scalar of the schema a spec may set: its key and component.
_SCALARS: dict[str, tuple[Parameter, str | None]] = scalar_parameters()


def _sweep_kind(parameter: Parameter):
    kind = parameter.kind
    if isinstance(kind, tuple) and kind[0] == "vector":
        return "number"
    return {"file": "path"}.get(kind, kind) if isinstance(kind, str) else kind


def _meaning(parameter: Parameter) -> str:
    unit = f" [{parameter.unit}]" if parameter.unit != "-" else ""
    applies = f" ({', '.join(parameter.applies_to)} only)" if parameter.applies_to else ""
    return f"{parameter.meaning}{unit}{applies}"


# kinds: "number", "bool", ("choice", options), "path"
#: Every parameter a spec may set, with its kind and meaning (units in brackets): the scalars of
#: the scenario schema, then the older names (aliases).
PARAMETERS: dict[str, tuple[Any, str]] = {
    name: (_sweep_kind(parameter), _meaning(parameter))
    for name, (parameter, _component) in _SCALARS.items()
}
PARAMETERS.update(
    {
        alias: (PARAMETERS[target][0], f"older name of `{target}`")
        for alias, target in ALIASES.items()
        if isinstance(target, str)
    }
)
#: Canonical (scenario) name of every scalar parameter name.
CANONICAL: dict[str, str] = {
    **{name: name for name in _SCALARS},
    **{alias: target for alias, target in ALIASES.items() if isinstance(target, str)},
}
#: Whole vectors a spec may give at once, and the (canonical) components they stand for.
VECTORS: dict[str, tuple[str, ...]] = {
    **{p.name: p.components for p in SCHEMA.values() if p.sweepable and p.components},
    **{alias: target for alias, target in ALIASES.items() if isinstance(target, tuple)},
}
#: Vectors a scalar may stand for (the same value in every component).
_SCALAR_VECTORS = ("k_e", "controller.k_e")
_GAIN_NAMES = tuple(f.name for f in fields(PathFollowingGains))
_GRID_FORMS = ("linspace", "geomspace")
_RANDOM_FORMS = ("uniform", "loguniform", "normal", "choice")
#: Dotted names that are the beginning of a parameter name (for specs written as nested tables).
_NAMES = frozenset([*PARAMETERS, *VECTORS, *SCHEMA])
_PREFIXES = frozenset(
    name.rsplit(".", k)[0] for name in _NAMES for k in range(1, name.count(".") + 1)
)


def components(name: str) -> tuple[str, ...]:
    """The canonical scalar names a parameter name (scalar, vector or older name) stands for."""
    if name in VECTORS:
        return VECTORS[name]
    return (CANONICAL.get(name, name),)


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _as_components(name: str, value) -> dict:
    """A value of a (possibly vector) parameter as a dict of its canonical components.

    The types were checked by the schema (:func:`sweep_file_model`); a vector of the wrong length
    is refused here too, never cut to length.
    """
    if name not in VECTORS:
        return {CANONICAL.get(name, name): value}
    parts = VECTORS[name]
    if name in _SCALAR_VECTORS and _is_number(value):
        value = [value] * len(parts)
    if not isinstance(value, (list, tuple)) or len(value) != len(parts):
        raise ValueError(
            f"{name}: expected a list of {len(parts)} numbers "
            f"({', '.join(c.rsplit('.', 1)[1] for c in parts)}), got {shown(value)}"
        )
    return dict(zip(parts, value, strict=True))


_components = components


def _grid_length(entry) -> int:
    """Number of values of a checked grid entry, counted before any is made."""
    if isinstance(entry, dict):
        return int(next(iter(entry.values()))[2])
    return len(entry)


def _grid_values(name: str, entry) -> list[dict]:
    """The values of a checked grid entry, each as a dict of components."""
    if isinstance(entry, dict):
        form, (start, stop, count) = next(iter(entry.items()))
        grid = np.linspace if form == "linspace" else np.geomspace
        entry = [float(x) for x in grid(start, stop, int(count))]
    return [_as_components(name, value) for value in entry]


@dataclass(frozen=True)
class Distribution:
    """One random parameter of a Monte Carlo sample.

    Attributes:
        name: Parameter name (a key of :data:`PARAMETERS` or :data:`VECTORS`, ``choice`` only).
        form: ``"uniform"``, ``"loguniform"``, ``"normal"`` or ``"choice"``.
        args: ``(low, high)``, ``(low, high)``, ``(mean, std)`` or the options.
    """

    name: str
    form: str
    args: tuple

    def draw(self, rng: np.random.Generator):
        """One value drawn from the distribution."""
        if self.form == "uniform":
            return float(rng.uniform(self.args[0], self.args[1]))
        if self.form == "loguniform":
            return float(math.exp(rng.uniform(math.log(self.args[0]), math.log(self.args[1]))))
        if self.form == "normal":
            return float(rng.normal(self.args[0], self.args[1]))
        return self.args[int(rng.integers(len(self.args)))]


def _distribution(name: str, entry) -> Distribution:
    """The distribution of a checked ``[random]`` entry."""
    form, args = next(iter(entry.items()))
    if form == "choice":
        return Distribution(name, form, tuple(args))
    return Distribution(name, form, tuple(float(x) for x in args))


# --------------------------------------------------------------------------------------------------
# The schema of sweep specs, generated from the scenario file's (aiauv_pin.scenario.file_schemas)


def _named(kind: str):
    """The type a function returns for a name, as one JSON-Schema ``$defs`` entry with the name's
    meaning (a reference wherever it is used)."""

    def decorate(function):
        @cache
        def named(name: str):
            meaning = PARAMETERS.get(name, ("", None))[1]
            alias = f"{kind}_{name.replace('.', '_')}"  # a dot would lengthen the $defs name
            return TypeAliasType(alias, Annotated[function(name), Field(description=meaning)])

        named.__doc__ = function.__doc__
        return named

    return decorate


@_named("value")
def _value_type(name: str):
    """The pydantic type of one value of a parameter name (scalar, component, vector, alias)."""
    if name in SCHEMA and SCHEMA[name].components:  # a whole vector of the scenario file
        return SCHEMA[name].annotation
    if name in VECTORS:  # an older name of a vector: its components' type, as a list
        parts = VECTORS[name]
        item = _SCALARS[parts[0]][0].item
        whole = Annotated[list[item], Field(min_length=len(parts), max_length=len(parts))]
        return item | whole if name in _SCALAR_VECTORS else whole
    parameter, component = _SCALARS[CANONICAL[name]]
    return parameter.item if component is not None else parameter.annotation


def _is_number_parameter(name: str) -> bool:
    return PARAMETERS.get(name, ("",))[0] == "number"


def _refuse_base_key(value):
    raise ValueError('set in the base scenario file (base = "scenario.toml"), not in a sweep spec')


#: A scenario key a spec may not set: refused with its reason, absent from the JSON Schema.
_BASE_ONLY = SkipJsonSchema[Annotated[Any, AfterValidator(_refuse_base_key)]]

_FINITE = Annotated[float, Field(allow_inf_nan=False)]
_PAIR = Annotated[list[_FINITE], Field(min_length=2, max_length=2)]
_TRIPLE = Annotated[list[_FINITE], Field(min_length=3, max_length=3)]
_SPEC_CONFIG = {"strict": True, "extra": "forbid", "allow_inf_nan": False, "frozen": True}


def _check_count(self):
    start, stop, count = self.args
    if not (count == int(count) and 1 <= count <= MAX_RUNS):
        raise ValueError(
            f"count must be a whole number >= 1 and <= {MAX_RUNS}, got {number_text(count)}"
        )
    if self.form == "geomspace" and (start <= 0 or stop <= 0):
        raise ValueError(f"geomspace needs start and stop > 0, got {start:g}, {stop:g}")
    return self


def _check_range(self):
    low, high = self.args
    if self.form == "normal":
        if high < 0:
            raise ValueError(f"normal standard deviation must be >= 0, got {high:g}")
    elif low >= high:
        raise ValueError(f"empty range [{low:g}, {high:g}] (need low < high)")
    elif self.form == "loguniform" and low <= 0:
        raise ValueError(f"loguniform needs low > 0, got {low:g}")
    return self


@cache
def _form_model(form: str, args_type, meaning: str, check, label: str = "") -> type[BaseModel]:
    """A one-key table ``{ form = [...] }`` of a grid or random entry (``label``: of a name)."""
    model = create_model(
        f"{form}_{label.replace('.', '_')}" if label else f"{form.capitalize()}Form",
        __config__=ConfigDict(**_SPEC_CONFIG, title=form),
        **{form: (args_type, Field(..., description=meaning))},
    )
    model.form = property(lambda self: form)
    model.args = property(lambda self: getattr(self, form))
    if check is None:
        return model
    return create_model(
        f"{form.capitalize()}Form",
        __base__=model,
        __validators__={"check": model_validator(mode="after")(check)},
    )


def _form_tag(forms: tuple[str, ...], list_tag: str | None):
    def tag(value):
        if isinstance(value, list) and list_tag is not None:
            return list_tag
        if isinstance(value, Mapping) and len(value) == 1 and next(iter(value)) in forms:
            return next(iter(value))
        return None

    return tag


@_named("grid")
def _axis_type(name: str):
    """A ``[grid]`` entry: a list of values, or ``{ linspace | geomspace = [a, b, n] }``."""
    values = Annotated[list[_value_type(name)], Field(min_length=1, title="list")]
    if not _is_number_parameter(name):
        return values
    members = [Annotated[values, Tag("list")]]
    for form in _GRID_FORMS:
        meaning = f"[start, stop, count]: {form} values, count in [1, {MAX_RUNS}]"
        members.append(Annotated[_form_model(form, _TRIPLE, meaning, _check_count), Tag(form)])
    return Annotated[Union[tuple(members)], Discriminator(_form_tag(_GRID_FORMS, "list"))]  # noqa: UP007


@_named("random")
def _distribution_type(name: str):
    """A ``[random]`` entry: ``{ uniform | loguniform | normal = [a, b] }`` or ``{ choice = [...] }``."""
    options = Annotated[list[_value_type(name)], Field(min_length=1)]
    members = [
        Annotated[
            _form_model("choice", options, "values drawn with equal odds", None, name),
            Tag("choice"),
        ]
    ]
    forms = ("choice",)
    if _is_number_parameter(name):
        meanings = {
            "uniform": "[low, high]",
            "loguniform": "[low, high], low > 0",
            "normal": "[mean, std]",
        }
        for form, meaning in meanings.items():
            model = _form_model(form, _PAIR, meaning, _check_range)
            members.append(Annotated[model, Tag(form)])
        forms = _RANDOM_FORMS
    return Annotated[Union[tuple(members)], Discriminator(_form_tag(forms, None))]  # noqa: UP007


def _is_table(value) -> str | None:
    if isinstance(value, Mapping) and not set(value) & {*_GRID_FORMS, *_RANDOM_FORMS}:
        return "table"
    return "value"


def _names_model(
    prefix: str, leaf, section: str, extra: dict | None = None, given: frozenset | None = None
) -> type[BaseModel]:
    """The table of parameter names under ``prefix`` (``""``: all), nested tables included.

    ``given``: only the names among these dotted key paths (:func:`_key_paths`); ``None``: all.
    """
    fields: dict[str, Any] = dict(extra or {})
    start = f"{prefix}." if prefix else ""

    def wanted(name: str) -> bool:
        return name.startswith(start) and (given is None or name in given)

    names = [n for n in (*PARAMETERS, *VECTORS) if wanted(n)]
    base_only = [n for n, p in SCHEMA.items() if not p.sweepable and wanted(n)]
    keys: dict[str, Any] = {}
    for name in dict.fromkeys(names):
        keys[name[len(start) :]] = leaf(name)
    for name in base_only:
        keys.setdefault(name[len(start) :], _BASE_ONLY)
    for rest in list(keys):
        head = rest.split(".", 1)[0]
        if "." in rest and head not in fields:
            node = _names_model(f"{start}{head}", leaf, section, given=given)
            whole = keys.get(head)
            if whole is None or whole is _BASE_ONLY:
                fields[head] = node
            else:
                fields[head] = Annotated[
                    Union[  # noqa: UP007
                        Annotated[whole, Tag("value"), Field(title="value")],
                        Annotated[node, Tag("table")],
                    ],
                    Discriminator(_is_table),
                ]
    for rest, kind in keys.items():
        fields.setdefault(rest, kind)
    definitions = {  # the meaning is in the type's $defs entry (:func:`_named`)
        f"f{k}": (kind | None, Field(None, alias=key))
        for k, (key, kind) in enumerate(fields.items())
    }
    title = f"{section}.{prefix}" if prefix else section
    model_name = "".join(p.capitalize() for p in f"{section}_{prefix}".replace(".", "_").split("_"))
    return create_model(
        model_name,
        __config__=ConfigDict(**_SPEC_CONFIG, title="table" if prefix else title),
        **definitions,
    )


#: Most key paths a spec may have for a model of only its own names (more: the whole model).
_MAX_GIVEN = 1000


def _key_paths(table: Any, prefix: str = "", out: set | None = None) -> set[str] | None:
    """The dotted paths of every key in nested tables (``None``: too many, or a key not text)."""
    out = set() if out is None else out
    if isinstance(table, Mapping):
        for name, value in table.items():
            if not isinstance(name, str) or len(out) >= _MAX_GIVEN:
                return None
            out.add(f"{prefix}{name}")
            if _key_paths(value, f"{prefix}{name}.", out) is None:
                return None
    return out


@lru_cache(maxsize=64)
def sweep_file_model(
    given: frozenset | None = None,
    grid_given: frozenset | None = None,
    random_given: frozenset | None = None,
) -> type[BaseModel]:
    """The pydantic model of a sweep spec, generated from the scenario file's schema.

    Fixed parameters, ``[grid]`` entries and ``[random]`` entries are the scenario's keys under
    their dotted names (or written as nested tables), with the scenario's types and ranges; a grid
    entry is a list or a ``linspace``/``geomspace`` table, a random entry a distribution table.

    Args:
        given, grid_given, random_given: Only the names among these key paths
            (:func:`_key_paths`) of the top level, ``[grid]`` and ``[random]`` (``None``: every
            name, as ``aiauv schema sweep`` prints it). A spec is checked by the model of its own
            names (a few fields, quick to build) and, if it fails, by the whole model, whose
            schema the message is written from.
    """
    grid = _names_model("", _axis_type, "grid", given=grid_given)
    random = _names_model(
        "",
        _distribution_type,
        "random",
        {
            "samples": Annotated[int, Field(ge=1, le=MAX_RUNS, description="number of draws")],
            "seed": Annotated[int, Field(ge=0, le=2**63 - 1, description="seed of the draws")],
        },
        given=random_given,
    )
    base = Annotated[str, Field(min_length=1, max_length=4096)]
    return _names_model(
        "",
        _value_type,
        "sweep spec",
        {
            "base": Annotated[base, Field(description="scenario file the spec starts from")],
            "grid": Annotated[grid, Field(description="cartesian product of values")],
            "random": Annotated[random, Field(description="Monte Carlo sample")],
        },
        given=given,
    )


def _check_spec(table: Any) -> None:
    """Check a spec against the model of its own names (a few fields, quick to build); an
    unknown key is worded from the whole model's schema (the keys it knows)."""
    model = None
    if isinstance(table, Mapping):
        paths = [_key_paths(table), _key_paths(table.get("grid")), _key_paths(table.get("random"))]
        if all(p is not None for p in paths):
            own = sweep_file_model(*(frozenset(p) for p in paths))
            try:
                own.model_validate(table)
                return
            except ValidationError as error:
                if all(p["type"] != "extra_forbidden" for p in error.errors()):
                    model = own  # the same problems as the whole model's
    validate(model or sweep_file_model(), table, SweepSpecError, "sweep spec")


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    from aiauv_pin.description.input_limits import read_bytes

    return hashlib.sha256(read_bytes(path, "URDF")).hexdigest()


def run_id(resolved: Mapping[str, Any]) -> str:
    """Stable key of a run: SHA-256 (20 hex digits) of its resolved parameters' canonical JSON.

    Args:
        resolved: The run's parameters as returned by :func:`resolve_parameters` (the names of
            :data:`RESOLVED_NAMES` for a line path in a constant current).
    """
    canonical = json.dumps(
        {"key": RUN_KEY_VERSION, **resolved}, sort_keys=True, separators=(",", ":"), allow_nan=False
    )
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:20]


def scenario_parameters(scenario: Scenario) -> dict[str, Any]:
    """A scenario's resolved parameters, flat, under their scenario-file names (without vehicle).

    Vectors by component (``start.position.x``), ``start.heading.*`` ``None`` when the vehicle
    starts along the path, the path and the current as their readers describe them (directions
    normalised; ``path.points`` a list of points), every gain (``k_d`` of the case,
    ``k_e = u_d / 10``, ``controller.k_e.y/z``), numbers as floats, ``control_period`` ``None``
    when the outer loops run every step, and the ``gait.*`` keys when the scenario has a gait.
    :func:`scenario_from_parameters` rebuilds the scenario.
    """
    period = scenario.control_period
    out: dict[str, Any] = {
        "case": scenario.case,
        "duration": float(scenario.duration),
        "dt": float(scenario.dt),
        "method": scenario.method,
        "control_period": None if period is None else float(period),
        "continuous_joints": bool(scenario.continuous_joints),
    }
    if scenario.added_mass != "exact":  # only then: the keys of exact runs stay as they were
        out["added_mass"] = scenario.added_mass
        out["lagged_filter"] = float(scenario.lagged_filter)
    heading = scenario.heading
    for k, axis in enumerate(XYZ):
        out[f"start.position.{axis}"] = float(scenario.start[k])
    for k, axis in enumerate(XYZ):
        out[f"start.heading.{axis}"] = None if heading is None else float(heading[k])
    out["start.surge"] = float(scenario.initial_surge)
    for section, table in (
        ("path", scenario.path_to_follow.describe()),
        ("current", as_current(scenario.current).describe()),
    ):
        for key, value in table.items():
            name = f"{section}.{key}"
            parameter = SCHEMA.get(name)
            if parameter is not None and parameter.components:
                for component, item in zip(parameter.components, value, strict=True):
                    out[component] = float(item)
            elif isinstance(value, (int, float)) and not isinstance(value, bool):
                out[name] = float(value)
            elif isinstance(value, (list, tuple)):
                out[name] = [[float(x) for x in item] for item in value]
            else:
                out[name] = value
    out["controller.type"] = scenario.controller
    gains = scenario.controller_gains
    for name in _GAIN_NAMES:
        value = getattr(gains, name)
        if name == "k_e":
            pair = (value, value) if _is_number(value) else tuple(value)
            out["controller.k_e.y"], out["controller.k_e.z"] = (float(x) for x in pair)
        elif isinstance(value, (str, bool)):  # feedforward, current_compensation, switches
            out[f"controller.{name}"] = value
        else:
            out[f"controller.{name}"] = float(value)
    if scenario.gait is not None:  # only then: the keys of other runs stay as they were
        for name, value in asdict(scenario.gait).items():
            plain = value is None or isinstance(value, (str, bool))
            out[f"gait.{name}"] = value if plain else float(value)
    if scenario.waves is not None:  # only then, as the gait
        for name, value in scenario.waves.describe().items():
            out[f"waves.{name}"] = value if isinstance(value, str) else float(value)
    return out


#: Names of the resolved parameters of a run on a line path in a constant current, in table order
#: (other path and current types have their own keys; ``vehicle`` is replaced by its hash).
RESOLVED_NAMES: tuple[str, ...] = (*scenario_parameters(Scenario()), "vehicle_sha256")


def is_parameter_column(name: str) -> bool:
    """Whether a column of ``results.csv`` is a resolved parameter (not a metric)."""
    if name == "vehicle":  # the resolved parameters hold the vehicle's hash, not its file
        return False
    section = name.split(".", 1)[0]
    return (
        name == "vehicle_sha256"
        or name in SCHEMA
        or section in ("start", "path", "current", "controller", "gait", "waves")
    )


def _place(table: dict, name: str, value) -> None:
    """Put a key's value (``name`` of :data:`SCHEMA`) into a nested scenario table."""
    section, _, key = name.rpartition(".")
    target = table.setdefault(section, {}) if section else table
    target[key] = value


def scenario_from_parameters(resolved: Mapping[str, Any]) -> Scenario:
    """The scenario of a run's resolved parameters (:func:`scenario_parameters`).

    Raises:
        ValueError: A value the scenario file reader rejects (one line).
    """
    table: dict = {}
    vectors: dict[str, list] = {}
    for name, value in resolved.items():
        if name == "vehicle_sha256" or value is None:
            continue
        if name in SCHEMA:
            _place(table, name, value)
            continue
        parameter, component = _SCALARS[name]
        vector = vectors.setdefault(parameter.name, [0.0] * len(parameter.kind[1]))
        vector[parameter.kind[1].index(component)] = value
    for name, vector in vectors.items():
        _place(table, name, vector)
    return scenario_from_mapping(table)


#: The default scenario's path and current tables, for a spec that sets one of their keys.
_DEFAULT_TABLES = {
    "path": Scenario().path_to_follow.describe(),
    "current": as_current(Scenario().current).describe(),
}


def apply_parameters(base: Mapping[str, Any] | None, values: Mapping[str, Any]) -> dict:
    """A scenario table: the base scenario's with the given parameters set.

    Args:
        base: A scenario file's tables (without ``vehicle``), or ``None`` for the paper's scenario.
        values: Values by canonical scalar name (:data:`CANONICAL`), components of vectors included.

    Raises:
        ValueError: A component of a vector the base does not give and that has no default
            (``start.heading``), or gains the controller rejects (one line).
    """
    table = copy.deepcopy(dict(base or {}))
    k_e: dict[str, float] = {}
    for name, value in values.items():
        parameter, component = _SCALARS[name]
        if parameter.name == "controller.k_e":
            k_e[component] = value
            continue
        section, _, key = parameter.name.rpartition(".")
        if section in _DEFAULT_TABLES and section not in table:
            table[section] = copy.deepcopy(_DEFAULT_TABLES[section])
        target = table.setdefault(section, {}) if section else table
        if component is None:
            target[key] = value
            continue
        vector = target.get(key)
        if vector is None:
            whole = all(component in values for component in parameter.components)
            if parameter.name == "start.heading" and not whole:
                raise ValueError(
                    f"{name}: the base scenario gives no start.heading (the vehicle starts along "
                    "the path); give the whole vector start.heading"
                )
            vector = list(Scenario().start) if parameter.name == "start.position" else [0.0] * 3
        vector = list(vector)
        vector[parameter.kind[1].index(component)] = value
        target[key] = vector
    if k_e:
        controller = table.setdefault("controller", {})
        given = controller.get("k_e")
        if given is None:
            others = {k: v for k, v in controller.items() if k not in ("type", "k_e")}
            given = PathFollowingGains.for_case(table.get("case", "uniform"), **others).k_e
        pair = [given, given] if _is_number(given) else list(given)
        for component, value in k_e.items():
            pair[("y", "z").index(component)] = value
        controller["k_e"] = pair
    return table


def resolve_parameters(
    values: Mapping[str, Any], vehicle_sha256: str, base: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """The fully resolved parameters of a point: the base scenario with the point's values set.

    Args:
        values: Values keyed by the names of :data:`PARAMETERS` (without ``vehicle``); older names
            are taken as their canonical ones.
        vehicle_sha256: SHA-256 of the vehicle file.
        base: The base scenario file's tables (without ``vehicle``), or ``None``.

    Returns:
        :func:`scenario_parameters` of the scenario, and ``vehicle_sha256``.

    Raises:
        ValueError: A value the scenario or the gains reject (one line).
    """
    canonical: dict[str, Any] = {}
    for name, value in values.items():
        canonical.update(_as_components(name, value))
    unknown = [name for name in canonical if name not in _SCALARS]
    if unknown:
        raise ValueError(f"unknown parameter '{unknown[0]}'")
    scenario = scenario_from_mapping(apply_parameters(base, canonical))
    from aiauv_pin._internal.array_checks import check_timing

    check_timing(scenario.duration, scenario.dt)  # the verdict simulate() gives (ArgumentError)
    steps = scenario.duration / scenario.dt
    if steps > MAX_STEPS_PER_RUN:
        raise ValueError(
            f"duration / dt = {steps:.3g} steps exceeds {MAX_STEPS_PER_RUN} per run; "
            "use a larger dt or a shorter duration"
        )
    return {**scenario_parameters(scenario), "vehicle_sha256": vehicle_sha256}


@dataclass(frozen=True)
class SweepPoint:
    """One run of a sweep.

    Attributes:
        run_id: Key of the run (:func:`run_id`).
        parameters: Resolved parameters (:func:`resolve_parameters`).
        vehicle: Vehicle URDF file.
        index: Position in the sweep (grid point major, random sample minor).
        sample: Random sample number, or ``None`` without a ``[random]`` table.
    """

    run_id: str
    parameters: dict
    vehicle: Path
    index: int
    sample: int | None


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep spec.

    Attributes:
        fixed: Fixed component values (``vehicle`` included if given).
        grid: Per grid parameter (spec order), its values as dicts of components.
        random: Random parameters (sorted by name).
        samples: Number of random samples (``0`` without random parameters).
        seed: Seed of the random draws.
        base_dir: Folder relative vehicle paths are resolved against.
        base: The base scenario file's tables (without ``vehicle``), or ``None``.
        base_file: The base scenario file, or ``None``.
        base_vehicle: The vehicle the base scenario names (relative to its folder), or ``None``.
    """

    fixed: dict
    grid: dict
    random: tuple[Distribution, ...] = ()
    samples: int = 0
    seed: int = 0
    base_dir: Path = Path(".")
    base: dict | None = None
    base_file: Path | None = None
    base_vehicle: Path | None = None

    @property
    def grid_names(self) -> tuple[str, ...]:
        """Grid parameters as written in the spec."""
        return tuple(self.grid)

    @property
    def random_names(self) -> tuple[str, ...]:
        """Random parameters as written in the spec."""
        return tuple(d.name for d in self.random)

    @property
    def swept_components(self) -> tuple[str, ...]:
        """Component names that vary across runs (grid first, then random)."""
        names = [c for name in self.grid for c in _components(name)]
        names += [c for d in self.random for c in _components(d.name)]
        return tuple(dict.fromkeys(names))

    def _vehicle_path(self, values: Mapping[str, Any]) -> Path:
        if "vehicle" in values:
            path = Path(values["vehicle"]).expanduser()
            return path if path.is_absolute() else self.base_dir / path
        if self.base_vehicle is not None:
            return self.base_vehicle
        case = values.get("case", (self.base or {}).get("case", PaperScenario().case))
        return bundled_urdf(case if case in BUNDLED_CASES else "uniform")

    def points(self) -> list[SweepPoint]:
        """Every run of the sweep (duplicates of the same resolved parameters removed).

        Raises:
            SweepSpecError: A point the scenario rejects, a missing vehicle file, too many runs.
        """
        count = math.prod(len(v) for v in self.grid.values()) * max(self.samples, 1)
        if count > MAX_RUNS:
            raise SweepSpecError(f"the spec expands to {count} runs, more than {MAX_RUNS}")
        rng = np.random.default_rng(self.seed)
        draws: list[dict | None] = []
        for _ in range(self.samples):
            sample: dict = {}
            for distribution in self.random:
                sample.update(_as_components(distribution.name, distribution.draw(rng)))
            draws.append(sample)
        if not draws:
            draws = [None]
        display = {}  # how a swept component is named in messages: as written for a scalar
        for name in (*self.grid, *(d.name for d in self.random)):
            parts = _components(name)
            display.update({c: name if len(parts) == 1 else c for c in parts})
        hashes: dict[Path, str] = {}
        points: list[SweepPoint] = []
        seen: set[str] = set()
        combos = itertools.product(*self.grid.values())
        for combo, (sample_index, sample) in itertools.product(combos, enumerate(draws)):
            values = dict(self.fixed)
            for part in combo:
                values.update(part)
            values.update(sample or {})
            vehicle = self._vehicle_path(values)
            if vehicle not in hashes:
                try:
                    hashes[vehicle] = file_sha256(vehicle)
                except OSError as exc:
                    reason = exc.strerror or exc.__class__.__name__
                    raise SweepSpecError(f"vehicle {vehicle}: cannot read ({reason})") from None
                except AiauvError as exc:  # missing, not a regular file, too large
                    reason = str(exc).removeprefix(f"{vehicle}: ")
                    raise SweepSpecError(f"vehicle {vehicle}: cannot read ({reason})") from None
            given = {k: v for k, v in values.items() if k != "vehicle"}
            try:
                resolved = resolve_parameters(given, hashes[vehicle], self.base)
            except ValueError as exc:
                swept = ", ".join(
                    f"{display[k]}={shown(v)}" for k, v in given.items() if k in display
                )
                where = f"run {len(points) + 1} ({swept})" if swept else "fixed parameters"
                raise SweepSpecError(f"{where}: {' '.join(str(exc).split())}") from None
            key = run_id(resolved)
            if key in seen:
                continue
            seen.add(key)
            sample_number = sample_index if sample is not None else None
            points.append(SweepPoint(key, resolved, vehicle, len(points), sample_number))
        return points

    @property
    def varying(self) -> frozenset[str]:
        """Component names set by the grid or the random table (``vehicle`` included)."""
        return frozenset(self.swept_components)


def _flatten(table: Mapping, prefix: str = "") -> dict:
    """A spec table with nested tables (``[path]``, ``start.position.y = ...`` unquoted) written as
    dotted names; a table whose keys do not continue a parameter name is a value."""
    out: dict = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if (
            isinstance(value, Mapping)
            and value
            and all(f"{name}.{k}" in _PREFIXES or f"{name}.{k}" in _NAMES for k in value)
        ):
            inner = _flatten(value, f"{name}.")
        else:
            inner = {name: value}
        for inner_name, inner_value in inner.items():
            if inner_name in out:
                raise SweepSpecError(f"'{inner_name}' is given twice")
            out[inner_name] = inner_value
    return out


def _split(table: Mapping, section: str) -> dict:
    """Check the names of a table and refuse two names of the same quantity."""
    owners: dict[str, str] = {}
    for name in table:
        for component in _components(name):
            if component in owners:
                raise SweepSpecError(
                    f"{section}: both '{owners[component]}' and '{name}' are given "
                    f"(both set {component}; use one name)"
                )
            owners[component] = name
    return dict(table)


def _load_base(base, base_dir: Path) -> tuple[dict, Path, Path | None]:
    """The base scenario's tables (checked, without ``vehicle``), its file and its vehicle."""
    if not isinstance(base, str) or not base:
        raise SweepSpecError(f"base: expected a scenario file name, got {shown(base)}")
    path = Path(base).expanduser()
    path = path if path.is_absolute() else base_dir / path
    try:
        text = read_scenario_text(path)
    except ScenarioFileError as exc:
        raise SweepSpecError(f"base: {exc}") from None
    try:
        table = parse_scenario_text(text, f"base {base}")
        scenario_from_mapping(table, path.parent)
    except ScenarioFileError as exc:
        message = str(exc)
        prefix = "" if message.startswith(f"base {base}:") else f"base {base}: "
        raise SweepSpecError(prefix + message) from None
    vehicle = table.pop("vehicle", None)
    table.pop("output", None)
    return table, path, (path.parent / vehicle if vehicle is not None else None)


def sweep_spec_from_dict(table: Mapping, base_dir: str | Path = ".") -> SweepSpec:
    """Validate a spec given as a (TOML-like) table.

    Args:
        table: Optional ``base`` scenario file, top-level fixed parameters, optional ``grid`` and
            ``random`` tables.
        base_dir: Folder that relative ``vehicle`` and ``base`` paths refer to.

    Raises:
        SweepSpecError: One line naming the entry.
    """
    _check_spec(table)
    table = dict(table)
    base_dir = Path(base_dir)
    base, base_file, base_vehicle = None, None, None
    if "base" in table:
        base, base_file, base_vehicle = _load_base(table.pop("base"), base_dir)
    grid_table = table.pop("grid", {})
    random_table = dict(table.pop("random", {}))
    fixed_names = _split(_flatten(table), "fixed parameters")
    fixed: dict = {}
    for name, value in fixed_names.items():
        fixed.update(_as_components(name, value))
    grid_entries = _split(_flatten(grid_table), "[grid]")
    samples = random_table.pop("samples", None)
    seed = random_table.pop("seed", 0)
    random_entries = _split(_flatten(random_table), "[random]")
    if random_entries and samples is None:
        raise SweepSpecError("[random]: 'samples' (number of draws) is missing")
    if samples is not None and not random_entries:
        raise SweepSpecError("[random]: 'samples' given without any random parameter")
    owners: dict[str, tuple[str, str]] = {}
    for section, names in (
        ("fixed parameters", fixed_names),
        ("[grid]", grid_entries),
        ("[random]", random_entries),
    ):
        for name in names:
            for component in _components(name):
                if component in owners:
                    other_section, other = owners[component]
                    also = f" (as '{other}')" if other != name else ""
                    raise SweepSpecError(
                        f"{section}: '{name}' is also set in {other_section}{also}"
                    )
                owners[component] = (section, name)
    # count the runs before any grid is made (a linspace count of 1e9 allocates nothing)
    count = math.prod(_grid_length(entry) for entry in grid_entries.values()) * max(samples or 1, 1)
    if count > MAX_RUNS:
        raise SweepSpecError(f"the spec expands to {count} runs, more than {MAX_RUNS}")
    grid = {name: _grid_values(name, entry) for name, entry in grid_entries.items()}
    random = tuple(_distribution(name, random_entries[name]) for name in sorted(random_entries))
    return SweepSpec(
        fixed=fixed,
        grid=grid,
        random=random,
        samples=samples or 0,
        seed=seed,
        base_dir=base_dir,
        base=base,
        base_file=base_file,
        base_vehicle=base_vehicle,
    )


def sweep_spec_from_toml(text: str, base_dir: str | Path = ".") -> SweepSpec:
    """Parse and validate a spec given as TOML text.

    Raises:
        SweepSpecError: Invalid TOML or an invalid spec (one line).
    """
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SweepSpecError(f"invalid TOML: {' '.join(str(error).split())}") from None
    return sweep_spec_from_dict(table, base_dir)


def load_sweep_spec(path: str | Path) -> SweepSpec:
    """Read and validate a sweep spec TOML file (relative vehicle paths refer to its folder).

    Raises:
        SweepSpecError: One line starting with the file name.
    """
    from aiauv_pin.description.input_limits import read_text

    try:
        text = read_text(
            path, "sweep spec"
        )  # regular file, byte cap (aiauv_pin.description.input_limits)
    except AiauvError as error:
        reason = str(error).removeprefix(f"{path}: ")
        raise SweepSpecError(f"{path}: cannot read sweep spec: {reason}") from None
    path = Path(path)
    try:
        return sweep_spec_from_toml(text, path.parent)
    except SweepSpecError as error:
        raise SweepSpecError(f"{path}: {error}") from None
