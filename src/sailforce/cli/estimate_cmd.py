"""``sail estimate``: end-effector force for every reading of a file, stdin or a serial port."""

from __future__ import annotations

import sys
from pathlib import Path

import click
from rich.console import Console
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from ..calfile import Calibration
from ..streaming import estimate_lines, stream_estimate
from . import cli
from ._options import lowpass_options, make_lowpass


@cli.command("estimate")
@click.option("--calibration", "cal_path", type=click.Path(dir_okay=False, path_type=Path), required=True, help="Calibration JSON.")
@click.argument("source", metavar="IN.csv", required=False, type=click.Path(dir_okay=False, allow_dash=True, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True, path_type=Path), default=None,
              help="CSV or .parquet to write; '-' or absent with a live stream: stdout.")
@click.option("--serial", "serial_port", default=None, metavar="PORT", help="Read the live stream from a serial port (pyserial URL or device).")
@click.option("--baud", type=int, default=115200, show_default=True, help="Serial baud rate.")
@lowpass_options
def estimate_command(cal_path, source, output, serial_port, baud, lowpass_hz, sample_rate_hz, lowpass_order):
    """Estimate the end-effector force for every row of IN.csv (or .parquet).

    Output: the input columns untouched, then fx_N, fy_N, force_N, angle_deg
    and status (ok, singular, saturated, extrapolated, invalid), one row per
    input row, in order.  IN.csv '-' reads a live stream from stdin; --serial
    reads one from a port; each estimate is then written and flushed as its
    line arrives.  A summary of the statuses goes to stderr.
    """
    console = Console(stderr=True)
    cal = Calibration.load(cal_path)
    lowpass = make_lowpass(lowpass_hz, sample_rate_hz, lowpass_order)
    live = serial_port is not None or str(source) == "-"
    if source is None and serial_port is None:
        raise click.UsageError("give IN.csv, '-' for stdin, or --serial PORT")
    if live:
        counts = _live(cal, source, output, serial_port, baud, lowpass)
    else:
        if output is None or str(output) == "-":
            raise click.UsageError("a file input needs -o OUT.csv (or OUT.parquet)")
        columns = (SpinnerColumn(), TextColumn("{task.completed:,} rows"), TimeElapsedColumn())
        with Progress(*columns, console=console, transient=True) as progress:
            task = progress.add_task("estimating", total=None)
            counts = stream_estimate(cal, source, output, lowpass=lowpass, on_chunk=lambda n: progress.advance(task, n))
    total = sum(counts.values())
    summary = ", ".join(f"{name} {n:,}" for name, n in counts.items())
    console.print(f"{total:,} rows: {summary}" + ("" if live else f"; wrote {output}"))


def _live(cal, source, output, serial_port, baud, lowpass):
    out = sys.stdout if output is None or str(output) == "-" else open(output, "w", encoding="utf-8")
    try:
        if serial_port is not None:
            import serial

            with serial.serial_for_url(serial_port, baudrate=baud, timeout=None) as port:
                return estimate_lines(cal, _serial_lines(port, serial.SerialException), out, lowpass=lowpass)
        return estimate_lines(cal, sys.stdin, out, lowpass=lowpass)
    finally:
        if out is not sys.stdout:
            out.close()


def _serial_lines(port, closed_error):
    """Lines from a serial port until it closes (the device hangs up or the cable is pulled)."""
    try:
        for raw in iter(port.readline, b""):
            yield raw.decode("utf-8", errors="replace")
    except closed_error:
        return
