"""``sail estimate``: end-effector force for every reading of a file, stdin or a serial port."""

from __future__ import annotations

import sys
from contextlib import ExitStack, nullcontext
from pathlib import Path

import click
import numpy as np
from rich.console import Console

from .. import kernel
from ..calibration.file import Calibration
from ..errors import InputError
from ..io.files import atomic_writer, check_output, table_format
from ..io.rosbag import BagWriter, Topics, is_bag, read_bag
from ..io.tables import READING_COLUMNS, csv_header, input_size, is_parquet, parquet_schema
from ..io.xdf import is_xdf, read_xdf
from ..stream.pipeline import estimate_lines, stream_estimate, table_motion
from . import cli
from ._options import bag_topic_options, latency_option, lowpass_options, make_lowpass, readings_parquet
from ._progress import progress_bar, skipped_note

#: A live stream is estimated in blocks at most this often [ms]: a 1 kHz stream in blocks of about ten lines, each
#: estimate's fixed cost shared, for at most 10 ms of added delay (bench/bench_stream.py measures both).
BLOCK_MS = 10.0

#: The columns a bag's messages need beyond the readings: each row's time, and the measured rates as velocities.
BAG_ALSO = ("t_s", "omega1_dps", "omega2_dps")
#: The column an LSL outlet's stamps and nominal rate come from.
LSL_ALSO = ("t_s",)


@cli.command("estimate")
@click.option("--calibration", "cal_path", type=click.Path(dir_okay=False, path_type=Path), required=True, help="Calibration JSON.")
@click.argument("source", metavar="IN.csv", required=False, type=click.Path(allow_dash=True, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, allow_dash=True, path_type=Path), default=None,
              help="OUT.csv or OUT.parquet to write; '-' or absent with a live stream: stdout (live output is CSV).")
@click.option("--serial", "serial_port", default=None, metavar="PORT",
              help="Read the live stream from a serial port (pyserial URL or device).")
@click.option("--baud", type=click.IntRange(1), default=115200, show_default=True, help="Serial baud rate.")
@click.option("--columns", default=None, metavar="NAMES",
              help="--serial: the stream's column names (comma-separated), for a device that sends no header line; "
              "without it, lines before the first header line are skipped (a port joined mid-stream).")
@click.option("--lsl-in", "lsl_in", default=None, metavar="NAME",
              help="Read the live stream from the Lab Streaming Layer stream NAME (theta1_deg, theta2_deg, load1, load2[, t_s]).")
@click.option("--lsl-out", "lsl_out", default=None, metavar="NAME",
              help="Publish a live stream's force as the Lab Streaming Layer stream NAME (fx_N, fy_N, force_N, angle_deg, "
                   "status), each sample stamped with its reading's own time on LSL's clock (docs/guide/live.md).")
@latency_option
@click.option("--mcap-out", "mcap_out", type=click.Path(dir_okay=False, path_type=Path), default=None, metavar="FILE.mcap",
              help="Also write a ROS 2 bag (MCAP, CDR): the wrench, joint states, loads and status of every row with a "
                   "t_s, stamped in the input's seconds (docs/guide/ros-lsl.md).")
@click.option("--mcap-topic", "mcap_topics", multiple=True, metavar="KIND=/NAME",
              help="--mcap-out: rename a topic, KIND one of wrench, joints, loads, status (default /sail/wrench, "
                   "/sail/joint_states, /sail/loads, /sail/status); repeatable.")
@bag_topic_options
@click.option("--stream", "xdf_stream", default=None, metavar="NAME",
              help="REC.xdf: the stream of readings (channels labelled theta1_deg, theta2_deg, load1, load2, others pass "
                   "through); t_s is pyxdf's synchronised, dejittered LSL time.")
@click.option("--rezero", is_flag=True,
              help="Re-zero the cells whenever the handle is free (a quiet window, and contact 0 if the table has a "
                   "contact column): the offsets follow the drift, within limits; adds offset1, offset2 and rezero "
                   "(1 where new offsets begin) before status (docs/reference/drift.md).  Needs t_s.")
