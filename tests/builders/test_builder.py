"""Tests of the vehicle spec, the URDF builder and the two bundled paper-vehicle URDFs."""

from __future__ import annotations

import copy
import io
import math
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

from aiauv_pin.builders.urdf_builder import (
    PAPER_CASES,
    build_urdf,
    bundled_spec_path,
    bundled_urdf_path,
    format_number,
    paper_spec,
    write_urdf,
)
from aiauv_pin.builders.vehicle_spec import (
    ModuleSpec,
    SpecError,
    VehicleSpec,
    load_spec,
    spec_from_dict,
    spec_from_toml,
)

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

# Table 1 of the paper and PAPER_DATA.md, typed in independently of the bundled TOML specs.
LENGTHS = (0.62, 0.104, 0.584, 0.104, 0.726, 0.104, 0.584, 0.104, 0.37)
MASSES = (14.3, 6.0, 12.7, 6.0, 9.8, 6.0, 12.7, 6.0, 7.8)
RADIUS = 0.085
RHO = 1000.0
JOINT_AXES = ((0, 0, 1), (0, 1, 0)) * 4  # joints 1, 3, 5, 7 about z; 2, 4, 6, 8 about y
JOINT_LIMIT = math.radians(65.0)
THRUSTERS = (  # name, link, position, direction
    ("link3_z", "link3", (0.237, 0.0, 0.0), (0, 0, 1)),
    ("link3_y", "link3", (0.347, 0.0, 0.0), (0, 1, 0)),
    ("link5_x_starboard", "link5", (0.278, -0.1, 0.0), (1, 0, 0)),
    ("link5_x_port", "link5", (0.278, 0.1, 0.0), (1, 0, 0)),
    ("link5_z", "link5", (0.488, 0.0, 0.0), (0, 0, 1)),
    ("link7_y", "link7", (0.237, 0.0, 0.0), (0, 1, 0)),
    ("link7_z", "link7", (0.347, 0.0, 0.0), (0, 0, 1)),
)
CG_DROP = {"uniform": 0.0, "stabilised": 0.5 * RADIUS}  # CG below the axis [m]
LINKS = tuple(f"link{i}" for i in range(1, 10))


def _vector(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()])


def _paper_table(case: str = "uniform") -> dict:
    return tomllib.loads(bundled_spec_path(case).read_text(encoding="utf-8"))


def _pinocchio_model(text: str) -> pin.Model:
    return pin.buildModelFromXML(text, pin.JointModelFreeFlyer())


# --------------------------------------------------------------------------------------------------
# Bundled URDFs


@pytest.mark.parametrize("case", PAPER_CASES)
def test_committed_urdf_matches_builder_output(case):
    committed = bundled_urdf_path(case).read_bytes()
    generated = build_urdf(paper_spec(case)).encode("utf-8")
    assert committed == generated, (
        f"urdf/paper_{case}.urdf is stale; regenerate it with "
        f"`aiauv build urdf/paper_{case}.toml -o urdf/paper_{case}.urdf`"
    )


@pytest.mark.parametrize("case", PAPER_CASES)
def test_paper_vehicle_round_trip_through_yourdfpy(case):
    text = build_urdf(paper_spec(case))
    robot = yourdfpy.URDF.load(io.BytesIO(text.encode()), build_scene_graph=False)
    assert robot.validate()
    links = {link.name: link for link in robot.robot.links}
    assert set(links) == {*LINKS, "end_effector"}
    assert links["end_effector"].inertial is None
    drop = CG_DROP[case]
    for name, length, mass in zip(LINKS, LENGTHS, MASSES, strict=True):
        link = links[name]
        assert link.inertial.mass == pytest.approx(mass, rel=1e-15)
        np.testing.assert_allclose(
            link.inertial.origin[:3, 3], [length / 2, 0.0, -drop], atol=1e-15
        )
        np.testing.assert_allclose(link.inertial.origin[:3, :3], np.eye(3), atol=1e-15)
        # solid cylinder about its centre of mass, axis along x
        axial = mass * RADIUS**2 / 2
        transverse = mass * (3 * RADIUS**2 + length**2) / 12
        np.testing.assert_allclose(
            link.inertial.inertia, np.diag([axial, transverse, transverse]), rtol=1e-14, atol=0.0
        )
        for shape in (link.collisions[0], link.visuals[0]):
            cylinder = shape.geometry.cylinder
            assert (cylinder.radius, cylinder.length) == pytest.approx((RADIUS, length), rel=1e-15)
            # the URDF cylinder's local z must lie along the link's x axis, centred at L/2
            np.testing.assert_allclose(shape.origin[:3, 2], [1.0, 0.0, 0.0], atol=1e-15)
            np.testing.assert_allclose(shape.origin[:3, 3], [length / 2, 0.0, 0.0], atol=1e-15)
    joints = {joint.name: joint for joint in robot.robot.joints}
    assert set(joints) == {f"joint{i}" for i in range(1, 9)} | {"end_effector_joint"}
    for i in range(8):
        joint = joints[f"joint{i + 1}"]
        assert (joint.type, joint.parent, joint.child) == ("revolute", LINKS[i], LINKS[i + 1])
        np.testing.assert_array_equal(joint.axis, JOINT_AXES[i])
        np.testing.assert_allclose(joint.origin, _translation(LENGTHS[i]), atol=1e-15)
        assert (joint.limit.lower, joint.limit.upper) == pytest.approx((-JOINT_LIMIT, JOINT_LIMIT))
        assert joint.limit.effort > 0 and joint.limit.velocity > 0
    end = joints["end_effector_joint"]
    assert (end.type, end.parent, end.child) == ("fixed", "link9", "end_effector")
    np.testing.assert_allclose(end.origin, _translation(LENGTHS[-1]), atol=1e-15)


