"""Estimating force over files of any size, and over a live line stream, in chunks.

Every input row gives exactly one output row, in order; rows without an
estimate (invalid, singular) have empty force fields.  The rows' format is
:mod:`sailforce.stream.output`'s; with a dynamic term, each row's joint
rates come from :mod:`sailforce.stream.motion`.  File mode and stream mode
share :func:`~sailforce.stream.output.csv_rows`: the same bytes in give the
same bytes out.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Protocol

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from .._signals import HeldSignals
from ..calibration.file import Calibration
from ..estimate.estimator import INVALID, STATUS_NAMES
from ..estimate.filters import LowPass
from ..estimate.multirate import LOAD_TIME_COLUMNS, MultiRateEstimator
from ..estimate.rezero import REZERO_COLUMNS, ReZero
from ..io.files import atomic_writer
from ..io.tables import (
    READING_COLUMNS,
    Chunk,
    TableError,
    chunk_jobs,
    csv_chunks,
    csv_header,
    is_parquet,
    parquet_schema,
    read_header,
)
from ..status import count_statuses
from .motion import TIME_COLUMN, MotionColumns, MotionRows, MotionStage, motion_columns
from .output import ParquetTypes, csv_output_header, csv_rows, output_columns, output_header, output_table


class ByteSink(Protocol):
    """Where a live stream's rows go: a binary file, stdout, or a live server's recorder."""

    def write(self, data: bytes, /) -> object: ...

    def flush(self) -> object: ...


def _discarding(sink: ByteSink) -> bool:
    """Whether a sink throws the rows' bytes away for now (a live page that is not recording): then they are not made."""
    return bool(getattr(sink, "discarding", False))


#: Receives each chunk of a live stream as it is estimated: the chunk (its ``values`` are the input's numbers,
#: degrees as in files), the output columns (``fx_N`` ...) and the status codes, one per row, in order.
RowListener = Callable[[Chunk, dict[str, np.ndarray], np.ndarray], None]

#: The cells' temperature [°C], which a calibration with temperature coefficients compensates.
TEMPERATURE_COLUMN = "temperature_C"

#: Chunks in flight at once: estimating and formatting one chunk (numpy and
#: Arrow release the GIL) overlaps with parsing the next and writing the last.
WORKERS = 2


def _loads(values: dict[str, np.ndarray], malformed: np.ndarray, lowpass: LowPass | None,
           motion: MotionRows | None = None) -> np.ndarray:  # fmt: skip
    """The ``(n, 2)`` loads, low-pass filtered if asked (sequential: the filter state runs through the stream).

    With a motion, the filter runs on the loads less their inertial part
    (which is then added back, to be subtracted with the estimate), so that
    the filter's delay does not misalign the loads and the dynamic term.
    """
    loads = np.column_stack([values["load1"], values["load2"]])
    if lowpass is None:
        return loads
    valid = ~malformed & np.all(np.isfinite(loads), axis=1)
    valid &= np.isfinite(values["theta1_deg"]) & np.isfinite(values["theta2_deg"])
    if motion is None:
        return lowpass.process(loads, valid)
    inertial = motion.inertial(values)
    known = valid & np.all(np.isfinite(inertial), axis=1)
    filtered = lowpass.process(loads - np.where(known[:, None], inertial, 0.0), known) + inertial
    return np.where(known[:, None], filtered, loads)  # unknown motion: the raw loads, for the static checks


class MultiRateStage:
    """The multi-rate estimator fed a table's chunks in order (:class:`sailforce.estimate.multirate.MultiRateEstimator`)."""

    def __init__(self, cal: Calibration, source: object, names: list[str], motion: MotionColumns | None):
        if TIME_COLUMN not in names:
            raise TableError(f"{source}: the calibration's ADC ({cal.adc.model}) makes this a multi-rate recording, "
                             f"which needs {TIME_COLUMN}, the time of each encoder tick [s] (docs/reference/multirate.md)")  # fmt: skip
        self.times = tuple(c for c in LOAD_TIME_COLUMNS if c in names)
        self.engine = MultiRateEstimator(cal, dynamic=motion is not None)

    @property
    def needed(self) -> tuple[str, ...]:
        return (TIME_COLUMN, *self.times)

    def estimate(self, chunk: Chunk, rows: MotionRows | None) -> tuple[dict[str, np.ndarray], np.ndarray]:
        values, n = chunk.values, chunk.num_rows
        q = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
        loads = np.column_stack([values["load1"], values["load2"]])
        load_t = np.column_stack([values[c] if c in values else np.full(n, np.nan) for c in LOAD_TIME_COLUMNS])
        out = self.engine.rows(values[TIME_COLUMN], q, loads, load_t, chunk.malformed,
                               None if rows is None else rows.rate, None if rows is None else rows.accel)  # fmt: skip
        return out.columns, out.status


