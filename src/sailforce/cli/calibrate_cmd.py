"""``sail calibrate`` and ``sail tare``: calibration files from measurements."""

from __future__ import annotations

from contextlib import ExitStack
from pathlib import Path

import click
import numpy as np
from rich.console import Console

from ..adc import PRESETS
from ..calibration.file import Calibration
from ..calibration.tare import TARE_MAX_SHIFT, tare
from ..errors import SailError
from ..fem.response import TRANSDUCTIONS
from ..fit.calibration import MODEL_KINDS
from ..fit.physics import DEFAULT_TRANSDUCTION
from ..io.files import check_output
from ..io.rosbag import is_bag, read_bag
from ..io.tables import read_clean
from ..io.xdf import is_xdf, read_xdf
from ..workflows import calibration_run, reference_calibration_run
from . import cli
from ._options import (
    bag_topic_options,
    file_only,
    load_robot,
    number_pair,
    readings_parquet,
    reference_options,
    resolve_reading,
    robot_option,
)
from ._progress import progress_bar


def _parse_capacity(ctx, param, value):
    return number_pair(value, positive=True, expected="two positive numbers RAW1,RAW2")


@cli.command("calibrate")
@click.argument("data", metavar="DATA.csv", type=click.Path(path_type=Path))
@robot_option
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True, callback=file_only,
              help="Calibration JSON to write.")
@click.option("--model", "kind", type=click.Choice((*MODEL_KINDS, "auto")), default="auto", show_default=True,
              help="seed: amplitude/phase polynomials per cell; matrix: C(Δ)·Jᵀ Chebyshev map; physics: the robot's "
              "frame model with fitted gains, offsets and joint stiffnesses; auto: the best cross-validated.")
@click.option("--free", "free", default=None, metavar="KEY,KEY,...",
              help="physics: the robot-file keys to fit besides offsets and gains. "
              "Default: joints.P1.stiffness,joints.P2.stiffness,joints.P3.stiffness.")
@click.option("--transduction", type=click.Choice(TRANSDUCTIONS), default=None,
              help="physics: what the cells read, the bridge (shear, with crosstalk) or the far face's deflection. "
              "Default: the --robot file's reading, else bridge.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar.")
@click.option("--capacity", callback=_parse_capacity, default=None, metavar="RAW1,RAW2",
              help="Raw reading (offset removed) at each cell's capacity. Default: estimated from the robot's load-cell rating.")
@click.option("--load-unit", default="raw", show_default=True, help="Label of the load columns' unit, stored in the file.")
@click.option("--free-motion", "free_motion", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="FREE.csv", help="The motors moving the arm with nobody holding the handle (t_s, theta1_deg, "
              "theta2_deg, load1, load2): identifies the inertial and gravity loads to subtract while moving.")
@click.option("--adc", "adc_name", type=click.Choice(tuple(PRESETS)), default=None,
              help="The cells' ADC, overriding the robot file's [adc]: a real one reads DATA (and FREE) as multi-rate "
                   "recordings (t_s, sparse loads) and stores the ADC in the calibration (docs/reference/multirate.md).")
@click.option("--dynamics", type=click.Choice(("prior", "none")), default=None,
              help="Without --free-motion: store the robot file's predicted dynamic term, or none (the default; with "
                   "--reference the default identifies it from DATA).")
@click.option("--reference", "reference", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="REF.csv", help="A six-axis F/T sensor's recording at the handle (t_s, fx, fy, ... in its own "
              "frame, on its own clock): the hand force at every sample of DATA, which then needs only t_s, "
              "theta1_deg, theta2_deg, load1, load2 (docs/guide/reference.md).")
@reference_options
@click.option("--stream", "xdf_stream", default=None, metavar="NAME",
              help="DATA.xdf (a LabRecorder file): the stream of readings and reference forces, its channels labelled "
                   "theta1_deg, theta2_deg, load1, load2, fx_N, fy_N; t_s is pyxdf's LSL time.")
@bag_topic_options
@click.option("--force-topic", default="/sail/reference_wrench", show_default=True,
              help="DATA.mcap: the reference force, a geometry_msgs/msg/WrenchStamped in the base frame [N], paired "
                   "with the joint state and loads of the same stamp.")
