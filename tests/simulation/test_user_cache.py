"""A user's compiled functions are compiled once per installation and content (issue 28, 34).

The compiled loop that runs a user's controller, path, current or disturbance is cached under the
content of those functions (aiauv_hydro.numerics.function_identity,
aiauv_pin.simulation.compiled_loop.loop_for): a second process compiles nothing and gives the same
result; editing the function compiles again.
"""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
import textwrap

import pytest

from aiauv_hydro.numerics.function_identity import (
    UUID_PREFIX,
    content_identity,
    saving_only_what_pickles,
    stable_uuid,
)
from aiauv_pin.simulation.compilation import default_target_environment

numba = pytest.importorskip("numba")

CONTROLLER = """
import numba
import numpy as np
from aiauv_pin.kernels.articulated_body import kinematics, thrust_into

GAINS = np.array([30.0, 50.0])


@numba.njit
def joint_pd(q, v, tau):
    for j in range(q.shape[0] - 7):
        tau[6 + j] += -GAINS[0] * q[7 + j] - GAINS[1] * v[6 + j]


@numba.njit
def forward(t, q, v, model, workspace, parameters, state, tau, info):
    kinematics(model.bodies, q, v, workspace)
    thrust_into(model, workspace, parameters, tau)
    joint_pd(q, v, tau)
    info[0] = v[0]  # surge speed


@numba.njit
def current(t, x, y, z, parameters):
    return parameters[0], parameters[1] * z, 0.0
"""

RUN = """
import hashlib, json, sys
import numpy as np
import aiauv_pin
from aiauv_hydro.currents import Current
from aiauv_pin.controllers.compiled_controller import CompiledController
from aiauv_pin.simulation.compilation import CompilationWatch

sys.path.insert(0, sys.argv[1])
import user_functions

vehicle = aiauv_pin.load_vehicle()
if sys.argv[2] == "controller":
    thrusts = np.array([0, 0, 20.0, 20.0, 0, 0, 0])
    controller, current = CompiledController(user_functions.forward, thrusts, info_shapes={"u": ()}), None
else:
    controller = CompiledController.passive()
    current = Current(user_functions.current, np.array([0.3, 0.01]))
with CompilationWatch(notice=False) as watch:
    run = aiauv_pin.simulate(vehicle, vehicle.neutral_configuration(), np.zeros(vehicle.nv), 0.2,
                             0.01, controller, current=current)
    rows = [run.q, run.v]
    if current is not None:  # an entry point outside the loop
        q = vehicle.neutral_configuration()
        rows.append(vehicle.fast.acceleration(q, np.zeros(vehicle.nv), np.zeros(vehicle.nv), current))
digest = hashlib.sha256(np.ascontiguousarray(np.hstack([r.ravel() for r in rows])).tobytes()).hexdigest()
print(json.dumps({"compiled": watch.compiled, "digest": digest}))
"""


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    """One numba cache for the module's processes (the project's kernels compile at most once)."""
    return tmp_path_factory.mktemp("numba-cache")


