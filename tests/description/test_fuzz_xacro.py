"""Hostile xacro and SDF inputs (issue 29): no code runs, nothing hangs, every refusal is one line.

Each class of hostile input is tried and must end in a one-line :class:`AiauvError` (the command
line: exit 1 with one ``aiauv: error:`` line) within a few seconds, never in code execution (the
code-execution payloads would create a marker file in ``tmp_path`` if they ran), a hang or a
traceback: expression escapes out of xacro's ``eval`` (dunder names, ``python.vars(...)`` to a
class's ``_module``, ``$(eval ...)`` through a property), random compositions of dangerous and
harmless expression pieces (fixed seed), exponent and size bombs, macro- and block-doubling bombs,
hostile includes (a FIFO, a 200 MB sparse file, a self-include, includes that double) and SDF /
URDF inputs of ``import-gz`` and ``export`` that are FIFOs or oversize sparse files. FIFOs are made
with :func:`os.mkfifo` in ``tmp_path``; no test touches ``/dev``.

Legitimate files must expand identically with the safe evaluator and with full xacro
(``trust=True``), and ``--trust-xacro`` must restore full xacro (there the payload runs: the marker
appears, in ``tmp_path``). The outcomes are counted in :data:`TALLY` and printed at the end (``-s``).
"""

from __future__ import annotations

import os
import random
import re
import time
from collections import Counter
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.app.cli import main
from aiauv_pin.description.xacro_loading import expand_xacro
from aiauv_pin.description.xacro_safe_eval import UnsafeXacroExpression
from aiauv_pin.errors import AiauvError, InputLimitError
from aiauv_pin.interop.gz import MAX_SDF_BYTES, import_gz, read_gz_model

PACKAGES = Path(__file__).parents[1] / "data" / "uuv_packages"
MINIROV = PACKAGES / "minirov_description" / "robots" / "minirov.urdf.xacro"
HEAD = '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
LINK = '<link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'  # noqa: E501
#: Longest any one hostile input may take [s] (a hang fails the test; they take well under 3 s).
BUDGET = 10.0
TALLY: Counter = Counter()


@pytest.fixture(scope="module", autouse=True)
def _print_tally():
    yield
    if TALLY:
        print("\nxacro/SDF campaign:", dict(sorted(TALLY.items())))


def _write(folder: Path, name: str, body: str) -> Path:
    path = folder / name
    path.write_text(HEAD + body + "</robot>", encoding="utf-8")
    return path


def _outcome(kind: str, call) -> str | None:
    """Run ``call``; ``None`` if it returned, else the one-line message; tallied under ``kind``."""
    start = time.monotonic()
    try:
        call()
        outcome, message = "accepted", None
    except AiauvError as exc:
        outcome, message = "refused", str(exc)
        assert "\n" not in message and message.strip(), message
        assert "Traceback" not in message
    elapsed = time.monotonic() - start
    assert elapsed < BUDGET, f"{kind}: {elapsed:.1f} s"
    TALLY[f"{kind}: {outcome}"] += 1
    return message


# --------------------------------------------------------------------------------------------------
# Code execution
# --------------------------------------------------------------------------------------------------

#: Expressions that ran code under xacro's own evaluator (or try to); MARK is the marker path.
ESCAPES = {
    # python.vars of classes: dunder names as string keys get past the dunder-name filter, and
    # catch_warnings()._module is the warnings module, whose globals hold sys and so os
    "vars_module": "${python.vars(python.vars([c for c in python.vars(python.type)"
    "['__subclasses__'](python.type.mro(python.type(0))[-1]) if 'catch_warnings' in "
    "python.str(c)][0]()._module)['sys']).get('modules')['os'].system('touch MARK')}",
    "dunder_import": "${__import__('os').system('touch MARK')}",
    "dunder_class": "${().__class__.__base__.__subclasses__()}",
    "open_builtin": "${open('MARK', 'w').write('x')}",
    "lambda": "${(lambda: open('MARK', 'w'))()}",
    "comprehension": "${[open('MARK', 'w') for i in [1]]}",
    "python_ns": "${python.vars(python)}",
    "xacro_ns": "${xacro.load_yaml('MARK')}",
    "format": "${'{0.__class__}'.format(1)}",
    "getattr_chain": "${python.type(0).mro()}",
    "eval_subst": "$(eval open('MARK', 'w'))",
}


