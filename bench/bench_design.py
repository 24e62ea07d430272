"""sail design (issue 17): the default design report's time, and the modal solver against dense eigh per pose."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.linalg

from sailforce.design.study import design_grid, run_design
from sailforce.fem.frame import assemble, assemble_basis
from sailforce.fem.model import build_model
from sailforce.fem.modes import arm_mass_basis, frame_modes
from sailforce.report.design_report import write_design
from sailforce.robot import Robot

REPORT_TARGET_S = 10.0  #: issue 17: the default design report


def run() -> list[tuple[str, str]]:
    robot = Robot()
    start = time.perf_counter()
    grid = design_grid(robot)
    design = run_design(robot, grid)
    maps_s = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as directory:
        write_design(Path(directory), design, maps_s, 110)
    report_s = time.perf_counter() - start
    model = build_model(robot)
    angles = np.stack([grid.theta1, grid.theta2], axis=-1)
    basis = arm_mass_basis(model)
    start = time.perf_counter()
    frame_modes(model.frame, basis, angles, 3)
    batched_s = time.perf_counter() - start
    K, M = assemble(model.frame, angles), assemble_basis(basis, angles)
    start = time.perf_counter()
    for k in range(len(angles)):
        scipy.linalg.eigh(K[k], M[k], eigvals_only=True, subset_by_index=(0, 2))
    dense_s = time.perf_counter() - start
    return [
        (f"sail design, default robot: maps of {grid.theta1.size:,} poses", f"{maps_s:10.2f} s"),
        ("  with the figures and the report", f"{report_s:10.2f} s (target <= {REPORT_TARGET_S:g} s: "
                                              f"{'met' if report_s <= REPORT_TARGET_S else 'NOT met'})"),
        (f"modes of {len(angles):,} poses: batched Cholesky + eigh / scipy eigh per pose",
         f"{batched_s:10.3f} s / {dense_s:.3f} s ({dense_s / batched_s:.1f}x)"),
    ]  # fmt: skip
