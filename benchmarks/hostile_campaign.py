"""Hostile/careless-user campaign of issue 11, reproducible: mutated files, command lines, API misuse,
kills of ``simulate`` and kill-and-resume of sweeps.

    python benchmarks/hostile_campaign.py [--quick] [--out benchmarks/hostile_campaign.json]

Everything is drawn from one seeded generator (:data:`SEED`), so each run tries the same inputs. The
figures are written to ``benchmarks/hostile_campaign.json``: runs tried per category, and the runs
that fell short, each with its command and the start of its standard error. A run falls short when
it ends in

* a **traceback** (or the command line's ``internal error`` line: an exception nobody anticipated),
* a **crash** (the process died of a signal), a **hang** (no answer within the time limit),
* a **messy error** (a failure that is not exactly one ``aiauv: error:`` line with exit status 1 or
  2; ``aiauv: warning:`` lines and the one-time compile notice are allowed beside it),
* an **accepted bad input**: a command that succeeded on an input known to be bad (a bad flag), or
  on a vehicle this script finds non-physical by its own reading of the file (negative or
  indefinite damping, a negative mass, an inertia breaking the triangle inequality, non-finite
  numbers, magnitudes beyond the documented thresholds of :mod:`aiauv_pin.model.validation`, unsafe
  names); an API call returning for a bad argument, or a non-finite result;
* **data lost** (a killed ``simulate`` leaving a folder that claims completeness it lacks or mixes
  runs; a sweep that, resumed, does not give exactly the table of an uninterrupted sweep) or a
  surviving child process of a killed run.

Scale (full): >= 700 command-line runs over >= 400 mutated files, every API misuse of issue 11
points 1 and 9 on both backends (each call in a forked process, so that a SIGSEGV is counted, not
fatal), 42 kills of ``simulate`` in fresh folders and 12 in a reused one, sweeps killed and resumed.
About 20 min on a shared 2-core machine (19 min on 2026-11-23); ``--quick`` (a twentieth of the
files, a tenth of the API calls, 3 kills, one sweep kill-and-resume) 95 s once the
kernels are compiled. Not part of the test suite (CI time); the tests hold a short version of each
claim (``tests/description/test_fuzz.py``, ``tests/app/test_hostile_input.py``,
``tests/results/test_kill.py``, ``tests/test_reliability.py``).
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


# --- main ----------------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="a short version (about 95 s)")
    parser.add_argument("--out", type=Path, default=None, help=f"JSON file ({DEFAULT_OUT.name})")
    parser.add_argument(
        "--sections", default="cli,api,kills,sweeps", help="comma-separated subset to run"
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
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
        else:
            print(f"work folder kept: {work}")
    report["wall_time_seconds"] = round(time.monotonic() - started, 1)
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
    failures = sum(
        len(report.get(s, {}).get("failures", [])) for s in ("cli", "api", "kills", "sweeps")
    )
    summary["shortfalls"] = failures + summary["check_simulate_disagreements"]
    return summary


if __name__ == "__main__":
    sys.exit(main())
