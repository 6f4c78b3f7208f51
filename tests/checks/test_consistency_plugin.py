"""The ``aiauv`` pytest plugin, run in nested pytest sessions (pytester) (issue 17).

The nested sessions run in subprocesses: pytester's in-process mode removes every module imported
during a test from ``sys.modules`` afterwards, and extension modules imported that way (numba's,
trimesh's manifold3d) abort the interpreter when a later test imports them again. For the same
reason the builder (yourdfpy, trimesh) is imported here, before any pytester test starts.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import pytest
from conftest import QUADRATIC_INJECTING

import aiauv_pin
import aiauv_pin.builders.urdf_builder  # before pytester's sys.modules snapshot (see above)
from aiauv_pin.app.cli import main
from aiauv_pin.checks import consistency

pytest_plugins = ["pytester"]

DATA = Path(__file__).parents[1] / "data"
N_CHECKS = len(consistency.CHECKS)


def copy_in(pytester, source: Path, name: str | None = None) -> Path:
    """A copy of a URDF in the nested session's folder (pytest picks its rootdir from the paths on
    the command line, the option values included, so the vehicles are kept beside the tests)."""
    path = pytester.path / (name or source.name)
    path.write_text(source.read_text(encoding="utf-8"), encoding="utf-8")
    return path


def test_plugin_is_registered_as_a_pytest11_entry_point():
    entry_points = importlib.metadata.entry_points(group="pytest11")
    assert [e.value for e in entry_points if e.name == "aiauv"] == ["aiauv_pin.testing.plugin"]


SPEC = """
name = "my_aiauv"
radius = 0.08
fluid_density = 1025.0
{modules}
"""
MODULE = """
[[module]]
name = "m{k}"
length = {length}
mass = {mass}
{joint}
[[module.thruster]]
name = "t{k}"
x = 0.1
y = 0.02
direction = "{direction}"
"""


def generated_vehicle(pytester) -> Path:
    """A 10-link vehicle from ``aiauv build`` (three joint axes, thrusters on every module)."""
    modules = "".join(
        MODULE.format(
            k=k,
            length=0.3 + 0.03 * k,
            mass=14.0 + k,
            joint=f'joint = "{"zyx"[k % 3]}"' if k < 9 else "",
            direction="xyz"[k % 3],
        )
        for k in range(10)
    )
    (pytester.path / "my_aiauv.toml").write_text(SPEC.format(modules=modules))
    urdf = pytester.path / "my_aiauv.urdf"
    assert main(["build", str(pytester.path / "my_aiauv.toml"), "-o", str(urdf)]) == 0
    return urdf


def test_good_vehicles_pass_with_readable_ids(pytester):
    stabilised = copy_in(pytester, aiauv_pin.bundled_urdf("stabilised"))
    two_link = copy_in(pytester, DATA / "two_link_hydro.urdf")
    generated = generated_vehicle(pytester)
    result = pytester.runpytest_subprocess(
        "--aiauv-vehicle",
        str(stabilised),
        "--aiauv-vehicle",
        str(two_link),
        "--aiauv-vehicle",
        str(generated),
        "-v",
        "-W",
        "default::aiauv_pin.testing.ConsistencyWarning",
    )
    result.assert_outcomes(passed=3 * N_CHECKS, warnings=1)
    result.stdout.fnmatch_lines(
        [
            "*::test_energy_conserved[[]paper_stabilised[]] PASSED*",
            "*::test_energy_conserved[[]two_link[]] PASSED*",
            "*::test_thrusters[[]two_link[]] PASSED*",
            "*::test_energy_conserved[[]my_aiauv[]] PASSED*",
            # the two-link vehicle is positively buoyant: a warning, not a failure
            "*ConsistencyWarning: hydrostatics: not neutrally buoyant: positively buoyant*",
        ]
    )


def test_own_tests_run_beside_the_suite_and_use_the_fixture(pytester):
    pytester.makepyfile(
        test_mine="""
        def test_vehicle_has_nine_links(aiauv_vehicle):
            assert len(aiauv_vehicle.hydro.links) == 9
        """
    )
    result = pytester.runpytest_subprocess(
        "test_mine.py", "--aiauv-vehicle", str(copy_in(pytester, aiauv_pin.bundled_urdf())), "-v"
    )
    result.assert_outcomes(passed=N_CHECKS + 1)
    result.stdout.fnmatch_lines(["*test_mine.py::test_vehicle_has_nine_links[[]paper_uniform[]]*"])


def test_inconsistent_vehicle_fails_with_figure_and_tolerance(pytester):
    """Quadratic damping whose surge-sway coupling injects energy (the gate cannot see it)."""
    text = (DATA / "two_link_hydro.urdf").read_text()
    bad = pytester.path / "leaky.urdf"
    bad.write_text(
        text.replace(
            "<quadratic_damping>6 60 60 0.2 8 8</quadratic_damping>",
            QUADRATIC_INJECTING,
        ).replace('<robot name="two_link">', '<robot name="leaky">')
    )
    result = pytester.runpytest_subprocess("--aiauv-vehicle", str(bad), "-rf")
    # the 5 s undriven run of energy_decays need not meet the injecting velocities; the
    # dissipation check, which samples velocities, does
    result.assert_outcomes(passed=N_CHECKS - 1, failed=1, warnings=1)
    result.stdout.fnmatch_lines(
        [
            f"collected {N_CHECKS} items",
            "_* test_damping_dissipates[[]leaky[]] _*",
            "damping_dissipates: FAIL: * >= tolerance 0 (largest damping power v_r . tau_D [[]W[]]*"
            "it must be negative)",
            "FAILED aiauv_pin/testing/suite.py::test_damping_dissipates[[]leaky[]] - *",
        ]
    )


def test_inconsistent_model_in_a_users_own_test(pytester):
    """A user imports the checks into their own tests: a thrust matrix without lever arms fails."""
    pytester.makepyfile(
        test_thrusters="""
        import aiauv_pin
        from aiauv_pin.checks.consistency import check_thrusters
        from aiauv_pin.testing import assert_check
        from aiauv_pin.model.vehicle import Vehicle

        class Leverless(Vehicle):
            def thrust_matrix(self, q):
                matrix = super().thrust_matrix(q)
                matrix[3:] = 0.0
                return matrix

        def test_my_thrusters():
            vehicle = aiauv_pin.load_vehicle()
            assert_check(check_thrusters(Leverless(vehicle.model, vehicle.hydro)))
        """
    )
    result = pytester.runpytest_subprocess("-rf")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        [
            "thrusters: FAIL: * > tolerance 1e-08 (max |B - B_virtual_work| / (1 + |B|) *",
            "FAILED test_thrusters.py::test_my_thrusters - *",
        ]
    )


def test_missing_vehicle_is_a_usage_error(pytester):
    result = pytester.runpytest_subprocess("--aiauv-vehicle", "nowhere.urdf")
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    result.stderr.fnmatch_lines(["*--aiauv-vehicle nowhere.urdf: no such file*"])


def test_unloadable_vehicle_errors_in_one_line(pytester):
    broken = pytester.path / "broken.urdf"
    broken.write_text("<robot name='broken'><link name='a'/><joint/></robot>")
    result = pytester.runpytest_subprocess("--aiauv-vehicle", str(broken), "-x", "-rE")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(
        [
            "_* ERROR at setup of test_mass_matrix_symmetric[[]broken[]] _*",
            "cannot load the vehicle: *broken.urdf: URDF <joint> without a name",
            "ERROR aiauv_pin/testing/suite.py::test_mass_matrix_symmetric[[]broken[]] - *",
        ]
    )
    assert "During handling" not in result.stdout.str()


def test_without_the_option_the_plugin_does_nothing(pytester):
    pytester.makepyfile(test_x="def test_x():\n    pass\n")
    result = pytester.runpytest_subprocess("-v")
    result.assert_outcomes(passed=1)


def test_duplicate_robot_names_get_numbered_ids(tmp_path):
    from aiauv_pin.testing.plugin import vehicle_ids

    a = tmp_path / "a.urdf"
    a.write_text('<robot name="my_aiauv"/>')
    b = tmp_path / "b.urdf"
    b.write_text('<robot name="my_aiauv"/>')
    c = tmp_path / "not_xml.urdf"
    c.write_text("<<<")
    assert vehicle_ids([a, b, c]) == ["my_aiauv", "my_aiauv-2", "not_xml"]
