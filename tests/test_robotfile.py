"""Robot files and the Arm's own checks."""

from __future__ import annotations

import re

import numpy as np
import pytest

from sailforce import Arm, GeometryError, RobotFileError
from sailforce.io.robotfile import load_arm, load_robot_file, robot_data, robot_from_data, template, write_template
from sailforce.io.robotkeys import get_key, robot_keys, with_keys
from sailforce.robot import Joint, Joints, Robot


def test_template_round_trips_to_the_default_arm(tmp_path):
    path = write_template(tmp_path / "robot.toml")
    assert load_arm(path) == Arm()


def test_template_is_commented():
    text = template()
    assert text.count("#") > 10 and "[links]" in text


def test_write_refuses_to_overwrite(tmp_path):
    path = write_template(tmp_path / "robot.toml")
    with pytest.raises(RobotFileError, match="already exists; pass --force"):
        write_template(path)
    write_template(path, overwrite=True)


def test_custom_lengths(tmp_path):
    path = tmp_path / "r.toml"
    path.write_text("[links]\nl1 = 0.25\nl2 = 0.4\nl3 = 0.6\nl4 = 0.4\n")
    assert load_arm(path) == Arm(l1=0.25, l2=0.4, l3=0.6, l4=0.4)


@pytest.mark.parametrize(
    "text, message",
    [
        ("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\n", "missing l4"),
        ("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\nl5 = 1\n", "unknown key.*l5"),
        ("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.31\n", "l4 = 0.31 m must equal l2"),
        ("[links]\nl1 = 0.5\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n", "l3 = 0.45 m must exceed l1"),
        ("[links]\nl1 = -0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n", "positive and finite"),
        ("[links]\nl1 = 'long'\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n", "l1 = 'long': expected a length"),
        ("[links]\nl1 = nan\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n", "positive and finite"),
        ("[linkz]\nl1 = 0.2\n", "unknown section.*linkz"),
        ("title = 'arm'\n", "unknown section"),
        ("", "missing the \\[links\\] table"),
        ("[links\nl1 = 0.2\n", "not valid TOML"),
    ],
)
def test_bad_files_are_refused_with_the_file_named(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(RobotFileError, match=message) as info:
        load_robot_file(path)
    assert str(path) in str(info.value)


def test_missing_file_says_how_to_make_one(tmp_path):
    with pytest.raises(RobotFileError, match="no such file; `sail robot init"):
        load_arm(tmp_path / "nope.toml")


@pytest.mark.parametrize("kwargs", [{"l1": 0.0}, {"l2": -1.0, "l4": -1.0}, {"l3": float("inf")}, {"l1": True}])
def test_arm_rejects_impossible_lengths(kwargs):
    with pytest.raises(GeometryError):
        Arm(**kwargs)


def test_arm_is_frozen():
    with pytest.raises(AttributeError):
        Arm().l1 = 1.0  # type: ignore[misc]


def test_arm_accepts_integers_as_floats():
    assert Arm(l1=1, l2=2, l3=3, l4=2).l3 == 3.0


def test_structure_sections_are_read(tmp_path):
    from sailforce.robot import Robot

    path = tmp_path / "r.toml"
    path.write_text(
        "[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n"
        "[sections]\ndepth = 0.03\n"
        "[materials.links]\nE = 7.0e10\n"
        "[loadcells]\nposition = 0.4\ncapacity_kg = 20\ndepth = 0.015\n"
        "[joints]\nmodel = \"spring\"\nstiffness = 12.5\n"
        "[motors]\nmodel = \"gearbox\"\n"
    )
    robot = load_robot_file(path).robot
    default = Robot()
    assert robot.link_section.depth == 0.03 and robot.link_section.thickness == default.link_section.thickness
    assert robot.link_material.E == 7.0e10 and robot.link_material.nu == default.link_material.nu
    assert robot.loadcell.position == 0.4 and robot.loadcell.capacity_kg == 20
    assert robot.loadcell.block.depth == 0.015 and robot.loadcell.block.thickness == default.loadcell.block.thickness
    assert (robot.joints.model, robot.joints.stiffness) == ("spring", 12.5)
    assert robot.motors.model == "gearbox" and robot.motors.stiffness == default.motors.stiffness


def test_per_link_sections_and_materials(tmp_path):
    """[sections.l3] and [materials.l4] override the shared tables key by key, and survive a round trip."""
    from sailforce.io.robotfile import robot_data, robot_from_data, template

    path = tmp_path / "r.toml"
    path.write_text(
        "[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n"
        "[sections]\ndepth = 0.03\n[sections.l3]\nthickness = 0.015\n"
        "[materials.links]\nE = 7.0e10\n[materials.l4]\nrho = 2700\n"
    )
    robot = load_robot_file(path).robot
    assert robot.section("l3").depth == 0.03 and robot.section("l3").thickness == 0.015
    assert robot.section("l1") == robot.link_section and robot.section("l1").thickness == 0.010
    assert robot.material("l4").rho == 2700 and robot.material("l4").E == 7.0e10 and robot.material("l3").rho == 7800
    assert not robot.uniform_links and Robot().uniform_links
    assert robot_from_data(robot_data(robot)) == robot
    (tmp_path / "t.toml").write_text(template(robot))
    assert load_robot_file(tmp_path / "t.toml").robot == robot
    path.write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[sections.l3]\nwidth = 0.015\n")
    with pytest.raises(RobotFileError, match=r"\[sections.l3\] has unknown key\(s\) width"):
        load_robot_file(path)
    path.write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[materials.l5]\nrho = 1\n")
    with pytest.raises(RobotFileError, match="unknown key"):
        load_robot_file(path)


def test_links_only_file_gets_structure_defaults(tmp_path):
    from sailforce.robot import Robot

    path = tmp_path / "r.toml"
    path.write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n")
    assert load_robot_file(path).robot == Robot()


@pytest.mark.parametrize(
    "extra, message",
    [
        ("[joints]\nmodel = \"welded\"\n", "joints model = 'welded': expected one of pin, bonded, spring"),
        ("[joints]\nmodel = 3\n", "expected a quoted name"),
        ("[loadcells]\ncapacity = 50\n", "\\[loadcells\\] has unknown key\\(s\\) capacity"),
        ("[loadcells]\nposition = 0.01\n", "does not fit inside l1"),
        ("[motors]\nstiffness = -1\n", "motors stiffness"),
        ("[materials.links]\nE = \"steel\"\n", "E = 'steel': expected a number"),
        ("[materials.steel]\nE = 1\n", "\\[materials\\] has unknown key\\(s\\) steel"),
        ("[sections]\ndepth = 0\n", "section depth"),
    ],
)
def test_bad_structure_sections_are_refused(tmp_path, extra, message):
    path = tmp_path / "r.toml"
    path.write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n" + extra)
    with pytest.raises(RobotFileError, match=message) as info:
        load_robot_file(path)
    assert str(path) in str(info.value)


def test_per_joint_tables_are_read_and_written(tmp_path):
    """``[joints.P1]`` overrides ``[joints]`` at P1 only; the template writes it back."""
    from sailforce.robot import Joint, Joints, Robot

    path = tmp_path / "r.toml"
    path.write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[joints]\nmodel = \"bonded\"\n"
                    "[joints.P2]\nmodel = \"spring\"\nstiffness = 170\n")  # fmt: skip
    joints = load_robot_file(path).robot.joints
    assert joints.at("P1") == Joint("bonded", 50.0) and joints.at("P2") == Joint("spring", 170.0)
    assert joints.label == "P1 bonded, P2 spring 170, P3 bonded"
    robot = Robot(joints=Joints("pin", 20.0, P3=Joint("bonded")))
    path.write_text(template(robot))
    assert load_robot_file(path).robot == robot
    assert robot.with_joints("spring").joints == Joints("spring", 20.0)  # every joint, overrides dropped


