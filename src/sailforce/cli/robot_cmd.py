"""``sail robot``: write and inspect robot files."""

from __future__ import annotations

import math
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ..io.robotfile import write_template
from . import cli
from ._options import load_robot, robot_option


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
    """Print the arm's geometry and reach, and the inertial parameters of the bodies beyond the cells."""
    robot_ = load_robot(robot_path)
    arm = robot_.arm
    table = Table(title=f"robot: {robot_path or 'built-in default'}", show_header=True)
    table.add_column("quantity")
    table.add_column("value", justify="right")
    for name, text in (("l1", "B to P1"), ("l2", "B to P2"), ("l3", "P2 to A"), ("l4", "P1 to P3")):
        table.add_row(f"{name} ({text})", f"{getattr(arm, name):.4f} m")
    inner, outer = arm.reach
    table.add_row("reach (annulus)", f"{inner:.4f} m .. {outer:.4f} m")
    table.add_row("cond(J) at delta = 90 deg (best)", f"{float(arm.condition(math.pi / 2, 0.0)):.3f}")
    console = Console()
    console.print(table)
    _print_adc(console, robot_)
    _print_inertia(console, robot_)


def _print_adc(console: Console, robot_) -> None:
    from ..design.maps import adc_noise_at_hand

    adc = robot_.adc
    if adc.ideal:
        console.print("ADC: ideal (a reading at every control tick, unfiltered); set [adc] model = \"hx711-80\" ... for a "
                      "real one (docs/reference/adc.md)", highlight=False)  # fmt: skip
        return
    table = Table(title=f"ADC: {adc.model} (docs/reference/adc.md)")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    rows = (("conversion rate", f"{adc.rate_Hz:g} SPS ± {adc.rate_tolerance:.1%}"),
            ("digital filter", f"sinc{adc.sinc_order}, settles in {adc.settling_s * 1e3:g} ms"),
            ("group delay (latency of a reading)", f"{adc.group_delay_s * 1e3:g} ms"),
            ("-3 dB bandwidth", f"{adc.bandwidth_Hz:.3g} Hz"),
            ("input noise at that rate", f"{adc.noise_nV:g} nV rms ({adc.noise_mV_V:.3g} mV/V on 5 V)"),
            ("that noise in N at the hand (1 sigma, worst direction, theta1 = 90°, theta2 = 0)", f"{adc_noise_at_hand(robot_):.3g} N"),
            ("clocking", "one chip, both cells at once" if adc.simultaneous else "one chip per cell, each its own clock"))  # fmt: skip
    for name, value in rows:
        table.add_row(name, value)
    console.print(table)


def _print_inertia(console: Console, robot_) -> None:
    from ..motion.dynamics import BODIES, base_parameters, inertial_parameters, parameter_vector

    params = inertial_parameters(robot_)
    table = Table(title="inertial parameters beyond the cells (prior from sections, densities and the handle)")
    for head in ("body", "about", "m [kg]", "hx [kg m]", "hy [kg m]", "I [kg m²]"):
        table.add_column(head, justify="left" if head in ("body", "about") else "right")
    for body, about in zip(BODIES, ("B", "B", "P1", "P2")):
        b = getattr(params, body)
        table.add_row(body, about, f"{b.m:.4g}", f"{b.hx:.4g}", f"{b.hy:.4g}", f"{b.I:.4g}")
    console.print(table)
    gx, gy = (v + 0.0 for v in robot_.plane.gravity)  # no "-0"
    console.print(f"in-plane gravity ({robot_.plane.tilt_deg:g}° tilt): ({gx:.4g}, {gy:.4g}) m/s²; "
                  f"handle {robot_.handle.mass:g} kg at {robot_.handle.position:g} l3 from P2", highlight=False)  # fmt: skip
    base = base_parameters(robot_.arm)
    values = base.of(parameter_vector(robot_.arm, params, robot_.plane.gravity))
    table = Table(title="the base parameters the cells can see (docs/dynamics.md)")
    table.add_column("base parameter")
    table.add_column("value", justify="right")
    for name, value in zip(base.names, values):
        table.add_row(name, f"{value:.5g}")
    console.print(table)