@click.option("--rezero-log", "rezero_log", type=click.Path(dir_okay=False, path_type=Path), default=None,
              metavar="LOG.csv", help="--rezero: write every decision, made or refused, with its time and reason.")
@click.option("--block-ms", "block_ms", type=click.FloatRange(0.0, 1000.0), default=BLOCK_MS,
              show_default=True, help="A live stream (stdin, --serial) is estimated in blocks at most this often [ms]: "
              "each line waits at most that long for the lines after it, and the estimate's fixed cost is shared "
              "(0: every line as it comes). The output bytes do not depend on it.")  # fmt: skip
@click.option("-q", "--quiet", is_flag=True, help="No progress display (on a terminal, a bar; elsewhere, a line every few seconds).")
@lowpass_options
def estimate_command(cal_path, source, output, serial_port, baud, columns, lsl_in, lsl_out, latency_ms, mcap_out, mcap_topics,
                     joint_topic, load_topic, xdf_stream, rezero, rezero_log, block_ms, quiet, lowpass_hz, sample_rate_hz,
                     lowpass_order):  # fmt: skip
    """Estimate the end-effector force for every row of IN.csv (or .parquet).

    Output: each input line as it was, then fx_N, fy_N, force_N, angle_deg
    and status (ok, singular, saturated, extrapolated, invalid), one row per
    input line, in order; status is always a row's last field.  IN.csv '-'
    reads a live stream from stdin; --serial reads one from a port, --lsl-in
    from a Lab Streaming Layer stream (until its outlet closes); each
    estimate is then written and flushed as its line arrives, and Ctrl-C
    ends the recording, keeping what was written.  A summary of the
    statuses goes to stderr.  IN.mcap (or a rosbag2 folder) reads a ROS 2
    bag's joint states and loads (--joint-topic, --load-topic); --mcap-out
    also writes the estimates as one.  REC.xdf --stream NAME reads one
    stream of a LabRecorder file.  --lsl-out also publishes a live stream's
    estimates on Lab Streaming Layer (status as its code; the stream's
    description names the codes).  It runs the numpy force kernel (SAILFORCE_KERNEL=compiled
    picks numba): numba's LLVM costs memory and nothing here is faster for it.

    \b
    In motion: when the calibration has a dynamic term (sail calibrate
    --free-motion, or --dynamics prior) and the table has t_s [s] (or
    measured omega1_dps, omega2_dps, alpha1_dps2, alpha2_dps2), the
    inertial and gravity load is subtracted and written as inertial1,
    inertial2 (reading units) before status.  Rows within half the
    differentiator's window of the start, of the end or of a gap get the
    status motion-unknown and no force.  A live stream's rows then come out
    half a window late (50 ms with the default window), each when its
    window is complete.  --sample-rate-Hz sets the sampling period; by
    default it is the median of the first 64 time steps.
    """
    kernel.prefer_backend("numpy")
    console = Console(stderr=True)
    given = [name for name, on in (("IN.csv", source is not None), ("--serial", serial_port is not None),
                                   ("--lsl-in", lsl_in is not None)) if on]  # fmt: skip
    if len(given) > 1:
        raise click.UsageError(f"give one input, not both {' and '.join(given)}")
    if not given:
        raise click.UsageError("give IN.csv, '-' for stdin, --serial PORT or --lsl-in NAME")
    live = serial_port is not None or lsl_in is not None or str(source) == "-"
    if columns is not None and serial_port is None:
        raise click.UsageError("--columns names a serial stream's columns: use it with --serial")
    if lsl_out is not None and not live:
        raise click.UsageError("--lsl-out publishes a live stream ('-', --serial or --lsl-in); a file has no live time")
    check_output(output, {"the input table": source, "the --calibration file": cal_path})
    if mcap_out is not None:
        check_output(mcap_out, {"the input table": source, "the --calibration file": cal_path, "-o": output})
    if rezero_log is not None:
        if not rezero:
            raise click.UsageError("--rezero-log logs the re-zeros: give --rezero too")
        check_output(rezero_log, {"the input table": source, "the --calibration file": cal_path, "-o": output})
    topics = _topics(mcap_topics)
    if (xdf_stream is not None) != (source is not None and is_xdf(source)):
        raise click.UsageError("--stream NAME picks the stream of an XDF file: give both REC.xdf and --stream"
                               if xdf_stream is None else "--stream picks a stream of REC.xdf: the input is not an .xdf file")
    if source is not None and str(source) != "-" and source.is_dir() and not is_bag(source):
        raise click.BadParameter(f"{source} is a folder, not a table (a rosbag2 folder holds metadata.yaml)",
                                 param_hint="IN.csv")  # fmt: skip
    if output is not None and str(output) != "-":
        table_format(output, parquet=not live)
    elif not live:
        raise click.UsageError("a file input needs -o OUT.csv (or OUT.parquet)")
    cal = Calibration.load(cal_path)
    lowpass = make_lowpass(lowpass_hz, sample_rate_hz, lowpass_order, rate_alone=cal.dynamics is not None)
    if sample_rate_hz is not None and not sample_rate_hz > 0:
        raise click.BadParameter(f"{sample_rate_hz:g} Hz is not a sample rate", param_hint="--sample-rate-Hz")
    dt = None if sample_rate_hz is None else 1.0 / sample_rate_hz
    zero = _rezero(cal) if rezero else None
    with ExitStack() as stack:
        if not live and is_bag(source):
            source = _bag_table(source, joint_topic, load_topic, stack, console)
        elif not live and is_xdf(source):
            source = readings_parquet(read_xdf(source, xdf_stream), stack)
        if cal.dynamics is not None and not live:
            _warn_if_static(console, cal, source)
        if cal.temperature is not None and not live:
            _warn_if_no_temperature(console, cal, source)
        bag = stack.enter_context(BagWriter(mcap_out, topics)) if mcap_out is not None else None
        if live:
            counts = _live(cal, output, serial_port, baud, lsl_in, lsl_out, lowpass, dt, console, columns, bag,
                           latency_ms / 1e3, zero, block_ms / 1e3)  # fmt: skip
        else:
            on_rows = None if bag is None else (lambda chunk, columns, status: bag.write(chunk.values, columns, status))
            unit = "rows" if is_parquet(source) else "bytes"
            with progress_bar(console, "estimating", total=input_size(source), unit=unit, quiet=quiet) as advance:
                counts = stream_estimate(cal, source, output, lowpass=lowpass, dt=dt, on_chunk=lambda rows, size: advance(size),
                                         on_rows=on_rows, also=BAG_ALSO if bag is not None else (), rezero=zero)  # fmt: skip
    if bag is not None:
        untimed = f"; {bag.untimed:,} rows without a t_s left out" if bag.untimed else ""
        console.print(f"wrote {mcap_out}: {bag.rows:,} rows on {bag.topics.wrench}, {bag.topics.joints}, "
                      f"{bag.topics.loads}, {bag.topics.status}{untimed}", highlight=False, soft_wrap=True)  # fmt: skip
    total = sum(counts.values())
    if cal.dynamics is None:
        counts.pop("motion-unknown")
    summary = ", ".join(f"{name} {n:,}" for name, n in counts.items())
    console.print(f"{total:,} rows: {summary}" + ("" if live else f"; wrote {output}"), highlight=False)
    for line in status_reasons(cal, counts):
        console.print(line, highlight=False, soft_wrap=True)
    if zero is not None:
        _report_rezero(console, zero, rezero_log)


