"""``sail plan-calibration``: the holds to make on a real rig, in order, and the force error they will give."""

from __future__ import annotations

import math
from pathlib import Path

import click
import numpy as np
from rich.console import Console
from rich.table import Table

from ..adc import PRESETS
from ..errors import InputError
from ..io.files import atomic_writer, write_figure, write_json, write_numeric_table
from ..plan import Plan, Rig, plan_calibration
from ..plan.design import ErrorMap
from ..plan.linear import MODELS
from ..plan.protocol import DEFAULT_CONVERSIONS, STILL_S
from . import cli
from ._options import load_robot, robot_option, spec
from ._progress import progress_bar

#: Files ``sail plan-calibration`` writes into its output directory.
OUTPUTS = ("plan.csv", "predicted.csv", "plan.json", "checklist.md", "plan.png")
#: The columns of plan.csv, one row per hold.
PLAN_COLUMNS = ("hold", "theta1_deg", "theta2_deg", "fx_N", "fy_N", "mass_kg", "direction_deg", "conversions", "hold_s",
                "start_s")


def _range(ctx, param, value):
    low, sep, high = value.partition(":")
    try:
        if not sep:
            raise ValueError
        return (math.radians(float(low)), math.radians(float(high)))
    except ValueError:
        raise click.BadParameter(f"{value!r}: expected LOW:HIGH in degrees, e.g. 30:120") from None


def _masses(ctx, param, value):
    try:
        return tuple(float(m) for m in value.split(",") if m.strip())
    except ValueError:
        raise click.BadParameter(f"{value!r}: expected masses in kg separated by commas, e.g. 0.5,1,2") from None


@cli.command("plan-calibration")
@robot_option
@click.option("--model", type=click.Choice(MODELS), default="physics", show_default=True,
              help="The calibration to plan for: the frame model's physics (offsets, gains and --free keys) or the "
                   "matrix series (offsets and Chebyshev coefficients of --order).")  # fmt: skip
@click.option("--free", default=None, metavar="KEY,KEY,...",
              help="physics: the free robot-file keys. Default: the three joint stiffnesses.")  # fmt: skip
@click.option("--order", type=click.IntRange(0, 8), default=None, help="matrix: the series' order. Default: 3.")
@click.option("--holds", type=click.IntRange(1, 10000), default=24, show_default=True, help="Holds in the plan.")
@click.option("--delta-range", "delta_range", default="30:120", show_default=True, callback=_range, metavar="A:B",
              help="The deltas the rig can hold [deg].")  # fmt: skip
@click.option("--delta-step-deg", type=click.FloatRange(0.1, 90.0), default=5.0, show_default=True,
              help="The candidate deltas' spacing [deg].")  # fmt: skip
@click.option("--theta2-deg", "theta2", default="0", show_default=True, callback=spec("theta2"), metavar="SPEC",
              help="The theta2 values the rig can hold [deg].")  # fmt: skip
@click.option("--directions-deg", "directions", default="0:315:45", show_default=True, callback=spec("directions"),
              metavar="SPEC", help="The pulleys' directions in the world frame [deg].")  # fmt: skip
@click.option("--masses-kg", "masses", default="0.5,1,2", show_default=True, callback=_masses, metavar="LIST",
              help="The masses on the shelf [kg]; the force is m g.")  # fmt: skip
@click.option("--adc", type=click.Choice(sorted(PRESETS)), default=None,
              help="The ADC to plan for. Default: the robot file's; hx711-10 when it has the ideal one.")  # fmt: skip
@click.option("--conversions", type=click.IntRange(1, 10000), default=DEFAULT_CONVERSIONS, show_default=True,
              help="Settled conversions averaged in each hold.")  # fmt: skip
@click.option("--force-N", "force_n", type=click.FloatRange(0.0, min_open=True), default=20.0, show_default=True,
              help="The force the predicted error is stated for [N].")  # fmt: skip
@click.option("--verify", type=click.IntRange(0, 10000), default=0, show_default=True, metavar="DRAWS",
              help="Also fit the model to DRAWS simulated recordings of the plan and report their spread beside the "
                   "prediction (physics: about 1 s a draw).")  # fmt: skip
