"""``sail identify``: fit physical parameters of the frame model to a Table 4 or to calibration readings."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from ..errors import InputError
from ..fem.response import TRANSDUCTIONS
from ..fit.identify import AMPLITUDE_WEIGHT, Identification, IdentifyError, ReadingsTarget
from ..io.files import read_numeric_csv, write_figure, write_json, write_numeric_table
from ..io.robotfile import template
from ..paper.study import TABLE4_COLUMNS, table4
from ..paper.table4_fit import Table4Target
from ..workflows import identify_robot, readings_target, table4_target
from . import cli
from ._options import load_robot, resolve_reading, robot_option
from ._progress import progress_bar

#: Files ``sail identify`` writes into its output directory.
OUTPUTS = ("identify.json", "residuals.csv", "identified.toml", "fit.png")


def _parse_bounds(ctx, param, values):
    bounds = {}
    for text in values:
        key, _, span = text.partition("=")
        low, _, high = span.partition(":")
        try:
            bounds[key.strip()] = (float(low), float(high))
        except ValueError:
            raise click.BadParameter(f"{text!r}: expected KEY=LOW:HIGH, e.g. joints.P1.stiffness=1:1e5") from None
    return bounds


def _table4_target(spec: str, transduction: str, amplitude_weight: float) -> Table4Target:
    """``seed`` (the built-in seed Table 4) or a CSV with :data:`TABLE4_COLUMNS`; its delta grid sets the sweeps."""
    if spec == "seed":
        from ..report.results import seed_table4

        return Table4Target(seed_table4(), transduction, amplitude_weight)
    names, table = read_numeric_csv(Path(spec), min_columns=5)
    if tuple(names[:5]) != TABLE4_COLUMNS:
        raise click.BadParameter(f"{spec}: expected the columns {', '.join(TABLE4_COLUMNS)} (as `sail reproduce` writes "
                                 f"table4.csv), found {', '.join(names)}", param_hint="--table4")  # fmt: skip
    try:
        return table4_target(table, transduction, amplitude_weight)
    except InputError as exc:
        raise click.BadParameter(f"{spec}: {exc}", param_hint="--table4") from None


@cli.command("identify")
@robot_option
@click.option(
    "--table4",
    "table4_spec",
    default=None,
    metavar="seed|TABLE4.csv",
    help="Target: the seed's Table 4 (seed), or a table4.csv as `sail reproduce` writes it.",
)
@click.option(
    "--data",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    metavar="DATA.csv",
    help="Target: calibration readings (theta1_deg, theta2_deg, load1, load2, fx_N, fy_N); each cell's offset and gain are fitted too.",
)
@click.option(
    "--free",
    required=True,
    metavar="KEY,KEY,...",
    help="Robot-file keys to fit, e.g. joints.P1.stiffness,links.l3,loadcells.position,"
    "loadcells.rated_deflection,loadcells.crosstalk_axial.",
)
@click.option(
    "--bounds",
    multiple=True,
    callback=_parse_bounds,
    metavar="KEY=LOW:HIGH",
    help="Bounds of one free key (repeatable). Default: stiffness 0.01…1e7 N·m/rad, lengths ½…2×, "
    "position 0.05…0.95, crosstalk ±0.5, other scales ÷10…×10.",
)
@click.option(
    "--transduction",
    type=click.Choice(TRANSDUCTIONS),
    default=None,
    help="What the cells read. Default: the --robot file's reading, else deflection for --table4 (the seed's "
    "surrogate), bridge for --data. identified.toml records it.",
)
@click.option(
    "--amplitude-weight",
    type=click.FloatRange(0.0),
    default=AMPLITUDE_WEIGHT,
    show_default=True,
    help="--table4: weight of the amplitude shape against the phases [deg per unit shape]; 0 fits phases only.",
)
@click.option(
    "--starts",
    type=click.IntRange(0, 16),
    default=None,
    help="Multi-start grid points per parameter (besides the robot's own values). Default: 4, at most 16 in all.",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(file_okay=False, path_type=Path),
    required=True,
    help=f"Directory for {', '.join(OUTPUTS)} (created if needed).",
)
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def identify_command(robot_path, table4_spec, data, free, bounds, transduction, amplitude_weight, starts, output, quiet):
    """Fit physical parameters of the robot's frame model to a target.

    Scipy's least_squares with bounds and several starts; stiffnesses and
    compliances in log space.  Prints each parameter with its standard error
    and whether the data identify it (a parameter whose effect is, to 0.99,
    a combination of the others', or whose standard error exceeds its value,
    is not), and writes into DIR: identify.json (parameters, standard errors,
    correlations, residuals), residuals.csv (row by row), identified.toml
    (the robot file with the identified values) and fit.png.
    """
    if (table4_spec is None) == (data is None):
        raise click.UsageError("give one target: --table4 seed|TABLE4.csv, or --data DATA.csv")
    robot = load_robot(robot_path)
    keys = tuple(k.strip() for k in free.split(",") if k.strip())
    console = Console()
    if table4_spec is not None:
        reading = resolve_reading(robot, transduction, "deflection", console)
        target: Table4Target | ReadingsTarget = _table4_target(table4_spec, reading, amplitude_weight)
    else:
        target = readings_target(data, resolve_reading(robot, transduction, "bridge", console))
    if robot_path is not None and output.joinpath("identified.toml").resolve() == Path(robot_path).resolve():
        raise click.UsageError(f"{robot_path} is the --robot file: choose another -o directory, so it is not replaced")
    with progress_bar(console, "identifying", None, unit="starts", quiet=quiet) as advance:
        try:
            run = identify_robot(robot, target, keys, bounds=bounds, starts=starts, progress=lambda done, total: advance(1))
        except IdentifyError as exc:
            raise click.UsageError(str(exc)) from None
    if run.springs_added:
        console.print(f"note: joints {robot.joints.label} -> {run.robot.joints.label}: a free stiffness needs a spring "
                      "(0.01 N·m/rad is a pin, 1e7 bonded)", highlight=False)  # fmt: skip
    fit, robot = run.identification, run.robot
    output.mkdir(parents=True, exist_ok=True)
    _write(output, fit, target, robot)
    _print(console, fit, output)


def _write(output: Path, fit: Identification, target, robot) -> None:
    from ..io.files import atomic_writer

    rows = np.column_stack([_row_key(target), fit.residuals])
    head = ["delta_deg" if isinstance(target, Table4Target) else "row", *(_column_name(c) for c in fit.residual_columns)]
    write_numeric_table(output / "residuals.csv", head, rows, csv_format="%.10g")
    with atomic_writer(output / "identified.toml") as stream:  # the reading it was fitted under, for every later command
        stream.write(template(replace(fit.robot, loadcell=replace(fit.robot.loadcell, reading=target.transduction))))
    write_json(output / "identify.json", {
        "target": "table4" if isinstance(target, Table4Target) else "readings",
        "transduction": target.transduction,
        "parameters": [{"name": n, "value": float(v), "standard_error": float(se), "identifiable": bool(ok),
                        "collinearity": float(c)}
                       for n, v, se, ok, c in zip(fit.names, fit.values, fit.standard_errors, fit.identifiable, fit.collinearity)],
        "bounds": {n: list(b) for n, b in zip(fit.names, fit.bounds)},
        "at_bound": list(fit.at_bound()),
        "correlation": fit.correlation.tolist(),
        "metrics": {k: list(v) for k, v in fit.metrics.items()},
        "residual_columns": list(head),
        "starts": fit.starts, "success": fit.success,
    })  # fmt: skip
    from ..report.identify_figure import identify_figure

    start = table4(robot, target.transduction, protocol=target.protocol) if isinstance(target, Table4Target) else None
    write_figure(output / "fit.png", identify_figure(fit, target, start), dpi=110)


def _row_key(target) -> np.ndarray:
    return target.table[:, 0] if isinstance(target, Table4Target) else np.arange(1, target.theta1.size + 1)


def _column_name(label: str) -> str:
    return label.replace(" [deg]", "_deg").replace(" (weighted)", "_weighted").replace(" / spread", "_per_spread").replace(" ", "")


def _print(console: Console, fit: Identification, output: Path) -> None:
    table = Table(title="identified parameters (± 1 standard error)")
    for head in ("parameter", "value", "± SE", "identifiable", "collinearity"):
        table.add_column(head, justify="left" if head == "parameter" else "right")
    for name, value, se, ok, c in zip(fit.names, fit.values, fit.standard_errors, fit.identifiable, fit.collinearity):
        table.add_row(name, f"{value:.6g}", "-" if math.isnan(se) else f"{se:.3g}", "yes" if ok else "[yellow]no[/yellow]", f"{c:.4f}")
    console.print(table)
    for key, (a, b) in fit.metrics.items():
        console.print(f"{key.replace('_', ' ')}: cell 1 {a:.4g}, cell 2 {b:.4g}", highlight=False)
    if fit.at_bound():
        console.print(f"[yellow]note:[/yellow] {', '.join(fit.at_bound())} ended on a bound: widen it with --bounds, "
                      "or read it as 'at least' / 'at most'")  # fmt: skip
    console.print(f"wrote {', '.join(str(output / name) for name in OUTPUTS)}", highlight=False)
