"""``sail statics``: torques from a force, or the force from torques, at one pose."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ..kinematics import jacobian_condition, sin_delta
from ..statics import cartesian, polar
from ..sweep import check_not_singular
from . import cli
from ._options import FINITE, PrimaryOption, load_arm, robot_option


@cli.command("statics")
@robot_option
@click.option("--theta1-deg", type=FINITE, required=True, help="Angle of link l1 [deg].")
@click.option("--theta2-deg", type=FINITE, required=True, help="Angle of link l2 [deg].")
@click.option("--force-N", "force_n", type=FINITE, help="End-effector force magnitude [N].")
@click.option("--phi-deg", type=FINITE, help="End-effector force direction [deg].")
@click.option("--t1-Nm", "--t1", "t1", cls=PrimaryOption, type=FINITE, help="Joint torque on l1 [N m] (T = J^T F).")
@click.option("--t2-Nm", "--t2", "t2", cls=PrimaryOption, type=FINITE, help="Joint torque on l2 [N m].")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of a table.")
def statics_command(robot_path: Path | None, theta1_deg, theta2_deg, force_n, phi_deg, t1, t2, as_json):
    """Joint torques from an end-effector force, or the force from joint torques.

    Give either --force-N and --phi-deg (prints T = J^T F) or --t1-Nm and
    --t2-Nm (prints F = J^-T T, Cartesian and polar).  T is the torque the force
    induces at the motors, counter-clockwise positive; the motors hold -T.
    Negative values work as --phi-deg=-30.
    """
    by_force = force_n is not None or phi_deg is not None
    by_torque = t1 is not None or t2 is not None
    if by_force == by_torque:
        raise click.UsageError("give either --force-N with --phi-deg, or --t1-Nm with --t2-Nm")
    if by_force and (force_n is None or phi_deg is None):
        raise click.UsageError("--force-N and --phi-deg go together")
    if by_torque and (t1 is None or t2 is None):
        raise click.UsageError("--t1-Nm and --t2-Nm go together")

    arm = load_arm(robot_path)
    theta1, theta2 = math.radians(theta1_deg), math.radians(theta2_deg)
    if by_force:
        fx, fy = cartesian(force_n, math.radians(phi_deg))
        t1, t2 = arm.joint_torques(theta1, theta2, fx, fy)
    else:
        check_not_singular(theta1, theta2)
        fx, fy = arm.end_effector_force(theta1, theta2, t1, t2)
    magnitude, phi = polar(fx, fy)
    x, y = arm.forward(theta1, theta2)
    result = {
        "theta1_deg": theta1_deg,
        "theta2_deg": theta2_deg,
        "x_m": float(x),
        "y_m": float(y),
        "sin_delta": float(sin_delta(theta1, theta2)),
        "condition": float(jacobian_condition(arm, theta1, theta2)),
        "fx_N": float(fx),
        "fy_N": float(fy),
        "force_N": float(magnitude),
        "phi_deg": math.degrees(float(phi)),
        "t1_Nm": float(t1),
        "t2_Nm": float(t2),
    }
    if as_json:
        click.echo(json.dumps(result))
        return
    _print_table(result, given="force" if by_force else "torques")


def _print_table(r: dict, given: str) -> None:
    table = Table(title=f"statics at theta1 = {r['theta1_deg']:g} deg, theta2 = {r['theta2_deg']:g} deg")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    table.add_column("")
    rows = [
        ("end effector A", f"({r['x_m']:.4f}, {r['y_m']:.4f}) m", ""),
        ("sin(theta1 - theta2)", f"{r['sin_delta']:.4f}", f"cond(J) = {r['condition']:.3g}"),
        ("force Fx, Fy", f"({r['fx_N']:.6g}, {r['fy_N']:.6g}) N", "given" if given == "force" else "computed"),
        ("force |F|, phi", f"{r['force_N']:.6g} N at {r['phi_deg']:.4g} deg", ""),
        ("torques T1, T2", f"({r['t1_Nm']:.6g}, {r['t2_Nm']:.6g}) N m", "given" if given == "torques" else "computed"),
    ]
    for row in rows:
        table.add_row(*row)
    Console().print(table)