def _multirate(cal: Calibration, source: object, names: list[str], motion: MotionColumns | None,
               lowpass: LowPass | None) -> MultiRateStage | None:  # fmt: skip
    if not cal.multirate:
        return None
    if lowpass is not None:
        raise TableError(f"{source}: the calibration's ADC ({cal.adc.model}) already filters each conversion; "
                         "a low-pass on its conversions would blur their instants: leave out --lowpass-Hz")  # fmt: skip
    return MultiRateStage(cal, source, names, motion)


def _estimate(cal: Calibration, values: dict[str, np.ndarray], malformed: np.ndarray, loads: np.ndarray,
              motion: MotionRows | None = None) -> tuple[dict[str, np.ndarray], np.ndarray]:  # fmt: skip
    theta1, theta2 = np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"])
    inertial = None
    if motion is None:
        # no motion columns: the still-arm estimate even with a dynamic term (the summary says why); chunks run in parallel
        fx, fy, status = cal.estimate(theta1, theta2, loads[:, 0], loads[:, 1], threads=1, static=True)
    else:
        fx, fy, status, inertial = motion.estimate(cal, theta1, theta2, loads)
    status[malformed] = INVALID
    fx[malformed] = np.nan
    fy[malformed] = np.nan
    columns = {"fx_N": fx, "fy_N": fy, "force_N": np.hypot(fx, fy), "angle_deg": np.degrees(np.arctan2(fy, fx))}
    if inertial is not None:
        inertial[malformed] = np.nan
        columns |= {"inertial1": inertial[:, 0], "inertial2": inertial[:, 1]}
    return columns, status


def _job_output(cal: Calibration, job: Callable[[], Chunk], parquet: ParquetTypes | None):
    chunk = job()
    return _chunk_output(cal, chunk, _loads(chunk.values, chunk.malformed, None), parquet)


def _heard(chunk: Chunk, motion: MotionRows | None) -> Chunk:
    """The chunk a listener hears: with a motion whose rates were derived, the rates among its values (``omega1_dps,
    omega2_dps``, as a table of measured rates names them)."""
    if motion is None or {"omega1_dps", "omega2_dps"} & chunk.values.keys():
        return chunk
    return replace(chunk, values={**chunk.values, "omega1_dps": np.degrees(motion.rate[:, 0]),
                                  "omega2_dps": np.degrees(motion.rate[:, 1])})  # fmt: skip


def _temperature_needed(cal: Calibration, names: list[str]) -> tuple[str, ...]:
    """``temperature_C`` when the calibration compensates temperature and the table has it."""
    return (TEMPERATURE_COLUMN,) if cal.temperature is not None and TEMPERATURE_COLUMN in names else ()


def _compensated(chunk: Chunk, cal: Calibration) -> Chunk:
    """The chunk with its loads as at the calibration's reference temperature (when it compensates and the table
    has ``temperature_C``; sailforce.drift.TemperatureCompensation).  The output's lines keep the raw loads."""
    if cal.temperature is None or TEMPERATURE_COLUMN not in chunk.values:
        return chunk
    v = chunk.values
    loads = cal.temperature.corrected(np.column_stack([v["load1"], v["load2"]]), v[TEMPERATURE_COLUMN], cal.offsets)
    return replace(chunk, values={**v, "load1": loads[:, 0], "load2": loads[:, 1]})


