"""Where live readings come from: blocks of raw lines, each line with the time of its reading.

Every source is an iterator of blocks: lists of ``(line, stamp)``, ``line``
the raw bytes of one CSV line (line end included), ``stamp`` the
:func:`now` [s] at which the reading was taken (when it arrived, less the
line's transmission time, for a serial port; when it arrived, for stdin;
when it was due, for a replay; the sample's own timestamp, for a Lab
Streaming Layer inlet).  :func:`now` reads like the wall clock but never
steps: an NTP correction during a session moves no stamp.  The first block starts with
the header line.  A block holds the lines that arrived together, so that
one estimate serves them all: at 1 kHz, replays come in
:data:`REPLAY_TICK_S` ticks.
"""

from __future__ import annotations

import csv
import io
import math
import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import InputError
from ..io.tables import READING_COLUMNS, TableError, read_header, read_line
from ..motion.reaching import reaching, record
from ..robot import Robot
from ..synthetic import NoiseModel, session_offsets

Block = list[tuple[bytes, float]]

#: Replays and the simulated arm wake this often and hand over every line that has come due [s]: 100 wake-ups a
#: second instead of one per line at 1 kHz, for at most 10 ms of added delay (`make bench`: at 1 kHz the server
#: then takes 14% of a core instead of 21% with 5 ms ticks, and the page's median latency is 16 ms instead of 14 ms).
REPLAY_TICK_S = 0.010

#: The simulated arm's sampling rate [Hz], that of the recordings ``sail simulate-motion`` makes.
SIMULATED_RATE_HZ = 1000.0

#: The simulated arm's hand pulls toward each reach's target with this spring [N/m] (``simulate-motion --session task``).
SIMULATED_HAND_STIFFNESS = 100.0

#: Columns of the simulated arm's lines: what a lab records, and the true hand force beside it.
SIMULATED_COLUMNS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "true_fx_N", "true_fy_N")


#: The wall clock and the monotonic clock read together, once: :func:`now` is the one plus the other's advance.
_ANCHOR = (time.time(), time.monotonic())


def now() -> float:
    """The time [s]: the wall clock's reading at start-up plus the monotonic clock's advance since, a clock that
    reads like the wall clock (the live page shows it) but never steps."""
    return _ANCHOR[0] + (time.monotonic() - _ANCHOR[1])


def _paced(lines: Iterator[tuple[bytes, float]], speed: float, clock: Callable[[], float] = now) -> Iterator[Block]:
    """Blocks of the lines whose due time (seconds from the start, at ``speed``) has come, every tick."""
    start = clock()
    block: Block = []
    for line, due in lines:
        when = start + due / speed
        now = clock()
        if when > now and block:
            yield block
            block = []
            now = clock()
        if when > now + REPLAY_TICK_S:
            time.sleep(when - now)  # the next line is not due: sleep until it is, a tick at least
        elif when > now:
            time.sleep(REPLAY_TICK_S)
        block.append((line, when))
    if block:
        yield block


def replay(path: Path, *, speed: float = 1.0, rate_hz: float | None = None) -> Iterator[Block]:
    """The lines of a CSV recording, each when it is due: at its ``t_s`` (or at ``rate_hz``), ``speed`` times as fast.

    The header is read and checked at once (the error comes here, not on
    the reader's thread).  A line whose ``t_s`` is not a number (or goes
    back in time) is handed over with the line before it: the estimator
    gives it its status.
    """
    if not speed > 0 or not math.isfinite(speed):
        raise InputError(f"--speed {speed:g}: a replay speed is a positive number (1 is real time)")
    try:
        stream = open(path, "rb")
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    try:
        first = read_line(stream)
        if not first:
            raise TableError(f"{path}: empty; expected a header line naming the columns, then one reading per line")
        header = read_header(path, first, READING_COLUMNS)
        if "t_s" not in header.names and rate_hz is None:
            raise TableError(f"{path}: no t_s column to replay it by; give --sample-rate-Hz, the rate it was recorded at")
    except BaseException:
        stream.close()
        raise
    column = header.names.index("t_s") if rate_hz is None else None

    def due() -> Iterator[tuple[bytes, float]]:
        with stream:
            yield first, 0.0
            t0, last, index = None, 0.0, 0
            while line := read_line(stream):
                if column is None:
                    last = index / rate_hz  # type: ignore[operator]
                else:
                    t = _field(line, column)
                    if math.isfinite(t):
                        t0 = t if t0 is None else t0
                        last = max(last, t - t0)
                index += 1
                yield line, last

    return _paced(due(), speed)


