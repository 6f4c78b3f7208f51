"""UUV Simulator hydrodynamic blocks: frame flip, damping signs, RexROV as shipped."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from aiauv_hydro import FRD_TO_FLU, HydroError, convert_fossen_matrices, read_hydrodynamics
from aiauv_hydro.urdf.uuv_simulator import read_uuv_simulator
from aiauv_hydro.urdf.xml_reading import parse_bool

REXROV = Path(__file__).parents[1] / "data" / "rexrov_uuv_simulator.urdf"

# RexROV's added mass as shipped (forward-right-down axes), row-major.
REXROV_ADDED_MASS = np.array(
    [
        [779.79, -6.8773, -103.32, 8.5426, -165.54, -7.8033],
        [-6.8773, 1222, 51.29, 409.44, -5.8488, 62.726],
        [-103.32, 51.29, 3659.9, 6.1112, -386.42, 10.774],
        [8.5426, 409.44, 6.1112, 534.9, -10.027, 21.019],
        [-165.54, -5.8488, -386.42, -10.027, 842.69, -1.1162],
        [-7.8033, 62.726, 10.775, 21.019, -1.1162, 224.32],
    ]
)
REXROV_LINEAR = np.array([-74.82, -69.48, -728.4, -268.8, -309.77, -105])
REXROV_QUADRATIC = np.array([-748.22, -992.53, -1821.01, -672, -774.44, -523.27])


def read_rexrov():
    with pytest.warns(UserWarning, match="asymmetric"):
        return read_uuv_simulator(REXROV)


def test_rexrov_block_as_shipped():
    spec = read_rexrov()
    assert spec.fluid_density == 1028.0
    (link,) = spec.links
    assert link.link == "rexrov/base_link"  # namespace prefix kept, as in the URDF link names
    assert link.volume == 1.83826
    # Centre of buoyancy is given in the Gazebo (forward-left-up) link frame: not flipped.
    np.testing.assert_array_equal(link.center_of_buoyancy, [0.0, 0.0, 0.3])


def test_rexrov_added_mass_is_symmetric_psd_with_flipped_couplings():
    matrix = read_rexrov().links[0].added_mass
    np.testing.assert_array_equal(matrix, matrix.T)
    assert np.linalg.eigvalsh(matrix).min() > 0.0
    # Diagonal unchanged.
    np.testing.assert_array_equal(np.diag(matrix), np.diag(REXROV_ADDED_MASS))
    # Surge-sway, surge-heave, surge-pitch couplings change sign (one flipped axis)...
    assert matrix[0, 1] == 6.8773 and matrix[0, 2] == 103.32 and matrix[0, 4] == 165.54
    assert matrix[1, 3] == -409.44 and matrix[3, 5] == -21.019
    # ...couplings between two flipped axes (or two unflipped) keep theirs.
    assert matrix[1, 2] == 51.29 and matrix[4, 5] == -1.1162 and matrix[0, 3] == 8.5426
    # The shipped 10.774 / 10.775 pair is averaged (heave-yaw: both axes flipped, no sign change).
    assert matrix[2, 5] == pytest.approx(10.7745) and matrix[5, 2] == matrix[2, 5]


def test_rexrov_damping_becomes_positive():
    link = read_rexrov().links[0]
    np.testing.assert_array_equal(link.linear_damping, np.diag(-REXROV_LINEAR))
    np.testing.assert_array_equal(link.quadratic_damping, np.diag(-REXROV_QUADRATIC))
    assert np.all(np.diag(link.linear_damping) > 0) and np.all(np.diag(link.quadratic_damping) > 0)


def uuv_wrench_frd(nu_frd, acceleration_frd, added_mass, linear, quadratic):
    """UUV Simulator's HMFossen wrench without Coriolis, transcribed: in its FRD axes."""
    damping = -linear - np.diag(np.diag(quadratic) * np.abs(nu_frd))  # ComputeDampingMatrix
    return -damping @ nu_frd - added_mass @ acceleration_frd


