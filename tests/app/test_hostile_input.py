"""Bad and hostile input through the command line: one line naming the problem, non-zero exit.

Every case runs ``aiauv_pin.app.cli.main`` in-process with ``capfd``, which captures file descriptors 1
and 2, so anything a C++ library (urdfdom) prints to the process's standard error is seen too.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from aiauv_pin.app.cli import main

LINK = """
  <link name="{name}">
    <inertial>
      <origin xyz="0.25 0 0"/>
      <mass value="{mass}"/>
      <inertia ixx="{ixx}" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.2"/>
    </inertial>
  </link>"""

HYDRO_LINK = """
    <link name="{name}" model="fossen">
      <volume>{volume}</volume>
      <center_of_buoyancy>0.25 0 0</center_of_buoyancy>
      <added_mass>{added_mass}</added_mass>
    </link>"""


def vehicle_urdf(
    *,
    mass="10",
    ixx="0.05",
    volume="0.01",
    added_mass="1 2 2 0 0.1 0.1",
    child="b",
    hydro_link="b",
    extra="",
) -> str:
    """A valid two-link vehicle with one parameter replaced."""
    return (
        '<?xml version="1.0"?>\n<robot name="two">'
        + LINK.format(name="a", mass="10", ixx="0.05")
        + LINK.format(name="b", mass=mass, ixx=ixx)
        + f"""
  <joint name="j" type="revolute">
    <parent link="a"/><child link="{child}"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/>
  </joint>{extra}
  <hydrodynamics fluid_density="1000">"""
        + HYDRO_LINK.format(name="a", volume="0.01", added_mass="1 2 2 0 0.1 0.1")
        + HYDRO_LINK.format(name=hydro_link, volume=volume, added_mass=added_mass)
        + "\n  </hydrodynamics>\n</robot>\n"
    )


def run_cli(capfd, argv) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exit_:  # argparse usage errors
        code = exit_.code
    out, err = capfd.readouterr()
    return code, out, err


def assert_one_line_error(code, err, *fragments):
    assert code not in (0, None)
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("aiauv")
    assert "error" in lines[0]
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment.lower() in lines[0].lower(), (fragment, lines[0])


def check_file(tmp_path, capfd, text, *fragments):
    path = tmp_path / "vehicle.urdf"
    path.write_text(text, encoding="utf-8")
    code, out, err = run_cli(capfd, ["check", path])
    assert_one_line_error(code, err, str(path), *fragments)
    assert "OK" not in out
    return err


def test_the_valid_template_passes(tmp_path, capfd):
    path = tmp_path / "vehicle.urdf"
    path.write_text(vehicle_urdf(), encoding="utf-8")
    code, out, err = run_cli(capfd, ["check", path])
    assert code == 0, err
    assert "OK: usable vehicle" in out


@pytest.mark.parametrize(
    ("text", "fragments"),
    [
        ("this is not XML at all", ("not well-formed XML",)),
        ('<?xml version="1.0"?><html><body/></html>', ("not a URDF", "<html>")),
        ("", ("not well-formed XML",)),
        ('<robot name="r"></robot>', ("no <link>",)),
    ],
    ids=["not-xml", "xml-not-urdf", "empty", "no-links"],
)
def test_not_a_urdf(tmp_path, capfd, text, fragments):
    check_file(tmp_path, capfd, text, *fragments)


def test_file_whose_text_is_a_path_is_not_followed(tmp_path, capfd):
    """The content of a URDF file is XML or an error: never the name of another file to read."""
    other = tmp_path / "other.urdf"
    other.write_text(vehicle_urdf())
    check_file(tmp_path, capfd, str(other), "not well-formed XML")


def test_joint_naming_a_missing_link(tmp_path, capfd):
    check_file(tmp_path, capfd, vehicle_urdf(child="ghost"), "joint 'j'", "'ghost'")


def test_hydrodynamics_for_an_unknown_link(tmp_path, capfd):
    check_file(tmp_path, capfd, vehicle_urdf(hydro_link="ghost"), "'ghost'", "hydrodynamics")


@pytest.mark.parametrize("value", ["-0.01", "nan", "inf"])
def test_bad_volume(tmp_path, capfd, value):
    check_file(tmp_path, capfd, vehicle_urdf(volume=value), "volume")


@pytest.mark.parametrize("value", ["-3", "nan", "abc"])
def test_bad_mass(tmp_path, capfd, value):
    check_file(tmp_path, capfd, vehicle_urdf(mass=value), "link 'b'", "mass")


def test_inertia_that_is_not_a_number_is_refused_before_pinocchio_drops_it(tmp_path, capfd):
    # urdfdom only prints this one and returns a model with zero inertia
    err = check_file(tmp_path, capfd, vehicle_urdf(ixx="abc"), "link 'b'", "ixx", "'abc'")
    assert "urdf_parser" not in err


def test_inertia_not_positive_semidefinite(tmp_path, capfd):
    check_file(tmp_path, capfd, vehicle_urdf(ixx="-1"), "link 'b'", "positive semi-definite")


@pytest.mark.parametrize("numbers", ["1 2 3 4 5", "1 " * 35, "1 " * 37])
def test_matrix_with_the_wrong_count_of_numbers(tmp_path, capfd, numbers):
    count = len(numbers.split())
    check_file(tmp_path, capfd, vehicle_urdf(added_mass=numbers), "added_mass", f"got {count}")


def test_added_mass_not_positive_semidefinite(tmp_path, capfd):
    check_file(
        tmp_path,
        capfd,
        vehicle_urdf(added_mass="1 -2 2 0 0.1 0.1"),
        "added_mass",
        "positive semi-definite",
    )


def test_two_roots_and_cycles(tmp_path, capfd):
    cycle = """
  <joint name="k" type="fixed"><parent link="b"/><child link="a"/></joint>"""
    check_file(tmp_path, capfd, vehicle_urdf(extra=cycle), "cycle")
    island = '\n  <link name="island"/>'
    check_file(tmp_path, capfd, vehicle_urdf(extra=island), "2 root links")


def test_unsupported_joint_type(tmp_path, capfd):
    text = vehicle_urdf().replace('type="revolute"', 'type="planar"')
    check_file(tmp_path, capfd, text, "joint 'j'", "planar")


def test_missing_file(tmp_path, capfd):
    path = tmp_path / "nowhere.urdf"
    code, _, err = run_cli(capfd, ["check", path])
    assert_one_line_error(code, err, str(path), "no such file")
    code, _, err = run_cli(capfd, ["simulate", "--vehicle", path, "--quiet", "--out", tmp_path])
    assert_one_line_error(code, err, "no such file")


def test_directory_and_binary_file(tmp_path, capfd):
    code, _, err = run_cli(capfd, ["check", tmp_path])
    assert_one_line_error(code, err, "directory")
    binary = tmp_path / "blob.urdf"
    binary.write_bytes(bytes(range(256)) * 4)
    code, _, err = run_cli(capfd, ["check", binary])
    assert_one_line_error(code, err, "not a text file")


BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE robot [
  <!ENTITY lol "lol">
  <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
  <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
  <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
  <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
  <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
  <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
  <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
  <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<robot name="&lol9;"><link name="a"/></robot>
"""