def _field(line: bytes, column: int) -> float:
    """The number in one field of a CSV line, NaN if there is none."""
    try:
        text = line.decode("utf-8", errors="replace")
        fields = text.split(",") if '"' not in text else next(csv.reader([text]))
        return float(fields[column])
    except (ValueError, IndexError, csv.Error):
        return math.nan


def simulated_arm(robot: Robot, *, rig: int = 1, speed: float = 1.0, noise: NoiseModel = NoiseModel()) -> Iterator[Block]:
    """An endless session of the simulated rig: reaching movements with a hand pulling toward each target.

    The rig of ``sail simulate-motion --rig`` (its cells' offsets), 8 reaches
    of 0.3 m that close on themselves (8 x 135 deg = 3 turns), repeated with
    a new noise draw each time, at :data:`SIMULATED_RATE_HZ`; a calibration
    of the same rig (``sail simulate-motion --session static --rig N``,
    ``sail calibrate``) reads them.
    """
    offsets = session_offsets(robot, noise, rig)
    motion = reaching(robot, sample_rate_hz=SIMULATED_RATE_HZ)
    period = motion.t[-1] + 1.0 / SIMULATED_RATE_HZ

    def lines() -> Iterator[tuple[bytes, float]]:
        yield (",".join(SIMULATED_COLUMNS) + "\n").encode(), 0.0
        for loop in range(sys.maxsize):
            rec = record(robot, motion, hand_stiffness=SIMULATED_HAND_STIFFNESS, noise=noise, seed=loop, offsets=offsets)
            t = rec.t + loop * period
            table = np.column_stack([t, np.degrees(rec.theta), rec.loads, rec.force])
            text = io.StringIO()
            np.savetxt(text, table, fmt=["%.4f", "%.6f", "%.6f", "%.0f", "%.0f", "%.4f", "%.4f"], delimiter=",")
            for line, when in zip(text.getvalue().encode().splitlines(keepends=True), t):
                yield line, float(when)

    return _paced(lines(), speed)


#: The simulated rig's joints turn at most this fast toward a guided hold's pose [rad/s].
GUIDED_SPEED = math.radians(90.0)
#: The simulated person hangs the weight this long after the arm reached the pose [s] ...
GUIDED_HANG_S = 0.3
#: ... and it takes this long to take up its load [s].
GUIDED_RAMP_S = 0.2


def guided_arm(robot: Robot, want: Callable[[], tuple], *, rig: int = 1, speed: float = 1.0,
               noise: NoiseModel = NoiseModel()) -> Iterator[Block]:  # fmt: skip
    """The simulated rig following a guided calibration (``sail live --simulate --calibrate``), endlessly, at
    ``speed`` times real time: :func:`guided_lines` paced."""
    return _paced(guided_lines(robot, want, rig=rig, noise=noise), speed)


