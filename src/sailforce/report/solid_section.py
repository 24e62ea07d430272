"""The report's section on the solid model (``sail reproduce --solid``): its Table 4 beside the frame's and the
seed's, and its torques against J^T F and the frame."""

from __future__ import annotations

import numpy as np

from ..robot import Robot
from ..sensing.maps import torque_rows
from ..solid.sweep import SweepResult
from .labels import markdown_table


def solid_section(robot: Robot, result: SweepResult, tables: dict[str, np.ndarray], frame_torques: np.ndarray,
                  mesh_mm: float, seconds: float) -> str:  # fmt: skip
    """Markdown: the solid's Table 4 (``tables``: solid, frame, seed) and its torque check over the sweep poses."""
    poses = np.array(result.poses)
    torques = np.stack([r.torques for r in result.responses if r is not None])
    jt = torque_rows(robot.arm, poses[:, 0], poses[:, 1])
    scale = np.abs(jt).max()
    rows = []
    for k, delta in enumerate(tables["solid"][:, 0]):
        rows.append([f"{delta:g}"] + [f"{tables[name][k, c]:.5g}" for c in (1, 2, 3, 4) for name in ("solid", "frame", "seed")])
    header = ["δ [°]"] + [f"{col} {name}" for col in ("A1", "P1 [°]", "A2", "P2 [°]") for name in ("solid", "frame", "seed")]
    return "\n\n".join([
        "## The solid model: Table 4 from gmsh + CalculiX",
        f"The seed's two sweeps ({len(result.poses)} poses, every φ by superposition of two unit loads) solved as a "
        f"2-D plane-stress solid, {mesh_mm:g} mm mesh, {robot.joints.label} joints, the load cell a block "
        f"{result.depth.depth * 1e3 if result.depth else float('nan'):.3f} mm deep (calibrated to its datasheet "
        f"deflection); {result.cached} poses from the cache, {seconds:.1f} s. `solid/table4_comparison.csv` holds "
        "the numbers.",
        "![Table 4: solid, frame and seed](solid/table4.png)",
        markdown_table(header, rows),
        f"Torques: largest |T_solid − J^T F| = {np.abs(torques - jt).max() / scale:.2e} of max |J^T F| "
        f"(zero for pin joints: the arm is then statically determinate); largest |T_solid − T_frame| = "
        f"{np.abs(torques - frame_torques).max() / scale:.2e}.",
    ])  # fmt: skip