def _rezero(cal):
    from ..estimate.rezero import ReZero

    return ReZero(lambda theta1, theta2, load1, load2: cal.estimate(theta1, theta2, load1, load2, static=True)[:2],
                  tuple(cal.offsets))  # fmt: skip


#: Refusals the summary lists; --rezero-log has them all.
SHOWN_REFUSALS = 3


def _report_rezero(console, zero, log: Path | None) -> None:
    made = [e for e in zero.events if e.applied]
    refused = [e for e in zero.events if not e.applied]
    last = f"; the offsets now {zero.delta[0]:+.6g}, {zero.delta[1]:+.6g} raw from the calibration's" if made else ""
    console.print(f"re-zero: {len(made):,} made, {len(refused):,} refused{last}", highlight=False, soft_wrap=True)
    for event in refused[:SHOWN_REFUSALS]:
        console.print(f"  refused at {event.t_s:.6g} s: {event.reason}", highlight=False, soft_wrap=True)
    if len(refused) > SHOWN_REFUSALS:
        console.print(f"  ... and {len(refused) - SHOWN_REFUSALS:,} more" + ("" if log else " (--rezero-log lists them)"),
                      highlight=False)  # fmt: skip
    if log is not None:
        with atomic_writer(log, "w") as out:
            out.write("t_s,applied,delta1,delta2,step_N,total_N,reason\n")
            for e in zero.events:
                reason = e.reason.replace('"', "'")
                out.write(f'{e.t_s!r},{int(e.applied)},{e.delta[0]!r},{e.delta[1]!r},{e.step_N!r},{e.total_N!r},"{reason}"\n')
        console.print(f"wrote {log}: {len(zero.events):,} re-zero decisions", highlight=False)