def _rezero_needed(rezero: ReZero | None, source: object, names: list[str]) -> tuple[str, ...]:
    """The columns a re-zero reads: ``t_s`` (required) and ``contact`` (when the table has it)."""
    if rezero is None:
        return ()
    if TIME_COLUMN not in names:
        raise TableError(f"{source}: a re-zero (--rezero) needs {TIME_COLUMN}, each row's time [s], to judge a window")
    return (TIME_COLUMN, *(("contact",) if "contact" in names else ()))


def _rezeroed(rezero: ReZero, chunk: Chunk, estimated: tuple[dict[str, np.ndarray], np.ndarray]):
    """The chunk's estimate with the re-zero applied, in order, and its :data:`REZERO_COLUMNS` added."""
    columns, status = estimated
    v = chunk.values
    out = rezero.process(v[TIME_COLUMN], np.radians(v["theta1_deg"]), np.radians(v["theta2_deg"]), columns["fx_N"],
                         columns["fy_N"], status, v.get("contact"))  # fmt: skip
    fx, fy = out["fx_N"], out["fy_N"]
    columns = {**columns, "fx_N": fx, "fy_N": fy, "force_N": np.hypot(fx, fy), "angle_deg": np.degrees(np.arctan2(fy, fx))}
    return columns | {name: out[name] for name in REZERO_COLUMNS}, status


def _appended(motion: bool, multirate: bool, rezero: bool) -> tuple[str, ...]:
    names = output_columns(motion, multirate)
    return (*names[:-1], *REZERO_COLUMNS, names[-1]) if rezero else names


def _chunk_output(cal: Calibration, chunk: Chunk, loads: np.ndarray, parquet: ParquetTypes | None,
                  motion: MotionRows | None = None, on_rows: RowListener | None = None,
                  estimated: tuple[dict[str, np.ndarray], np.ndarray] | None = None):  # fmt: skip
    """One chunk's output (CSV bytes, or an Arrow table when writing Parquet), its status counts, its size, and what
    a listener hears of it (the chunk, its columns and statuses: ``stream_estimate`` tells it in order).  With a
    motion whose rates were derived, the chunk heard carries them among its values, as ``omega1_dps, omega2_dps``.

    ``estimated`` holds the chunk's columns and statuses when they were made in order beforehand (multi-rate).
    """
    columns, status = estimated if estimated is not None else _estimate(cal, chunk.values, chunk.malformed, loads, motion)
    heard_chunk = _heard(chunk, motion)
    if on_rows is not None:
        on_rows(heard_chunk, columns, status)
    counts, size, heard = count_statuses(status), (chunk.num_rows, chunk.input_size), (heard_chunk, columns, status)
    if parquet is not None:
        table = parquet.convert(chunk) if chunk.from_csv else chunk.table
        return output_table(table, columns, status), counts, size, heard
    if chunk.lines is not None and not chunk.verbatim:
        return csv_rows(chunk.lines, columns, status), counts, size, heard
    # Arrow's writer: for Parquet input it formats the typed columns; for a verbatim CSV chunk, unquoted, it
    # writes the very bytes csv_rows would (tests/test_differential.py), some 25% faster.
    options = pacsv.WriteOptions(include_header=False, quoting_style="none" if chunk.verbatim else "needed")
    sink = pa.BufferOutputStream()
    pacsv.write_csv(output_table(chunk.table, columns, status), sink, options)
    return sink.getvalue().to_pybytes(), counts, size, heard


def table_motion(cal: Calibration, source: object, names: list[str]) -> MotionColumns | None:
    """The motion columns ``sail estimate`` uses: None unless the calibration has a dynamic term and the table a motion."""
    return None if cal.dynamics is None else motion_columns(source, names)


