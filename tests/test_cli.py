"""The sail CLI: exit codes, one-line errors, the statics and robot commands."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest
from click.testing import CliRunner

from sailforce import Arm, __version__
from sailforce.cli import cli


def run(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_version():
    result = run("--version")
    assert result.exit_code == 0 and __version__ in result.output


@pytest.mark.parametrize("command", [[], ["statics"], ["robot"], ["robot", "init"], ["robot", "show"], ["demo"]])
def test_every_command_has_help(command):
    result = run(*command, "--help")
    assert result.exit_code == 0 and "Usage:" in result.output


def test_statics_force_to_torques_json():
    result = run("statics", "--theta1-deg", "75", "--theta2-deg=0", "--force-N", "10", "--phi-deg=-30", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    arm = Arm()
    phi, th1 = math.radians(-30.0), math.radians(75.0)
    assert data["t1_Nm"] == pytest.approx(arm.l3 * 10 * math.sin(phi - th1), rel=1e-12)
    assert data["t2_Nm"] == pytest.approx(arm.l2 * 10 * math.sin(phi), rel=1e-12)
    assert data["force_N"] == pytest.approx(10.0) and data["phi_deg"] == pytest.approx(-30.0)


def test_statics_torques_to_force_round_trips():
    forward = json.loads(run("statics", "--theta1-deg=120", "--theta2-deg=15", "--force-N=7", "--phi-deg=200", "--json").output)
    back = run("statics", "--theta1-deg=120", "--theta2-deg=15", f"--t1={forward['t1_Nm']!r}", f"--t2={forward['t2_Nm']!r}", "--json")
    data = json.loads(back.output)
    assert data["force_N"] == pytest.approx(7.0, rel=1e-12)
    assert data["phi_deg"] % 360 == pytest.approx(200.0, rel=1e-12)


def test_statics_table_output():
    result = run("statics", "--theta1-deg=90", "--theta2-deg=0", "--t1=0", "--t2=3")
    assert result.exit_code == 0
    assert "10 N at 90 deg" in result.output


def test_statics_with_robot_file(tmp_path):
    path = tmp_path / "r.toml"
    assert run("robot", "init", str(path)).exit_code == 0
    path.write_text(path.read_text().replace("l3 = 0.45", "l3 = 0.9"))
    data = json.loads(run("statics", "--robot", str(path), "--theta1-deg=90", "--theta2-deg=0", "--force-N=1", "--phi-deg=180", "--json").output)
    assert data["t1_Nm"] == pytest.approx(0.9 * math.sin(math.pi - math.pi / 2))  # l3 F sin(phi - th1)


def test_singular_pose_is_a_data_error():
    result = CliRunner().invoke(cli, ["statics", "--theta1-deg=30", "--theta2-deg=30", "--t1=1", "--t2=1"])
    assert result.exit_code == 1
    assert "singular pose" in result.output and "Traceback" not in result.output


@pytest.mark.parametrize(
    "args",
    [
        ["statics", "--theta1-deg=30", "--theta2-deg=0"],
        ["statics", "--theta1-deg=30", "--theta2-deg=0", "--force-N=1"],
        ["statics", "--theta1-deg=30", "--theta2-deg=0", "--t1=1"],
        ["statics", "--theta1-deg=30", "--theta2-deg=0", "--t1=1", "--t2=1", "--force-N=2", "--phi-deg=0"],
        ["statics", "--theta1-deg=abc", "--theta2-deg=0", "--t1=1", "--t2=1"],
        ["nonsense"],
    ],
)
def test_usage_errors_exit_2(args):
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output


def test_bad_robot_file_is_one_line_exit_1(tmp_path):
    path = tmp_path / "r.toml"
    path.write_text("[links]\nl1 = 0.2\n")
    result = CliRunner().invoke(cli, ["robot", "show", "--robot", str(path)])
    assert result.exit_code == 1
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "missing l2, l3, l4" in lines[0]


def test_robot_init_refuses_overwrite_then_forces(tmp_path):
    path = tmp_path / "r.toml"
    assert run("robot", "init", str(path)).exit_code == 0
    assert CliRunner().invoke(cli, ["robot", "init", str(path)]).exit_code == 1
    assert run("robot", "init", str(path), "--force").exit_code == 0


def test_robot_show():
    result = run("robot", "show")
    assert result.exit_code == 0 and "0.7500 m" in result.output


def test_demo_runs_and_shows_the_guard():
    result = CliRunner(env={"COLUMNS": "200"}).invoke(cli, ["demo"], catch_exceptions=False)
    assert result.exit_code == 0
    assert "singular pose(s)" in result.output and "seed Eq. 11" in result.output


def test_console_script_is_installed():
    completed = subprocess.run(
        [sys.executable, "-m", "sailforce.cli", "--version"], capture_output=True, text=True, check=False
    )
    assert completed.returncode == 0 and __version__ in completed.stdout
