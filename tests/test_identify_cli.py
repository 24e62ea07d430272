"""``sail identify`` and ``sail calibrate --model physics``: files written, values recovered, errors refused."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce.cli import cli
from sailforce.io.robotfile import load_robot_file, template
from sailforce.robot import Joints, Robot
from sailforce.synthetic import NoiseModel, calibration_session


def run(*args: str):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A pulley-and-weights session on an arm with 900 N m/rad springs at every joint, its robot file pin-jointed."""
    directory = tmp_path_factory.mktemp("rig")
    t1, t2, fx, fy, counts, _ = calibration_session(Robot(joints=Joints("spring", 900.0)), noise=NoiseModel())
    rows = np.column_stack([np.degrees(t1), np.degrees(t2), counts, fx, fy])
    path = directory / "static.csv"
    np.savetxt(path, rows, delimiter=",", header="theta1_deg,theta2_deg,load1,load2,fx_N,fy_N", comments="", fmt="%.12g")
    (directory / "robot.toml").write_text(template(Robot()))
    return directory


def test_identify_from_readings_recovers_the_stiffness_within_its_error_and_writes_a_robot_file(session, tmp_path):
    result = run("identify", "--data", session / "static.csv", "--robot", session / "robot.toml",
                 "--free", "joints.stiffness", "-o", tmp_path / "id", "-q")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "a free stiffness needs a spring" in result.output  # the pin-jointed robot file was made springy
    report = json.loads((tmp_path / "id" / "identify.json").read_text())
    stiffness = report["parameters"][0]
    assert stiffness["name"] == "joints.stiffness" and stiffness["identifiable"]
    assert abs(stiffness["value"] - 900.0) < 3.0 * stiffness["standard_error"]
    identified = load_robot_file(tmp_path / "id" / "identified.toml").robot
    assert identified.joints.model == "spring" and identified.joints.stiffness == pytest.approx(stiffness["value"], rel=1e-5)
    residuals = np.loadtxt(tmp_path / "id" / "residuals.csv", delimiter=",", skiprows=1)
    assert residuals.shape == (len(np.loadtxt(session / "static.csv", delimiter=",", skiprows=1)), 3)
    assert (tmp_path / "id" / "fit.png").stat().st_size > 10_000


def test_identify_against_the_seed_table4_fits_a_spring_near_the_issues_170(tmp_path):
    """The issue's hand fit: a spring of about 170 N m/rad with the lengths free matches the seed's phases."""
    result = run("identify", "--table4", "seed", "--free", "joints.stiffness,links.l3", "--amplitude-weight", "0",
                 "-o", tmp_path, "-q")  # fmt: skip
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "identify.json").read_text())
    values = {p["name"]: p["value"] for p in report["parameters"]}
    assert 100.0 < values["joints.stiffness"] < 300.0
    assert max(report["metrics"]["phase_rms_deg"]) < 3.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--free", "joints.stiffness"], "give one target"),
        (["--table4", "seed", "--data", "x.csv", "--free", "joints.stiffness"], "give one target"),
        (["--table4", "seed", "--free", "handle.mass"], "does not enter the static sensing map"),
        (["--table4", "seed", "--free", "joints.P9.stiffness"], "unknown parameter"),
        (["--table4", "seed", "--free", "joints.stiffness", "--bounds", "joints.stiffness=a:b"], "KEY=LOW:HIGH"),
        (["--table4", "seed", "--free", "joints.stiffness", "--bounds", "links.l1=0.1:0.3"], "which is not free"),
    ],
)
def test_identify_refuses_bad_requests_with_one_line(tmp_path, args, message):
    result = run("identify", *args, "-o", tmp_path / "out")
    assert result.exit_code == 2 and message in result.output
    assert not (tmp_path / "out").exists()


def test_calibrate_physics_stores_a_map_over_the_whole_range_and_records_the_parameters(session, tmp_path):
    result = run("calibrate", session / "static.csv", "--model", "physics", "--free", "joints.stiffness",
                 "-o", tmp_path / "cal.json", "-q")  # fmt: skip
    assert result.exit_code == 0, result.output
    cal = json.loads((tmp_path / "cal.json").read_text())
    assert cal["model"]["kind"] == "matrix" and np.degrees(cal["delta_range"]) == pytest.approx([15.0, 165.0])
    parameters = cal["metrics"]["physics"]["parameters"]
    assert abs(parameters["joints.stiffness"]["value"] - 900.0) < 3.0 * parameters["joints.stiffness"]["standard_error"]
    assert cal["metrics"]["physics"]["map_error"] < 1e-6
    wrong = run("calibrate", session / "static.csv", "--model", "matrix", "--free", "joints.stiffness", "-o", tmp_path / "x.json")
    assert wrong.exit_code == 2 and "--model physics or auto" in wrong.output