def stream_estimate(
    cal: Calibration,
    source: str | Path,
    destination: str | Path,
    *,
    lowpass: LowPass | None = None,
    on_chunk: Callable[[int, int], None] | None = None,
    dt: float | None = None,
    on_rows: RowListener | None = None,
    also: tuple[str, ...] = (),
    rezero: ReZero | None = None,
) -> dict[str, int]:
    """Estimate every row of ``source`` into ``destination`` (CSV or Parquet by extension), in constant memory.

    The output file appears only when complete (atomic write).  ``on_chunk``
    receives, for progress, the number of rows written and the part of the
    input they came from (:func:`sailforce.io.tables.input_size`'s unit).  Chunks are estimated
    on :data:`WORKERS` threads and written in order.  When the calibration
    has a dynamic term and the table a motion (:func:`table_motion`), it is
    subtracted; ``dt`` [s] is then the sampling period (probed from the
    first steps when None).  ``on_rows`` hears each chunk's numbers in order
    (:data:`RowListener`), with the columns of ``also`` that the table has
    among its values (``t_s`` for a bag's stamps).  With ``rezero``
    (:class:`sailforce.estimate.rezero.ReZero`) the offsets are re-estimated
    while the handle is free, in order, and each row carries the offsets in
    use and a ``rezero`` mark; its ``events`` log the decisions.  Returns
    the count of rows per status.
    """
    source, destination = Path(source), Path(destination)
    counts = np.zeros(len(STATUS_NAMES), dtype=np.int64)
    parquet = ParquetTypes() if is_parquet(destination) else None
    header = csv_header(source, READING_COLUMNS)
    names = header.names if header is not None else list(parquet_schema(source, READING_COLUMNS).names)
    motion = table_motion(cal, source, names)
    stage = MotionStage(cal, motion, dt) if motion is not None else None
    multirate = _multirate(cal, source, names, motion, lowpass)
    needed = tuple(dict.fromkeys(READING_COLUMNS + (motion.names if motion is not None else ())
                                 + (multirate.needed if multirate is not None else ())
                                 + tuple(name for name in also if name in names)
                                 + _rezero_needed(rezero, source, names) + _temperature_needed(cal, names)))  # fmt: skip
    writer = None

    def write(job: Future) -> None:
        nonlocal writer, counts
        output, chunk_counts, (rows, size), heard = job.result()
        if on_rows is not None:
            on_rows(*heard)
        if parquet is not None:
            writer = writer or pq.ParquetWriter(stream, output.schema)
            writer.write_table(output)
        else:
            stream.write(output)
        counts += chunk_counts
        if on_chunk:
            on_chunk(rows, size)

    with atomic_writer(destination, "wb") as stream, ThreadPoolExecutor(WORKERS) as pool:
        try:
            if parquet is None:
                stream.write(csv_output_header(source, header, _appended(motion is not None, multirate is not None,
                                                                         rezero is not None)))  # fmt: skip
            pending: deque[Future] = deque()

            def submit(chunk: Chunk, rows: MotionRows | None) -> None:
                loads = _loads(chunk.values, chunk.malformed, lowpass, rows)  # in order: the filter runs through
                estimated = multirate.estimate(chunk, rows) if multirate is not None else None  # in order: it has state
                if rezero is not None:  # in order too
                    estimated = _rezeroed(rezero, chunk, estimated or _estimate(cal, chunk.values, chunk.malformed, loads, rows))
                pending.append(pool.submit(_chunk_output, cal, chunk, loads, parquet, rows, None, estimated))
                while len(pending) >= WORKERS:
                    write(pending.popleft())

            for raw_job in chunk_jobs(source, needed):
                job = raw_job if cal.temperature is None else partial(lambda j: _compensated(j(), cal), raw_job)
                if stage is not None:
                    for chunk, rows in stage.push(job()):
                        submit(chunk, rows)
                elif lowpass is None and multirate is None and rezero is None:  # chunks are independent: parse them on the workers too
                    pending.append(pool.submit(_job_output, cal, job, parquet))
                    while len(pending) >= WORKERS:
                        write(pending.popleft())
                else:
                    submit(job(), None)
            for chunk, rows in stage.finish() if stage is not None else ():
                submit(chunk, rows)
            while pending:
                write(pending.popleft())
        finally:
            if writer is not None:  # before the file closes, also when a chunk fails
                writer.close()
        if not counts.sum():
            raise TableError(f"{source}: no data rows below the header")
    return {name: int(n) for name, n in zip(STATUS_NAMES, counts)}


