"""Regression tests for the second hardening round: one test per defect, named after it.

Each test fails on the code before its fix (the defect is described in its
docstring) and passes after it.  The bad-input cases that only need the real
command's exit code and message are in tests/test_corpus.py; the live
server's are in tests/test_live_security.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sailforce import Arm
from sailforce.calibration.file import TEXT_FIELDS, Calibration, CalibrationFileError, checksum
from sailforce.export_c import calibration_header, comment_text
from sailforce.io.files import OutputPathError, atomic_writer

ROOT = Path(__file__).resolve().parents[1]
SAIL = Path(sys.executable).parent / "sail"
CAL_PATH = ROOT / "c" / "examples" / "calibration.json"


def _resealed(data: dict) -> dict:
    """``data`` with its checksum recomputed, as anyone can do to a calibration file."""
    data = {k: v for k, v in data.items() if k != "checksum"}
    return data | {"checksum": checksum(data)}


def _write(path: Path, data: dict) -> Path:
    path.write_text(json.dumps(data))
    return path


# -- C injection through `sail export-c` ------------------------------------------------------------------------
INJECTION = "x */ static const int injected = 1; /*"


@pytest.mark.parametrize("field", ["created", "software", "data_sha256", "units.load"])
def test_export_c_injection_is_refused_at_load(tmp_path, field):
    """A calibration whose text field closes the C comment was accepted; each such field is now refused at load."""
    data = json.loads(CAL_PATH.read_text())
    if field == "units.load":
        data["units"]["load"] = INJECTION
    else:
        data[field] = INJECTION
    path = _write(tmp_path / "cal.json", _resealed(data))
    with pytest.raises(CalibrationFileError, match=field.replace(".", r"\.")):
        Calibration.load(path)
    result = subprocess.run([str(SAIL), "export-c", str(path), "-o", str(tmp_path / "h.h")], capture_output=True, text=True)
    assert result.returncode == 1 and field in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "h.h").exists()


def test_export_c_injection_is_escaped_in_the_header(tmp_path):
    """A Calibration made in Python (never loaded) with hostile text still gives a header that declares nothing extra."""
    cal = Calibration.load(CAL_PATH)
    hostile = replace(cal, created=INJECTION, software=INJECTION, data_sha256=INJECTION, load_unit=INJECTION)
    header = calibration_header(hostile, "sail_cal", source="in */ int also_injected; /*.json")
    (tmp_path / "h.h").write_text(header)
    comment_end = header.index("*/")
    assert "injected" not in header[comment_end:]  # the only */ is the one that ends the comment
    (tmp_path / "probe.c").write_text('#include "h.h"\nint main(void) { return injected + also_injected; }\n')
    compiled = subprocess.run(["cc", "-std=c99", f"-I{ROOT / 'c' / 'include'}", f"-I{tmp_path}", "-c", "probe.c", "-o", "probe.o"],
                              cwd=tmp_path, capture_output=True, text=True)  # fmt: skip
    assert compiled.returncode != 0 and "injected" in compiled.stderr  # undeclared: the comment held it
    (tmp_path / "ok.c").write_text('#include "h.h"\nint main(void) { return (int)sail_cal.l2; }\n')
    assert subprocess.run(["cc", "-std=c99", f"-I{ROOT / 'c' / 'include'}", "-c", "ok.c", "-o", "ok.o"], cwd=tmp_path).returncode == 0


def test_comment_text_keeps_ordinary_text():
    assert comment_text("sailforce 0.1.0 (dev)") == "sailforce 0.1.0 (dev)"
    assert comment_text("2026-12-01T20:17:26+00:00") == "2026-12-01T20:17:26+00:00"
    assert "*/" not in comment_text("*/") and "\n" not in comment_text("a\nb")


def test_schema_patterns_are_the_loaders():
    """calibration.schema.json states the same text rules that loading enforces."""
    from importlib.resources import files

    schema = json.loads(files("sailforce.calibration").joinpath("calibration.schema.json").read_text())
    props = schema["properties"]
    where = {"created": props["created"], "software": props["software"], "data_sha256": props["data_sha256"],
             "units.load": props["units"]["properties"]["load"]}  # fmt: skip
    for name, (pattern, _) in TEXT_FIELDS.items():
        assert where[name]["pattern"] == "^" + pattern.pattern.replace("\\Z", "$")


# -- Loading a calibration does not bound its numbers ------------------------------------------------------------
@pytest.mark.parametrize("edit, message", [
    (lambda d: d["model"].__setitem__("coefficients", (np.asarray(d["model"]["coefficients"]) * 1e-300).tolist()),
     "not invertible|full cell"),
    (lambda d: d["model"].__setitem__("coefficients", (np.asarray(d["model"]["coefficients"]) * 1e300).tolist()), "full cell"),
    (lambda d: d.__setitem__("capacity", [1e308, 1e308]), "within"),
    (lambda d: d.__setitem__("load_range", [[5.0, -5.0], [0.0, 1.0]]), "min <= max"),
    (lambda d: d.__setitem__("schema_version", True), "schema_version"),
    (lambda d: d.__setitem__("offsets", [1e300, 0.0]), "within"),
])  # fmt: skip
def test_calibration_numbers_are_bounded_at_load(tmp_path, edit, message):
    """An amplitude of 1e-300, a capacity of 1e308, a reversed load range and schema_version = true were all accepted."""
    data = json.loads(CAL_PATH.read_text())
    edit(data)
    with pytest.raises(CalibrationFileError, match=message):
        Calibration.load(_write(tmp_path / "cal.json", _resealed(data)))


def test_the_shipped_calibrations_still_load():
    assert Calibration.load(CAL_PATH).kind == "matrix"


# -- Outputs replace device nodes, FIFOs and symlink targets -----------------------------------------------------
def test_outputs_never_replace_a_device_node(tmp_path):
    """`sail tare ... -o dev/null`, dev/null a character device, exited 0 and left a regular file in its place."""
    device = tmp_path / "null"
    try:
        os.mknod(device, 0o666 | 0o020000, os.makedev(1, 3))
    except PermissionError:
        os.symlink("/dev/null", device)  # not root: a link to the real one tests the same refusal
    before = os.stat(device).st_rdev
    with pytest.raises(OutputPathError, match="character device"), atomic_writer(device) as stream:
        stream.write("x")
    assert os.stat(device).st_rdev == before and not list(tmp_path.glob(".*.tmp"))
    noload = tmp_path / "n.csv"
    noload.write_text("load1,load2\n" + "".join(f"{-42809 + i % 3},{76765 - i % 2}\n" for i in range(40)))
    result = subprocess.run([str(SAIL), "tare", str(CAL_PATH), str(noload), "-o", str(device)], capture_output=True, text=True)
    assert result.returncode == 1 and "character device" in result.stderr and "Traceback" not in result.stderr
    assert not os.path.isfile(device) and os.stat(device).st_rdev == before


def test_outputs_never_replace_a_fifo_or_a_folder(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(OutputPathError, match="FIFO"), atomic_writer(fifo) as stream:
        stream.write("x")
    folder = tmp_path / "folder"
    folder.mkdir()
    os.symlink(folder, tmp_path / "to-folder")
    with pytest.raises(OutputPathError, match="folder"), atomic_writer(tmp_path / "to-folder") as stream:
        stream.write("x")
    assert fifo.is_fifo() and folder.is_dir()


def test_symlinked_output_replaces_its_regular_target_and_stays_a_link(tmp_path):
    """The documented meaning of a symlinked output: the link stays, its regular target gets the new content."""
    (tmp_path / "real.txt").write_text("old\n")
    os.symlink("real.txt", tmp_path / "link.txt")
    with atomic_writer(tmp_path / "link.txt") as stream:
        stream.write("new\n")
    assert (tmp_path / "link.txt").is_symlink() and (tmp_path / "real.txt").read_text() == "new\n"


# -- The solid cache is trusted and followed ---------------------------------------------------------------------
def _fake_solver(task):
    """A pose's result without CalculiX: the pin-joint torques J^T, and deflections proportional to them."""
    from sailforce.kinematics import jacobian

    torques = np.swapaxes(jacobian(Arm(), task.theta1, task.theta2), -1, -2)
    return {"theta1": task.theta1, "theta2": task.theta2, "torques": torques.tolist(), "deflection": (1e-6 * torques).tolist(),
            "relative": (1e-6 * torques).tolist(), "moment_balance": [0.0, 0.0], "dofs": 1234}  # fmt: skip


