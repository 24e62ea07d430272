"""A rig's serial port, read for a fixed time into a recording, with its traffic (``sail check-rig --serial``).

The port is read as ``sail estimate --serial`` reads it
(:class:`~sailforce.live.sources.SerialStream`: text lines, or the binary
frames decoded into rows of the multi-rate format), for ``seconds`` of wall
time.  The rows go to a CSV file, which :func:`sailforce.rig.check_rig` then
checks; the bytes, the rows and the frame counts make the
:class:`~sailforce.rig.check.Link`.  The throughput is timed from the first
byte to the last, so a device that starts late is not called slow.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from .._extras import require
from ..errors import InputError
from ..io.files import atomic_writer
from ..io.frames import FrameDecoder
from ..rig.check import Link
from .sources import SerialStream

#: How long one read of the port may wait before the deadline is looked at again [s].
POLL_S = 0.05


class _Timed:
    """A port whose reads block until data comes or the deadline passes (then ``b""``: the stream's end), and that
    counts the bytes and the instants of the first and last."""

    def __init__(self, port, deadline: float) -> None:
        self._port, self._deadline = port, deadline
        self.bytes = 0
        self.first: float | None = None
        self.last: float | None = None

    @property
    def in_waiting(self) -> int:
        return self._port.in_waiting

    def _seen(self, data: bytes) -> bytes:
        if data:
            now = time.monotonic()
            self.first = self.first if self.first is not None else now
            self.last = now
            self.bytes += len(data)
        return data

    def read(self, size: int = 1) -> bytes:
        while time.monotonic() < self._deadline:
            if data := self._port.read(size):
                return self._seen(data)
        return b""

    def readline(self, size: int = -1) -> bytes:
        line = b""
        while time.monotonic() < self._deadline and not line.endswith(b"\n") and (size < 0 or len(line) < size):
            line += self._seen(self._port.readline(size - len(line) if size >= 0 else -1))
        return line


def capture_rig(port_name: str, baud: int, seconds: float, out: Path,
                progress: Callable[[float], None] | None = None) -> Link:  # fmt: skip
    """Read ``port_name`` for ``seconds`` into the CSV ``out`` (written atomically); ``progress`` hears the seconds
    gone.  Raises :class:`~sailforce.errors.InputError` when the port cannot be opened or sends nothing."""
    serial = require("serial", "serial", "sail check-rig --serial")
    try:
        port = serial.serial_for_url(port_name, baudrate=baud, timeout=POLL_S)
    except (serial.SerialException, ValueError) as exc:
        raise InputError(f"--serial {port_name}: cannot open it ({exc})") from None
    start = time.monotonic()
    rows = 0
    with port:
        timed = _Timed(port, start + seconds)
        stream = SerialStream(timed, serial)
        with atomic_writer(out, "wb") as sink:
            for line in stream:
                sink.write(line)
                rows += 1
                if progress is not None and rows % 256 == 0:
                    progress(min(seconds, time.monotonic() - start))
    if progress is not None:
        progress(seconds)
    if timed.bytes == 0:
        raise InputError(f"--serial {port_name}: no bytes in {seconds:g} s: is the rig powered, and the baud rate "
                         f"{baud}?")  # fmt: skip
    span = (timed.last - timed.first) if timed.first is not None and timed.last is not None else 0.0
    decoder = stream.decoder
    if isinstance(decoder, FrameDecoder):
        return Link(port=port_name, seconds=span, bytes=timed.bytes, rows=decoder.frames, binary=True,
                    frames=decoder.frames, lost=decoder.lost, corrupt=decoder.corrupt)  # fmt: skip
    return Link(port=port_name, seconds=span, bytes=timed.bytes, rows=max(0, rows - 1), binary=False)
