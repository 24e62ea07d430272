"""``sail solid``, ``sail solid-sweep`` and ``sail cell-fit``: the arm as a gmsh + CalculiX solid."""

from __future__ import annotations

import math
import time
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from ..io.files import atomic_writer, check_output, write_figure, write_json, write_numeric_table
from ..paper.study import Protocol
from . import cli
from ._options import FINITE, load_robot, robot_option
from ._progress import print_notes, progress_bar

#: Default element size [mm]: 2 mm solves a 2-D pose in about 10 s on one core.
DEFAULT_MESH_MM = 2.0
#: The pose ``sail solid`` and ``sail cell-fit`` check at: the seed's stress pose (sailforce.paper.study.Protocol).
CHECK_POSE_DEG = Protocol().stress_pose_deg

joints_choice = click.option("--joints", type=click.Choice(("pin", "bonded")), default=None,
                             help="Passive-joint model; overrides the robot file (the solid offers pin and bonded).")  # fmt: skip
mesh_option = click.option("--mesh-mm", type=click.FloatRange(0.25, 50.0), default=DEFAULT_MESH_MM, show_default=True,
                           help="Element size [mm] (finer across the load cells: three elements through their depth).")  # fmt: skip
cache_option = click.option("--cache-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
                            help="Where solved poses are cached. Default: $SAIL_CACHE_DIR, else ~/.cache/sailforce/solid.")  # fmt: skip


def _prepare(robot_path, joints):
    """The robot, after checking that gmsh and ccx are here (a clear error before any work)."""
    from .._extras import require
    from ..solid.arm import check_joints
    from ..solid.ccx import ccx_binary

    require("gmsh", "solid", "the solid model")
    ccx_binary()
    robot = load_robot(robot_path, joints)
    check_joints(robot)
    return robot


def _settings(mesh_mm: float):
    from ..solid.sweep import SolidSettings

    return SolidSettings(mesh_size=mesh_mm / 1e3)


@cli.command("solid")
@robot_option
@joints_choice
@click.option("--theta1-deg", type=FINITE, default=CHECK_POSE_DEG[0], show_default=True, help="Angle of l1 [deg].")
@click.option("--theta2-deg", type=FINITE, default=CHECK_POSE_DEG[1], show_default=True, help="Angle of l2 [deg].")
@mesh_option
@click.option("--force-N", "force_n", type=FINITE, default=Protocol().force_N, show_default=True, help="Force at A [N].")
@cache_option
@click.option("--keep-deck", is_flag=True, help="Keep CalculiX's input deck and output in DIR/ccx.")
@click.option("--dpi", type=click.IntRange(50, 600), default=110, show_default=True, help="Figure resolution.")
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Directory for readings.csv, results.json, stress.png and readings.png (created if needed).")
def solid_command(robot_path, joints, theta1_deg, theta2_deg, mesh_mm, force_n, cache_dir, keep_deck, dpi, output):
    """Solve the arm as a solid at one pose and compare it with the frame model.

    The load cell's depth is first calibrated to its datasheet deflection.
    Two unit loads at the handle give every force angle by superposition.
    Writes readings.csv (torques, far-face and relative deflections for
    phi = 0...345 deg, solid and frame), results.json (amplitude ratios and
    phase differences against the frame, equilibrium), stress.png (the
    seed's Fig. 4 from the solid) and readings.png.
    """
    from ..report.solid_figure import readings_figure, solid_stress_figure
    from ..solid.compare import READINGS
    from ..workflows import check_solid

    check_output(output / "readings.csv", {"the --robot file": robot_path})
    robot = _prepare(robot_path, joints)
    theta1, theta2 = math.radians(theta1_deg), math.radians(theta2_deg)
    console = Console(stderr=True)
    with console.status("solving") as status:
        check = check_solid(robot, theta1, theta2, mesh_size=mesh_mm / 1e3, force_N=force_n, cache_dir=cache_dir,
                            workdir=output / "ccx" if keep_deck else None, status=status.update)  # fmt: skip
    print_notes(console, check.notes)
    response, depth, seconds, phi = check.response, check.depth, check.seconds, check.phi
    output.mkdir(parents=True, exist_ok=True)
    columns = ["phi_deg"] + [f"{name}_{i}_{src}" for name in READINGS for src in ("solid", "frame") for i in (1, 2)]
    table = np.column_stack([np.degrees(phi)] + [c[name][i] for name in READINGS for c in (check.solid_curves, check.frame_curves)
                                                 for i in range(2)])  # fmt: skip
    write_numeric_table(output / "readings.csv", columns, table, csv_format="%.10g")
    comparison = check.comparison
    write_json(output / "results.json", {
        "pose_deg": [theta1_deg, theta2_deg], "joints": robot.joints.label, "mesh_mm": mesh_mm,
        "dofs": response.dofs, "seconds": seconds, "force_N": force_n,
        "cell": {"depth_m": depth.depth, "rated_deflection_m": depth.target, "achieved_m": depth.achieved},
        "solid": response.as_dict(), "comparison": comparison,
    })  # fmt: skip
    from ..solid.compare import pose_deg

    title = f"{pose_deg(theta1, theta2)}, {robot.joints.label} joints, {force_n:g} N, {mesh_mm:g} mm mesh"
    figures = {"readings.png": lambda: readings_figure(phi, check.solid_curves, check.frame_curves, title)}
    if response.stresses is not None:
        figures["stress.png"] = lambda: solid_stress_figure(response, np.radians(Protocol().stress_phi_deg), force_n, title)
    for name, make in figures.items():
        write_figure(output / name, make(), dpi=dpi)
    _print_comparison(Console(), comparison, response, depth, seconds, output)


