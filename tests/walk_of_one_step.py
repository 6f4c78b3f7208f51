"""Trace of one ``aiauv simulate`` step, run by ``tests/test_layers.py`` in a child process.

The compiled loop and its kernels run interpreted (``NUMBA_DISABLE_JIT=1``, the same source that
numba compiles) under :func:`sys.settrace`; the script prints, as JSON, every call made inside the
loop between two project files (caller file, callee file), the project files on the call stack at
the deepest calls of the step (the fluid terms, the controller's laws), and the file of the
function that writes the results. Interpreted kernels are not a supported backend: the vehicle is
told numba is there, and each plain function gets the ``py_func`` attribute of a numba dispatcher
(the checks at the boundary look for it).
"""

import json
import os
import sys
import types

os.environ["NUMBA_DISABLE_JIT"] = "1"

import aiauv_hydro.numerics.jit as jit
import aiauv_pin.app.cli as cli
import aiauv_pin.results.outputs as outputs
import aiauv_pin.scenario.definition  # noqa: F401
import aiauv_pin.simulation.compiled_loop as compiled_loop

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the checkout


def project_file(path: str) -> str | None:
    """``path`` relative to the checkout (``hydro/laws/fluid_terms.py``), None outside it."""
    if path.startswith(ROOT + os.sep):
        relative = path[len(ROOT) + 1 :]
        if relative.split(os.sep)[0] in ("aiauv_pin", "hydro", "control"):
            return relative.replace(os.sep, "/")
    return None


edges: set[tuple[str, str]] = set()
spine: set[str] = set()
DEEPEST = {"hydro/laws/fluid_terms.py", "control/laws/paper_laws.py"}


def is_trampoline(frame) -> bool:
    """A frame of :func:`aiauv_hydro.numerics.jit.user_or_builtin`'s ``select``: compiled, the
    choice is made at compile time and the caller calls the chosen function itself."""
    return frame.f_code.co_name == "select" and frame.f_code.co_filename == jit.__file__


def tracer(frame, event, arg):
    if event == "call" and not is_trampoline(frame):
        callee = project_file(frame.f_code.co_filename)
        above = frame.f_back
        while above is not None and is_trampoline(above):
            above = above.f_back
        caller = above and project_file(above.f_code.co_filename)
        if callee and caller and callee != caller:
            edges.add((caller, callee))
        if callee in DEEPEST:
            f = frame
            while f is not None:
                name = None if is_trampoline(f) else project_file(f.f_code.co_filename)
                if name:
                    spine.add(name)
                f = f.f_back
    return None


original_run_chunk = compiled_loop.run_chunk


def traced_run_chunk(*args, **kwargs):
    sys.settrace(tracer)
    try:
        return original_run_chunk(*args, **kwargs)
    finally:
        sys.settrace(None)


writer = {}
original_write = outputs.write_results


def recorded_write(*args, **kwargs):
    caller = project_file(sys._getframe(1).f_code.co_filename)
    writer["caller"], writer["writer"] = caller, project_file(original_write.__code__.co_filename)
    return original_write(*args, **kwargs)


compiled_loop.run_chunk = traced_run_chunk
outputs.write_results = recorded_write
jit.NUMBA_AVAILABLE = True
for name, module in list(sys.modules.items()):
    if name.split(".")[0] in ("aiauv_pin", "aiauv_hydro", "aiauv_control"):
        for value in list(vars(module).values()):
            if isinstance(value, types.FunctionType) and not hasattr(value, "py_func"):
                value.py_func = value
code = cli.main(["simulate", "--duration", "0.02", "--no-html", "--quiet", *sys.argv[1:]])
print(json.dumps({"code": code, "edges": sorted(edges), "spine": sorted(spine), **writer}))