def _seeded_cache(directory, settings, depth=0.01):
    """A cache holding the cell's calibrated depth, so that no test needs CalculiX."""
    from sailforce.io.robotfile import robot_data
    from sailforce.robot import Robot
    from sailforce.solid.cache import SolidCache
    from sailforce.solid.sweep import MODEL_VERSION

    data = robot_data(Robot())
    inputs = {"kind": "cell", "version": MODEL_VERSION, "cell": [data["loadcells"], data["materials"]["loadcells"]],
              "settings": settings.as_dict()}  # fmt: skip
    SolidCache(directory).write(inputs, {"depth": depth, "achieved": 1e-4, "target": 1e-4, "solves": 2})
    return inputs


POSES = [(float(np.radians(60.0)), float(np.radians(20.0))), (float(np.radians(90.0)), 0.0)]


def _sweep(directory, calls):
    from sailforce.robot import Robot
    from sailforce.solid.sweep import SolidSettings, run_poses

    def solver(task):
        calls.append((task.theta1, task.theta2))
        return _fake_solver(task)

    return run_poses(Robot(), POSES, SolidSettings(0.004), cache_dir=directory, solver=solver)


def _entries(directory):
    return sorted(p for p in directory.glob("*.json") if json.loads(p.read_text())["inputs"]["kind"] == "pose")