@click.option("-o", "--output", type=click.Path(file_okay=False, path_type=Path), required=True,
              help=f"Directory for {', '.join(OUTPUTS)} (created if needed).")  # fmt: skip
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
def plan_command(robot_path, model, free, order, holds, delta_range, delta_step_deg, theta2, directions, masses, adc,
                 conversions, force_n, verify, output, quiet):  # fmt: skip
    """Plan a calibration: which holds to make, in which order, and how accurate the result will be.

    The holds are chosen from what the rig can do (deltas, theta2, pulley
    directions, masses) to minimise the predicted force error averaged over
    the workspace, delta = 15..165 deg (I-optimal design on the model
    linearised about the robot file, with each hold's reading noise from its
    ADC).  Writes into DIR: plan.csv (the holds in order), checklist.md (to
    print and tick), predicted.csv and plan.png (the predicted error against
    delta for the plan, the seed's grid and a uniform grid of as many holds)
    and plan.json (the summary).
    """
    robot = load_robot(robot_path)
    keys = None if free is None else tuple(k.strip() for k in free.split(",") if k.strip())
    console = Console()
    try:
        rig = Rig(delta_range, tuple(float(t) for t in np.radians(theta2)), math.radians(delta_step_deg),
                  tuple(float(d) for d in np.radians(directions)), masses)  # fmt: skip
        with progress_bar(console, "planning", None, quiet=quiet) as advance:
            plan = plan_calibration(robot, model, holds=holds, free=keys, order=order, rig=rig, adc=adc,
                                    conversions=conversions, force_N=force_n, progress=lambda done, total: advance(1))  # fmt: skip
        simulated = None
        if verify:
            from ..plan.verify import simulated_spread

            with progress_bar(console, "simulated calibrations", verify, unit="draws", quiet=quiet) as advance:
                simulated = simulated_spread(plan, verify, progress=lambda done, total: advance(1))
    except InputError as exc:
        raise click.UsageError(str(exc)) from None
    output.mkdir(parents=True, exist_ok=True)
    _write(output, plan, simulated)
    _print(console, plan, simulated, output)


def _summary(plan: Plan, simulated: ErrorMap | None) -> dict:
    low, high = plan.rig.delta_range
    maps = {"plan": plan.predicted, "seed_grid": plan.seed_grid, "uniform_grid": plan.uniform}
    if simulated is not None:
        maps["simulated"] = simulated
    summary = {name: {"worst_inside_N": _finite(m.worst_within(low, high)), "worst_N": _finite(float(m.worst_N.max())),
                      "rms_N": _finite(float(np.sqrt(np.mean(m.rms_N**2))))}
               for name, m in maps.items()}  # fmt: skip
    # what a lab sees at run time: each calibration's error with one conversion's noise, against the noise floor
    summary["noise_floor"] = {"worst_inside_N": plan.floor.worst_within(low, high), "worst_N": float(plan.floor_N.max()),
                              "rms_N": float(np.sqrt(np.mean(plan.floor_N**2)))}  # fmt: skip
    for name, m in maps.items():
        if not np.all(np.isfinite(m.worst_N)):
            continue
        seen = plan.seen(m)
        summary[name] |= {"seen_worst_inside_N": seen.worst_within(low, high), "seen_worst_N": float(seen.worst_N.max()),
                          "extrapolation": plan.extrapolation(m), "seen_extrapolation": plan.extrapolation(seen),
                          "seen_over_floor": plan.over_floor(m)}  # fmt: skip
    return summary


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _write(output: Path, plan: Plan, simulated: ErrorMap | None) -> None:
    h = plan.holds
    start = np.concatenate([[0.0], np.cumsum(plan.hold_s)[:-1]])
    direction = np.degrees(np.mod(np.arctan2(h.fy, h.fx), 2 * np.pi))
    rows = np.column_stack([np.arange(1, len(h) + 1), np.degrees(h.theta1), np.degrees(h.theta2), h.fx, h.fy, h.mass_kg,
                            direction, plan.conversions, plan.hold_s, start])  # fmt: skip
    write_numeric_table(output / "plan.csv", PLAN_COLUMNS, rows, csv_format="%.10g")
    head = ["delta_deg", "plan_worst_N", "plan_rms_N", "seed_grid_worst_N", "uniform_grid_worst_N", "noise_floor_N",
            "plan_seen_worst_N"]  # fmt: skip
    table = [np.degrees(plan.predicted.delta), plan.predicted.worst_N, plan.predicted.rms_N, plan.seed_grid.worst_N,
             plan.uniform.worst_N, plan.floor_N, plan.seen(plan.predicted).worst_N]  # fmt: skip
    if simulated is not None:
        head += ["simulated_worst_N", "simulated_rms_N"]
        table += [simulated.worst_N, simulated.rms_N]
    write_numeric_table(output / "predicted.csv", head, np.column_stack(table), csv_format="%.8g")
    write_json(output / "plan.json", {
        "model": plan.model.model, "parameters": list(plan.model.names), "holds": len(h), "budget_holds": plan.budget,
        "adc": plan.adc.model, "conversions_per_hold": plan.conversions_per_hold, "conversions": int(plan.conversions.sum()),
        "total_hold_s": plan.total_s, "force_N": plan.predicted.force_N, "criterion": "I-optimal",
        "delta_range_deg": list(np.degrees(plan.rig.delta_range)), "errors": _summary(plan, simulated),
        "notes": list(plan.notes),
    })  # fmt: skip
    with atomic_writer(output / "checklist.md") as stream:
        stream.write(_checklist(plan))
    from ..report.plan_figure import plan_figure

    write_figure(output / "plan.png", plan_figure(plan, simulated), dpi=110)


