"""``sail simulate``: the virtual experiment, one CSV row per (pose, force angle)."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.progress import Progress

from .. import __version__
from ..fem.model import build_model
from ..fem.response import TRANSDUCTION_UNITS, TRANSDUCTIONS, simulate_model
from ..io import atomic_writer, write_json
from ..sweep import COLUMNS, check_not_singular, pose_grid, sweep_rows
from . import cli
from ._options import joints_option, load_robot, robot_option, spec

POSES_PER_CHUNK = 2048  #: poses solved, and rows written, per progress step


@cli.command("simulate")
@robot_option
@joints_option
@click.option("--transduction", type=click.Choice(TRANSDUCTIONS), default="deflection", show_default=True,
              help="Load-cell signal: far-face deflection [m] or bridge output [mV/V].")
@click.option("--theta1-deg", required=True, callback=spec("theta1"), help="SPEC: A or start:stop:step (stop inclusive).")
@click.option("--theta2-deg", required=True, callback=spec("theta2"), help="SPEC for theta2.")
@click.option("--phi-deg", default="0:345:15", show_default=True, callback=spec("phi"), help="SPEC for the force direction.")
@click.option("--force-N", "force_n", type=float, default=10.0, show_default=True, help="Force magnitude at A [N].")
@click.option("--shear/--no-shear", default=True, show_default=True, help="Timoshenko (shear-flexible) or Euler-Bernoulli members.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True, help="CSV file to write.")
def simulate_command(robot_path, joints, transduction, theta1_deg, theta2_deg, phi_deg, force_n, shear, output):
    """Simulate the load cells over a grid of poses and force directions.

    Writes OUT.csv with the columns theta1_deg, theta2_deg, phi_deg, fx_N,
    fy_N, load1, load2, t1_Nm, t2_Nm (one row per pose and force angle) and
    OUT.json beside it, naming the unit of load1/load2, the robot and the
    options.  Each pose costs two solves (unit Fx, unit Fy); every force
    angle follows by superposition.  Warns when a load cell's shear exceeds
    its capacity.
    """
    if not math.isfinite(force_n):
        raise click.BadParameter("must be finite", param_hint="--force-N")
    robot = load_robot(robot_path, joints)
    theta1, theta2 = pose_grid(np.radians(theta1_deg), np.radians(theta2_deg))
    check_not_singular(theta1, theta2)
    phi = np.radians(phi_deg)
    model = build_model(robot, shear_deformation=shear)

    console = Console(stderr=True)
    capacity = robot.loadcell.capacity_N
    overloads, worst_safety, peak_shear = 0, math.inf, 0.0
    with atomic_writer(output) as stream, Progress(console=console, transient=True) as progress:
        task = progress.add_task("simulating", total=theta1.size)
        stream.write(",".join(COLUMNS) + "\n")
        for start in range(0, theta1.size, POSES_PER_CHUNK):
            chunk = slice(start, start + POSES_PER_CHUNK)
            response = simulate_model(model, theta1[chunk], theta2[chunk])
            rows = sweep_rows(response, phi, force_n, transduction)
            np.savetxt(stream, np.column_stack([rows[c] for c in COLUMNS]), fmt="%.12g", delimiter=",")
            shear_abs = np.maximum(np.abs(rows["cell_shear1"]), np.abs(rows["cell_shear2"]))
            overloads += int(np.count_nonzero(shear_abs > capacity))
            peak_shear = max(peak_shear, float(shear_abs.max()))
            worst_safety = min(worst_safety, float(rows["safety_factor"].min()))
            progress.advance(task, response.theta1.size)

    n_rows = theta1.size * phi.size
    sidecar = output.with_suffix(".json")
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