@pytest.mark.parametrize("name", sorted(ESCAPES))
def test_expression_escapes_are_refused_and_run_nothing(tmp_path, name):
    marker = tmp_path / "marker"
    expression = ESCAPES[name].replace("MARK", str(marker))
    path = _write(tmp_path, "evil.xacro", f"{LINK}<gazebo><x v={quoteattr(expression)}/></gazebo>")
    message = _outcome("escape", lambda: expand_xacro(path))
    assert message is not None and str(path) in message
    assert not marker.exists()


def _eval_through_property(marker: Path) -> str:
    """``$(eval ...)`` cannot hold ')', but its text is expanded first: a property brings it."""
    code = f'open("{marker}", "w").write("x")'
    return (
        f'<xacro:property name="p" value={quoteattr(repr(code))}/>{LINK}'
        '<gazebo><x v="$(eval ${p})"/></gazebo>'
    )


def test_eval_substitution_through_a_property_is_refused_but_trusted_runs(tmp_path):
    marker = tmp_path / "marker"
    path = _write(tmp_path, "evil.xacro", _eval_through_property(marker))
    with pytest.raises(UnsafeXacroExpression, match="refused") as error:
        expand_xacro(path)
    assert str(path) in str(error.value) and "--trust-xacro" in str(error.value)
    assert not marker.exists()
    expand_xacro(path, trust=True)  # full xacro: the user said the file is trusted
    assert marker.exists()


def test_cli_refuses_code_and_trust_xacro_restores_full_xacro(tmp_path, capsys):
    marker = tmp_path / "marker"
    path = _write(tmp_path, "evil.xacro", _eval_through_property(marker))
    assert main(["check", str(path)]) == 1
    error = capsys.readouterr().err
    assert error.startswith("aiauv: error: ") and error.count("\n") == 1 and "refused" in error
    assert not marker.exists()
    main(["check", str(path), "--trust-xacro"])  # the expansion runs the payload
    assert marker.exists()
    capsys.readouterr()


def test_a_scenario_cannot_grant_trust(tmp_path, capsys):
    marker = tmp_path / "marker"
    vehicle = _write(tmp_path, "evil.xacro", _eval_through_property(marker))
    for extra in ("", "trust_xacro = true\n"):
        scenario = tmp_path / "s.toml"
        scenario.write_text(f'vehicle = "{vehicle.name}"\nduration = 0.1\n{extra}')
        assert main(["simulate", str(scenario), "--out", str(tmp_path / "out"), "--no-html"]) == 1
        assert capsys.readouterr().err.count("\n") == 1
        assert not marker.exists()


#: Pieces of random expressions: names and calls that must be refused, harmless arithmetic, and
#: size bombs.
PIECES = [
    "python", "xacro", "math", "__import__", "open", "eval", "exec", "getattr", "vars", "type",
    "globals", "python.vars", "python.type", "xacro.load_yaml", "math.sin", "math.factorial",
    "pi", "p", "s", "l", "1", "2.5", "-3", "'a'", "'touch MARK'", "[1, 2]", "(1, 2)", "True",
    "9**9**9", "10**400", "2.0**4096", "'a'*10**9", "[0]*10**9", "[l]*10**5", "1 << 10**9",
    "'%0999999999d' % 1", "sin(p)", "radians(p)", "sqrt(-1)", "max(l)", "len(s)", "int('9'*5000)",
    "dict(a=1)", "p if p > 1 else -p", "not p", "p == 1 and s",
]  # fmt: skip
JOINS = [" + ", " * ", " ** ", " - ", " / ", " // ", " % ", " and ", " or ", " < ", " == ", " in "]
SUFFIXES = ["", ".__class__", "._module", ".mro()", ".system('touch MARK')", "[0]", "(1)", "()"]


def _random_expression(rng: random.Random) -> str:
    parts = [rng.choice(PIECES) + rng.choice(SUFFIXES) for _ in range(rng.randint(1, 4))]
    text = parts[0]
    for part in parts[1:]:
        text += rng.choice(JOINS) + part
    return text


def test_random_hostile_expressions_run_nothing_and_end_in_one_line(tmp_path):
    rng = random.Random(29)
    marker = tmp_path / "marker"
    for index in range(150):
        expression = _random_expression(rng).replace("MARK", str(marker))
        path = _write(
            tmp_path,
            f"e{index}.xacro",
            '<xacro:property name="p" value="2"/><xacro:property name="s" value="ab"/>'
            '<xacro:property name="l" value="${[1, 2, 3]}"/>'
            f"{LINK}<gazebo><x v={quoteattr('${' + expression + '}')}/></gazebo>",
        )
        _outcome("random expression", lambda path=path: expand_xacro(path))
        assert not marker.exists(), expression