def calibrate_command(data, robot_path, output, kind, free, transduction, quiet, capacity, load_unit, free_motion, adc_name,
                      dynamics, reference, reference_on, reference_offsets, max_clock_offset, xdf_stream, joint_topic, load_topic,
                      force_topic):  # fmt: skip
    """Fit offsets and the sensing map from DATA.csv (or .parquet) with reference forces.

    DATA has the columns theta1_deg, theta2_deg, load1, load2 (raw readings
    in any linear unit) and fx_N, fy_N (the applied force); other columns are
    ignored.  DATA.xdf --stream NAME reads one stream of a LabRecorder file,
    its channels labelled with those names; DATA.mcap (or a rosbag2 folder)
    a ROS 2 bag's joint states, loads and reference wrench (--joint-topic,
    --load-topic, --force-topic).  Record several force directions at each of several poses
    spanning the Δ = θ1 − θ2 range the robot will use.

    With --model physics (and auto, which tries it), the robot's frame model
    is fitted and stored as a matrix model over Δ = 15…165° (or the data's
    range, if wider): physics extrapolates beyond the calibrated range where
    its structure is right, and cross-validation keeps auto from choosing it
    where it is not.

    With --reference REF.csv the force comes from a six-axis sensor at the
    handle instead: the clocks are aligned by cross-correlation, the sensor's
    mount angle and offsets fitted, the static map fitted at rest and the
    dynamic term in motion, all from DATA.
    """
    if (xdf_stream is not None) != is_xdf(data):
        raise click.UsageError("--stream NAME picks the stream of an XDF file: give both DATA.xdf and --stream"
                               if xdf_stream is None else "--stream picks a stream of DATA.xdf: DATA is not an .xdf file")
    robot = load_robot(robot_path)
    free_keys = tuple(k.strip() for k in free.split(",") if k.strip()) if free else None
    if (free_keys or transduction) and kind not in ("physics", "auto"):
        raise click.UsageError("--free and --transduction set up the physics model: use them with --model physics or auto")
    check_output(output, {"the calibration data": data, "the --robot file": robot_path, "the --free-motion recording": free_motion,
                          "the --reference recording": reference})  # fmt: skip
    if reference is not None:
        if free_motion is not None or xdf_stream is not None or is_bag(data) or adc_name is not None:
            raise click.UsageError("--reference reads DATA.csv (or .parquet) against the sensor's recording, a reading "
                                   "at every tick; leave out --free-motion, --stream, --adc and bags")  # fmt: skip
        return _calibrate_against_reference(data, reference, robot, output, kind=kind, free=free_keys,
                                            transduction=transduction, capacity=capacity, load_unit=load_unit,
                                            dynamics=dynamics or "fit", on=reference_on, max_offset=max_clock_offset,
                                            offsets=reference_offsets, quiet=quiet)  # fmt: skip
    if free_motion is not None and dynamics is not None:
        raise click.UsageError("--dynamics chooses a dynamic term without --free-motion; give one or the other")
    console = Console()
    if kind in ("physics", "auto"):
        transduction = resolve_reading(robot, transduction, DEFAULT_TRANSDUCTION, console)
    stack = ExitStack()
    if xdf_stream is not None:
        data = readings_parquet(read_xdf(data, xdf_stream), stack)
    elif is_bag(data):
        readings = read_bag(data, joint_topic, load_topic, force_topic)
        for topic, n in readings.unpaired.items():
            if n:
                console.print(f"note: {n:,} messages on {topic} have no partner of the same stamp on the others: not "
                              "used", highlight=False)  # fmt: skip
        data = readings_parquet(readings.table, stack)
    elif data.is_dir():
        raise click.BadParameter(f"{data} is a folder, not a table (a rosbag2 folder holds metadata.yaml)",
                                 param_hint="DATA.csv")  # fmt: skip
    with stack, progress_bar(console, "fitting the physics model", None, unit="starts",
                             quiet=quiet or kind not in ("physics", "auto")) as advance:  # fmt: skip
        run = calibration_run(data, robot=robot, model=kind, free=free_keys, transduction=transduction, capacity=capacity,
                              load_unit=load_unit, free_motion=free_motion, dynamics=dynamics,
                              progress=lambda done, total: advance(1),
                              adc=PRESETS[adc_name] if adc_name is not None else None)  # fmt: skip
    cal, report = run.calibration, run.fit
    if report.physics is not None:
        _print_physics(console, report.physics)
    if run.dynamic_fit is not None:
        _print_dynamics(console, run, free_motion)
    if run.holds is not None:
        h = run.holds
        console.print(f"{cal.adc.model}: {h.used_holds} of {h.holds} holds used; settled conversions (whole window in "
                      f"a hold) {h.settled[0]} of {h.conversions[0]} and {h.settled[1]} of {h.conversions[1]}, the others "
                      "dropped", highlight=False)  # fmt: skip
    if run.multirate is not None:
        _print_multirate(console, run)
    offsets, capacity = cal.offsets, cal.capacity
    cal.save(output)
    low, high = np.degrees(report.delta_range)
    scores = ", ".join(f"{k} {v:.4g} N" for k, v in report.cv_rmse_by_kind.items())
    console.print(f"wrote {output}: model [bold]{report.kind}[/bold] from {report.n_samples} samples at "
                  f"{report.n_deltas} Δ values, Δ = {low:.4g}…{high:.4g}°")  # fmt: skip
    console.print(f"force RMSE: fit {report.fit_rmse_N:.4g} N, cross-validated {report.cv_rmse_N:.4g} N ({scores})")
    console.print(f"offsets {offsets[0]:.6g}, {offsets[1]:.6g} {load_unit}; capacity ±{capacity[0]:.4g}, ±{capacity[1]:.4g} {load_unit}")
    if cal.temperature is not None:
        t, (low_C, high_C) = cal.temperature, cal.metrics["temperature_range_C"]
        se = cal.metrics["temperature_se"]
        zero = ", ".join(f"{v:+.4g} ± {e:.2g}" for v, e in zip(t.zero_per_C, se["zero_per_C"]))
        span = ", ".join(f"{v * 1e6:+.4g} ± {e * 1e6:.2g}" for v, e in zip(t.span_per_C, se["span_per_C"]))
        console.print(f"temperature over {low_C:.3g}…{high_C:.3g} °C, about {t.reference_C:.4g} °C: zero {zero} "
                      f"{load_unit}/°C, span {span} ppm/°C (fit RMSE {cal.metrics['fit_rmse_uncompensated_N']:.4g} N "
                      "without them)", highlight=False, soft_wrap=True)  # fmt: skip
    for note in run.notes:
        console.print(f"[yellow]note:[/yellow] {note}", highlight=False, soft_wrap=True)