def test_solid_cache_entries_are_checked_doubled_torques_and_swapped_poses(tmp_path):
    """Plain JSON entries were used as they were: doubled torques, a swapped pose and a tripled depth went unnoticed."""
    from sailforce.solid.sweep import SolidSettings

    _seeded_cache(tmp_path, SolidSettings(0.004))
    calls: list = []
    first = _sweep(tmp_path, calls)
    assert len(calls) == 2 and first.cached == 0 and not first.notes
    assert _sweep(tmp_path, calls).cached == 2 and len(calls) == 2
    a, b = _entries(tmp_path)
    doubled = json.loads(a.read_text())
    doubled["value"]["torques"] = (2 * np.asarray(doubled["value"]["torques"])).tolist()  # checksum left as it was
    a.write_text(json.dumps(doubled))
    resealed = json.loads(b.read_text())
    resealed["value"]["theta1"], resealed["value"]["theta2"] = resealed["value"]["theta2"], resealed["value"]["theta1"]
    from sailforce.solid.cache import _canonical

    resealed.pop("sha256")
    resealed["sha256"] = __import__("hashlib").sha256(_canonical(resealed)).hexdigest()  # a careful forger
    b.write_text(json.dumps(resealed))
    calls.clear()
    again = _sweep(tmp_path, calls)
    assert len(calls) == 2 and again.cached == 0
    assert any("checksum" in n for n in again.notes) and any("pose" in n for n in again.notes)
    for got, want in zip(again.responses, first.responses):
        np.testing.assert_array_equal(got.torques, want.torques)


def test_solid_cache_refuses_an_entry_for_another_request(tmp_path):
    """An entry copied under another entry's name (its own checksum intact) answers another request: refused."""
    from sailforce.solid.sweep import SolidSettings

    _seeded_cache(tmp_path, SolidSettings(0.004))
    _sweep(tmp_path, [])
    a, b = _entries(tmp_path)
    a.write_bytes(b.read_bytes())
    calls: list = []
    again = _sweep(tmp_path, calls)
    assert len(calls) == 1 and any("key" in n for n in again.notes)


def test_solid_cache_never_follows_or_writes_through_a_symlink(tmp_path):
    """An entry that was a symlink had its target overwritten."""
    from sailforce.solid.sweep import SolidSettings

    _seeded_cache(tmp_path, SolidSettings(0.004))
    _sweep(tmp_path, [])
    a, _ = _entries(tmp_path)
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me\n")
    a.unlink()
    os.symlink(precious, a)
    calls: list = []
    again = _sweep(tmp_path, calls)
    assert len(calls) == 1 and any("symlink" in n for n in again.notes)
    assert precious.read_text() == "keep me\n" and not a.is_symlink() and json.loads(a.read_text())["value"]["dofs"] == 1234


def test_solid_cache_with_a_negative_depth_says_it_is_the_cache(tmp_path):
    """A negative cached cell depth was reported as a mesh error, with no word about the cache."""
    from sailforce.robot import Robot
    from sailforce.solid.cache import SolidCache
    from sailforce.solid.sweep import SolidSettings, cell_depth

    inputs = _seeded_cache(tmp_path, SolidSettings(0.004), depth=-0.01)
    cache = SolidCache(tmp_path)
    assert cache.read(inputs, lambda v: v) is not None  # the entry itself is intact: its number is the problem
    from sailforce.solid import sweep

    calibrated = []
    original = sweep.calibrate_depth
    sweep.calibrate_depth = lambda cell, mesh: calibrated.append(mesh) or original.__globals__["CellDepth"](0.012, 1e-4, 1e-4, 1)
    try:
        depth = cell_depth(Robot(), SolidSettings(0.004), cache)
    finally:
        sweep.calibrate_depth = original
    assert calibrated and depth.depth == 0.012
    assert any("cache entry" in n and "positive" in n for n in cache.notes)


def test_a_read_only_solid_cache_solves_warns_and_remembers(tmp_path):
    from sailforce.solid.sweep import SolidSettings

    _seeded_cache(tmp_path, SolidSettings(0.004))
    os.chmod(tmp_path, 0o555)
    try:
        if os.access(tmp_path, os.W_OK):  # root writes anywhere: make the folder unwritable another way
            os.chmod(tmp_path, 0o755)
            (tmp_path / "blocker").mkdir()
            for task_name in (f"{k}.json" for k in _pose_keys()):
                (tmp_path / task_name).mkdir()  # a folder where the entry would go cannot be replaced by a file
        calls: list = []
        first = _sweep(tmp_path, calls)
        assert len(calls) == 2 and any("cannot be written" in n and "memory" in n for n in first.notes)
        again = _sweep(tmp_path, calls)
        assert len(calls) == 2 and again.cached == 2  # kept in memory for this process
    finally:
        os.chmod(tmp_path, 0o755)


def _pose_keys():
    from sailforce.io.robotfile import robot_data
    from sailforce.robot import Robot
    from sailforce.solid.sweep import PoseTask, SolidSettings

    return [PoseTask(robot_data(Robot()), a, b, SolidSettings(0.004), 0.01).key for a, b in POSES]


# -- Ctrl-C drops a row ------------------------------------------------------------------------------------------
def _dynamic_calibration(cals) -> Path:
    d, _, _ = cals
    return d / "dynamic.json"


