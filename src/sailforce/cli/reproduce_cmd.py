"""``sail reproduce``: the seed paper's whole virtual study, its compensators and its accuracy, with a report."""

from __future__ import annotations

import time
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from ..calibration.regressors import CRITERIA, DEFAULT_CRITERION, DEFAULT_THRESHOLD
from ..fem.response import TRANSDUCTIONS
from ..robot import JOINT_MODELS
from ..study import ModelId, StudyResult, run_study
from . import cli
from ._options import load_robot, resolve_reading, robot_option, robot_with_joints
from ._progress import print_notes

DEFAULT_DPI = 110  #: figure resolution: sharp on screen, ~1 MB of HTML per pass


@cli.command("reproduce")
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Directory for the figures, tables, results.json and report (created if needed).")
@robot_option
@click.option("--joints", type=click.Choice(JOINT_MODELS), default=None,
              help="Passive-joint model. Default: the --robot file's joints, else bonded (closest to the seed's "
              "SolidWorks set-up); given with --robot, it overrides the file's, and says so.")
@click.option("--transduction", type=click.Choice(TRANSDUCTIONS), default=None,
              help="Load-cell signal: far-face deflection [m] (the seed's surrogate) or bridge output [mV/V]. "
              "Default: the --robot file's reading, else deflection.")
@click.option("--criterion", type=click.Choice(CRITERIA), default=DEFAULT_CRITERION, show_default=True,
              help="Order selection for the Table 4 regressors: adjusted R² (the seed's stated rule) or plain R².")
@click.option("--threshold", type=click.FloatRange(0.0, 1.0, min_open=True, max_open=True),
              default=DEFAULT_THRESHOLD, show_default=True, help="The criterion must exceed this.")
@click.option("--compare-joints", type=click.Choice((*JOINT_MODELS, "none")), default="pin", show_default=True,
              help="A second pass with this joint model, compared in the report (skipped if equal to --joints).")
@click.option("--dpi", type=click.IntRange(50, 600), default=DEFAULT_DPI, show_default=True, help="Figure resolution.")
@click.option("--seed-model/--no-seed-model", default=True, show_default=True,
              help="Fit structure families to the seed's Table 4 (\"What was the seed's model?\", about 40 s).")
@click.option("--solid", is_flag=True,
              help="Add the gmsh + CalculiX solid's Table 4 and torque check (16 poses, cached; needs ccx).")
@click.option("--solid-mesh-mm", type=click.FloatRange(0.25, 50.0), default=4.0, show_default=True,
              help="Element size of the solid [mm].")
def reproduce_command(output, robot_path, joints, transduction, criterion, threshold, compare_joints, dpi, seed_model,
                      solid, solid_mesh_mm):  # fmt: skip
    """Run the seed's virtual study (docs/errata.md protocol) and write a report.

    Stress patterns (Fig. 4), sweeps 1 and 2 (Fig. 5), Table 4 by
    least-squares sinusoid fits, polynomial regressors, validation with the
    compensator (Fig. 6, RMSE before and after), and a better compensator
    over the whole workspace, and which frame models could have produced the
    seed's Table 4.  Writes into DIR: fig4_stress.png, fig5_sweeps.png,
    fig6_compensated.png, table4.png, workspace.png, table4.csv,
    results.json, seed_model.json, seed_model.png, report.md and
    report.html (self-contained).
    The comparison pass goes to DIR/<joints>/.
    """
    import sailforce.report  # noqa: F401  (checks the report extra before anything is written)

    console = Console(stderr=True)
    started = time.perf_counter()
    base = robot_with_joints(robot_path, joints, "bonded", console)
    transduction = resolve_reading(base, transduction, "deflection", console)
    output.mkdir(parents=True, exist_ok=True)
    label = base.joints.label
    robots = {label: base} | ({compare_joints: base.with_joints(compare_joints)} if compare_joints not in ("none", label) else {})
    passes = list(robots)
    results: list[StudyResult] = []
    study_seconds = 0.0
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as progress:
        from ..seed_model import FAMILIES

        families = len(FAMILIES) if seed_model else 0
        task = progress.add_task("reproducing", total=3 * len(passes) + 1 + families + (1 if solid else 0))
        for k, model in enumerate(passes):
            robot = robots[model]
            progress.update(task, description=f"study, {model} joints")
            t0 = time.perf_counter()
            result = run_study(robot, transduction, criterion=criterion, threshold=threshold)
            study_seconds += time.perf_counter() - t0
            results.append(result)
            progress.advance(task)
            directory = output if k == 0 else output / model
            directory.mkdir(exist_ok=True)
            progress.update(task, description=f"tables, {model} joints")
            from ..report.results import write_results

            write_results(directory, result)
            progress.advance(task)
            progress.update(task, description=f"figures, {model} joints")
            _write_figures(directory, result, dpi)
            progress.advance(task)
        seed_fits = None
        if seed_model:
            from ..report.seed_model import write_seed_model
            from ..seed_model import seed_model_study

            def fitting(name: str) -> None:
                if progress.tasks[0].description.startswith("seed model"):
                    progress.advance(task)
                progress.update(task, description=f"seed model: {name}")

            seed_fits = seed_model_study(load_robot(robot_path), results[0].protocol, progress=fitting)  # its own joints
            progress.advance(task)
            write_seed_model(output, seed_fits, dpi)
        solid_markdown = None
        if solid:
            progress.update(task, description=f"solid model, {label} joints ({solid_mesh_mm:g} mm)")
            solid_markdown = _solid_pass(output, base, results[0], solid_mesh_mm, dpi)
            progress.advance(task)
        progress.update(task, description="report")
        from ..report.document import write_report

        write_report(output, results[0], results[1] if len(results) > 1 else None, study_seconds, seed_fits, solid_markdown)
        progress.advance(task)

    _print_summary(console, results, output, study_seconds, time.perf_counter() - started)


