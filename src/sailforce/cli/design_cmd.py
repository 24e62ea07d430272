"""``sail design``: resolution, overload, compensation need and bandwidth over the workspace, before anything is built."""

from __future__ import annotations

import time
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ..design.maps import DEFAULT_SAFETY_FACTOR
from ..design.study import DEFAULT_DELTA_DEG, DEFAULT_GRID, DEFAULT_THETA1_DEG, DEFAULT_THETA2_DEG
from . import cli
from ._options import load_robot, robot_option


def _range(text: str, name: str) -> tuple[float, float]:
    parts = text.split(":")
    try:
        low, high = (float(p) for p in parts)
    except ValueError:
        raise click.BadParameter(f"expected LOW:HIGH in degrees, got {text!r}", param_hint=f"--{name}-deg") from None
    return low, high


@cli.command("design")
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Directory for design.json, the figures and the report (created if needed).")
@robot_option
@click.option("--grid", type=click.IntRange(2, 400), default=DEFAULT_GRID, show_default=True,
              help="Points per side of the x-y grid over the workspace.")
@click.option("--theta1-deg", "theta1", default=f"{DEFAULT_THETA1_DEG[0]:g}:{DEFAULT_THETA1_DEG[1]:g}", show_default=True,
              help="Joint limits of theta1, LOW:HIGH [deg].")
@click.option("--theta2-deg", "theta2", default=f"{DEFAULT_THETA2_DEG[0]:g}:{DEFAULT_THETA2_DEG[1]:g}", show_default=True,
              help="Joint limits of theta2, LOW:HIGH [deg].")
@click.option("--delta-deg", "delta", default=f"{DEFAULT_DELTA_DEG[0]:g}:{DEFAULT_DELTA_DEG[1]:g}", show_default=True,
              help="Limits of delta = theta1 - theta2, LOW:HIGH [deg], away from the singularities at 0 and 180.")
@click.option("--safety-factor", type=click.FloatRange(0.0, min_open=True), default=DEFAULT_SAFETY_FACTOR,
              show_default=True, help="On the links' yield strength, for the overload map.")
@click.option("--dpi", type=click.IntRange(50, 600), default=110, show_default=True, help="Figure resolution.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def design_command(output, robot_path, grid, theta1, theta2, delta, safety_factor, dpi, quiet):
    """Map what an arm design gives over its workspace.

    At every reachable pose of an x-y grid: the 1-sigma force resolution (an
    ellipse, from the cells' reading noise `noise_mV_V` through the sensing
    map), the overload (the largest hand force before a cell saturates or a
    link yields), the compensation need (each cell's phase and gain against
    J^T F) and the first natural frequencies (consistent mass, the cells'
    compliance, the handle).  Writes design.json (summary, and per pose
    theta1_deg, theta2_deg, resolution_N, overload_N, first_frequency_Hz ...),
    resolution.png, overload.png, compensation.png, modes.png, report.md and
    report.html.
    """
    import sailforce.report  # noqa: F401  (checks the report extra before anything is computed)

    from ..design.study import design_grid, run_design
    from ..report.design_report import write_design

    console = Console(stderr=True, quiet=quiet)
    robot = load_robot(robot_path)
    started = time.perf_counter()
    with console.status("computing the maps"):
        poses = design_grid(robot, grid, _range(theta1, "theta1"), _range(theta2, "theta2"), _range(delta, "delta"))
        design = run_design(robot, poses, safety_factor=safety_factor)
    seconds = time.perf_counter() - started
    with console.status("writing the figures and the report"):
        write_design(output, design, seconds, dpi)
    summary = design.summary()
    table = Table(title=f"{poses.theta1.size} poses, computed in {seconds:.2f} s")
    for name in ("quantity", "worst", "median"):
        table.add_column(name, justify="right" if name != "quantity" else "left")
    for key, label in (("resolution_N", "resolution, 1σ [N]"), ("overload_N", "overload [N]"),
                       ("first_frequency_Hz", "first frequency [Hz]"), ("phase_need_deg", "phase need [deg]"),
                       ("amplitude_need", "|gain − 1|"), ("condition", "cond(J)")):  # fmt: skip
        table.add_row(label, f"{summary[key]['worst']:.4g}", f"{summary[key]['median']:.4g}")
    console.print(table)
    console.print(f"report: {output / 'report.html'}")
