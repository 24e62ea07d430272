"""Measurement tables: CSV or Parquet (by extension), read in chunks of constant memory.

A table has a header row naming its columns; sailforce needs some of them
(``theta1_deg, theta2_deg, load1, load2``, and ``fx_N, fy_N`` to calibrate)
and passes every other column through untouched: CSV fields are read as
text and written back as the same text.

Bad rows are never dropped.  A field that is empty, not a number, or a row
with too few or too many fields gives NaN in the numeric columns, and the
row is flagged in :attr:`Chunk.malformed`; callers mark such rows
``invalid``.  A short row keeps the fields it has; a long row keeps the
first ones (the extras are reported in the count of malformed rows).
Newlines inside quoted fields are not supported (the file is split at
line ends to stream it).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from .io import TableError

READING_COLUMNS = ("theta1_deg", "theta2_deg", "load1", "load2")
REFERENCE_COLUMNS = ("fx_N", "fy_N")

#: Bytes of CSV parsed per chunk: ~50k rows of a typical file, a few tens of
#: MB of working memory whatever the file size.
CHUNK_BYTES = 2 << 20


@dataclass(frozen=True)
class Chunk:
    """Consecutive rows: the original columns, the needed ones as float64, and malformed-row flags."""

    table: pa.Table  #: every column as read (CSV: text), for pass-through
    values: dict[str, np.ndarray]  #: needed column -> float64, NaN where missing or not a number
    malformed: np.ndarray  #: bool, rows with the wrong number of fields
    first_line: int  #: file line of the first row (1 is the header), for messages
    quoted: bool = True  #: some text field may need quoting when written back as CSV


def is_parquet(path: Path) -> bool:
    return path.suffix.lower() in (".parquet", ".pq")


def read_chunks(path: str | Path, needed: tuple[str, ...], chunk_bytes: int = CHUNK_BYTES) -> Iterator[Chunk]:
    """Yield the table at ``path`` chunk by chunk (CSV or Parquet by extension)."""
    path = Path(path)
    if not path.is_file():
        raise TableError(f"{path}: no such file")
    if is_parquet(path):
        yield from _parquet_chunks(path, needed)
    else:
        yield from _csv_chunks(path, needed, chunk_bytes)


def read_all(path: str | Path, needed: tuple[str, ...]) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The needed columns of a whole (small) table: ``(values, malformed, line numbers)``."""
    values: dict[str, list] = {n: [] for n in needed}
    malformed, lines = [], []
    for chunk in read_chunks(path, needed):
        for n in needed:
            values[n].append(chunk.values[n])
        malformed.append(chunk.malformed)
        lines.append(chunk.first_line + np.arange(chunk.malformed.size))
    if not malformed:
        raise TableError(f"{path}: no data rows below the header")
    return ({n: np.concatenate(v) for n, v in values.items()}, np.concatenate(malformed), np.concatenate(lines))


def _check_columns(path: Path, names: list[str], needed: tuple[str, ...]) -> None:
    missing = [n for n in needed if n not in names]
    if missing:
        raise TableError(f"{path}: missing column(s) {', '.join(missing)}; the header has {', '.join(names) or 'nothing'}")
    duplicated = {n for n in names if names.count(n) > 1}
    if duplicated:
        raise TableError(f"{path}: duplicated column(s) {', '.join(sorted(duplicated))} in the header")


def _csv_chunks(path: Path, needed: tuple[str, ...], chunk_bytes: int) -> Iterator[Chunk]:
    with open(path, "rb") as stream:
        header = stream.readline()
        try:
            names = [n.strip() for n in next(csv.reader([header.decode("utf-8-sig")]), [])]
        except UnicodeDecodeError:
            raise TableError(f"{path}: the header is not UTF-8 text; is this a CSV file?") from None
        _check_columns(path, names, needed)
        line = 2
        tail = b""
        while True:
            block = stream.read(chunk_bytes)
            data = tail + block
            if not block:
                tail = b""
            else:
                cut = data.rfind(b"\n") + 1
                data, tail = data[:cut], data[cut:]
            if data.strip():
                chunk = _parse_csv(path, data, names, needed, line)
                line += data.count(b"\n")
                yield chunk
            if not block:
                break


def _parse_csv(path: Path, data: bytes, names: list[str], needed: tuple[str, ...], first_line: int) -> Chunk:
    bad_rows = []

    def on_invalid(row) -> str:
        bad_rows.append(row)
        return "skip"

    try:
        table = pacsv.read_csv(
            io.BytesIO(data),
            read_options=pacsv.ReadOptions(column_names=names),
            parse_options=pacsv.ParseOptions(invalid_row_handler=on_invalid),
            convert_options=pacsv.ConvertOptions(column_types={n: pa.string() for n in names}, strings_can_be_null=False),
        )
    except (pa.ArrowInvalid, UnicodeDecodeError):
        bad_rows.append(None)
    if bad_rows:  # rare: keep every row, in order, by parsing this chunk slowly
        return _parse_csv_slowly(path, data, names, needed, first_line)
    values = {n: _to_float(table.column(n)) for n in needed}
    # Unquoted CSV text cannot hold a separator, quote or line end, so it is written back as is.
    return Chunk(table, values, np.zeros(table.num_rows, dtype=bool), first_line, quoted=b'"' in data)


def _parse_csv_slowly(path: Path, data: bytes, names: list[str], needed: tuple[str, ...], first_line: int) -> Chunk:
    text = data.decode("utf-8", errors="replace")
    rows, malformed = [], []
    for fields in csv.reader(io.StringIO(text)):
        if not fields or (len(fields) == 1 and not fields[0].strip()):
            continue
        malformed.append(len(fields) != len(names))
        rows.append((fields + [""] * len(names))[: len(names)])
    columns = list(zip(*rows)) if rows else [()] * len(names)
    table = pa.table({n: pa.array(list(c), type=pa.string()) for n, c in zip(names, columns)})
    values = {n: _to_float(table.column(n)) for n in needed}
    return Chunk(table, values, np.array(malformed, dtype=bool), first_line)


def _to_float(column: pa.ChunkedArray) -> np.ndarray:
    """Text to float64; NaN for anything that is not a number (the caller flags it invalid)."""
    try:
        return pc.cast(column, pa.float64()).to_numpy(zero_copy_only=False).astype(float, copy=False)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return np.array([_parse_number(v) for v in column.to_pylist()], dtype=float)


def _parse_number(value) -> float:
    if value is None:
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _parquet_chunks(path: Path, needed: tuple[str, ...]) -> Iterator[Chunk]:
    try:
        parquet = pq.ParquetFile(path)
        names = parquet.schema_arrow.names
    except (pa.ArrowInvalid, OSError) as exc:
        raise TableError(f"{path}: not a readable Parquet file ({exc})") from None
    _check_columns(path, list(names), needed)
    line = 1
    try:
        for batch in parquet.iter_batches(batch_size=1 << 18):
            table = pa.Table.from_batches([batch])
            values = {}
            for n in needed:
                column = table.column(n)
                values[n] = _to_float(column) if pa.types.is_string(column.type) else (
                    pc.cast(column, pa.float64()).to_numpy(zero_copy_only=False).astype(float))
            yield Chunk(table, values, np.zeros(table.num_rows, dtype=bool), line)
            line += table.num_rows
    except (pa.ArrowInvalid, OSError) as exc:
        raise TableError(f"{path}: corrupt Parquet data after row {line - 1} ({exc})") from None
