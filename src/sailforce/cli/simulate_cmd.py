"""``sail simulate``: the virtual experiment, one CSV row per (pose, force angle)."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np
from rich.console import Console

from .._version import __version__
from ..fem.model import build_model
from ..fem.response import TRANSDUCTION_UNITS, TRANSDUCTIONS, simulate_model
from ..io.files import check_output, check_sidecar, numeric_table_writer, table_format, write_json
from ..sweep import COLUMNS, check_not_singular, pose_grid, sweep_rows
from . import cli
from ._options import FINITE, joints_option, load_robot, resolve_reading, robot_option, spec
from ._progress import progress_bar

#: Rows computed and written per step: about 30 MB of working arrays whatever the grid.
ROWS_PER_CHUNK = 65536

#: Rows refused without --max-rows: about 1 GB of CSV, more than any study of this arm needs.
MAX_ROWS = 10_000_000


@cli.command("simulate")
@robot_option
@joints_option
@click.option("--transduction", type=click.Choice(TRANSDUCTIONS), default=None,
              help="Load-cell signal: far-face deflection [m] or bridge output [mV/V]. Default: the --robot file's "
              "reading, else deflection.")
@click.option("--theta1-deg", required=True, callback=spec("theta1"), help="SPEC: A or start:stop:step (stop inclusive).")
@click.option("--theta2-deg", required=True, callback=spec("theta2"), help="SPEC for theta2.")
@click.option("--phi-deg", default="0:345:15", show_default=True, callback=spec("phi"), help="SPEC for the force direction.")
@click.option("--force-N", "force_n", type=FINITE, default=10.0, show_default=True, help="Force magnitude at A [N].")
@click.option("--shear/--no-shear", default=True, show_default=True, help="Timoshenko (shear-flexible) or Euler-Bernoulli members.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="OUT.csv or OUT.parquet to write; OUT.csv.json beside it records units and options.")
@click.option("--max-rows", type=click.IntRange(1), default=MAX_ROWS, show_default=True,
              help="Refuse sweeps with more rows than this (poses x force angles).")
def simulate_command(robot_path, joints, transduction, theta1_deg, theta2_deg, phi_deg, force_n, shear, output, max_rows):
    """Simulate the load cells over a grid of poses and force directions.

    Writes OUT.csv (or OUT.parquet) with the columns theta1_deg, theta2_deg,
    phi_deg, fx_N, fy_N, load1, load2, t1_Nm, t2_Nm (one row per pose and
    force angle) and OUT.csv.json beside it (the output's name plus .json, so
    that it never replaces another file), naming the unit of load1/load2,
    the robot and the options.  Each pose costs two solves (unit Fx, unit Fy); every force
    angle follows by superposition.  Warns when a load cell's shear exceeds
    its capacity.
    """
    table_format(output)
    sidecar = check_sidecar(output)
    check_output(output, {"the --robot file": robot_path})
    check_output(sidecar, {"the --robot file": robot_path}, flag=f"the sidecar of -o {output},")
    n_rows = theta1_deg.size * theta2_deg.size * phi_deg.size
    if n_rows > max_rows:
        raise click.UsageError(f"the sweep has {n_rows:,} rows ({theta1_deg.size:,} x {theta2_deg.size:,} poses x "
                               f"{phi_deg.size:,} force angles), more than --max-rows {max_rows:,}; use coarser steps "
                               "or raise --max-rows")  # fmt: skip
    robot = load_robot(robot_path, joints)
    console = Console(stderr=True)
    transduction = resolve_reading(robot, transduction, "deflection", console)
    theta1, theta2 = pose_grid(np.radians(theta1_deg), np.radians(theta2_deg))
    check_not_singular(theta1, theta2)
    phi = np.radians(phi_deg)
    model = build_model(robot, shear_deformation=shear)

    capacity = robot.loadcell.capacity_N
    overloads, worst_safety, peak_shear = 0, math.inf, 0.0
    poses_per_chunk = max(1, ROWS_PER_CHUNK // phi.size)
    with numeric_table_writer(output, COLUMNS) as write, progress_bar(console, "simulating", n_rows, unit="rows") as advance:
        for start in range(0, theta1.size, poses_per_chunk):
            chunk = slice(start, start + poses_per_chunk)
            response = simulate_model(model, theta1[chunk], theta2[chunk])
            for first in range(0, phi.size, ROWS_PER_CHUNK):  # many force angles: a few poses, in blocks of angles
                rows = sweep_rows(response, phi[first : first + ROWS_PER_CHUNK], force_n, transduction)
                write(rows)
                shear_abs = np.maximum(np.abs(rows["cell_shear1"]), np.abs(rows["cell_shear2"]))
                overloads += int(np.count_nonzero(shear_abs > capacity))
                peak_shear = max(peak_shear, float(shear_abs.max()))
                worst_safety = min(worst_safety, float(rows["safety_factor"].min()))
                advance(shear_abs.size)

    write_json(sidecar, {
        "software": f"sailforce {__version__}",
        "rows": n_rows,
        "columns": list(COLUMNS),
        "units": {"theta1_deg": "deg", "theta2_deg": "deg", "phi_deg": "deg", "fx_N": "N", "fy_N": "N",
                  "load1": TRANSDUCTION_UNITS[transduction], "load2": TRANSDUCTION_UNITS[transduction],
                  "t1_Nm": "N m", "t2_Nm": "N m"},
        "transduction": transduction,
        "force_N": force_n,
        "shear_deformation": shear,
        "robot_file": str(robot_path) if robot_path else None,
        "robot": robot,
        "loadcell_equivalent_EI_Nm2": robot.loadcell.bending_rigidity,
        "peak_loadcell_shear_N": peak_shear,
        "loadcell_capacity_N": capacity,
        "overloaded_rows": overloads,
        "min_yield_safety_factor": worst_safety,
    })  # fmt: skip
    console.print(f"wrote {n_rows} rows to {output} (units and options in {sidecar})")
    console.print(f"peak load-cell shear {peak_shear:.4g} N of {capacity:.4g} N capacity; "
                  f"smallest yield safety factor {worst_safety:.3g}")  # fmt: skip
    if overloads:
        console.print(f"[bold red]warning:[/bold red] {overloads} row(s) load a cell beyond its {capacity:.4g} N capacity")