# --------------------------------------------------------------------------------------------------
# Bombs and limits
# --------------------------------------------------------------------------------------------------

BOMBS = {
    "power": "${9**9**9}",
    "float_power": "${9.0**9**9}",
    "nested_power": "${(10**300)**(10**300)}",
    "product": "${(2**1000) * (2**1000) * (2**1000)}",
    "shift": "${1 &lt;&lt; 10**9}",
    "string": "${'a' * 10**9}",
    "list": "${[0] * 10**9}",
    "format": "${'%0999999999d' % 1}",
    "deep": "${" + "+".join(["1"] * 3000) + "}",
    "long": "${" + "1" * 20_000 + "}",
}


@pytest.mark.parametrize("name", sorted(BOMBS))
def test_expression_bombs_are_refused_quickly(tmp_path, name):
    path = _write(tmp_path, "bomb.xacro", f'{LINK}<gazebo><x v="{BOMBS[name]}"/></gazebo>')
    assert _outcome("expression bomb", lambda: expand_xacro(path)) is not None


@pytest.mark.parametrize(
    "expression", ["(10**300)**(10**300)", "[" * 500 + "]" * 500, "1" * 300 + " ** 99"]
)
def test_refusals_of_long_expressions_and_numbers_stay_short(tmp_path, expression):
    """The campaign (benchmarks/hostile_campaign.py) found refusals of 860 and 1,103 characters:
    the huge base of a power, xacro's own message quoting a whole expression. They are abridged."""
    path = _write(tmp_path, "long.xacro", f'{LINK}<gazebo><x v="${{{expression}}}"/></gazebo>')
    message = _outcome("expression bomb", lambda: expand_xacro(path))
    assert message is not None and len(message) <= 400, len(message)


def _doubling_macros(leaf: str) -> str:
    macros = f'<xacro:macro name="m0">{leaf}</xacro:macro>'
    for level in range(1, 31):
        macros += (
            f'<xacro:macro name="m{level}"><xacro:m{level - 1}/><xacro:m{level - 1}/></xacro:macro>'
        )
    return macros + "<xacro:m30/>"  # 2**30 expansions of the leaf


EXPANSION_BOMBS = {
    "doubling_macro": _doubling_macros('<link name="x"/>'),
    "doubling_empty_macro": _doubling_macros(""),
    "doubling_block": '<xacro:macro name="b" params="*x"><a><xacro:insert_block name="x"/>'
    '<xacro:insert_block name="x"/></a></xacro:macro>' + "<xacro:b>" * 25 + "<y/>" + "</xacro:b>" * 25,
    "recursive_macro": '<xacro:macro name="m"><xacro:m/></xacro:macro><xacro:m/>',
    "property_chain": "".join(
        f'<xacro:property name="p{i}" value="${{p{i - 1} + 1}}"/>' for i in range(1, 3000)
    )
    + f'<xacro:property name="p0" value="1"/>{LINK}<x v="${{p2999}}"/>',
    "string_doubling": '<xacro:property name="s0" value="ab"/>'
    + "".join(f'<xacro:property name="s{i}" value="${{s{i - 1} + s{i - 1}}}"/>' for i in range(1, 40))
    + f'{LINK}<x v="${{s39}}"/>',
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(EXPANSION_BOMBS))
def test_expansion_bombs_are_refused_in_one_line(tmp_path, name):
    path = _write(tmp_path, "bomb.xacro", EXPANSION_BOMBS[name])
    assert _outcome("expansion bomb", lambda: expand_xacro(path)) is not None


def test_hostile_includes_are_refused_in_one_line(tmp_path):
    fifo = tmp_path / "fifo.xacro"
    os.mkfifo(fifo)
    huge = tmp_path / "huge.xacro"
    with open(huge, "wb") as handle:
        handle.truncate(200_000_000)  # sparse: no disk used
    (tmp_path / "folder.xacro").mkdir()
    cases = {
        "fifo": (f'<xacro:include filename="{fifo}"/>', "not a regular file"),
        "huge": (f'<xacro:include filename="{huge}"/>', "larger than"),
        "folder": ('<xacro:include filename="folder.xacro"/>', "directory"),
        "self": ('<xacro:include filename="top_self.xacro"/>', "nested deeper"),
    }
    for name, (body, expected) in cases.items():
        path = _write(tmp_path, f"top_{name}.xacro", body)
        message = _outcome("hostile include", lambda path=path: expand_xacro(path))
        assert message is not None and expected in message, (name, message)
    # mutual recursion, and includes that double at each of 12 levels (4096 files)
    _write(tmp_path, "ping.xacro", '<xacro:include filename="pong.xacro"/>')
    _write(tmp_path, "pong.xacro", '<xacro:include filename="ping.xacro"/>')
    for level in range(12):
        _write(tmp_path, f"d{level}.xacro", f'<xacro:include filename="d{level + 1}.xacro"/>' * 2)
    _write(tmp_path, "d12.xacro", "")
    for name, expected in (("ping.xacro", "nested deeper"), ("d0.xacro", "xacro files read")):
        message = _outcome("hostile include", lambda n=name: expand_xacro(tmp_path / n))
        assert message is not None and expected in message, (name, message)
    # the top file itself
    message = _outcome("hostile include", lambda: aiauv_pin.load_vehicle(fifo))
    assert message is not None and "not a regular file" in message


