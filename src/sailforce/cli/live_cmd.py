"""``sail live``: the arm and its force in a browser page, live, from a serial port, a replay, LSL or the simulated arm."""

from __future__ import annotations

import asyncio
import logging
from contextlib import ExitStack
from pathlib import Path

import click
from rich.console import Console

from .. import kernel
from ..calibration.file import Calibration
from ..errors import SailError
from ..live.recorder import RECORD_FORMATS
from . import cli
from ._options import FINITE, PrimaryOption, latency_option, lowpass_options, make_lowpass, robot_option

#: The shortest token accepted from --token or SAIL_LIVE_TOKEN: 16 characters.
MIN_TOKEN_CHARS = 16


@cli.command("live")
@click.option("--calibration", "cal_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Calibration JSON (required, unless --calibrate runs on the robot file's nominal one).")
@click.option("--calibrate", "plan_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              metavar="PLAN.csv", help="Walk through a calibration plan (`sail plan-calibration`'s plan.csv): each hold's "
              "pose and weight on the page, recorded once settled and still; at the end the recording, the fitted "
              "calibration and the achieved accuracy map are written to --record-dir.")
@click.argument("source", metavar="IN.csv", required=False, type=click.Path(dir_okay=False, allow_dash=True, path_type=Path))
@click.option("--replay", is_flag=True, help="Replay IN.csv at the pace of its t_s column (or of --sample-rate-Hz).")
@click.option("--speed", cls=PrimaryOption, type=FINITE, default=1.0, show_default=True, help="Replay speed (2: twice as fast).")
@click.option("--serial", "serial_port", default=None, metavar="PORT", help="Read the readings from a serial port.")
@click.option("--baud", type=click.IntRange(1), default=115200, show_default=True, help="Serial baud rate.")
@click.option("--columns", default=None, metavar="NAMES",
              help="--serial: the stream's column names, for a device that sends no header (else lines before one are skipped).")
@click.option("--simulate", is_flag=True, help="The simulated arm: reaching movements with a hand pulling toward each "
              "target, 1 kHz, through the synthetic noise model (`make live` calibrates for it).")
@robot_option
@click.option("--rig", type=click.IntRange(0), default=1, show_default=True,
              help="--simulate: which simulated rig (its cells' offsets), as in `sail simulate-motion --rig`.")
@click.option("--lsl-in", "lsl_in", default=None, metavar="NAME",
              help="Read the readings from the Lab Streaming Layer stream NAME (theta1_deg, theta2_deg, load1, load2[, t_s]).")
@click.option("--lsl-out", "lsl_out", default=None, metavar="NAME",
              help="Also publish the force as the Lab Streaming Layer stream NAME (fx_N, fy_N, force_N, angle_deg, status).")
@latency_option
@click.option("--mcap-out", "mcap_out", type=click.Path(dir_okay=False, path_type=Path), default=None, metavar="FILE.mcap",
              help="Also record the session as a ROS 2 bag (MCAP): wrench, joint states, loads and status of every row, "
                   "stamped with its t_s (or, without one, its arrival time); finished when the server stops.")
@click.option("--foxglove", "foxglove_port", type=click.IntRange(0, 65535), is_flag=False, flag_value=8765, default=None,
              metavar="[PORT]", help="Also serve the wrench, joint states and status to Foxglove Studio over its WebSocket "
              "protocol on 127.0.0.1 (port 8765 unless given; 0: any free one); docs/guide/ros-lsl.md shows the layout.")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to serve on; 0.0.0.0 lets other machines see the page (and warns).")
@click.option("--port", type=click.IntRange(0, 65535), default=8050, show_default=True, help="Port (0: any free one).")
@click.option("--allow-host", "allow_hosts", multiple=True, metavar="NAME",
              help="Beyond loopback: also answer requests for this host name (repeatable); IP addresses always are.")
@click.option("--token", envvar="SAIL_LIVE_TOKEN", default=None, metavar="TEXT",
              help="The commands' token (default: a new random one); also from $SAIL_LIVE_TOKEN. At least 16 characters.")
@click.option("--record-dir", type=click.Path(file_okay=False, path_type=Path), default=Path("recordings"), show_default=True,
              help="Where the record button's files and saved calibrations go (named by the server, never overwritten).")
@click.option("--record-format", type=click.Choice(RECORD_FORMATS), default="csv", show_default=True,
              help="The record button's file format (Parquet is converted when a recording stops).")
@click.option("-v", "--verbose", is_flag=True,
              help="Also log pages connecting and commands carried out (refused and malformed messages always are).")
@lowpass_options
def live_command(cal_path, plan_path, source, replay, speed, serial_port, baud, columns, simulate, robot_path, rig, lsl_in,
                 lsl_out, latency_ms, mcap_out, foxglove_port, host, port, allow_hosts, token, record_dir, record_format,
                 verbose, lowpass_hz, sample_rate_hz, lowpass_order):  # fmt: skip
    """Serve a live page of the arm and its force at http://127.0.0.1:8050/.

    \b
    One source of readings:
      IN.csv --replay     a recording, at the pace of its t_s column
      --serial PORT       the rig's serial stream (the lines `sail estimate --serial` reads)
      -                   standard input
      --lsl-in NAME       a Lab Streaming Layer stream
      --simulate          the simulated arm (`make live`)

    The page draws the arm to scale with the force at A, shows |F|, its
    angle, fx, fy and the status, each cell's reading against its
    capacity, and fx, fy and |F| over the last 10 s; it updates over a
    WebSocket at up to 50 Hz with the newest row, however fast the input.
    Every row is estimated by `sail estimate`'s own stream code.  Its tare
    button averages the next N samples into new offsets and uses them at
    once; "save calibration" writes them to a new file in --record-dir.
    Its record button writes the estimated rows (the columns `sail
    estimate` writes) to a new file in --record-dir.  Commands need the
    server's token: the page carries it when opened over a loopback address
    (127.0.0.1, localhost); over any other it asks for the token that this
    command prints.  Requests for a Host name the server does not answer to
    are refused (DNS rebinding).  Ctrl-C stops, closing any recording.

    \b
    --calibrate PLAN.csv walks through a plan of `sail plan-calibration`:
      a tare with no weight on, then for each hold its pose (drawn on the
      arm), its weight and direction; each hold is recorded once the ADC has
      settled and the readings are still; "redo" and "skip" are offered.  At
      the end it writes the recording, the fitted calibration and the
      achieved accuracy map (beside the planned one) to --record-dir.
      Without --calibration it starts from the robot file's nominal map.
    """
    kernel.prefer_backend("numpy")
    console = Console(stderr=True)
    given = [name for name, on in (("IN.csv", source is not None), ("--serial", serial_port is not None),
                                   ("--simulate", simulate), ("--lsl-in", lsl_in is not None)) if on]  # fmt: skip
    if len(given) != 1:
        raise click.UsageError("give one source: IN.csv --replay, '-' (stdin), --serial PORT, --lsl-in NAME or --simulate"
                               + (f" (not {' and '.join(given)})" if given else ""))  # fmt: skip
    if source is not None and str(source) != "-" and not replay:
        raise click.UsageError(f"{source} is a file: add --replay to play it back at its own pace")
    if replay and (source is None or str(source) == "-"):
        raise click.UsageError("--replay plays back a file: give IN.csv")
    if columns is not None and serial_port is None:
        raise click.UsageError("--columns names a serial stream's columns: use it with --serial")
    if robot_path is not None and not simulate and plan_path is None:
        raise click.UsageError("--robot sets up the simulated arm or a guided calibration: use it with --simulate or --calibrate")
    if cal_path is None and plan_path is None:
        raise click.UsageError("give --calibration CAL.json (or --calibrate PLAN.csv, which can start from the robot file)")
    if not speed > 0:
        raise click.BadParameter(f"{speed:g}: a replay speed is a positive number (1 is real time)", param_hint="--speed")
    guide_plan, robot = None, None
    if plan_path is not None:
        from ..live.guide import read_plan
        from ._options import load_robot

        guide_plan, robot = read_plan(plan_path), load_robot(robot_path)
    if cal_path is not None:
        cal = Calibration.load(cal_path)
    else:
        from ..workflows import nominal_calibration

        cal = nominal_calibration(robot)
        console.print("no --calibration: the page estimates with the robot file's nominal map; the guide's first step "
                      "tares it", highlight=False)  # fmt: skip
    if guide_plan is not None and cal.multirate:
        raise click.UsageError("--calibrate reads a synchronous stream (both loads on every row); this calibration "
                               "has a real ADC's multi-rate estimate: give one with the ideal ADC")  # fmt: skip
    lowpass = make_lowpass(lowpass_hz, sample_rate_hz, lowpass_order, rate_alone=True)
    dt = None if sample_rate_hz is None else 1.0 / sample_rate_hz
    logging.basicConfig(format="sail live: %(message)s", level=logging.INFO if verbose else logging.WARNING)
    if token is not None and (len(token) < MIN_TOKEN_CHARS or not token.isprintable() or " " in token):
        raise click.BadParameter(f"a token is at least {MIN_TOKEN_CHARS} printable characters without spaces", param_hint="--token")

    from .._extras import require

    require("aiohttp", "live", "sail live")
    from ..live.pipeline import LivePipeline
    from ..live.server import HostPolicy, LiveServer, is_loopback, serve

    hosts = HostPolicy(host, frozenset(allow_hosts))
    if not is_loopback(host):
        console.print(f"[bold yellow]warning:[/bold yellow] serving on {host}: anyone who can reach this machine can watch "
                      "the stream. Tare, record and save need the token, which the page asks for when it is opened from "
                      "another machine; give it only to those who may change the offsets", highlight=False)  # fmt: skip

    with ExitStack() as stack:
        guide = None
        if guide_plan is not None:
            from ..live.guide import Guide

            guide = Guide(guide_plan, robot, record_dir, lambda samples: pipeline.tare(samples))
        blocks, label = _source(stack, source, serial_port, baud, simulate, robot_path, rig, lsl_in, speed, sample_rate_hz,
                                cal.arm, columns, console, guide)  # fmt: skip
        bag = None
        if mcap_out is not None:
            from ..io.files import check_output
            from ..io.rosbag import BagWriter
            from ..live.pipeline import bag_listener

            check_output(mcap_out, {"the --calibration file": cal_path, "the replayed file": source})
            bag = stack.enter_context(BagWriter(mcap_out))
        pipeline = LivePipeline(cal, blocks, source=label, lowpass=lowpass, dt=dt,
                                also=("t_s", "omega1_dps", "omega2_dps") if bag is not None
                                else ("t_s",) if lsl_out or foxglove_port is not None or guide is not None else ())  # fmt: skip
        if bag is not None:
            pipeline.listen(bag_listener(bag))
            stack.callback(lambda: console.print(f"wrote {mcap_out}: {bag.rows:,} rows", highlight=False))
            stack.callback(pipeline.stop)  # the rows stop before the bag closes (callbacks run in reverse)
        if guide is not None:
            pipeline.listen(guide)
        server = LiveServer(pipeline, record_dir=record_dir, record_format=record_format, calibration_path=cal_path, hosts=hosts,
                            guide=guide, **({"token": token} if token else {}))  # fmt: skip
        if lsl_out is not None:
            from ..live.lsl import Outlet

            rate = 1.0 / dt if dt is not None else getattr(blocks, "rate_hz", None)
            pipeline.listen(Outlet(lsl_out, rate_hz=rate, latency_s=latency_ms / 1e3,
                                   lsl_time=bool(getattr(blocks, "lsl_time", False))))  # fmt: skip
            console.print(f"publishing the force as the Lab Streaming Layer stream {lsl_out!r}", highlight=False)
        if foxglove_port is not None:
            from ..live.foxglove import FoxgloveView

            view = FoxgloveView(foxglove_port)
            stack.callback(view.close)
            pipeline.listen(view)
            click.echo(f"sail live: Foxglove WebSocket at {view.url} (Foxglove Studio: Open connection)", err=False)
        pipeline.start()

        def ready(url: str) -> None:
            click.echo(f"sail live: serving {url} ({label}); Ctrl-C stops", err=False)
            if not hosts.loopback_only:
                click.echo(f"sail live: the commands' token is {server.token}", err=False)

        try:
            asyncio.run(serve(server, host, port, ready))
        finally:
            stopped = server.stop_recording()
            if stopped:
                console.print(f"kept the recording {record_dir / stopped}", highlight=False)
            failed = pipeline.output.failed
            if failed is not None:
                try:
                    kept = failed.stop()  # a Parquet recording is converted now, if the disk allows
                except OSError as exc:
                    kept = failed.path
                    console.print(f"could not convert it ({exc.strerror or exc}): the CSV stays", highlight=False)
                console.print(f"[bold yellow]warning:[/bold yellow] a recording stopped by itself: {failed.error} "
                              f"(kept {kept})", highlight=False)  # fmt: skip
            for path in server.saved:
                console.print(f"saved calibration {path}", highlight=False)
            if guide is not None and guide.result is not None:
                r = guide.result
                console.print(f"guided calibration: {r.holds} holds ({r.skipped} skipped), fit {1e3 * r.fit_rmse_N:.1f} mN "
                              f"RMS; wrote {record_dir / r.recording.name}, {record_dir / r.calibration.name} and "
                              f"{record_dir / r.achieved_csv.name}", highlight=False)  # fmt: skip


def _source(stack: ExitStack, source, serial_port, baud, simulate, robot_path, rig, lsl_in, speed, rate_hz, cal_arm, columns,
            console, guide=None):  # fmt: skip
    """The chosen source's blocks, and a label for people."""
    from ..live import sources

    if simulate:
        from ._options import check_same_arm, load_robot

        robot = load_robot(robot_path)
        check_same_arm(cal_arm, robot.arm, robot_path)
        if guide is not None:
            return sources.guided_arm(robot, guide.want, rig=rig, speed=speed), f"simulated rig {rig}, guided"
        return sources.simulated_arm(robot, rig=rig, speed=speed), f"simulated arm (rig {rig})"
    if serial_port is not None:
        from ._progress import skipped_note

        name = f"serial port {serial_port}"
        port = stack.enter_context(sources.serial_lines(serial_port, baud))
        lines = sources.from_header(port, columns=columns, on_skipped=skipped_note(console, name))
        return sources.stamped(lines, seconds_per_byte=sources.serial_seconds_per_byte(baud)), name
    if lsl_in is not None:
        from ..live.lsl import inlet_blocks

        return inlet_blocks(lsl_in), f"LSL stream {lsl_in}"
    if str(source) == "-":
        return sources.stamped(sources.stdin_lines()), "stdin"
    if not source.is_file():
        raise SailError(f"{source}: no such file to replay")
    return sources.replay(source, speed=speed, rate_hz=rate_hz if _lacks_time(source) else None), f"replay of {source.name}"


def _lacks_time(path: Path) -> bool:
    from ..io.tables import READING_COLUMNS, csv_header

    header = csv_header(path, READING_COLUMNS)
    return header is None or "t_s" not in header.names
