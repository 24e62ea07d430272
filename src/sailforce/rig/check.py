"""``sail check-rig``: does a rig's recording meet the assumptions its calibration and estimates make?

From a recording in the multi-rate format (docs/reference/multirate.md; a
synchronous table is the ``ideal`` ADC's case) it measures:

- **each cell's conversions**: the rate (1 / the median interval, from
  ``loadN_t_s`` when the firmware stamps data-ready, else the ticks) against
  the ADC's nominal rate and its datasheet tolerance; the intervals' jitter
  (standard deviation, missed conversions left out); missed conversions (an
  interval beyond :data:`~sailforce.estimate.multirate.MISSED_CONVERSION`
  periods); readings at the ADC's full scale or beyond the calibration's
  capacity;
- **the skew between the cells**: cell 2's first conversions less cell 1's
  latest, within half a period either side, and its drift, the two rates'
  ratio less 1 [s/s] (two free-running chips drift; one chip's two channels
  should not);
- **the ticks**: the control period (median step), its jitter, gaps beyond
  :data:`~sailforce.estimate.multirate.GAP_STEPS` ticks, steps back in time,
  rows that are not readings (malformed, or an angle that is not a number),
  and encoder jumps: a joint angle that moves faster than
  :data:`~sailforce.motion.differentiate.MAX_JOINT_RATE` between two ticks
  (missed edges, a glitch, a wrapped counter);
- **the firmware's own flags**, when the recording has a ``device_status``
  column (the binary frames', :data:`~sailforce.io.frames.DEVICE_STATUS`):
  ticks with each bit set; a cell timing out, dropped ticks (overrun) and
  missed encoder edges are problems;
- **the link**, when :func:`sailforce.live.capture.capture_rig` read it from a
  port (:class:`Link`): bytes and rows a second, and the frames lost or
  corrupt on the way.

:func:`check_rig` gives a :class:`RigCheck`; its :attr:`~RigCheck.problems`
say, in words, each assumption that fails (an empty tuple: the rig is fit).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..adc import ADC
from ..errors import InputError
from ..estimate.multirate import GAP_STEPS, LOAD_TIME_COLUMNS, MISSED_CONVERSION
from ..io.tables import READING_COLUMNS, csv_header, is_parquet, parquet_schema, read_all
from ..motion.differentiate import MAX_JOINT_RATE

#: The 24-bit bridge ADCs' full-scale codes: a conversion at +-(2^23 - 1) or beyond is saturated (HX711, ADS1232,
#: NAU7802 and ADS131M02 datasheets: 24-bit two's complement output).
FULL_SCALE_CODE = 2**23 - 1
#: A rig may miss at most this fraction of a cell's conversions (each one is a window the estimate cannot use).
MISSED_LIMIT = 0.01
#: Ticks may wander by at most this fraction of their period (rms): the rate filter takes them as regular.
TICK_JITTER_LIMIT = 0.10
#: A cell's conversions may wander by at most this fraction of their period (rms): the filter's window is placed
#: by the measured period.
CONVERSION_JITTER_LIMIT = 0.05
#: One chip's two channels convert together: their skew must stay within this fraction of a period.
SIMULTANEOUS_SKEW_LIMIT = 0.05
#: A rate within this of nominal passes when the ADC states no tolerance (the ideal sensor: its ticks).
DEFAULT_RATE_TOLERANCE = 0.01
#: At most this fraction of the conversions may be saturated.
SATURATED_LIMIT = 0.001
#: At most this fraction of a live port's frames may be lost or corrupt (each one is a tick the estimate lacks).
LOST_FRAME_LIMIT = 0.001
#: A live port must carry at least this fraction of the device's ticks (rows a second against the tick rate).
THROUGHPUT_LIMIT = 0.99
#: Device status bits that are problems whenever they show (settling and taring are the start's, and saturation
#: is counted per cell).
DEVICE_PROBLEMS = {
    "timeout": "a cell gave no conversion for 3 periods on {n} ticks: a loose wire or a stopped chip",
    "overrun": "the firmware dropped ticks {n} times: the link is too slow for its tick (the baud budget, "
               "docs/reference/frames.md)",
    "encoder": "an encoder missed edges on {n} ticks: its interrupt is too slow for the shaft's speed",
}


@dataclass(frozen=True)
class Link:
    """A live port's traffic over a capture (``sail check-rig --serial``)."""

    port: str
    seconds: float
    bytes: int
    rows: int
    binary: bool  #: the rig's binary frames (else text lines)
    frames: int = 0  #: good frames
    lost: int = 0  #: ticks missing from the sequence
    corrupt: int = 0  #: frames with a bad CRC, length or stuffing

    @property
    def bytes_per_s(self) -> float:
        return self.bytes / self.seconds if self.seconds > 0 else math.nan

    @property
    def rows_per_s(self) -> float:
        return self.rows / self.seconds if self.seconds > 0 else math.nan