def status_reasons(cal, counts: dict[str, int]) -> list[str]:
    """Why rows are extrapolated or motion-unknown, for the summary: the calibration's range and the rate window."""
    from ..motion.differentiate import MAX_JOINT_ACCEL, MAX_JOINT_RATE

    reasons = []
    if counts.get("extrapolated"):
        lo, hi = np.degrees(cal.delta_range)
        reasons.append(f"extrapolated: delta = theta1 - theta2 outside the calibrated {lo:.4g} .. {hi:.4g} deg (the force "
                       "is given, less accurate)")  # fmt: skip
    if counts.get("motion-unknown") and cal.dynamics is not None:
        half = cal.dynamics.differentiator.window_s / 2
        reasons.append(f"motion-unknown: within {half * 1e3:g} ms (half the rate window) of the start, the end, a gap "
                       f"or an invalid row, or moving faster than an arm can ({MAX_JOINT_RATE:g} rad/s, "
                       f"{MAX_JOINT_ACCEL:g} rad/s^2): no force")  # fmt: skip
    if counts.get("motion-unknown") and cal.multirate:
        reasons.append(f"motion-unknown ({cal.adc.model}): before both cells have a conversion whose whole "
                       f"{cal.adc.settling_s * 1e3:g} ms window lies in the recording, or a window over a gap or unknown "
                       "rates: no force")  # fmt: skip
    return reasons


def _warn_if_static(console, cal, source) -> None:
    header = csv_header(source, READING_COLUMNS)
    names = header.names if header is not None else list(parquet_schema(source, READING_COLUMNS).names)
    if table_motion(cal, source, names) is None:
        console.print(f"warning: the calibration has a dynamic term, but {source} has no t_s column (nor measured "
                      "rates): the estimates are static, right only while the arm is at rest", highlight=False)  # fmt: skip


def _warn_if_no_temperature(console, cal, source) -> None:
    header = csv_header(source, READING_COLUMNS)
    names = header.names if header is not None else list(parquet_schema(source, READING_COLUMNS).names)
    if "temperature_C" not in names:
        console.print(f"warning: the calibration has temperature coefficients (about {cal.temperature.reference_C:.4g} "
                      f"degC), but {source} has no temperature_C column: the loads are taken as at that temperature",
                      highlight=False, soft_wrap=True)  # fmt: skip


def _topics(pairs) -> Topics:
    """``--mcap-topic KIND=/NAME`` options as :class:`Topics`."""
    names = {}
    for pair in pairs:
        kind, _, name = pair.partition("=")
        if kind not in Topics.__dataclass_fields__ or not name:
            raise click.BadParameter(f"{pair!r}: give KIND=/NAME with KIND one of {', '.join(Topics.__dataclass_fields__)}",
                                     param_hint="--mcap-topic")  # fmt: skip
        names[kind] = name
    try:
        return Topics(**names)
    except InputError as exc:
        raise click.BadParameter(str(exc), param_hint="--mcap-topic") from None