def _print_comparison(console: Console, comparison: dict, response, depth, seconds: float, output: Path) -> None:
    table = Table(title="solid against frame (amplitude ratio, phase difference)")
    table.add_column("reading")
    for i in (1, 2):
        table.add_column(f"cell {i} ratio", justify="right")
        table.add_column(f"cell {i} Δphase [°]", justify="right")
    for name, row in comparison.items():
        cells = []
        for i in range(2):
            cells += [f"{row['ratio'][i]:.4f}", f"{row['phase_difference_deg'][i]:+.3f}"]
        table.add_row(name, *cells)
    console.print(table)
    console.print(f"cell depth {depth.depth * 1e3:.3f} mm (rated deflection {depth.achieved * 1e3:.4f} mm of "
                  f"{depth.target * 1e3:g}); {response.dofs} DOF, {seconds:.1f} s; "
                  f"equilibrium |T1 + T2 - A x F| <= {response.moment_balance.max():.2g} N·m/N; wrote {output}",
                  highlight=False)  # fmt: skip


#: What solid-sweep writes into its output folder; none of them may be one of its inputs.
SWEEP_OUTPUTS = ("poses.csv", "results.json", "table4.csv", "table4_comparison.csv", "table4.png")


@cli.command("solid-sweep")
@click.option("--protocol", "protocol_spec", default="seed", show_default=True, metavar="seed|FILE",
              help="seed: the seed's two sweeps (16 poses, Table 4); or a CSV file with columns theta1_deg, theta2_deg.")
@robot_option
@joints_choice
@mesh_option
@cache_option
@click.option("--no-cache", is_flag=True, help="Solve every pose again (the cache is neither read nor written).")
@click.option("--workers", type=click.IntRange(1, 512), default=None,
              help="Run on a Dask cluster of N worker processes on this machine.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run on an existing Dask cluster (tcp://HOST:PORT; see `dask scheduler`, `dask worker`).")
@click.option("--retries", type=click.IntRange(0, 10), default=2, show_default=True,
              help="Times a pose whose task failed or whose worker died is tried again.")