@dataclass(frozen=True)
class CellTiming:
    """One cell's conversions, as :func:`check_rig` measures them."""

    conversions: int
    stamped: bool  #: the recording has this cell's data-ready instants (loadN_t_s)
    rate_Hz: float  #: 1 / the median interval
    nominal_Hz: float
    rate_error: float  #: rate / nominal - 1
    jitter_s: float  #: rms of the intervals about the median, missed conversions left out
    missed: int
    saturated: int


@dataclass(frozen=True)
class RigCheck:
    """What :func:`check_rig` measured, and the problems it found (see the module docstring)."""

    source: str
    adc: str
    rows: int
    invalid_rows: int
    tick_Hz: float
    tick_jitter_s: float
    gaps: int
    steps_back: int
    encoder_jumps: int
    cells: tuple[CellTiming, CellTiming]
    skew_s: float  #: cell 2's first conversions less cell 1's latest (median), within -T/2 .. T/2
    skew_drift: float  #: rate 2 / rate 1 - 1: how fast two free-running chips' phase slides [s per s]
    problems: tuple[str, ...]
    device_status: dict[str, int] | None = None  #: ticks with each firmware flag set (None: no device_status column)
    link: Link | None = None

    @property
    def fit(self) -> bool:
        return not self.problems

    def as_json(self) -> dict:
        out = asdict(self)
        out["cells"] = [asdict(c) for c in self.cells]
        if self.link is not None:
            out["link"] |= {"bytes_per_s": self.link.bytes_per_s, "rows_per_s": self.link.rows_per_s}
        out["fit"] = self.fit
        return _finite(out)


def _finite(value):
    """JSON has no NaN: None instead."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _names(path: Path) -> list[str]:
    header = None if is_parquet(path) else csv_header(path, READING_COLUMNS)
    return header.names if header is not None else list(parquet_schema(path, READING_COLUMNS).names)


def _cell(times: np.ndarray, values: np.ndarray, stamped: bool, nominal: float, limit: float | None) -> CellTiming:
    """One cell's timing: ``times`` of its conversions (the rows where ``values`` is a number)."""
    intervals = np.diff(times)
    median = float(np.median(intervals)) if intervals.size else math.nan
    period = 1.0 / nominal if nominal > 0 else median
    missed = int(np.count_nonzero(intervals > MISSED_CONVERSION * period)) if intervals.size else 0
    kept = intervals[intervals <= MISSED_CONVERSION * period] if intervals.size else intervals
    jitter = float(np.sqrt(np.mean((kept - np.median(kept)) ** 2))) if kept.size > 1 else math.nan
    rate = 1.0 / median if median > 0 else math.nan
    full = np.abs(values) >= FULL_SCALE_CODE if limit is None else np.abs(values) > limit
    return CellTiming(conversions=int(times.size), stamped=stamped, rate_Hz=rate, nominal_Hz=nominal,
                      rate_error=rate / nominal - 1 if nominal > 0 else math.nan, jitter_s=jitter, missed=missed,
                      saturated=int(np.count_nonzero(full)))  # fmt: skip


#: The skew is read over the first conversions of cell 2, before two free-running clocks slide it far.
SKEW_CONVERSIONS = 8


def _skew(first: np.ndarray, second: np.ndarray, period: float) -> float:
    """The median of cell 2's first :data:`SKEW_CONVERSIONS` conversions less cell 1's latest, within a period."""
    if first.size < 2 or second.size < 2 or not period > 0:
        return math.nan
    latest = np.searchsorted(first, second, side="right") - 1
    inside = np.flatnonzero(latest >= 0)[:SKEW_CONVERSIONS]
    if inside.size == 0:
        return math.nan
    offset = np.mod(second[inside] - first[latest[inside]], period)
    offset = np.where(offset > 0.5 * period, offset - period, offset)  # the nearer side: -T/2 .. T/2
    return float(np.median(offset))