def _calibrate_against_reference(data, reference, robot, output, *, kind, free, transduction, capacity, load_unit,
                                 dynamics, on, max_offset, offsets, quiet) -> None:  # fmt: skip
    console = Console()
    if kind in ("physics", "auto"):
        transduction = resolve_reading(robot, transduction, DEFAULT_TRANSDUCTION, console)
    with progress_bar(console, "fitting the physics model", None, unit="starts",
                      quiet=quiet or kind not in ("physics", "auto")) as advance:  # fmt: skip
        result = reference_calibration_run(data, reference, robot=robot, model=kind, free=free,
                                           transduction=transduction, capacity=capacity, load_unit=load_unit,
                                           dynamics=dynamics, on=on, max_offset_s=max_offset,
                                           offsets_N=offsets, progress=lambda done, total: advance(1))  # fmt: skip
    run, rows = result.run, result.rows
    a, f = rows.alignment, rows.frame
    console.print(f"reference: its clock {a.offset_s * 1e3:+.3f} ms from the robot's (correlation {a.coarse_offset_s * 1e3:+.1f} "
                  f"ms, score {a.score:.3g} of 2, the next peak {a.second_score:.3g}); mount {np.degrees(f.mount_rad):.3f} "
                  f"± {np.degrees(f.mount_se_rad):.3f}° on the {f.on}; offsets {_offsets(f)}",
                  highlight=False)  # fmt: skip
    console.print(f"{rows.t.size:,} samples under the reference ({rows.dropped:,} outside it), {int(rows.rest.sum()):,} at "
                  f"rest; the static fit took {result.static_rows:,} of those", highlight=False)  # fmt: skip
    if run.fit.physics is not None:
        _print_physics(console, run.fit.physics)
    if result.dynamic_fit is not None:
        _print_dynamics(console, run, data)
    cal, report = run.calibration, run.fit
    cal.save(output)
    low, high = np.degrees(report.delta_range)
    console.print(f"wrote {output}: model [bold]{report.kind}[/bold] from {report.n_samples} samples at rest over "
                  f"Δ = {low:.4g}…{high:.4g}°; force RMSE: fit {report.fit_rmse_N:.4g} N, cross-validated "
                  f"{report.cv_rmse_N:.4g} N")  # fmt: skip
    for note in run.notes:
        console.print(f"[yellow]note:[/yellow] {note}", highlight=False, soft_wrap=True)


def _offsets(frame) -> str:
    """The reference's offsets for people: with their standard errors when fitted."""
    b, se = frame.offsets_N, frame.offsets_se_N
    if not frame.offsets_fitted:
        return f"{b[0]:+.4g}, {b[1]:+.4g} N (given)"
    return f"{b[0]:+.4f} ± {se[0]:.4f}, {b[1]:+.4f} ± {se[1]:.4f} N (fitted)"