def _translation(x: float) -> np.ndarray:
    transform = np.eye(4)
    transform[0, 3] = x
    return transform


@pytest.mark.parametrize("case", PAPER_CASES)
def test_paper_vehicle_hydrodynamics_block(case):
    root = ET.fromstring(build_urdf(paper_spec(case)))
    blocks = root.findall("hydrodynamics")
    assert len(blocks) == 1
    block = blocks[0]
    assert float(block.get("fluid_density")) == RHO
    assert float(block.get("gravity")) == 9.81
    entries = block.findall("link")
    assert [entry.get("name") for entry in entries] == list(LINKS)
    displaced_mass = 0.0
    for entry, length, mass in zip(entries, LENGTHS, MASSES, strict=True):
        assert entry.get("model") == "slender_cylinder"
        # no hydrodynamic matrices: the reader derives them from the collision cylinder
        assert {child.tag for child in entry} == {"volume", "center_of_buoyancy"}
        volume = float(entry.find("volume").text)
        assert volume == pytest.approx(mass / RHO, rel=1e-15)  # each link neutrally buoyant
        displaced_mass += RHO * volume
        np.testing.assert_allclose(
            _vector(entry.find("center_of_buoyancy").text), [length / 2, 0, 0], atol=1e-15
        )
    assert displaced_mass == pytest.approx(sum(MASSES), rel=1e-14)
    thrusters = block.findall("thruster")
    assert len(thrusters) == len(THRUSTERS)
    for element, (name, link, position, direction) in zip(thrusters, THRUSTERS, strict=True):
        assert (element.get("name"), element.get("link")) == (name, link)
        np.testing.assert_allclose(_vector(element.get("xyz")), position, atol=1e-15)
        np.testing.assert_array_equal(_vector(element.get("direction")), direction)
        assert float(element.get("max_thrust")) == 50.0


@pytest.mark.parametrize("case", PAPER_CASES)
def test_paper_vehicle_totals_and_centre_of_gravity_in_pinocchio(case):
    model = _pinocchio_model(bundled_urdf_path(case).read_text(encoding="utf-8"))
    data = model.createData()
    q = pin.neutral(model)
    assert (model.nq, model.nv) == (7 + 8, 6 + 8)
    assert pin.computeTotalMass(model) == pytest.approx(81.3, rel=1e-14)
    pin.framesForwardKinematics(model, data, q)
    tip = data.oMf[model.getFrameId("end_effector")]
    np.testing.assert_allclose(tip.translation, [3.30, 0.0, 0.0], atol=1e-14)
    np.testing.assert_allclose(tip.rotation, np.eye(3), atol=1e-15)
    # centre of mass: every link's CG at its middle, CG_DROP below the axis
    starts = np.concatenate([[0.0], np.cumsum(LENGTHS)[:-1]])
    x_com = sum(m * (s + length / 2) for m, s, length in zip(MASSES, starts, LENGTHS, strict=True))
    expected = [x_com / sum(MASSES), 0.0, -CG_DROP[case]]
    np.testing.assert_allclose(pin.centerOfMass(model, data, q), expected, atol=1e-14)


