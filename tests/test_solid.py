"""The gmsh + CalculiX solid model: physics, the frame comparison, the cache, the CLI, and a real Dask cluster.

Coarse meshes keep this file to about a minute; the 2 mm runs are in `make bench` and the README.
"""

from __future__ import annotations

import json
import math
import os
import signal
import threading

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce import Arm
from sailforce.cli import cli
from sailforce.distributed import run_tasks
from sailforce.io.robotfile import load_robot_file, robot_data
from sailforce.kinematics import forward
from sailforce.robot import Robot
from sailforce.solid import SolverError, calibrate_depth, fit_compliance, solve_pose, with_compliance
from sailforce.solid.cell import DEPTH_RTOL, cantilever_flexibility
from sailforce.solid.compare import compare
from sailforce.solid.sweep import PoseTask, SolidSettings, run_poses, solve_task
from tests.dask_cluster import local_cluster

pytest.importorskip("gmsh")

COARSE = 0.008  #: [m] element size for most tests: a pose in about a second
FINER = 0.006  #: the other half of the convergence pair
POSE = (math.radians(60.0), math.radians(20.0))
#: The pin solid's torques equal J^T F to this: ccx prints 7 significant digits per node.
PIN_RTOL = 1e-5


@pytest.fixture(scope="module")
def depth():
    return calibrate_depth(Robot().loadcell, COARSE)


@pytest.fixture(scope="module")
def pin(depth):
    return solve_pose(Robot().with_joints("pin"), *POSE, cell_depth=depth.depth, mesh_size=COARSE)


@pytest.fixture(scope="module")
def bonded(depth):
    return solve_pose(Robot().with_joints("bonded"), *POSE, cell_depth=depth.depth, mesh_size=COARSE)


def test_pin_joint_torques_are_jt_f(pin):
    """With ideal pins the arm is statically determinate: T = J^T F exactly (seed Eq. 3), whatever the stiffness."""
    jt = Arm().jacobian(*POSE).T
    np.testing.assert_allclose(pin.torques, jt, rtol=0, atol=PIN_RTOL * np.abs(jt).max())


@pytest.mark.parametrize("response", ["pin", "bonded"])
def test_the_motors_hold_the_moment_of_the_force_about_b(response, request):
    """Equilibrium of the whole arm about B: T1 + T2 = A x F for each unit load, A from the kinematics (seed Eq. 1)."""
    solid = request.getfixturevalue(response)
    x, y = forward(Arm(), *POSE)
    moment = np.array([-float(y), float(x)])  # A x (1, 0), A x (0, 1)
    np.testing.assert_allclose(solid.torques.sum(axis=0), moment, rtol=0, atol=1e-6 * abs(moment).max())
    assert solid.moment_balance.max() < 1e-6 * abs(moment).max()


def test_the_calibrated_cell_reproduces_its_rated_deflection(depth):
    """The depth found gives the datasheet deflection; and it is the Timoshenko beam's depth within a few per cent
    (a 7:1 block: plane-stress end effects only), growing as the cube root of the stiffness asked for."""
    cell = Robot().loadcell
    assert abs(depth.achieved / cell.rated_deflection - 1) < DEPTH_RTOL
    beam = np.cbrt(12 * cell.bending_rigidity / (cell.material.E * cell.block.thickness))
    assert depth.depth == pytest.approx(beam, rel=0.05)
    from dataclasses import replace

    stiffer = calibrate_depth(replace(cell, rated_deflection=cell.rated_deflection / 2), COARSE)
    assert stiffer.depth / depth.depth == pytest.approx(2 ** (1 / 3), rel=0.02)


def test_a_coarse_pair_of_meshes_agrees(pin, depth):
    """Refining 8 mm -> 6 mm moves the torques by < 1e-5 (pin: statics) and the cell deflections by < 0.5 %."""
    finer_depth = calibrate_depth(Robot().loadcell, FINER)
    finer = solve_pose(Robot().with_joints("pin"), *POSE, cell_depth=finer_depth.depth, mesh_size=FINER)
    np.testing.assert_allclose(finer.torques, pin.torques, atol=1e-5 * abs(pin.torques).max())
    np.testing.assert_allclose(finer.deflection, pin.deflection, rtol=0, atol=5e-3 * abs(pin.deflection).max())


def test_bonded_torques_and_phases_follow_the_frame(bonded):
    """Bonded joints carry moment, so T differs from J^T F; the frame predicts it within 1 % and 1 deg."""
    torques = compare(Robot().with_joints("bonded"), bonded)["torques"]
    assert np.allclose(torques["ratio"], 1.0, atol=0.01), torques
    assert np.max(np.abs(torques["phase_difference_deg"])) < 1.0
    jt = Arm().jacobian(*POSE).T
    assert np.abs(bonded.torques - jt).max() > 0.05 * np.abs(jt).max()  # the moment really goes through the joints