def _run(folder, what: str, cache) -> dict:
    env = default_target_environment()
    env.update(NUMBA_CACHE_DIR=str(cache))
    done = subprocess.run(
        [sys.executable, str(folder / "run.py"), str(folder), what],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize(
    ("what", "edits"),
    [
        ("controller", ("info[0] = v[0]", ("info[0] = 3.0 * v[0]", "info[0] = 2.0 * v[0]"))),
        ("current", ("parameters[1] * z", ("parameters[1] * z * 0.25", "parameters[1] * z * 0.5"))),
    ],
)
def test_a_second_process_compiles_nothing_and_an_edit_compiles_again(
    tmp_path, cache_dir, what, edits
):
    """Run, run again (nothing compiled, the same bits), edit the body, run (compiled again).

    A first run with another body compiles the project's kernels its functions call (the shipped
    ones serve only the tree they were built from): numba links a kernel it has just compiled
    differently from one it loads (LLVM may inline the first), which may change the last bits.
    """
    folder = tmp_path / what
    folder.mkdir()
    (folder / "run.py").write_text(RUN)
    functions = folder / "user_functions.py"
    original, (warm, edited) = edits
    functions.write_text(CONTROLLER.replace(original, warm))
    _run(folder, what, cache_dir)
    functions.write_text(CONTROLLER)
    first = _run(folder, what, cache_dir)
    assert first["compiled"]
    second = _run(folder, what, cache_dir)
    assert second == {"compiled": [], "digest": first["digest"]}
    functions.write_text(CONTROLLER.replace(original, edited))
    assert _run(folder, what, cache_dir)["compiled"]


def _module(tmp_path, name, source):
    """Import ``source`` as module ``name`` from a file in ``tmp_path``."""
    import importlib.util

    path = tmp_path / f"{name}.py"
    path.write_text(textwrap.dedent(source))
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def test_the_identity_follows_source_globals_callees_and_options(tmp_path):
    """The digest changes with the source, a global's value, a callee's source and the options;
    it is the same for the same content; a function without source has none."""
    source = """
        import numba
        import numpy as np
        from aiauv_hydro.numerics.jit import interpreted
        SCALE = np.array([1.0, 2.0])

        @numba.njit
        def helper(x):
            return x * SCALE[1]

        @numba.njit
        def user(x):
            return helper(x) + np.pi
    """

    def identity(name, text, **options):
        module = _module(tmp_path, name, text)
        function = numba.njit(**options)(module.user.py_func) if options else module.user
        return content_identity(function)

    base = identity("identity_a", source)
    assert base is not None
    assert identity("identity_a", source) == base  # the same content, a new dispatcher
    assert identity("identity_a", source.replace("[1.0, 2.0]", "[1.0, 3.0]")) != base
    assert identity("identity_a", source.replace("x * SCALE", "x / SCALE")) != base
    assert identity("identity_a", source.replace("+ np.pi", "- np.pi")) != base
    assert identity("identity_a", source, boundscheck=True) != base
    assert identity("identity_b", source) != base  # another module

    namespace: dict = {}
    exec("import numba\n@numba.njit\ndef typed_in_a_repl(x):\n    return x\n", namespace)
    function = namespace["typed_in_a_repl"]
    assert content_identity(function) is None
    assert stable_uuid(function) is None


def test_a_stable_uuid_is_given_once_and_not_over_another_dispatcher(tmp_path):
    """numba's uuid is set to the content's; a second live dispatcher of the same content, or one
    whose uuid numba already set, gets none (it is then compiled in memory)."""
    source = """
        import numba

        @numba.njit
        def user(x):
            return x + 1.0
    """
    first = _module(tmp_path, "uuid_a", source).user
    uuid = stable_uuid(first)
    assert uuid == UUID_PREFIX + content_identity(first)
    assert first._uuid == uuid and stable_uuid(first) == uuid
    assert stable_uuid(_module(tmp_path, "uuid_a", source).user) is None  # the same content
    used = _module(tmp_path, "uuid_b", source).user
    assert used._uuid  # numba names it (as when it is pickled)
    assert stable_uuid(used) is None


def test_a_signature_numba_cannot_pickle_is_not_saved_and_the_call_goes_on():
    """numba pickles a user's function (and its globals) into the cache index: if that fails, the
    loop is not kept on disk, and the run that compiled it is not failed."""
    saved = []

    class Cache:
        def save_overload(self, sig, data):
            if sig == "unpicklable":
                raise pickle.PicklingError("cannot pickle a lock")
            saved.append(sig)

    class Dispatcher:
        _cache = Cache()

    dispatcher = saving_only_what_pickles(Dispatcher())
    dispatcher._cache.save_overload("unpicklable", None)
    dispatcher._cache.save_overload("fine", None)
    assert saved == ["fine"]