def check_rig(path: str | Path, adc: ADC, *, capacity: tuple[float, float] | None = None,
              offsets: tuple[float, float] | None = None, tick_s: float | None = None,
              link: Link | None = None) -> RigCheck:  # fmt: skip
    """Check the recording ``path`` against ``adc`` (and, from a calibration, its cells' ``capacity`` about their
    ``offsets`` and the rate filter's tick ``tick_s``; with the ``link`` it came over, its traffic); see the module
    docstring."""
    path = Path(path)
    names = _names(path)
    if "t_s" not in names:
        raise InputError(f"{path}: sail check-rig needs t_s, the time of each tick [s] (docs/reference/multirate.md)")
    stamps = tuple(c for c in LOAD_TIME_COLUMNS if c in names)
    flagged = ("device_status",) if "device_status" in names else ()
    values, malformed, _ = read_all(path, (*READING_COLUMNS, "t_s", *stamps, *flagged))
    t = values["t_s"]
    valid = ~malformed & np.isfinite(t) & np.isfinite(values["theta1_deg"]) & np.isfinite(values["theta2_deg"])
    if np.count_nonzero(valid) < 3:
        raise InputError(f"{path}: fewer than three valid ticks (t_s and both angles numbers): nothing to check")
    tv = t[valid]
    steps = np.diff(tv)
    tick = float(np.median(steps[steps > 0])) if np.any(steps > 0) else math.nan
    forward = steps[steps > 0]
    regular = forward[forward <= GAP_STEPS * tick]
    tick_jitter = float(np.sqrt(np.mean((regular - tick) ** 2))) if regular.size else math.nan
    gaps = int(np.count_nonzero(steps > GAP_STEPS * tick))
    steps_back = int(np.count_nonzero(steps <= 0))
    q = np.radians(np.column_stack([values["theta1_deg"][valid], values["theta2_deg"][valid]]))
    dq = np.abs(np.diff(q, axis=0))
    limit = MAX_JOINT_RATE * np.where(steps > 0, steps, tick)[:, None]
    jumps = int(np.count_nonzero(np.any(dq > limit, axis=1)))
    nominal = adc.rate_Hz if adc.rate_Hz > 0 else (1.0 / tick if tick > 0 else math.nan)
    cells, times = [], []
    for i, column in enumerate(("load1", "load2")):
        load = values[column]
        has = ~malformed & np.isfinite(load)
        stamp = LOAD_TIME_COLUMNS[i] in stamps
        when = values[LOAD_TIME_COLUMNS[i]][has] if stamp else t[has]
        when = np.where(np.isfinite(when), when, t[has])
        order = np.argsort(when, kind="stable")
        times.append(when[order])
        bound = None if capacity is None or offsets is None else capacity[i]
        centred = load[has] - (offsets[i] if bound is not None and offsets is not None else 0.0)
        cells.append(_cell(when[order], centred, stamp, nominal, bound))
    period = 1.0 / nominal if nominal > 0 else math.nan
    skew = _skew(times[0], times[1], period)
    drift = cells[1].rate_Hz / cells[0].rate_Hz - 1  # the phase slides this many seconds a second
    problems = _problems(adc, cells, tick, tick_jitter, gaps, steps_back, jumps, skew, period, tick_s,
                         int(np.count_nonzero(~valid)), t.size)  # fmt: skip
    device = _device_flags(values["device_status"]) if flagged else None
    for name, text in DEVICE_PROBLEMS.items():
        if device and device[name]:
            problems.append(text.format(n=device[name]))
    if link is not None:
        problems.extend(_link_problems(link, 1.0 / tick if tick > 0 else math.nan))
    return RigCheck(source=str(path), adc=adc.model, rows=int(t.size), invalid_rows=int(np.count_nonzero(~valid)),
                    tick_Hz=1.0 / tick if tick > 0 else math.nan, tick_jitter_s=tick_jitter, gaps=gaps,
                    steps_back=steps_back, encoder_jumps=jumps, cells=(cells[0], cells[1]), skew_s=skew,
                    skew_drift=drift, problems=tuple(problems), device_status=device, link=link)  # fmt: skip


