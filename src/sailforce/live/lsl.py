"""Lab Streaming Layer (pylsl, whose wheel bundles liblsl): the force as an outlet, the readings from an inlet.

- **Outlet** (``--lsl-out NAME``): one stream of type ``Force``,
  ``double64``, channels ``fx_N, fy_N, force_N, angle_deg, status``.  A row
  without a force (singular, invalid) sends NaN for it.  ``status`` is the
  code of :data:`sailforce.estimate.estimator.STATUS_NAMES`, whose names the
  stream's description lists (``desc/status_codes``), so LabRecorder's XDF
  files carry them.
  - **Its rate**: the nominal rate given (``--sample-rate-Hz``), or the one
    its first :data:`RATE_PROBE_ROWS` rows' ``t_s`` steps show when they are
    regular (within :data:`REGULAR_SPREAD` of their median);
    ``IRREGULAR_RATE`` otherwise.  Without a given rate the outlet opens
    once those rows have come.
  - **Its stamps**, on LSL's clock (:func:`pylsl.local_clock`): the
    reading's own time, back-dated by its known age (``latency_s``,
    ``--source-latency-ms``) and, for a multi-rate recording, by ``t_s -
    force_t_s`` (the force refers to its conversion's centroid).  The
    reading's own time is its ``t_s`` mapped by :class:`DeviceClock` when
    the stream stamps its samples, its ``t_s`` itself when that is LSL time
    (an inlet's stamps), else its arrival (sources' :func:`~sailforce.live.sources.now`,
    a serial line's transmission time taken off).  The clocks are read
    together at every push and neither steps, so a wall-clock step moves no
    stamp.
- **Inlet** (``--lsl-in NAME``): a stream with channels ``theta1_deg,
  theta2_deg, load1, load2`` (and ``t_s``), labelled in its description or
  in that order; without a ``t_s`` channel, each sample's LSL timestamp is
  its ``t_s``.  The stream ends when its outlet closes.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator

import numpy as np

from .._extras import require
from ..errors import InputError, ToolError
from ..estimate.estimator import STATUS_NAMES
from ..io.tables import READING_COLUMNS
from .pipeline import Rows
from .sources import Block, now

OUTLET_CHANNELS = (("fx_N", "N"), ("fy_N", "N"), ("force_N", "N"), ("angle_deg", "degrees"), ("status", "code"))

#: An inlet's channels when its description does not label them: the readings, then t_s.
INLET_COLUMNS = (*READING_COLUMNS, "t_s")

#: How long ``--lsl-in`` looks for its stream before giving up [s].
RESOLVE_TIMEOUT_S = 10.0

#: An inlet is polled this often for new samples [s].
PULL_TIMEOUT_S = 0.05

#: liblsl's log level: errors only (its INFO lines would fill a terminal).
_LOG_CONFIG = "[log]\nlevel = -2\n"
_configured = False


def _pylsl(flag: str):
    """pylsl, configured once (before liblsl's first call), or an error naming the extra that brings it."""
    global _configured
    pylsl = require("pylsl", "live", flag)
    if not _configured:
        _configured = True
        try:
            pylsl.util.set_config_content(_LOG_CONFIG)
        except Exception:  # liblsl already started (a test's outlet): keep its configuration
            pass
    return pylsl


def _clock_offset(pylsl) -> float:
    """LSL's clock less the sources' (:func:`sailforce.live.sources.now`) [s]: both monotonic, so this stays put."""
    return pylsl.local_clock() - now()


#: Rows whose t_s steps decide an outlet's nominal rate.
RATE_PROBE_ROWS = 32
#: The steps are regular when their 5th to 95th percentiles lie within this fraction of their median.
REGULAR_SPREAD = 0.05
#: An outlet waiting for its probe rows opens anyway after this long [s] (a slow or timeless stream: irregular).
RATE_PROBE_WAIT_S = 1.0


class DeviceClock:
    """A device's clock (its samples' ``t_s``) mapped to LSL's: ``t + offset(t)``, with the offset the lower envelope
    of ``arrival - t`` (transport only adds delay).  Each :data:`BIN_S` bin of the last :data:`WINDOW_S` keeps its
    least delay; the offset is the line fitted through the newest run of the bins' lower convex hull whose edges
    slope no more than :data:`MAX_DRIFT` (the device's drift), as clock-skew estimation from one-way delays does
    (Moon, Skelly and Towsley, IEEE INFOCOM 1999); the newest bin, still open, joins the fit once closed, and a bin
    with fewer than half the fullest bin's samples (the part of a second a stream starts or resumes in) never does:
    one stall can hold all of its few rows, and its least delay would tilt the line as a drift.  An edge
    steeper than any clock drifts is a delay that passed (a reader that stalled on its first rows), and the hull
    before it is left out.  A step back in ``t`` or a jump of the offset beyond :data:`RESET_S` (a device that
    restarted) starts the fit again."""

    BIN_S = 1.0
    WINDOW_S = 60.0
    RESET_S = 1.0
    #: A clock drifts against LSL's by at most this (a ceramic resonator's 0.5 %, with room): a steeper slope is not a drift.
    MAX_DRIFT = 0.01

    def __init__(self) -> None:
        self._bins: deque[list[float]] = deque()  # [bin, t at the least delay, least delay, samples]
        self._last = -math.inf

    def offset(self, t: np.ndarray) -> np.ndarray:
        """The fitted ``arrival - t`` at ``t``."""
        if not self._bins:
            return np.full(np.shape(t), np.nan)
        bins = np.array([b[1:3] for b in self._bins])
        counts = np.array([b[3] for b in self._bins])
        # the newest bin is still open: its least delay so far may be a stall's, as the bin opened, and as the hull's
        # last vertex it would tilt the line by that much; it enters once closed (and the constant below at once)
        closed = bins[:-1][counts[:-1] >= counts.max() / 2]
        points = _drifting_envelope(closed, self.MAX_DRIFT) if len(closed) >= 2 else bins[:0]
        if len(points) < 2 or np.ptp(points[:, 0]) < self.BIN_S:
            return np.full(np.shape(t), bins[:, 1].min())
        slope, intercept = np.polyfit(points[:, 0] - points[0, 0], points[:, 1], 1)
        return intercept + slope * (np.asarray(t) - points[0, 0])

    def update(self, t: np.ndarray, arrival: np.ndarray) -> None:
        for time_s, delay in zip(t.tolist(), (arrival - t).tolist()):
            if not (math.isfinite(time_s) and math.isfinite(delay)):
                continue
            if time_s < self._last or (self._bins and abs(delay - float(self.offset(np.array(time_s)))) > self.RESET_S):
                self._bins.clear()
            self._last = time_s
            index = math.floor(time_s / self.BIN_S)
            if self._bins and self._bins[-1][0] == index:
                self._bins[-1][3] += 1
                if delay < self._bins[-1][2]:
                    self._bins[-1][1:3] = [time_s, delay]
            else:
                self._bins.append([index, time_s, delay, 1])
            while self._bins and self._bins[0][0] < index - self.WINDOW_S / self.BIN_S:
                self._bins.popleft()

    def to_lsl(self, t: np.ndarray, arrival: np.ndarray) -> np.ndarray:
        """``t`` on LSL's clock, having seen these samples arrive at ``arrival`` (LSL's clock)."""
        self.update(t, arrival)
        mapped = t + self.offset(t)
        return np.where(np.isfinite(mapped), mapped, arrival)


def _drifting_envelope(points: np.ndarray, max_drift: float) -> np.ndarray:
    """The newest run of the lower convex hull of ``points`` ``(n, 2)`` (time, delay; in time order) whose edges slope
    by at most ``max_drift``: the vertices a clock's drift can join."""
    hull: list[np.ndarray] = []
    for point in points:  # Andrew's monotone chain, lower half
        while len(hull) >= 2 and ((hull[-1][0] - hull[-2][0]) * (point[1] - hull[-2][1])
                                  - (hull[-1][1] - hull[-2][1]) * (point[0] - hull[-2][0])) <= 0:  # fmt: skip
            hull.pop()
        hull.append(point)
    start = len(hull) - 1
    while start > 0 and abs(hull[start][1] - hull[start - 1][1]) <= max_drift * (hull[start][0] - hull[start - 1][0]):
        start -= 1
    return np.array(hull[start:])


def nominal_rate(t: np.ndarray) -> float:
    """The rate [Hz] regular steps of ``t`` show (0, LSL's IRREGULAR_RATE, when they are not regular)."""
    steps = np.diff(t[np.isfinite(t)])
    if steps.size < RATE_PROBE_ROWS // 2 or not np.all(steps > 0):
        return 0.0
    middle = float(np.median(steps))
    low, high = np.percentile(steps, [5, 95])
    return round(1.0 / middle, 6) if high - low <= REGULAR_SPREAD * middle else 0.0


class Outlet:
    """The live force as an LSL outlet; a pipeline listener (see the module docstring).

    ``rate_hz``: the nominal rate, 0 for irregular, None to probe it from the
    first rows.  ``latency_s``: the readings' known age when they arrive.
    ``lsl_time``: the rows' ``t_s`` is already LSL time (an inlet's stamps).
    """

    def __init__(self, name: str, source_id: str | None = None, *, rate_hz: float | None = 0.0, latency_s: float = 0.0,
                 lsl_time: bool = False) -> None:  # fmt: skip
        self._pylsl = _pylsl("--lsl-out")
        self.name = name
        self.source_id = source_id or f"sailforce-{name}"
        self.latency_s = float(latency_s)
        self.lsl_time = lsl_time
        self.rate_hz: float | None = None
        self._waiting: list[Rows] = []
        self._since = now()
        self._device = DeviceClock()
        self._outlet: object | None = None
        if rate_hz is not None:
            self._open(rate_hz)

    def _open(self, rate_hz: float) -> None:
        pylsl = self._pylsl
        self.rate_hz = rate_hz
        info = pylsl.StreamInfo(self.name, "Force", len(OUTLET_CHANNELS), rate_hz or pylsl.IRREGULAR_RATE,
                                pylsl.cf_double64, self.source_id)  # fmt: skip
        channels = info.desc().append_child("channels")
        for label, unit in OUTLET_CHANNELS:
            channel = channels.append_child("channel")
            channel.append_child_value("label", label)
            channel.append_child_value("unit", unit)
        codes = info.desc().append_child("status_codes")
        for code, status in enumerate(STATUS_NAMES):
            codes.append_child("code").append_child_value("value", str(code)).append_child_value("name", status)
        info.desc().append_child_value("software", "sailforce")
        self._outlet = pylsl.StreamOutlet(info)

    def stamps(self, rows: Rows) -> np.ndarray:
        """The rows' LSL timestamps (see the module docstring)."""
        arrival = rows.stamps + _clock_offset(self._pylsl)
        t = rows.values.get("t_s")
        if t is None:
            own = arrival
        elif self.lsl_time:
            own = np.where(np.isfinite(t), t, arrival)
        else:
            own = self._device.to_lsl(np.asarray(t, dtype=float), arrival)
        force_t = rows.columns.get("force_t_s")
        if force_t is not None and t is not None:
            age = np.asarray(t, dtype=float) - force_t
            own = own - np.where(np.isfinite(age), age, 0.0)
        return own - self.latency_s

    def __call__(self, rows: Rows) -> None:
        if self._outlet is None:
            self._waiting.append(rows)
            count = sum(len(r) for r in self._waiting)
            if count < RATE_PROBE_ROWS and now() - self._since < RATE_PROBE_WAIT_S:
                return
            times = [r.values["t_s"] for r in self._waiting if "t_s" in r.values]
            self._open(nominal_rate(np.concatenate(times)) if times else 0.0)
            waiting, self._waiting = self._waiting, []
            for each in waiting:
                self._push(each)
            return
        self._push(rows)

    def _push(self, rows: Rows) -> None:
        data = np.column_stack([rows.columns["fx_N"], rows.columns["fy_N"], rows.columns["force_N"],
                                rows.columns["angle_deg"], rows.status.astype(float)])  # fmt: skip
        assert self._outlet is not None, "pushed before the outlet opened"
        self._outlet.push_chunk(data, self.stamps(rows).tolist())  # type: ignore[attr-defined]


def _labels(info) -> list[str]:
    channel = info.desc().child("channels").child("channel")
    labels = []
    while not channel.empty():
        labels.append(channel.child_value("label"))
        channel = channel.next_sibling()
    return labels


class InletBlocks(Iterator[Block]):
    """An inlet's blocks (:func:`inlet_blocks`), whether their ``t_s`` is LSL time (the samples' stamps), and the
    stream's nominal rate [Hz] (0: irregular)."""

    def __init__(self, blocks: Iterator[Block], lsl_time: bool, rate_hz: float) -> None:
        self._blocks = blocks
        self.lsl_time = lsl_time
        self.rate_hz = rate_hz

    def __next__(self) -> Block:
        return next(self._blocks)


def inlet_blocks(name: str, *, timeout: float = RESOLVE_TIMEOUT_S) -> InletBlocks:
    """The readings of the LSL stream ``name`` as blocks of stamped CSV lines (:mod:`sailforce.live.sources`).

    The stream is found and its channels checked at once (the error comes
    here, not on a reader's thread).  Without a ``t_s`` channel, ``t_s`` is
    each sample's LSL timestamp (``lsl_time``).
    """
    pylsl = _pylsl("--lsl-in")
    found = pylsl.resolve_byprop("name", name, 1, timeout)
    if not found:
        raise ToolError(f"--lsl-in {name}: no Lab Streaming Layer stream of that name answered within {timeout:g} s; "
                        "is its outlet running, on this machine or this network?")  # fmt: skip
    inlet = pylsl.StreamInlet(found[0], recover=False, processing_flags=pylsl.proc_clocksync)
    info = inlet.info(timeout)
    count = info.channel_count()
    labels = _labels(info)
    if len(labels) != count or not set(READING_COLUMNS) <= set(labels):
        if count not in (len(READING_COLUMNS), len(INLET_COLUMNS)):
            raise InputError(f"--lsl-in {name}: {count} channels labelled {', '.join(labels) or '(none)'}; expected "
                            f"{', '.join(INLET_COLUMNS)} (t_s optional), labelled or in that order")  # fmt: skip
        labels = list(INLET_COLUMNS[:count])
    stamp_column = "t_s" not in labels
    header = ",".join(labels + (["t_s"] if stamp_column else [])) + "\n"

    def blocks() -> Iterator[Block]:
        yield [(header.encode(), now())]
        offset = _clock_offset(pylsl)
        while True:
            try:
                samples, stamps = inlet.pull_chunk(timeout=PULL_TIMEOUT_S)
            except pylsl.util.LostError:
                return  # the outlet has closed: the stream has ended
            if not samples:
                continue
            block = []
            for sample, stamp in zip(samples, stamps):
                values = list(sample) + ([stamp] if stamp_column else [])
                line = ",".join("" if not math.isfinite(v) else repr(float(v)) for v in values) + "\n"
                block.append((line.encode(), stamp - offset))
            yield block

    return InletBlocks(blocks(), lsl_time=stamp_column, rate_hz=float(info.nominal_srate()))