def _bag_table(source: Path, joint_topic: str, load_topic: str, stack: ExitStack, console) -> Path:
    """A bag's readings as a Parquet table in a temporary folder, for the file pipeline; unpaired messages reported."""
    readings = read_bag(source, joint_topic, load_topic)
    for topic, n in readings.unpaired.items():
        if n:
            console.print(f"note: {n:,} messages on {topic} have no partner of the same stamp on the other topic: "
                          "not estimated", highlight=False)  # fmt: skip
    return readings_parquet(readings.table, stack)


def _live(cal, output, serial_port, baud, lsl_in, lsl_out, lowpass, dt, console, columns=None, bag=None, latency_s=0.0,
          rezero=None, block_s=0.0):  # fmt: skip
    """A live stream to stdout or to a file written atomically; an interrupt keeps what was recorded."""
    from ..live import sources
    from ..live.pipeline import StampedLines, bag_listener, rows_of

    to_file = output is not None and str(output) != "-"
    name = f"serial port {serial_port}" if serial_port is not None else f"LSL stream {lsl_in}" if lsl_in else "stdin"

    def report(stage) -> None:
        if stage is None:
            console.print(f"warning: the calibration has a dynamic term, but {name} has no t_s column (nor measured "
                          "rates): the estimates are static, right only while the arm is at rest", highlight=False)  # fmt: skip
        elif stage.delay() != 0:
            late = stage.cal.dynamics.differentiator.window_s / 2
            console.print(f"dynamic term on: each row comes out {late * 1e3:g} ms late (half the rate window), "
                          "when its window is complete", highlight=False)  # fmt: skip

    stamps = StampedLines()
    listeners = [] if bag is None else [bag_listener(bag)]

    def on_rows(chunk, columns, status) -> None:
        rows = rows_of(stamps, chunk, columns, status)  # once: it takes the rows' stamps
        for listener in listeners:
            listener(rows)

    with ExitStack() as stack:
        if lsl_in is not None:
            from ..live.lsl import inlet_blocks

            blocks = inlet_blocks(lsl_in)
        elif serial_port is not None:
            port = stack.enter_context(sources.serial_lines(serial_port, baud))
            stack.callback(lambda: _report_frames(console, port))
            blocks = sources.gathered(sources.from_header(port, columns=columns, on_skipped=skipped_note(console, name)),
                                      seconds_per_byte=sources.serial_seconds_per_byte(baud), period_s=block_s)  # fmt: skip
        else:
            blocks = sources.gathered(sources.stdin_lines(), period_s=block_s)
        if lsl_out is not None:
            listeners.append(_outlet(lsl_out, dt, latency_s, blocks))
            console.print(f"publishing the force as the Lab Streaming Layer stream {lsl_out!r}", highlight=False)
        out = stack.enter_context(atomic_writer(output, "wb", keep_on_interrupt=True) if to_file else nullcontext(sys.stdout.buffer))
        return estimate_lines(cal, stamps.lines(blocks), lambda: out, lowpass=lowpass, source=name, dt=dt, on_motion=report,
                              on_rows=on_rows if listeners else None,
                              also=(*BAG_ALSO, *LSL_ALSO) if bag is not None else LSL_ALSO if lsl_out else (),
                              rezero=rezero)  # fmt: skip


def _report_frames(console, port) -> None:
    """A binary stream's frame counts: every lost tick is a row of its own, marked frame=lost (docs/reference/frames.md)."""
    decoder = getattr(port, "decoder", None)
    if decoder is not None:
        console.print(f"frames: {decoder.frames:,} ticks, {decoder.lost:,} lost (each an invalid row, frame=lost), "
                      f"{decoder.corrupt:,} corrupt (bad CRC or length)", highlight=False, soft_wrap=True)  # fmt: skip


def _outlet(name: str, dt: float | None, latency_s: float, blocks):
    """The --lsl-out outlet: its nominal rate 1 / dt when --sample-rate-Hz gives one, an inlet's own, else probed
    from t_s; its stamps back-dated by latency_s, and an inlet's t_s taken as LSL time."""
    from ..live.lsl import Outlet

    rate = 1.0 / dt if dt is not None else getattr(blocks, "rate_hz", None)
    return Outlet(name, rate_hz=rate, latency_s=latency_s, lsl_time=bool(getattr(blocks, "lsl_time", False)))