@pytest.mark.parametrize(("extra", "message"), [
    ("[joints.P1]\nmodel = \"glued\"\n", "joints model = 'glued'"),
    ("[joints.P1]\nmodel = 1\n", "\\[joints.P1\\] model = 1: expected a quoted name"),
    ("[joints.P4]\nmodel = \"pin\"\n", "\\[joints\\] has unknown key\\(s\\) P4"),
    ("[joints.P2]\nstifness = 3\n", "\\[joints.P2\\] has unknown key\\(s\\) stifness"),
    ("[joints.P3]\nstiffness = -3\n", "joints stiffness = -3"),
])  # fmt: skip
def test_bad_per_joint_tables_are_refused(tmp_path, extra, message):
    path = tmp_path / "r.toml"
    path.write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n" + extra)
    with pytest.raises(RobotFileError, match=message) as info:
        load_robot_file(path)
    assert str(path) in str(info.value)


# --- robot-file keys as dotted paths (identify's parameters, design's sweeps) ----------------------------------


def test_robot_data_round_trips_at_full_precision():
    robot = Robot(joints=Joints("spring", 123.456789012345, P2=Joint("bonded", 1.0)))
    assert robot_from_data(robot_data(robot)) == robot


def test_with_keys_sets_one_value_and_keeps_the_parallelogram():
    robot = with_keys(Robot(), {"links.l2": 0.25, "joints.P1.stiffness": 170.0, "loadcells.crosstalk_axial": 0.02})
    assert (robot.arm.l2, robot.arm.l4) == (0.25, 0.25)
    assert robot.joints.P1 == Joint("pin", 170.0) and robot.joints.P2 is None  # P1 starts from the shared joint
    assert get_key(robot, "joints.P1.stiffness") == 170.0 and get_key(robot, "joints.P3.stiffness") == 50.0
    assert robot.loadcell.crosstalk_axial == 0.02
    assert "joints.P3.stiffness" in robot_keys(Robot(), numeric=True) and "joints.model" not in robot_keys(Robot(), numeric=True)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"links.l5": 0.1}, "unknown robot key 'links.l5': expected one of links.l1"),
        ({"loadcells.position": 2.0}, "position = 2.0 must lie strictly between 0 and 1"),
        ({"joints.P1.model": "weld"}, "'weld': expected one of pin, bonded, spring"),
        ({"links": 0.3}, "unknown robot key 'links'"),
    ],
)
def test_with_keys_refuses_unknown_keys_and_bad_values_by_name(values, message):
    with pytest.raises(RobotFileError, match=re.escape(message)):
        with_keys(Robot(), values)


def test_the_cell_compliance_models_read_from_a_file(tmp_path):
    path = tmp_path / "r.toml"
    path.write_text('[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[loadcells]\ncompliance = "matrix"\n'
                    "compliance_vv = 2e-6\ncompliance_vm = 5e-5\ncompliance_mm = 2e-3\n")  # fmt: skip
    cell = load_robot_file(path).robot.loadcell
    np.testing.assert_array_equal(cell.flexibility, [[2e-6, 5e-5], [5e-5, 2e-3]])
    path.write_text(path.read_text().replace("compliance_mm = 2e-3", "compliance_mm = 1e-3"))
    with pytest.raises(RobotFileError, match="not positive definite"):
        load_robot_file(path)
    path.write_text(path.read_text().replace('"matrix"', "3"))
    with pytest.raises(RobotFileError, match=re.escape("[loadcells] compliance = 3: expected a quoted name")):
        load_robot_file(path)