def test_limits_apply_with_trust_too(tmp_path):
    fifo = tmp_path / "fifo.xacro"
    os.mkfifo(fifo)
    for body in (f'<xacro:include filename="{fifo}"/>', _doubling_macros("")):
        path = _write(tmp_path, "t.xacro", body)
        with pytest.raises(InputLimitError):
            expand_xacro(path, trust=True)


# --------------------------------------------------------------------------------------------------
# SDF and gz inputs
# --------------------------------------------------------------------------------------------------


def test_sdf_and_urdf_fifos_and_oversize_files_are_refused(tmp_path, capsys):
    fifo = tmp_path / "model.sdf"
    os.mkfifo(fifo)
    oversize = tmp_path / "big.sdf"
    with open(oversize, "wb") as handle:
        handle.truncate(MAX_SDF_BYTES + 1)
    urdf_fifo = tmp_path / "vehicle.urdf"
    os.mkfifo(urdf_fifo)
    urdf = aiauv_pin.bundled_urdf("uniform")
    for sdf, expected in ((fifo, "not a regular file"), (oversize, "larger than")):
        message = _outcome("SDF input", lambda sdf=sdf: read_gz_model(sdf))
        assert message is not None and expected in message
        message = _outcome("SDF input", lambda sdf=sdf: import_gz(sdf, urdf, tmp_path / "out.urdf"))
        assert message is not None and expected in message
        assert main(["import-gz", str(sdf), "--urdf", str(urdf), "-o", str(tmp_path / "o.urdf")])
        assert capsys.readouterr().err.count("\n") == 1
    for argv in (
        ["export", str(urdf_fifo), "-o", str(tmp_path / "o.sdf")],
        ["import-gz", str(oversize), "--urdf", str(urdf_fifo), "-o", str(tmp_path / "o.urdf")],
    ):
        start = time.monotonic()
        assert main(argv) == 1
        assert time.monotonic() - start < BUDGET
        error = capsys.readouterr().err
        assert error.startswith("aiauv: error: ") and error.count("\n") == 1
        TALLY["SDF input: refused"] += 1
    assert not (tmp_path / "o.urdf").exists() and not (tmp_path / "o.sdf").exists()


@pytest.mark.parametrize(
    "pattern, replacement, expected",
    [
        (r"(<sphere>\s*<radius>)[^<]*", r"\g<1>1e308", "sphere <radius>"),
        (
            r"<sphere>\s*<radius>[^<]*</radius>\s*</sphere>",
            "<box><size>1 1e308 1</size></box>",
            "box <size>",
        ),
        (r"(<xx>)[^<]*", r"\g<1>1e308", "does not load"),
    ],
)
def test_import_gz_refuses_what_the_gate_refuses(tmp_path, pattern, replacement, expected):
    """The campaign: a collision sphere of radius 1e308 surfaced as OverflowError; an added mass of
    1e308 (and damping not positive semi-definite) were written. Sizes are checked
    against the gate's distances, and the written URDF is loaded through the gate first."""
    from aiauv_pin.interop.gz import export_sdf

    urdf = aiauv_pin.bundled_urdf("uniform")
    sdf = tmp_path / "model.sdf"
    export_sdf(urdf, sdf)
    sdf.write_text(re.sub(pattern, replacement, sdf.read_text(), count=1))  # the first collision
    out = tmp_path / "out.urdf"
    message = _outcome("SDF input", lambda: import_gz(sdf, urdf, out))
    assert message is not None and expected in message, message
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["model.sdf"]