def guided_lines(robot: Robot, want: Callable[[], tuple], *, rig: int = 1,
                 noise: NoiseModel = NoiseModel()) -> Iterator[tuple[bytes, float]]:  # fmt: skip
    """The simulated rig's lines following a guided calibration, each with its time [s], endlessly.

    ``want()`` gives the guide's phase, hold, pose [rad] and force [N]
    (:meth:`sailforce.live.guide.Guide.want`).  The arm turns toward the
    hold's pose at :data:`GUIDED_SPEED`; once there, the simulated person
    hangs the weight after :data:`GUIDED_HANG_S` (taking up its load over
    :data:`GUIDED_RAMP_S`), and takes it off when the guide moves on.  During
    the tare nothing moves and nothing is hung.  The cells read through the
    frame model with the synthetic noise model and rig ``rig``'s offsets, at
    :data:`SIMULATED_RATE_HZ`: what a lab's rig would send.
    """
    from ..fem.model import build_model
    from ..fem.response import simulate_model
    from ..synthetic import HX711_COUNTS_PER_MV_V

    offsets = session_offsets(robot, noise, rig)
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    model = build_model(robot)
    rng = np.random.default_rng(rig)
    dt = 1.0 / SIMULATED_RATE_HZ
    units: dict[tuple[float, float], np.ndarray] = {}

    def lines() -> Iterator[tuple[bytes, float]]:
        yield (",".join(SIMULATED_COLUMNS) + "\n").encode(), 0.0
        _, _, t1, t2, _, _ = want()
        theta = np.array([t1 - math.radians(20.0), t2])  # the arm starts away from the first pose
        hold, arrived = None, math.inf
        for step in range(sys.maxsize):
            t = step * dt
            phase, k, t1, t2, fx, fy = want()
            target = np.array([t1, t2])
            if k != hold or phase in ("tare", "taring", "fitting", "done", "failed"):
                hold, arrived = k, math.inf  # a new hold (or none): the weight comes off
            if phase not in ("tare", "taring"):
                gap = target - theta
                theta = np.where(np.abs(gap) <= GUIDED_SPEED * dt, target, theta + np.sign(gap) * GUIDED_SPEED * dt)
            if np.all(theta == target) and arrived == math.inf and phase in ("move", "hang", "settle", "record"):
                arrived = t
            load = float(np.clip((t - arrived - GUIDED_HANG_S) / GUIDED_RAMP_S, 0.0, 1.0))
            force = np.array([fx, fy]) * load
            key = (float(theta[0]), float(theta[1]))
            if load > 0 and key not in units:
                units[key] = simulate_model(model, np.array([key[0]]), np.array([key[1]])).signal("bridge")[0]
            signal = units[key] @ force if load > 0 else np.zeros(2)
            counts = np.round(offsets + signal * HX711_COUNTS_PER_MV_V + rng.normal(0.0, noise.noise_fraction * rated, 2))
            line = (f"{t:.4f},{math.degrees(theta[0]):.6f},{math.degrees(theta[1]):.6f},{counts[0]:.0f},{counts[1]:.0f},"
                    f"{force[0]:.4f},{force[1]:.4f}\n")  # fmt: skip
            yield line.encode(), t

    return lines()


#: Bytes a serial stream is looked at before it is taken as text or frames.
DETECT_BYTES = 512


class SerialStream(Iterator[bytes]):
    """A serial port's lines: its own text lines, or rows decoded from the rig's binary frames
    (:mod:`sailforce.io.frames`), told apart by the first bytes (a frame ends with a zero byte; text has none).
    Nothing is read until the first line is asked for; ``decoder`` then holds the frames' counts (None for text)."""

    def __init__(self, port, serial) -> None:
        self.decoder: object | None = None  # a sailforce.io.frames.FrameDecoder once frames are detected
        self._lines = self._detect(port, serial)

    def __next__(self) -> bytes:
        return next(self._lines)

    def _detect(self, port, serial) -> Iterator[bytes]:
        from ..io.frames import FrameDecoder

        first = b""
        try:
            while len(first) < DETECT_BYTES and b"\x00" not in first and b"\n" not in first:
                chunk = port.read(max(1, min(port.in_waiting, DETECT_BYTES)))
                if not chunk:
                    break
                first += chunk
            if b"\x00" in first:
                decoder = self.decoder = FrameDecoder()
                yield decoder.header()
                yield from decoder.feed(first)
                while chunk := port.read(max(1, port.in_waiting)):
                    yield from decoder.feed(chunk)
                return
            pending = first
            while b"\n" in pending:  # the detected bytes' whole lines, then the port's
                line, _, pending = pending.partition(b"\n")
                yield line + b"\n"
            rest = read_line(port) if pending or first else b""
            if pending or rest:
                yield pending + rest
            while line := read_line(port):
                yield line
        except serial.SerialException:
            return


@contextmanager
def serial_lines(port_name: str, baud: int):
    """Lines from a serial port, until it ends (hang-up, cable pulled); needs the ``serial`` extra.  Text lines as
    they come, or the rows of the rig's binary frames (:class:`SerialStream`)."""
    from .._extras import require

    serial = require("serial", "serial", "--serial")
    try:
        port = serial.serial_for_url(port_name, baudrate=baud, timeout=None)
    except (serial.SerialException, ValueError) as exc:
        raise TableError(f"--serial {port_name}: cannot open it ({exc})") from None
    with port:
        yield SerialStream(port, serial)


def is_header(line: bytes, required: tuple[str, ...] = READING_COLUMNS) -> bool:
    """Whether ``line`` names (at least) the ``required`` columns: a header line, not a row of readings."""
    names = {name.strip() for name in line.decode("utf-8", errors="replace").lstrip("\ufeff").split(",")}
    return set(required) <= names


