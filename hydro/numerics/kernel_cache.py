"""Compiled kernels shipped with the package: numba's on-disk cache, built once and seeded on use.

numba compiles the project's kernels on their first call and keeps the machine code in its
on-disk cache (:mod:`aiauv_hydro.numerics.jit`). Without help, every new installation would compile
for about a
minute before its first result. The package therefore ships that cache:
the project's kernel-archive builder runs the common workloads (the paper scenario by both
integrators, both vehicle cases, a batch rollout) in a fresh cache and packs what numba wrote into
``<python tag>.zip`` in the folder a package declares (:data:`ARCHIVES_GROUP`), one archive per
CPython version, with a manifest. Its entries
are named by source folder (``pkg/sub/module.function-<line>.py311.nbi``: the folder's
path from the project's packages, :func:`aiauv_hydro.numerics.jit.project_path`). When a compiled
function of the
project is defined, :func:`seed` copies that function's source folder's entries from the archive
(read from the package data, never written) into the same folder of the per-user cache
(:func:`aiauv_hydro.numerics.jit.cache_folder`), unless a current entry is already there. numba
then loads them
as if it had compiled them itself.

What makes a shipped entry valid is numba's own rule. numba uses an entry only when its version,
the source stamp (here the content hash :func:`aiauv_hydro.numerics.jit.source_hash`), the function's bytecode
and signature, the target triple and the CPU name and features all match; anything else it
compiles as usual. The manifest records the first and the platform, so that an archive built for
other sources, another numba or another platform is not even unpacked.

The CPU name and features are the part a native build would tie to one machine: numba compiles for
the host's exact CPU by default. On an x86-64 host that has the x86-64-v3 level (AVX2, FMA, BMI2,
MOVBE; Intel Haswell and AMD Excavator onwards; x86-64 psABI, "Micro-architecture levels"),
:func:`choose_portable_target` therefore makes numba compile for that level, so that one shipped
archive serves every such machine (portable and native code run equally fast within a shared
machine's noise; the docs' performance page has the figures). It does so through numba's own settings
``NUMBA_CPU_NAME``/``NUMBA_CPU_FEATURES``, and only when the user set neither; numba reads them
for every compiled function of the process, the user's own included.

Environment switches:

* ``AIAUV_NATIVE_CPU=1``: compile for the host's exact CPU (the shipped kernels then never match);
* ``AIAUV_PREBUILT_KERNELS=0``: do not unpack the shipped kernels (compile everything).

Which numba serves: the project accepts a range of numba versions (``pyproject.toml``); the shipped
kernels are used only when the manifest's numba is the installed one (numba rejects cache entries
of another version anyway); otherwise the kernels are compiled once into the per-user cache.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import sys
import tempfile
import warnings
import zipfile
from functools import lru_cache
from pathlib import Path

#: The CPU name numba compiles for when the host has every feature of it (x86-64 psABI level 3).
PORTABLE_CPU_NAME = "x86-64-v3"

#: LLVM feature names of the x86-64-v3 level (x86-64 psABI, "Micro-architecture levels": v2 adds
#: CMPXCHG16B, LAHF-SAHF, POPCNT, SSE3, SSE4.1, SSE4.2, SSSE3 to the baseline; v3 adds AVX, AVX2,
#: BMI1, BMI2, F16C, FMA, LZCNT, MOVBE, XSAVE). The host must have all of them.
PORTABLE_CPU_FEATURES = (
    "cx16", "sahf", "popcnt", "sse3", "sse4.1", "sse4.2", "ssse3",
    "avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave",
)  # fmt: skip

#: Version of the archive layout (the manifest's ``format``).
ARCHIVE_FORMAT = 1

#: Name of the manifest inside an archive.
MANIFEST = "manifest.json"


class PrebuiltCacheWarning(UserWarning):
    """The shipped kernels could not be read; numba compiles instead."""


def python_tag() -> str:
    """The Python part of numba's cache file names, e.g. ``py311`` (numba's ``_CacheImpl``)."""
    return f"py{sys.version_info[0]}{sys.version_info[1]}{getattr(sys, 'abiflags', '')}"


#: The entry-point group through which a package declares the folder of its shipped archives
#: (``"package.subpackage:folder"``; this floor names no package above it).
ARCHIVES_GROUP = "aiauv.kernel_archives"


@lru_cache(maxsize=1)
def declared_entry_points():
    """The entry points of every installed distribution, read once per process: reading them
    opens each distribution's ``entry_points.txt`` (about 5 ms with the test dependencies
    installed), and :func:`archive_path` and :func:`aiauv_hydro.numerics.jit.compiled_sources`
    both look in them at every start."""
    from importlib import metadata

    return metadata.entry_points()


def archive_path() -> Path:
    """Where this Python's shipped archive is (it may not exist): ``<python tag>.zip`` in the folder
    declared in :data:`ARCHIVES_GROUP` (the first, by entry name)."""
    entries = sorted(
        declared_entry_points().select(group=ARCHIVES_GROUP), key=lambda entry: entry.name
    )
    if not entries:
        return Path(f"no-archive-declared/{python_tag()}.zip")
    package, _, folder = entries[0].value.partition(":")
    top, _, inside = package.partition(".")
    # found as import would find it, without importing it (this runs while packages import)
    spec = importlib.util.find_spec(top)
    if spec is None or not spec.submodule_search_locations:
        return Path(f"no-archive-declared/{python_tag()}.zip")
    root = Path(next(iter(spec.submodule_search_locations)))
    return root.joinpath(*(inside.split(".") if inside else ()), folder, f"{python_tag()}.zip")


def portable_target_wanted(environ, machine: str, host_features: dict[str, bool]) -> bool:
    """Whether numba should compile for :data:`PORTABLE_CPU_NAME` (the decision alone).

    Args:
        environ: The environment (a mapping).
        machine: ``platform.machine()``.
        host_features: LLVM feature name -> whether the host has it.
    """
    if "NUMBA_CPU_NAME" in environ or "NUMBA_CPU_FEATURES" in environ:
        return False  # the user's own choice
    if environ.get("AIAUV_NATIVE_CPU", "0") not in ("", "0"):
        return False
    if machine.lower() not in ("x86_64", "amd64"):
        return False
    return all(host_features.get(name, False) for name in PORTABLE_CPU_FEATURES)


def _host_features() -> dict[str, bool]:
    import llvmlite.binding as llvm

    return {name: bool(on) for name, on in llvm.get_host_cpu_features().items()}


def choose_portable_target() -> bool:
    """Make numba compile for :data:`PORTABLE_CPU_NAME` if wanted; return whether it does.

    Call before numba compiles anything. If numba's CPU target is already set up (something was
    compiled before this package was imported), nothing changes: the shipped kernels then do not
    match and numba compiles as usual.
    """
    import platform

    try:
        wanted = portable_target_wanted(os.environ, platform.machine(), _host_features())
    except Exception:  # no llvmlite, or one without a host-feature query: numba's defaults
        return False
    if not wanted:
        return os.environ.get("NUMBA_CPU_NAME") == PORTABLE_CPU_NAME
    loaded = "numba" in sys.modules  # then numba read its settings already
    if loaded:
        from numba.core.registry import cpu_target

        if "_toplevel_target_context" in vars(cpu_target):
            return False  # numba's code generator exists: its CPU is fixed
    os.environ["NUMBA_CPU_NAME"] = PORTABLE_CPU_NAME
    os.environ["NUMBA_CPU_FEATURES"] = ""  # the features of the CPU name, none of the host's
    if loaded:
        from numba.core import config

        config.reload_config()
    return True


@dataclasses.dataclass(frozen=True)
class Manifest:
    """What an archive was built for (written by the project's kernel-archive builder).

    Attributes:
        source_hash: :func:`aiauv_hydro.numerics.jit.source_hash` of the sources it was compiled from.
        numba: numba's version.
        python_tag: See :func:`python_tag`.
        triple: LLVM target triple of the process that built it.
        cpu_name: ``NUMBA_CPU_NAME`` it was built with.
        workloads: What was run to fill it.
    """

    source_hash: str
    numba: str
    python_tag: str
    triple: str
    cpu_name: str
    workloads: tuple[str, ...]

    @classmethod
    def from_json(cls, text: str) -> Manifest:
        data = json.loads(text)
        if data.get("format") != ARCHIVE_FORMAT:
            raise ValueError(f"archive format {data.get('format')!r}, expected {ARCHIVE_FORMAT}")
        return cls(
            source_hash=str(data["source_hash"]),
            numba=str(data["numba"]),
            python_tag=str(data["python_tag"]),
            triple=str(data["triple"]),
            cpu_name=str(data["cpu_name"]),
            workloads=tuple(str(w) for w in data["workloads"]),
        )

    def to_json(self) -> str:
        data = {"format": ARCHIVE_FORMAT, **dataclasses.asdict(self)}
        data["workloads"] = list(self.workloads)
        return json.dumps(data, indent=1, sort_keys=True) + "\n"

    def mismatch(self, source_hash: str) -> str | None:
        """Why this archive cannot serve the running process, or ``None`` if it can."""
        import llvmlite.binding as llvm
        import numba

        if self.numba != numba.__version__:  # first: the one a user can act on (pyproject's range)
            return f"built with numba {self.numba}, running {numba.__version__}"
        if self.source_hash != source_hash:
            return "built from other sources"
        if self.python_tag != python_tag():
            return f"built for {self.python_tag}, running {python_tag()}"
        if self.triple != llvm.get_process_triple():
            return f"built for {self.triple}, running {llvm.get_process_triple()}"
        cpu = (os.environ.get("NUMBA_CPU_NAME"), os.environ.get("NUMBA_CPU_FEATURES"))
        if cpu != (self.cpu_name, ""):
            return f"built for CPU {self.cpu_name}, compiling for {cpu[0] or 'the host'}"
        return None


class Archive:
    """An opened archive: its manifest and, per source folder, its cache files."""

    def __init__(self, path: Path):
        self.path = path
        with zipfile.ZipFile(path) as archive:
            self.manifest = Manifest.from_json(archive.read(MANIFEST).decode())
            self.files: dict[str, dict[str, zipfile.ZipInfo]] = {}
            for info in archive.infolist():
                folder, _, name = info.filename.rpartition("/")
                if folder and name:
                    self.files.setdefault(folder, {})[name] = info


#: This process's state: what became of the archive, the (cache folder, source folder) pairs
#: already seeded, and whether a copy failed (then nothing more is unpacked).
_state: dict[str, object] = {"status": "not consulted", "seeded": set(), "failed": False}


def status() -> str:
    """What became of the shipped kernels in this process (for messages and tests)."""
    return str(_state["status"])


@lru_cache(maxsize=1)
def _usable_archive(source_hash: str) -> Archive | None:
    if os.environ.get("AIAUV_PREBUILT_KERNELS", "1") in ("0", ""):
        _state["status"] = "switched off (AIAUV_PREBUILT_KERNELS=0)"
        return None
    path = archive_path()
    if not path.is_file():
        _state["status"] = f"none shipped for {python_tag()}"
        return None
    try:
        archive = Archive(path)
    except (OSError, RuntimeError, zipfile.BadZipFile, KeyError, ValueError, TypeError) as error:
        _state["status"] = f"unreadable ({error})"
        warnings.warn(
            f"aiauv: the shipped compiled kernels {path} are unreadable ({error}); compiling instead",
            PrebuiltCacheWarning,
            stacklevel=2,
        )
        return None
    reason = archive.manifest.mismatch(source_hash)
    if reason is not None:
        _state["status"] = f"not used: {reason}"
        return None
    _state["status"] = "used"
    return archive


def _write_atomically(path: Path, data: bytes) -> None:
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(data)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def seed_folder(archive: Archive, folder: str, cache_path: Path) -> int:
    """Copy ``folder``'s entries of ``archive`` into ``cache_path``; return how many indexes.

    Only indexes missing from ``cache_path`` are copied, with their data files: an index already
    there is current (the cache folder is keyed by the sources' hash,
    :func:`aiauv_hydro.numerics.jit.cache_key`)
    and may hold the user's own compilations. It is not opened to check: its signatures name classes
    of modules still being imported when seeding runs, and an index that failed to load must not be
    taken as stale and replaced, or every run would compile again what it had saved.
    Each index is written after its data files, each file to a temporary name first, so that an
    interrupted copy leaves no index naming a missing file.

    Args:
        archive: The shipped archive.
        folder: A source folder's project path, e.g. ``"pkg/sub"``.
        cache_path: The cache folder of that source folder's functions.
    """
    files = archive.files.get(folder, {})
    missing = [
        (name, info)
        for name, info in sorted(files.items())
        if name.endswith(".nbi") and not (cache_path / name).exists()
    ]
    if not missing:
        return 0
    with zipfile.ZipFile(archive.path) as opened:
        for name, info in missing:
            prefix = name[: -len("nbi")]  # data files: <prefix><n>.nbc
            for data_name, data_info in files.items():
                if data_name.startswith(prefix) and data_name.endswith(".nbc"):
                    _write_atomically(cache_path / data_name, opened.read(data_info))
            _write_atomically(cache_path / name, opened.read(info))
    return len(missing)


def seed(cache_path: str, folder: str, source_hash: str) -> None:
    """Unpack the shipped entries of the source folder ``folder`` into ``cache_path`` (once each).

    Called by :class:`aiauv_hydro.numerics.jit.ProjectCacheLocator` when a compiled function is defined; the
    archive is only read, never written. The first error is reported as
    :class:`PrebuiltCacheWarning` and ends the unpacking for this process; numba then compiles what
    it does not find.

    Args:
        cache_path: The cache folder of ``folder``'s functions (in the per-user cache).
        folder: A source folder's project path, e.g. ``"pkg/sub"``.
        source_hash: The running sources' stamp.
    """
    key = (cache_path, folder)
    seeded: set = _state["seeded"]  # type: ignore[assignment]
    if key in seeded or _state["failed"]:
        return
    seeded.add(key)
    archive = _usable_archive(source_hash)
    if archive is None:
        return
    try:
        seed_folder(archive, folder, Path(cache_path))
    except (OSError, RuntimeError, zipfile.BadZipFile, KeyError) as error:
        _state["status"] = f"seeding failed ({error})"
        _state["failed"] = True
        warnings.warn(
            f"aiauv: could not unpack the shipped compiled kernels into {cache_path} ({error}); "
            "compiling instead",
            PrebuiltCacheWarning,
            stacklevel=2,
        )