def test_entity_expansion_is_refused(tmp_path, capfd):
    err = check_file(tmp_path, capfd, BILLION_LAUGHS, "refused", "DTD")
    assert "lollol" not in err


def test_external_entity_never_reads_the_file(tmp_path, capfd):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-7f3a9c", encoding="utf-8")
    text = f"""<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY leak SYSTEM "file://{secret}">]>
<robot name="r"><link name="&leak;"/></robot>
"""
    path = tmp_path / "xxe.urdf"
    path.write_text(text, encoding="utf-8")
    for argv in (["check", path], ["simulate", "--vehicle", path, "--quiet", "--out", tmp_path]):
        code, out, err = run_cli(capfd, argv)
        assert_one_line_error(code, err, "refused")
        assert "TOP-SECRET" not in out + err
    assert not (tmp_path / "timeseries.csv").exists()


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--duration", "-5"], "--duration"),
        (["--duration", "inf"], "--duration"),
        (["--dt", "0"], "--dt"),
        (["--dt", "-0.01"], "--dt"),
        (["--dt", "abc"], "'abc' is not a number"),
        (["--dt", "nan"], "--dt"),
        (["--case", "sideways"], "sideways"),
        (["--feedforward", "psychic"], "psychic"),
        (["--bogus"], "--bogus"),
    ],
)
def test_bad_simulate_arguments(tmp_path, capfd, argv, fragment):
    code, _, err = run_cli(capfd, ["simulate", "--quiet", "--out", tmp_path, *argv])
    assert code == 2
    assert_one_line_error(code, err, fragment)
    assert not (tmp_path / "timeseries.csv").exists()


def test_bad_combinations_of_values(tmp_path, capfd):
    code, _, err = run_cli(capfd, ["simulate", "--duration", "1", "--dt", "2", "--out", tmp_path])
    assert_one_line_error(code, err, "dt", "duration")
    code, _, err = run_cli(capfd, ["simulate", "--duration", "1e9", "--out", tmp_path])
    assert_one_line_error(code, err, "steps", "exceeds")


def test_unknown_subcommand_and_missing_argument(capfd):
    code, _, err = run_cli(capfd, ["fly"])
    assert_one_line_error(code, err, "fly")
    code, _, err = run_cli(capfd, ["check"])
    assert_one_line_error(code, err, "urdf")


