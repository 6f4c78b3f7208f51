"""Fuzz of every compiled entry point with bad arguments, threads sharing a vehicle, and the
plausibility ranges of the validation gate (issue 29).

The bad-argument cases run in a child process (:data:`FUZZ_SCRIPT`): a case that crashes the
interpreter (heap corruption, SIGSEGV) then fails the test instead of killing pytest. Every case
must raise a :class:`aiauv_pin.errors.AiauvError` subclass; the child prints one JSON line with
the counts per class of argument and per outcome. Fixed seed; a few seconds once compiled.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

import aiauv_pin
from aiauv_pin.description.plausible_ranges import PLAUSIBLE_RANGES
from aiauv_pin.errors import AiauvError, PhysicalParameterError, VehicleLoadError

FUZZ_SCRIPT = textwrap.dedent(
    r'''
    import collections, dataclasses, json, sys
    import numba
    import numpy as np
    import aiauv_pin
    import aiauv_pin.dynamics.linear_model
    import aiauv_pin.dynamics.transitions
    from aiauv_pin.kernels.records import Servo
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing
    from aiauv_pin.controllers.compiled_controller import CompiledController
    from aiauv_pin.model.derivatives import compiled_derivatives
    from aiauv_pin.errors import AiauvError
    from aiauv_pin.dynamics.linear_model import Trim
    from aiauv_hydro.currents import Current, constant_current, tidal_current
    from aiauv_hydro.spec import HydroError

    rng = np.random.default_rng(20260429)
    vehicle = aiauv_pin.load_vehicle()
    fast = vehicle.fast
    nq, nv, m = vehicle.nq, vehicle.nv, len(vehicle.thruster_names)
    q0, v0, tau0 = vehicle.neutral_configuration(), 0.1 * rng.normal(size=nv), np.zeros(nv)
    outcomes = collections.Counter()
    failures = []

    def bad_arrays(good):
        """Each way an array argument can be wrong: one entry too long or short, complex or
        object dtype, NaN, inf, a string, a 2-D array, an empty array."""
        n = good.shape[0]
        nan, inf = good.copy(), good.copy()
        nan[rng.integers(n)] = np.nan
        inf[rng.integers(n)] = -np.inf
        return {
            "too long": np.concatenate((good, [0.0])),
            "too short": good[:-1].copy(),
            "complex": good.astype(complex) + 1j,
            "object": np.array(list(good) + [None], dtype=object)[:n],
            "nan": nan,
            "inf": inf,
            "string": "abc",
            "2-D": good[None, :],
            "empty": np.zeros(0),
        }

    def convertible_arrays(good):
        """Arrays that a copy converts (int32, non-contiguous, a list): accepted where the
        argument is read, refused where it is advanced in place (``run``'s ``q`` and ``v``)."""
        strided = np.zeros(2 * good.shape[0])
        strided[::2] = good
        return {
            "int32": np.round(good).astype(np.int32),
            "non-contiguous": strided[::2],
            "list": list(good),
        }

    def case(kind, call, must_fail=True, foreign=()):
        try:
            call()
        except AiauvError:
            outcomes[(kind, "project error")] += 1
            return
        except foreign as exc:  # the hydro layer's own error, from its constructors
            outcomes[(kind, type(exc).__name__)] += 1
            return
        except Exception as exc:  # a foreign exception: a failure of the test
            outcomes[(kind, type(exc).__name__)] += 1
            failures.append(f"{kind}: {type(exc).__name__}: {str(exc)[:120]}")
            return
        outcomes[(kind, "accepted")] += 1
        if must_fail:
            failures.append(f"{kind}: accepted")

    # --- state arrays through every entry point that takes them
    entries = {  # name -> (call, the argument slots it takes)
        "fast.acceleration": lambda q, v, tau: fast.acceleration(q, v, tau),
        "fast.acceleration(current)": lambda q, v, tau: fast.acceleration(
            q, v, tau, np.array([0.1, 0.0, 0.0])
        ),
        "fast.step": lambda q, v, tau: fast.step(q, v, tau, 0.01),
        "fast.step(euler)": lambda q, v, tau: fast.step(q, v, tau, 0.01, method="euler"),
        "fast.run": lambda q, v, tau: fast.run(q, v, tau, 0.01, 2),
        "fast.restoring_forces": lambda q, v, tau: fast.restoring_forces(q),
        "fast.thrust_matrix": lambda q, v, tau: fast.thrust_matrix(q),
        "fast.frame_motion": lambda q, v, tau: fast.frame_motion(q, v, 1),
        "compiled_derivatives": lambda q, v, tau: compiled_derivatives(vehicle)(
            q, v, tau, np.zeros(3), 0.0
        ),
        "Vehicle.acceleration": lambda q, v, tau: vehicle.acceleration(q, v, tau),
        "acceleration_derivatives": lambda q, v, tau: vehicle.acceleration_derivatives(q, v, tau),
        "transition_jacobians": lambda q, v, tau: aiauv_pin.dynamics.transitions.transition_jacobians(
            vehicle, q, v, dt=0.01, tau=tau
        ),
        "linearize(Trim)": lambda q, v, tau: aiauv_pin.dynamics.linear_model.linearize(
            vehicle, Trim(q, v, np.zeros(m), tau, 0.0)  # tau: the trim's joint torques
        ),
    }
    in_place = {("fast.run", 0), ("fast.run", 1)}
    goods = {"linearize(Trim)": (q0, v0, tau0[6:])}
    for name, entry in entries.items():
        slots = 1 if "restoring" in name or "thrust_matrix" in name else (
            2 if "frame_motion" in name else 3)
        for slot in range(slots):
            good = goods.get(name, (q0, v0, tau0))[slot]
            for label, bad in bad_arrays(good).items():
                args = [a.copy() for a in goods.get(name, (q0, v0, tau0))]
                args[slot] = bad
                case(f"{name} arg {slot} {label}", lambda: entry(*args))
            if slot == 0:
                continue  # a configuration's quaternion does not survive a conversion to int
            for label, bad in convertible_arrays(good).items():
                args = [a.copy() for a in goods.get(name, (q0, v0, tau0))]
                args[slot] = bad
                case(f"{name} arg {slot} {label}", lambda: entry(*args),
                     must_fail=(name, slot) in in_place)
        case(f"{name} good", lambda: entry(*[a.copy() for a in goods.get(name, (q0, v0, tau0))]),
             must_fail=False)

    # --- other scalar and record arguments
    read_only = q0.copy()
    read_only.setflags(write=False)
    others = {
        "step dt nan": lambda: fast.step(q0, v0, tau0, float("nan")),
        "step dt 0": lambda: fast.step(q0, v0, tau0, 0.0),
        "step dt str": lambda: fast.step(q0, v0, tau0, "0.01"),
        "step method": lambda: fast.step(q0, v0, tau0, 0.01, method="rk5"),
        "step t inf": lambda: fast.step(q0, v0, tau0, 0.01, t=float("inf")),
        "run n_steps -1": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, -1),
        "run n_steps 1e308": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, 1e308),
        "run q read-only": lambda: fast.run(read_only, v0.copy(), tau0, 0.01, 2),
        "run n_steps str": lambda: fast.run(q0.copy(), v0.copy(), tau0, 0.01, "2"),
        "acceleration quaternion 0": lambda: fast.acceleration(np.zeros(nq), v0, tau0),
        "frame_motion id -1": lambda: fast.frame_motion(q0, v0, -1),
        "frame_motion id 10**6": lambda: fast.frame_motion(q0, v0, 10**6),
        "frame_positions 1-D": lambda: fast.frame_positions(q0, 1),
        "servo short": lambda: fast.acceleration(
            q0, v0, tau0, servo=Servo(np.ones(1), np.ones(1), np.ones(1), True, True)
        ),
        "disturbance str": lambda: fast.acceleration(q0, v0, tau0, disturbance="wind"),
        "derivatives thrusts long": lambda: compiled_derivatives(vehicle)(
            q0, v0, tau0, np.zeros(3), 0.0, np.zeros(m + 1)
        ),
        "derivatives velocity short": lambda: compiled_derivatives(vehicle)(
            q0, v0, tau0, np.zeros(2), 0.0
        ),
        "linearize trim not a Trim": lambda: aiauv_pin.dynamics.linear_model.linearize(vehicle, (q0, v0)),
        "linearize trim thrusts short": lambda: aiauv_pin.dynamics.linear_model.linearize(
            vehicle, Trim(q0, v0, np.zeros(m - 1), tau0[6:], 0.0)
        ),
        "linearize joint_gains nan": lambda: aiauv_pin.dynamics.linear_model.linearize(
            vehicle, joint_gains=(float("nan"), 1.0)
        ),
        "transition method": lambda: aiauv_pin.dynamics.transitions.transition_jacobians(
            vehicle, q0, v0, dt=0.01, method="rk9"
        ),
        "Vehicle.frame_placement id": lambda: vehicle.frame_placement(q0, 5),
        "Vehicle.link_placements ids": lambda: vehicle.link_placements(q0, [5]),
    }
    for name, call in others.items():
        case(name, call)

    # --- currents: too few parameters, NaN, a kind that is not its function
    currents = {
        "constant 1 parameter": lambda: Current(constant_current, np.zeros(1), "constant"),
        "tidal 3 parameters": lambda: Current(tidal_current, np.zeros(3), "tidal"),
        "user tidal function 3 parameters": lambda: Current(tidal_current, np.zeros(3)),
        "constant NaN": lambda: Current.constant([np.nan, 0.0, 0.0]),
        "kind not its function": lambda: Current(constant_current, np.zeros(8), "tidal"),
    }
    for name, call in currents.items():
        case(f"current {name}", call, foreign=HydroError)
    mutated = Current.constant([0.1, 0.0, 0.0])
    mutated.parameters[1] = np.nan  # after construction: the entry point checks again
    for name, call in {
        "fast.acceleration": lambda: fast.acceleration(q0, v0, tau0, mutated),
        "Vehicle.acceleration": lambda: vehicle.acceleration(q0, v0, tau0, mutated),
        "rollout": lambda: aiauv_pin.rollout(vehicle, q0, v0, 0.02, 0.01, current=mutated),
    }.items():
        case(f"current mutated to NaN via {name}", call)
    object.__setattr__(mutated, "parameters", np.zeros(1))
    case("current shrunk via fast.step", lambda: fast.step(q0, v0, tau0, 0.01, current=mutated))

    # --- controllers whose records lie: one function (one loop to compile), told by its
    # parameters what to write: info[0:n], info[k] through a helper, state[j]
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
        return CompiledController(
            writes, np.array([n_info, helper, state_index], dtype=float), np.zeros(2), **shapes
        )

    lying = {
        "info_shapes understated": law(4, 0, 0, info_shapes={"u": ()}),
        "info_shapes empty": law(4, 0, 0),
        "info through a helper": law(0, 2, 0, info_shapes={"u": (2,)}),
        "state too short": law(0, 0, 5),
        "not compiled": CompiledController(lambda *a: None),
        "info_shapes not tuples": law(4, 0, 0, info_shapes={"u": 4}),
        "paper info_shapes understated": dataclasses.replace(
            VehiclePathFollowing(vehicle).compiled(), info_shapes={"u": ()}
        ),
    }
    honest = law(4, 3, 1, info_shapes={"u": (4,)})
    for name, controller in lying.items():
        case(f"simulate {name}",
             lambda: aiauv_pin.simulate(vehicle, q0, np.zeros(nv), 0.05, 0.01, controller))
        case(f"rollout {name}",
             lambda: aiauv_pin.rollout(vehicle, q0, np.zeros(nv), 0.05, 0.01,
                                       [controller, controller]))
    case("simulate honest", lambda: aiauv_pin.simulate(
        vehicle, q0, np.zeros(nv), 0.05, 0.01, honest), must_fail=False)
    case("rollout honest", lambda: aiauv_pin.rollout(
        vehicle, q0, np.zeros(nv), 0.05, 0.01, honest), must_fail=False)

    summary = collections.Counter()
    by_class = collections.Counter()
    for (kind, outcome), count in outcomes.items():
        summary[outcome] += count
        by_class[(kind.split(" arg ")[0].split(" ")[0], outcome)] += count
    print(json.dumps({"calls": sum(outcomes.values()), "outcomes": dict(summary),
                      "by_class": {f"{k} -> {o}": n for (k, o), n in sorted(by_class.items())},
                      "failures": failures}))
    '''
)


def test_every_entry_point_refuses_bad_arguments_in_a_child_process():
    """Wrong shapes, dtypes, contiguity, non-finite values, lying records: project errors only,
    never a crash (a crash fails here: the child dies with a signal)."""
    child = subprocess.run(
        [sys.executable, "-c", FUZZ_SCRIPT], capture_output=True, text=True, timeout=600
    )
    assert child.returncode == 0, f"child died ({child.returncode}): {child.stderr[-2000:]}"
    report = json.loads(child.stdout.strip().splitlines()[-1])
    assert report["failures"] == [], report
    outcomes = report["outcomes"]
    assert set(outcomes) <= {"project error", "accepted", "HydroError"}, outcomes
    assert outcomes["HydroError"] == 5, outcomes  # Current's own constructor (the hydro layer)
    assert outcomes["project error"] >= 350, outcomes


# ---------------------------------------------------------------- threads
def _serial_and_threaded(function, states, threads: int = 4):
    serial = [function(*state) for state in states]
    threaded: list = [None] * len(states)
    barrier = threading.Barrier(threads)

    def work(start: int) -> None:
        barrier.wait()
        for i in range(start, len(states), threads):
            threaded[i] = function(*states[i])

    workers = [threading.Thread(target=work, args=(k,)) for k in range(threads)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    return serial, threaded


@pytest.mark.parametrize("backend", ["pinocchio", "numba"])
def test_one_vehicle_shared_by_threads_gives_the_serial_results_bit_for_bit(backend):
    """4 threads x 300 calls of ``acceleration`` (and 4 x 25 of ``mass_matrix`` and
    ``restoring_forces``) on one vehicle: bit-identical to the serial calls (issue 29: 43 to 242
    of 1,200 differed on the Pinocchio backend)."""
    vehicle = aiauv_pin.load_vehicle(backend=backend)
    rng = np.random.default_rng(29)
    nv = vehicle.nv
    states = []
    for _ in range(1200):
        q = vehicle.neutral_configuration()
        q[7:] = rng.uniform(-0.6, 0.6, vehicle.nq - 7)
        q[:3] = rng.normal(size=3)
        states.append((q, rng.normal(size=nv), rng.normal(size=nv)))
    serial, threaded = _serial_and_threaded(vehicle.acceleration, states)
    differing = sum(not np.array_equal(a, b) for a, b in zip(serial, threaded, strict=True))
    assert differing == 0
    for method in (vehicle.mass_matrix, vehicle.restoring_forces):
        serial, threaded = _serial_and_threaded(method, [(s[0],) for s in states[:100]])
        assert all(np.array_equal(a, b) for a, b in zip(serial, threaded, strict=True))


def test_simulate_on_threads_sharing_a_vehicle_matches_serial():
    """Concurrent ``simulate`` on one Pinocchio-backed vehicle gives the serial trajectories."""
    vehicle = aiauv_pin.load_vehicle(backend="pinocchio")
    rng = np.random.default_rng(3)
    starts = []
    for _ in range(4):
        q = vehicle.neutral_configuration()
        q[7:] = rng.uniform(-0.4, 0.4, vehicle.nq - 7)
        starts.append((q, 0.2 * rng.normal(size=vehicle.nv)))

    def run(q, v):
        return aiauv_pin.simulate(vehicle, q, v, 0.2, 0.01).q

    serial, threaded = _serial_and_threaded(run, starts)
    assert all(np.array_equal(a, b) for a, b in zip(serial, threaded, strict=True))


# ---------------------------------------------------------------- plausibility ranges
TWO_LINK = Path(__file__).parents[1] / "data" / "two_link_hydro.urdf"


def _mutated(tmp_path: Path, old: str, new: str) -> Path:
    text = TWO_LINK.read_text()
    assert old in text, old
    path = tmp_path / "mutated.urdf"
    path.write_text(text.replace(old, new, 1))
    return path


def _cylinder_vehicle(
    tmp_path: Path, *, radius="0.1", length="0.5", xyz="0.25 0 0", attributes=""
) -> Path:
    path = tmp_path / "cylinder.urdf"
    path.write_text(
        f"""<robot name="c">
  <link name="hull">
    <inertial><mass value="10"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0.3"/>
    </inertial>
    <visual><origin xyz="{xyz}" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="{radius}" length="{length}"/></geometry></visual>
  </link>
  <hydrodynamics><link name="hull" model="slender_cylinder" {attributes}/></hydrodynamics>
</robot>"""
    )
    return path


@pytest.mark.parametrize(
    "mutation, named",
    [
        (dict(radius="1e308"), "cylinder size"),
        (dict(length="1e308"), "cylinder size"),
        (dict(xyz="1e308 0 0"), "<origin> xyz"),
        (dict(attributes='C_dC="1e20"'), "C_dC"),
        (dict(attributes='length="1e308"'), "cylinder length"),
        (dict(attributes='C_a="1e6"'), "C_a"),
        (dict(attributes='v_ref="1e-9"'), "v_ref"),
    ],
)
def test_implausible_geometry_and_coefficients_are_refused_up_front(tmp_path, mutation, named):
    """Issue 29: a visual radius or origin of 1e308, a cylinder length of 1e308 and C_dC = 1e20
    passed ``check`` (or surfaced as OverflowError); the gate now names the parameter."""
    assert aiauv_pin.load_vehicle(_cylinder_vehicle(tmp_path)).nv == 6  # the unmutated one loads
    with pytest.raises(VehicleLoadError) as error:
        aiauv_pin.load_vehicle(_cylinder_vehicle(tmp_path, **mutation))
    message = str(error.value)
    assert named in message and "\n" not in message
    assert "plausible range" in message


def test_the_range_table_holds_every_bundled_vehicle():
    """The table's ranges are ordered and the bundled vehicles load within them."""
    for low, high, unit in PLAUSIBLE_RANGES.values():
        assert low < high and unit
    for path in (None, TWO_LINK, aiauv_pin.bundled_urdf("stabilised")):
        aiauv_pin.load_vehicle(path)


def test_a_mesh_scale_out_of_range_is_refused(tmp_path):
    path = _cylinder_vehicle(tmp_path)
    text = path.read_text().replace(
        "</link>",
        '<visual><geometry><mesh filename="hull.stl" scale="1e9 1 1"/></geometry></visual></link>',
    )
    path.write_text(text)
    with pytest.raises(AiauvError, match="mesh scale"):
        aiauv_pin.load_vehicle(path)


def test_divergence_suspect_names_the_coefficient_nearest_its_range(tmp_path):
    """With no damping time constant below the step, the suspect is the coefficient largest
    relative to the top of its plausible range."""
    from aiauv_pin.model.validation import divergence_suspect

    vehicle = aiauv_pin.load_vehicle(_cylinder_vehicle(tmp_path, attributes='C_dC="900"'))
    suspect = divergence_suspect(vehicle, 1e-9)
    assert suspect is not None and "C_dC" in suspect and "hull" in suspect


def test_compiled_runs_on_the_pinocchio_backend_are_project_errors():
    """The campaign found a plain ValueError ending in ': None' (issue 29: one hierarchy)."""
    from aiauv_pin.errors import ArgumentError

    vehicle = aiauv_pin.load_vehicle(backend="pinocchio")
    q0 = vehicle.neutral_configuration()
    with pytest.raises(ArgumentError, match="compiled backend") as error:
        aiauv_pin.rollout(vehicle, q0, np.zeros(vehicle.nv), 0.02, 0.01)
    assert "None" not in str(error.value) and "backend='numba'" in str(error.value)
    from aiauv_pin.controllers.paper_controller import VehiclePathFollowing

    controller = VehiclePathFollowing(aiauv_pin.load_vehicle()).compiled()
    with pytest.raises(ArgumentError, match="numba backend") as error:
        aiauv_pin.simulate(vehicle, q0, np.zeros(vehicle.nv), 0.02, 0.01, controller)
    assert "None" not in str(error.value)


def test_current_flag_has_the_scenario_files_range(tmp_path, capsys):
    """``simulate --current 1e6 0 0`` ran and diverged (the campaign); the flag now has the
    scenario file's plausible range and is refused up front, naming it."""
    from aiauv_pin.app.cli import main

    out = tmp_path / "run"
    assert (
        main(["simulate", "--current", "1e6", "0", "0", "--duration", "0.1", "--out", str(out)])
        == 1
    )
    error = capsys.readouterr().err
    assert error.startswith("aiauv: error: --current") and "plausible range" in error
    assert error.count("\n") == 1 and not out.exists()


def test_physical_parameter_error_is_a_project_error():
    assert issubclass(PhysicalParameterError, AiauvError)


def test_strided_and_converted_arrays_give_the_contiguous_results(paper_vehicle):
    """The fast path refuses non-contiguous arrays inside the compiled call (from their strides)
    and the checked path converts them: same result, bit for bit."""
    rng = np.random.default_rng(5)
    q = paper_vehicle.neutral_configuration()
    q[7:] = rng.uniform(-0.5, 0.5, paper_vehicle.nq - 7)
    v, tau = rng.normal(size=paper_vehicle.nv), rng.normal(size=paper_vehicle.nv)

    def strided(a):
        twice = np.zeros(2 * a.shape[0])
        twice[::2] = a
        return twice[::2]

    for evaluate in (paper_vehicle.acceleration, paper_vehicle.fast.acceleration):
        expected = evaluate(q, v, tau)
        np.testing.assert_array_equal(evaluate(strided(q), strided(v), strided(tau)), expected)
        np.testing.assert_array_equal(evaluate(list(q), list(v), tau.astype(">f8")), expected)
    expected = paper_vehicle.fast.step(q, v, tau, 0.01)
    got = paper_vehicle.fast.step(strided(q), strided(v), strided(tau), 0.01)
    for a, b in zip(got, expected, strict=True):
        np.testing.assert_array_equal(a, b)
