"""``sail robot``: write and inspect robot files."""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ..robotfile import write_template
from . import cli
from ._options import load_arm, robot_option


@cli.group()
def robot() -> None:
    """Write and inspect robot TOML files."""


@robot.command("init")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--force", is_flag=True, help="Overwrite FILE if it exists.")
def robot_init(file: Path, force: bool) -> None:
    """Write a commented robot-file template to FILE (the default robot)."""
    write_template(file, overwrite=force)
    click.echo(f"wrote {file}")


@robot.command("show")
@robot_option
def robot_show(robot_path: Path | None) -> None:
    """Print the arm's geometry and reach."""
    arm = load_arm(robot_path)
    table = Table(title=f"robot: {robot_path or 'built-in default'}", show_header=True)
    table.add_column("quantity")
    table.add_column("value", justify="right")
    for name, text in (("l1", "B to P1"), ("l2", "B to P2"), ("l3", "P2 to A"), ("l4", "P1 to P3")):
        table.add_row(f"{name} ({text})", f"{getattr(arm, name):.4f} m")
    inner, outer = arm.reach
    table.add_row("reach (annulus)", f"{inner:.4f} m .. {outer:.4f} m")
    table.add_row("cond(J) at delta = 90 deg (best)", f"{float(arm.condition(math.pi / 2, 0.0)):.3f}")
    Console().print(table)