def test_diverging_run_names_time_and_cause_and_keeps_the_partial_results(tmp_path, capfd):
    out = tmp_path / "run"
    code, _, err = run_cli(
        capfd,
        [
            *("simulate", "--dt", "0.5", "--method", "rk4", "--duration", "20"),
            *("--quiet", "--no-html", "--out", out),
        ],
    )
    # the step warning foretold it (one line), then the one-line error (after the announcement of
    # a first compilation, when this test is the first to need the RK4 loop)
    warning, error = [line for line in err.splitlines() if "compiling kernels" not in line]
    assert warning.startswith("aiauv: warning: dt = 0.5 s is") and "stable step of RK4" in warning
    assert_one_line_error(code, error, "diverged", "t = 1 s", "non-finite", str(out))
    rows = (out / "timeseries.csv").read_text().splitlines()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "diverged"
    assert "non-finite" in summary["message"]
    # everything written is the finite part: t = 0 and t = 0.5 s, before the blow-up at t = 1 s
    assert len(rows) == 1 + 2
    times = [float(row.split(",")[0]) for row in rows[1:]]
    assert times == [0.0, 0.5]
    assert all(math.isfinite(float(x)) for row in rows[1:] for x in row.split(","))
    assert summary["simulated_time"] == 0.5
    # no temporary files left behind (atomic writes); the manifest lists what the run wrote
    assert [p.name for p in out.glob(".*")] == [".aiauv-run.json"]


def test_command_line_entry_point_reports_one_line(tmp_path):
    # the real process: urdfdom's own standard-error output must not reach the terminal
    path = tmp_path / "bad.urdf"
    path.write_text(vehicle_urdf(child="ghost"), encoding="utf-8")
    process = subprocess.run(
        [sys.executable, "-m", "aiauv_pin.app.cli", "check", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert process.returncode == 1
    assert process.stderr.count("\n") == 1
    assert "'ghost'" in process.stderr and "Traceback" not in process.stderr


def test_a_mesh_the_playback_cannot_read_is_refused_before_the_run(tmp_path, capfd):
    # found by benchmarks/hostile_campaign.py: the run was simulated, then lost when the playback
    # failed to read the mesh; now the error comes first, and --no-html runs the same file
    path = tmp_path / "v.urdf"
    text = vehicle_urdf().replace(
        '<link name="b">',
        '<link name="b">\n    <visual><geometry><mesh filename="/etc/hostname"/></geometry></visual>',
        1,
    )
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "run"
    argv = ["simulate", "--vehicle", path, "--controller", "none", "--duration", "0.02"]
    code, _, err = run_cli(capfd, [*argv, "--out", out, "--quiet"])
    assert_one_line_error(code, err, "cannot read the visuals", "--no-html")
    assert not out.exists()
    code, _, err = run_cli(capfd, [*argv, "--out", out, "--quiet", "--no-html"])
    assert code == 0, err
    assert (out / "summary.json").exists()


def test_cli_prints_warnings_for_the_user_but_not_libraries_deprecations(
    tmp_path, capfd, monkeypatch
):
    # a library's deprecation (on Python 3.10, xacro's import-time "private variables ... will be
    # normal attributes in 3.11") is shown under pytest's filters; the command must still say its
    # error in one line, while a warning meant for the user (a UserWarning) keeps its own line
    import warnings

    from aiauv_pin.app import annotate_command as annotation
    from aiauv_pin.errors import VehicleLoadError

    def failing_annotate(*args, **kwargs):
        warnings.warn("an old keyword", DeprecationWarning, stacklevel=1)
        warnings.warn("a parameter for the developers", PendingDeprecationWarning, stacklevel=1)
        raise VehicleLoadError("vehicle.urdf: refused: XML with a DTD/entities")

    monkeypatch.setattr(annotation, "annotate_file", failing_annotate)
    path = tmp_path / "vehicle.urdf"
    path.write_text("<robot/>", encoding="utf-8")
    code, _, err = run_cli(capfd, ["annotate", path, "-o", tmp_path / "out.urdf"])
    assert_one_line_error(code, err, "refused", "DTD")

    def warning_annotate(*args, **kwargs):
        warnings.warn("link 'x' has no collision shape", UserWarning, stacklevel=1)
        raise VehicleLoadError("vehicle.urdf: refused")

    monkeypatch.setattr(annotation, "annotate_file", warning_annotate)
    code, _, err = run_cli(capfd, ["annotate", path, "-o", tmp_path / "out.urdf"])
    assert err.splitlines() == [
        "aiauv: warning: link 'x' has no collision shape",
        "aiauv: error: vehicle.urdf: refused",
    ]
    assert code not in (0, None)
