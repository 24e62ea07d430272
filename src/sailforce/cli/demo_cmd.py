"""``sail demo``: a short tour of the statics on the default robot."""

from __future__ import annotations

import math

import numpy as np
from rich.console import Console
from rich.table import Table

from ..arm import Arm
from ..errors import SingularPoseError
from ..paper import seed
from ..statics import SINGULAR_SIN_DELTA, cartesian, polar
from . import cli

DEMO_POSE_DEG = (75.0, 0.0)  # a seed sweep-1 pose: theta2 = 0, delta = 75 deg
DEMO_FORCE_N = 10.0  # the seed's end-effector load


@cli.command("demo")
def demo_command() -> None:
    """Torques for a sweep of force directions, the force recovered, the singularity guard."""
    console = Console()
    arm = Arm()
    console.print(
        f"[bold]Default robot[/bold] (our assumption; seed Table 1 is garbled): "
        f"l1 = {arm.l1} m, l2 = {arm.l2} m, l3 = {arm.l3} m, l4 = {arm.l4} m"
    )
    _round_trip(console, arm)
    _singularity(console, arm)


def _round_trip(console: Console, arm: Arm) -> None:
    theta1, theta2 = np.radians(DEMO_POSE_DEG)
    phi = np.radians(np.arange(0.0, 360.0, 45.0))
    fx, fy = cartesian(DEMO_FORCE_N, phi)
    t1, t2 = arm.joint_torques(theta1, theta2, fx, fy)
    fx_back, fy_back = arm.end_effector_force(theta1, theta2, t1, t2)
    seed_fx, seed_fy = seed.printed_end_effector_force(arm, theta1, theta2, t1, t2)
    magnitude, phi_back = polar(fx_back, fy_back)

    table = Table(
        title=f"{DEMO_FORCE_N:g} N at theta1 = {DEMO_POSE_DEG[0]:g} deg, theta2 = {DEMO_POSE_DEG[1]:g} deg: "
        "F -> T = J^T F -> F"
    )
    for name in ("phi [deg]", "T1 [N m]", "T2 [N m]", "|F| back [N]", "phi back [deg]", "error [N]", "seed Eq. 11 error [N]"):
        table.add_column(name, justify="right")
    for i in range(phi.size):
        err = math.hypot(fx_back[i] - fx[i], fy_back[i] - fy[i])
        seed_err = math.hypot(seed_fx[i] - fx[i], seed_fy[i] - fy[i])
        table.add_row(
            f"{math.degrees(phi[i]):.0f}",
            f"{t1[i]:+.4f}",
            f"{t2[i]:+.4f}",
            f"{magnitude[i]:.6f}",
            f"{math.degrees(phi_back[i]) % 360:.3f}",
            f"{err:.1e}",
            f"{seed_err:.3f}",
        )
    console.print(table)
    console.print(
        "The last column applies the seed's printed Eq. 10/11, which is the transpose of the true "
        "inverse (docs/errata.md): it does not recover the force."
    )


def _singularity(console: Console, arm: Arm) -> None:
    deltas_deg = np.array([90.0, 30.0, 10.0, 5.0, 2.5, 1.5, 0.5, 0.0])
    theta2 = 0.0
    theta1 = np.radians(deltas_deg)
    fx, fy = cartesian(DEMO_FORCE_N, np.radians(45.0))
    t1, t2 = arm.joint_torques(theta1, theta2, fx, fy)
    # A 1 mN m torque error, as from load-cell noise, shows how the force error grows as 1/|sin(delta)|.
    fx_n, fy_n, singular = arm.end_effector_force(theta1, theta2, t1 + 1e-3, t2, on_singular="mask")
    table = Table(
        title=f"Approaching the singularity (threshold |sin(delta)| >= {SINGULAR_SIN_DELTA:.4f}, "
        f"delta >= {math.degrees(math.asin(SINGULAR_SIN_DELTA)):.1f} deg)"
    )
    for name in ("delta [deg]", "sin(delta)", "cond(J)", "force error from 1 mN m [N]", "status"):
        table.add_column(name, justify="right")
    cond = arm.condition(theta1, theta2)
    for i, delta in enumerate(deltas_deg):
        err = "-" if singular[i] else f"{math.hypot(fx_n[i] - fx, fy_n[i] - fy):.4f}"
        table.add_row(
            f"{delta:g}", f"{math.sin(theta1[i]):.4f}", f"{cond[i]:.3g}", err, "singular" if singular[i] else "ok"
        )
    console.print(table)
    try:
        arm.end_effector_force(theta1, theta2, t1, t2)
    except SingularPoseError as exc:
        console.print(f"[bold]on_singular='raise' (the default) says:[/bold] {exc}")