def test_converted_model_gives_uuv_simulators_wrench_in_our_axes():
    rng = np.random.default_rng(8)
    symmetric = 0.5 * (REXROV_ADDED_MASS + REXROV_ADDED_MASS.T)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ours_m, ours_l, ours_q = convert_fossen_matrices(
            symmetric, np.diag(REXROV_LINEAR), np.diag(REXROV_QUADRATIC)
        )
    flip = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])  # ToNEDConvention on (v, w)
    for _ in range(5):
        nu_flu, acceleration_flu = rng.normal(size=6), rng.normal(size=6)
        theirs_frd = uuv_wrench_frd(
            flip * nu_flu, flip * acceleration_flu, symmetric, np.diag(REXROV_LINEAR),
            np.diag(REXROV_QUADRATIC),
        )  # fmt: skip
        theirs_flu = flip * theirs_frd  # FromNEDConvention on force and torque
        ours = -ours_m @ acceleration_flu - ours_l @ nu_flu - ours_q @ (np.abs(nu_flu) * nu_flu)
        np.testing.assert_allclose(ours, theirs_flu, rtol=1e-12, atol=1e-9)
        # Damping dissipates in our convention.
        assert nu_flu @ (-ours_l @ nu_flu - ours_q @ (np.abs(nu_flu) * nu_flu)) < 0.0


def test_full_linear_damping_is_flipped():
    linear = -np.diag(np.arange(1.0, 7.0))
    linear[1, 5] = linear[5, 1] = -0.5  # sway-yaw: both flipped, sign kept after negation
    linear[0, 2] = linear[2, 0] = -0.25  # surge-heave: one flipped
    _, ours, _ = convert_fossen_matrices(np.eye(6), linear, np.zeros((6, 6)))
    assert ours[1, 5] == 0.5 and ours[0, 2] == -0.25
    np.testing.assert_array_equal(ours, -(FRD_TO_FLU @ linear @ FRD_TO_FLU))


def test_read_hydrodynamics_includes_uuv_blocks():
    with pytest.warns(UserWarning, match="asymmetric"):
        spec = read_hydrodynamics(REXROV)
    reference = read_rexrov()
    assert spec.fluid_density == reference.fluid_density
    np.testing.assert_array_equal(spec.links[0].added_mass, reference.links[0].added_mass)


def uuv_link(name: str, body: str) -> str:
    return f"""<link name="{name}">{body}<hydrodynamic_model><type>fossen</type>
      <added_mass>{" ".join(["0"] * 36)}</added_mass>
      <linear_damping>-1 -2 -3 -4 -5 -6</linear_damping></hydrodynamic_model></link>"""


def vehicle(plugin_links: str, block: str = "", density: str = "1000") -> str:
    return f"""<robot name="v">
      <link name="v/a"><inertial><mass value="10"/></inertial>
        <collision><origin xyz="0.1 0 0"/><geometry><box size="0.2 0.1 0.1"/></geometry>
        </collision>
        <collision><origin xyz="0.4 0 0.2"/><geometry><box size="0.2 0.1 0.1"/></geometry>
        </collision>
      </link>
      <link name="v/b"><inertial><mass value="5"/></inertial></link>
      <link name="v/massless"/>
      <gazebo><plugin name="uuv_plugin" filename="libunderwater_object_ros_plugin.so">
        <fluid_density>{density}</fluid_density>{plugin_links}</plugin></gazebo>{block}</robot>"""


def test_neutrally_buoyant_volume_from_urdf_mass():
    body = "<neutrally_buoyant>1</neutrally_buoyant><center_of_buoyancy>0 0 0</center_of_buoyancy>"
    spec = read_uuv_simulator(vehicle(uuv_link("v/b", body)))
    assert spec.links[0].volume == pytest.approx(5.0 / 1000.0)  # rho V = m


@pytest.mark.parametrize(
    ("text", "expected"),
    [("1", True), (" TRUE ", True), ("true", True), ("0", False), ("False", False)],
)
def test_xml_booleans(text, expected):
    assert parse_bool(text, "x") is expected


@pytest.mark.parametrize("text", [None, "", "yes", "2", "t rue"])
def test_xml_boolean_errors_name_the_element(text):
    with pytest.raises(
        HydroError, match=r"^<neutrally_buoyant>: expected 0, 1, true or false"
    ) as error:
        parse_bool(text, "<neutrally_buoyant>")
    assert "\n" not in str(error.value)


def test_a_bad_neutrally_buoyant_is_one_line():
    body = (
        "<neutrally_buoyant>maybe</neutrally_buoyant><center_of_buoyancy>0 0 0</center_of_buoyancy>"
    )
    with pytest.raises(HydroError, match="expected 0, 1, true or false, got 'maybe'"):
        read_uuv_simulator(vehicle(uuv_link("v/b", body)))