@pytest.mark.parametrize("after_rows", [120, 3000, 20_000])
def test_ctrl_c_with_a_dynamic_term_keeps_every_row(cals, tmp_path, after_rows):
    """`gen | sail estimate --calibration dynamic.json - -o x.csv`, then SIGINT: the row half a window (50 rows)
    before the last was lost in 4 runs of 4.  Every row read must come out, in order, with none missing."""
    import signal
    import threading
    import time

    cal = Calibration.load(_dynamic_calibration(cals))
    o1, o2 = cal.offsets
    rows = [f"{0.001 * k:.3f},{60 + 10 * np.sin(k / 500):.6f},{10 * np.cos(k / 700):.6f},{o1 + 900:.0f},{o2 - 400:.0f}\n"
            for k in range(200_000)]  # fmt: skip
    process = subprocess.Popen([str(SAIL), "estimate", "--calibration", str(_dynamic_calibration(cals)), "-", "-o", "x.csv", "-q"],
                               cwd=tmp_path, stdin=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip

    def feed():  # 20,000 rows a second, as a fast device would send them: the stream lasts 10 s
        try:
            process.stdin.write(b"t_s,theta1_deg,theta2_deg,load1,load2\n")
            for start in range(0, len(rows), 100):
                process.stdin.write("".join(rows[start : start + 100]).encode())
                process.stdin.flush()
                time.sleep(0.005)
        except (BrokenPipeError, ValueError, OSError):
            pass

    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and process.poll() is None:
        written = list(tmp_path.glob(".x.csv.*.tmp"))
        if written and written[0].read_bytes().count(b"\n") >= after_rows:
            break
        time.sleep(0.002)
    assert process.poll() is None, "the estimate ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    process.wait(timeout=60)
    stderr = process.stderr.read()
    writer.join(timeout=10)
    assert process.returncode == 130 and b"Traceback" not in stderr, stderr
    lines = (tmp_path / "x.csv").read_text().splitlines()
    assert len(lines) > after_rows, "too few rows to test the half window"
    t = np.array([float(line.split(",", 1)[0]) for line in lines[1:]])
    np.testing.assert_array_equal(np.rint(t * 1000).astype(int), np.arange(t.size))  # a contiguous prefix: no row lost


# -- `sail reproduce --robot FILE` silently replaces the file's joints; the reading is not in the robot file --------
PER_JOINT_ROBOT = """[links]
l1 = 0.2
l2 = 0.3
l3 = 0.45
l4 = 0.3

[loadcells]
reading = "bridge"

[joints]
model = "bonded"

[joints.P1]
model = "spring"
stiffness = 170
"""


def _study_inputs(tmp_path, monkeypatch, *args):
    """What `sail reproduce` hands the study (its robot and reading), and the command's output."""
    from click.testing import CliRunner

    from sailforce.cli import cli
    from sailforce.errors import SailError
    from sailforce.workflows import _reproduce

    seen = {}

    def study(robot, transduction, **kwargs):
        seen.update(robot=robot, transduction=transduction)
        raise SailError("stopped after the study's inputs")

    monkeypatch.setattr(_reproduce, "run_study", study)
    (tmp_path / "robot.toml").write_text(PER_JOINT_ROBOT)
    result = CliRunner().invoke(cli, ["reproduce", "-o", str(tmp_path / "out"), "--robot", str(tmp_path / "robot.toml"),
                                      "--no-seed-model", *args])  # fmt: skip
    assert result.exit_code == 1 and "stopped after" in result.output, result.output
    return seen, result.output


def test_reproduce_keeps_the_robot_files_joints_and_reading(tmp_path, monkeypatch):
    """--joints defaulted to bonded and always applied, dropping the file's per-joint P1 spring."""
    seen, output = _study_inputs(tmp_path, monkeypatch)
    joints = seen["robot"].joints
    assert joints.at("P1").model == "spring" and joints.at("P1").stiffness == 170 and joints.at("P2").model == "bonded"
    assert seen["transduction"] == "bridge" and "overrides" not in output


def test_reproduce_says_when_its_options_override_the_robot_file(tmp_path, monkeypatch):
    seen, output = _study_inputs(tmp_path, monkeypatch, "--joints", "pin", "--transduction", "deflection")
    assert seen["robot"].joints.label == "pin" and seen["transduction"] == "deflection"
    assert "--joints pin overrides the robot file's joints (P1 spring 170, P2 bonded, P3 bonded)" in output
    assert "--transduction deflection overrides the robot file's reading = 'bridge'" in output


def test_reproduce_without_a_robot_file_is_as_before(monkeypatch):
    from rich.console import Console

    from sailforce.cli._options import robot_with_joints

    robot = robot_with_joints(None, None, "bonded", Console())
    assert robot.joints.label == "bonded" and robot.loadcell.reading == ""


def test_the_reading_is_a_robot_file_key_that_round_trips(tmp_path):
    from sailforce.io.robotfile import load_robot_file, robot_data, robot_from_data, template

    (tmp_path / "robot.toml").write_text(PER_JOINT_ROBOT)
    robot = load_robot_file(tmp_path / "robot.toml").robot
    assert robot.loadcell.reading == "bridge"
    (tmp_path / "again.toml").write_text(template(robot))
    assert load_robot_file(tmp_path / "again.toml").robot == robot
    assert robot_from_data(robot_data(robot)) == robot
    (tmp_path / "bad.toml").write_text(PER_JOINT_ROBOT.replace('"bridge"', '"strain"'))
    from sailforce.errors import RobotFileError

    with pytest.raises(RobotFileError, match="reading"):
        load_robot_file(tmp_path / "bad.toml")


def test_identify_writes_the_reading_it_fitted_under(tmp_path):
    """identified.toml did not say that it was fitted under the bridge reading; every later command assumed its own."""
    from click.testing import CliRunner

    from sailforce.cli import cli
    from sailforce.io.robotfile import load_robot_file

    result = CliRunner().invoke(cli, ["identify", "--table4", "seed", "--free", "loadcells.position", "--transduction", "bridge",
                                      "--starts", "0", "-q", "-o", str(tmp_path / "id")])  # fmt: skip
    assert result.exit_code == 0, result.output
    assert load_robot_file(tmp_path / "id" / "identified.toml").robot.loadcell.reading == "bridge"


def test_live_refuses_a_calibration_of_another_arm(cals, tmp_path):
    """`sail live --simulate --robot OTHER` gave 7x the error without a word."""
    from click.testing import CliRunner

    from sailforce.cli import cli

    d, _, _ = cals
    (tmp_path / "other.toml").write_text("[links]\nl1 = 0.25\nl2 = 0.3\nl3 = 0.5\nl4 = 0.3\n")
    result = CliRunner().invoke(cli, ["live", "--calibration", str(d / "static.json"), "--simulate", "--robot",
                                      str(tmp_path / "other.toml"), "--port", "0"])  # fmt: skip
    assert result.exit_code == 2 and "another arm" in result.output and "l1 = 0.25" in result.output


# -- t_s in milliseconds; an angle that wraps -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def task_session(tmp_path_factory):
    """A 4-reach task session of simulated rig 1 (the rig the `cals` calibrations are of), and its truth."""
    import pandas as pd

    d = tmp_path_factory.mktemp("task")
    result = subprocess.run([str(SAIL), "simulate-motion", "--session", "task", "--rig", "1", "--reaches", "4", "-o", "task.csv"],
                            cwd=d, capture_output=True, text=True)  # fmt: skip
    assert result.returncode == 0, result.stderr
    return d, pd.read_csv(d / "task.csv")


def _estimate(cal_path, table, tmp_path, name):
    import pandas as pd

    table.to_csv(tmp_path / f"{name}.csv", index=False, float_format="%.9g")
    result = subprocess.run([str(SAIL), "estimate", "--calibration", str(cal_path), f"{name}.csv", "-o", f"{name}.out.csv"],
                            cwd=tmp_path, capture_output=True, text=True)  # fmt: skip
    return result, (pd.read_csv(tmp_path / f"{name}.out.csv") if result.returncode == 0 else None)


def test_t_s_in_milliseconds_is_refused_naming_the_unit(cals, task_session, tmp_path):
    """With t_s x 1000, 2,096 of 2,100 rows came out ok at 1.89 N RMS instead of 0.061 N, with no warning."""
    d, _, _ = cals
    _, table = task_session
    result, _ = _estimate(d / "dynamic.json", table.assign(t_s=table.t_s * 1000), tmp_path, "ms")
    assert result.returncode == 1 and "milliseconds" in result.stderr and "Traceback" not in result.stderr
    assert len([line for line in result.stderr.splitlines() if line.strip()]) == 1
    assert not (tmp_path / "ms.out.csv").exists()
    seconds, out = _estimate(d / "dynamic.json", table, tmp_path, "s")
    assert seconds.returncode == 0 and (out.status == "ok").mean() > 0.9


def test_t_s_in_milliseconds_on_a_stream_ends_it_with_the_unit(cals, task_session, tmp_path):
    d, _, _ = cals
    _, table = task_session
    text = table.assign(t_s=table.t_s * 1000).to_csv(index=False, float_format="%.9g")
    result = subprocess.run([str(SAIL), "estimate", "--calibration", str(d / "dynamic.json"), "-", "-o", "x.csv"], cwd=tmp_path,
                            input=text, capture_output=True, text=True)  # fmt: skip
    assert result.returncode == 1 and "milliseconds" in result.stderr and "Traceback" not in result.stderr


def test_an_angle_that_wraps_is_unwrapped_before_differentiating(cals, task_session, tmp_path):
    """theta2 written as mod(theta2, 360) across 0 gave 50 ok rows with errors up to 5,120 N where the force was 17 N."""
    d, _, _ = cals
    _, table = task_session
    assert (table.theta2_deg < 0).any() and (table.theta2_deg > 0).any()  # the session crosses 0
    _, plain = _estimate(d / "dynamic.json", table, tmp_path, "plain")
    result, wrapped = _estimate(d / "dynamic.json", table.assign(theta2_deg=np.mod(table.theta2_deg, 360)), tmp_path, "wrapped")
    assert result.returncode == 0, result.stderr
    ok = wrapped.status == "ok"
    assert ok.sum() > 1000 and (plain.status[ok] == "ok").all()  # rows at theta2 < 0 read delta < -180 deg: extrapolated
    # 1e-4 N: at %.9g a wrapped angle near 360 deg keeps 6 decimals where the plain one near 0 kept 11 (measured 2e-6 N)
    np.testing.assert_allclose(wrapped.fx_N[ok], plain.fx_N[ok], rtol=0, atol=1e-4)
    np.testing.assert_allclose(wrapped.fy_N[ok], plain.fy_N[ok], rtol=0, atol=1e-4)
    error = np.hypot(wrapped.fx_N - table.true_fx_N, wrapped.fy_N - table.true_fy_N)[ok]
    assert error.max() < 2.0  # newtons, not kilonewtons


def test_an_unwrapped_stream_gives_the_files_numbers(cals, task_session, tmp_path):
    """File and stream unwrap alike (the carry between blocks): the same bytes."""
    d, _, _ = cals
    _, table = task_session
    wrapped = table.assign(theta2_deg=np.mod(table.theta2_deg, 360))
    _estimate(d / "dynamic.json", wrapped, tmp_path, "file")
    text = (tmp_path / "file.csv").read_text()
    result = subprocess.run([str(SAIL), "estimate", "--calibration", str(d / "dynamic.json"), "-", "-o", "stream.csv"],
                            cwd=tmp_path, input=text, capture_output=True, text=True)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "stream.csv").read_bytes() == (tmp_path / "file.out.csv").read_bytes()


