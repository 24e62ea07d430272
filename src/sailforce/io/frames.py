"""The rig's binary wire format: COBS-framed ticks with device time, a sequence number and a CRC (docs/reference/frames.md).

Each frame is one control tick, :data:`TICK` laid out little-endian,
followed by its CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection,
no final XOR; ``binascii.crc_hqx(data, 0xFFFF)``), then COBS-encoded and
ended by a zero byte (Cheshire & Baker, "Consistent Overhead Byte
Stuffing", IEEE/ACM Trans. Networking 7(2), 1999), so that a reader joining
mid-stream finds the next frame at the next zero.  A :data:`HELLO` frame
(type 2), sent at start-up, gives the encoders' counts per turn.

:class:`FrameDecoder` turns bytes into rows of the multi-rate format
(docs/reference/multirate.md): ``t_s`` is the device's time (its 32-bit
microsecond counter, unwrapped), the angles are counts over counts per turn,
a cell's load and ``loadN_t_s`` are on the row of its new conversion only.
A frame whose CRC or length is wrong is counted (``corrupt``); a gap in the
sequence numbers gives one row per missing frame, with no angles (the
estimate marks it ``invalid``) and ``frame`` ``lost``, so that nothing goes
missing in silence.  The ``frame`` column says ``ok``, ``lost`` or, on the
row after a corrupt frame, ``resync``.
"""

from __future__ import annotations

import binascii
import math
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from .._extras import require

#: Frame types.
TICK_TYPE, HELLO_TYPE = 1, 2
#: A tick (before the CRC): type u8, sequence u16, device time [us] u32, theta1 and theta2 [counts] i32, flags u8
#: (bit 0: cell 1 has a new conversion, bit 1: cell 2), load1 and load2 [raw] i32, each conversion's data-ready
#: time less the tick's [us] i16, device status u8.
TICK = struct.Struct("<BHIiiBiihhB")
#: A hello: type u8, format version u8, counts per turn of each encoder u32.
HELLO = struct.Struct("<BBII")
CRC = struct.Struct("<H")
VERSION = 1
#: Without a hello: the counts per turn libsail's rate filter uses (SAIL_COUNTS_PER_TURN, 2^24).
DEFAULT_COUNTS_PER_TURN = 2**24
#: The device status bits of the sketch's acquisition (``SAIL_ACQ_*`` in c/examples/arduino/sail_hx711/sail_acq.h).
DEVICE_STATUS = {0x01: "settling", 0x02: "timeout", 0x04: "encoder", 0x08: "overrun", 0x10: "saturated", 0x20: "taring"}
#: The header of the rows :class:`FrameDecoder` gives.
COLUMNS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "load1_t_s", "load2_t_s", "device_status", "frame")
#: A frame on the wire at most: COBS adds one byte per 254, plus the zero.
MAX_FRAME_BYTES = TICK.size + CRC.size + 2


