"""sail design (issue 17): the default design report's time, the modal solvers, and a 1,000-variant sweep on Dask."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.linalg

from sailforce.design.study import design_grid, run_design
from sailforce.design.sweep import GridSpec, parse_sweep, run_sweep
from sailforce.fem.frame import assemble, assemble_basis
from sailforce.fem.model import build_model
from sailforce.fem.modes import arm_mass_basis, frame_modes, lowest_frequencies
from sailforce.report.design_report import write_design
from sailforce.robot import Robot

REPORT_TARGET_S = 10.0  #: issue 17: the default design report
SWEEP_TARGET_S = 60.0  #: issue 17: 1,000 variants x 2,500 poses on two cores
#: 70 x 70 grid points: 2,577 reachable poses of the default robot (the issue's 2,500)
SWEEP_GRID = GridSpec(n=70)
#: 10 x 10 x 10 variants: where the cells go, their capacity, and l3's depth
SWEEP = ("loadcells.position=0.3:0.75:0.05", "loadcells.capacity_kg=10:100:10", "sections.l3.depth=0.016:0.034:0.002")


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
    big = design_grid(robot, SWEEP_GRID.n)
    angles_big = np.stack([big.theta1, big.theta2], axis=-1)
    start = time.perf_counter()
    frame_modes(model.frame, basis, angles_big, 1)
    reduction_s = time.perf_counter() - start
    start = time.perf_counter()
    lowest_frequencies(model.frame, basis, angles_big, 1)
    subspace_s = time.perf_counter() - start

    axes = [parse_sweep(text, robot) for text in SWEEP]
    start = time.perf_counter()
    run_sweep(robot, axes[:2], grid=SWEEP_GRID)  # 100 variants in this process
    one_s = time.perf_counter() - start
    start = time.perf_counter()
    run_sweep(robot, axes[:2], grid=SWEEP_GRID, workers=2)
    two_s = time.perf_counter() - start
    start = time.perf_counter()
    full = run_sweep(robot, axes, grid=SWEEP_GRID, workers=2)
    sweep_s = time.perf_counter() - start
    met = "met" if sweep_s <= SWEEP_TARGET_S else "NOT met"
    return [
        (f"sail design, default robot: maps of {grid.theta1.size:,} poses", f"{maps_s:10.2f} s"),
        ("  with the figures and the report", f"{report_s:10.2f} s (target <= {REPORT_TARGET_S:g} s: "
                                              f"{'met' if report_s <= REPORT_TARGET_S else 'NOT met'})"),
        (f"modes of {len(angles):,} poses: batched Cholesky + eigh / scipy eigh per pose",
         f"{batched_s:10.3f} s / {dense_s:.3f} s ({dense_s / batched_s:.1f}x)"),
        (f"first frequency of {len(angles_big):,} poses: subspace iteration / full reduction",
         f"{subspace_s:10.3f} s / {reduction_s:.3f} s ({reduction_s / subspace_s:.1f}x)"),
        (f"sweep of 100 variants x {len(angles_big):,} poses: 1 process / 2 Dask workers",
         f"{one_s:10.1f} s / {two_s:.1f} s ({one_s / two_s:.2f}x, cluster start-up included)"),
        (f"sweep of {len(full):,} variants x {len(angles_big):,} poses, 2 Dask workers",
         f"{sweep_s:10.1f} s (target <= {SWEEP_TARGET_S:g} s: {met}; {sweep_s / len(full) * 1e3:.0f} ms per variant)"),
    ]  # fmt: skip
