"""The sail CLI: exit codes, one-line errors, the statics and robot commands."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from sailforce import Arm, __version__
from sailforce.cli import cli


def run(*args: str):
    return CliRunner().invoke(cli, list(args), catch_exceptions=False)


def test_version():
    result = run("--version")
    assert result.exit_code == 0 and __version__ in result.output


@pytest.mark.parametrize("command", [[], ["statics"], ["robot"], ["robot", "init"], ["robot", "show"], ["demo"], ["simulate"],
                                     ["stress"], ["reproduce"], ["fit-poly"]])
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
    data = json.loads(run("statics", "--robot", str(path), "--theta1-deg=90", "--theta2-deg=0", "--force-N=1", "--phi-deg=180",
                          "--json").output)
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


@pytest.mark.parametrize("module", ["sailforce", "sailforce.cli"])
def test_python_dash_m_runs_the_cli(module):
    completed = subprocess.run([sys.executable, "-m", module, "--version"], capture_output=True, text=True, check=False)
    assert completed.returncode == 0 and __version__ in completed.stdout
    completed = subprocess.run([sys.executable, "-m", module, "--help"], capture_output=True, text=True, check=False)
    assert completed.returncode == 0 and "Usage: sail" in completed.stdout



def test_the_sail_process_runs_without_pandas_unless_asked(tmp_path):
    """pyarrow would import pandas (0.2 s) on its first array; sail's process keeps it out, and SAIL_PANDAS=1 lets it in."""
    import os

    from sailforce.cli import PANDAS_ENV

    pytest.importorskip("pandas")
    (tmp_path / "in.csv").write_text("theta1_deg,theta2_deg,load1,load2\n90,10,1000,2000\n")
    cal = str(Path(__file__).resolve().parents[1] / "c" / "examples" / "calibration.json")
    code = ("import sys; from sailforce.cli import main; sys.argv = ['sail', 'estimate', '--calibration', sys.argv[1], "
            "sys.argv[2], '-o', sys.argv[3], '-q']\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
            "print(sys.modules.get('pandas') is not None)")
    for allowed, loaded in (("", "False"), ("1", "True")):
        env = {**os.environ, PANDAS_ENV: allowed}
        done = subprocess.run([sys.executable, "-c", code, cal, str(tmp_path / "in.csv"), str(tmp_path / "out.csv")],
                              capture_output=True, text=True, env=env, check=True)  # fmt: skip
        assert done.stdout.split()[-1] == loaded
        assert (tmp_path / "out.csv").read_text().count("\n") == 2

def _csv(path):
    import csv

    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_simulate_writes_rows_and_sidecar(tmp_path):
    out = tmp_path / "sweep.csv"
    result = run("simulate", "--theta1-deg=15:120:15", "--theta2-deg=0", "--phi-deg=0:345:15", "--force-N=10",
                 "--transduction=bridge", "-o", str(out))  # fmt: skip
    assert result.exit_code == 0, result.output
    rows = _csv(out)
    assert len(rows) == 8 * 24
    assert list(rows[0]) == ["theta1_deg", "theta2_deg", "phi_deg", "fx_N", "fy_N", "load1", "load2", "t1_Nm", "t2_Nm"]
    sidecar = json.loads(out.with_name(out.name + ".json").read_text())
    assert sidecar["units"]["load1"] == "mV/V" and sidecar["rows"] == 192 and sidecar["overloaded_rows"] == 0
    # Default robot, pin joints: torques are J^T F, and the bridge reads T_i / l_i.
    arm = Arm()
    for row in rows[::17]:
        th1, th2 = math.radians(float(row["theta1_deg"])), math.radians(float(row["theta2_deg"]))
        t1, t2 = arm.joint_torques(th1, th2, float(row["fx_N"]), float(row["fy_N"]))
        assert float(row["t1_Nm"]) == pytest.approx(float(t1), abs=1e-9)
        assert float(row["t2_Nm"]) == pytest.approx(float(t2), abs=1e-9)
        assert float(row["load1"]) == pytest.approx(2.0 / (50 * 9.80665) * float(t1) / arm.l1, abs=1e-11)


def test_simulate_warns_on_overload(tmp_path):
    out = tmp_path / "big.csv"
    result = CliRunner().invoke(cli, ["simulate", "--theta1-deg=90", "--theta2-deg=0", "--phi-deg=90", "--force-N=2000", "-o", str(out)])
    assert result.exit_code == 0
    assert "beyond its 490.3 N capacity" in result.output
    assert json.loads(out.with_name(out.name + ".json").read_text())["overloaded_rows"] == 1


@pytest.mark.parametrize(
    "args, code, message",
    [
        (["--theta1-deg=30", "--theta2-deg=30"], 1, "collapsed"),
        (["--theta1-deg=30:10:5", "--theta2-deg=0"], 2, "never goes from 30 to 10"),
        (["--theta1-deg=1:2:3:4", "--theta2-deg=0"], 2, "three numbers"),
        (["--theta1-deg=30", "--theta2-deg=0", "--force-N=nan"], 2, "finite"),
    ],
)
def test_simulate_refuses_bad_sweeps_and_keeps_old_output(tmp_path, args, code, message):
    out = tmp_path / "keep.csv"
    out.write_text("precious\n")
    result = CliRunner().invoke(cli, ["simulate", *args, "-o", str(out)])
    assert result.exit_code == code and message in result.output
    assert out.read_text() == "precious\n"


def test_stress_draws_a_figure(tmp_path):
    out = tmp_path / "fig4.png"
    result = run("stress", "--joints=bonded", "--phi-deg=0:315:45", "-o", str(out))
    assert result.exit_code == 0, result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000
    assert "smallest yield safety factor" in result.output


@pytest.mark.parametrize(("blocked", "args", "extra"), [
    ("matplotlib", ["reproduce", "-o", "{tmp}/out"], "report"),
    ("markdown_it", ["reproduce", "-o", "{tmp}/out"], "report"),
    ("matplotlib", ["stress", "-o", "{tmp}/s.png"], "report"),
    ("serial", ["estimate", "--calibration", "c/examples/calibration.json", "--serial", "loop://"], "serial"),
])  # fmt: skip
def test_a_missing_extra_is_named(blocked, args, extra, tmp_path):
    """Without an optional package, the command says which extra to install, in one line, exit 1."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code = (f"import sys; sys.modules[{blocked!r}] = None; sys.argv = ['sail'] + {[a.format(tmp=tmp_path) for a in args]!r}; "
            "from sailforce.cli import main; main()")  # fmt: skip
    result = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=120)
    assert result.returncode == 1, result.stderr
    assert f"pip install 'sailforce[{extra}]'" in result.stderr and "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists() and not (tmp_path / "s.png").exists()
