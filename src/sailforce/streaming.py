"""Estimating force over files of any size, and over a live line stream.

Output columns: the input's, untouched, then ``fx_N, fy_N, force_N,
angle_deg, status``.  Every input row gives exactly one output row, in
order; rows without an estimate (invalid, singular) have empty force fields.
"""

from __future__ import annotations

import csv
import math
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Callable, IO, Iterable

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from .calfile import Calibration
from .estimator import INVALID, STATUS_NAMES
from .filters import LowPass
from .io import atomic_writer
from .tables import READING_COLUMNS, Chunk, TableError, is_parquet, read_chunks

OUTPUT_COLUMNS = ("fx_N", "fy_N", "force_N", "angle_deg", "status")
_STATUS_TEXT = pa.array(STATUS_NAMES)


#: Chunks in flight at once: estimating and formatting one chunk (numpy and
#: Arrow release the GIL) overlaps with parsing the next and writing the last.
WORKERS = 2


def estimate_columns(cal: Calibration, values: dict[str, np.ndarray], malformed: np.ndarray,
                     lowpass: LowPass | None = None) -> tuple[dict[str, np.ndarray], np.ndarray]:  # fmt: skip
    """The output columns for one chunk of readings (degrees in, as in files), and the status codes."""
    return _estimate(cal, values, malformed, _loads(values, malformed, lowpass))


def _loads(values: dict[str, np.ndarray], malformed: np.ndarray, lowpass: LowPass | None) -> np.ndarray:
    """The ``(n, 2)`` loads, low-pass filtered if asked (sequential: the filter state runs through the stream)."""
    loads = np.column_stack([values["load1"], values["load2"]])
    if lowpass is None:
        return loads
    valid = ~malformed & np.all(np.isfinite(loads), axis=1)
    valid &= np.isfinite(values["theta1_deg"]) & np.isfinite(values["theta2_deg"])
    return lowpass.process(loads, valid)


def _estimate(cal: Calibration, values: dict[str, np.ndarray], malformed: np.ndarray,
              loads: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:  # fmt: skip
    theta1, theta2 = np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"])
    fx, fy, status = cal.estimate(theta1, theta2, loads[:, 0], loads[:, 1], threads=1)  # chunks already run in parallel
    status[malformed] = INVALID
    fx[malformed] = np.nan
    fy[malformed] = np.nan
    force = np.hypot(fx, fy)
    angle = np.degrees(np.arctan2(fy, fx))
    return {"fx_N": fx, "fy_N": fy, "force_N": force, "angle_deg": angle}, status


def _output_table(table: pa.Table, columns: dict[str, np.ndarray], status: np.ndarray) -> pa.Table:
    for name, values in columns.items():
        table = table.append_column(name, pa.array(values, mask=np.isnan(values)))
    return table.append_column("status", _STATUS_TEXT.take(pa.array(status.astype(np.int32))))


def _chunk_output(cal: Calibration, chunk: Chunk, loads: np.ndarray, csv_header: bool | None):
    """One chunk's output (an Arrow table, or its CSV bytes when ``csv_header`` is not None) and status counts."""
    columns, status = _estimate(cal, chunk.values, chunk.malformed, loads)
    counts = np.bincount(status, minlength=len(STATUS_NAMES))
    table = _output_table(chunk.table, columns, status)
    if csv_header is None:
        return table, counts
    sink = pa.BufferOutputStream()
    style = "needed" if chunk.quoted else "none"  # "none" keeps pass-through fields byte-identical
    pacsv.write_csv(table, sink, pacsv.WriteOptions(include_header=csv_header, quoting_style=style))
    return sink.getvalue(), counts


def stream_estimate(
    cal: Calibration,
    source: str | Path,
    destination: str | Path,
    *,
    lowpass: LowPass | None = None,
    on_chunk: Callable[[int], None] | None = None,
) -> dict[str, int]:
    """Estimate every row of ``source`` into ``destination`` (CSV or Parquet by extension), in constant memory.

    The output file appears only when complete (atomic write).  ``on_chunk``
    receives the number of rows written, for progress.  Chunks are estimated
    on :data:`WORKERS` threads and written in order.  Returns the count of
    rows per status.
    """
    source, destination = Path(source), Path(destination)
    counts = np.zeros(len(STATUS_NAMES), dtype=np.int64)
    parquet_out = is_parquet(destination)
    writer = None

    def write(job: tuple[Future, int]) -> None:
        nonlocal writer, counts
        output, chunk_counts = job[0].result()
        if parquet_out:
            writer = writer or pq.ParquetWriter(stream, output.schema)
            writer.write_table(output)
        else:
            stream.write(output)
        counts += chunk_counts
        if on_chunk:
            on_chunk(job[1])

    with atomic_writer(destination, "wb") as stream, ThreadPoolExecutor(WORKERS) as pool:
        pending: deque[tuple[Future, int]] = deque()
        first = True
        for chunk in read_chunks(source, READING_COLUMNS):
            loads = _loads(chunk.values, chunk.malformed, lowpass)
            header = None if parquet_out else first
            pending.append((pool.submit(_chunk_output, cal, chunk, loads, header), chunk.table.num_rows))
            first = False
            while len(pending) >= WORKERS:
                write(pending.popleft())
        while pending:
            write(pending.popleft())
        if writer is not None:
            writer.close()
        if first:
            raise TableError(f"{source}: no data rows below the header")
    return {name: int(n) for name, n in zip(STATUS_NAMES, counts)}


def estimate_lines(cal: Calibration, lines: Iterable[str], out: IO[str], *, lowpass: LowPass | None = None) -> dict[str, int]:
    """Live stream: a header line, then one reading per line; each estimate is written and flushed at once."""
    counts = dict.fromkeys(STATUS_NAMES, 0)
    lines = iter(lines)
    header_line = next(lines, None)
    if header_line is None:
        raise TableError("the stream ended before its header line")
    names = [n.strip() for n in next(csv.reader([header_line]))]
    missing = [n for n in READING_COLUMNS if n not in names]
    if missing:
        raise TableError(f"stream header lacks column(s) {', '.join(missing)}: got {', '.join(names)}")
    index = {n: names.index(n) for n in READING_COLUMNS}
    out.write(",".join(names + list(OUTPUT_COLUMNS)) + "\n")
    out.flush()
    for line in lines:
        if not line.strip():
            continue
        fields = next(csv.reader([line.rstrip("\r\n")]))
        malformed = np.array([len(fields) != len(names)])
        values = {n: np.array([_number(fields, i)]) for n, i in index.items()}
        columns, status = estimate_columns(cal, values, malformed, lowpass)
        name = STATUS_NAMES[int(status[0])]
        counts[name] += 1
        numbers = ["" if math.isnan(columns[c][0]) else f"{columns[c][0]:.9g}" for c in OUTPUT_COLUMNS[:-1]]
        out.write(line.rstrip("\r\n") + "," + ",".join(numbers + [name]) + "\n")
        out.flush()
    return counts


def _number(fields: list[str], i: int) -> float:
    try:
        return float(fields[i])
    except (IndexError, ValueError):
        return math.nan