def test_the_fitted_cell_brings_the_frame_within_two_percent(depth, pin, bonded):
    """The datasheet beam misses the solid's deflections by ~10 %; the in-situ compliance closes it to 2 %."""
    robot = Robot()
    fit = fit_compliance(robot, depth, COARSE)
    L, EI, kGA = robot.loadcell.length, robot.loadcell.bending_rigidity, robot.loadcell.shear_rigidity
    np.testing.assert_allclose(fit.datasheet, cantilever_flexibility(L, EI, kGA), rtol=1e-12)
    assert np.all(fit.compliance > fit.datasheet)  # the junctions add compliance
    fitted = with_compliance(robot, fit)
    for joints, solid in (("pin", pin), ("bonded", bonded)):
        before = compare(robot.with_joints(joints), solid)["deflection"]
        after = compare(fitted.with_joints(joints), solid)["deflection"]
        assert max(abs(r - 1) for r in before["ratio"]) > 0.05, (joints, before)
        assert max(abs(r - 1) for r in after["ratio"]) < 0.02, (joints, after)
        assert max(abs(d) for d in after["phase_difference_deg"]) < 1.0


def test_spring_joints_are_refused_by_name():
    with pytest.raises(ValueError, match="joint P1 is 'spring'"):
        solve_pose(Robot().with_joints("spring"), *POSE, cell_depth=0.005, mesh_size=COARSE)


def test_a_missing_ccx_says_what_to_install(monkeypatch, depth):
    monkeypatch.setenv("SAIL_CCX", "/nonexistent/ccx")
    with pytest.raises(SolverError, match="calculix-ccx"):
        solve_pose(Robot(), *POSE, cell_depth=depth.depth, mesh_size=COARSE)


def test_the_cache_solves_only_what_changed(tmp_path, monkeypatch):
    calls = []

    def counting(task: PoseTask) -> dict:
        calls.append(task.key)
        return solve_task(task)

    poses = [POSE, (math.radians(90.0), 0.0)]
    settings = SolidSettings(mesh_size=COARSE)
    first = run_poses(Robot(), poses, settings, cache_dir=tmp_path, solver=counting)
    again = run_poses(Robot(), poses, settings, cache_dir=tmp_path, solver=counting)
    assert len(calls) == 2 and first.cached == 0 and again.cached == 2
    for a, b in zip(first.responses, again.responses):
        np.testing.assert_array_equal(a.deflection, b.deflection)
    moved = run_poses(Robot(), [POSE, (math.radians(95.0), 0.0)], settings, cache_dir=tmp_path, solver=counting)
    assert len(calls) == 3 and moved.cached == 1
    entry = tmp_path / f"{PoseTask(robot_data(Robot()), *POSE, settings, first.depth.depth).key}.json"
    entry.write_text("{damaged")  # a damaged entry is solved again and replaced
    repaired = run_poses(Robot(), [POSE], settings, cache_dir=tmp_path, solver=counting)
    assert len(calls) == 4 and repaired.cached == 0 and json.loads(entry.read_text())["value"]["dofs"] > 0
    bonded = run_poses(Robot().with_joints("bonded"), [POSE], settings, cache_dir=tmp_path, solver=counting)
    assert len(calls) == 5 and bonded.cached == 0


def test_a_failing_pose_is_reported_not_dropped(tmp_path):
    def flaky(task: PoseTask) -> dict:
        if task.theta1 > 1.5:
            raise RuntimeError("the mesher gave up")
        return solve_task(task)

    result = run_poses(Robot(), [POSE, (math.radians(95.0), 0.0)], SolidSettings(mesh_size=COARSE), solver=flaky)
    assert result.responses[0] is not None and result.responses[1] is None
    assert result.failures == {1: "RuntimeError: the mesher gave up"} and not result.complete


