"""``sail reproduce``: the seed paper's whole virtual study, its compensators and its accuracy, with a report."""

from __future__ import annotations

import os
import time
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from ..fem.response import TRANSDUCTIONS
from ..paper.study import ModelId, StudyResult
from ..robot import JOINT_MODELS
from ..sensing.polynomial import CRITERIA, DEFAULT_CRITERION, DEFAULT_THRESHOLD
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
              help="Fit structure families to the seed's Table 4 (\"What was the seed's model?\"; about 25 s on two "
              "cores, a few when cached).")
@click.option("--workers", type=click.IntRange(1, 512), default=None, envvar="SAIL_WORKERS",
              help="Processes that fit the seed-model families, the studies' figures drawn meanwhile. Default: "
              "$SAIL_WORKERS, else one per core.")
@click.option("--no-cache", is_flag=True,
              help="Fit the seed-model families afresh, neither reading nor writing the fit cache "
              "($SAIL_CACHE_DIR, else ~/.cache/sailforce/fits; an entry answers only the same fit by the same code).")
@click.option("--solid", is_flag=True,
              help="Add the gmsh + CalculiX solid's Table 4 and torque check (16 poses, cached; needs ccx).")
@click.option("--solid-mesh-mm", type=click.FloatRange(0.25, 50.0), default=4.0, show_default=True,
              help="Element size of the solid [mm].")
def reproduce_command(output, robot_path, joints, transduction, criterion, threshold, compare_joints, dpi, seed_model,
                      workers, no_cache, solid, solid_mesh_mm):  # fmt: skip
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
    from ..io.cache import default_cache_dir
    from ..paper.seed_model import FAMILIES
    from ..workflows import reproduce

    passes = 1 + (compare_joints not in ("none", base.joints.label))
    columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as progress:
        task = progress.add_task("reproducing", total=3 * passes + 1 + (len(FAMILIES) if seed_model else 0) + (1 if solid else 0))
        steps = [0]

        def step(description: str) -> None:  # each step done when the next starts
            if steps[0]:
                progress.advance(task)
            steps[0] += 1
            progress.update(task, description=description)

        from ..report.results import write_results

        def write_studies(studies) -> None:  # while the seed-model families are fitted on the other cores
            for k, result in enumerate(studies):
                directory = output if k == 0 else output / result.robot.joints.label
                directory.mkdir(exist_ok=True)
                step(f"tables, {result.robot.joints.label} joints")
                write_results(directory, result)
                step(f"figures, {result.robot.joints.label} joints")
                _write_figures(directory, result, dpi)

        run = reproduce(base, transduction=transduction, compare_joints=compare_joints, criterion=criterion,
                        threshold=threshold, seed_model=seed_model, seed_robot=load_robot(robot_path), solid=solid,
                        solid_mesh_size=solid_mesh_mm / 1e3, progress=step, with_studies=write_studies,
                        workers=workers or os.cpu_count() or 1,
                        fit_cache_dir=None if no_cache else default_cache_dir("fits"))  # fmt: skip
        print_notes(console, run.notes)
        if run.seed_model is not None:
            from ..report.seed_model import write_seed_model

            write_seed_model(output, run.seed_model, dpi)
        solid_markdown = _solid_outputs(output, base, run.solid, solid_mesh_mm, dpi) if run.solid is not None else None
        step("report")
        from ..report.document import write_report

        results = list(run.studies)
        write_report(output, results[0], results[1] if len(results) > 1 else None, run.study_seconds, run.seed_model,
                     solid_markdown)  # fmt: skip
        progress.advance(task)

    _print_summary(console, results, output, run.study_seconds, time.perf_counter() - started)


def _solid_outputs(output: Path, robot, solid, mesh_mm: float, dpi: int) -> str:
    """The solid pass written to DIR/solid; the report section's Markdown."""
    from ..io.files import write_json
    from ..report.solid_figure import write_table4_comparison
    from ..report.solid_section import solid_section

    print_notes(Console(stderr=True), solid.result.notes)
    directory = output / "solid"
    directory.mkdir(exist_ok=True)
    write_table4_comparison(directory, solid.tables, dpi)
    write_json(directory / "results.json", {"mesh_mm": mesh_mm, "joints": robot.joints.label, "seconds": solid.seconds,
                                            "cached": solid.result.cached,
                                            "table4": {n: t.tolist() for n, t in solid.tables.items()}})  # fmt: skip
    return solid_section(robot, solid.result, solid.tables, solid.frame_torques, mesh_mm, solid.seconds)


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