def _checklist(plan: Plan) -> str:
    h = plan.holds
    lines = [f"# Calibration checklist: {len(h)} holds, {plan.model.model} model", "",
             f"Each hold: move the arm to the pose, hang the mass over the pulley in the direction given, wait "
             f"{STILL_S:g} s for it to settle, then record the conversions of the {plan.adc.model} the row asks for "
             f"(the hold time includes the filter's settling; {plan.total_s / 60:.1f} min of holds in all).", "",
             "| ✓ | hold | θ1 [deg] | θ2 [deg] | direction [deg] | mass [kg] | fx [N] | fy [N] | conversions | hold [s] |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    previous = None
    for k in range(len(h)):
        pose = (round(math.degrees(h.theta1[k]), 3), round(math.degrees(h.theta2[k]), 3))
        where = f"{pose[0]:g} | {pose[1]:g}" if pose != previous else "〃 | 〃"
        direction = math.degrees(math.atan2(h.fy[k], h.fx[k])) % 360.0
        fx, fy = (round(float(f), 3) + 0.0 for f in (h.fx[k], h.fy[k]))  # no "-0.000"
        lines.append(f"| ☐ | {k + 1} | {where} | {direction:.0f} | {h.mass_kg[k]:g} | {fx:.3f} | {fy:.3f} | "
                     f"{plan.conversions[k]} | {plan.hold_s[k]:.2f} |")
        previous = pose
    low, high = np.degrees(plan.rig.delta_range)
    seen = plan.seen(plan.predicted)
    lines += ["", f"Predicted force error at {plan.predicted.force_N:g} N, worst direction: "
              f"{1e3 * plan.predicted.worst_within(*plan.rig.delta_range):.1f} mN over Δ = {low:g}…{high:g}°, "
              f"{1e3 * plan.predicted.worst_N.max():.1f} mN over Δ = 15…165°.",
              f"With one conversion's noise at run time: {1e3 * seen.worst_within(*plan.rig.delta_range):.1f} mN and "
              f"{1e3 * seen.worst_N.max():.1f} mN, at most {plan.over_floor(plan.predicted):.2f} times an exactly "
              "calibrated arm's.", ""]  # fmt: skip
    return "\n".join(lines)


def _print(console: Console, plan: Plan, simulated: ErrorMap | None, output: Path) -> None:
    for note in plan.notes:
        console.print(f"[yellow]note:[/yellow] {note}", highlight=False)
    low, high = np.degrees(plan.rig.delta_range)
    table = Table(title=f"predicted force error at {plan.predicted.force_N:g} N, worst direction [mN]")
    for head in ("protocol", "holds", f"Δ {low:g}…{high:g}°", "Δ 15…165°", "at run time, Δ 15…165°", "× floor"):
        table.add_column(head, justify="left" if head == "protocol" else "right")
    rows = [("the plan (I-optimal)", plan.budget, plan.predicted), ("the seed's grid", len(plan.seed_holds), plan.seed_grid),
            ("a uniform grid", len(plan.uniform_holds), plan.uniform)]  # fmt: skip
    if simulated is not None:
        rows.append(("the plan, simulated calibrations", plan.budget, simulated))
    for name, n, m in rows:
        inside, worst = m.worst_within(*plan.rig.delta_range), float(m.worst_N.max())
        seen, over = float(plan.seen(m).worst_N.max()), plan.over_floor(m)
        table.add_row(name, str(n), *(f"{1e3 * v:.2f}" if math.isfinite(v) else "cannot determine the model" for v in (inside, worst)),
                      f"{1e3 * seen:.1f}" if math.isfinite(seen) else "", f"{over:.2f}" if math.isfinite(over) else "")  # fmt: skip
    table.add_row("an exact calibration (the noise floor)", "∞", f"{1e3 * plan.floor.worst_within(*plan.rig.delta_range):.2f}",
                  f"{1e3 * plan.floor_N.max():.2f}", f"{1e3 * plan.floor_N.max():.1f}", "1.00")  # fmt: skip
    console.print(table)
    console.print(f"the first columns are the calibration's own error; 'at run time' adds one conversion's noise of the "
                  f"{plan.adc.model}, and '× floor' is that against an exactly calibrated arm's, worst over Δ",
                  highlight=False)  # fmt: skip
    console.print(f"the plan: {plan.budget} holds of {plan.conversions_per_hold} conversions of the {plan.adc.model}, "
                  f"made as {len(plan.holds)} distinct holds (a hold chosen k times is one hold k times as long), "
                  f"{plan.total_s / 60:.1f} min of holds; wrote {', '.join(str(output / n) for n in OUTPUTS)}",
                  highlight=False)  # fmt: skip