def _solid_pass(output: Path, robot, study: StudyResult, mesh_mm: float, dpi: int) -> str:
    """The seed protocol's sweeps as solids (cached), written to DIR/solid; the report section's Markdown."""
    from ..fem.response import simulate
    from ..io.files import write_json
    from ..report.solid_figure import write_table4_comparison
    from ..report.solid_section import solid_section
    from ..seed import seed_table4
    from ..solid.arm import check_joints
    from ..solid.sweep import SolidSettings, default_cache_dir, response_rows, run_poses, seed_poses
    from ..study import table4_from_rows
    from . import DataError

    check_joints(robot)
    poses, sweeps = seed_poses(study.protocol)
    started = time.perf_counter()
    result = run_poses(robot, poses, SolidSettings(mesh_size=mesh_mm / 1e3), cache_dir=default_cache_dir())
    seconds = time.perf_counter() - started
    print_notes(Console(stderr=True), result.notes)
    rows = [response_rows(result, s) for s in sweeps]
    if rows[0] is None or rows[1] is None:
        raise DataError(f"the solid failed at {len(result.failures)} poses: {next(iter(result.failures.values()))}")
    tables = {"solid": table4_from_rows(robot.arm, study.protocol, rows[0], rows[1]), "frame": study.table4,
              "seed": seed_table4()}  # fmt: skip
    directory = output / "solid"
    directory.mkdir(exist_ok=True)
    write_table4_comparison(directory, tables, dpi)
    pose_array = np.array(poses)
    frame_torques = simulate(robot, pose_array[:, 0], pose_array[:, 1]).torques
    write_json(directory / "results.json", {"mesh_mm": mesh_mm, "joints": robot.joints.label, "seconds": seconds,
                                            "cached": result.cached, "table4": {n: t.tolist() for n, t in tables.items()}})  # fmt: skip
    return solid_section(robot, result, tables, frame_torques, mesh_mm, seconds)


def _write_figures(directory: Path, result: StudyResult, dpi: int) -> None:
    from ..io.files import write_figure
    from ..report.results import seed_table4
    from ..report.stress_figure import stress_figure
    from ..report.study_figures import compensated_figure, sweeps_figure, table4_figure, workspace_figure

    phi = np.radians(result.protocol.stress_phi_deg)
    figures = {
        "fig4_stress.png": lambda: stress_figure(result.stress_response, phi, result.protocol.force_N),
        "fig5_sweeps.png": lambda: sweeps_figure(result),
        "fig6_compensated.png": lambda: compensated_figure(result),
        "table4.png": lambda: table4_figure(result, seed_table4()),
        "workspace.png": lambda: workspace_figure(result),
    }
    for name, make in figures.items():
        write_figure(directory / name, make(), dpi=dpi)


def _print_summary(console: Console, results: list[StudyResult], output: Path, study_s: float, total_s: float) -> None:
    from ..report.results import SEED_RMSE

    before, after = SEED_RMSE["before"], SEED_RMSE["after"]
    seed = f"{before['t1']:g}/{before['t2']:g} -> {after['t1']:g}/{after['t2']:g}"
    for r in results:
        orders = ", ".join(f"{name} {fit.order}{'' if fit.passed else ' (criterion not met)'}"
                           for name, fit in r.regressors.items())  # fmt: skip
        console.print(
            f"[bold]{r.robot.joints.label} joints[/bold]: prescale k1 = {r.prescale[0]:.4g}, k2 = {r.prescale[1]:.4g}; "
            f"regressor orders {orders}; RMSE T1/T2 [N m] before {r.rmse_before.t1:.3g}/{r.rmse_before.t2:.3g}, "
            f"after {r.rmse_after.t1:.3g}/{r.rmse_after.t2:.3g} (seed: {seed}); "
            f"force RMSE [N] seed compensator {r.force_rmse[ModelId.SEED]:.3g}, matrix {r.force_rmse[ModelId.MATRIX]:.3g}"
        )
    console.print(f"study {study_s:.2f} s, total {total_s:.1f} s; report: {output / 'report.html'} and {output / 'report.md'}")
