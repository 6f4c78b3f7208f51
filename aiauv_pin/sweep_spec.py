"""Sweep specifications: TOML files naming a grid and/or a random sample of scenario parameters.

A spec is a TOML table with fixed parameters, a ``[grid]`` and a ``[random]`` sample; the format
is documented in ``docs/source/sweep.md`` ("Sweep spec" on the documentation site). The runs are
the cartesian product of the grid with the random samples (the same draws for every grid point);
draws come from ``numpy.random.default_rng(seed)`` sample by sample, in the sorted order of the
random parameter names, so raising ``samples`` keeps the earlier draws.

Parameter names (:data:`PARAMETERS`) are the fields of :class:`aiauv_pin.scenario.PaperScenario` and
of :class:`control.path_following.PathFollowingGains`, with components of vectors addressable on
their own (``initial_offset.y``, ``current.z``, ``k_e.y``), plus ``vehicle``. Every run is keyed
by :func:`run_id`: the SHA-256 of the canonical JSON of its fully resolved parameters (defaults
filled in, ``k_d`` of the case, ``k_e = u_d / 10``, every number a float) and of the vehicle file's
SHA-256, so the key is the same in every process, and a point spelled differently but meaning the
same run (``k_d = 19`` for the uniform case, ``duration = 60`` or ``60.0``) has the same key.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from control.path_following import PathFollowingGains

from .errors import AiauvError
from .loading import BUNDLED_CASES, bundled_urdf
from .scenario import CASES, PaperScenario

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib


class SweepSpecError(AiauvError, ValueError):
    """Malformed sweep spec; the message is one line naming the entry."""


#: Format tag hashed into every run id (bump it when the meaning of a parameter changes).
RUN_KEY_VERSION = "aiauv-sweep-run/1"
#: Largest number of runs a spec may expand to.
MAX_RUNS = 100_000
#: Largest number of integration steps of one run (``duration / dt``).
MAX_STEPS_PER_RUN = 5_000_000
#: Integrators of :func:`aiauv_pin.simulate`.
METHODS = ("rk4", "euler")
#: Feedforward options of :class:`control.path_following.PathFollowingGains`.
FEEDFORWARD = ("exact", "paper")

# kinds: "number", "bool", ("choice", options), "path"
#: Every parameter a spec may set, with its kind and meaning (units in brackets).
PARAMETERS: dict[str, tuple[Any, str]] = {
    "vehicle": ("path", "URDF file of the vehicle (default: the bundled URDF of `case`)"),
    "case": (("choice", CASES), "paper case: selects k_d and the default bundled vehicle"),
    "duration": ("number", "simulated time [s]"),
    "dt": ("number", "integration step [s]"),
    "method": (("choice", METHODS), "integrator"),
    "initial_offset.y": ("number", "end-effector start p_y [m]"),
    "initial_offset.z": ("number", "end-effector start p_z [m]"),
    "initial_surge": ("number", "initial forward speed [m/s]"),
    "current.x": ("number", "water velocity, world x [m/s]"),
    "current.y": ("number", "water velocity, world y [m/s]"),
    "current.z": ("number", "water velocity, world z [m/s]"),
    "continuous_joints": ("bool", "joint PD as a continuous servo (true) or sampled (false)"),
    "control_period": ("number", "sampling period of the outer loops [s] (absent: every step)"),
    "u_d": ("number", "desired surge speed [m/s] (eq. 21, 25)"),
    "k_e.y": ("number", "cross-track gain, y [1/s] (eq. 21); default u_d / 10"),
    "k_e.z": ("number", "cross-track gain, z [1/s] (eq. 21); default u_d / 10"),
    "alpha": ("number", "joint-reference shape parameter [-] (eq. 22)"),
    "k_p": ("number", "pointing-error gain [-] (eq. 23)"),
    "k_d": ("number", "angular-velocity-error gain [s] (eq. 23); default 19 or 12 by case"),
    "k_qp": ("number", "joint proportional gain [N m/rad] (eq. 24)"),
    "k_qd": ("number", "joint derivative gain [N m s/rad] (eq. 24)"),
    "k_1p": ("number", "surge proportional gain [N s/m] (eq. 25)"),
    "k_1i": ("number", "surge integral gain [N/m] (eq. 25)"),
    "q_max": ("number", "saturation of the base angles [rad] (eq. 22)"),
    "feedforward": (("choice", FEEDFORWARD), "feedforward of eq. (23)"),
}
#: Whole vectors a spec may give at once, and the components they stand for.
VECTORS: dict[str, tuple[str, ...]] = {
    "initial_offset": ("initial_offset.y", "initial_offset.z"),
    "current": ("current.x", "current.y", "current.z"),
    "k_e": ("k_e.y", "k_e.z"),
}
#: Vectors a scalar may stand for (the same value in every component).
_SCALAR_VECTORS = ("k_e",)
#: Names of the resolved parameters of a run, in table order (``vehicle`` is replaced by its hash).
RESOLVED_NAMES: tuple[str, ...] = (
    *(name for name in PARAMETERS if name != "vehicle"),
    "vehicle_sha256",
)
_GAIN_NAMES = tuple(f.name for f in fields(PathFollowingGains))
_GRID_FORMS = ("linspace", "geomspace")
_RANDOM_FORMS = ("uniform", "loguniform", "normal", "choice")


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _check_value(name: str, value, where: str):
    """Validate one value of a (possibly vector) parameter; return it as a dict of components."""
    if name in VECTORS:
        components = VECTORS[name]
        if name in _SCALAR_VECTORS and _is_number(value):
            value = [value] * len(components)
        if not isinstance(value, list) or len(value) != len(components):
            raise SweepSpecError(
                f"{where}: expected a list of {len(components)} numbers "
                f"({', '.join(c.split('.')[1] for c in components)}), got {_shown(value)}"
            )
        out = {}
        for component, item in zip(components, value, strict=True):
            out.update(_check_value(component, item, where))
        return out
    kind = PARAMETERS[name][0]
    if kind == "number":
        if not _is_number(value) or not math.isfinite(value):
            raise SweepSpecError(f"{where}: expected a finite number, got {_shown(value)}")
        return {name: float(value)}
    if kind == "bool":
        if not isinstance(value, bool):
            raise SweepSpecError(f"{where}: expected true or false, got {_shown(value)}")
        return {name: value}
    if kind == "path":
        if not isinstance(value, str) or not value:
            raise SweepSpecError(f"{where}: expected a file name, got {_shown(value)}")
        return {name: value}
    options = kind[1]
    if value not in options:
        raise SweepSpecError(f"{where}: expected one of {', '.join(options)}, got {_shown(value)}")
    return {name: value}


def _check_name(name, section: str) -> None:
    if not isinstance(name, str) or (name not in PARAMETERS and name not in VECTORS):
        known = ", ".join([*PARAMETERS, *VECTORS])
        raise SweepSpecError(f"{section}: unknown parameter '{name}' (known: {known})")


def _components(name: str) -> tuple[str, ...]:
    return VECTORS.get(name, (name,))


def _grid_values(name: str, entry, where: str) -> list[dict]:
    """The list of values of a grid entry, each as a dict of components."""
    if isinstance(entry, dict):
        if len(entry) != 1 or next(iter(entry)) not in _GRID_FORMS:
            raise SweepSpecError(
                f"{where}: expected a list or a table with one of {', '.join(_GRID_FORMS)}, "
                f"got {_shown(entry)}"
            )
        form, args = next(iter(entry.items()))
        if PARAMETERS.get(name, ("",))[0] != "number":
            raise SweepSpecError(f"{where}: {form} needs a scalar number parameter")
        if (
            not isinstance(args, list)
            or len(args) != 3
            or not all(_is_number(a) and math.isfinite(a) for a in args)
        ):
            raise SweepSpecError(
                f"{where}: {form} expects [start, stop, count], got {_shown(args)}"
            )
        start, stop, count = args
        if not (isinstance(count, int) and count >= 1):
            raise SweepSpecError(f"{where}: {form} count must be a whole number >= 1, got {count}")
        if form == "geomspace" and (start <= 0 or stop <= 0):
            raise SweepSpecError(
                f"{where}: geomspace needs start and stop > 0, got {start}, {stop}"
            )
        grid = np.linspace if form == "linspace" else np.geomspace
        entry = [float(x) for x in grid(start, stop, count)]
    if not isinstance(entry, list):
        raise SweepSpecError(f"{where}: expected a list of values, got {_shown(entry)}")
    if not entry:
        raise SweepSpecError(f"{where}: empty list of values")
    return [_check_value(name, value, f"{where}[{k}]") for k, value in enumerate(entry)]


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


def _distribution(name: str, entry, where: str) -> Distribution:
    if not isinstance(entry, dict) or len(entry) != 1 or next(iter(entry)) not in _RANDOM_FORMS:
        raise SweepSpecError(
            f"{where}: expected a table with one of {', '.join(_RANDOM_FORMS)}, got {_shown(entry)}"
        )
    form, args = next(iter(entry.items()))
    if not isinstance(args, list):
        raise SweepSpecError(f"{where}: {form} expects a list, got {_shown(args)}")
    if form == "choice":
        if not args:
            raise SweepSpecError(f"{where}: choice from an empty list")
        for k, value in enumerate(args):
            _check_value(name, value, f"{where}.choice[{k}]")
        return Distribution(name, form, tuple(args))
    if PARAMETERS.get(name, ("",))[0] != "number":
        raise SweepSpecError(f"{where}: {form} needs a scalar number parameter (use choice)")
    if len(args) != 2 or not all(_is_number(a) and math.isfinite(a) for a in args):
        raise SweepSpecError(f"{where}: {form} expects two finite numbers, got {_shown(args)}")
    a, b = (float(x) for x in args)
    if form == "normal":
        if b < 0:
            raise SweepSpecError(f"{where}: normal standard deviation must be >= 0, got {b}")
    elif a >= b:
        raise SweepSpecError(f"{where}: empty range [{a}, {b}] (need low < high)")
    elif form == "loguniform" and a <= 0:
        raise SweepSpecError(f"{where}: loguniform needs low > 0, got {a}")
    return Distribution(name, form, (a, b))


def file_sha256(path: str | Path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    from .input_limits import read_bytes

    return hashlib.sha256(read_bytes(path, "URDF")).hexdigest()


def run_id(resolved: Mapping[str, Any]) -> str:
    """Stable key of a run: SHA-256 (20 hex digits) of its resolved parameters' canonical JSON.

    Args:
        resolved: The run's parameters as returned by :func:`resolve_parameters` (the names of
            :data:`RESOLVED_NAMES`).
    """
    canonical = json.dumps(
        {"key": RUN_KEY_VERSION, **resolved}, sort_keys=True, separators=(",", ":"), allow_nan=False
    )
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:20]


def scenario_from_parameters(resolved: Mapping[str, Any]) -> PaperScenario:
    """The scenario (with its gains) of a run's resolved parameters.

    Raises:
        ValueError: A value the scenario or the gains reject (one line).
    """
    gains = PathFollowingGains.for_case(
        resolved["case"],
        **{name: resolved[name] for name in _GAIN_NAMES if name != "k_e" and name in resolved},
        k_e=(resolved["k_e.y"], resolved["k_e.z"]),
    )
    period = resolved.get("control_period")
    return PaperScenario(
        case=resolved["case"],
        duration=resolved["duration"],
        dt=resolved["dt"],
        initial_offset=(resolved["initial_offset.y"], resolved["initial_offset.z"]),
        initial_surge=resolved["initial_surge"],
        method=resolved["method"],
        current=(resolved["current.x"], resolved["current.y"], resolved["current.z"]),
        gains=gains,
        continuous_joints=resolved["continuous_joints"],
        control_period=period,
    )


def resolve_parameters(values: Mapping[str, Any], vehicle_sha256: str) -> dict[str, Any]:
    """Fill in every default of a point given by (component) parameter values.

    Args:
        values: Values keyed by the names of :data:`PARAMETERS` (without ``vehicle``).
        vehicle_sha256: SHA-256 of the vehicle file.

    Returns:
        Every name of :data:`RESOLVED_NAMES`; numbers as floats, ``control_period`` ``None`` when
        the outer loops run every step.

    Raises:
        ValueError: A value the scenario or the gains reject (one line).
    """
    default = PaperScenario()
    case = values.get("case", default.case)
    gain_values = {k: values[k] for k in _GAIN_NAMES if k in values}
    gains = PathFollowingGains.for_case(case, **gain_values)
    k_e = gains.k_e if isinstance(gains.k_e, tuple) else (gains.k_e, gains.k_e)
    k_e = (values.get("k_e.y", k_e[0]), values.get("k_e.z", k_e[1]))
    gains = gains.with_changes(k_e=k_e)
    resolved: dict[str, Any] = {
        "case": case,
        "duration": float(values.get("duration", default.duration)),
        "dt": float(values.get("dt", default.dt)),
        "method": values.get("method", default.method),
        "initial_offset.y": float(values.get("initial_offset.y", default.initial_offset[0])),
        "initial_offset.z": float(values.get("initial_offset.z", default.initial_offset[1])),
        "initial_surge": float(values.get("initial_surge", default.initial_surge)),
        "current.x": float(values.get("current.x", default.current[0])),
        "current.y": float(values.get("current.y", default.current[1])),
        "current.z": float(values.get("current.z", default.current[2])),
        "continuous_joints": bool(values.get("continuous_joints", default.continuous_joints)),
        "control_period": values.get("control_period", default.control_period),
    }
    for name in _GAIN_NAMES:
        if name == "k_e":
            k_e = gains.k_e if isinstance(gains.k_e, tuple) else (gains.k_e, gains.k_e)
            resolved["k_e.y"], resolved["k_e.z"] = float(k_e[0]), float(k_e[1])
        elif name == "feedforward":
            resolved[name] = gains.feedforward
        else:
            resolved[name] = float(getattr(gains, name))
    if resolved["control_period"] is not None:
        resolved["control_period"] = float(resolved["control_period"])
    resolved["vehicle_sha256"] = vehicle_sha256
    resolved = {name: resolved[name] for name in RESOLVED_NAMES}
    scenario = scenario_from_parameters(resolved)  # the scenario's own checks
    from .arguments import check_timing

    check_timing(scenario.duration, scenario.dt)  # the verdict simulate() gives (ArgumentError)
    steps = scenario.duration / scenario.dt
    if steps > MAX_STEPS_PER_RUN:
        raise ValueError(
            f"duration / dt = {steps:.3g} steps exceeds {MAX_STEPS_PER_RUN} per run; "
            "use a larger dt or a shorter duration"
        )
    return resolved


@dataclass(frozen=True)
class SweepPoint:
    """One run of a sweep.

    Attributes:
        run_id: Key of the run (:func:`run_id`).
        parameters: Resolved parameters (:data:`RESOLVED_NAMES`).
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
    """

    fixed: dict
    grid: dict
    random: tuple[Distribution, ...] = ()
    samples: int = 0
    seed: int = 0
    base_dir: Path = Path(".")

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
        case = values.get("case", PaperScenario().case)
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
                sample.update(_check_value(distribution.name, distribution.draw(rng), "random"))
            draws.append(sample)
        if not draws:
            draws = [None]
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
                resolved = resolve_parameters(given, hashes[vehicle])
            except ValueError as exc:
                shown = ", ".join(f"{k}={_shown(v)}" for k, v in given.items() if k in self.varying)
                where = f"run {len(points) + 1} ({shown})" if shown else "fixed parameters"
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


def _split(table: Mapping, section: str) -> dict:
    """Check the names of a table and refuse a vector given with one of its own components."""
    for name in table:
        _check_name(name, section)
    for vector, components in VECTORS.items():
        both = [c for c in components if c in table]
        if vector in table and both:
            raise SweepSpecError(f"{section}: both '{vector}' and '{both[0]}' are given")
    return dict(table)


def sweep_spec_from_dict(table: Mapping, base_dir: str | Path = ".") -> SweepSpec:
    """Validate a spec given as a (TOML-like) table.

    Args:
        table: Top-level fixed parameters, optional ``grid`` and ``random`` tables.
        base_dir: Folder that relative ``vehicle`` paths refer to.

    Raises:
        SweepSpecError: One line naming the entry.
    """
    table = dict(table)
    grid_table = table.pop("grid", {})
    random_table = table.pop("random", {})
    for name, section in ((grid_table, "grid"), (random_table, "random")):
        if not isinstance(name, dict):
            raise SweepSpecError(f"[{section}] must be a table, got {_shown(name)}")
    fixed_names = _split(table, "fixed parameters")
    fixed: dict = {}
    for name, value in fixed_names.items():
        fixed.update(_check_value(name, value, name))
    grid_entries = _split(grid_table, "[grid]")
    random_table = dict(random_table)
    samples = random_table.pop("samples", None)
    seed = random_table.pop("seed", 0)
    random_entries = _split(random_table, "[random]")
    if random_entries and samples is None:
        raise SweepSpecError("[random]: 'samples' (number of draws) is missing")
    if samples is not None and not (
        isinstance(samples, int) and not isinstance(samples, bool) and samples >= 1
    ):
        raise SweepSpecError(
            f"[random]: samples must be a whole number >= 1, got {_shown(samples)}"
        )
    if samples is not None and not random_entries:
        raise SweepSpecError("[random]: 'samples' given without any random parameter")
    if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
        raise SweepSpecError(f"[random]: seed must be a whole number >= 0, got {_shown(seed)}")
    owners: dict[str, str] = {}
    for section, names in (
        ("fixed parameters", fixed_names),
        ("[grid]", grid_entries),
        ("[random]", random_entries),
    ):
        for name in names:
            for component in _components(name):
                if component in owners:
                    raise SweepSpecError(f"{section}: '{name}' is also set in {owners[component]}")
                owners[component] = section
    grid = {name: _grid_values(name, entry, f"grid.{name}") for name, entry in grid_entries.items()}
    random = tuple(
        _distribution(name, random_entries[name], f"random.{name}")
        for name in sorted(random_entries)
    )
    return SweepSpec(
        fixed=fixed,
        grid=grid,
        random=random,
        samples=samples or 0,
        seed=seed,
        base_dir=Path(base_dir),
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
    from .input_limits import read_text

    try:
        text = read_text(path, "sweep spec")  # regular file, byte cap (aiauv_pin.input_limits)
    except AiauvError as error:
        reason = str(error).removeprefix(f"{path}: ")
        raise SweepSpecError(f"{path}: cannot read sweep spec: {reason}") from None
    path = Path(path)
    try:
        return sweep_spec_from_toml(text, path.parent)
    except SweepSpecError as error:
        raise SweepSpecError(f"{path}: {error}") from None