@click.option("--dpi", type=click.IntRange(50, 600), default=110, show_default=True, help="Figure resolution.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Directory for poses.csv, results.json and, for the seed protocol, table4.csv and table4.png.")
def solid_sweep_command(protocol_spec, robot_path, joints, mesh_mm, cache_dir, no_cache, workers, scheduler,
                        retries, dpi, quiet, output):  # fmt: skip
    """Solve the solid at many poses, each pose one task, cached, here or on Dask.

    With --protocol seed, writes the solid's Table 4 beside the frame's and
    the seed's (table4.csv, table4.png).  A pose that keeps failing is
    listed with its error, in results.json and here, and the exit code is 1.
    """
    from ..distributed import ClusterError
    from ..paper.seed import seed_table4
    from ..paper.study import TABLE4_COLUMNS, table4, table4_from_rows
    from ..solid.sweep import default_cache_dir, read_poses, response_rows, run_poses, seed_poses
    from . import DataError

    inputs = {"the --robot file": robot_path, "the --protocol file": None if protocol_spec == "seed" else protocol_spec}
    for name in SWEEP_OUTPUTS:
        check_output(output / name, inputs)
    protocol = Protocol()
    if protocol_spec == "seed":
        poses, sweeps = seed_poses(protocol)
    else:
        try:
            poses, sweeps = read_poses(Path(protocol_spec)), None
        except FileNotFoundError:
            raise click.BadParameter(f"{protocol_spec}: no such file (expected 'seed' or a CSV of poses)",
                                     param_hint="--protocol") from None  # fmt: skip
    robot = _prepare(robot_path, joints)
    settings = _settings(mesh_mm)
    cache = None if no_cache else (cache_dir or default_cache_dir())
    console = Console(stderr=True)
    started = time.perf_counter()
    with progress_bar(console, f"solid poses ({mesh_mm:g} mm)", len(poses), unit="poses", quiet=quiet) as advance:
        try:
            result = run_poses(robot, poses, settings, cache_dir=cache, workers=workers, scheduler=scheduler,
                               retries=retries, advance=advance)  # fmt: skip
        except ClusterError as exc:
            raise click.UsageError(str(exc)) from None
    seconds = time.perf_counter() - started
    output.mkdir(parents=True, exist_ok=True)
    _write_poses(output / "poses.csv", result)
    summary: dict = {"protocol": protocol_spec, "joints": robot.joints.label, "mesh_mm": mesh_mm,
                     "poses": len(poses), "cached": result.cached, "seconds": seconds,
                     "cell_depth_m": result.depth.depth if result.depth else None,
                     "failures": [{"theta1_deg": math.degrees(poses[k][0]), "theta2_deg": math.degrees(poses[k][1]),
                                   "error": error} for k, error in sorted(result.failures.items())]}  # fmt: skip
    if sweeps is not None:
        rows = [response_rows(result, s) for s in sweeps]
        if rows[0] is not None and rows[1] is not None:
            tables = {"solid": table4_from_rows(robot.arm, protocol, rows[0], rows[1]), "frame": table4(robot),
                      "seed": seed_table4()}  # fmt: skip
            write_numeric_table(output / "table4.csv", TABLE4_COLUMNS, tables["solid"], csv_format="%.8g")
            from ..report.solid_figure import write_table4_comparison

            write_table4_comparison(output, tables, dpi)
            summary["table4"] = {name: t.tolist() for name, t in tables.items()}
            from ..solid.compare import torque_against_jt

            torques = np.stack([r.torques for r in result.responses if r is not None])
            summary["torque_vs_jt_max_relative"] = torque_against_jt(robot, poses, torques)
    write_json(output / "results.json", summary)
    print_notes(console, result.notes)
    console.print(f"{len(poses)} poses ({result.cached} from the cache) in {seconds:.1f} s; wrote {output}", highlight=False)
    if result.failures:
        for item in summary["failures"]:
            console.print(f"pose θ1 = {item['theta1_deg']:g}°, θ2 = {item['theta2_deg']:g}° failed: {item['error']}",
                          highlight=False, markup=False)  # fmt: skip
        raise DataError(f"{len(result.failures)} of {len(poses)} poses failed (listed above and in results.json)")


def _write_poses(path: Path, result) -> None:
    names = ["theta1_deg", "theta2_deg", "ok"] + [f"{q}_{i}{j}" for q in ("torque", "deflection", "relative")
                                                  for i in (1, 2) for j in ("x", "y")]  # fmt: skip
    rows = [[math.degrees(a), math.degrees(b), float(response is not None)]
            + ([np.nan] * 12 if response is None else
               np.concatenate([response.torques.ravel(), response.deflection.ravel(), response.relative.ravel()]).tolist())
            for (a, b), response in zip(result.poses, result.responses)]  # fmt: skip
    write_numeric_table(path, names, rows, csv_format="%.10g")  # the ok flag reads 1 or 0