def test_stabilised_vehicle_roll_restoring_stiffness():
    """d^2U/dphi^2 of the weight under a roll of the straight vehicle is M g h (about 34 N m/rad).

    Buoyancy acts on the roll axis, so it contributes no roll stiffness; the weight does.
    """
    model = _pinocchio_model(bundled_urdf_path("stabilised").read_text(encoding="utf-8"))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = model.createData()

    def potential(phi: float) -> float:
        q = pin.neutral(model)
        q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(phi, 0.0, 0.0)).coeffs()
        return pin.computePotentialEnergy(model, data, q)

    step = 1e-3
    stiffness = (potential(step) - 2 * potential(0.0) + potential(-step)) / step**2
    assert stiffness == pytest.approx(81.3 * 9.81 * 0.0425, rel=1e-5)
    assert stiffness == pytest.approx(34.0, abs=0.2)


def test_pinocchio_joints_turn_about_the_specified_axes():
    model = _pinocchio_model(build_urdf(paper_spec("uniform")))
    data = model.createData()
    angle = 0.4
    for i, axis in enumerate(JOINT_AXES):
        q = pin.neutral(model)
        q[model.joints[model.getJointId(f"joint{i + 1}")].idx_q] = angle
        pin.framesForwardKinematics(model, data, q)
        child = data.oMf[model.getFrameId(LINKS[i + 1])]
        np.testing.assert_allclose(child.rotation, pin.exp3(angle * np.array(axis)), atol=1e-14)
        np.testing.assert_allclose(child.translation, [sum(LENGTHS[: i + 1]), 0, 0], atol=1e-14)


# --------------------------------------------------------------------------------------------------
# Generated vehicles