def test_a_rate_no_arm_reaches_is_never_ok(cals, tmp_path):
    """theta1 spun at 60 rad/s for 0.3 s (no arm a hand holds turns so): those rows' motion is unknown, the rest ok;
    measured rates beyond reach likewise."""
    import pandas as pd

    from sailforce.motion.differentiate import MAX_JOINT_RATE

    d, static, _ = cals
    t = np.arange(3000) * 1e-3
    spin = (t > 1.2) & (t < 1.5)
    rate = np.where(spin, 60.0, 0.0)
    theta1 = np.radians(80.0) + np.cumsum(rate) * 1e-3
    table = pd.DataFrame({"t_s": t, "theta1_deg": np.degrees(theta1), "theta2_deg": 10.0,
                          "load1": static.offsets[0], "load2": static.offsets[1]})  # fmt: skip
    _, out = _estimate(d / "dynamic.json", table, tmp_path, "spin")
    assert 60.0 > MAX_JOINT_RATE and (out.status[spin] != "ok").all() and (out.status[spin] == "motion-unknown").mean() > 0.5
    assert (out.status[(t > 0.2) & (t < 1.0)] == "ok").all()
    measured = table.assign(omega1_dps=np.where(spin, np.degrees(60.0), 0.0), omega2_dps=0.0, alpha1_dps2=0.0, alpha2_dps2=0.0)
    _, out = _estimate(d / "dynamic.json", measured, tmp_path, "measured")
    assert (out.status[spin] != "ok").all() and (out.status[(t > 0.2) & (t < 1.0)] == "ok").all()