@cli.command("cell-fit")
@robot_option
@mesh_option
@click.option("--link", type=click.Choice(("l1", "l2")), default="l1", show_default=True,
              help="The link whose section holds the cell in the fitting solid.")
@click.option("--check/--no-check", default=True, show_default=True,
              help="Solve the arm at θ1 = 75°, θ2 = 0 with pin and bonded joints and compare the frame before and after.")
@cache_option
@click.option("--force", is_flag=True, help="Replace OUTPUT if it exists.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The robot file to write: --robot's, with the fitted compliance in [loadcells].")
def cell_fit_command(robot_path, mesh_mm, link, check, cache_dir, force, output):
    """Fit the load cell's in-situ 2x2 compliance from a solid of the cell between link stubs.

    The datasheet fixes only the cell's tip compliance; in the arm its faces
    are bonded to link bars, which yield too.  Writes a robot file with
    compliance = "matrix" and the fitted compliance_vv, compliance_vm,
    compliance_mm, after which the frame's readings follow the solid's.
    """
    from ..io.robotfile import template
    from ..solid.cache import SolidCache
    from ..solid.cell import fit_compliance, with_compliance
    from ..solid.sweep import cell_depth, default_cache_dir

    if output.exists() and not force:
        raise click.UsageError(f"{output} already exists; pass --force to replace it")
    check_output(output, {"the --robot file": robot_path})
    robot = _prepare(robot_path, None)
    settings = _settings(mesh_mm)
    console = Console(stderr=True)
    cache = SolidCache(cache_dir or default_cache_dir())
    with console.status("calibrating the cell's depth and fitting its compliance"):
        depth = cell_depth(robot, settings, cache)
        fit = fit_compliance(robot, depth, settings.mesh_size, link)
    print_notes(console, cache.notes)
    fitted = with_compliance(robot, fit)
    out = Console()
    table = Table(title=f"load-cell compliance, in {link} (near face clamped; far face loaded)")
    for column in ("", "datasheet beam", "in situ (solid)", "ratio"):
        table.add_column(column, justify="right")
    for (i, j), label in zip(((0, 0), (0, 1), (1, 1)), ("c_vv [m/N]", "c_vm [1/N]", "c_mm [1/(N·m)]")):
        ratio = fit.compliance[i, j] / fit.datasheet[i, j]
        table.add_row(label, f"{fit.datasheet[i, j]:.5g}", f"{fit.compliance[i, j]:.5g}", f"{ratio:.4f}")
    out.print(table)
    if check:
        _check_fit(out, robot, fitted, depth, settings)
    with atomic_writer(output) as stream:
        stream.write(template(fitted))
    out.print(f"wrote {output} (cell depth {depth.depth * 1e3:.3f} mm in the solid)", highlight=False)


def _check_fit(console: Console, robot, fitted, depth, settings) -> None:
    from ..solid.arm import solve_pose
    from ..solid.compare import compare

    theta1, theta2 = (math.radians(a) for a in CHECK_POSE_DEG)
    table = Table(title=f"far-face deflection amplitude, solid / frame, at θ1 = {CHECK_POSE_DEG[0]:g}°, θ2 = {CHECK_POSE_DEG[1]:g}°")
    for column in ("joints", "datasheet cell 1", "cell 2", "fitted cell 1", "cell 2"):
        table.add_column(column, justify="right")
    for joints in ("pin", "bonded"):
        with console.status(f"checking: the solid with {joints} joints"):
            response = solve_pose(robot.with_joints(joints), theta1, theta2, cell_depth=depth.depth, mesh_size=settings.mesh_size)
        before = compare(robot.with_joints(joints), response)["deflection"]["ratio"]
        after = compare(fitted.with_joints(joints), response)["deflection"]["ratio"]
        table.add_row(joints, *(f"{r:.4f}" for r in (*before, *after)))
    console.print(table)
