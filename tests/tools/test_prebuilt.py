"""The compiled kernels shipped with the package (aiauv_hydro.numerics.kernel_cache,
aiauv_pin.tools.kernel_archive)."""

from __future__ import annotations

import json
import pickle
import platform
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

from aiauv_hydro.numerics import kernel_cache as prebuilt
from aiauv_hydro.numerics.jit import cache_key, source_hash
from aiauv_pin.simulation.compilation import COMPILE_NOTICE, default_target_environment

ROOT = Path(__file__).resolve().parents[2]
#: The CPython versions archives are shipped for (README, Performance).
SHIPPED = ("py310", "py311", "py312", "py313")

V3 = dict.fromkeys(prebuilt.PORTABLE_CPU_FEATURES, True)


def numba_requirement() -> Requirement:
    """numba's requirement in pyproject.toml."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib
    dependencies = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    return next(r for r in map(Requirement, dependencies) if r.name == "numba")


def test_numba_is_a_range_that_holds_the_installed_one():
    """A range, not a pin (issue 28): other packages may need another numba."""
    specifier = numba_requirement().specifier
    assert len(specifier) == 2 and all(s.operator in ("<", ">=") for s in specifier), specifier
    numba = pytest.importorskip("numba")
    assert Version(numba.__version__) in specifier


def test_portable_target_decision():
    assert prebuilt.portable_target_wanted({}, "x86_64", V3)
    assert prebuilt.portable_target_wanted({"AIAUV_NATIVE_CPU": "0"}, "AMD64", V3)
    assert not prebuilt.portable_target_wanted({"AIAUV_NATIVE_CPU": "1"}, "x86_64", V3)
    assert not prebuilt.portable_target_wanted({"NUMBA_CPU_NAME": "generic"}, "x86_64", V3)
    assert not prebuilt.portable_target_wanted({"NUMBA_CPU_FEATURES": "+avx"}, "x86_64", V3)
    assert not prebuilt.portable_target_wanted({}, "aarch64", V3)
    for feature in prebuilt.PORTABLE_CPU_FEATURES:  # an older CPU: every feature is needed
        assert not prebuilt.portable_target_wanted({}, "x86_64", {**V3, feature: False})


@pytest.mark.parametrize("tag", SHIPPED)
def test_shipped_archive_is_current(tag):
    """Fails after any change to a compiled source until ``python -m aiauv_pin.tools.kernel_archive`` runs."""
    path = ROOT / "aiauv_pin" / "kernels" / "shipped" / f"{tag}.zip"
    assert path.is_file(), (
        f"{path} missing: build it with python -m aiauv_pin.tools.kernel_archive --python"
    )
    with zipfile.ZipFile(path) as archive:
        manifest = prebuilt.Manifest.from_json(archive.read(prebuilt.MANIFEST).decode())
        names = archive.namelist()
    assert manifest.source_hash == source_hash(), (
        f"{path.name} was built from other sources: rebuild with python -m aiauv_pin.tools.kernel_archive"
    )
    assert manifest.python_tag == tag
    assert manifest.cpu_name == prebuilt.PORTABLE_CPU_NAME
    assert Version(manifest.numba) in numba_requirement().specifier  # an installable numba
    loop = "aiauv_pin/simulation/compiled_loop.run_chunk-"
    assert any(n.startswith(loop) and n.endswith(".nbi") for n in names)


def _synthetic_archive(tmp_path: Path, stamp: str) -> prebuilt.Archive:
    manifest = prebuilt.Manifest(stamp, "0", prebuilt.python_tag(), "triple", "x86-64-v3", ())
    path = tmp_path / "archive.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr(prebuilt.MANIFEST, manifest.to_json())
        for function in ("f", "g"):
            index = pickle.dumps("0") + pickle.dumps((stamp, {"key": f"m.{function}-1.py3.1.nbc"}))
            archive.writestr(f"hydro/m.{function}-1.py3.nbi", index)
            archive.writestr(f"hydro/m.{function}-1.py3.1.nbc", f"code of {function}".encode())
        archive.writestr("control/m.h-1.py3.nbi", pickle.dumps("0") + pickle.dumps((stamp, {})))
    return prebuilt.Archive(path)


def test_seeding_fills_missing_entries_and_keeps_existing_ones(tmp_path):
    archive = _synthetic_archive(tmp_path, "current")
    assert archive.manifest.source_hash == "current"
    cache = tmp_path / "cache"
    cache.mkdir()
    # the user's own (e.g. a passive run's loop): kept, even when it cannot be unpickled here
    kept = pickle.dumps("0") + b"a signature naming a class of a module not yet imported"
    (cache / "m.f-1.py3.nbi").write_bytes(kept)
    assert prebuilt.seed_folder(archive, "hydro", cache) == 1
    assert (cache / "m.f-1.py3.nbi").read_bytes() == kept
    assert not (cache / "m.f-1.py3.1.nbc").exists()
    assert (cache / "m.g-1.py3.nbi").read_bytes() == archive_bytes(archive, "hydro/m.g-1.py3.nbi")
    assert (cache / "m.g-1.py3.1.nbc").read_bytes() == b"code of g"
    # the other folder's entry is not copied here, and no temporary file is left
    assert sorted(p.name for p in cache.iterdir()) == [
        "m.f-1.py3.nbi",
        "m.g-1.py3.1.nbc",
        "m.g-1.py3.nbi",
    ]
    assert prebuilt.seed_folder(archive, "hydro", cache) == 0  # all there now


def archive_bytes(archive: prebuilt.Archive, name: str) -> bytes:
    with zipfile.ZipFile(archive.path) as opened:
        return opened.read(name)


def test_interrupted_seeding_leaves_no_index_without_its_data(tmp_path, monkeypatch):
    archive = _synthetic_archive(tmp_path, "current")
    cache = tmp_path / "cache"
    cache.mkdir()
    written = []

    def fail_on_second(path, data):
        if written:
            raise OSError("disk full")
        written.append(path.name)
        path.write_bytes(data)

    monkeypatch.setattr(prebuilt, "_write_atomically", fail_on_second)
    with pytest.raises(OSError):
        prebuilt.seed_folder(archive, "hydro", cache)
    assert written == ["m.f-1.py3.1.nbc"]  # data first: the index naming it never appeared
    assert not list(cache.glob("*.nbi"))


def test_unreadable_archive_warns_once_and_is_not_used(tmp_path, monkeypatch):
    broken = tmp_path / "py3.zip"
    broken.write_bytes(b"PK\x03\x04 not a zip archive")
    monkeypatch.setattr(prebuilt, "archive_path", lambda: broken)
    monkeypatch.delenv("AIAUV_PREBUILT_KERNELS", raising=False)
    prebuilt._usable_archive.cache_clear()
    try:
        with pytest.warns(prebuilt.PrebuiltCacheWarning, match="unreadable"):
            assert prebuilt._usable_archive("stamp") is None
        assert prebuilt.status().startswith("unreadable")
    finally:
        prebuilt._usable_archive.cache_clear()


def test_manifest_mismatches_are_named(monkeypatch):
    numba = pytest.importorskip("numba")
    import llvmlite.binding as llvm

    monkeypatch.setenv("NUMBA_CPU_NAME", "x86-64-v3")
    monkeypatch.setenv("NUMBA_CPU_FEATURES", "")
    good = prebuilt.Manifest(
        "s", numba.__version__, prebuilt.python_tag(), llvm.get_process_triple(), "x86-64-v3", ()
    )
    assert good.mismatch("s") is None
    assert good.mismatch("other") == "built from other sources"
    cases = {
        "numba": "built with numba 0.1",
        "python_tag": "built for py27",
        "triple": "built for sparc",
        "cpu_name": "built for CPU generic",
    }
    values = {"numba": "0.1", "python_tag": "py27", "triple": "sparc", "cpu_name": "generic"}
    import dataclasses

    for field, start in cases.items():
        reason = dataclasses.replace(good, **{field: values[field]}).mismatch("s")
        assert reason is not None and reason.startswith(start), (field, reason)
    monkeypatch.setenv("NUMBA_CPU_FEATURES", "+avx")  # the CPU's name alone does not fix the code
    assert good.mismatch("s").startswith("built for CPU x86-64-v3")
    with pytest.raises(ValueError, match="format"):
        prebuilt.Manifest.from_json('{"format": 99}')


def _shipped_kernels_serve_this_process() -> str | None:
    if platform.machine().lower() not in ("x86_64", "amd64") or not sys.platform.startswith(
        "linux"
    ):
        return "kernels are shipped for x86-64 Linux only"
    import aiauv_hydro.numerics.jit

    if not aiauv_hydro.numerics.jit.PORTABLE_TARGET:
        return "numba does not compile for x86-64-v3 here (an older CPU, or the user's setting)"
    if not prebuilt.archive_path().is_file():
        return f"no archive shipped for {prebuilt.python_tag()}"
    return None


@pytest.mark.parametrize(
    "arguments",
    [
        ["simulate", "--duration", "1", "--no-html"],  # the quick start's command
        ["simulate", "--duration", "0.2", "--no-html", "--method", "rk4", "--case", "stabilised"],
        # a passive run of a foreign vehicle: the loop's types do not depend on the vehicle
        ["simulate", "--duration", "0.2", "--no-html", "--controller", "none", "--vehicle",
         str(ROOT / "tests" / "data" / "two_link_hydro.urdf")],
        ["simulate", "--duration", "0.2", "--no-html", "--controller", "thruster_turning"],
        ["simulate", "--duration", "0.2", "--no-html", "--controller", "gait"],
    ],
)  # fmt: skip
def test_a_new_installation_compiles_nothing(tmp_path, arguments):
    """An empty numba cache, as in a new installation: the shipped kernels serve the first run."""
    pytest.importorskip("numba")
    reason = _shipped_kernels_serve_this_process()
    if reason is not None:
        pytest.skip(reason)
    env = default_target_environment()
    env.update(
        NUMBA_CACHE_DIR=str(tmp_path / "cache"),
        NUMBA_DEBUG_CACHE="1",
        XDG_CACHE_HOME=str(tmp_path / "xdg"),
    )
    done = subprocess.run(
        [sys.executable, "-m", "aiauv_pin", *arguments, "--out", str(tmp_path / "out")],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    output = done.stdout + done.stderr
    assert "compiling kernels" not in output
    assert "data saved" not in output  # numba saves what it compiled: nothing
    assert "data loaded" in output
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["compiled_now"] is False


@pytest.mark.parametrize(
    ("before", "portable"),
    [("import numba", True), ("import numba; numba.njit(lambda x: x + 1)(1)", False)],
)
def test_the_target_is_chosen_only_while_numba_has_compiled_nothing(before, portable):
    """numba imported first: its settings are re-read; something compiled first: left alone."""
    pytest.importorskip("numba")
    import aiauv_hydro.numerics.jit

    if not aiauv_hydro.numerics.jit.PORTABLE_TARGET:
        pytest.skip("numba does not compile for x86-64-v3 here")
    env = default_target_environment()
    code = (
        f"{before}\nimport aiauv_hydro.numerics.jit\nfrom numba.core import config\n"
        "print(aiauv_hydro.numerics.jit.PORTABLE_TARGET, config.CPU_NAME)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    expected = f"{portable} {prebuilt.PORTABLE_CPU_NAME if portable else None}"
    assert done.stdout.strip() == expected


def test_the_first_failed_copy_warns_and_ends_the_unpacking(tmp_path, monkeypatch):
    archive = _synthetic_archive(tmp_path, "current")
    monkeypatch.setattr(prebuilt, "_usable_archive", lambda source_hash: archive)
    monkeypatch.setitem(prebuilt._state, "seeded", set())
    monkeypatch.setitem(prebuilt._state, "failed", False)
    monkeypatch.setitem(prebuilt._state, "status", "not consulted")
    calls = []

    def disk_full(*arguments):
        calls.append(arguments[1])
        raise OSError("disk full")

    monkeypatch.setattr(prebuilt, "seed_folder", disk_full)
    with pytest.warns(prebuilt.PrebuiltCacheWarning, match="disk full"):
        prebuilt.seed(str(tmp_path / "cache" / "hydro"), "hydro", "current")
    assert prebuilt.status() == "seeding failed (disk full)"
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no second warning, no second attempt
        prebuilt.seed(str(tmp_path / "cache" / "control"), "control", "current")
    assert calls == ["hydro"]


#: Runs ``aiauv`` as if the installed numba were another version than the shipped kernels' (the
#: range in pyproject.toml allows it), then says what became of the shipped kernels.
OTHER_NUMBA = """
import sys
import numba
numba.__version__ = "0.0+other"  # read by the manifest check and by numba's own cache index
from aiauv_pin.app.cli import main
from aiauv_hydro.numerics import kernel_cache as prebuilt
code = main(sys.argv[1:])
print("shipped kernels:", prebuilt.status(), file=sys.stderr)
sys.exit(code)
"""


@pytest.mark.slow
def test_another_numba_compiles_once_into_the_user_cache_and_every_later_run_reuses_it(tmp_path):
    """The mismatch path of the numba range: the shipped kernels are not used, the kernels compile
    once (with the notice) into the per-user cache, and a second run of each built-in controller,
    on the bundled and on a foreign vehicle, compiles nothing (issue 28: the passive run compiled
    in every process). About two minutes of CPU: the one full compilation of the suite."""
    pytest.importorskip("numba")
    env = default_target_environment()
    env.update(NUMBA_CACHE_DIR=str(tmp_path / "cache"), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    foreign = str(ROOT / "tests" / "data" / "two_link_hydro.urdf")
    runs = {
        "paper": ["--duration", "0.2"],
        "passive": ["--duration", "0.2", "--controller", "none", "--vehicle", foreign],
        "turning": ["--duration", "0.2", "--controller", "thruster_turning"],
        "gait": ["--duration", "0.2", "--controller", "gait"],
    }

    def simulate(name: str) -> tuple[bool, str]:
        out = tmp_path / f"{name}-{len(list(tmp_path.glob(name + '-*')))}"
        done = subprocess.run(
            [sys.executable, "-c", OTHER_NUMBA, "simulate", "--no-html", "--out", str(out)]
            + runs[name],
            env=env,
            capture_output=True,
            text=True,
            timeout=900,
        )
        assert done.returncode == 0, done.stderr
        summary = json.loads((out / "summary.json").read_text())
        noticed = COMPILE_NOTICE in done.stderr
        assert summary["compiled_now"] is noticed, done.stderr  # the notice iff compilation
        assert "set-up" in done.stdout and "simulation" in done.stdout
        return summary["compiled_now"], done.stderr

    compiled, stderr = simulate("paper")
    assert compiled
    assert "shipped kernels: not used: built with numba" in stderr or "none shipped" in stderr
    for name in runs:
        if name != "paper":
            simulate(name)  # may compile what the paper's run did not
    for name in runs:
        compiled, stderr = simulate(name)
        assert not compiled, f"the second {name} run compiled: {stderr}"
    cache = tmp_path / "cache" / "aiauv-pin"
    assert [p.name for p in cache.iterdir()] == [cache_key()]
    loop_folder = cache / cache_key() / "aiauv_pin" / "simulation"
    assert list(loop_folder.glob("compiled_loop.run_chunk-*.nbi"))