def test_unwrapped_gives_one_pass_numbers_in_blocks():
    from sailforce.motion.differentiate import unwrapped

    rng = np.random.default_rng(3)
    q = np.cumsum(rng.normal(0, 0.3, (500, 2)), axis=0)
    q[100, 1] = np.nan
    wrapped = np.mod(q + np.pi, 2 * np.pi) - np.pi
    whole, _ = unwrapped(wrapped)
    steps = np.diff(whole, axis=0)
    assert np.nanmax(np.abs(steps)) < np.pi
    parts, carry = [], None
    for block in np.array_split(wrapped, 7):
        part, carry = unwrapped(block, carry)
        parts.append(part)
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    same, _ = unwrapped(q[:50])
    assert same is not None and np.shares_memory(same, q) or np.array_equal(same, q[:50])


# -- A full disk kills the live stream ------------------------------------------------------------------------------
class _FillsUp:
    """A file that takes ``budget`` bytes and then fails as a full disk does: part of the block written, then ENOSPC."""

    def __init__(self, real, budget):
        self.real, self.budget = real, budget

    def write(self, data):
        import errno

        if len(data) > self.budget:
            self.real.write(data[: self.budget])  # a row cut mid-line, as a full disk leaves it
            self.real.flush()
            self.budget = 0
            raise OSError(errno.ENOSPC, "No space left on device")
        self.budget -= len(data)
        return self.real.write(data)

    def __getattr__(self, name):
        return getattr(self.real, name)


def test_a_full_disk_stops_the_recording_not_the_stream(cals, tmp_path):
    """With the record folder full, pressing record ended the estimate itself, and the last row was cut mid-line."""
    from sailforce.live.pipeline import LivePipeline
    from sailforce.live.recorder import Recorder
    from sailforce.live.sources import simulated_arm
    from sailforce.robot import Robot

    _, static, _ = cals
    pipeline = LivePipeline(static, simulated_arm(Robot(), rig=1), source="simulated arm")
    seen = []
    pipeline.listen(lambda rows: seen.append(len(rows.status)))
    pipeline.start()
    try:
        import time

        deadline = time.monotonic() + 30
        while pipeline.output.header is None and time.monotonic() < deadline:
            time.sleep(0.01)
        recorder = Recorder(tmp_path, pipeline.output.header)
        recorder._file = _FillsUp(recorder._file, 20_000)
        with pipeline.output.lock:
            pipeline.output.recorder = recorder
        while pipeline.output.failed is None and time.monotonic() < deadline:
            time.sleep(0.01)
        before = pipeline.rows
        time.sleep(0.5)
        assert pipeline.rows > before + 100 and pipeline.error is None and not pipeline.ended.is_set()  # the stream goes on
    finally:
        pipeline.stop()
    assert recorder.error is not None and "No space left" in recorder.error and pipeline.output.recorder is None
    data = recorder.path.read_bytes()
    assert data.endswith(b"\n") and data.count(b"\n") == recorder.rows + 1  # the header and whole rows, nothing cut
    assert all(line.count(b",") == data.splitlines()[0].count(b",") for line in data.splitlines())