def test_missing_center_of_buoyancy_is_the_collision_centroid():
    spec = read_uuv_simulator(vehicle(uuv_link("v/a", "<volume>0.004</volume>")))
    np.testing.assert_allclose(spec.links[0].center_of_buoyancy, [0.25, 0, 0.1])


def test_our_block_wins_and_sets_density():
    plugin = uuv_link("v/a", "<volume>0.01</volume>") + uuv_link(
        "v/b", "<neutrally_buoyant>true</neutrally_buoyant><center_of_buoyancy>0 0 0"
        "</center_of_buoyancy>"
    )  # fmt: skip
    block = """<hydrodynamics fluid_density="1025"><link name="v/a" model="fossen">
      <volume>0.5</volume></link></hydrodynamics>"""
    with pytest.warns(UserWarning, match="overrides"):
        spec = read_hydrodynamics(vehicle(plugin, block))
    assert spec.fluid_density == 1025.0
    ours, theirs = spec.links
    assert (ours.link, ours.volume) == ("v/a", 0.5)
    np.testing.assert_array_equal(ours.linear_damping, np.zeros((6, 6)))
    assert theirs.link == "v/b"
    assert theirs.volume == pytest.approx(5.0 / 1025.0)  # neutral at the vehicle's density
    np.testing.assert_array_equal(np.diag(theirs.linear_damping), [1, 2, 3, 4, 5, 6])


def test_forward_speed_damping_is_read_and_offdiagonal_quadratic_warns():
    body = """<volume>0.01</volume><center_of_buoyancy>0 0 0</center_of_buoyancy>
      <hydrodynamic_model><type>fossen</type>
      <linear_damping_forward_speed>-1 0 0 0 0 0</linear_damping_forward_speed>
      <quadratic_damping>{}</quadratic_damping></hydrodynamic_model>"""
    quadratic = -np.eye(6)
    quadratic[0, 1] = -0.5
    text = vehicle(f'<link name="v/b">{body.format(" ".join(map(str, quadratic.ravel())))}</link>')
    with pytest.warns(UserWarning) as record:
        spec = read_uuv_simulator(text)
    messages = " ".join(str(item.message) for item in record)
    assert "forward_speed" not in messages and "off-diagonal" in messages
    np.testing.assert_array_equal(spec.links[0].quadratic_damping, np.eye(6))
    expected = np.zeros((6, 6))
    expected[0, 0] = 1.0  # -(-1): FRD to FLU keeps surge, dissipative sign made positive
    np.testing.assert_array_equal(spec.links[0].forward_speed_damping, expected)


BAD = {
    "positive damping": (
        uuv_link("v/b", "<volume>1</volume><center_of_buoyancy>0 0 0</center_of_buoyancy>").replace(
            "-1 -2", "1 -2"
        ),
        "negative",
    ),
    "unknown link": (uuv_link("v/zzz", "<volume>1</volume>"), "not a <link>"),
    "unsupported type": (
        uuv_link("v/b", "<volume>1</volume>").replace(">fossen<", ">sphere<"),
        "sphere",
    ),
    "missing volume": (uuv_link("v/b", "<center_of_buoyancy>0 0 0</center_of_buoyancy>"), "volume"),
    "neutral without mass": (
        uuv_link("v/massless", "<neutrally_buoyant>1</neutrally_buoyant>"),
        "mass",
    ),
    "bad flag": (uuv_link("v/b", "<neutrally_buoyant>maybe</neutrally_buoyant>"), "maybe"),
    "no cob estimate": (uuv_link("v/b", "<volume>1</volume>"), "center_of_buoyancy"),
    "asymmetric": (
        uuv_link("v/b", "<volume>1</volume>").replace(
            " ".join(["0"] * 36), " ".join(["1"] + ["0"] * 5 + ["0.5"] + ["1"] + ["0"] * 28)
        ),
        "not symmetric",
    ),
    "wrong count": (
        uuv_link("v/b", "<volume>1</volume>").replace("-1 -2 -3 -4 -5 -6", "-1 -2"),
        "expected 6 or 36",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_uuv_blocks_raise_one_line_hydro_error(case):
    plugin, fragment = BAD[case]
    with pytest.raises(HydroError) as error:
        read_uuv_simulator(vehicle(plugin))
    assert "\n" not in str(error.value)
    assert fragment in str(error.value), str(error.value)