def _print_physics(console: Console, physics) -> None:
    from rich.table import Table

    fit = physics.identification
    table = Table(title="physics model: identified parameters (± 1 standard error)")
    for head in ("parameter", "value", "± SE", "identifiable"):
        table.add_column(head, justify="left" if head == "parameter" else "right")
    for name, value, se, ok in zip(fit.names, fit.values, fit.standard_errors, fit.identifiable):
        table.add_row(name, f"{value:.6g}", f"{se:.3g}", "yes" if ok else "[yellow]no[/yellow]")
    console.print(table)
    console.print(f"physics map stored as Chebyshev order {physics.compensator.order} over Δ = "
                  f"{np.degrees(physics.compensator.delta_range[0]):.4g}…{np.degrees(physics.compensator.delta_range[1]):.4g}° "
                  f"(within {physics.map_error:.2g} of the fitted map)", highlight=False)  # fmt: skip
    at_bound = fit.at_bound()
    if at_bound:
        console.print(f"[yellow]note:[/yellow] {', '.join(at_bound)} ended on a bound: the data push it beyond the "
                      "range allowed (a stiffness at 0.01 is a pin, at 1e7 a bonded joint)")  # fmt: skip


def _print_multirate(console: Console, run) -> None:
    fit = run.multirate
    rates = ", ".join(f"{c.rate_Hz:.4g} Hz (phase {c.phase_s * 1e3:.2f} ms)" for c in fit.clocks)
    console.print(f"dynamic term through the ADC: {fit.conversions} conversions, residual {fit.rmse:.4g} raw, condition "
                  f"{fit.condition:.3g}; the filter's extra delay {fit.delay_s * 1e3:+.2f} ± {fit.delay_se_s * 1e3:.2f} ms; "
                  f"measured clocks {rates}; motion bandwidth {fit.motion_bandwidth_Hz:.3g} Hz", highlight=False)  # fmt: skip
    for warning in fit.warnings:
        Console(stderr=True).print(f"[bold yellow]warning:[/bold yellow] {warning}", highlight=False)


def _print_dynamics(console: Console, run, free_motion: Path) -> None:
    from rich.table import Table

    fit = run.dynamic_fit
    table = Table(title=f"dynamic term from {free_motion}: base parameters [SI] (docs/dynamics.md)")
    for head in ("base parameter", "identified", "robot-file prior"):
        table.add_column(head, justify="left" if head == "base parameter" else "right")
    for name, value, expected in zip(fit.term.combinations, fit.term.values, run.prior.values):
        table.add_row(name, f"{value:.5g}", f"{expected:.5g}")
    console.print(table)
    console.print(f"dynamic fit: residual {fit.rmse_N:.4g} N, cross-validated by blocks {fit.cv_rmse_N:.4g} N, "
                  f"condition number {fit.condition:.3g}, {fit.samples} samples", highlight=False)  # fmt: skip


@cli.command("tare")
@click.argument("calibration", metavar="CAL.json", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("noload", metavar="NOLOAD.csv", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True, callback=file_only,
              help="New calibration JSON.")
@click.option("--force", is_flag=True, help=f"Accept offsets that move by more than {TARE_MAX_SHIFT:.0%} of a cell's capacity.")
def tare_command(calibration, noload, output, force):
    """New offsets from a no-load recording: the mean of its load1 and load2.

    NOLOAD has at least the columns load1 and load2, and at least 10 rows,
    recorded with nothing touching the end effector.  Reports the spread
    (standard deviation) and warns when it exceeds 0.5% of a cell's
    capacity.  Refuses offsets that move by more than 10% of a cell's
    capacity from the calibration's, unless --force.
    """
    check_output(output, {"the no-load recording": noload, "the calibration CAL.json": calibration})
    cal = Calibration.load(calibration)
    values = read_clean(noload, ("load1", "load2"), "A no-load recording")
    result = tare(cal, np.column_stack([values["load1"], values["load2"]]), noload)
    if not force and result.too_far:
        raise SailError(f"{noload}: {result.shift_warnings(cal.load_unit)[0]} --force accepts it")
    offsets, spread = result.offsets, result.spread
    cal.with_offsets(offsets).save(output)
    console = Console()
    console.print(f"wrote {output}: offsets {offsets[0]:.6g}, {offsets[1]:.6g} {cal.load_unit} from {result.samples} samples "
                  f"(were {cal.offsets[0]:.6g}, {cal.offsets[1]:.6g}); spread ±{spread[0]:.3g}, ±{spread[1]:.3g}")  # fmt: skip
    if warning := result.spread_warning():
        Console(stderr=True).print(f"[bold yellow]warning:[/bold yellow] {warning}", highlight=False)