def test_the_page_hears_of_a_failed_recording_and_can_record_again(cals, tmp_path):
    import asyncio
    import time

    from tests.test_live_security import _serve

    _, static, _ = cals

    async def check(client, server):
        good = {"X-Sail-Token": server.token}
        deadline = time.monotonic() + 30
        while server.pipeline.output.header is None and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        started = await (await client.post("/api/record", json={"on": True}, headers=good)).json()
        assert started["ok"]
        server.recorder._file = _FillsUp(server.recorder._file, 5_000)
        ws = await client.ws_connect("/ws")
        while time.monotonic() < deadline:
            message = await ws.receive_json(timeout=30)
            if message["type"] == "update" and message.get("recording_failed"):
                break
        failed = message["recording_failed"]
        assert "No space left" in failed["error"] and failed["file"] == started["recording"]["file"]
        assert message["recording"] is None and server.pipeline.rows > 0
        again = await (await client.post("/api/record", json={"on": True}, headers=good)).json()
        assert again["ok"] and again["recording"]["file"] != failed["file"]
        await client.post("/api/record", json={"on": False}, headers=good)
        await ws.close()

    _serve(static, tmp_path, check)


# -- An interrupted `sail design` leaves a new design.json beside an old report --------------------------------------
def test_design_writes_its_outputs_as_one_set(tmp_path, monkeypatch):
    """An interrupted sweep left a new design.json and sweep.csv beside the old report.md of another sweep."""
    from click.testing import CliRunner

    from sailforce.cli import cli
    from sailforce.report import design_report

    out = tmp_path / "design"
    swept = CliRunner().invoke(cli, ["design", "-o", str(out), "--grid", "8", "--sweep", "loadcells.position=0.3,0.6", "-q"])
    assert swept.exit_code == 0, swept.output
    first = {p.name: p.read_bytes() for p in out.iterdir()}
    assert {"sweep.csv", "report.md", "design.json"} <= set(first)

    def interrupted(directory, *args, **kwargs):
        (directory / "design.json").write_text("{}")  # part of the new set written, then Ctrl-C
        raise KeyboardInterrupt

    monkeypatch.setattr(design_report, "write_design", interrupted)
    stopped = CliRunner().invoke(cli, ["design", "-o", str(out), "--grid", "6", "-q"])
    assert stopped.exit_code != 0
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first  # the previous set, whole, and no staging folder
    monkeypatch.undo()
    plain = CliRunner().invoke(cli, ["design", "-o", str(out), "--grid", "6", "-q"])
    assert plain.exit_code == 0, plain.output
    names = {p.name for p in out.iterdir()}
    assert "sweep.csv" not in names and "pareto.png" not in names and {"report.md", "design.json"} <= names
    assert "Sweep" not in (out / "report.md").read_text()


def test_a_garbage_line_in_a_parquet_recording_keeps_the_csv_and_says_so(tmp_path):
    """One line with a stray field made the Parquet conversion raise ArrowInvalid: the page never got an answer."""
    from sailforce.errors import SailError
    from sailforce.live.recorder import Recorder

    recorder = Recorder(tmp_path, b"t_s,theta1_deg,theta2_deg,load1,load2,status\n", "parquet")
    recorder.write(b"0.001,80,10,1,2,ok\n0.002,80,10,1,2,extra,invalid\n0.003,80,10,1,2,ok\n")
    with pytest.raises(SailError, match="could not be converted to Parquet.*the CSV is kept"):
        recorder.stop()
    assert recorder.path.suffix == ".csv" and recorder.path.read_bytes().count(b"\n") == 4
    assert not list(tmp_path.glob("*.parquet"))


# -- Joining a serial stream that is already running -----------------------------------------------------------------
def _serial_session(tmp_path, before: bytes, after: bytes, *extra):
    """`sail estimate --serial PTY` reading ``before`` then ``after`` from a device on a pseudo-terminal; the hang-up ends it."""
    import time
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    process = subprocess.Popen([str(SAIL), "estimate", "--calibration", str(CAL_PATH), "--serial", os.ttyname(slave),
                                "-o", "out.csv", *extra], cwd=tmp_path, stderr=subprocess.PIPE, text=True)  # fmt: skip
    name, deadline = os.ttyname(slave), time.monotonic() + 30  # the port is open (and flushed) before the device's
    while time.monotonic() < deadline and process.poll() is None:  # lines come, however slowly sail starts: it joins
        try:
            opened = [os.path.realpath(f"/proc/{process.pid}/fd/{fd}") for fd in os.listdir(f"/proc/{process.pid}/fd")]
        except OSError:  # a descriptor closed while it was listed
            opened = []
        if name in opened:
            break
        time.sleep(0.05)
    time.sleep(0.5)  # past the flush that follows the open
    os.write(master, before)
    time.sleep(0.3)
    os.write(master, after)
    time.sleep(1.0)
    os.close(slave)
    os.close(master)  # the device hangs up
    _, stderr = process.communicate(timeout=30)
    return process.returncode, stderr, (tmp_path / "out.csv").read_text().splitlines() if (tmp_path / "out.csv").exists() else []