def _cobs():
    """The ``cobs`` package's codec (the ``serial`` extra)."""
    return require("cobs.cobs", "serial", "the rig's binary frames")


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value 0x29B1 for b"123456789")."""
    return binascii.crc_hqx(data, 0xFFFF)


@dataclass(frozen=True)
class Tick:
    """One tick as a device sends it (the fields of :data:`TICK`)."""

    sequence: int
    time_us: int
    theta_counts: tuple[int, int]
    new: tuple[bool, bool]
    load: tuple[int, int]
    ready_us: tuple[int, int]
    status: int = 0


def encode_tick(tick: Tick) -> bytes:
    """The bytes on the wire for ``tick``: COBS of the fields and their CRC, then a zero."""
    flags = int(tick.new[0]) | int(tick.new[1]) << 1
    body = TICK.pack(TICK_TYPE, tick.sequence & 0xFFFF, tick.time_us & 0xFFFFFFFF, *tick.theta_counts, flags,
                     *tick.load, *tick.ready_us, tick.status)  # fmt: skip
    return _cobs().encode(body + CRC.pack(crc16(body))) + b"\x00"


def encode_hello(counts_per_turn: tuple[int, int]) -> bytes:
    body = HELLO.pack(HELLO_TYPE, VERSION, *counts_per_turn)
    return _cobs().encode(body + CRC.pack(crc16(body))) + b"\x00"


class FrameDecoder:
    """Bytes in (:meth:`feed`), CSV lines of the multi-rate format out, with the counts of what went wrong."""

    def __init__(self, counts_per_turn: tuple[int, int] = (DEFAULT_COUNTS_PER_TURN, DEFAULT_COUNTS_PER_TURN)) -> None:
        self.counts_per_turn = counts_per_turn
        self.frames = 0  #: good ticks
        self.corrupt = 0  #: frames with a bad CRC, length or stuffing
        self.lost = 0  #: ticks missing from the sequence (a corrupt one among them)
        self._pending = b""
        self._sequence: int | None = None
        self._wraps = 0
        self._last_us: int | None = None
        self._resync = False
        self._started = False

    def header(self) -> bytes:
        return (",".join(COLUMNS) + "\n").encode()

    def feed(self, data: bytes) -> list[bytes]:
        """The rows (CSV lines) of the whole frames in ``data`` (and what was left of the last call)."""
        decode = _cobs().decode
        *frames, self._pending = (self._pending + data).split(b"\x00")
        if len(self._pending) > 4 * MAX_FRAME_BYTES:  # no zero for too long: noise, not frames
            self._pending = b""
            self.corrupt += 1
        lines: list[bytes] = []
        for raw in frames:
            if not raw:
                continue
            try:
                frame = decode(raw)
            except Exception:  # cobs.DecodeError: a zero inside, or a code past the end
                frame = b""
            if len(frame) < CRC.size + 1 or crc16(frame[:-CRC.size]) != CRC.unpack(frame[-CRC.size:])[0]:
                self._bad()
                continue
            body = frame[:-CRC.size]
            if body[0] == HELLO_TYPE and len(body) == HELLO.size:
                _, _, c1, c2 = HELLO.unpack(body)
                if c1 > 0 and c2 > 0:
                    self.counts_per_turn = (c1, c2)
                continue
            if body[0] != TICK_TYPE or len(body) != TICK.size:
                self._bad()
                continue
            lines.extend(self._rows(TICK.unpack(body)))
        return lines

    def _bad(self) -> None:
        if self._started:  # before the first good frame, a joined stream's partial frame
            self.corrupt += 1
            self._resync = True

    def _rows(self, fields) -> Iterator[bytes]:
        _, sequence, time_us, th1, th2, flags, l1, l2, r1, r2, status = fields
        self._started = True
        if self._sequence is not None:
            missing = (sequence - self._sequence - 1) & 0xFFFF
            self.lost += missing
            for _ in range(missing):
                yield b",,,,,,,,lost\n"
        self._sequence = sequence
        if self._last_us is not None and time_us < self._last_us and self._last_us - time_us > 1 << 31:
            self._wraps += 1  # the 32-bit microsecond counter wrapped (every 71.6 minutes)
        self._last_us = time_us
        t = (self._wraps * (1 << 32) + time_us) * 1e-6
        self.frames += 1
        degrees = (360.0 * th1 / self.counts_per_turn[0], 360.0 * th2 / self.counts_per_turn[1])
        cells = []
        for bit, load, ready in ((1, l1, r1), (2, l2, r2)):
            cells.append((repr(float(load)), repr(t + ready * 1e-6)) if flags & bit else ("", ""))
        tag = "resync" if self._resync else "ok"
        self._resync = False
        yield (f"{t!r},{degrees[0]!r},{degrees[1]!r},{cells[0][0]},{cells[1][0]},{cells[0][1]},{cells[1][1]},"
               f"{status},{tag}\n").encode()  # fmt: skip


def frame_lines(chunks: Iterable[bytes], decoder: FrameDecoder | None = None) -> Iterator[bytes]:
    """The header, then the rows, of a stream of frames given as byte chunks."""
    decoder = decoder or FrameDecoder()
    yield decoder.header()
    for chunk in chunks:
        yield from decoder.feed(chunk)


def degrees_to_counts(theta_deg: float, counts_per_turn: int = DEFAULT_COUNTS_PER_TURN) -> int:
    """An angle as the whole counts a device would send (the nearest)."""
    return int(math.floor(theta_deg / 360.0 * counts_per_turn + 0.5))