def _random_table(n_modules: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    modules = []
    for i in range(n_modules):
        length = float(rng.uniform(0.05, 0.8))
        radius = float(rng.uniform(0.03, 0.12))
        module = {
            "name": f"m{i}",
            "length": length,
            "radius": radius,
            "cg_offset": [0.0, 0.0, float(-rng.uniform(0.0, 0.5) * radius)],
        }
        if i % 2:
            module["density"] = float(rng.uniform(500.0, 2000.0))
        else:
            module["mass"] = float(rng.uniform(0.5, 20.0))
        if i < n_modules - 1:
            module["joint"] = "xyz"[int(rng.integers(3))]
        if i == 1:
            module["thruster"] = [{"name": "t0", "x": length / 2, "direction": [0.0, 3.0, 4.0]}]
        modules.append(module)
    return {"name": f"generated_{n_modules}", "module": modules}


def _expected_mass(module: dict) -> float:
    if "mass" in module:
        return module["mass"]
    return module["density"] * math.pi * module["radius"] ** 2 * module["length"]


@pytest.mark.parametrize("n_modules", range(3, 16))
def test_generated_vehicle_loads_in_pinocchio_and_yourdfpy(n_modules):
    table = _random_table(n_modules, seed=n_modules)
    spec = spec_from_dict(table)
    text = build_urdf(spec)
    model = _pinocchio_model(text)
    data = model.createData()
    assert model.nq == 7 + n_modules - 1
    assert model.nv == 6 + n_modules - 1
    masses = [_expected_mass(m) for m in table["module"]]
    assert pin.computeTotalMass(model) == pytest.approx(sum(masses), rel=1e-13)
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    length = sum(m["length"] for m in table["module"])
    tip = data.oMf[model.getFrameId("end_effector")].translation
    np.testing.assert_allclose(tip, [length, 0.0, 0.0], atol=1e-13)
    robot = yourdfpy.URDF.load(io.BytesIO(text.encode()), build_scene_graph=False)
    assert robot.validate()
    assert robot.num_dofs == n_modules - 1
    for module, joint in zip(table["module"], robot.robot.joints, strict=False):
        if "joint" in module:
            np.testing.assert_array_equal(joint.axis, np.eye(3)["xyz".index(module["joint"])])
    # default volume: neutrally buoyant link by link
    volumes = [float(v.text) for v in ET.fromstring(text).iter("volume")]
    np.testing.assert_allclose(np.array(volumes) * 1000.0, masses, rtol=1e-14)
    thruster = ET.fromstring(text).find("hydrodynamics/thruster")
    np.testing.assert_allclose(_vector(thruster.get("direction")), [0.0, 0.6, 0.8], atol=1e-15)


def test_explicit_volume_and_cb_offset_are_written():
    table = _random_table(3, seed=0)
    table["module"][0]["volume"] = 0.5
    table["module"][0]["cb_offset"] = [0.01, 0.0, 0.02]
    root = ET.fromstring(build_urdf(spec_from_dict(table)))
    entry = root.find("hydrodynamics/link")
    length = table["module"][0]["length"]
    assert float(entry.find("volume").text) == 0.5
    np.testing.assert_allclose(
        _vector(entry.find("center_of_buoyancy").text), [length / 2 + 0.01, 0.0, 0.02], atol=1e-15
    )


def test_write_urdf_is_atomic_and_deterministic(tmp_path):
    spec = load_spec(bundled_spec_path("stabilised"))
    target = tmp_path / "vehicle.urdf"
    target.write_text("old content")
    assert write_urdf(spec, target) == target
    assert target.read_text(encoding="utf-8") == build_urdf(paper_spec("stabilised"))
    assert [p.name for p in tmp_path.iterdir()] == ["vehicle.urdf"]  # no temporary file left


@pytest.mark.parametrize(
    ("value", "text"),
    [(0.62, "0.62"), (-0.0, "0"), (1000.0, "1000"), (math.pi / 2, "1.5707963267948966")],
)
def test_format_number_is_exact_and_short(value, text):
    assert format_number(value) == text
    assert float(format_number(value)) == value


@pytest.mark.parametrize("value", [0.1 + 0.2, 14.3 * 0.085**2 / 2, 1e-300, -2.5e17, math.tau])
def test_format_number_round_trips(value):
    assert float(format_number(value)) == value


# --------------------------------------------------------------------------------------------------
# Spec validation


def _set(path: tuple, value):
    def mutate(table: dict) -> None:
        target = table
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return mutate


def _delete(path: tuple):
    def mutate(table: dict) -> None:
        target = table
        for key in path[:-1]:
            target = target[key]
        del target[path[-1]]

    return mutate


def _density(index: int, value: float):
    def mutate(table: dict) -> None:
        module = table["module"][index]
        del module["mass"]
        module["density"] = value

    return mutate


THRUSTER = ("module", 2, "thruster", 0)
BAD_SPECS = {
    "unknown top key": (_set(("colour",), "red"), "colour: unknown key"),
    "unknown module key": (
        _set(("module", 3, "lenght"), 1.0),
        "module 'link4'.lenght: unknown key",
    ),
    "unknown thruster key": (
        _set((*THRUSTER, "thrust"), 1.0),
        "module 'link3'.thruster 'link3_z'.thrust: unknown key",
    ),
    "missing name": (_delete(("name",)), "name: missing"),
    "missing module name": (_delete(("module", 4, "name")), "module[4].name: missing"),
    "missing length": (_delete(("module", 0, "length")), "module 'link1'.length: missing"),
    "missing mass": (_delete(("module", 0, "mass")), "module 'link1': give exactly one of 'mass'"),
    "mass and density": (_set(("module", 0, "density"), 900.0), "exactly one of 'mass'"),
    "zero length": (
        _set(("module", 1, "length"), 0.0),
        "module 'link2'.length: expected a number in (0, 100], got 0.0",
    ),
    "negative mass": (_set(("module", 1, "mass"), -6.0), "module 'link2'.mass: expected a number"),
    "negative density": (
        _density(1, -1.0),
        "module 'link2'.density: expected a number in (0, 1e5], got -1.0",
    ),
    "nan density": (
        _density(1, math.nan),
        "module 'link2'.density: expected a number in (0, 1e5], got nan",
    ),
    "zero radius": (_set(("radius",), 0.0), "radius: expected a number in (0, 10], got 0.0"),
    "module radius": (
        _set(("module", 2, "radius"), -0.1),
        "module 'link3'.radius: expected a number in (0, 10]",
    ),
    "nan length": (
        _set(("module", 2, "length"), math.nan),
        "module 'link3'.length: expected a number",
    ),
    "inf mass": (
        _set(("module", 2, "mass"), math.inf),
        "module 'link3'.mass: expected a number in (0, 1e7], got inf",
    ),
    "string mass": (
        _set(("module", 2, "mass"), "heavy"),
        "module 'link3'.mass: expected a number in (0, 1e7], got 'heavy'",
    ),
    "bool mass": (
        _set(("module", 2, "mass"), True),
        "module 'link3'.mass: expected a number in (0, 1e7] (a bool is not a number)",
    ),
    "nan cg": (
        _set(("module", 2, "cg_offset"), [0, 0, math.nan]),
        "module 'link3'.cg_offset[2]: expected a number",
    ),
    "short cg": (
        _set(("module", 2, "cg_offset"), [0, 0]),
        "module 'link3'.cg_offset: expected a list of 3 numbers",
    ),
    "cg outside": (_set(("module", 2, "cg_offset"), [0, 0, -0.2]), "cg_offset"),
    "zero volume": (
        _set(("module", 2, "volume"), 0.0),
        "module 'link3'.volume: expected a number in (0, 1e4], got 0.0",
    ),
    "bad axis": (
        _set(("module", 0, "joint"), "w"),
        "module 'link1'.joint: expected one of x, y, z, got 'w'",
    ),
    "head joint": (_set(("module", 8, "joint"), "z"), "module 'link9': the head module"),
    "missing joint": (_delete(("module", 3, "joint")), "module 'link4': missing field 'joint'"),
    "duplicate module": (_set(("module", 3, "name"), "link1"), "module name 'link1' used twice"),
    "reserved name": (_set(("module", 3, "name"), "joint2"), "module name 'joint2' is reserved"),
    "bad name": (
        _set(("module", 3, "name"), "link 4"),
        "module[3].name: expected a name of letters",
    ),
    "one module": (
        lambda t: t.update(module=t["module"][:1]),
        "module: expected a list of 2 to 127 tables, got 1 entry",
    ),
    "no modules": (_delete(("module",)), "module: missing"),
    "module not table": (_set(("module",), 3), "module: expected a list of 2 to 127 tables, got 3"),
    "thruster outside": (_set((*THRUSTER, "x"), 0.6), "thruster 'link3_z' x = 0.6"),
    "thruster behind": (_set((*THRUSTER, "x"), -0.01), "thruster 'link3_z' x = -0.01"),
    "thruster no x": (_delete((*THRUSTER, "x")), "module 'link3'.thruster 'link3_z'.x: missing"),
    "thruster direction": (
        _set((*THRUSTER, "direction"), "up"),
        "module 'link3'.thruster 'link3_z'.direction: expected one of x, y, z",
    ),
    "zero direction": (_set((*THRUSTER, "direction"), [0, 0, 0]), "direction must be nonzero"),
    "thrust limit": (
        _set((*THRUSTER, "max_thrust"), 0.0),
        "module 'link3'.thruster 'link3_z'.max_thrust: expected a number",
    ),
    "duplicate thruster": (_set((*THRUSTER, "name"), "link7_y"), "thruster name 'link7_y' used"),
    "joint limit": (
        _set(("joint_limit_deg",), 200.0),
        "joint_limit_deg: expected a number in (0, 180], got 200.0",
    ),
    "fluid density": (
        _set(("fluid_density",), -1.0),
        "fluid_density: expected a number in (0, 1e5], got -1.0",
    ),
    "gravity": (_set(("gravity",), math.nan), "gravity: expected a number in [0, 100], got nan"),
}


@pytest.mark.parametrize("case", sorted(BAD_SPECS))
def test_spec_errors_are_one_line_and_name_the_field(case):
    mutate, expected = BAD_SPECS[case]
    table = copy.deepcopy(_paper_table())
    mutate(table)
    with pytest.raises(SpecError) as error:
        spec_from_dict(table)
    message = str(error.value)
    assert "\n" not in message
    assert expected in message


def test_spec_error_is_a_value_error_and_file_errors_name_the_file(tmp_path):
    assert issubclass(SpecError, ValueError)
    missing = tmp_path / "missing.toml"
    with pytest.raises(SpecError, match=r"missing\.toml: cannot read"):
        load_spec(missing)
    broken = tmp_path / "broken.toml"
    broken.write_text('name = "x"\n[[module]\n')
    with pytest.raises(SpecError) as error:
        load_spec(broken)
    assert "\n" not in str(error.value) and "broken.toml: invalid TOML" in str(error.value)
    with pytest.raises(SpecError, match="invalid TOML"):
        spec_from_toml("radius = ")


def test_dataclasses_validate_direct_construction():
    with pytest.raises(SpecError, match="module 'a': length"):
        ModuleSpec(name="a", length=-1.0, mass=1.0, radius=0.1)
    with pytest.raises(SpecError, match="at least 2 modules"):
        VehicleSpec(name="v", modules=(ModuleSpec(name="a", length=1.0, mass=1.0, radius=0.1),))
    with pytest.raises(SpecError, match="unknown paper vehicle case"):
        paper_spec("heavy")


def test_density_gives_cylinder_mass_and_paper_spec_matches_table_1():
    table = _random_table(3, seed=1)
    module = table["module"][1]
    spec = spec_from_dict(table)
    expected = module["density"] * math.pi * module["radius"] ** 2 * module["length"]
    assert spec.modules[1].mass == pytest.approx(expected, rel=1e-15)
    for case in PAPER_CASES:
        paper = paper_spec(case)
        assert paper.link_names == LINKS
        assert tuple(m.length for m in paper.modules) == LENGTHS
        assert tuple(m.mass for m in paper.modules) == MASSES
        assert paper.total_mass == pytest.approx(81.3, rel=1e-15)
        assert paper.total_length == pytest.approx(3.30, rel=1e-15)
        assert Path(bundled_urdf_path(case)).name == f"paper_{case}.urdf"