def test_cli_solid_writes_readings_comparison_and_figures(tmp_path, monkeypatch):
    monkeypatch.setenv("SAIL_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "s"
    result = CliRunner().invoke(cli, ["solid", "--joints", "pin", "--mesh-mm", "8", "--dpi", "50", "-o", str(out)])
    assert result.exit_code == 0, result.output
    data = json.loads((out / "results.json").read_text())
    assert np.allclose(data["comparison"]["torques"]["ratio"], 1.0, atol=1e-5)
    header, *rows = (out / "readings.csv").read_text().splitlines()
    assert header.startswith("phi_deg,torques_1_solid") and len(rows) == 24
    assert (out / "stress.png").stat().st_size > 0 and (out / "readings.png").stat().st_size > 0


def test_cli_solid_sweep_writes_poses_and_reruns_from_the_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SAIL_CACHE_DIR", str(tmp_path / "cache"))
    poses = tmp_path / "poses.csv"
    poses.write_text("theta1_deg,theta2_deg\n60,20\n90,0\n")
    args = ["solid-sweep", "--protocol", str(poses), "--mesh-mm", "8", "-q", "-o", str(tmp_path / "w")]
    assert CliRunner().invoke(cli, args).exit_code == 0
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0 and "2 from the cache" in result.output, result.output
    table = np.genfromtxt(tmp_path / "w" / "poses.csv", delimiter=",", names=True)
    jt = Arm().jacobian(np.radians(table["theta1_deg"]), np.radians(table["theta2_deg"]))
    np.testing.assert_allclose(table["torque_1x"], jt[:, 0, 0], atol=1e-5)
    bad = CliRunner().invoke(cli, ["solid-sweep", "--protocol", str(tmp_path / "none.csv"), "-o", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "no such file" in bad.output


def test_cli_cell_fit_writes_a_robot_file_and_keeps_an_existing_one(tmp_path, monkeypatch):
    monkeypatch.setenv("SAIL_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "fitted.toml"
    result = CliRunner().invoke(cli, ["cell-fit", "--mesh-mm", "8", "--no-check", "-o", str(out)])
    assert result.exit_code == 0, result.output
    cell = load_robot_file(out).robot.loadcell
    assert cell.compliance == "matrix" and cell.compliance_vv > Robot().loadcell.flexibility[0, 0]
    before = out.read_text()
    again = CliRunner().invoke(cli, ["cell-fit", "--mesh-mm", "8", "--no-check", "-o", str(out)])
    assert again.exit_code == 2 and "--force" in again.output and out.read_text() == before


def _solve_with_pid(task: PoseTask) -> dict:
    return {**solve_task(task), "pid": os.getpid()}


def test_a_killed_worker_loses_no_pose(tmp_path):
    """A real `dask scheduler` and two `dask worker`s on 127.0.0.1; one is killed mid-sweep; every pose comes back
    once, solved, and equal to the same pose solved here."""
    with local_cluster(tmp_path) as (address, workers):  # the workers import tests.test_solid for _solve_with_pid
        depth = calibrate_depth(Robot().loadcell, COARSE).depth
        tasks = [PoseTask(robot_data(Robot()), math.radians(a), 0.0, SolidSettings(COARSE), depth) for a in range(30, 130, 15)]
        killed = threading.Event()

        def advance(amount: float) -> None:
            if not killed.is_set():
                os.killpg(workers[0].pid, signal.SIGKILL)
                killed.set()

        outcomes = run_tasks(_solve_with_pid, tasks, scheduler=address, advance=advance)
        assert killed.is_set() and workers[0].wait(timeout=10) is not None
        assert len(outcomes) == len(tasks) and all(o.ok for o in outcomes), [o.error for o in outcomes]
        assert workers[1].pid in {o.value["pid"] for o in outcomes}
        for task, outcome in zip(tasks, outcomes):
            assert outcome.value["theta1"] == task.theta1
            np.testing.assert_allclose(outcome.value["torques"], Arm().jacobian(task.theta1, 0.0).T, atol=1e-5)
        here = solve_task(tasks[-1])
        np.testing.assert_allclose(outcomes[-1].value["deflection"], here["deflection"], rtol=1e-9)


def test_reproduce_solid_adds_the_solids_table4_to_the_report(tmp_path, monkeypatch):
    monkeypatch.setenv("SAIL_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "r"
    args = ["reproduce", "-o", str(out), "--no-seed-model", "--compare-joints", "none", "--dpi", "50", "--solid",
            "--solid-mesh-mm", "8", "--joints", "pin"]  # fmt: skip
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 0, result.output
    report = (out / "report.md").read_text()
    assert "## The solid model: Table 4 from gmsh + CalculiX" in report and (out / "solid" / "table4.png").exists()
    tables = json.loads((out / "solid" / "results.json").read_text())["table4"]
    solid, frame = np.array(tables["solid"]), np.array(tables["frame"])
    np.testing.assert_array_equal(solid[:, 0], frame[:, 0])
    # pin joints: each cell reads its own torque alone, so the phase is 0 in both models (docs/errata.md, Physics)
    assert np.abs(solid[:, [2, 4]]).max() < 0.05 and np.abs(frame[:, [2, 4]]).max() < 1e-6
    np.testing.assert_allclose(solid[:, [1, 3]], frame[:, [1, 3]], rtol=0.15)
