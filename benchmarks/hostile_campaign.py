"""Hostile/careless-user campaign of issues 11 and 29, reproducible: mutated files, command lines,
API misuse, kills of ``simulate``, kill-and-resume of sweeps (issue 11); hostile xacro, special
outputs, compiled entry points, threads, SDF/gz inputs, late failures (issue 29).

    python benchmarks/hostile_campaign.py [--quick] [--sections a,b] [--update] [--out FILE]

Everything is drawn from seeded generators (:data:`SEED`; each issue-29 section has its own, so a
section run alone tries the same inputs), so each run tries the same inputs. The figures are
written to ``benchmarks/hostile_campaign.json``: runs tried per section, the runs that fell short
(each with its command and the start of its standard error), and ``summary.categories``, the
per-section table of runs and findings. A run falls short when it ends in

* a **traceback** (or the command line's ``internal error`` line, or an API call raising an
  exception outside :class:`aiauv_pin.errors.AiauvError`: an exception nobody anticipated),
* a **crash** (the process died of a signal), a **hang** (no answer within the time limit: every
  run has one, so a hang is counted, not fatal),
* a **messy error** (a failure that is not exactly one ``aiauv: error:`` line with exit status 1 or
  2, or an API message of several lines or over 400 characters; ``aiauv: warning:`` lines and the
  one-time compile notice are allowed beside it), or a **late failure** (a bad number refused only
  when the run diverges, or by a message that does not name the parameter),
* an **accepted bad input**: a command that succeeded on an input known to be bad (a bad flag, an
  escape, a FIFO, an implausible number), or on a vehicle this script finds non-physical by its own
  reading of the file (negative or indefinite damping, a negative mass, an inertia breaking the
  triangle inequality, non-finite numbers, magnitudes beyond the documented thresholds of
  :mod:`aiauv_pin.model.validation`, unsafe names); an API call returning for a bad argument;
* **silently wrong**: a non-finite result, backends that disagree, a thread's result that differs
  from the serial call's, a writer that said ``ok`` and wrote nothing;
* **code executed**: a xacro payload left the marker file it would create (in the scratch
  folder). Each escape also runs under ``--trust-xacro`` as a positive control: there, the payloads
  that can run at all leave their marker, which shows the marker would catch an escape;
* **files lost**: the scratch tree, compared before and after each output run without following
  links, has an entry changed, replaced, removed or left behind; a killed ``simulate`` leaving a
  folder that claims completeness it lacks or mixes runs; a sweep that, resumed, does not give
  exactly the table of an uninterrupted sweep; or a surviving child process of a killed run.

Devices: the issue-29 sections never touch ``/dev`` (the issue-11 section gives ``/dev/zero`` and
``/dev/null`` as inputs, and ``simulate --out /dev/null``, which must be refused). A device node
cannot be made without privileges,
so it is stood in for, inside the temporary folder, by a FIFO (one with a reader thread that
discards what it gets: ``/dev/null``; one a thread feeds zeros: ``/dev/zero``) and a UNIX socket.

Scale (full, 2026-11-27): 740 command-line runs over 430 mutated files, 1,446 API misuse calls on
both backends (each in a forked process, so that a SIGSEGV is counted), 42 kills of ``simulate`` in
fresh folders and 12 in a reused one, 7 sweep kills and 3 resumes (issue 11: 13 min); 2,146
xacro runs (1,786 files through ``expand_xacro``, each forked, and 360 command lines), 182
output runs (6 file writers and ``simulate --out``/``sweep --out`` against FIFOs, sockets, links,
folders, planted links, absolute and relative), 1,389 forked calls of the compiled entry points on
both backends, 63,396 threaded calls compared with serial ones (2, 4 and 8 threads, 3 rounds), 242
SDF/gz and special-input runs, 66 implausible numbers (issue 29: 9.5 min). In all 6,279 runs and
63,396 threaded calls in 23 min on a shared 2-core machine (load about 3-4); ``--quick`` (a
twentieth of the files, a tenth of the API calls, 3 kills, one sweep kill-and-resume, a sample of
each issue-29 class) 2.6 min (159 s, 22,005 runs and calls) once the kernels are compiled. Not
part of the test suite (CI time); the tests hold a short version of each claim
(``tests/description/test_fuzz.py``, ``tests/app/test_hostile_input.py``,
``tests/results/test_kill.py``, ``tests/test_reliability.py``, ``tests/description/test_fuzz_xacro.py``,
``tests/app/test_fuzz_outputs.py``, ``tests/model/test_fuzz_entry_points.py``).
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from aiauv_pin.testing.processes import descendants, wait_gone

ROOT = Path(__file__).resolve().parents[1]
SEED = 20261123
#: The sections, in the order they run (the first four: issue 11; the rest: issue 29).
SECTIONS = (
    "cli",
    "api",
    "kills",
    "sweeps",
    "xacro",
    "outputs",
    "entry_points",
    "threads",
    "gz_inputs",
    "late",
)
DEFAULT_OUT = ROOT / "benchmarks" / "hostile_campaign.json"
#: Command lines run at once (the machine has 2 cores).
PARALLEL = 2
#: [s] a command taking longer is a hang (process start-up alone is ~1-3 s on a loaded machine).
TIMEOUT = 120.0
SWEEP_TIMEOUT = 400.0
COMPILE_NOTICE = "aiauv: compiling kernels once"

PAPER_URDF = (ROOT / "urdf" / "paper_uniform.urdf").read_text(encoding="utf-8")
TWO_LINK = (ROOT / "tests" / "data" / "two_link_hydro.urdf").read_text(encoding="utf-8")
LAUV = (ROOT / "tests" / "data" / "lauv_uuv_simulator.urdf").read_text(encoding="utf-8")
PAPER_SPEC = (ROOT / "urdf" / "paper_uniform.toml").read_text(encoding="utf-8")
SCENARIOS = sorted((ROOT / "examples").glob("*.toml"))
SWEEP_SPEC = """case = "uniform"
duration = 0.3
dt = 0.01
method = "rk4"
[grid]
k_e = [0.05, 0.1]
"initial_offset.y" = { linspace = [1.0, 3.0, 2] }
[random]
samples = 1
seed = 1
"current.y" = { uniform = [-0.2, 0.2] }
feedforward = { choice = ["exact", "paper"] }
"""

#: Replacement values: non-numbers, non-finite, huge, negative, zero, separators, control chars.
NASTY = [
    "-1", "0", "-0", "1e308", "-1e308", "1e300", "nan", "inf", "-inf", "1e-320", "abc", "", " ",
    "1 2", "1,2", "12345678901234567890", "0.5", "1e6", "1e9", "2", "a,b", "x\ny", "é", "'", '"',
    "&amp;", "<", "0x10", "1_000", "--", "\t", "\x00", "1e3 0 0", "0 0 0", "-5 0 0", "-1e-3",
    "NaN NaN NaN", "1e308 0 0", "-2 -2 -2 0 0 0",
]  # fmt: skip
#: Names a careless or hostile user might give a link, joint or thruster.
HOSTILE_NAMES = [
    "a,b", "x&#10;y", "aiauv: error: forged", "x&#10;aiauv: error: forged", "a\"b", "a;b", "",
    " ", "../../etc/passwd", "n" * 300, "tab&#9;name", "link1", "é", "a b", "$(rm -rf ~)", "<b>",
    "0,1,2,3", "x&#13;y",
]  # fmt: skip
_ATTRIBUTE = re.compile(r'="([^"]*)"')
_TEXT = re.compile(r">([^<>]+)<")
_TOML_VALUE = re.compile(r"= (.+)$", re.M)
_NAME = re.compile(r'name="([^"]*)"')


# --- the mutated files -------------------------------------------------------------------------------


def _xml_escape(value: str) -> str:
    return value.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;")


def mutate_values(text: str, rng: random.Random, pattern: re.Pattern, count: int) -> str:
    """Replace ``count`` values matched by ``pattern`` with nasty ones."""
    for _ in range(count):
        spans = [m.span(1) for m in pattern.finditer(text)]
        if not spans:
            break
        start, end = rng.choice(spans)
        kind = rng.random()
        if kind < 0.7:
            value = rng.choice(NASTY)
        elif kind < 0.85:
            value = repr(rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-320, 308))
        else:
            value = "".join(chr(rng.randint(1, 0x2FF)) for _ in range(rng.randint(0, 8)))
        text = text[:start] + value + text[end:]
    return text


def mutate_structure(text: str, rng: random.Random) -> str:
    """Delete, duplicate or swap a line, or truncate the text."""
    lines = text.splitlines(keepends=True)
    kind = rng.choice(["delete", "duplicate", "truncate", "swap", "none"])
    if kind == "none" or len(lines) < 3:
        return text
    k = rng.randrange(len(lines))
    if kind == "delete":
        del lines[k]
    elif kind == "duplicate":
        lines.insert(k, lines[k])
    elif kind == "swap":
        j = rng.randrange(len(lines))
        lines[k], lines[j] = lines[j], lines[k]
    else:
        return text[: rng.randrange(len(text) + 1)]
    return "".join(lines)


def mutate_elements(text: str, rng: random.Random) -> str:
    """Delete or duplicate a whole XML element (of a well-formed base file)."""
    root = ET.fromstring(text)
    pairs = [(parent, child) for parent in root.iter() for child in parent]
    parent, child = rng.choice(pairs)
    if rng.random() < 0.5:
        parent.remove(child)
    else:
        parent.insert(list(parent).index(child), copy.deepcopy(child))
    return ET.tostring(root, encoding="unicode")


def mutate_name(text: str, rng: random.Random) -> str:
    spans = [m.span(1) for m in _NAME.finditer(text)]
    start, end = rng.choice(spans)
    name = rng.choice(HOSTILE_NAMES)
    name = name if "&#" in name else _xml_escape(name)
    return text[:start] + name + text[end:]


def _set_hydro(text: str, link: str, tag: str, value: str) -> str:
    """The two-link vehicle with ``<tag>`` of hydro link ``link`` set to ``value``."""
    pattern = re.compile(rf'(<link name="{link}" model="fossen">.*?)(<{tag}>[^<]*</{tag}>)', re.S)
    if pattern.search(text):
        return pattern.sub(lambda m: m.group(1) + f"<{tag}>{value}</{tag}>", text, count=1)
    return text.replace(
        f'<link name="{link}" model="fossen">',
        f'<link name="{link}" model="fossen">\n      <{tag}>{value}</{tag}>',
    )


def physics_mutants() -> list[tuple[str, str]]:
    """Non-physical vehicles of issue 11 point 4, each (label, URDF text)."""
    out = []
    indefinite36 = " ".join(
        str(v) for v in (np.diag([4, 20, 20, 0.5, 3, 3]) + 30 * np.eye(6, k=1)).ravel()
    )
    for tag in ("linear_damping", "quadratic_damping", "added_mass"):
        out.append((f"negative {tag}", _set_hydro(TWO_LINK, "hull", tag, "-4 20 20 0.5 3 3")))
        out.append((f"indefinite 6x6 {tag}", _set_hydro(TWO_LINK, "hull", tag, indefinite36)))
        out.append((f"nan {tag}", _set_hydro(TWO_LINK, "hull", tag, "nan 20 20 0.5 3 3")))
        out.append((f"huge {tag}", _set_hydro(TWO_LINK, "hull", tag, "1e300 20 20 0.5 3 3")))
    out.append(("iyy 1e308", TWO_LINK.replace('iyy="1.0"', 'iyy="1e308"')))
    out.append(("20-digit mass", TWO_LINK.replace('value="30.0"', 'value="12345678901234567890"')))
    out.append(("negative mass", TWO_LINK.replace('value="30.0"', 'value="-30"')))
    zero = re.sub(r'<mass value="[^"]*"/>', '<mass value="0"/>', PAPER_URDF)
    out.append(("all masses zero", zero))
    out.append(("triangle inequality", TWO_LINK.replace('ixx="0.2"', 'ixx="5"')))
    out.append(("gravity 1e300", TWO_LINK.replace('gravity="9.81"', 'gravity="1e300"')))
    out.append(("negative gravity", TWO_LINK.replace('gravity="9.81"', 'gravity="-9.81"')))
    out.append(("density 0", TWO_LINK.replace('fluid_density="1000"', 'fluid_density="0"')))
    out.append(("thruster 1000 km", TWO_LINK.replace('xyz="0.237 0 0"', 'xyz="1e6 0 0"')))
    out.append(("thruster 50 m", TWO_LINK.replace('xyz="0.237 0 0"', 'xyz="50 0 0"')))
    out.append(("max_thrust -50", TWO_LINK.replace('max_thrust="50"', 'max_thrust="-50"')))
    out.append(("direction 0", TWO_LINK.replace('direction="0 0 1"', 'direction="0 0 0"')))
    out.append(("volume -1", TWO_LINK.replace("<volume>0.0305", "<volume>-1")))
    out.append(("volume 1e9", TWO_LINK.replace("<volume>0.0305", "<volume>1e9")))
    out.append(("joint 1e6 away", TWO_LINK.replace('origin xyz="0.4 0 0"', 'origin xyz="1e6 0 0"')))
    out.append(("inertia nan", TWO_LINK.replace('izz="0.384"', 'izz="nan"')))
    out.append(("inertia negative", TWO_LINK.replace('izz="0.384"', 'izz="-0.384"')))
    return out


def hostile_xml(folder: Path) -> list[tuple[str, Path]]:
    """Huge, deep, ill-formed and malicious XML, and special files, each (label, path)."""
    out: list[tuple[str, Path]] = []

    def write(label: str, data: str | bytes) -> None:
        path = folder / f"hostile_{len(out)}.urdf"
        if isinstance(data, str):
            data = data.encode("utf-8", "surrogatepass")
        path.write_bytes(data)
        out.append((label, path))

    attributes = " ".join(f'a{i}="{i}"' for i in range(200_000))
    write("200000 attributes", PAPER_URDF.replace('<robot name="', f'<robot {attributes} name="'))
    write("deep nesting", "<robot name='r'>" + "<a>" * 100_000 + "</a>" * 100_000 + "</robot>")
    many = "".join(f'<link name="l{i}"/>' for i in range(300_000))
    write("300000 elements", f"<robot name='r'>{many}</robot>")
    lol = '<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa">' + "".join(
        f'<!ENTITY {chr(98 + i)} "' + f"&{chr(97 + i)};" * 10 + '">' for i in range(8)
    )
    write("billion laughs", lol + "]><robot name='r'>&i;</robot>")
    write(
        "external entity",
        '<!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]><robot name="&x;"></robot>',
    )
    write("unclosed", PAPER_URDF[: len(PAPER_URDF) // 2])
    write("binary", bytes(random.Random(SEED).randrange(256) for _ in range(5000)))
    write("utf-16", PAPER_URDF.encode("utf-16"))
    write("empty", b"")
    write("not xml", "hello, world\n")
    write("two roots", PAPER_URDF + PAPER_URDF)
    links = "".join(
        f'<link name="m{i}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" '
        f'iyy="1" iyz="0" izz="1"/></inertial></link>'
        + (
            f'<joint name="j{i}" type="revolute"><parent link="m{i - 1}"/><child link="m{i}"/>'
            f'<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
            if i
            else ""
        )
        for i in range(1000)
    )
    write("1000-module vehicle", f"<robot name='r'>{links}</robot>")
    big = folder / "hostile_big.urdf"
    with open(big, "wb") as handle:
        handle.write(PAPER_URDF.encode())
        handle.write(b"<!--" + b" " * 30_000_000 + b"-->")
    out.append(("30 MB file", big))
    fifo = folder / "hostile_fifo.urdf"
    os.mkfifo(fifo)
    out.append(("FIFO", fifo))
    out.append(("/dev/zero", Path("/dev/zero")))
    out.append(("/dev/null", Path("/dev/null")))
    out.append(("a folder", folder))
    out.append(("missing file", folder / "missing.urdf"))
    write("processing instruction", '<?xml-stylesheet href="x"?>' + PAPER_URDF.split("?>", 1)[1])
    write(
        "mesh outside",
        TWO_LINK.replace('<box size="0.8 0.3 0.3"/>', '<mesh filename="/etc/passwd"/>'),
    )
    write(
        "package uri",
        TWO_LINK.replace('<box size="0.8 0.3 0.3"/>', '<mesh filename="package://nope/x.stl"/>'),
    )
    return out


def make_files(folder: Path, rng: random.Random, scale: float) -> list[dict]:
    """Every mutated file: a dict with kind (urdf, spec, scenario, sweep), label and path."""
    folder.mkdir(parents=True, exist_ok=True)
    files: list[dict] = []

    def add(kind: str, label: str, text: str, suffix: str) -> None:
        path = folder / f"{kind}_{len(files):04d}{suffix}"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        files.append({"kind": kind, "label": label, "path": str(path)})

    bases = [("paper", PAPER_URDF), ("two_link", TWO_LINK), ("lauv", LAUV)]
    for _ in range(int(260 * scale)):
        base_name, base = rng.choices(bases, weights=[5, 4, 1])[0]
        how = rng.choice(["attribute", "text", "element", "name", "mixed"])
        if how == "attribute":
            text = mutate_values(base, rng, _ATTRIBUTE, rng.randint(1, 3))
        elif how == "text":
            text = mutate_values(base, rng, _TEXT, rng.randint(1, 3))
        elif how == "element":
            text = mutate_elements(base, rng)
        elif how == "name":
            text = mutate_name(base, rng)
        else:
            text = mutate_structure(mutate_values(base, rng, _ATTRIBUTE, 1), rng)
        add("urdf", f"{base_name} {how}", text, ".urdf")
    mutants = physics_mutants()
    for label, text in mutants if scale >= 1 else mutants[:: max(1, int(1 / scale))]:
        add("urdf", f"physics: {label}", text, ".urdf")
    for path in (folder / "hostile").glob("*"):
        path.unlink()
    (folder / "hostile").mkdir(exist_ok=True)
    hostile = hostile_xml(folder / "hostile")
    for label, path in hostile if scale >= 1 else hostile[::4]:
        files.append({"kind": "urdf", "label": f"hostile: {label}", "path": str(path)})
    for _ in range(int(50 * scale)):
        text = mutate_structure(mutate_values(PAPER_SPEC, rng, _TOML_VALUE, rng.randint(1, 3)), rng)
        add("spec", "vehicle spec", text, ".toml")
    for _ in range(int(45 * scale)):
        base = rng.choice(SCENARIOS)
        text = base.read_text(encoding="utf-8")
        text = re.sub(r"^duration = .*$", "duration = 0.2", text, flags=re.M)
        if "duration" not in text:
            text = "duration = 0.2\n" + text
        if rng.random() < 0.2:  # the vehicle a scenario names: a mutated URDF
            urdf = rng.choice(
                [f for f in files if f["kind"] == "urdf" and "hostile" not in f["label"]]
            )
            text = f"vehicle = {json.dumps(urdf['path'])}\n" + re.sub(
                r"^case = .*$", "", text, flags=re.M
            )
        text = mutate_structure(mutate_values(text, rng, _TOML_VALUE, rng.randint(1, 2)), rng)
        add("scenario", f"scenario {base.stem}", text, ".toml")
    for _ in range(int(25 * scale)):
        text = mutate_structure(mutate_values(SWEEP_SPEC, rng, _TOML_VALUE, rng.randint(1, 3)), rng)
        add("sweep", "sweep spec", text, ".toml")
    return files


# --- running and classifying command lines ------------------------------------------------------------


def aiauv(*args: str) -> list[str]:
    return [
        sys.executable,
        "-c",
        "from aiauv_pin.app.cli import console_main; console_main()",
        *args,
    ]


def classify(returncode: int | None, out: str, err: str) -> str:
    """ok, error (one clean line), or a shortfall: traceback, internal error, crash, hang, messy."""
    if returncode is None:
        return "hang"
    if returncode < 0:
        return "crash"
    if "Traceback" in err:
        return "traceback"
    if "internal error" in err:
        return "internal error"
    lines = [
        line
        for line in err.splitlines()
        if line.strip()
        and not line.startswith("aiauv: warning: ")
        and not line.startswith(COMPILE_NOTICE)
    ]
    if returncode == 0:
        if any(re.match(r"aiauv[\w -]*: error", line) for line in out.splitlines() + lines):
            return "forged output"
        return "ok"
    if returncode in (1, 2) and len(lines) == 1 and re.match(r"aiauv( [\w-]+)?: error: ", lines[0]):
        return "error"
    return "messy error"


def run_command(argv: list[str], cwd: Path, env: dict, timeout: float = TIMEOUT) -> dict:
    start = time.monotonic()
    process = subprocess.Popen(
        argv,
        cwd=cwd,
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )
    try:
        out, err = process.communicate(timeout=timeout)
        code = process.returncode
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        out, err = process.communicate()
        code = None
    out_text = out.decode("utf-8", "replace")
    err_text = err.decode("utf-8", "replace")
    return {
        "argv": argv[3:],
        "status": code,
        "outcome": classify(code, out_text, err_text),
        "stderr": err_text[-600:],
        "stdout": out_text[-300:],
        "seconds": round(time.monotonic() - start, 2),
    }


# --- an independent reading of a vehicle: is it physical? ----------------------------------------------


#: Elements whose names the toolkit prints or writes (collision, visual, plugin names it ignores).
_NAMED = ("robot", "link", "joint", "thruster", "frame")


def _numbers(text: str | None) -> list[float]:
    return [float(token) for token in (text or "").split()]


def non_physical_reasons(path: Path) -> list[str]:
    """Why the URDF at ``path`` is not a physical vehicle, by this script's own reading of the XML.

    Uses the thresholds documented in :mod:`aiauv_pin.model.validation` (the numbers, not its code).
    """
    reasons: list[str] = []
    try:
        root = ET.fromstring(path.read_bytes())
    except (ET.ParseError, OSError, ValueError) as exc:
        return [f"unreadable: {exc}"]
    try:
        return _non_physical_reasons(root, reasons)
    except ValueError as exc:  # a number field holding something else, accepted
        return [*reasons, f"not a number: {exc}"]


def _non_physical_reasons(root: ET.Element, reasons: list[str]) -> list[str]:
    from aiauv_pin.description.safe_names import NAME_PATTERN
    from aiauv_pin.model import validation as limits

    hydro_elements = {e for block in root.findall("hydrodynamics") for e in block.iter()}
    masses = []
    for element in root.iter():
        for key, value in element.attrib.items():
            if key == "name" and element.tag in _NAMED and not NAME_PATTERN.fullmatch(value):
                reasons.append(f"unsafe name {value!r}")
            if key in ("filename",):
                continue
            for token in value.split():
                try:
                    number = float(token)
                except ValueError:
                    continue
                if not math.isfinite(number):
                    reasons.append(f"{element.tag}.{key} = {value}")
        if element.text and element.text.strip() and element in hydro_elements:
            try:
                values = _numbers(element.text)
            except ValueError:
                continue
            if not all(math.isfinite(x) for x in values):
                reasons.append(f"<{element.tag}> {element.text.strip()[:40]}")
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        mass_element = inertial.find("mass")
        mass = float(mass_element.get("value", "0")) if mass_element is not None else 0.0
        masses.append(mass)
        if mass < 0 or mass > limits.MAX_LINK_MASS:
            reasons.append(f"link {link.get('name')} mass {mass}")
        inertia = inertial.find("inertia")
        if inertia is not None:
            get = lambda k, inertia=inertia: float(inertia.get(k, "0"))  # noqa: E731
            matrix = np.array(
                [
                    [get("ixx"), get("ixy"), get("ixz")],
                    [get("ixy"), get("iyy"), get("iyz")],
                    [get("ixz"), get("iyz"), get("izz")],
                ]
            )
            if np.all(np.isfinite(matrix)):
                moments = np.linalg.eigvalsh(matrix)
                scale = max(abs(moments[-1]), 1e-300)
                if moments[0] < -1e-9 * scale:
                    reasons.append(f"link {link.get('name')} inertia not PSD")
                if moments[0] + moments[1] < moments[2] * (1 - 1e-5):
                    reasons.append(f"link {link.get('name')} triangle inequality")
                if moments[-1] > limits.MAX_INERTIA:
                    reasons.append(f"link {link.get('name')} inertia {moments[-1]:.3g}")
    if masses and not sum(masses) > 0:
        reasons.append("all masses zero")
    hydro = root.find("hydrodynamics")
    if hydro is not None:
        gravity = float(hydro.get("gravity", "9.81"))
        density = float(hydro.get("fluid_density", "1000"))
        if not 0 <= gravity <= limits.MAX_GRAVITY:
            reasons.append(f"gravity {gravity}")
        if not limits.MIN_FLUID_DENSITY <= density <= limits.MAX_FLUID_DENSITY:
            reasons.append(f"fluid density {density}")
        for link in hydro.findall("link"):
            for tag in ("added_mass", "linear_damping", "quadratic_damping"):
                element = link.find(tag)
                if element is None:
                    continue
                values = np.array(_numbers(element.text))
                if values.size == 6:
                    matrix = np.diag(values)
                elif values.size == 36:
                    matrix = values.reshape(6, 6)
                else:
                    continue  # malformed: the reader must refuse it (counted if accepted below)
                if not np.all(np.isfinite(matrix)):
                    continue
                symmetric = 0.5 * (matrix + matrix.T)
                peak = max(float(np.max(np.abs(symmetric))), 1e-300)
                if np.linalg.eigvalsh(symmetric)[0] < -1e-8 * peak:
                    reasons.append(f"{link.get('name')} {tag} not PSD")
                if peak > limits.MAX_COEFFICIENT:
                    reasons.append(f"{link.get('name')} {tag} entry {peak:.3g}")
            volume = link.find("volume")
            if volume is not None and volume.text and volume.text.strip():
                v = float(volume.text.split()[0]) if volume.text.split() else 0.0
                if not 0 <= v <= limits.MAX_VOLUME:
                    reasons.append(f"{link.get('name')} volume {v}")
        for thruster in hydro.findall("thruster"):
            position = np.array(_numbers(thruster.get("xyz", "0 0 0")))
            if position.size == 3 and np.linalg.norm(position) > limits.MAX_DISTANCE:
                reasons.append(
                    f"thruster {thruster.get('name')} at {np.linalg.norm(position):.3g} m"
                )
            direction = np.array(_numbers(thruster.get("direction", "1 0 0")))
            if direction.size == 3 and not np.linalg.norm(direction) > 0:
                reasons.append(f"thruster {thruster.get('name')} without direction")
            thrust = thruster.get("max_thrust")
            if thrust is not None and thrust.split() and not float(thrust.split()[0]) >= 0:
                reasons.append(f"thruster {thruster.get('name')} max_thrust {thrust}")
    for joint in root.findall("joint"):
        origin = joint.find("origin")
        if origin is not None:
            xyz = np.array(_numbers(origin.get("xyz", "0 0 0")))
            if xyz.size == 3 and np.linalg.norm(xyz) > limits.MAX_DISTANCE:
                reasons.append(f"joint {joint.get('name')} origin {np.linalg.norm(xyz):.3g} m")
    return reasons


def loaded_vehicle_reasons(path: Path) -> list[str]:
    """Invariants of the vehicle as loaded (Pinocchio's model, the parsed hydrodynamics)."""
    import aiauv_pin
    from aiauv_pin.description.safe_names import NAME_PATTERN
    from aiauv_pin.errors import AiauvError

    try:
        vehicle = aiauv_pin.load_vehicle(path, backend="pinocchio")
    except AiauvError as exc:
        return [f"check accepted it but load_vehicle refused: {exc}"]
    reasons = []
    model = vehicle.model
    names = [*model.names[1:], *vehicle.thruster_names, vehicle.name]
    names += [frame.name for frame in model.frames[1:]]
    reasons += [
        f"unsafe name {n!r}" for n in names if n != "root_joint" and not NAME_PATTERN.fullmatch(n)
    ]
    masses = np.array([inertia.mass for inertia in model.inertias[1:]])
    if not (np.all(np.isfinite(masses)) and np.all(masses >= 0) and masses.sum() > 0):
        reasons.append(f"masses {masses}")
    for inertia in model.inertias[1:]:
        moments = np.linalg.eigvalsh(inertia.inertia)
        if not (np.all(np.isfinite(moments)) and moments[0] >= -1e-9 * max(1.0, moments[-1])):
            reasons.append(f"rotational inertia {moments}")
        elif moments[0] + moments[1] < moments[2] * (1 - 1e-5) - 1e-12:
            reasons.append(f"triangle inequality {moments}")
    hydro = vehicle.hydro
    if not (0 <= hydro.gravity <= 100 and 0 < hydro.fluid_density <= 2e4):
        reasons.append(f"gravity {hydro.gravity}, density {hydro.fluid_density}")
    for link in hydro.links:
        for what in ("added_mass", "linear_damping", "quadratic_damping"):
            matrix = getattr(link, what)
            symmetric = 0.5 * (matrix + matrix.T)
            peak = max(1e-300, float(np.max(np.abs(symmetric))))
            if not np.all(np.isfinite(matrix)) or np.linalg.eigvalsh(symmetric)[0] < -1e-8 * peak:
                reasons.append(f"{what} not PSD")
    mass = vehicle.mass_matrix(vehicle.neutral_configuration())
    if not (np.all(np.isfinite(mass)) and np.linalg.eigvalsh(mass)[0] > 0):
        reasons.append("mass matrix not positive definite")
    for thruster in hydro.thrusters:
        if not np.linalg.norm(thruster.position) < 1e3:
            reasons.append(f"thruster at {thruster.position}")
    return reasons


# --- section 1: command lines over mutated files --------------------------------------------------------

BAD_FLAGS = [
    ["simulate", "--duration", "0"], ["simulate", "--duration", "-1"], ["simulate", "--duration", "nan"],
    ["simulate", "--duration", "inf"], ["simulate", "--duration", "1e309"], ["simulate", "--dt", "0"],
    ["simulate", "--dt", "abc"], ["simulate", "--duration", "0.5", "--dt", "10"],
    ["simulate", "--duration", "1e6", "--dt", "1e-6"], ["simulate", "--method", "rk5"],
    ["simulate", "--controller", "pid"], ["simulate", "--case", "sideways"],
    ["simulate", "--current", "nan", "0", "0"], ["simulate", "--current", "1"],
    ["simulate", "--current", "1e309", "0", "0"], ["simulate", "--figure-format", "gif"],
    ["simulate", "--feedforward", "magic"], ["simulate", "--nonsense"], ["simulate", "a", "b"],
    ["simulate", "--arg", "novalue"], ["check"], ["check", "--physics"], ["check", "a", "b"],
    ["build"], ["build", "x.toml"], ["sweep"], ["sweep", "x.toml", "--workers", "0"],
    ["sweep", "x.toml", "--workers", "-3"], ["sweep", "x.toml", "--workers", "100000"],
    ["sweep", "x.toml", "--workers", "1.5"], ["sweep", "x.toml", "--workers", "nan"],
    ["sweep", "x.toml", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"],
    ["sweep", "x.toml", "--figure-format", "bmp"], ["annotate"], ["annotate", "x.urdf"],
    ["annotate", "x.urdf", "-o", "y.urdf", "--fluid-density", "-1"],
    ["annotate", "x.urdf", "-o", "y.urdf", "--fluid-density", "nan"],
    ["annotate", "x.urdf", "-o", "y.urdf", "--fluid-density", "0"], ["linearize"],
    ["linearize", "x.toml", "--speed", "nan"], ["linearize", "x.toml", "--speed", "abc"],
    ["bench", "--nonsense"], ["bench", "--quick", "--out"], ["nope"], [""], ["--duration", "1e308"],
    ["export", "x.urdf", "-o", "y.txt"], ["export"], ["import-gz"], ["\x7f"],
    ["simulate", "--duration", "1e308", "--dt", "0.01"],
    ["check", "-"], ["simulate", "--out", "/dev/null", "--duration", "0.1"],
    ["simulate", "--out", "/proc/self", "--duration", "0.1"],
]  # fmt: skip


def plan_cli_runs(files: list[dict], work: Path, rng: random.Random, scale: float) -> list[dict]:
    runs = []
    outputs = work / "outputs"
    outputs.mkdir(exist_ok=True)

    def out(name: str) -> str:
        return str(outputs / f"{len(runs):04d}_{name}")

    for entry in files:
        path = entry["path"]
        if entry["kind"] == "urdf":
            runs.append({"file": entry, "argv": ["check", path], "command": "check"})
            draw = rng.random()
            hostile = "hostile" in entry["label"]
            if draw < 0.25 or (hostile and draw < 0.5):
                argv = ["simulate", "--vehicle", path, "--duration", "0.2", "--quiet"]
                argv += rng.choice([["--controller", "none"], [], ["--no-html"]])
                runs.append(
                    {"file": entry, "argv": [*argv, "--out", out("sim")], "command": "simulate"}
                )
            elif draw < 0.45:
                runs.append(
                    {
                        "file": entry,
                        "argv": ["annotate", path, "-o", out("a.urdf")],
                        "command": "annotate",
                    }
                )
            elif draw < 0.52:
                runs.append(
                    {
                        "file": entry,
                        "argv": ["export", path, "-o", out("e.sdf")],
                        "command": "export",
                    }
                )
            elif draw < 0.58:
                scenario = Path(out("lin.toml"))
                scenario.write_text(f"vehicle = {json.dumps(path)}\n", encoding="utf-8")
                runs.append(
                    {"file": entry, "argv": ["linearize", str(scenario)], "command": "linearize"}
                )
        elif entry["kind"] == "spec":
            runs.append(
                {"file": entry, "argv": ["build", path, "-o", out("b.urdf")], "command": "build"}
            )
        elif entry["kind"] == "scenario":
            argv = ["simulate", path, "--quiet", "--out", out("sc")]
            runs.append({"file": entry, "argv": argv, "command": "simulate"})
            if rng.random() < 0.4:
                runs.append({"file": entry, "argv": ["linearize", path], "command": "linearize"})
        else:
            argv = ["sweep", path, "--workers", "1", "--quiet", "--no-plots", "--out", out("sw")]
            runs.append({"file": entry, "argv": argv, "command": "sweep"})
    flags = BAD_FLAGS * max(1, round(2 * scale)) if scale >= 1 else BAD_FLAGS[:: int(1 / scale)]
    for argv in flags:
        argv = [a if a not in ("x.urdf", "x.toml") else str(work / a) for a in argv]
        runs.append({"file": None, "argv": list(argv), "command": "bad flag", "bad": True})
    return runs


def run_cli_section(work: Path, env: dict, rng: random.Random, scale: float) -> dict:
    files = make_files(work / "files", rng, scale)
    (work / "x.urdf").write_text(TWO_LINK)
    (work / "x.toml").write_text("duration = 0.1\n")
    runs = plan_cli_runs(files, work, rng, scale)
    print(f"cli: {len(files)} files, {len(runs)} runs", flush=True)
    done = [0]

    def execute(run: dict) -> dict:
        timeout = SWEEP_TIMEOUT if run["command"] == "sweep" else TIMEOUT
        result = run_command(aiauv(*run["argv"]), work, env, timeout)
        done[0] += 1
        if done[0] % 50 == 0:
            print(f"  {done[0]}/{len(runs)}", flush=True)
        return {**run, **result}

    with ThreadPoolExecutor(PARALLEL) as pool:
        results = list(pool.map(execute, runs))
    failures = []
    tally: Counter = Counter()
    per_command: dict[str, Counter] = {}
    for result in results:
        outcome = result["outcome"]
        label = result["file"]["label"] if result["file"] else None
        if outcome == "ok":
            if result.get("bad"):
                outcome = "accepted bad input"
            elif result["command"] in ("check", "simulate", "annotate", "export", "linearize"):
                outcome = _judge_accepted_vehicle(result)
            elif result["command"] == "build":
                built = Path(result["argv"][-1])
                reasons = non_physical_reasons(built) + loaded_vehicle_reasons(built)
                if reasons:
                    outcome = "accepted bad input"
                    result["reasons"] = reasons[:5]
        result["outcome"] = outcome
        tally[outcome] += 1
        per_command.setdefault(result["command"], Counter())[outcome] += 1
        if outcome not in ("ok", "error"):
            failures.append(
                {
                    "command": result["command"],
                    "file": label,
                    "path": result["file"]["path"] if result["file"] else None,
                    "argv": result["argv"],
                    "outcome": outcome,
                    "status": result["status"],
                    "stderr": result["stderr"],
                    "reasons": result.get("reasons"),
                }
            )
    # check and simulate must agree: a vehicle check calls usable is one simulate loads
    verdicts: dict[str, dict] = {}
    for result in results:
        if result["file"] and result["file"]["kind"] == "urdf":
            verdicts.setdefault(result["file"]["path"], {})[result["command"]] = result
    disagreements = []
    for path, by_command in verdicts.items():
        if "check" in by_command and "simulate" in by_command:
            checked = by_command["check"]["outcome"] == "ok"
            sim = by_command["simulate"]
            # refused at load: not a divergence, nor a shape the playback cannot draw (a mesh
            # that is no mesh: check judges the physics; simulate refuses it before the run)
            refused_at_load = sim["outcome"] == "error" and not any(
                word in sim["stderr"] for word in ("diverged", "cannot read the visuals")
            )
            # the paper's controller needs the paper's frames and thrusters; a passive run
            # (--controller none) needs only a usable vehicle
            passive = "none" in sim["argv"]
            if checked and refused_at_load and passive:
                disagreements.append({"path": path, "simulate": sim["stderr"][-300:]})
            if not checked and sim["outcome"] == "ok":
                disagreements.append({"path": path, "check": by_command["check"]["stderr"][-300:]})
    slowest = sorted(results, key=lambda r: -r["seconds"])[:5]
    return {
        "files": len(files),
        "files_by_kind": dict(Counter(f["kind"] for f in files)),
        "runs": len(results),
        "outcomes": dict(tally),
        "outcomes_by_command": {k: dict(v) for k, v in sorted(per_command.items())},
        "check_simulate_disagreements": disagreements,
        "slowest_runs": [{"argv": r["argv"], "seconds": r["seconds"]} for r in slowest],
        "failures": failures,
    }


def _judge_accepted_vehicle(result: dict) -> str:
    path = Path(result["file"]["path"])
    if result["file"]["kind"] == "scenario":  # its vehicle is a bundled one or a checked URDF
        return "ok"
    reasons = non_physical_reasons(path)
    if not reasons:
        reasons = loaded_vehicle_reasons(path)
    if reasons:
        result["reasons"] = reasons[:5]
        return "accepted bad input"
    return "ok"


# --- section 2: Python API misuse, each call in a forked process ----------------------------------------

API_WORKER = r"""
import json, os, sys, select, signal, ctypes, mmap, math, time
import numpy as np
import aiauv_pin
from aiauv_pin.errors import AiauvError

backend = sys.argv[1]
vehicle = aiauv_pin.load_vehicle(backend=backend)
nq, nv = vehicle.nq, vehicle.nv
q0 = vehicle.neutral_configuration()
v0 = np.full(nv, 0.1)
tau0 = np.zeros(nv)

page = mmap.PAGESIZE
guard = mmap.mmap(-1, 2 * page)
address = ctypes.addressof(ctypes.c_char.from_buffer(guard))
libc = ctypes.CDLL(None, use_errno=True)
assert libc.mprotect(ctypes.c_void_p(address + page), ctypes.c_size_t(page), 0) == 0

def at_guard(count):
    # an array of `count` floats ending exactly where an unreadable page begins
    return np.frombuffer(guard, dtype=np.float64, count=count, offset=page - 8 * count)

def with_quaternion(values):
    q = q0.copy(); q[3:7] = values; return q

def variants(n, what):
    base = {"q": q0, "v": v0, "tau": tau0}[what]
    strided = np.zeros(2 * n); strided[::2] = base
    readonly = base.copy(); readonly.flags.writeable = False
    out = {
        "empty": ("bad", np.zeros(0)), "seven": ("bad", np.zeros(7)), "short": ("bad", base[:-1].copy()),
        "long": ("bad", np.append(base, 0.0)), "column": ("bad", base.reshape(-1, 1)),
        "two rows": ("bad", np.vstack([base, base])), "scalar": ("bad", np.float64(0.0)),
        "none": ("bad", None), "nan": ("bad", np.where(np.arange(n) == n - 1, np.nan, base)),
        "inf": ("bad", np.where(np.arange(n) == 0, np.inf, base)),
        "complex": ("bad", base.astype(complex)), "strings": ("bad", ["a"] * n),
        "object": ("bad", np.array([object()] * n, dtype=object)), "text": ("bad", "abc"),
        "ragged": ("bad", [[1.0], [2.0, 3.0]]), "dict": ("bad", {"a": 1}),
        "guard short": ("bad", at_guard(1)), "guard n-1": ("bad", at_guard(n - 1)),
        "guard n": ("good", at_guard(n)),
        "int32": ("either", base.astype(np.int32)), "bool": ("either", base.astype(bool)),
        "float32": ("good", base.astype(np.float32)), "big-endian": ("good", base.astype(">f8")),
        "strided": ("good", strided[::2]), "read-only": ("good", readonly),
        "list": ("good", base.tolist()), "tuple": ("good", tuple(base.tolist())),
        "huge": ("absurd", np.full(n, 1e308) if what != "q" else q0 + np.r_[1e308, np.zeros(n - 1)]),
    }
    if what == "q":
        del out["guard n"]  # zeros: a zero quaternion (refused as such, tested as "guard n-1")
        out.update({
            "zero quaternion": ("bad", with_quaternion([0, 0, 0, 0])),
            "quaternion x2": ("bad", with_quaternion([0, 0, 0, 2])),
            "quaternion 1+1e-7": ("either", with_quaternion([0, 0, 0, 1 + 1e-7])),
            "quaternion 1+1e-3": ("bad", with_quaternion([0, 0, 0, 1 + 1e-3])),
            "quaternion nan": ("bad", with_quaternion([np.nan, 0, 0, 1])),
            "negative quaternion": ("good", with_quaternion([0, 0, 0, -1])),
        })
    return out

CALLS = {
    "acceleration": (("q", "v", "tau"), lambda q, v, tau: vehicle.acceleration(q, v, tau)),
    "acceleration+current": (
        ("q", "v", "tau"), lambda q, v, tau: vehicle.acceleration(q, v, tau, [0.1, 0.2, 0])
    ),
    "fluid_forces": (("q", "v"), lambda q, v: vehicle.fluid_forces(q, v).bias),
    "mass_matrix": (("q",), lambda q: vehicle.mass_matrix(q)),
    "kinetic_energy": (("q", "v"), lambda q, v: vehicle.kinetic_energy(q, v)),
    "restoring_forces": (("q",), lambda q: vehicle.restoring_forces(q)),
    "thrust_matrix": (("q",), lambda q: vehicle.thrust_matrix(q)),
    "momentum_in_world": (("q", "v"), lambda q, v: vehicle.momentum_in_world(q, v)),
    "frame_motion": (("q", "v"), lambda q, v: vehicle.frame_motion(q, v, 1)[1]),
    "frame_placement": (("q",), lambda q: vehicle.frame_placement(q, "end_effector").translation),
    "link_placements": (("q",), lambda q: np.array([p.translation for p in vehicle.link_placements(q)])),
    "acceleration_derivatives": (
        ("q", "v", "tau"), lambda q, v, tau: vehicle.acceleration_derivatives(q, v, tau)[1]
    ),
}

cases = []
for method, (names, call) in CALLS.items():
    for position, what in enumerate(names):
        n = nq if what == "q" else nv
        for label, (expect, value) in variants(n, what).items():
            args = [{"q": q0, "v": v0, "tau": tau0}[a] for a in names]
            args[position] = value
            cases.append((f"{method}({what}={label})", expect, lambda call=call, args=args: call(*args)))

def sim(**kw):
    from aiauv_pin.simulation.fixed_step import simulate
    args = dict(vehicle=vehicle, q0=q0, v0=np.zeros(nv), duration=0.05, dt=0.01)
    args.update(kw)
    return simulate(**args).q[-1]

for label, expect, kw in [
    ("duration=0.5, dt=10", "bad", dict(duration=0.5, dt=10)),
    ("duration=0", "bad", dict(duration=0)), ("dt=0", "bad", dict(dt=0)),
    ("dt=-0.01", "bad", dict(dt=-0.01)), ("duration=nan", "bad", dict(duration=float("nan"))),
    ("dt=inf", "bad", dict(dt=float("inf"))), ("duration=1e308", "bad", dict(duration=1e308)),
    ("duration=1e300, dt=1", "bad", dict(duration=1e300, dt=1.0)),
    ("duration=0.05 dt=0.03 (not a multiple)", "either", dict(dt=0.03)),
    ("duration='1'", "bad", dict(duration="1")), ("dt=None", "bad", dict(dt=None)),
    ("q0 empty", "bad", dict(q0=np.zeros(0))),
    ("q0 zero quaternion", "bad", dict(q0=with_quaternion([0, 0, 0, 0]))),
    ("v0 nan", "bad", dict(v0=np.full(nv, np.nan))), ("v0 seven", "bad", dict(v0=np.zeros(7))),
    ("method rk5", "bad", dict(method="rk5")), ("log_every=0", "bad", dict(log_every=0)),
    ("log_every=-1", "bad", dict(log_every=-1)), ("control_period=0", "bad", dict(control_period=0.0)),
    ("control_period=nan", "bad", dict(control_period=float("nan"))),
    ("chunk_seconds=-1", "bad", dict(chunk_seconds=-1.0)),
    ("current nan", "bad", dict(current=[np.nan, 0, 0])),
    ("current 2 values", "bad", dict(current=[0.1, 0.2])),
    ("current text", "bad", dict(current="fast")), ("added_mass='magic'", "bad", dict(added_mass="magic")),
    ("lagged_filter=-1", "bad", dict(lagged_filter=-1.0)), ("good run", "good", dict()),
]:
    cases.append((f"simulate({label})", expect, lambda kw=kw: sim(**kw)))

from aiauv_pin.model.loading import bundled_urdf
text = bundled_urdf("uniform").read_text()
for label, expect, fn in [
    ("URDF text as path", "bad", lambda: aiauv_pin.load_vehicle(text)),
    ("URDF bytes", "bad", lambda: aiauv_pin.load_vehicle(text.encode())),
    ("/dev/zero", "bad", lambda: aiauv_pin.load_vehicle("/dev/zero")),
    ("a folder", "bad", lambda: aiauv_pin.load_vehicle("/tmp")),
    ("missing", "bad", lambda: aiauv_pin.load_vehicle("/nonexistent/v.urdf")),
    ("NUL in path", "bad", lambda: aiauv_pin.load_vehicle("v\x00.urdf")),
    ("integer path", "bad", lambda: aiauv_pin.load_vehicle(5)),
    ("backend cuda", "bad", lambda: aiauv_pin.load_vehicle(backend="cuda")),
    ("case sideways", "bad", lambda: aiauv_pin.bundled_urdf("sideways")),
    ("frame nonexistent", "bad", lambda: vehicle.frame_placement(q0, "nope")),
    ("frame integer", "bad", lambda: vehicle.frame_placement(q0, 5)),
    ("frame_motion index 1000", "bad", lambda: vehicle.frame_motion(q0, v0, 1000)),
    ("frame_motion index -1", "bad", lambda: vehicle.frame_motion(q0, v0, -1)),
    ("frame_motion index 'a'", "bad", lambda: vehicle.frame_motion(q0, v0, "a")),
    ("acceleration t=nan", "bad", lambda: vehicle.acceleration(q0, v0, tau0, t=float("nan"))),
    ("acceleration current nan", "bad", lambda: vehicle.acceleration(q0, v0, tau0, [np.nan, 0, 0])),
    ("acceleration current 7", "bad", lambda: vehicle.acceleration(q0, v0, tau0, np.zeros(7))),
    ("acceleration current guard", "bad", lambda: vehicle.acceleration(q0, v0, tau0, at_guard(1))),
    ("link_placements unknown link", "bad", lambda: vehicle.link_placements(q0, ["nope"])),
    ("backend assignment", "bad", lambda: setattr(vehicle, "backend", "gpu")),
]:
    cases.append((label, expect, fn))

def child(fn, write_end):
    try:
        value = fn()
        array = np.asarray(value, dtype=float)
        message = {"kind": "ok", "finite": bool(np.all(np.isfinite(array))), "shape": list(array.shape),
                   "value": array.ravel()[:400].tolist() if np.all(np.isfinite(array)) else None}
    except BaseException as exc:
        message = {"kind": "exception", "type": type(exc).__name__,
                   "aiauv": isinstance(exc, AiauvError), "value_error": isinstance(exc, ValueError),
                   "message": str(exc)[:1000]}
    os.write(write_end, json.dumps(message).encode())
    os._exit(0)

every = int(sys.argv[2]) if len(sys.argv) > 2 else 1
results = []
for label, expect, fn in cases[::every]:
    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read_end)
        child(fn, write_end)
    os.close(write_end)
    chunks, deadline = [], time.monotonic() + 60
    while time.monotonic() < deadline:
        ready, _, _ = select.select([read_end], [], [], 1.0)
        if ready:
            data = os.read(read_end, 1 << 16)
            if not data:
                break
            chunks.append(data)
    else:
        os.kill(pid, signal.SIGKILL)
    os.close(read_end)
    _, status = os.waitpid(pid, 0)
    record = {"case": label, "expect": expect}
    if os.WIFSIGNALED(status) and not chunks:
        record["kind"] = "crash" if time.monotonic() < deadline else "hang"
        record["signal"] = os.WTERMSIG(status)
    else:
        record.update(json.loads(b"".join(chunks).decode()))
    results.append(record)
print(json.dumps(results))
"""


def run_api_section(work: Path, env: dict, quick: bool) -> dict:
    script = work / "api_worker.py"
    script.write_text(API_WORKER, encoding="utf-8")
    by_backend = {}
    for backend in ("numba", "pinocchio"):
        done = subprocess.run(
            [sys.executable, str(script), backend, "10" if quick else "1"],
            cwd=work,
            env=env,
            capture_output=True,
            text=True,
            timeout=1800,
        )
        if done.returncode != 0:
            by_backend[backend] = None
            print(f"api worker {backend} failed: {done.stderr[-2000:]}", flush=True)
            continue
        results = json.loads(done.stdout.strip().splitlines()[-1])
        by_backend[backend] = {r["case"]: r for r in results}
    tally: Counter = Counter()
    failures = []
    disagreements = []
    for backend, results in by_backend.items():
        if results is None:
            failures.append({"backend": backend, "outcome": "api worker failed"})
            continue
        for record in results.values():
            outcome = _api_outcome(record)
            tally[outcome] += 1
            if outcome not in ("ok", "error", "overflow (absurd input)"):
                failures.append({"backend": backend, **record, "outcome": outcome})
    if all(by_backend.values()):
        numba, pinocchio = by_backend["numba"], by_backend["pinocchio"]
        for label in sorted(set(numba) & set(pinocchio)):
            a, b = numba[label], pinocchio[label]
            if a["expect"] == "absurd":  # 1e308: overflow, or cancellation at 1e308 m, differ
                continue
            if a["kind"] != b["kind"]:
                disagreements.append(
                    {
                        "case": label,
                        "numba": a.get("message", a["kind"]),
                        "pinocchio": b.get("message", b["kind"]),
                    }
                )
            elif a["kind"] == "ok" and a.get("value") is not None and b.get("value") is not None:
                if a["shape"] != b["shape"] or not np.allclose(
                    a["value"], b["value"], rtol=1e-8, atol=1e-8
                ):
                    disagreements.append({"case": label, "numba": "value", "pinocchio": "differs"})
    for item in disagreements:
        failures.append({**item, "outcome": "backends disagree"})
    return {
        "calls": sum(tally.values()),
        "cases_per_backend": {b: len(r) if r else 0 for b, r in by_backend.items()},
        "outcomes": dict(tally),
        "backend_disagreements": len(disagreements),
        "failures": failures,
    }


def _api_outcome(record: dict) -> str:
    kind, expect = record["kind"], record["expect"]
    if kind in ("crash", "hang"):
        return kind
    if kind == "exception":
        message = record["message"]
        if not (record["aiauv"] or record["value_error"]):
            return "foreign exception"
        if "\n" in message or len(message) > 300 or not message:
            return "messy error"
        if expect == "good":
            return "refused good input"
        return "error"
    if expect == "bad":
        return "accepted bad input"
    if not record["finite"]:
        return "overflow (absurd input)" if expect == "absurd" else "non-finite result"
    return "ok"


# --- section 3: kills of simulate -------------------------------------------------------------------------


def _folder_problems(out: Path, html: bool, duration: float) -> list[str]:
    """What a result folder claims and lacks (empty: a complete run of ``duration``)."""
    from aiauv_pin.results.outputs import FIGURES

    problems = []
    try:
        summary = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError) as exc:
        return [f"summary.json unreadable: {exc}"]
    if summary.get("status") != "complete":
        problems.append(f"status {summary.get('status')}")
    for name in FIGURES:
        figure = out / "figures" / name
        if not figure.exists() or figure.stat().st_size == 0:
            problems.append(f"figure {name} missing")
    playback = out / "playback.html"
    if html and not (playback.exists() and playback.stat().st_size > 0):
        problems.append("playback.html missing")
    if not html and playback.exists():
        problems.append("stale playback.html")
    try:
        with open(out / "timeseries.csv", newline="") as handle:
            rows = list(csv.reader(handle))
        if any(len(row) != len(rows[0]) for row in rows):
            problems.append("ragged timeseries.csv")
        if abs(float(rows[-1][0]) - summary.get("simulated_time", -1)) > 1e-9:
            problems.append("timeseries.csv and summary.json of different runs")
        if abs(float(rows[-1][0]) - duration) > 1e-6:
            problems.append(f"run of {rows[-1][0]} s where {duration} s was asked")
    except (OSError, ValueError, IndexError) as exc:
        problems.append(f"timeseries.csv unreadable: {exc}")
    return problems


def _snapshot(out: Path) -> dict[str, tuple[int, int]]:
    return {
        str(p.relative_to(out)): (p.stat().st_ino, p.stat().st_mtime_ns)
        for p in out.rglob("*")
        if p.is_file()
    }


def run_kill_section(
    work: Path, env: dict, rng: random.Random, fresh_kills: int, reused_kills: int
) -> dict:
    base = work / "kills"
    base.mkdir()
    argv = aiauv("simulate", "--duration", "1", "--quiet")
    start = time.monotonic()
    reference = base / "reference"
    subprocess.run(
        [*argv, "--out", str(reference)], env=env, cwd=work, check=True, capture_output=True
    )
    full = time.monotonic() - start
    failures = []
    tally: Counter = Counter()

    def kill_one(out: Path, html: bool, delay: float, duration: str) -> tuple[set[int], float]:
        command = aiauv("simulate", "--duration", duration, "--quiet", "--out", str(out))
        if not html:
            command.append("--no-html")
        process = subprocess.Popen(
            command, cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        time.sleep(delay)
        family = descendants(process.pid)
        process.send_signal(signal.SIGKILL)
        process.wait()
        survivors = wait_gone(family, 5.0)
        for pid in survivors:
            os.kill(pid, signal.SIGKILL)
        return survivors, delay

    for i in range(fresh_kills):
        out = base / f"fresh_{i}"
        html = rng.random() < 0.7
        delay = rng.uniform(0.05, 1.15) * full
        survivors, _ = kill_one(out, html, delay, "1")
        tally["kills"] += 1
        if survivors:
            tally["surviving children"] += 1
            failures.append(
                {
                    "kill": f"fresh {i}",
                    "delay": delay,
                    "problem": f"{len(survivors)} child(ren) survived",
                }
            )
        if out.exists():
            problems = _folder_problems(out, html, 1.0)
            tally["folder complete" if not problems else "data lost"] += 1
            if problems:
                failures.append({"kill": f"fresh {i}", "delay": delay, "problem": problems})
        else:
            tally["no folder"] += 1
    # a reused folder: an earlier complete 0.5 s run, then kills of 1 s runs, with and without html
    reused = base / "reused"
    subprocess.run(
        [*aiauv("simulate", "--duration", "0.5", "--quiet", "--out", str(reused))],
        env=env,
        cwd=work,
        check=True,
        capture_output=True,
    )
    previous = _snapshot(reused)
    for i in range(reused_kills):
        html = rng.random() < 0.5
        duration = rng.choice(["0.5", "1"])
        delay = rng.uniform(0.05, 1.15) * full
        survivors, _ = kill_one(reused, html, delay, duration)
        tally["kills in reused folder"] += 1
        if survivors:
            tally["surviving children"] += 1
            failures.append(
                {
                    "kill": f"reused {i}",
                    "delay": delay,
                    "problem": f"{len(survivors)} child(ren) survived",
                }
            )
        if not reused.exists():
            failures.append({"kill": f"reused {i}", "problem": "the earlier complete run vanished"})
            tally["data lost"] += 1
            continue
        now = _snapshot(reused)
        if now == previous:
            tally["earlier run intact"] += 1
            continue
        mixed = [name for name, key in now.items() if previous.get(name) == key]
        problems = _folder_problems(reused, html, float(duration))
        if mixed:
            problems.append(f"files of the earlier run mixed in: {mixed[:4]}")
        tally["replaced by the new run" if not problems else "data lost"] += 1
        if problems:
            failures.append({"kill": f"reused {i}", "delay": delay, "problem": problems})
        previous = now
    leftovers = [p.name for p in base.iterdir() if p.name.startswith(".")]
    # the next run into the reused folder removes what killed runs left beside it
    subprocess.run(
        [*aiauv("simulate", "--duration", "0.5", "--quiet", "--no-html", "--out", str(reused))],
        env=env,
        cwd=work,
        check=True,
        capture_output=True,
    )
    left_after = [p.name for p in base.iterdir() if p.name.startswith(".reused")]
    problems = _folder_problems(reused, False, 0.5)
    if problems or left_after:
        failures.append({"kill": "clean-up run", "problem": problems + left_after})
        tally["data lost"] += bool(problems)
    return {
        "uninterrupted_run_seconds": round(full, 2),
        "tally": dict(tally),
        "hidden_siblings_left_by_kills": len(leftovers),
        "failures": failures,
    }


# --- section 4: sweeps -------------------------------------------------------------------------------------

SWEEP_RESUME = """duration = 2.0
dt = 0.01
method = "rk4"
[grid]
k_e = [0.04, 0.06, 0.08, 0.1]
"initial_offset.y" = [1.0, 2.0]
"""


def _table(out: Path) -> list[dict]:
    with open(out / "results.csv", newline="") as handle:
        return list(csv.DictReader(handle))


_VOLATILE = ("wall_time", "real_time_factor", "worker", "started_at", "finished_at", "task_time")


def _compare_tables(reference: list[dict], resumed: list[dict]) -> list[str]:
    problems = []
    if [r["run_id"] for r in reference] != [r["run_id"] for r in resumed]:
        return ["run ids differ"]
    for a, b in zip(reference, resumed, strict=True):
        for key, value in a.items():
            if any(v in key for v in _VOLATILE):
                continue
            other = b.get(key)
            if value == other:
                continue
            try:
                x, y = float(value), float(other)
            except (TypeError, ValueError):
                problems.append(f"{a['run_id']} {key}: {value!r} vs {other!r}")
                continue
            # numba compiles a caller differently when its callees come from the disk cache: the
            # last digit or two may differ between processes (tests/results/test_kill.py)
            if not abs(x - y) <= 1e-12 * max(abs(x), abs(y)) + 1e-15:
                problems.append(f"{a['run_id']} {key}: {value} vs {other}")
    return problems


def run_sweep_section(
    work: Path, env: dict, rng: random.Random, kill_cycles: int, kills_per_cycle: int, quick: bool
) -> dict:
    base = work / "sweeps"
    base.mkdir()
    spec = base / "resume.toml"
    spec.write_text(SWEEP_RESUME)
    failures: list[dict] = []
    tally: Counter = Counter()

    def sweep(out: Path, *extra: str, spec_path: Path = spec) -> dict:
        return run_command(
            aiauv(
                "sweep",
                str(spec_path),
                "--out",
                str(out),
                "--workers",
                "1",
                "--quiet",
                "--no-plots",
                *extra,
            ),
            work,
            env,
            SWEEP_TIMEOUT,
        )

    start = time.monotonic()
    reference = sweep(base / "reference")
    full = time.monotonic() - start
    if reference["outcome"] != "ok":
        failures.append({"what": "uninterrupted sweep", **reference})
        return {"failures": failures}
    table = _table(base / "reference")
    for cycle in range(kill_cycles):
        out = base / f"resumed_{cycle}"
        command = aiauv(
            "sweep", str(spec), "--out", str(out), "--workers", "1", "--quiet", "--no-plots"
        )
        for _ in range(kills_per_cycle):
            process = subprocess.Popen(
                command, cwd=work, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
            )
            delay = rng.uniform(0.15, 0.9) * full
            time.sleep(delay)
            family = descendants(process.pid)
            process.send_signal(signal.SIGKILL)
            process.wait()
            tally["sweep kills"] += 1
            survivors = wait_gone(family, 10.0)
            for pid in survivors:
                os.kill(pid, signal.SIGKILL)
            if survivors:
                failures.append({"what": f"cycle {cycle}", "problem": "a worker survived the kill"})
            if (out / "results.csv").exists():
                for row in _table(out):
                    if row.get("status") != "complete":
                        failures.append({"what": f"cycle {cycle}", "problem": f"row {row}"})
        resumed = sweep(out)
        tally["resumes"] += 1
        if resumed["outcome"] != "ok":
            failures.append({"what": f"resume {cycle}", **resumed})
            tally["data lost"] += 1
            continue
        problems = _compare_tables(table, _table(out))
        if problems:
            failures.append({"what": f"resume {cycle}", "problem": problems[:5]})
            tally["data lost"] += 1
        else:
            tally["resumed tables exact"] += 1
    if quick:  # the kill-and-resume cycle only
        return {
            "uninterrupted_sweep_seconds": round(full, 2),
            "runs_per_sweep": len(table),
            "tally": dict(tally),
            "failures": failures,
        }
    # a killed worker: its runs are run again, not lost
    out = base / "worker_killed"
    slow = base / "slow.toml"
    slow.write_text(
        'duration = 30.0\ndt = 0.002\nmethod = "rk4"\n[grid]\nk_e = [0.05, 0.06, 0.07, 0.08]\n'
    )
    process = subprocess.Popen(
        aiauv("sweep", str(slow), "--out", str(out), "--workers", "1", "--quiet", "--no-plots"),
        cwd=work,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 300
    while not any((out / "runs").glob("*.json")) and time.monotonic() < deadline:
        time.sleep(0.1)
    killed = 0
    for pid in descendants(process.pid):
        try:
            if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes():
                os.kill(pid, signal.SIGKILL)
                killed += 1
        except OSError:
            continue
    _, err = process.communicate(timeout=SWEEP_TIMEOUT)
    records = [json.loads(p.read_text()) for p in (out / "runs").glob("*.json")]
    tally["worker kills"] += killed
    if (
        process.returncode != 0
        or len(records) != 4
        or {r["status"] for r in records} != {"complete"}
    ):
        failures.append(
            {
                "what": "killed worker",
                "status": process.returncode,
                "stderr": err[-400:],
                "records": len(records),
            }
        )
        tally["data lost"] += 1
    # two sweeps on the same --out: the second gets one line and exits non-zero
    out = base / "locked"
    first = subprocess.Popen(
        aiauv("sweep", str(slow), "--out", str(out), "--workers", "1", "--quiet", "--no-plots"),
        cwd=work,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    while not (out / ".sweep.lock").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)
    second = run_command(
        aiauv("sweep", str(slow), "--out", str(out), "--workers", "1", "--quiet", "--no-plots"),
        work,
        env,
        SWEEP_TIMEOUT,
    )
    tally["concurrent sweeps"] += 1
    if second["outcome"] != "error" or "another sweep" not in second["stderr"]:
        failures.append({"what": "second sweep on the same --out", **second})
    family = descendants(first.pid)
    first.send_signal(signal.SIGKILL)
    first.wait()
    for pid in wait_gone(family, 10.0):
        os.kill(pid, signal.SIGKILL)
    # --workers 100000
    result = run_command(
        aiauv("sweep", str(spec), "--workers", "100000", "--out", str(base / "w")), work, env
    )
    tally["--workers 100000"] += 1
    if result["outcome"] != "error":
        failures.append({"what": "--workers 100000", **result})
    # every run fails: non-zero exit, one line
    failing = base / "failing.toml"
    failing.write_text(
        'duration = 5.0\ndt = 0.5\nmethod = "rk4"\ncontroller = "none"\n[grid]\nk_e = [0.05, 0.1]\n'
    )
    result = run_command(
        aiauv(
            "sweep",
            str(failing),
            "--workers",
            "1",
            "--quiet",
            "--no-plots",
            "--out",
            str(base / "failing"),
        ),
        work,
        env,
        SWEEP_TIMEOUT,
    )
    tally["all-runs-fail sweeps"] += 1
    if result["outcome"] != "error":
        failures.append({"what": "every run fails", **result})
    # a vehicle planted in the cache under the genuine vehicle's hash is not used
    import hashlib

    from aiauv_pin.model.loading import bundled_urdf

    tmp = Path(env["TMPDIR"])
    folder = tmp / f"aiauv-sweep-vehicles-{os.getuid()}"
    genuine = bundled_urdf("uniform").read_text(encoding="utf-8")
    folder.mkdir(mode=0o700, exist_ok=True)
    digest = hashlib.sha256(genuine.encode()).hexdigest()
    planted = genuine.replace('max_thrust="50"', 'max_thrust="1"')
    (folder / f"{digest}.urdf").write_text(planted)
    result = sweep(base / "planted")
    tally["planted cache file"] += 1
    if result["outcome"] != "ok" or _compare_tables(table, _table(base / "planted")):
        failures.append({"what": "planted vehicle in the cache", **result})
        tally["data lost"] += 1
    elif (folder / f"{digest}.urdf").read_text() == planted:
        failures.append({"what": "planted vehicle left in the cache"})
    return {
        "uninterrupted_sweep_seconds": round(full, 2),
        "runs_per_sweep": len(table),
        "tally": dict(tally),
        "failures": failures,
    }


# --- shared by the issue-29 sections: forked calls, scratch special files, tallies ----------------------

#: The outcomes that are findings, by column of the per-category table (:func:`summarise`).
FINDING_COLUMNS = {
    "tracebacks": ("traceback", "internal error", "foreign exception"),
    "crashes": ("crash",),
    "hangs": ("hang",),
    "messy_errors": ("messy error", "forged output", "late failure"),
    "accepted_bad_inputs": ("accepted bad input",),
    "silently_wrong": ("silently wrong", "non-finite result", "backends disagree"),
    "code_executed": ("code executed",),
    "files_lost": ("files lost",),
}

#: The loop of every forked-call worker: each case runs in a child (a SIGSEGV or a hang is
#: counted, not fatal); ``describe`` turns a returned value into a JSON-able record.
FORK_LOOP = r"""
import json, os, select, signal, time
from aiauv_pin.errors import AiauvError

#: The exceptions that count as the project's own (a script may add a layer's own error).
PROJECT_ERRORS = (AiauvError,)

def _child(fn, describe, write_end):
    try:
        message = describe(fn())
    except BaseException as exc:
        message = {"kind": "exception", "type": type(exc).__name__,
                   "aiauv": isinstance(exc, PROJECT_ERRORS), "message": str(exc)[:1000]}
    os.write(write_end, json.dumps(message, default=str).encode())
    os._exit(0)

def run_forked(cases, describe, timeout, out_path):
    results = []
    for label, expect, fn in cases:
        read_end, write_end = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(read_end)
            _child(fn, describe, write_end)
        os.close(write_end)
        chunks, start, timed_out = [], time.monotonic(), False
        while True:
            if time.monotonic() - start > timeout:
                os.kill(pid, signal.SIGKILL)
                timed_out = True
                break
            ready, _, _ = select.select([read_end], [], [], 0.5)
            if ready:
                data = os.read(read_end, 1 << 16)
                if not data:
                    break
                chunks.append(data)
        os.close(read_end)
        _, status = os.waitpid(pid, 0)
        record = {"case": label, "expect": expect, "seconds": round(time.monotonic() - start, 2)}
        if timed_out:
            record["kind"] = "hang"
        elif os.WIFSIGNALED(status) and not chunks:
            record["kind"], record["signal"] = "crash", os.WTERMSIG(status)
        else:
            try:
                record.update(json.loads(b"".join(chunks).decode()))
            except ValueError:
                record["kind"] = "crash"
        results.append(record)
    with open(out_path, "w") as handle:
        json.dump(results, handle)
"""


def run_worker(script: str, work: Path, env: dict, args: list[str], timeout: float) -> list | None:
    """Run a forked-call worker script; its records, or None if the worker itself failed."""
    path = work / f"worker_{abs(hash(script)) % 10**8}.py"
    path.write_text(FORK_LOOP + script, encoding="utf-8")
    out = work / f"{path.stem}_{len(list(work.glob(path.stem + '_*.json')))}.json"
    result = run_command([sys.executable, str(path), str(out), *args], work, env, timeout)
    if result["status"] != 0 or not out.exists():
        print(f"worker {path.name} {args} failed: {result['stderr'][-1500:]}", flush=True)
        return None
    return json.loads(out.read_text())


def forked_outcome(record: dict) -> str:
    """ok / error, or a finding: crash, hang, foreign exception, messy error, accepted bad input."""
    kind, expect = record["kind"], record["expect"]
    if kind in ("crash", "hang"):
        return kind
    if kind == "exception":
        message = record["message"]
        if not record["aiauv"]:
            return "foreign exception"
        if "\n" in message or len(message) > 400 or not message.strip():
            return "messy error"
        return "refused good input" if expect == "good" else "error"
    if expect == "bad":
        return "accepted bad input"
    if record.get("finite") is False:
        return "non-finite result"
    return "ok"


def tally_section(records: list[dict], findings: list[dict], extra: dict | None = None) -> dict:
    """A section's report: runs, outcomes, failures (records whose outcome is a finding)."""
    outcomes = Counter(r["outcome"] for r in records)
    return {
        "runs": len(records),
        "outcomes": dict(sorted(outcomes.items())),
        **(extra or {}),
        "failures": findings,
    }


def _is_finding(outcome: str) -> bool:
    return outcome not in ("ok", "error", "refused good input")


def snapshot(root: Path) -> dict[str, tuple]:
    """Every entry under ``root``, never following links: kind and content or link target."""
    import hashlib
    import stat

    found = {}
    for top, dirs, names in os.walk(root, followlinks=False):
        for name in dirs + names:
            path = Path(top) / name
            mode = os.lstat(path).st_mode
            key = str(path.relative_to(root))
            if stat.S_ISLNK(mode):
                found[key] = ("link", os.readlink(path))
            elif stat.S_ISREG(mode):
                found[key] = (
                    "file",
                    os.lstat(path).st_ino,
                    hashlib.sha256(path.read_bytes()).hexdigest(),
                )
            elif stat.S_ISDIR(mode):
                found[key] = ("dir",)
            else:
                found[key] = ("special", stat.S_IFMT(mode))
    return found


def make_socket(path: Path) -> None:
    """A UNIX socket file at ``path``: with a FIFO, the stand-in for a device node (this script
    never touches ``/dev``; a real character device cannot be made without privileges)."""
    import socket

    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(path))
    server.close()  # the socket file stays


class ZeroFeeder:
    """A FIFO standing in for ``/dev/zero``: a thread writes zeros to whoever opens it to read."""

    def __init__(self, path: Path, data: bytes = b"\0" * 65536) -> None:
        import threading

        os.mkfifo(path)
        self.path, self.data, self.stop = path, data, threading.Event()
        self.thread = threading.Thread(target=self._feed, daemon=True)
        self.thread.start()

    def _feed(self) -> None:
        while not self.stop.is_set():
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader yet (ENXIO)
                time.sleep(0.05)
                continue
            os.set_blocking(fd, True)
            try:
                while not self.stop.is_set():
                    os.write(fd, self.data)
            except OSError:  # the reader went away (EPIPE)
                pass
            finally:
                os.close(fd)

    def close(self) -> None:
        self.stop.set()


# --- section 5: hostile xacro expressions and includes (issue 29 point 1 and 5) ---------------------------

XACRO_HEAD = '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
#: The two-link vehicle's body: a file whose harmless expressions give a usable vehicle.
XACRO_BODY = TWO_LINK.split("<robot", 1)[1].split(">", 1)[1].rsplit("</robot>", 1)[0]
#: Code-execution attempts; MARK is the marker file the payload would create, if it ran.
XACRO_ESCAPES = {
    "python.vars to _module": "python.vars(python.vars([c for c in python.vars(python.type)"
    "['__subclasses__'](python.type.mro(python.type(0))[-1]) if 'catch_warnings' in "
    "python.str(c)][0]()._module)['sys']).get('modules')['os'].system('touch MARK')",
    "__import__": "__import__('os').system('touch MARK')",
    "__builtins__": "__builtins__['__import__']('os').system('touch MARK')",
    "dunder class chain": "[c for c in ().__class__.__base__.__subclasses__() "
    "if c.__name__ == 'catch_warnings'][0]()._module.sys.modules['os'].system('touch MARK')",
    "open": "open('MARK', 'w').write('x')",
    "lambda": "(lambda: open('MARK', 'w'))()",
    "comprehension": "[open('MARK', 'w') for i in [1]]",
    "python.open": "python.open('MARK', 'w')",
    "python.eval": "python.eval(\"__import__('os').system('touch MARK')\")",
    "python.exec": "python.exec(\"import os; os.system('touch MARK')\")",
    "python.getattr": "python.getattr(python, 'open')('MARK', 'w')",
    "python.vars(python)": "python.vars(python)['open']('MARK', 'w')",
    "python.globals": "python.globals()['__builtins__']",
    "xacro.os": "xacro.os.system('touch MARK')",
    "xacro.sys": "xacro.sys.modules['os'].system('touch MARK')",
    "xacro.subprocess": "xacro.subprocess.call(['touch', 'MARK'])",
    "xacro.load_yaml": "xacro.load_yaml('MARK')",
    "math.__loader__": "math.__loader__.load_module('os').system('touch MARK')",
    "format attribute": "'{0.__class__.__init__.__globals__}'.format(xacro)",
    "getattr chain": "python.type(0).mro()[-1].__subclasses__()",
    "str.format_map": "'{x.__globals__}'.format_map({'x': xacro.load_yaml})",
    "os.system name": "os.system('touch MARK')",
    "sys.modules": "sys.modules['os'].system('touch MARK')",
    "vars()": "vars()['__builtins__']",
    "globals()": "globals()['__builtins__']['open']('MARK', 'w')",
    "walrus": "[(o := open), o('MARK', 'w')]",
}
#: Where an expression may sit in a xacro file (``{e}`` is the expression).
XACRO_PLACES = {
    "attribute": '<gazebo><x v="${{{e}}}"/></gazebo>',
    "text": "<gazebo><x>${{{e}}}</x></gazebo>",
    "property": '<xacro:property name="p" value="${{{e}}}"/><gazebo><x v="${{p}}"/></gazebo>',
    "lazy property": '<xacro:property name="p" value="${{{e}}}" lazy_eval="false"/>',
    "if": '<xacro:if value="${{{e}}}"><gazebo/></xacro:if>',
    "macro default": '<xacro:macro name="m" params="a:=${{{e}}}"><x v="${{a}}"/></xacro:macro>'
    "<gazebo><xacro:m/></gazebo>",
    "element name": '<gazebo><xacro:element xacro:name="${{{e}}}"/></gazebo>',
    "include filename": '<xacro:include filename="${{{e}}}"/>',
    "eval substitution": '<xacro:property name="p" value="{r}"/><gazebo><x v="$(eval ${{p}})"/></gazebo>',
}
XACRO_BOMBS = {
    "9**9**9": "9**9**9", "9.0**9**9": "9.0**9**9", "(10**300)**(10**300)": "(10**300)**(10**300)",
    "2**1000 cubed": "(2**1000) * (2**1000) * (2**1000)", "shift": "1 << 10**9",
    "string": "'a' * 10**9", "list": "[0] * 10**9", "format width": "'%0999999999d' % 1",
    "3000 terms": "+".join(["1"] * 3000), "20000 digits": "1" * 20_000,
    "int of 5000 digits": "int('9' * 5000)", "factorial": "math.factorial(10**6)",
    "nested lists": "[" * 500 + "]" * 500, "range list": "list(range(10**9))",
    "string repeat in join": "','.join(['x'] * 10**8)",
}  # fmt: skip


def _xacro_escape(value: str) -> str:
    return value.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;")


def _xacro_file(folder: Path, name: str, body: str) -> Path:
    path = folder / name
    path.write_text(f'<?xml version="1.0"?>\n{XACRO_HEAD}{XACRO_BODY}{body}</robot>\n')
    return path


def _doubling_macros(leaf: str, levels: int = 30) -> str:
    macros = f'<xacro:macro name="m0">{leaf}</xacro:macro>'
    for level in range(1, levels + 1):
        macros += (
            f'<xacro:macro name="m{level}"><xacro:m{level - 1}/><xacro:m{level - 1}/></xacro:macro>'
        )
    return macros + f"<xacro:m{levels}/>"


def make_xacro_cases(folder: Path, rng: random.Random, scale: float) -> list[dict]:
    """Every hostile xacro file: dicts with label, path, marker, expect (bad, either)."""
    folder.mkdir(parents=True, exist_ok=True)
    markers = folder / "markers"
    markers.mkdir(exist_ok=True)
    cases: list[dict] = []

    def add(label: str, body: str | None, expect: str, path: Path | None = None, **extra) -> dict:
        index = len(cases)
        marker = markers / f"m{index}"
        if path is None:
            path = _xacro_file(folder, f"x{index:04d}.xacro", body.replace("MARK", str(marker)))
        case = {"label": label, "path": str(path), "marker": str(marker), "expect": expect, **extra}
        cases.append(case)
        return case

    for name, expression in XACRO_ESCAPES.items():
        for place, template in XACRO_PLACES.items():
            if place == "eval substitution":  # $(eval) cannot hold ')': a property brings it
                body = template.format(r=_xacro_escape(repr(expression.replace("'", '"'))))
            else:
                body = template.format(e=_xacro_escape(expression))
            case = add(f"escape {name} in {place}", body, "bad")
            # the positive control: the same payload under full xacro (trust) must leave its
            # marker when it can run at all (it shows the marker would catch an escape)
            trusted = Path(case["path"]).with_suffix(".trusted.xacro")
            trusted.write_text(
                Path(case["path"]).read_text().replace(case["marker"], case["marker"] + ".trusted")
            )
            case["trusted_path"] = str(trusted)
    for name, expression in XACRO_BOMBS.items():
        for place in ("attribute", "property") if scale >= 1 else ("attribute",):
            add(
                f"bomb {name} in {place}",
                XACRO_PLACES[place].format(e=_xacro_escape(expression)),
                "bad",
            )
    expansion = {
        "doubling macro 2^30": _doubling_macros('<link name="x"/>'),
        "doubling empty macro 2^30": _doubling_macros(""),
        "doubling macro 2^60": _doubling_macros("", 60),
        "doubling block": '<xacro:macro name="b" params="*x"><a><xacro:insert_block name="x"/>'
        '<xacro:insert_block name="x"/></a></xacro:macro>' + "<xacro:b>" * 25 + "<y/>" + "</xacro:b>" * 25,
        "recursive macro": '<xacro:macro name="m"><xacro:m/></xacro:macro><xacro:m/>',
        "mutual macros": '<xacro:macro name="a"><xacro:b/></xacro:macro>'
        '<xacro:macro name="b"><xacro:a/></xacro:macro><xacro:a/>',
        "property chain 3000": "".join(
            f'<xacro:property name="p{i}" value="${{p{i - 1} + 1}}"/>' for i in range(1, 3000)
        ) + '<xacro:property name="p0" value="1"/><x v="${p2999}"/>',
        "string doubling 2^39": '<xacro:property name="s0" value="ab"/>' + "".join(
            f'<xacro:property name="s{i}" value="${{s{i - 1} + s{i - 1}}}"/>' for i in range(1, 40)
        ) + '<x v="${s39}"/>',
        "self-referencing property": '<xacro:property name="p" value="${p}"/><x v="${p}"/>',
    }  # fmt: skip
    for name, body in expansion.items():
        add(f"expansion {name}", body, "bad")
    # hostile includes: a FIFO, a 200 MB and a 2 GB sparse file, a folder, a socket, a zero-feeding
    # FIFO (the stand-in for /dev/zero), self, mutual, doubling includes (4096 files)
    special = folder / "special"
    special.mkdir(exist_ok=True)
    os.mkfifo(special / "fifo.xacro")
    for name, size in (("huge.xacro", 200_000_000), ("huge2g.xacro", 2_000_000_000)):
        with open(special / name, "wb") as handle:
            handle.truncate(size)  # sparse: no disk used
    (special / "folder.xacro").mkdir(exist_ok=True)
    make_socket(special / "socket.xacro")
    includes = {
        "FIFO": special / "fifo.xacro", "200 MB": special / "huge.xacro",
        "2 GB": special / "huge2g.xacro", "folder": special / "folder.xacro",
        "socket": special / "socket.xacro", "zero FIFO": special / "zero.xacro",
        "missing": special / "missing.xacro",
    }  # fmt: skip
    for name, target in includes.items():
        add(f"include {name}", f'<xacro:include filename="{target}"/>', "bad")
    add(
        "include self",
        None,
        "bad",
        path=_xacro_file(folder, "self.xacro", '<xacro:include filename="self.xacro"/>'),
    )
    (folder / "ping.xacro").write_text(
        f'{XACRO_HEAD}<xacro:include filename="pong.xacro"/></robot>'
    )
    (folder / "pong.xacro").write_text(
        f'{XACRO_HEAD}<xacro:include filename="ping.xacro"/></robot>'
    )
    add("include ping-pong", None, "bad", path=folder / "ping.xacro")
    for level in range(12):
        (folder / f"d{level}.xacro").write_text(
            XACRO_HEAD + f'<xacro:include filename="d{level + 1}.xacro"/>' * 2 + "</robot>"
        )
    (folder / "d12.xacro").write_text(XACRO_HEAD + "</robot>")
    add("include doubling 2^12", None, "bad", path=folder / "d0.xacro")
    add("top file FIFO", None, "bad", path=special / "fifo.xacro")
    add("top file zero FIFO", None, "bad", path=special / "zero.xacro")
    add("top file 2 GB", None, "bad", path=special / "huge2g.xacro")
    # random compositions of dangerous and harmless pieces (fixed seed)
    for index in range(int(1500 * scale)):
        parts = [
            rng.choice(RANDOM_PIECES) + rng.choice(RANDOM_SUFFIXES)
            for _ in range(rng.randint(1, 4))
        ]
        expression = parts[0]
        for part in parts[1:]:
            expression += rng.choice(RANDOM_JOINS) + part
        place = rng.choice(["attribute", "property", "if", "macro default", "text"])
        body = (
            '<xacro:property name="n" value="2"/><xacro:property name="s" value="ab"/>'
            '<xacro:property name="l" value="${[1, 2, 3]}"/>'
            + XACRO_PLACES[place].format(e=_xacro_escape(expression))
        )
        add(f"random {index}", body, "either", expression=expression)
    return cases


RANDOM_PIECES = [
    "python", "xacro", "math", "__import__", "open", "eval", "exec", "getattr", "vars", "type",
    "globals", "python.vars", "python.type", "xacro.load_yaml", "math.sin", "math.factorial",
    "__builtins__", "os", "sys", "xacro.os", "().__class__", "''.__class__", "[].__class__",
    "pi", "n", "s", "l", "1", "2.5", "-3", "'a'", "'touch MARK'", "[1, 2]", "(1, 2)", "True",
    "9**9**9", "10**400", "2.0**4096", "'a'*10**9", "[0]*10**9", "[l]*10**5", "1 << 10**9",
    "'%0999999999d' % 1", "sin(n)", "radians(n)", "sqrt(-1)", "max(l)", "len(s)", "int('9'*5000)",
    "dict(a=1)", "n if n > 1 else -n", "not n", "n == 1 and s", "lambda: 1", "[x for x in l]",
    "{'a': 1}", "s.upper", "s.format", "'{0}'.format", "l.__len__", "math.__dict__",
]  # fmt: skip
RANDOM_JOINS = [
    " + ",
    " * ",
    " ** ",
    " - ",
    " / ",
    " // ",
    " % ",
    " and ",
    " or ",
    " < ",
    " == ",
    " in ",
]
RANDOM_SUFFIXES = [
    "", ".__class__", "._module", ".mro()", ".system('touch MARK')", "[0]", "(1)", "()",
    ".__globals__", ".__subclasses__()", "('MARK', 'w')", ".__dict__",
]  # fmt: skip

XACRO_WORKER = r"""
import sys
import aiauv_pin
from aiauv_pin.description.xacro_loading import expand_xacro
cases = json.load(open(sys.argv[2]))
calls = [(c["label"], c["expect"], lambda c=c: expand_xacro(c["path"])) for c in cases]
calls += [
    ("trusted: " + c["label"], "either", lambda c=c: expand_xacro(c["trusted_path"], trust=True))
    for c in cases
    if "trusted_path" in c
]
run_forked(calls, lambda value: {"kind": "ok"}, 60.0, sys.argv[1])
"""


def run_xacro_section(work: Path, env: dict, rng: random.Random, scale: float) -> dict:
    folder = work / "xacro"
    cases = make_xacro_cases(folder, rng, scale)
    feeder = ZeroFeeder(folder / "special" / "zero.xacro")
    records: list[dict] = []
    findings: list[dict] = []
    try:
        # the API route (expand_xacro), each file in a forked child
        listing = work / "xacro_cases.json"
        listing.write_text(json.dumps(cases))
        forked = run_worker(XACRO_WORKER, work, env, [str(listing)], 3600) or []
        by_label = {r["case"]: r for r in forked}
        controls = [c for c in cases if "trusted_path" in c]
        live = [c["label"] for c in controls if Path(c["marker"] + ".trusted").exists()]
        for case in cases:
            record = by_label.get(
                case["label"], {"kind": "worker failed", "expect": case["expect"]}
            )
            outcome = (
                "worker failed" if record["kind"] == "worker failed" else forked_outcome(record)
            )
            if Path(case["marker"]).exists():
                outcome = "code executed"
                Path(case["marker"]).unlink()
            records.append({"route": "expand_xacro", "outcome": outcome})
            if _is_finding(outcome):
                findings.append(
                    {
                        "route": "expand_xacro",
                        "case": case["label"],
                        "path": case["path"],
                        "outcome": outcome,
                        "message": record.get("message", "")[:300],
                    }
                )
        # the command line: every fixed payload, a sample of the random ones, and the routes a
        # scenario, a sweep and --arg open to a vehicle file
        fixed = [c for c in cases if not c["label"].startswith("random")]
        sample = rng.sample(
            [c for c in cases if c["label"].startswith("random")],
            min(int(60 * scale) or 3, len(cases) - len(fixed)),
        )
        chosen = fixed if scale >= 1 else fixed[::6]
        runs = [(c, ["check", c["path"]]) for c in chosen + sample]
        escape = next(c for c in cases if c["label"] == "escape __import__ in attribute")
        trojan = next(
            c for c in cases if c["label"] == "escape python.vars to _module in eval substitution"
        )
        for c in (escape, trojan):
            scenario = folder / f"scenario_{Path(c['path']).stem}.toml"
            scenario.write_text(f'vehicle = "{c["path"]}"\nduration = 0.1\n')
            sweep = folder / f"sweep_{Path(c['path']).stem}.toml"
            sweep.write_text(
                f'vehicle = "{c["path"]}"\nduration = 0.1\ndt = 0.01\n[grid]\nk_e = [0.05, 0.1]\n'
            )
            runs.append(
                (
                    c,
                    [
                        "simulate",
                        str(scenario),
                        "--quiet",
                        "--no-html",
                        "--out",
                        str(folder / f"out_{len(runs)}"),
                    ],
                )
            )
            runs.append(
                (
                    c,
                    [
                        "simulate",
                        "--vehicle",
                        c["path"],
                        "--duration",
                        "0.1",
                        "--quiet",
                        "--out",
                        str(folder / f"out_{len(runs)}"),
                    ],
                )
            )
            runs.append(
                (
                    c,
                    [
                        "sweep",
                        str(sweep),
                        "--workers",
                        "1",
                        "--quiet",
                        "--no-plots",
                        "--out",
                        str(folder / f"sw_{len(runs)}"),
                    ],
                )
            )
            runs.append((c, ["annotate", c["path"], "-o", str(folder / f"a_{len(runs)}.urdf")]))
            runs.append((c, ["export", c["path"], "-o", str(folder / f"e_{len(runs)}.sdf")]))
            runs.append((c, ["linearize", str(scenario)]))
        marker = folder / "markers" / "arg"
        argument = _xacro_file(
            folder,
            "argument.xacro",
            '<xacro:arg name="x" default="1"/><gazebo><x v="$(arg x)" w="${xacro.arg(\'x\')}"/></gazebo>',
        )
        arg_case = {
            "label": "--arg payload",
            "path": str(argument),
            "marker": str(marker),
            "expect": "either",
        }
        for payload in (
            "${__import__('os').system('touch MARK')}",
            "$(eval __import__('os').system('touch MARK'))",
        ):
            runs.append(
                (
                    arg_case,
                    ["check", str(argument), "--arg", "x=" + payload.replace("MARK", str(marker))],
                )
            )
        print(
            f"xacro: {len(cases)} files through expand_xacro, {len(runs)} command lines", flush=True
        )

        def execute(item):
            case, argv = item
            result = run_command(aiauv(*argv), work, env, TIMEOUT)
            return case, result

        with ThreadPoolExecutor(PARALLEL) as pool:
            done = list(pool.map(execute, runs))
        for case, result in done:
            outcome = result["outcome"]
            if outcome == "ok" and case["expect"] == "bad":
                outcome = "accepted bad input"
            if Path(case["marker"]).exists():
                outcome = "code executed"
                Path(case["marker"]).unlink()
            records.append({"route": result["argv"][0], "outcome": outcome})
            if _is_finding(outcome):
                findings.append(
                    {
                        "route": "cli",
                        "case": case["label"],
                        "argv": result["argv"],
                        "outcome": outcome,
                        "stderr": result["stderr"][-400:],
                    }
                )
    finally:
        feeder.close()
    cli = Counter(r["outcome"] for r in records if r["route"] != "expand_xacro")
    return tally_section(
        records,
        findings,
        {
            "files": len(cases),
            "positive_controls": {
                "escapes run with --trust-xacro": len(controls),
                "of them leaving their marker (code ran)": len(live),
                "live payloads": sorted({label.split(" in ")[0] for label in live}),
            },
            "outcomes_command_line": dict(cli),
            "seconds_slowest_expansion": max((r.get("seconds", 0) for r in forked), default=None),
        },
    )


# --- section 6: special outputs of every writing command (issue 29 point 2 and 4) -------------------------


class DrainReader:
    """A FIFO with a reader that discards what it gets: the stand-in for ``/dev/null``."""

    def __init__(self, path: Path) -> None:
        import threading

        os.mkfifo(path)
        self.fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._drain, daemon=True)
        self.thread.start()

    def _drain(self) -> None:
        import select

        while not self.stop.is_set():
            ready, _, _ = select.select([self.fd], [], [], 0.1)
            if ready:
                try:
                    os.read(self.fd, 1 << 16)
                except OSError:
                    pass

    def close(self) -> None:
        self.stop.set()
        self.thread.join()
        os.close(self.fd)


#: File writers: suffix of the output and the command line (i: the inputs, out: the output).
FILE_WRITERS = {
    "build": (".urdf", lambda i, out: ["build", i["spec"], "-o", out]),
    "annotate": (".urdf", lambda i, out: ["annotate", i["urdf"], "-o", out]),
    "export sdf": (".sdf", lambda i, out: ["export", i["urdf"], "-o", out]),
    "export mjcf": (".xml", lambda i, out: ["export", i["urdf"], "-o", out]),
    "import-gz": (".urdf", lambda i, out: ["import-gz", i["sdf"], "--urdf", i["urdf"], "-o", out]),
    "bench": (".json", lambda i, out: ["bench", "--quick", "--out", out]),
}
FOLDER_WRITERS = {
    "simulate --out": lambda i, out: [
        "simulate",
        "--duration",
        "0.1",
        "--no-html",
        "--quiet",
        "--out",
        out,
    ],
    "sweep --out": lambda i, out: [
        "sweep",
        i["sweep"],
        "--workers",
        "1",
        "--quiet",
        "--no-plots",
        "--out",
        out,
    ],
}


def _output_targets(root: Path, suffix: str, folder_writer: str | None) -> tuple[dict, list]:
    """Hostile output paths in ``root/work`` (expect: refuse, or ok for a regular file), with
    ``root/outside`` holding what links point at; and the helpers to close afterwards."""
    from aiauv_pin._internal.result_folder import claim_folder, staged_folder

    work, outside = root / "work", root / "outside"
    work.mkdir(parents=True)
    outside.mkdir()
    (outside / f"precious{suffix}").write_text("precious bytes\n")
    (outside / "keep.png").write_text("keep")
    os.mkfifo(outside / "pipe")
    make_socket(outside / "sock")
    helpers: list = []
    targets: dict[str, tuple[Path, str]] = {}

    def target(name: str, expect: str = "refuse") -> Path:
        path = work / f"{re.sub(r'[^A-Za-z0-9.]+', '_', name)}{suffix}"
        targets[name] = (path, expect)
        return path

    os.mkfifo(target("FIFO"))
    helpers.append(DrainReader(target("FIFO with a reader (/dev/null stand-in)")))
    make_socket(target("socket (device stand-in)"))
    target("link to a file outside").symlink_to(outside / f"precious{suffix}")
    target("link to a FIFO").symlink_to(outside / "pipe")
    target("link to a socket").symlink_to(outside / "sock")
    target("dangling link").symlink_to(outside / f"nothing{suffix}")
    target("link to a folder outside").symlink_to(outside)
    if folder_writer is None:
        folder = target("folder")
        folder.mkdir()
        (folder / "inside.txt").write_text("kept\n")
        regular = target("regular file with a second name", "ok")
        regular.write_text("old bytes\n")
        os.link(regular, work / "second_name")
        return targets, helpers
    target("regular file").write_text("a file\n")
    hidden = target("folder of hidden entries only (.git)")
    (hidden / ".git").mkdir(parents=True)
    (hidden / ".git" / "HEAD").write_text("ref: refs/heads/main\n")
    (hidden / ".env").write_text("SECRET=1\n")
    foreign = target("folder with a foreign summary.json and results.csv")
    foreign.mkdir()
    (foreign / "summary.json").write_text('{"status": "complete"}')
    (foreign / "results.csv").write_text("mine\n")
    other = target("folder with a user's file")
    other.mkdir()
    (other / "notes.txt").write_text("mine\n")
    kind = "simulate" if folder_writer.startswith("simulate") else "sweep"
    if kind == "simulate":
        for planted, link in (
            ("figures", outside),
            ("summary.json", outside / "keep.png"),
            ("timeseries.csv", outside / f"precious{suffix}"),
        ):
            ours = target(f"our result folder with {planted} a link outside")
            with staged_folder(ours) as staging:
                (staging / "summary.json").write_text("{}")
                (staging / "timeseries.csv").write_text("t\n0\n")
                (staging / "figures").mkdir()
                (staging / "figures" / "a.png").write_text("a")
            victim = ours / planted
            shutil.rmtree(victim) if victim.is_dir() else victim.unlink()
            victim.symlink_to(link)
        ours = target("our result folder with the manifest a link")
        with staged_folder(ours) as staging:
            (staging / "summary.json").write_text("{}")
        from aiauv_pin._internal.result_folder import MARKER

        (outside / "forged.json").write_text(
            json.dumps(
                {
                    "written_by": "aiauv-pin",
                    "kind": "simulate",
                    "files": [str(outside / "keep.png"), "../outside/keep.png"],
                    "folders": [".."],
                }
            )
        )
        (ours / MARKER).unlink()
        (ours / MARKER).symlink_to(outside / "forged.json")
    else:
        for planted in ("runs", "figures", ".sweep.lock"):
            ours = target(f"our sweep folder with {planted} a link outside")
            claim_folder(ours, "sweep")
            (ours / planted).symlink_to(outside if planted != ".sweep.lock" else outside / "pipe")
        ours = target("our sweep folder with a FIFO lock")
        claim_folder(ours, "sweep")
        os.mkfifo(ours / ".sweep.lock")
    return targets, helpers


def run_outputs_section(work: Path, env: dict, rng: random.Random, scale: float) -> dict:
    base = work / "outputs29"
    base.mkdir()
    inputs = {
        "urdf": str(ROOT / "urdf" / "paper_uniform.urdf"),
        "spec": str(ROOT / "urdf" / "paper_uniform.toml"),
        "sdf": str(base / "paper.sdf"),
        "sweep": str(base / "sweep.toml"),
    }
    (base / "sweep.toml").write_text("duration = 0.1\ndt = 0.01\n[grid]\nk_e = [0.05, 0.08]\n")
    exported = run_command(aiauv("export", inputs["urdf"], "-o", inputs["sdf"]), work, env)
    if exported["outcome"] != "ok":
        return {"runs": 0, "failures": [{"what": "export of the input SDF", **exported}]}
    plans = []
    variants = ("absolute", "relative") if scale >= 1 else ("absolute",)
    writers = [(name, suffix, argv, None) for name, (suffix, argv) in FILE_WRITERS.items()]
    writers += [(name, "", argv, name) for name, argv in FOLDER_WRITERS.items()]
    helpers: list = []
    for name, suffix, argv, folder_writer in writers:
        for variant in variants:
            root = base / f"{name.replace(' ', '_').replace('--', '')}_{variant}"
            targets, more = _output_targets(root, suffix, folder_writer)
            helpers += more
            items = sorted(targets.items())
            rng.shuffle(items)
            if scale < 1:
                items = items[::3]
            for label, (path, expect) in items:
                if name == "bench" and expect == "ok":
                    continue  # a real benchmark run: not what this section tries
                shown = os.path.relpath(path, root / "work") if variant == "relative" else str(path)
                plans.append(
                    {
                        "writer": name,
                        "variant": variant,
                        "target": label,
                        "expect": expect,
                        "root": root,
                        "path": path,
                        "argv": [str(a) for a in argv(inputs, shown)],
                    }
                )
    print(f"outputs: {len(plans)} runs", flush=True)
    records, findings = [], []
    try:
        for plan in plans:  # one at a time: each compares its scratch tree before and after
            before = snapshot(plan["root"])
            cwd = plan["root"] / "work" if plan["variant"] == "relative" else work
            result = run_command(aiauv(*plan["argv"]), cwd, env, TIMEOUT)
            after = snapshot(plan["root"])
            key = str(plan["path"].relative_to(plan["root"]))
            changed = sorted(
                k for k in before.keys() | after.keys() if before.get(k) != after.get(k)
            )
            outcome = result["outcome"]
            lost = [k for k in changed if k in before]
            if plan["expect"] == "ok":
                lost = [k for k in lost if k != key]
                litter = [k for k in changed if k not in before]
                if outcome == "ok" and (
                    after.get(key, ("",))[0] != "file" or after[key] == before[key]
                ):
                    outcome = "silently wrong"  # said ok, did not write
            else:
                litter = [k for k in changed if k not in before]
                if outcome == "ok":
                    outcome = "accepted bad input"
            if lost:
                outcome = "files lost"
            elif litter:
                outcome = "files lost"  # left behind (a temporary file, a folder it made)
            if plan["expect"] == "ok":
                (plan["root"] / "work" / "second_name").unlink(missing_ok=True)
                plan["path"].write_text("old bytes\n")
                os.link(plan["path"], plan["root"] / "work" / "second_name")
            records.append({"outcome": outcome})
            if _is_finding(outcome) or (plan["expect"] == "ok" and outcome != "ok"):
                findings.append(
                    {
                        "writer": plan["writer"],
                        "target": plan["target"],
                        "variant": plan["variant"],
                        "argv": plan["argv"],
                        "outcome": outcome,
                        "changed": changed[:6],
                        "stderr": result["stderr"][-400:],
                    }
                )
    finally:
        for helper in helpers:
            helper.close()
    by_writer = Counter()
    for plan, record in zip(plans, records, strict=False):
        by_writer[f"{plan['writer']}: {record['outcome']}"] += 1
    return tally_section(
        records,
        findings,
        {
            "by_writer": dict(sorted(by_writer.items())),
            "devices": "stood in for by FIFOs and UNIX sockets in a scratch folder; /dev is never touched",
        },
    )


# --- section 7: every compiled entry point with bad arguments, each call forked (issue 29 point 3) --------

ENTRY_WORKER = r'''
import collections, ctypes, dataclasses, mmap, sys
import numba
import numpy as np
import aiauv_pin
import aiauv_pin.dynamics.linear_model
import aiauv_pin.dynamics.transitions
from aiauv_pin.kernels.records import Servo
from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.model.derivatives import compiled_derivatives
from aiauv_pin.dynamics.linear_model import Trim
from aiauv_hydro.currents import Current, constant_current, tidal_current
from aiauv_hydro.spec import HydroError

PROJECT_ERRORS = (AiauvError, HydroError)  # HydroError: the hydro layer's own (a ValueError)
backend, every = sys.argv[2], int(sys.argv[3])
rng = np.random.default_rng(20261127)
vehicle = aiauv_pin.load_vehicle(backend=backend)
fast = vehicle.fast
nq, nv, m = vehicle.nq, vehicle.nv, len(vehicle.thruster_names)
q0, v0, tau0 = vehicle.neutral_configuration(), 0.1 * rng.normal(size=nv), np.zeros(nv)

page = mmap.PAGESIZE
guard = mmap.mmap(-1, 2 * page)
address = ctypes.addressof(ctypes.c_char.from_buffer(guard))
libc = ctypes.CDLL(None, use_errno=True)
assert libc.mprotect(ctypes.c_void_p(address + page), ctypes.c_size_t(page), 0) == 0

def at_guard(values):
    """A copy of ``values`` ending exactly where an unreadable page begins."""
    n = len(values)
    array = np.frombuffer(guard, dtype=np.float64, count=n, offset=page - 8 * n)
    array[:] = values
    return array

def bad_arrays(good):
    n = good.shape[0]
    nan, inf = good.copy(), good.copy()
    nan[rng.integers(n)] = np.nan
    inf[rng.integers(n)] = -np.inf
    k = int(rng.integers(2, 50))
    return {
        "too long": np.concatenate((good, [0.0])), "too short": good[:-1].copy(),
        f"{k} too long": np.concatenate((good, np.zeros(k))), "one entry": good[:1].copy(),
        "complex": good.astype(complex) + 1j, "object": np.array(list(good) + [None], dtype=object)[:n],
        "nan": nan, "inf": inf, "string": "abc", "bytes": b"abc" * n, "2-D": good[None, :],
        "column": good[:, None], "empty": np.zeros(0), "none": None, "scalar": np.float64(0.0),
        "dict": {"a": 1}, "ragged": [[1.0], [2.0, 3.0]], "guard short": at_guard(good[:-1]),
        "strings": ["a"] * n, "datetime": np.zeros(n, dtype="datetime64[s]"),
    }

def convertible_arrays(good):
    strided = np.zeros(2 * good.shape[0])
    strided[::2] = good
    readonly = good.copy()
    readonly.setflags(write=False)
    return {
        "int32": np.round(good).astype(np.int32), "non-contiguous": strided[::2], "list": list(good),
        "float32": good.astype(np.float32), "big-endian": good.astype(">f8"), "read-only": readonly,
        "guard exact": at_guard(good), "tuple": tuple(good), "bool": good.astype(bool),
    }

cases = []
def case(kind, call, must_fail=True):
    cases.append((kind, "bad" if must_fail else "either", call))

entries = {
    "fast.acceleration": lambda q, v, tau: fast.acceleration(q, v, tau),
    "fast.acceleration(current)": lambda q, v, tau: fast.acceleration(q, v, tau, np.array([0.1, 0.0, 0.0])),
    "fast.step": lambda q, v, tau: fast.step(q, v, tau, 0.01),
    "fast.step(euler)": lambda q, v, tau: fast.step(q, v, tau, 0.01, method="euler"),
    "fast.run": lambda q, v, tau: fast.run(q, v, tau, 0.01, 2),
    "fast.restoring_forces": lambda q, v, tau: fast.restoring_forces(q),
    "fast.thrust_matrix": lambda q, v, tau: fast.thrust_matrix(q),
    "fast.frame_motion": lambda q, v, tau: fast.frame_motion(q, v, 1),
    "compiled_derivatives": lambda q, v, tau: compiled_derivatives(vehicle)(q, v, tau, np.zeros(3), 0.0),
    "Vehicle.acceleration": lambda q, v, tau: vehicle.acceleration(q, v, tau),
    "acceleration_derivatives": lambda q, v, tau: vehicle.acceleration_derivatives(q, v, tau),
    "transition_jacobians": lambda q, v, tau: aiauv_pin.dynamics.transitions.transition_jacobians(
        vehicle, q, v, dt=0.01, tau=tau),
    "linearize(Trim)": lambda q, v, tau: aiauv_pin.dynamics.linear_model.linearize(
        vehicle, Trim(q, v, np.zeros(m), tau, 0.0)),
}
if fast is None:  # the Pinocchio backend: no compiled kernels to call
    entries = {k: f for k, f in entries.items() if "fast" not in f.__code__.co_names}
in_place = {("fast.run", 0), ("fast.run", 1)}
goods = {"linearize(Trim)": (q0, v0, tau0[6:])}
for name, entry in entries.items():
    good_args = goods.get(name, (q0, v0, tau0))
    try:  # compile in the parent, so that no child compiles
        entry(*[a.copy() for a in good_args])
    except Exception:
        pass
    slots = 1 if "restoring" in name or "thrust_matrix" in name else (2 if "frame_motion" in name else 3)
    for slot in range(slots):
        good = good_args[slot]
        for label, bad in bad_arrays(good).items():
            if (name, slot, label) == ("transition_jacobians", 2, "none"):
                continue  # tau=None: the documented default (no joint torques)
            args = [a.copy() for a in good_args]
            args[slot] = bad
            case(f"{name} arg {slot} {label}", lambda entry=entry, args=args: entry(*args))
        if slot == 0:
            continue  # a configuration's quaternion does not survive most conversions
        for label, value in convertible_arrays(good).items():
            args = [a.copy() for a in good_args]
            args[slot] = value
            # advanced in place: refused unless it is already a writable contiguous float64
            case(f"{name} arg {slot} {label}", lambda entry=entry, args=args: entry(*args),
                 must_fail=(name, slot) in in_place and label != "guard exact")
    case(f"{name} good", lambda entry=entry, g=good_args: entry(*[a.copy() for a in g]), must_fail=False)

read_only = q0.copy()
read_only.setflags(write=False)
others = {
    "step dt nan": lambda: fast.step(q0, v0, tau0, float("nan")),
    "step dt 0": lambda: fast.step(q0, v0, tau0, 0.0),
    "step dt -0.01": lambda: fast.step(q0, v0, tau0, -0.01),
    "step dt 1e308": lambda: fast.step(q0, v0, tau0, 1e308),
    "step dt str": lambda: fast.step(q0, v0, tau0, "0.01"),
    "step method": lambda: fast.step(q0, v0, tau0, 0.01, method="rk5"),
    "step t inf": lambda: fast.step(q0, v0, tau0, 0.01, t=float("inf")),
    "run n_steps -1": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, -1),
    "run n_steps 1e308": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, 1e308),
    "run n_steps 2**63": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, 2**63),
    "run q read-only": lambda: fast.run(read_only, v0.copy(), tau0, 0.01, 2),
    "run n_steps str": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, "2"),
    "run same array q and v": lambda: fast.run(np.zeros(nq), np.zeros(nq)[:nv], tau0, 0.01, 2),
    "acceleration quaternion 0": lambda: fast.acceleration(np.zeros(nq), v0, tau0),
    "acceleration quaternion x2": lambda: fast.acceleration(np.r_[q0[:3], 0, 0, 0, 2, q0[7:]], v0, tau0),
    "frame_motion id -1": lambda: fast.frame_motion(q0, v0, -1),
    "frame_motion id 10**6": lambda: fast.frame_motion(q0, v0, 10**6),
    "frame_motion id 2**70": lambda: fast.frame_motion(q0, v0, 2**70),
    "frame_motion id 1.5": lambda: fast.frame_motion(q0, v0, 1.5),
    "frame_positions 1-D": lambda: fast.frame_positions(q0, 1),
    "servo short": lambda: fast.acceleration(
        q0, v0, tau0, servo=Servo(np.ones(1), np.ones(1), np.ones(1), True, True)),
    "servo nan": lambda: fast.acceleration(q0, v0, tau0, servo=Servo(
        np.full(nv - 6, np.nan), np.ones(nv - 6), np.ones(nv - 6), True, True)),
    "disturbance str": lambda: fast.acceleration(q0, v0, tau0, disturbance="wind"),
    "disturbance short": lambda: fast.acceleration(q0, v0, tau0, disturbance=np.zeros(2)),
    "derivatives thrusts long": lambda: compiled_derivatives(vehicle)(
        q0, v0, tau0, np.zeros(3), 0.0, np.zeros(m + 1)),
    "derivatives thrusts nan": lambda: compiled_derivatives(vehicle)(
        q0, v0, tau0, np.zeros(3), 0.0, np.full(m, np.nan)),
    "derivatives velocity short": lambda: compiled_derivatives(vehicle)(q0, v0, tau0, np.zeros(2), 0.0),
    "derivatives t nan": lambda: compiled_derivatives(vehicle)(q0, v0, tau0, np.zeros(3), float("nan")),
    "linearize trim not a Trim": lambda: aiauv_pin.dynamics.linear_model.linearize(vehicle, (q0, v0)),
    "linearize trim thrusts short": lambda: aiauv_pin.dynamics.linear_model.linearize(
        vehicle, Trim(q0, v0, np.zeros(m - 1), tau0[6:], 0.0)),
    "linearize trim nan": lambda: aiauv_pin.dynamics.linear_model.linearize(
        vehicle, Trim(q0, np.full(nv, np.nan), np.zeros(m), tau0[6:], 0.0)),
    "linearize joint_gains nan": lambda: aiauv_pin.dynamics.linear_model.linearize(
        vehicle, joint_gains=(float("nan"), 1.0)),
    "linearize joint_gains 1e308": lambda: aiauv_pin.dynamics.linear_model.linearize(
        vehicle, joint_gains=(1e308, 1e308)),
    "transition method": lambda: aiauv_pin.dynamics.transitions.transition_jacobians(
        vehicle, q0, v0, dt=0.01, method="rk9"),
    "transition dt 0": lambda: aiauv_pin.dynamics.transitions.transition_jacobians(vehicle, q0, v0, dt=0.0),
    "Vehicle.frame_placement id": lambda: vehicle.frame_placement(q0, 5),
    "Vehicle.link_placements ids": lambda: vehicle.link_placements(q0, [5]),
}
for name, call in others.items():
    if fast is not None or "fast" not in call.__code__.co_names:
        case(name, call)

currents = {
    "constant 1 parameter": lambda: Current(constant_current, np.zeros(1), "constant"),
    "tidal 3 parameters": lambda: Current(tidal_current, np.zeros(3), "tidal"),
    "user tidal function 3 parameters": lambda: Current(tidal_current, np.zeros(3)),
    "constant NaN": lambda: Current.constant([np.nan, 0.0, 0.0]),
    "kind not its function": lambda: Current(constant_current, np.zeros(8), "tidal"),
}
for name, call in currents.items():
    case(f"current {name}", call)
for name, make in {  # plausible only through the scenario gate; a run must refuse or not diverge
    "tidal period 1e-300": lambda: Current.tidal([0, 0, 0], [0.1, 0, 0], 1e-300),
    "constant 1e6 m/s": lambda: Current.constant([1e6, 0.0, 0.0]),
}.items():
    case(f"simulate current {name}", lambda make=make: aiauv_pin.simulate(
        vehicle, q0, np.zeros(nv), 0.05, 0.01, current=make()), must_fail=False)

def mutated_current():
    current = Current.constant([0.1, 0.0, 0.0])
    current.parameters[1] = np.nan
    return current

def shrunk_current():
    current = Current.constant([0.1, 0.0, 0.0])
    object.__setattr__(current, "parameters", np.zeros(1))
    return current

for name, call in {
    "fast.acceleration": lambda c: fast.acceleration(q0, v0, tau0, c),
    "fast.step": lambda c: fast.step(q0, v0, tau0, 0.01, current=c),
    "Vehicle.acceleration": lambda c: vehicle.acceleration(q0, v0, tau0, c),
    "rollout": lambda c: aiauv_pin.rollout(vehicle, q0, v0, 0.02, 0.01, current=c),
    "simulate": lambda c: aiauv_pin.simulate(vehicle, q0, v0, 0.02, 0.01, current=c),
}.items():
    if fast is None and "fast" in call.__code__.co_names:
        continue
    case(f"current mutated to NaN via {name}", lambda call=call: call(mutated_current()))
    case(f"current shrunk via {name}", lambda call=call: call(shrunk_current()))

@numba.njit
def helper_writes(array, k):
    array[k] = 1.0

@numba.njit
def writes(t, q, v, model, workspace, parameters, state, tau, info):
    for i in range(tau.shape[0]):
        tau[i] = 0.0
    for i in range(int(parameters[0])):
        info[i] = t
    if parameters[1] > 0:
        helper_writes(info, int(parameters[1]))
    if parameters[2] > 0:
        state[int(parameters[2])] = t

def law(n_info, helper, state_index, **shapes):
    parameters = np.array([n_info, helper, state_index], dtype=float)
    return CompiledController(writes, parameters, np.zeros(2), **shapes)

lying = {
    "info_shapes understated": lambda: law(4, 0, 0, info_shapes={"u": ()}),
    "info_shapes empty": lambda: law(4, 0, 0),
    "info through a helper": lambda: law(0, 2, 0, info_shapes={"u": (2,)}),
    "state too short": lambda: law(0, 0, 5),
    "not compiled": lambda: CompiledController(lambda *a: None),
    "info_shapes not tuples": lambda: law(4, 0, 0, info_shapes={"u": 4}),
    "info_shapes negative": lambda: law(0, 0, 0, info_shapes={"u": (-3,)}),
    "paper info_shapes understated": lambda: dataclasses.replace(
        VehiclePathFollowing(vehicle).compiled(), info_shapes={"u": ()}),
}
honest = law(4, 3, 1, info_shapes={"u": (4,)})
try:  # compile the loops for `writes` in the parent
    aiauv_pin.simulate(vehicle, q0, np.zeros(nv), 0.05, 0.01, honest)
    aiauv_pin.rollout(vehicle, q0, np.zeros(nv), 0.05, 0.01, [honest, honest])
except Exception:
    pass
for name, make in lying.items():
    case(f"simulate {name}", lambda make=make: aiauv_pin.simulate(
        vehicle, q0, np.zeros(nv), 0.05, 0.01, make()))
    case(f"rollout {name}", lambda make=make: aiauv_pin.rollout(
        vehicle, q0, np.zeros(nv), 0.05, 0.01, [make(), make()]))
case("simulate honest", lambda: aiauv_pin.simulate(
    vehicle, q0, np.zeros(nv), 0.05, 0.01, honest).q, must_fail=False)

def describe(value):
    try:
        if hasattr(value, "q"):
            value = value.q
        arrays = value if isinstance(value, tuple) else (value,)
        finite = all(bool(np.all(np.isfinite(np.asarray(a, dtype=float)))) for a in arrays)
    except (TypeError, ValueError):
        finite = None
    return {"kind": "ok", "finite": finite}

run_forked(cases[::every], describe, 120.0, sys.argv[1])
'''


def run_entry_section(work: Path, env: dict, quick: bool) -> dict:
    records, findings, per_backend = [], [], {}
    for backend in ("numba",) if quick else ("numba", "pinocchio"):
        results = run_worker(ENTRY_WORKER, work, env, [backend, "5" if quick else "1"], 5400)
        if results is None:
            records.append({"outcome": "crash"})
            findings.append({"backend": backend, "outcome": "crash", "what": "the worker died"})
            continue
        per_backend[backend] = len(results)
        for record in results:
            outcome = forked_outcome(record)
            records.append({"outcome": outcome})
            if _is_finding(outcome) or outcome == "refused good input":
                findings.append({"backend": backend, **record, "outcome": outcome})
    return tally_section(records, findings, {"calls_per_backend": per_backend})


# --- section 8: threads sharing one Vehicle (issue 29 point 6) -------------------------------------------

THREAD_WORKER = r"""
import collections, json, sys, threading
import numpy as np
import aiauv_pin
from aiauv_pin.errors import AiauvError

backend, rounds = sys.argv[1], int(sys.argv[2])
vehicle = aiauv_pin.load_vehicle(backend=backend)
rng = np.random.default_rng(29_1127)
nv = vehicle.nv
states = []
for _ in range(1200):
    q = vehicle.neutral_configuration()
    q[7:] = rng.uniform(-0.6, 0.6, vehicle.nq - 7)
    q[:3] = rng.normal(size=3)
    states.append((q, rng.normal(size=nv), rng.normal(size=nv)))

def call(function, args):
    try:
        return ("ok", function(*args))
    except AiauvError as exc:  # a refusal (the Pinocchio backend's rollout): allowed if clear
        return ("error", str(exc))
    except Exception as exc:
        return ("foreign exception", f"{type(exc).__name__}: {exc}")

def parallel(function, args, threads):
    out = [None] * len(args)
    barrier = threading.Barrier(threads)
    def work(start):
        barrier.wait()
        for i in range(start, len(args), threads):
            out[i] = call(function, args[i])
    workers = [threading.Thread(target=work, args=(k,)) for k in range(threads)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    return out

def as_arrays(value):
    if hasattr(value, "q"):
        return (np.asarray(value.q), np.asarray(value.v))
    if hasattr(value, "bias"):
        return (np.asarray(value.bias),)
    return tuple(np.asarray(a) for a in (value if isinstance(value, tuple) else (value,)))

starts = [(s[0], 0.2 * s[1]) for s in states[:8]]
functions = {
    "acceleration": (vehicle.acceleration, states),
    "mass_matrix": (vehicle.mass_matrix, [(s[0],) for s in states[:300]]),
    "restoring_forces": (vehicle.restoring_forces, [(s[0],) for s in states[:300]]),
    "thrust_matrix": (vehicle.thrust_matrix, [(s[0],) for s in states[:300]]),
    "fluid_forces": (vehicle.fluid_forces, [s[:2] for s in states[:300]]),
    "kinetic_energy": (vehicle.kinetic_energy, [s[:2] for s in states[:300]]),
    "acceleration_derivatives": (vehicle.acceleration_derivatives, states[:60]),
    "simulate": (lambda q, v: aiauv_pin.simulate(vehicle, q, v, 0.2, 0.01), starts),
    "rollout": (lambda q, v: aiauv_pin.rollout(vehicle, q, v, 0.2, 0.01), starts[:4]),
}
if vehicle.fast is not None:  # the compiled kernels (the numba backend)
    functions["fast.acceleration"] = (vehicle.fast.acceleration, states)
    functions["fast.step"] = (lambda q, v, tau: vehicle.fast.step(q, v, tau, 0.01), states[:300])
report = collections.Counter()
details = []
for name, (function, args) in functions.items():
    serial = [call(function, a) for a in args]
    for round_ in range(rounds):
        for threads in (2, 4, 8):
            threaded = parallel(function, args, threads)
            for a, b in zip(serial, threaded):
                if b[0] != "ok":
                    report[b[0]] += 1
                    details.append(f"{name} x{threads}: {b[1][:200]}")
                elif a[0] != "ok":
                    report["silently wrong"] += 1
                    details.append(f"{name} x{threads}: returned where the serial call failed")
                elif all(np.array_equal(x, y, equal_nan=True)
                         for x, y in zip(as_arrays(a[1]), as_arrays(b[1]))):
                    report["ok"] += 1
                else:
                    report["silently wrong"] += 1
                    details.append(f"{name} x{threads}: differs from the serial call")
with open(sys.argv[3], "w") as handle:
    json.dump({"outcomes": dict(report), "details": details[:20]}, handle)
"""


def run_thread_section(work: Path, env: dict, quick: bool) -> dict:
    script = work / "thread_worker.py"
    script.write_text(THREAD_WORKER, encoding="utf-8")
    records, findings, details = [], [], {}
    for backend in ("pinocchio", "numba"):
        out = work / f"threads_{backend}.json"
        result = run_command(
            [sys.executable, str(script), backend, "1" if quick else "3", str(out)], work, env, 3600
        )
        if result["outcome"] != "ok":
            records.append({"outcome": result["outcome"]})
            findings.append(
                {"backend": backend, "outcome": result["outcome"], "stderr": result["stderr"]}
            )
            continue
        report = json.loads(out.read_text())
        for outcome, count in report["outcomes"].items():
            records += [{"outcome": outcome}] * count
        details[backend] = report["details"]
        if any(_is_finding(o) for o in report["outcomes"]):
            findings.append({"backend": backend, "details": report["details"]})
    return tally_section(records, findings, {"threads": [2, 4, 8], "details": details})


# --- section 9: SDF / gz and other inputs that are FIFOs, zero streams or huge (issue 29 point 5) ---------


def run_gz_inputs_section(work: Path, env: dict, rng: random.Random, scale: float) -> dict:
    from aiauv_pin.interop.gz import MAX_SDF_BYTES

    base = work / "gz_inputs"
    base.mkdir()
    urdf = str(ROOT / "urdf" / "paper_uniform.urdf")
    sdf = base / "paper.sdf"
    exported = run_command(aiauv("export", urdf, "-o", str(sdf)), work, env)
    if exported["outcome"] != "ok":
        return {"runs": 0, "failures": [{"what": "export of the input SDF", **exported}]}
    sdf_text = sdf.read_text()
    special = base / "special"
    special.mkdir()
    helpers = [ZeroFeeder(special / "zero"), ZeroFeeder(special / "sdf_stream", sdf_text.encode())]
    os.mkfifo(special / "fifo")
    make_socket(special / "socket")
    (special / "folder").mkdir()
    (special / "empty").write_bytes(b"")
    for name, size in (("over_limit", MAX_SDF_BYTES + 1), ("sparse_2g", 2_000_000_000)):
        with open(special / name, "wb") as handle:
            handle.truncate(size)
    big = special / "big_valid.sdf"  # under the byte limit, far over any element count
    big.write_text(sdf_text.replace("</model>", "<frame name='f'/>" * 300_000 + "</model>", 1))
    (special / "laughs.sdf").write_text(
        '<?xml version="1.0"?><!DOCTYPE s [<!ENTITY a "aaaaaaaaaa">'
        + "".join(f'<!ENTITY {chr(98 + i)} "' + f"&{chr(97 + i)};" * 10 + '">' for i in range(8))
        + "]><sdf version='1.9'><model name='&i;'/></sdf>"
    )
    (special / "entity.sdf").write_text(
        '<?xml version="1.0"?><!DOCTYPE s [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
        "<sdf version='1.9'><model name='&x;'/></sdf>"
    )
    (special / "binary").write_bytes(bytes(random.Random(SEED).randrange(256) for _ in range(5000)))
    names = ["zero", "sdf_stream", "fifo", "socket", "folder", "empty", "over_limit", "sparse_2g"]
    sdf_only = ["big_valid.sdf", "laughs.sdf", "entity.sdf", "binary"]
    out = base / "out"
    out.mkdir()
    plans = []

    def plan(label: str, argv: list[str], judge: str = "refuse") -> None:
        if label.endswith(" empty") and argv[0] in ("simulate", "sweep", "linearize"):
            judge = "either"  # an empty TOML file: every key at its default, a valid scenario
        plans.append({"label": label, "argv": [str(a) for a in argv], "judge": judge})

    for name in names + sdf_only:
        path = special / name
        plan(
            f"import-gz SDF {name}",
            ["import-gz", path, "--urdf", urdf, "-o", out / f"i_{len(plans)}.urdf"],
        )
    for name in names:
        path = special / name
        plan(
            f"import-gz --urdf {name}",
            ["import-gz", sdf, "--urdf", path, "-o", out / f"u_{len(plans)}.urdf"],
        )
        plan(f"export {name}", ["export", path, "-o", out / f"e_{len(plans)}.sdf"])
        plan(f"check {name}", ["check", path])
        plan(f"annotate {name}", ["annotate", path, "-o", out / f"a_{len(plans)}.urdf"])
        plan(f"build {name}", ["build", path, "-o", out / f"b_{len(plans)}.urdf"])
        plan(
            f"simulate scenario {name}",
            ["simulate", path, "--quiet", "--out", out / f"s_{len(plans)}"],
        )
        plan(
            f"simulate --vehicle {name}",
            [
                "simulate",
                "--vehicle",
                path,
                "--duration",
                "0.1",
                "--quiet",
                "--out",
                out / f"v_{len(plans)}",
            ],
        )
        plan(
            f"sweep spec {name}",
            ["sweep", path, "--workers", "1", "--quiet", "--out", out / f"w_{len(plans)}"],
        )
        plan(f"linearize {name}", ["linearize", path])
        scenario = base / f"names_{name}.toml"
        scenario.write_text(f'vehicle = "{path}"\nduration = 0.1\n')
        plan(
            f"scenario naming {name}",
            ["simulate", scenario, "--quiet", "--out", out / f"n_{len(plans)}"],
        )
    for index in range(int(150 * scale)):  # mutated SDFs (values and structure), fixed seed
        text = mutate_values(
            sdf_text, rng, _TEXT if rng.random() < 0.6 else _ATTRIBUTE, rng.randint(1, 3)
        )
        if rng.random() < 0.3:
            text = mutate_structure(text, rng)
        path = base / f"mutated_{index:03d}.sdf"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        plan(
            f"mutated SDF {index}",
            ["import-gz", path, "--urdf", urdf, "-o", out / f"m_{index}.urdf"],
            "mutated",
        )
    if scale < 1:
        plans = plans[::4]
    print(f"gz inputs: {len(plans)} runs", flush=True)

    def execute(item):
        return item, run_command(aiauv(*item["argv"]), work, env, TIMEOUT)

    records, findings = [], []
    try:
        with ThreadPoolExecutor(PARALLEL) as pool:
            done = list(pool.map(execute, plans))
    finally:
        for helper in helpers:
            helper.close()
    for item, result in done:
        outcome = result["outcome"]
        reasons = None
        if outcome == "ok" and item["judge"] == "refuse":
            outcome = "accepted bad input"
        elif outcome == "ok" and item["judge"] == "mutated":
            written = Path(item["argv"][-1])
            reasons = non_physical_reasons(written) or loaded_vehicle_reasons(written)
            if reasons:
                outcome = "accepted bad input"
        records.append({"outcome": outcome})
        if _is_finding(outcome):
            findings.append(
                {
                    "case": item["label"],
                    "argv": item["argv"],
                    "outcome": outcome,
                    "stderr": result["stderr"][-400:],
                    "reasons": (reasons or [])[:5],
                    "seconds": result["seconds"],
                }
            )
    slowest = sorted(done, key=lambda d: -d[1]["seconds"])[:3]
    return tally_section(
        records,
        findings,
        {
            "zero_stream": "a FIFO fed with zeros by a thread (the stand-in for /dev/zero)",
            "slowest_runs": [{"case": i["label"], "seconds": r["seconds"]} for i, r in slowest],
        },
    )


# --- section 10: accepted, then failing late or silently wrong (issue 29 points 6 and 7) -----------------

CYLINDER_VEHICLE = """<robot name="c">
  <link name="hull">
    <inertial><mass value="10"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0.3"/>
    </inertial>
    <visual><origin xyz="{xyz}" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="{radius}" length="{length}"/></geometry></visual>{extra}
  </link>
  <hydrodynamics><link name="hull" model="slender_cylinder" {attributes}/></hydrodynamics>
</robot>"""
#: Vehicles: (label, CYLINDER_VEHICLE fields, what the refusal must name).
LATE_VEHICLES = [
    ("visual radius 1e308", dict(radius="1e308"), "cylinder"),
    ("visual length 1e308", dict(length="1e308"), "cylinder"),
    ("visual origin 1e308", dict(xyz="1e308 0 0"), "origin"),
    ("C_dC 1e20", dict(attributes='C_dC="1e20"'), "C_dC"),
    ("hydro cylinder length 1e308", dict(attributes='length="1e308"'), "length"),
    ("C_a 1e6", dict(attributes='C_a="1e6"'), "C_a"),
    ("v_ref 1e-9", dict(attributes='v_ref="1e-9"'), "v_ref"),
    (
        "mesh scale 1e9",
        dict(
            extra='<visual><geometry><mesh filename="hull.stl" scale="1e9 1 1"/></geometry></visual>'
        ),
        "scale",
    ),
    (
        "sphere visual radius 1e308",
        dict(extra='<visual><geometry><sphere radius="1e308"/></geometry></visual>'),
        "sphere",
    ),
    (
        "box visual 1e308",
        dict(extra='<visual><geometry><box size="1e308 1 1"/></geometry></visual>'),
        "box",
    ),
]
#: Scenario files: (label, TOML text, what the refusal must name).
LATE_SCENARIOS = [
    ("current 1e6 m/s", "[current]\nvelocity = [1e6, 0.0, 0.0]\n", "velocity"),
    ("current 1e308 m/s", "[current]\nvelocity = [1e308, 0.0, 0.0]\n", "velocity"),
    (
        "tidal period 1e-300",
        '[current]\ntype = "tidal"\namplitude = [0.1, 0.0, 0.0]\nperiod = 1e-300\n',
        "period",
    ),
    (
        "tidal amplitude 1e6",
        '[current]\ntype = "tidal"\namplitude = [1e6, 0.0, 0.0]\nperiod = 100.0\n',
        "amplitude",
    ),
    ("shear gradient 1e6", '[current]\ntype = "shear"\ngradient = [1e6, 0.0, 0.0]\n', "gradient"),
    ("k_d 1e308", "[controller]\nk_d = 1e308\n", "k_d"),
    ("k_p 1e308", "[controller]\nk_p = 1e308\n", "k_p"),
    ("k_e [1, 2, 3]", "[controller]\nk_e = [1.0, 2.0, 3.0]\n", "k_e"),
    ("k_e 1e308", "[controller]\nk_e = 1e308\n", "k_e"),
    ("csv_period 1e308", "[output]\ncsv_period = 1e308\n", "csv_period"),
    ("start 1e308", "[start]\nposition = [1e308, 0.0, 0.0]\n", "position"),
    ("surge 1e6", "[start]\nsurge = 1e6\n", "surge"),
]
#: Sweep specs: (label, TOML text after the fixed part, what the refusal must name).
LATE_SWEEPS = [
    (
        "linspace count 1e9",
        '"initial_offset.y" = { linspace = [1.0, 3.0, 1000000000] }\n',
        "count",
    ),
    (
        "linspace count 1e18",
        '"initial_offset.y" = { linspace = [1.0, 3.0, 1000000000000000000] }\n',
        "count",
    ),
    ("grid k_d 1e308", "k_d = [1e308, 12.0]\n", "k_d"),
    ("grid current.y 1e6", '"current.y" = [1e6]\n', "current"),
    ("grid k_e [1, 2, 3]", "k_e = [[1.0, 2.0, 3.0]]\n", "k_e"),
    (
        "grid 1e6 x 1e6 cells",
        '"initial_offset.y" = { linspace = [1.0, 3.0, 1000000] }\n'
        '"initial_offset.z" = { linspace = [1.0, 3.0, 1000000] }\n',
        "count",
    ),
]


def run_late_section(work: Path, env: dict, scale: float) -> dict:
    base = work / "late"
    base.mkdir()
    plans = []

    def plan(label: str, argv: list, named: str) -> None:
        plans.append({"label": label, "argv": [str(a) for a in argv], "named": named})

    fields = dict(radius="0.1", length="0.5", xyz="0.25 0 0", attributes="", extra="")
    good = base / "good_cylinder.urdf"
    good.write_text(CYLINDER_VEHICLE.format(**fields))
    plan("the unmutated cylinder vehicle (control)", ["check", good], "")
    for index, (label, mutation, named) in enumerate(LATE_VEHICLES):
        path = base / f"vehicle_{index}.urdf"
        path.write_text(CYLINDER_VEHICLE.format(**{**fields, **mutation}))
        plan(f"check {label}", ["check", path], named)
        plan(
            f"simulate {label}",
            [
                "simulate",
                "--vehicle",
                path,
                "--controller",
                "none",
                "--duration",
                "0.2",
                "--quiet",
                "--no-html",
                "--out",
                base / f"sv_{index}",
            ],
            named,
        )
        plan(f"export {label}", ["export", path, "-o", base / f"ev_{index}.sdf"], named)
    sdf = base / "paper.sdf"
    run_command(
        aiauv("export", str(ROOT / "urdf" / "paper_uniform.urdf"), "-o", str(sdf)), work, env
    )
    text = sdf.read_text()
    for label, pattern, replacement, named in (  # the first link's collision, its added mass
        ("SDF sphere radius 1e308", r"(<sphere>\s*<radius>)[^<]*", r"\g<1>1e308", "radius"),
        (
            "SDF box size 1e308",
            r"<sphere>\s*<radius>[^<]*</radius>\s*</sphere>",
            "<box><size>1e308 1 1</size></box>",
            "size",
        ),
        ("SDF added mass 1e308", r"(<xx>)[^<]*", r"\g<1>1e308", "added"),
        ("SDF added mass -1e3", r"(<xx>)[^<]*", r"\g<1>-1e3", "added"),
    ):
        mutated = base / f"{label.replace(' ', '_')}.sdf"
        mutated.write_text(re.sub(pattern, replacement, text, count=1))
        urdf = ROOT / "urdf" / "paper_uniform.urdf"
        argv = ["import-gz", mutated, "--urdf", urdf, "-o", base / f"{mutated.stem}.urdf"]
        plan(f"import-gz {label}", argv, named)
    for index, (label, body, named) in enumerate(LATE_SCENARIOS):
        path = base / f"scenario_{index}.toml"
        path.write_text(f"duration = 0.2\ndt = 0.01\n{body}")
        plan(
            f"simulate {label}",
            ["simulate", path, "--quiet", "--no-html", "--out", base / f"ss_{index}"],
            named,
        )
        plan(f"linearize {label}", ["linearize", path], named)
    plan(
        "simulate --current 1e6 0 0",
        [
            "simulate",
            "--current",
            "1e6",
            "0",
            "0",
            "--duration",
            "0.2",
            "--quiet",
            "--out",
            base / "flag_current",
        ],
        "current",
    )
    for index, (label, grid, named) in enumerate(LATE_SWEEPS):
        path = base / f"sweep_{index}.toml"
        path.write_text(f"duration = 0.2\ndt = 0.01\n[grid]\n{grid}")
        plan(
            f"sweep {label}",
            [
                "sweep",
                path,
                "--workers",
                "1",
                "--quiet",
                "--no-plots",
                "--out",
                base / f"sw_{index}",
            ],
            named,
        )
    if scale < 1:
        plans = plans[:1] + plans[1::4]
    print(f"late: {len(plans)} runs", flush=True)

    def execute(item):
        return item, run_command(aiauv(*item["argv"]), work, env, TIMEOUT)

    with ThreadPoolExecutor(PARALLEL) as pool:
        done = list(pool.map(execute, plans))
    records, findings = [], []
    for item, result in done:
        outcome = result["outcome"]
        if not item["named"]:  # the control: a good vehicle passes
            outcome = "ok" if outcome == "ok" else "refused good input"
        elif outcome == "ok":
            outcome = "accepted bad input"
        elif outcome == "error":
            message = result["stderr"].strip().splitlines()[-1]
            late = any(
                word in message for word in ("diverged", "smaller step", "internal error", "JSON")
            )
            if late or item["named"].lower() not in message.lower():
                outcome = "late failure"  # refused, but late or without naming the parameter
        records.append({"outcome": outcome})
        if outcome not in ("ok", "error"):
            findings.append(
                {
                    "case": item["label"],
                    "argv": item["argv"],
                    "outcome": outcome,
                    "expected to name": item["named"],
                    "stderr": result["stderr"][-400:],
                    "seconds": result["seconds"],
                }
            )
    return tally_section(records, findings)


# --- main ----------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="a short version (about 3 min)")
    parser.add_argument("--out", type=Path, default=None, help=f"JSON file ({DEFAULT_OUT.name})")
    parser.add_argument(
        "--sections", default=",".join(SECTIONS), help="comma-separated subset to run"
    )
    parser.add_argument(
        "--update",
        action="store_true",
        help="keep the other sections of an existing --out file (a campaign run in parts)",
    )
    parser.add_argument("--keep", action="store_true", help="keep the work folder")
    args = parser.parse_args(argv)
    out = args.out or (
        DEFAULT_OUT
        if not args.quick
        else Path(tempfile.gettempdir()) / "hostile_campaign_quick.json"
    )
    sections = set(args.sections.split(","))
    rng = random.Random(SEED)
    scale = 0.05 if args.quick else 1.0
    work = Path(tempfile.mkdtemp(prefix="aiauv-hostile-"))
    (work / "tmp").mkdir()
    env = {**os.environ, "TMPDIR": str(work / "tmp"), "PYTHONFAULTHANDLER": ""}
    env.pop("AIAUV_DEBUG", None)
    started = time.monotonic()
    report: dict = {
        "seed": SEED,
        "quick": args.quick,
        "date": time.strftime("%Y-%m-%d", time.gmtime()),
        "machine": f"{os.cpu_count()} cores, Python {sys.version.split()[0]}",
    }
    if args.update and out.exists():
        previous = json.loads(out.read_text())
        report["parts"] = previous.get("parts") or [
            {
                "sections": [k for k in SECTIONS if k in previous],
                "date": previous.get("date"),
                "wall_time_seconds": previous.get("wall_time_seconds"),
            }
        ]
        report.update({k: previous[k] for k in SECTIONS if k in previous and k not in sections})
    subprocess.run(
        aiauv("simulate", "--duration", "0.05", "--quiet", "--out", str(work / "warm")),
        env=env,
        capture_output=True,
    )
    try:
        if "cli" in sections:
            section_start = time.monotonic()
            report["cli"] = run_cli_section(work, env, rng, scale)
            report["cli"]["seconds"] = round(time.monotonic() - section_start, 1)
            print(f"cli: {report['cli']['outcomes']}", flush=True)
        if "api" in sections:
            section_start = time.monotonic()
            report["api"] = run_api_section(work, env, args.quick)
            report["api"]["seconds"] = round(time.monotonic() - section_start, 1)
            print(f"api: {report['api']['outcomes']}", flush=True)
        if "kills" in sections:
            section_start = time.monotonic()
            report["kills"] = run_kill_section(
                work, env, rng, 2 if args.quick else 42, 1 if args.quick else 12
            )
            report["kills"]["seconds"] = round(time.monotonic() - section_start, 1)
            print(f"kills: {report['kills']['tally']}", flush=True)
        if "sweeps" in sections:
            section_start = time.monotonic()
            report["sweeps"] = run_sweep_section(
                work, env, rng, 1 if args.quick else 3, 1 if args.quick else 2, args.quick
            )
            report["sweeps"]["seconds"] = round(time.monotonic() - section_start, 1)
            print(f"sweeps: {report['sweeps'].get('tally')}", flush=True)
        # issue 29's classes: each section draws from its own generator (a section run alone
        # tries the same inputs as in the whole campaign)
        issue29 = {
            "xacro": lambda r: run_xacro_section(work, env, r, scale),
            "outputs": lambda r: run_outputs_section(work, env, r, scale),
            "entry_points": lambda r: run_entry_section(work, env, args.quick),
            "threads": lambda r: run_thread_section(work, env, args.quick),
            "gz_inputs": lambda r: run_gz_inputs_section(work, env, r, scale),
            "late": lambda r: run_late_section(work, env, scale),
        }
        for number, (name, run) in enumerate(issue29.items()):
            if name not in sections:
                continue
            section_start = time.monotonic()
            report[name] = run(random.Random(SEED + 29 + number))
            report[name]["seconds"] = round(time.monotonic() - section_start, 1)
            print(f"{name}: {report[name].get('outcomes')}", flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
        else:
            print(f"work folder kept: {work}")
    report["wall_time_seconds"] = round(time.monotonic() - started, 1)
    if "parts" in report:
        report["parts"].append(
            {
                "sections": sorted(sections),
                "date": report["date"],
                "wall_time_seconds": report["wall_time_seconds"],
            }
        )
        report["wall_time_seconds"] = round(
            sum(p["wall_time_seconds"] or 0 for p in report["parts"]), 1
        )
    report["summary"] = summarise(report)
    out.write_text(json.dumps(report, indent=1, default=str) + "\n")
    print(json.dumps(report["summary"], indent=1))
    print(f"-> {out}")
    return 0 if report["summary"]["shortfalls"] == 0 else 1


def summarise(report: dict) -> dict:
    cli = report.get("cli", {}).get("outcomes", {})
    api = report.get("api", {}).get("outcomes", {})
    kills = report.get("kills", {}).get("tally", {})
    sweeps = report.get("sweeps", {}).get("tally", {})
    summary = {
        "overflow_for_absurd_inputs": api.get("overflow (absurd input)", 0),
        "cli_runs": report.get("cli", {}).get("runs", 0),
        "mutated_files": report.get("cli", {}).get("files", 0),
        "api_calls": report.get("api", {}).get("calls", 0),
        "simulate_kills": kills.get("kills", 0),
        "simulate_kills_in_reused_folder": kills.get("kills in reused folder", 0),
        "sweep_kills": sweeps.get("sweep kills", 0) + sweeps.get("worker kills", 0),
        "sweep_resumes": sweeps.get("resumes", 0),
        "tracebacks": cli.get("traceback", 0) + cli.get("internal error", 0),
        "crashes": cli.get("crash", 0) + api.get("crash", 0),
        "hangs": cli.get("hang", 0) + api.get("hang", 0),
        "messy_errors": cli.get("messy error", 0)
        + cli.get("forged output", 0)
        + api.get("messy error", 0),
        "foreign_exceptions": api.get("foreign exception", 0),
        "accepted_bad_inputs": cli.get("accepted bad input", 0) + api.get("accepted bad input", 0),
        "refused_good_inputs": api.get("refused good input", 0),
        "non_finite_results": api.get("non-finite result", 0),
        "backend_disagreements": report.get("api", {}).get("backend_disagreements", 0),
        "check_simulate_disagreements": len(
            report.get("cli", {}).get("check_simulate_disagreements", [])
        ),
        "data_lost": kills.get("data lost", 0) + sweeps.get("data lost", 0),
        "surviving_children": kills.get("surviving children", 0),
    }
    summary["categories"] = categories(report)
    summary["total_runs"] = sum(row["runs"] for row in summary["categories"].values())
    summary["total_findings"] = {
        column: sum(row[column] for row in summary["categories"].values())
        for column in FINDING_COLUMNS
    }
    failures = sum(len(report.get(s, {}).get("failures", [])) for s in SECTIONS)
    summary["shortfalls"] = failures + summary["check_simulate_disagreements"]
    return summary


def categories(report: dict) -> dict:
    """The per-category table: runs and findings by column (:data:`FINDING_COLUMNS`)."""
    table = {}
    for name in SECTIONS:
        section = report.get(name)
        if not section:
            continue
        if name in ("kills", "sweeps"):
            tally = section.get("tally", {})
            runs = sum(
                tally.get(k, 0)
                for k in (
                    "kills",
                    "kills in reused folder",
                    "sweep kills",
                    "worker kills",
                    "resumes",
                    "concurrent sweeps",
                    "--workers 100000",
                    "all-runs-fail sweeps",
                    "planted cache file",
                )
            )
            outcomes = {"files lost": tally.get("data lost", 0)}
        else:
            runs = section.get("runs", section.get("calls", 0))
            outcomes = dict(section.get("outcomes", {}))
            if name == "api":
                outcomes["backends disagree"] = section.get("backend_disagreements", 0)
        row = {"runs": runs}
        for column, kinds in FINDING_COLUMNS.items():
            row[column] = sum(outcomes.get(kind, 0) for kind in kinds)
        row["failure_records"] = len(section.get("failures", []))
        table[name] = row
    return table


if __name__ == "__main__":
    sys.exit(main())