def estimate_lines(cal: Calibration, lines: Iterable[bytes], open_output: Callable[[], ByteSink], *,
                   lowpass: LowPass | None = None, source: str = "the stream", dt: float | None = None,
                   on_motion: Callable[[MotionStage | None], None] | None = None,
                   on_rows: RowListener | None = None, also: tuple[str, ...] = (),
                   rezero: ReZero | None = None) -> dict[str, int]:  # fmt: skip
    """Live stream: a header line, then one reading per line; each estimate is written and flushed at once.

    ``lines`` are raw lines (bytes, line end included).  ``open_output`` is
    called once the header is read and checked, so that nothing is opened,
    let alone truncated, for a stream that is not a table of readings.  The
    rows are those :func:`stream_estimate` writes for the same bytes.  With
    a dynamic term and derived rates, each row is written half a window
    late (:meth:`sailforce.stream.motion.MotionStage.delay`), when its
    window is complete; an interrupt writes the rows still waiting, their
    motion unknown, before it ends the stream.  With a dynamic term,
    ``on_motion`` receives the motion stage once the header is read (None
    when the stream gives no motion), to report its delay.  ``on_rows``
    receives each chunk's numbers as it is written (:data:`RowListener`):
    live displays and Lab Streaming Layer outlets read them there, with the
    columns of ``also`` the stream has among the values.  A sink
    whose ``discarding`` attribute is true gets no bytes while it is (the
    rows are not formatted).  ``rezero`` re-zeros as in :func:`stream_estimate`.
    """
    counts = np.zeros(len(STATUS_NAMES), dtype=np.int64)
    lines = iter(lines)
    first = next(lines, b"")
    if not first:
        raise TableError(f"{source} ended before its header line")
    header = read_header(source, first, READING_COLUMNS)
    motion = table_motion(cal, source, header.names)
    stage = MotionStage(cal, motion, dt) if motion is not None else None
    multirate = _multirate(cal, source, header.names, motion, lowpass)
    needed = tuple(dict.fromkeys(READING_COLUMNS + (motion.names if motion is not None else ())
                                 + (multirate.needed if multirate is not None else ())
                                 + tuple(name for name in also if name in header.names)
                                 + _rezero_needed(rezero, source, header.names) + _temperature_needed(cal, header.names)))  # fmt: skip
    out = open_output()
    out.write(header.line + output_header(_appended(motion is not None, multirate is not None, rezero is not None)))
    out.flush()
    if cal.dynamics is not None and on_motion is not None:
        on_motion(stage)

    def write(chunk: Chunk, rows: MotionRows | None) -> None:
        nonlocal counts
        loads = _loads(chunk.values, chunk.malformed, lowpass, rows)
        estimated = multirate.estimate(chunk, rows) if multirate is not None else None
        if rezero is not None:
            estimated = _rezeroed(rezero, chunk, estimated or _estimate(cal, chunk.values, chunk.malformed, loads, rows))
        if _discarding(out):  # the numbers alone, for the listener
            columns, status = estimated or _estimate(cal, chunk.values, chunk.malformed, loads, rows)
            if on_rows is not None:
                on_rows(_heard(chunk, rows), columns, status)
            counts += count_statuses(status)
            return
        output, chunk_counts, _, _ = _chunk_output(cal, chunk, loads, None, rows, on_rows, estimated)
        out.write(output)
        out.flush()
        counts += chunk_counts

    try:
        with HeldSignals() as signals:
            for raw in csv_chunks(source, header, needed, _whole_lines(lines), fast=False):
                chunk = _compensated(raw, cal)
                with signals.held():  # a row the stage has released is written before Ctrl-C acts
                    for ready in stage.push(chunk) if stage is not None else [(chunk, None)]:
                        write(*ready)
    except KeyboardInterrupt:  # keep every row read: those still waiting for their window go out unknown
        for ready in stage.finish() if stage is not None else ():
            write(*ready)
        raise
    for ready in stage.finish() if stage is not None else ():
        write(*ready)
    if not counts.sum():
        raise TableError(f"{source}: no data rows below the header")
    return {name: int(n) for name, n in zip(STATUS_NAMES, counts)}
def _whole_lines(lines: Iterator[bytes]) -> Iterator[bytes]:
    """Each line as a block of its own, ending with ``\\n`` (the last line of a stream may lack one)."""
    for line in lines:
        yield line if line.endswith(b"\n") else line + b"\n"