def from_header(lines: Iterator[bytes], *, columns: str | None = None,
                on_skipped: Callable[[int], None] | None = None) -> Iterator[bytes]:  # fmt: skip
    """A stream from its header on, for a port joined while the device already streams.

    Opening a serial port flushes what it had received, and a device that
    streams without resetting never sends its header again.  With
    ``columns`` (``--columns``: the header's names, comma-separated) that
    header comes first and every line is a row.  Otherwise the lines before
    the first header line are dropped; ``on_skipped(n)`` hears of the first
    dropped line (n = 1) and, once the header comes, of their count.
    """
    if columns is not None:
        yield (columns.strip() + "\n").encode()
        yield from lines
        return
    skipped = 0
    for line in lines:
        if is_header(line):
            if skipped and on_skipped is not None:
                on_skipped(skipped)
            yield line
            yield from lines
            return
        skipped += 1
        if skipped == 1 and on_skipped is not None:
            on_skipped(1)


def stdin_lines() -> Iterator[bytes]:
    """Raw lines from standard input, until it ends.

    Read through a reader of its own on a duplicate of the descriptor: a
    thread blocked in ``sys.stdin.buffer`` holds its lock, and Python aborts
    at exit (Ctrl-C) when it cannot take that lock to close it.
    """
    stream: BinaryIO
    try:
        stream = os.fdopen(os.dup(sys.stdin.fileno()), "rb")
    except (OSError, ValueError, AttributeError):  # io.UnsupportedOperation: a stdin in memory (tests, embedding)
        stream = sys.stdin.buffer
    return iter(lambda: read_line(stream), b"")


#: Lines gathered into one block at most, by :func:`gathered`: about 10 ms of a 1 kHz stream's work at full speed.
GATHER_LINES = 4096


def gathered(lines: Iterator[bytes], *, limit: int = GATHER_LINES, seconds_per_byte: float = 0.0,
             period_s: float = 0.0) -> Iterator[Block]:  # fmt: skip
    """Blocks of every stamped line that has arrived, read on a thread of their own: a stream estimated in blocks.

    A stream that arrives faster than it is estimated line by line (a pipe,
    a 1 kHz port behind a dynamic term) comes in blocks of all that is
    waiting, up to ``limit`` lines.  With ``period_s`` a block is handed over
    at most that often: a line that arrives sooner waits for the lines that
    follow it, at most ``period_s`` (``sail estimate --block-ms``, 10 ms by
    default); without, no line waits for others, and one that arrives
    slowly comes a line at a time, as :func:`stamped` gives it.  Each line
    keeps its arrival time, less its transmission time at
    ``seconds_per_byte`` (a serial port's 10 / baud: its first byte left the
    device that long before the last).
    """
    import queue
    import threading

    waiting: queue.Queue = queue.Queue(maxsize=64 * limit)
    end = object()

    def read() -> None:
        try:
            for line in lines:
                waiting.put((line, now() - len(line) * seconds_per_byte))
        except BaseException as exc:  # the source's error ends the stream, in the reading thread
            waiting.put(exc)
        finally:
            waiting.put(end)

    threading.Thread(target=read, name="sail-stream-reader", daemon=True).start()
    due = time.monotonic()  # the next block's earliest hand-over
    while True:
        item = waiting.get()
        wait = due - time.monotonic()
        if wait > 0 and item is not end and not isinstance(item, BaseException):
            time.sleep(wait)  # one wake-up for the block, not one for each line that comes meanwhile
        block: Block = []
        while item is not end and not isinstance(item, BaseException):
            block.append(item)
            if len(block) >= limit:
                break
            try:
                item = waiting.get_nowait()
            except queue.Empty:
                break
        if block:
            due = time.monotonic() + period_s
            yield block
        if item is end:
            return
        if isinstance(item, BaseException):
            raise item


def stamped(lines: Iterator[bytes], *, seconds_per_byte: float = 0.0) -> Iterator[Block]:
    """Blocks of one line each, stamped with their arrival time (less their transmission time at
    ``seconds_per_byte``, as :func:`gathered`): for sources that block on each line."""
    for line in lines:
        yield [(line, now() - len(line) * seconds_per_byte)]


def serial_seconds_per_byte(baud: int) -> float:
    """A serial byte's time on the wire [s]: 10 bits (start, 8 data, stop) at ``baud``."""
    return 10.0 / baud
