"""``aiauv check``: the table's figures against independent sums, and the exit-status policy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aiauv_pin import bundled_urdf
from aiauv_pin.app.cli import main
from aiauv_pin.checks.vehicle_check import check_vehicle, format_report
from aiauv_pin.errors import VehicleLoadError

# PAPER_DATA.md, Table 1: link masses [kg] and lengths [m]
PAPER_MASSES = [14.3, 6.0, 12.7, 6.0, 9.8, 6.0, 12.7, 6.0, 7.8]
PAPER_LENGTHS = [0.62, 0.104, 0.584, 0.104, 0.726, 0.104, 0.584, 0.104, 0.37]


def test_paper_vehicle_report_matches_table_1():
    report = check_vehicle(bundled_urdf("uniform"))
    links = [row for row in report.links if row.name.startswith("link")]
    np.testing.assert_allclose([row.mass for row in links], PAPER_MASSES)
    assert math.isclose(report.total_mass, 81.3, rel_tol=1e-12)
    # each link neutrally buoyant on its own: V = m / rho, margin zero
    np.testing.assert_allclose([row.volume for row in links], np.array(PAPER_MASSES) / 1000.0)
    assert all(row.buoyancy_margin == 0.0 for row in report.links)
    assert report.warnings == ()
    # CG of the straight uniform vehicle: mass-weighted link centres along x
    starts = np.concatenate(([0.0], np.cumsum(PAPER_LENGTHS)[:-1]))
    centres = starts + 0.5 * np.array(PAPER_LENGTHS)
    expected = np.dot(PAPER_MASSES, centres) / sum(PAPER_MASSES)
    np.testing.assert_allclose(report.center_of_gravity, [expected, 0, 0], atol=1e-12)
    np.testing.assert_allclose(report.center_of_buoyancy, [expected, 0, 0], atol=1e-12)
    assert len(report.thrusters) == 7
    assert sum(1 for j in report.structure.joints if j.type == "revolute") == 8
    assert all(
        j.lower == -math.radians(65) for j in report.structure.joints if j.type == "revolute"
    )


def test_stabilised_vehicle_cg_below_cb_by_half_a_radius():
    report = check_vehicle(bundled_urdf("stabilised"))
    drop = report.center_of_buoyancy[2] - report.center_of_gravity[2]
    assert math.isclose(drop, 0.5 * 0.085, rel_tol=1e-12)


def test_cli_prints_the_table_and_exits_zero(capfd):
    assert main(["check", str(bundled_urdf("uniform"))]) == 0
    out, err = capfd.readouterr()
    assert err == ""
    assert "link5_x_port" in out and "joint8" in out and out.rstrip().endswith("OK: usable vehicle")


def heavy_urdf(tmp_path, volume: float, mass: float = 10.0, geometry: str | None = None):
    visual = "" if geometry is None else f"<visual><geometry>{geometry}</geometry></visual>"
    text = f"""<robot name="blob">
  <link name="a"><inertial><mass value="{mass}"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>{visual}</link>
  <hydrodynamics fluid_density="1000" gravity="10">
    <link name="a" model="fossen"><volume>{volume}</volume></link>
  </hydrodynamics>
</robot>"""
    path = tmp_path / "blob.urdf"
    path.write_text(text, encoding="utf-8")
    return path


def test_not_neutrally_buoyant_is_a_warning_with_the_margin(tmp_path, capfd):
    path = heavy_urdf(tmp_path, volume=0.008)
    report = check_vehicle(path)
    # (rho V - m) g = (8 - 10) * 10 = -20 N
    assert math.isclose(report.buoyancy_margin, -20.0, rel_tol=1e-12)
    assert any("negatively buoyant by -20 N" in w for w in report.warnings)
    assert main(["check", str(path)]) == 0
    out, _ = capfd.readouterr()
    assert "warning: not neutrally buoyant" in out
    assert "usable vehicle (" in format_report(report)


def test_within_one_percent_is_neutral(tmp_path):
    report = check_vehicle(heavy_urdf(tmp_path, volume=0.01005))
    assert not any("buoyant" in w for w in report.warnings)


def test_a_body_without_mass_or_added_mass_is_unusable(tmp_path, capfd):
    text = """<robot name="ghost">
  <link name="a"><inertial><mass value="0"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
</robot>"""
    path = tmp_path / "ghost.urdf"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(VehicleLoadError, match="singular"):
        check_vehicle(path)
    assert main(["check", str(path)]) == 1
    out, err = capfd.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and "singular" in err


def visual_urdf(tmp_path, geometry: str):
    """A neutrally buoyant one-link vehicle drawn with ``geometry``."""
    return heavy_urdf(tmp_path, volume=0.01, geometry=geometry)


def test_a_missing_mesh_is_a_playback_warning(tmp_path, capfd):
    path = visual_urdf(tmp_path, '<mesh filename="meshes/hull.stl"/>')
    report = check_vehicle(path)
    assert (
        "the playback: 1 mesh file(s) not found, e.g. meshes/hull.stl (give --package-path)"
        in report.warnings
    )
    assert main(["check", str(path)]) == 0  # still usable: the link is drawn without it
    assert "meshes/hull.stl" in capfd.readouterr().out


def test_an_unreadable_mesh_is_a_playback_warning(tmp_path):
    (tmp_path / "hull.stl").write_bytes(b"solid hull\nfacet garbage\n")
    report = check_vehicle(visual_urdf(tmp_path, '<mesh filename="hull.stl"/>'))
    (warning,) = [w for w in report.warnings if "playback" in w]
    assert warning.startswith("the playback cannot draw this vehicle: cannot read the visuals")
    assert warning.endswith("(simulate with --no-html)") and "\n" not in warning


def test_primitive_visuals_give_no_playback_warning(tmp_path):
    report = check_vehicle(visual_urdf(tmp_path, '<box size="1 0.2 0.2"/>'))
    assert not [w for w in report.warnings if "playback" in w]