def test_sdf_element_limit_is_the_urdf_one(tmp_path):
    """An SDF under the byte limit but with 300,000 elements was imported (the campaign): the
    URDF's element and attribute limits apply to SDF too, before any tree is built."""
    from aiauv_pin.description.input_limits import MAX_XML_ELEMENTS
    from aiauv_pin.interop.gz import export_sdf

    sdf = tmp_path / "model.sdf"
    export_sdf(aiauv_pin.bundled_urdf("uniform"), sdf)
    read_gz_model(sdf)  # the exported file reads
    text = sdf.read_text().replace("</model>", "<frame name='f'/>" * 300_000 + "</model>", 1)
    sdf.write_text(text)
    message = _outcome("SDF input", lambda: read_gz_model(sdf))
    assert message is not None and f"more than {MAX_XML_ELEMENTS} XML elements" in message
    wide = tmp_path / "wide.sdf"
    attributes = " ".join(f'a{i}="{i}"' for i in range(100))
    wide.write_text(
        sdf.read_text().replace("<frame name='f'/>" * 300_000, f"<frame {attributes}/>")
    )
    message = _outcome("SDF input", lambda: read_gz_model(wide))
    assert message is not None and "attributes" in message


# --------------------------------------------------------------------------------------------------
# Legitimate files
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "arguments", [{}, {"with_arm": "false", "namespace": "r2"}, {"max_thrust": "1500"}]
)
def test_uuv_vehicles_expand_identically_with_the_safe_evaluator(arguments):
    safe = expand_xacro(MINIROV, arguments, package_path=[PACKAGES])
    trusted = expand_xacro(MINIROV, arguments, package_path=[PACKAGES], trust=True)
    assert safe == trusted


def test_uuv_vehicle_numbers_are_the_trusted_ones():
    safe = aiauv_pin.load_vehicle(MINIROV, package_path=[PACKAGES], backend="pinocchio")
    trusted = aiauv_pin.load_vehicle(
        MINIROV, package_path=[PACKAGES], backend="pinocchio", trust_xacro=True
    )
    q = safe.neutral_configuration()
    np.testing.assert_array_equal(safe.mass_matrix(q), trusted.mass_matrix(q))
    np.testing.assert_array_equal(safe.thrust_matrix(q), trusted.thrust_matrix(q))


def test_what_the_safe_evaluator_allows_matches_xacro(tmp_path):
    """Arithmetic, math, comparisons, conditionals, strings, containers, namespaces, $(eval)."""
    (tmp_path / "inc.xacro").write_text(
        HEAD + '<xacro:property name="width" value="0.25"/></robot>', encoding="utf-8"
    )
    body = (
        '<xacro:arg name="arm" default="true"/>'
        '<xacro:include filename="inc.xacro" ns="parts"/>'
        '<xacro:property name="d2r" value="${pi / 180}"/>'
        "<xacro:property name=\"dims\" value=\"${dict(a=[1, 2.5, 'x y'], b=[3, 4, 'z'])}\"/>"
        '<xacro:property name="n" value="3"/>'
        '<xacro:macro name="box" params="name size:=1 *origin">'
        '<link name="${name}_link"><x v="${size ** 2 / 2}" w="${name + \'_\' + str(size)}"/>'
        '<xacro:insert_block name="origin"/></link></xacro:macro>'
        '<xacro:box name="a" size="${dims[\'a\'][1]}"><origin rpy="0 ${-90 * d2r} 0"/></xacro:box>'
        '<xacro:if value="${n &gt; 2 and not (n == 5)}"><k v="${max(1, n) if n else 0}"/></xacro:if>'
        '<xacro:unless value="$(arg arm)"><no/></xacro:unless>'
        '<t v="${sin(radians(30))} ${math.cos(math.pi)} ${sqrt(2)} ${atan2(1, 1)} ${fabs(-n)}"/>'
        "<t v=\"${round(2.567, 2)} ${int(7 / 2)} ${float('1.5')} ${len(dims)} ${n % 2} ${n // 2}\"/>"
        "<t v=\"${parts.width * 2} ${'x' in dims['a'][2]} ${[1, 2][-1]} ${(1, 2) &lt; (1, 3)}\"/>"
        '<t v="$(eval 2 * 3 + 1 if arm else 0)" w="$(eval arm and 2 ** 3)"/>'
    )
    path = _write(tmp_path, "ok.xacro", body)
    safe = expand_xacro(path, {"arm": "true"})
    assert safe == expand_xacro(path, {"arm": "true"}, trust=True)
    assert 'x v="3.125"' in safe and "a_2.5" in safe and "<k v=" in safe and "0.5" in safe
