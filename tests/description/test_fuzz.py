"""Fuzzing (issue 11): mutated URDFs, vehicle specs, sweep specs, command lines and API calls.

Hypothesis with a fixed seed (``derandomize``) and no example database, so every CI run tries the
same inputs. Each input must end in a result or in a one-line error rooted in
:class:`aiauv_pin.errors.AiauvError` (the command line: exit status 1 or 2 with one
``aiauv: error:`` line): no traceback, no crash, no hang (a per-example deadline). Every accepted
vehicle is checked against physical invariants computed independently of the validation gate (from
Pinocchio's model, not from our parsed URDF): so a non-physical input that slips through fails here.

The number of examples per test is ``AIAUV_FUZZ_EXAMPLES`` (default 40: about 20 s in all on one
core); the outcomes are counted in :data:`TALLY` and printed at the end of the session (``-s``).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import aiauv_pin  # noqa: E402
from aiauv_pin.app.cli import main  # noqa: E402
from aiauv_pin.description.safe_names import NAME_PATTERN  # noqa: E402
from aiauv_pin.errors import AiauvError  # noqa: E402

EXAMPLES = int(os.environ.get("AIAUV_FUZZ_EXAMPLES", "40"))
FUZZ = settings(
    max_examples=EXAMPLES,
    derandomize=True,
    database=None,
    deadline=10_000,  # [ms] per example: a hang fails the test
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    print_blob=False,
)
TALLY: Counter = Counter()

PAPER_URDF = aiauv_pin.bundled_urdf("uniform").read_text(encoding="utf-8")
TWO_LINK = (Path(__file__).parents[1] / "data" / "two_link_hydro.urdf").read_text(encoding="utf-8")
PAPER_SPEC = (Path(__file__).parents[2] / "urdf" / "paper_uniform.toml").read_text(encoding="utf-8")
SWEEP_SPEC = """case = "uniform"
duration = 1.0
dt = 0.01
method = "rk4"
[grid]
k_e = [0.05, 0.1]
"initial_offset.y" = { linspace = [1.0, 3.0, 2] }
[random]
samples = 2
seed = 1
"current.y" = { uniform = [-0.2, 0.2] }
feedforward = { choice = ["exact", "paper"] }
"""

#: Replacement values: non-numbers, non-finite, huge, negative, empty, separators, control chars.
NASTY = [
    "-1", "0", "-0", "1e308", "-1e308", "1e300", "nan", "inf", "-inf", "1e-320", "abc", "", " ",
    "1 2", "1,2", "12345678901234567890", "0.5", "1e6", "1e9", "2", "a,b", "x\ny", "é", "'", '"',
    "&amp;", "<", "0x10", "1_000", "--", "\t", "\x00", "1e3 0 0", "0 0 0", "-5 0 0",
]  # fmt: skip
_ATTRIBUTE = re.compile(r'="([^"]*)"')
_TEXT = re.compile(r">([^<>]+)<")
_TOML_VALUE = re.compile(r"= (.+)$", re.M)


@pytest.fixture(scope="module", autouse=True)
def _pinocchio_backend():
    previous = os.environ.get("AIAUV_BACKEND")
    os.environ["AIAUV_BACKEND"] = "pinocchio"  # the verdicts do not depend on it; no compiling
    yield
    if previous is None:
        os.environ.pop("AIAUV_BACKEND", None)
    else:
        os.environ["AIAUV_BACKEND"] = previous


def teardown_module(module):
    print(f"\nfuzz tally: {dict(sorted(TALLY.items()))}")


def _run_cli(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(argv)
        except SystemExit as exc:  # argparse usage errors
            status = exc.code
    return int(status), out.getvalue(), err.getvalue()


def _assert_clean_failure(status: int, out: str, err: str, what: str) -> None:
    assert status in (1, 2), (what, status, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, (what, err)
    assert re.match(r"aiauv( \w+)?: error: ", lines[0]), (what, err)
    assert "Traceback" not in err and "internal error" not in err, (what, err)


def _assert_physical(vehicle: aiauv_pin.Vehicle) -> None:
    """Invariants of a usable vehicle, from Pinocchio's model (independent of the gate's code)."""
    model = vehicle.model
    names = [*model.names[1:], *vehicle.thruster_names, vehicle.name]
    names += [frame.name for frame in model.frames[1:]]
    for name in names:
        if name != "root_joint":
            assert NAME_PATTERN.fullmatch(name), name
    masses = np.array([inertia.mass for inertia in model.inertias[1:]])
    assert np.all(np.isfinite(masses)) and np.all(masses >= 0) and masses.sum() > 0
    for inertia in model.inertias[1:]:
        moments = np.linalg.eigvalsh(inertia.inertia)
        assert np.all(np.isfinite(moments)) and moments[0] >= -1e-9 * max(1.0, moments[-1])
        assert moments[0] + moments[1] >= moments[2] * (1 - 1e-5) - 1e-12
    hydro = vehicle.hydro
    assert 0 <= hydro.gravity <= 100 and 0 < hydro.fluid_density <= 2e4
    for link in hydro.links:
        for matrix in (link.added_mass, link.linear_damping, link.quadratic_damping):
            sym = 0.5 * (matrix + matrix.T)
            peak = max(1e-300, float(np.max(np.abs(sym))))
            assert np.min(np.linalg.eigvalsh(sym)) >= -1e-8 * peak
    mass = vehicle.mass_matrix(vehicle.neutral_configuration())
    assert np.all(np.isfinite(mass)) and np.linalg.eigvalsh(mass)[0] > 0
    for thruster in hydro.thrusters:
        assert np.linalg.norm(thruster.position) < 1e3


def _mutate(text: str, data, pattern: re.Pattern, count: int) -> str:
    spans = [m.span(1) for m in pattern.finditer(text)]
    for _ in range(count):
        if not spans:
            break
        start, end = spans[data.draw(st.integers(0, len(spans) - 1))]
        value = data.draw(
            st.one_of(
                st.sampled_from(NASTY),
                st.floats(allow_nan=True, allow_infinity=True).map(repr),
                st.text(max_size=8),
            )
        )
        text = text[:start] + value + text[end:]
        spans = [m.span(1) for m in pattern.finditer(text)]
    return text


def _structural(text: str, data) -> str:
    lines = text.splitlines(keepends=True)
    kind = data.draw(st.sampled_from(["delete", "duplicate", "truncate", "swap", "none"]))
    if kind == "none" or len(lines) < 3:
        return text
    k = data.draw(st.integers(0, len(lines) - 1))
    if kind == "delete":
        del lines[k]
    elif kind == "duplicate":
        lines.insert(k, lines[k])
    elif kind == "swap":
        j = data.draw(st.integers(0, len(lines) - 1))
        lines[k], lines[j] = lines[j], lines[k]
    else:
        return text[: data.draw(st.integers(0, len(text)))]
    return "".join(lines)


def _urdf_verdict(path: Path) -> str:
    try:
        vehicle = aiauv_pin.load_vehicle(path)
    except AiauvError as exc:
        message = str(exc)
        assert "\n" not in message and len(message) < 600, message
        return "refused"
    _assert_physical(vehicle)
    return "accepted"


@FUZZ
@given(data=st.data())
def test_fuzzed_urdfs_are_loaded_physically_or_refused_in_one_line(tmp_path_factory, data):
    base = data.draw(st.sampled_from([PAPER_URDF, TWO_LINK]))
    text = _mutate(
        base, data, data.draw(st.sampled_from([_ATTRIBUTE, _TEXT])), data.draw(st.integers(1, 3))
    )
    text = _structural(text, data)
    path = tmp_path_factory.mktemp("urdf") / "v.urdf"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    verdict = _urdf_verdict(path)
    TALLY[f"urdf {verdict}"] += 1
    status, out, err = _run_cli(["check", str(path)])
    if verdict == "accepted":  # check gives the verdict load_vehicle gives
        assert status == 0, err
        assert not any(line.startswith("aiauv") for line in out.splitlines())
    else:
        _assert_clean_failure(status, out, err, text[:200])


@FUZZ
@given(data=st.data())
def test_fuzzed_vehicle_specs_build_loadable_urdfs_or_fail_in_one_line(tmp_path_factory, data):
    text = _mutate(PAPER_SPEC, data, _TOML_VALUE, data.draw(st.integers(1, 3)))
    text = _structural(text, data)
    folder = tmp_path_factory.mktemp("spec")
    spec = folder / "v.toml"
    spec.write_text(text, encoding="utf-8", errors="surrogatepass")
    out_path = folder / "v.urdf"
    status, out, err = _run_cli(["build", str(spec), "-o", str(out_path)])
    if status == 0:
        TALLY["spec built"] += 1
        _assert_physical(aiauv_pin.load_vehicle(out_path))
    else:
        TALLY["spec refused"] += 1
        _assert_clean_failure(status, out, err, text[:200])
        assert not out_path.exists()


@FUZZ
@given(data=st.data())
def test_fuzzed_sweep_specs_expand_or_fail_in_one_line(tmp_path_factory, data):
    from aiauv_pin.scenario.sweep_spec import SweepSpecError, load_sweep_spec

    text = _mutate(SWEEP_SPEC, data, _TOML_VALUE, data.draw(st.integers(1, 3)))
    text = _structural(text, data)
    spec = tmp_path_factory.mktemp("sweep") / "s.toml"
    spec.write_text(text, encoding="utf-8", errors="surrogatepass")
    try:
        points = load_sweep_spec(spec).points()
    except SweepSpecError as exc:
        assert "\n" not in str(exc)
        TALLY["sweep spec refused"] += 1
        return
    TALLY["sweep spec accepted"] += 1
    for point in points:  # every accepted run is one simulate() accepts
        from aiauv_pin._internal.array_checks import check_timing

        assert check_timing(point.parameters["duration"], point.parameters["dt"]) >= 1


_PATHS = ["/dev/zero", "/dev/null", "/nonexistent/x.urdf", ".", "FIFO", "TEXT", "BIG", "EMPTY"]
_VALUES = ["0", "-1", "1e309", "nan", "inf", "abc", "", "100000", "1.5", "-0", "1e-300", "2"]


def _materialise(token: str, folder: Path) -> str:
    if token == "FIFO":
        path = folder / "fifo"
        if not path.exists():
            os.mkfifo(path)
        return str(path)
    if token == "TEXT":
        return PAPER_URDF[:300]
    if token == "BIG":
        path = folder / "big.urdf"
        with open(path, "wb") as handle:
            handle.truncate(20_000_000)  # sparse: 20 MB of zeros
        return str(path)
    if token == "EMPTY":
        path = folder / "empty"
        path.write_text("")
        return str(path)
    return token


@FUZZ
@given(data=st.data())
def test_fuzzed_command_lines_fail_in_one_line(tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("cli")
    command = data.draw(st.sampled_from(["check", "build", "sweep", "simulate", "bench", "nope"]))
    path = _materialise(data.draw(st.sampled_from(_PATHS)), folder)
    value = data.draw(st.sampled_from(_VALUES))
    if command == "check":
        argv = ["check", path]
    elif command == "build":
        argv = ["build", path, "-o", _materialise(data.draw(st.sampled_from(_PATHS)), folder)]
    elif command == "sweep":  # an empty spec is a valid one-run sweep: only bad worker counts
        workers = data.draw(st.sampled_from(["0", "-1", "100000", "abc", "1.5", "", "nan"]))
        argv = ["sweep", path, "--workers", workers, "--out", str(folder / "o")]
    elif command == "simulate":  # always with one bad value, so that nothing long runs
        option = data.draw(st.sampled_from(["--duration", "--dt", "--vehicle", "--case"]))
        bad = path if option == "--vehicle" else value if option != "--case" else "sideways"
        if option in ("--duration", "--dt") and value in ("1e-300", "2", "1.5"):
            argv = ["simulate", "--duration", "0.5", "--dt", "10", "--out", str(folder / "o")]
        elif option == "--duration":
            argv = ["simulate", option, bad, "--out", str(folder / "o")]
        else:
            argv = ["simulate", option, bad, "--duration", "0.05", "--out", str(folder / "o")]
    elif command == "bench":
        argv = ["bench", "--nonsense", value]
    else:
        argv = [command, value]
    status, out, err = _run_cli(argv)
    TALLY["cli refused" if status else "cli accepted"] += 1
    _assert_clean_failure(status, out, err, shlex.join(argv))
    assert not (folder / "o" / "summary.json").exists()


_SHAPES = [(), (0,), (3,), (7,), (14,), (15,), (16,), (15, 1), (2, 15)]


@pytest.fixture(scope="module")
def two_backends():
    return (
        aiauv_pin.load_vehicle(backend="numba"),
        aiauv_pin.load_vehicle(backend="pinocchio"),
    )


def _api_call(vehicle, method, q, v, tau):
    return {
        "acceleration": lambda: vehicle.acceleration(q, v, tau),
        "restoring_forces": lambda: vehicle.restoring_forces(q),
        "thrust_matrix": lambda: vehicle.thrust_matrix(q),
        "mass_matrix": lambda: vehicle.mass_matrix(q),
        "kinetic_energy": lambda: vehicle.kinetic_energy(q, v),
        "momentum_in_world": lambda: vehicle.momentum_in_world(q, v),
        "frame_motion": lambda: vehicle.frame_motion(q, v, 2)[2],
    }[method]


@FUZZ
@given(data=st.data())
def test_fuzzed_api_calls_give_the_same_verdict_on_both_backends(two_backends, data):
    def array(name: str, size: int):
        kind = data.draw(st.sampled_from(["good", "shape", "nan", "dtype", "list", "quaternion"]))
        shape = (size,) if kind != "shape" else data.draw(st.sampled_from(_SHAPES))
        value = np.zeros(shape) + 0.1
        if name == "q" and shape == (15,):
            value[3:7] = [0, 0, 0, 1]
            if kind == "quaternion":
                value[3:7] = data.draw(
                    st.sampled_from([[0, 0, 0, 0], [0, 0, 0, 2], [0, 0, 0, 1.0000001]])
                )
        if kind == "nan" and value.size:
            value.flat[data.draw(st.integers(0, value.size - 1))] = data.draw(
                st.sampled_from([np.nan, np.inf])
            )
        if kind == "dtype":
            return value.astype(data.draw(st.sampled_from([complex, object, str, np.int32, bool])))
        if kind == "list":
            return value.tolist()
        return value

    q, v, tau = array("q", 15), array("v", 14), array("tau", 14)
    method = data.draw(
        st.sampled_from(
            [
                "acceleration",
                "restoring_forces",
                "thrust_matrix",
                "mass_matrix",
                "kinetic_energy",
                "momentum_in_world",
                "frame_motion",
            ]
        )
    )
    outcomes = []
    for vehicle in two_backends:
        call = _api_call(vehicle, method, q, v, tau)
        try:
            outcomes.append(np.asarray(call(), dtype=float))
        except AiauvError as exc:
            assert isinstance(exc, ValueError) and "\n" not in str(exc) and len(str(exc)) < 200
            outcomes.append(str(exc))
    TALLY["api refused" if isinstance(outcomes[0], str) else "api accepted"] += 1
    if isinstance(outcomes[0], str) or isinstance(outcomes[1], str):
        assert outcomes[0] == outcomes[1]
    else:
        np.testing.assert_allclose(outcomes[0], outcomes[1], rtol=1e-8, atol=1e-8)