def test_joining_a_running_serial_stream_waits_for_the_next_header(tmp_path):
    """A device that streams without resetting never repeats its header: 'the header line cannot be read as CSV'."""
    cal = Calibration.load(CAL_PATH)
    row = f"80,10,{cal.offsets[0]:.0f},{cal.offsets[1]:.0f}\n".encode()
    header = b"theta1_deg,theta2_deg,load1,load2\n"
    code, stderr, lines = _serial_session(tmp_path, b"0,12,3\n" + row * 5, header + row * 7)
    assert code == 0, stderr
    assert "already streaming" in stderr and "skipped 6 lines" in stderr
    assert lines[0].startswith("theta1_deg,theta2_deg,load1,load2,") and len(lines) == 8


def test_a_serial_device_without_a_header_is_read_with_columns(tmp_path):
    cal = Calibration.load(CAL_PATH)
    row = f"80,10,{cal.offsets[0]:.0f},{cal.offsets[1]:.0f}\n".encode()
    code, stderr, lines = _serial_session(tmp_path, row * 4, row * 3, "--columns", "theta1_deg,theta2_deg,load1,load2")
    assert code == 0, stderr
    assert len(lines) == 8 and all(line.endswith(",ok") for line in lines[1:])


# -- LOW: reasons in the summary, duplicated --sweep keys, absurd robot values, long --name -------------------------
def test_the_summary_says_why_rows_are_motion_unknown_or_extrapolated(cals, task_session, tmp_path):
    d, _, _ = cals
    _, table = task_session
    result, _ = _estimate(d / "dynamic.json", table, tmp_path, "why")
    assert result.returncode == 0 and "motion-unknown: within 50 ms (half the rate window) of the start" in result.stderr
    static = table.drop(columns="t_s").assign(theta2_deg=np.where(table.index < 50, table.theta1_deg - 8.0, table.theta2_deg))
    result, out = _estimate(d / "static.json", static, tmp_path, "static")
    assert result.returncode == 0 and (out.status == "extrapolated").sum() == 50
    assert "extrapolated: delta = theta1 - theta2 outside the calibrated" in result.stderr and "motion-unknown:" not in result.stderr


def test_a_duplicated_sweep_key_is_refused():
    from click.testing import CliRunner

    from sailforce.cli import cli

    result = CliRunner().invoke(cli, ["design", "-o", "unused", "--grid", "4", "--sweep", "loadcells.position=0.3,0.6",
                                      "--sweep", "loadcells.position=0.4"])  # fmt: skip
    assert result.exit_code != 0 and "given twice" in result.output and not Path("unused").exists()


def test_absurd_robot_values_are_warned_about(tmp_path):
    (tmp_path / "r.toml").write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[sections]\ndepth = 1e6\n[handle]\nmass = 1e300\n")
    result = subprocess.run([str(SAIL), "robot", "show", "--robot", "r.toml"], cwd=tmp_path, capture_output=True, text=True)
    assert result.returncode == 0
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert len(warned) == 2 and "sections.depth = 1e+06 m" in warned[0] and "handle.mass = 1e+300 kg" in warned[1]
    from sailforce.io.robotkeys import plausibility_warnings
    from sailforce.robot import Robot

    assert plausibility_warnings(Robot()) == []


def test_a_long_export_c_name_is_refused(tmp_path):
    from sailforce.export_c import ExportError, calibration_header

    cal = Calibration.load(CAL_PATH)
    with pytest.raises(ExportError, match="10,000 characters"):
        calibration_header(cal, "a" * 10_000)
    assert "static const sail_calibration " + "b" * 48 in calibration_header(cal, "b" * 48)


# -- SIGINT while Dask workers start ---------------------------------------------------------------------------------
DASK_INTERRUPTED = """
import os, signal, sys, threading
from sailforce.cli import _terminate
from sailforce.distributed import run_tasks
signal.signal(signal.SIGTERM, _terminate)
threading.Timer(float(sys.argv[1]), lambda: os.kill(os.getpid(), signal.SIGINT)).start()
try:
    run_tasks(abs, list(range(40)), workers=2)
except KeyboardInterrupt:
    sys.exit(130)
sys.exit(3)  # finished before the interrupt
"""


@pytest.mark.parametrize("delay_s", [0.05, 0.2, 0.4, 0.6, 0.9])
def test_ctrl_c_while_dask_workers_start_exits_cleanly(delay_s):
    """Ctrl-C while the LocalCluster started its workers left a half-made cluster: Dask's atexit hook then failed with
    AssertionError: Status.init (and sometimes 'Nanny failed to start'), after the exit message."""
    result = subprocess.run([sys.executable, "-c", DASK_INTERRUPTED, str(delay_s)], capture_output=True, text=True, timeout=120)
    assert result.returncode in (130, 3), result.stderr
    assert "Traceback" not in result.stderr and "AssertionError" not in result.stderr, result.stderr


def test_held_signals_wait_for_the_section_and_act_at_once_outside_it():
    """The stream's Ctrl-C guard: inside a held section SIGINT waits for its end; outside it acts at once; the
    handlers are restored after."""
    import signal

    from sailforce._signals import HeldSignals

    before = signal.getsignal(signal.SIGINT)
    done = []
    with pytest.raises(KeyboardInterrupt):
        with HeldSignals() as signals:
            with signals.held():
                signal.raise_signal(signal.SIGINT)
                done.append("the section ran on")
            done.append("not reached")
    assert done == ["the section ran on"]
    with pytest.raises(KeyboardInterrupt):
        with HeldSignals():
            signal.raise_signal(signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is before
