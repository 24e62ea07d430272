"""``sail check-rig``: a rig's recording against the assumptions of its ADC and calibration."""

from __future__ import annotations

import dataclasses
import json
import math
import tempfile
from pathlib import Path

import click
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from ..adc import PRESETS
from ..calibration.file import Calibration
from ..io.files import atomic_writer, check_output
from ..rig import Link, RigCheck, check_rig
from . import cli
from ._options import load_robot, robot_option


def _ms(seconds: float) -> str:
    return "–" if not math.isfinite(seconds) else f"{seconds * 1e3:.3g} ms"


@cli.command("check-rig")
@click.argument("recording", metavar="[REC.csv]", required=False,
                type=click.Path(dir_okay=False, exists=True, path_type=Path))
@click.option("--serial", "serial_port", metavar="PORT", default=None,
              help="Read the rig live from this port instead (binary frames or text lines, told apart), for "
                   "--seconds: adds the link's throughput and its lost and corrupt frames.")
@click.option("--baud", type=click.IntRange(1), default=921600, show_default=True, help="--serial's baud rate.")
@click.option("--seconds", type=click.FloatRange(0.5, 3600), default=10.0, show_default=True,
              help="How long to read --serial.")
@click.option("--record", "record_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="OUT.csv", help="Keep what --serial read (the multi-rate format); else it goes to a temporary file.")
@click.option("--calibration", "cal_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The calibration the rig will run: its ADC, and its cells' capacity for the saturation count.")
@click.option("--adc", "adc_name", type=click.Choice(tuple(PRESETS)), default=None,
              help="The cells' ADC, without a calibration (else the --robot file's [adc]).")
@robot_option
@click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=Path), default=None, metavar="OUT.json",
              help="Also write the numbers and the problems as JSON.")
def check_rig_command(recording, serial_port, baud, seconds, record_path, cal_path, adc_name, robot_path, json_path):
    """Check a rig's recording (the multi-rate format: t_s, the angles, each cell's conversions, loadN_t_s if
    stamped), or the rig itself on --serial PORT, against its ADC and calibration.

    It measures each cell's conversion rate against the ADC's nominal rate,
    its jitter, missed conversions and saturations, the skew between the two
    cells and its drift, and the ticks' period, jitter, gaps, steps back in
    time, rows that are not readings and encoder jumps; with a device_status
    column (the firmware's frames), the ticks with each flag; live, the
    link's bytes and rows a second and its lost and corrupt frames.  One
    screen of results; --json writes them.  Exit code 1 when the rig cannot
    meet an assumption of the calibration or the estimate, each one said.
    """
    if cal_path is not None and (adc_name is not None or robot_path is not None):
        raise click.UsageError("the calibration names its ADC: give --calibration, or --adc / --robot, not both")
    if (recording is None) == (serial_port is None):
        raise click.UsageError("give a recording REC.csv, or --serial PORT to read the rig live (one of them)")
    if record_path is not None and serial_port is None:
        raise click.UsageError("--record keeps what --serial reads: it needs --serial")
    for path in (json_path, record_path):
        if path is not None:
            check_output(path, {"the recording": recording, "the --calibration file": cal_path})
    capacity = offsets = None
    if cal_path is not None:
        cal = Calibration.load(cal_path)
        adc = cal.adc
        capacity, offsets = tuple(cal.capacity), tuple(cal.offsets)
    elif adc_name is not None:
        adc = PRESETS[adc_name]
    else:
        adc = load_robot(robot_path).adc
    console = Console()
    with tempfile.TemporaryDirectory(prefix="sail-check-rig-") as scratch:
        link = None
        if serial_port is not None:
            recording = record_path or Path(scratch) / "rig.csv"
            link = _capture(console, serial_port, baud, seconds, recording)
        result = check_rig(recording, adc, capacity=capacity, offsets=offsets, link=link)
        if link is not None and record_path is None:  # the temporary file is gone: name the port
            result = dataclasses.replace(result, source=f"{serial_port} ({seconds:g} s live)")
    _print(console, result)
    if json_path is not None:
        with atomic_writer(json_path, "w") as out:
            json.dump(result.as_json(), out, indent=2)
        console.print(f"wrote {json_path}", highlight=False)
    if not result.fit:
        raise SystemExit(1)


def _capture(console: Console, port: str, baud: int, seconds: float, out: Path) -> Link:
    from ..live.capture import capture_rig

    with Progress(TextColumn("reading {task.description}"), BarColumn(), TimeRemainingColumn(), console=console,
                  transient=True) as progress:  # fmt: skip
        task = progress.add_task(port, total=seconds)
        link = capture_rig(port, baud, seconds, out, progress=lambda done: progress.update(task, completed=done))
    return link


def _print(console: Console, r: RigCheck) -> None:
    table = Table(title=f"{r.source}: {r.rows:,} rows, ADC {r.adc}", title_justify="left")
    table.add_column("")
    table.add_column("cell 1", justify="right")
    table.add_column("cell 2", justify="right")
    a, b = r.cells
    table.add_row("conversions", f"{a.conversions:,}", f"{b.conversions:,}")
    table.add_row("rate", f"{a.rate_Hz:.5g} Hz", f"{b.rate_Hz:.5g} Hz")
    table.add_row(f"against nominal {a.nominal_Hz:g} Hz", f"{a.rate_error:+.2%}", f"{b.rate_error:+.2%}")
    table.add_row("jitter (rms)", _ms(a.jitter_s), _ms(b.jitter_s))
    table.add_row("missed", f"{a.missed:,}", f"{b.missed:,}")
    table.add_row("saturated", f"{a.saturated:,}", f"{b.saturated:,}")
    table.add_row("data-ready stamped", "yes" if a.stamped else "no (the tick's time)", "yes" if b.stamped else "no (the tick's time)")
    console.print(table)
    drift = "–" if not math.isfinite(r.skew_drift) else f"{r.skew_drift * 1e3:+.3g} ms/s"
    console.print(f"skew cell 2 - cell 1: {_ms(r.skew_s)} (drift {drift})", highlight=False)
    console.print(f"ticks: {r.tick_Hz:.5g} Hz, jitter {_ms(r.tick_jitter_s)} rms, {r.gaps} gaps, {r.steps_back} steps "
                  f"back, {r.invalid_rows} rows not readings, {r.encoder_jumps} encoder jumps", highlight=False)  # fmt: skip
    if r.device_status is not None:
        flags = ", ".join(f"{name} {n:,}" for name, n in r.device_status.items())
        console.print(f"device flags (ticks): {flags}", highlight=False, soft_wrap=True)
    if r.link is not None:
        k = r.link
        frames = f", {k.frames:,} frames, {k.lost:,} lost, {k.corrupt:,} corrupt" if k.binary else " (text lines)"
        console.print(f"link {k.port}: {k.bytes_per_s:,.0f} bytes/s, {k.rows_per_s:,.1f} rows/s over {k.seconds:.3g} s"
                      f"{frames}", highlight=False, soft_wrap=True)  # fmt: skip
    if r.fit:
        console.print("[bold green]fit[/bold green]: the rig meets the ADC's and the estimate's assumptions")
    for problem in r.problems:
        console.print(f"[bold red]problem[/bold red]: {problem}", highlight=False, soft_wrap=True)
