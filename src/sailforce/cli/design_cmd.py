"""``sail design``: resolution, overload, compensation need and bandwidth over the workspace, before anything is built."""

from __future__ import annotations

import time
from pathlib import Path

import click
from rich.console import Console
from rich.table import Table

from ..design.maps import DEFAULT_SAFETY_FACTOR
from ..design.study import DEFAULT_DELTA_DEG, DEFAULT_GRID, DEFAULT_THETA1_DEG, DEFAULT_THETA2_DEG
from ..design.sweep import DEFAULT_MIN_FREQUENCY_HZ, DEFAULT_REQUIRED_FORCE_N
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
@click.option("--sweep", "sweeps", multiple=True, metavar="KEY=VALUES",
              help="Vary a robot-file key: KEY=start:stop:step (stop inclusive) or KEY=v1,v2,... Repeat for a product "
                   "of several keys, e.g. --sweep loadcells.position=0.2:0.8:0.1 --sweep loadcells.capacity_kg=10,20,50.")
@click.option("--capacity-catalogue", "catalogue", type=click.Path(dir_okay=False, path_type=Path),
              help="CSV of available cells (name, capacity_kg, rated_output_mV_V, rated_deflection_m, price; "
                   "optionally noise_mV_V): each is tried on the robot and ranked.")
@click.option("--required-force-N", "required_force", type=click.FloatRange(0.0), default=DEFAULT_REQUIRED_FORCE_N,
              show_default=True, help="Sweeps rank only the variants whose worst-direction overload reaches this.")
@click.option("--min-frequency-Hz", "min_frequency", type=click.FloatRange(0.0), default=DEFAULT_MIN_FREQUENCY_HZ,
              show_default=True, help="... and whose lowest first natural frequency reaches this.")
@click.option("--workers", type=click.IntRange(1, 512),
              help="Run the sweep on a Dask cluster of N worker processes on this machine.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run the sweep on an existing Dask cluster (tcp://HOST:PORT; see `dask scheduler`, `dask worker`).")
@click.option("--dpi", type=click.IntRange(50, 600), default=110, show_default=True, help="Figure resolution.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def design_command(output, robot_path, grid, theta1, theta2, delta, safety_factor, sweeps, catalogue, required_force,
                   min_frequency, workers, scheduler, dpi, quiet):  # fmt: skip
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

    With --sweep and/or --capacity-catalogue it also evaluates every variant
    (the product of the sweeps and the catalogue's cells) on its own grid and
    writes sweep.csv and sweep.parquet (one row per variant: its settings,
    the worst resolution, overload and first frequency, Pareto flag, rank),
    pareto.png and a Sweep section in the report.  --workers or --scheduler
    run the variants on Dask.
    """
    import sailforce.report  # noqa: F401  (checks the report extra before anything is computed)

    from ..design.study import design_grid, run_design
    from ..design.sweep import GridSpec, Requirements, parse_sweep, read_catalogue, run_sweep
    from ..io.files import output_set
    from ..report.design_report import design_outputs, write_design
    from ..report.sweep_report import SWEEP_OUTPUTS, write_sweep

    console = Console(stderr=True, quiet=quiet)
    robot = load_robot(robot_path)
    limits = _range(theta1, "theta1"), _range(theta2, "theta2"), _range(delta, "delta")
    axes = [parse_sweep(text, robot) for text in sweeps] + ([read_catalogue(catalogue)] if catalogue else [])
    if (workers or scheduler) and not axes:
        raise click.UsageError("--workers and --scheduler run a sweep: add --sweep KEY=VALUES or --capacity-catalogue")
    started = time.perf_counter()
    with console.status("computing the maps"):
        poses = design_grid(robot, grid, *limits)
        design = run_design(robot, poses, safety_factor=safety_factor)
    seconds = time.perf_counter() - started
    sections = []
    if axes:
        from ._progress import progress_bar

        total = 1
        for axis in axes:
            total *= len(axis.labels)
        with progress_bar(console, f"sweeping {total} variants", total, quiet=quiet) as advance:
            result = run_sweep(robot, axes, grid=GridSpec(grid, *limits), safety_factor=safety_factor,
                               requirements=Requirements(required_force, min_frequency), workers=workers,
                               scheduler=scheduler, advance=advance)  # fmt: skip
    with console.status("writing the figures and the report"), output_set(output, design_outputs() + SWEEP_OUTPUTS) as staging:
        if axes:
            sections.append(write_sweep(staging, result, dpi))
        write_design(staging, design, seconds, dpi, sections)
    summary = design.summary()
    table = Table(title=f"{poses.theta1.size} poses, computed in {seconds:.2f} s")
    for name in ("quantity", "worst", "median"):
        table.add_column(name, justify="right" if name != "quantity" else "left")
    for key, label in (("resolution_N", "resolution, 1σ [N]"), ("overload_N", "overload [N]"),
                       ("first_frequency_Hz", "first frequency [Hz]"), ("phase_need_deg", "phase need [deg]"),
                       ("amplitude_need", "|gain − 1|"), ("condition", "cond(J)")):  # fmt: skip
        table.add_row(label, f"{summary[key]['worst']:.4g}", f"{summary[key]['median']:.4g}")
    console.print(table)
    if not robot.adc.ideal:
        from ..design.adc import adc_summary

        adc = adc_summary(robot)
        console.print(f"ADC {robot.adc.model}: latency {adc['adc_latency_ms']:.3g} ms, -3 dB {adc['adc_bandwidth_Hz']:.3g} Hz, "
                      f"its noise at the hand {adc['adc_resolution_N']:.3g} N; a 0.3 m reach at 3 m/s² leaves "
                      f"{adc['reach_error_N']:.3g} N RMS (noise-free, estimated at each conversion)", highlight=False)  # fmt: skip
    if axes:
        _print_sweep(console, result)
    console.print(f"report: {output / 'report.html'}")


def _print_sweep(console: Console, result) -> None:
    c = result.columns
    ranked = result.ranked()
    failed = int((c["status"] != "ok").sum())
    table = Table(title=f"{len(result)} variants in {result.seconds:.1f} s: {len(ranked)} meet the requirements, "
                        f"{int(result.pareto.sum())} on the Pareto set" + (f", {failed} FAILED" if failed else ""))  # fmt: skip
    names = [axis.name for axis in result.axes]
    adc = "reach_error_N" in c  # a real ADC: its latency, bandwidth and the error it leaves in a reach
    heads = ("latency [ms]", "-3 dB [Hz]", "ADC noise [N]", "reach error [N]") if adc else ()
    for name in ("rank", *names, "resolution [N]", "overload [N]", "f1 [Hz]", *heads):
        table.add_column(name, justify="right")
    for i in ranked[:10]:
        values = [c[n][i] if isinstance(c[n][i], str) else f"{c[n][i]:.4g}" for n in names]
        more = [f"{c[k][i]:.3g}" for k in ("adc_latency_ms", "adc_bandwidth_Hz", "adc_resolution_N", "reach_error_N")] if adc else []
        table.add_row(str(c["rank"][i]), *values, f"{c['resolution_N'][i]:.3g}", f"{c['overload_N'][i]:.4g}",
                      f"{c['first_frequency_Hz'][i]:.3g}", *more)  # fmt: skip
    console.print(table)
    if adc:
        console.print("reach error: the RMS force error at each estimate's instant over a 0.3 m reach at 3 m/s² peak, "
                      "noise-free (the ADC's timing alone; docs/reference/adc.md)", highlight=False)
