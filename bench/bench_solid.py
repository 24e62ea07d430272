"""The solid model (issue 13): a 2-D pose at 2 mm on one core, and the seed protocol at 4 mm on one and two Dask workers."""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

from sailforce.paper.study import Protocol
from sailforce.robot import Robot
from sailforce.solid import calibrate_depth, solve_pose
from sailforce.solid.sweep import SolidSettings, run_poses, seed_poses

POSE_TARGET_S = 10.0  #: issue 13: a 2-D pose (two load cases) at 2 mm, one core
SWEEP_TARGET_S = 20 * 60.0  #: issue 13: the seed protocol at 4 mm on two workers
CACHED_TARGET_S = 10.0  #: issue 13: the same sweep again, from the cache


def run() -> list[tuple[str, str]]:
    robot = Robot().with_joints("bonded")
    depth = calibrate_depth(robot.loadcell, 0.002).depth
    start = time.perf_counter()
    response = solve_pose(robot, math.radians(75.0), 0.0, cell_depth=depth, mesh_size=0.002)
    pose_s = time.perf_counter() - start
    rows = [("2-D pose at 2 mm, two load cases, one core (target <= 10 s)",
             f"{pose_s:.1f} s, {response.dofs} DOF")]  # fmt: skip
    poses, _ = seed_poses(Protocol())
    settings = SolidSettings(mesh_size=0.004)
    seconds = {}
    with tempfile.TemporaryDirectory() as scratch:
        for workers in (1, 2):
            start = time.perf_counter()
            run_poses(robot, poses, settings, cache_dir=Path(scratch) / f"w{workers}", workers=workers)
            seconds[workers] = time.perf_counter() - start
        start = time.perf_counter()
        cached = run_poses(robot, poses, settings, cache_dir=Path(scratch) / "w2", workers=2)
        cached_s = time.perf_counter() - start
    rows += [
        (f"seed protocol, {len(poses)} poses at 4 mm, 1 worker", f"{seconds[1]:.1f} s ({seconds[1] / len(poses):.2f} s/pose)"),
        (f"seed protocol, {len(poses)} poses at 4 mm, 2 workers (target <= 20 min)", f"{seconds[2]:.1f} s"),
        ("speed-up 1 -> 2 workers, same run", f"{seconds[1] / seconds[2]:.2f}x"),
        ("cached rerun (target <= 10 s)", f"{cached_s:.2f} s, {cached.cached} of {len(poses)} from the cache"),
    ]
    return rows