def _device_flags(status: np.ndarray) -> dict[str, int]:
    """Ticks with each :data:`~sailforce.io.frames.DEVICE_STATUS` bit set (rows without a status count none)."""
    from ..io.frames import DEVICE_STATUS

    known = np.isfinite(status)
    bits = np.where(known, status, 0).astype(np.int64)
    return {name: int(np.count_nonzero(bits & bit)) for bit, name in DEVICE_STATUS.items()}


def _link_problems(link: Link, tick_Hz: float) -> list[str]:
    problems = []
    sent = link.frames + link.lost
    if link.binary and sent and link.lost > LOST_FRAME_LIMIT * sent:  # a corrupt frame is among the lost
        problems.append(f"{link.lost} frames lost ({link.corrupt} of them corrupt) of {sent:,} on {link.port} (over "
                        f"{LOST_FRAME_LIMIT:.1%}): a noisy cable, or a baud rate the link cannot hold")  # fmt: skip
    if math.isfinite(tick_Hz) and link.rows_per_s < THROUGHPUT_LIMIT * tick_Hz:
        problems.append(f"{link.port} carried {link.rows_per_s:.4g} rows/s ({link.bytes_per_s:,.0f} bytes/s) of a "
                        f"{tick_Hz:.4g} Hz tick: the link is too slow for the stream (the baud budget, "
                        f"docs/reference/frames.md)")  # fmt: skip
    return problems


def _problems(adc: ADC, cells, tick, tick_jitter, gaps, steps_back, jumps, skew, period, tick_s, invalid, rows) -> list[str]:
    problems = []
    tolerance = adc.rate_tolerance or DEFAULT_RATE_TOLERANCE
    for i, cell in enumerate(cells, start=1):
        if cell.conversions < 3:
            problems.append(f"cell {i} has {cell.conversions} conversions: too few to measure its rate")
            continue
        if adc.rate_Hz > 0 and not abs(cell.rate_error) <= tolerance:
            problems.append(f"cell {i} converts at {cell.rate_Hz:.4g} Hz, {cell.rate_error:+.1%} from {adc.model}'s "
                            f"{cell.nominal_Hz:g} Hz (its tolerance {tolerance:.1%}): another chip or rate pin?")  # fmt: skip
        if cell.missed > MISSED_LIMIT * cell.conversions:
            problems.append(f"cell {i} missed {cell.missed} conversions of {cell.conversions} (over "
                            f"{MISSED_LIMIT:.0%}): the firmware reads it too late, or it blocks")  # fmt: skip
        if adc.rate_Hz > 0 and cell.jitter_s > CONVERSION_JITTER_LIMIT / adc.rate_Hz:
            problems.append(f"cell {i}'s conversions wander by {cell.jitter_s * 1e3:.3g} ms rms (over "
                            f"{CONVERSION_JITTER_LIMIT:.0%} of a period): stamp data-ready (loadN_t_s) or poll it faster")  # fmt: skip
        if cell.saturated > SATURATED_LIMIT * cell.conversions:
            problems.append(f"cell {i} saturated {cell.saturated} times: its gain or the load is too high")
    if tick_jitter > TICK_JITTER_LIMIT * tick:
        problems.append(f"the ticks wander by {tick_jitter * 1e3:.3g} ms rms, over {TICK_JITTER_LIMIT:.0%} of their "
                        f"{tick * 1e3:.3g} ms: the rate filter takes them as regular (a hardware timer)")  # fmt: skip
    if tick_s is not None and abs(tick / tick_s - 1) > DEFAULT_RATE_TOLERANCE:
        problems.append(f"the ticks come every {tick * 1e3:.4g} ms; the calibration's rate filter was made for "
                        f"{tick_s * 1e3:.4g} ms")  # fmt: skip
    if steps_back:
        problems.append(f"t_s steps back {steps_back} times: a clock reset or rows out of order")
    if jumps:
        problems.append(f"an angle jumps faster than {MAX_JOINT_RATE:g} rad/s {jumps} times: missed encoder edges or glitches")
    if invalid > 0.01 * rows:
        problems.append(f"{invalid} of {rows} rows are not readings (malformed, or an angle or t_s not a number)")
    if adc.simultaneous and math.isfinite(skew) and abs(skew) > SIMULTANEOUS_SKEW_LIMIT * period:
        problems.append(f"{adc.model} converts both cells together, but they are {skew * 1e3:.3g} ms apart")
    del gaps  # reported, not a problem: the estimate marks the rows about a gap motion-unknown
    return problems
