"""Measurement tables: CSV or Parquet (by extension), read in chunks of constant memory.

A table has a header row naming its columns; sailforce needs some of them
(``theta1_deg, theta2_deg, load1, load2``, and ``fx_N, fy_N`` to calibrate)
and passes every other column through untouched.

**One line, one row.**  In a CSV file every physical line after the header
is one row, whatever it holds, so a file read in chunks and the same bytes
read line by line from a stream give the same rows (docs/reference/guarantees.md):

- a line ends at ``\\n``; one ``\\r`` before it belongs to the line end;
  the last line needs no line end; a UTF-8 byte-order mark before the
  header is dropped;
- fields are split at commas; a line that holds a ``"`` is read with CSV
  quoting (:mod:`csv`), but a quote never continues a row onto the next
  line, so newlines inside quoted fields are not supported;
- a row whose field count differs from the header's, a blank line, a line
  that cannot be split (a stray ``\\r`` inside quotes), a field longer than
  :data:`MAX_FIELD_CHARS` and a line longer than :data:`MAX_LINE_BYTES` are
  **malformed**: their numbers are NaN and the
  caller marks them ``invalid``.  A line longer than :data:`MAX_LINE_BYTES`
  is not copied (its pass-through text is empty);
- a needed field that is empty or not a number is NaN.

:attr:`Chunk.lines` keeps each row's line (without its line end) for
byte-faithful CSV pass-through, unless the chunk is :attr:`Chunk.verbatim`
(every line its fields joined by commas, as Arrow's parser saw them); a row with too few fields (a blank line
too) gets empty fields appended there, so its columns stay in place.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import BinaryIO

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from .files import TableError

READING_COLUMNS = ("theta1_deg", "theta2_deg", "load1", "load2")
REFERENCE_COLUMNS = ("fx_N", "fy_N")

#: Bytes of CSV parsed per chunk: ~25k rows of a typical file, a few tens of
#: MB of working memory whatever the file size.  Measured on 10 M rows
#: (`make bench`): 1 MiB gave 1.15 M rows/s at 248 MB peak, 2 MiB 0.98 M
#: rows/s at 298 MB.
CHUNK_BYTES = 1 << 20

#: A line longer than this is malformed and not copied: a reading is under
#: 200 bytes, and reading on would let one corrupt line exhaust memory.
MAX_LINE_BYTES = 1 << 20

#: A field longer than this (in characters) makes its row malformed: the
#: limit of Python's csv module, which reads quoted lines, applied to every line.
MAX_FIELD_CHARS = 128 << 10

#: The spellings of a number that Arrow's string-to-float64 cast reads
#: (checked in tests/test_tables.py), matched case-insensitively.
_NUMBER = r"^[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:e[+-]?[0-9]+)?|inf|infinity|nan)$"

_BOM = b"\xef\xbb\xbf"

#: What an over-long line is read as, in files and streams alike: too long, so malformed and not copied.
_OVERLONG = b"\0" * (MAX_LINE_BYTES + 1) + b"\n"


@dataclass(frozen=True)
class Chunk:
    """Consecutive rows: the original columns, the needed ones as float64, and malformed-row flags."""

    table: pa.Table  #: every column as read (CSV: text, padded or cut to the header's width), for pass-through
    values: dict[str, np.ndarray]  #: needed column -> float64, NaN where missing or not a number
    malformed: np.ndarray  #: bool, rows that are not a well-formed line of the header's width
    first_line: int  #: file line of the first row (1 is the header), for messages
    lines: pa.Array | None = None  #: CSV, unless verbatim: each row's input line (binary, without its line end)
    input_size: int = 0  #: how much of the input the chunk covers, in :func:`input_size`'s unit
    verbatim: bool = False  #: CSV: each line is exactly its fields joined by commas (no quote, width as the header's)

    @property
    def num_rows(self) -> int:
        return self.malformed.size

    @property
    def from_csv(self) -> bool:
        return self.verbatim or self.lines is not None


@dataclass(frozen=True)
class Header:
    """A CSV header line: the column names and the line itself (for the output's header)."""

    names: list[str]
    line: bytes  #: without byte-order mark and line end


def is_parquet(path: Path) -> bool:
    return path.suffix.lower() in (".parquet", ".pq")


def read_chunks(path: str | Path, needed: tuple[str, ...], chunk_bytes: int | None = None) -> Iterator[Chunk]:
    """Yield the table at ``path`` chunk by chunk (CSV or Parquet by extension)."""
    for job in chunk_jobs(path, needed, chunk_bytes):
        yield job()


def chunk_jobs(path: str | Path, needed: tuple[str, ...], chunk_bytes: int | None = None) -> Iterator[Callable[[], Chunk]]:
    """Like :func:`read_chunks`, but each chunk comes as a function that parses it, to be run on any thread.

    The file is read in order here; only the parsing is deferred.
    """
    path = Path(path)
    if not path.is_file():
        raise TableError(f"{path}: no such file")
    if is_parquet(path):
        for chunk in _parquet_chunks(path, needed):
            yield lambda chunk=chunk: chunk
        return
    with open(path, "rb") as stream:
        header = read_header(path, stream.readline(MAX_LINE_BYTES + 1), needed)
        line = 2
        for block in _line_blocks(stream, chunk_bytes or CHUNK_BYTES):
            yield partial(_csv_chunk, block, header.names, needed, line, True)
            line += block.count(b"\n")


def input_size(path: str | Path) -> int:
    """The size of a table for progress: bytes of a CSV file, rows of a Parquet file."""
    path = Path(path)
    try:
        return pq.ParquetFile(path).metadata.num_rows if is_parquet(path) else path.stat().st_size
    except (pa.ArrowInvalid, OSError):  # reading it will say what is wrong
        return 0


def csv_header(path: str | Path, needed: tuple[str, ...]) -> Header | None:
    """The header of the CSV file at ``path`` (None for Parquet), checked for the needed columns."""
    path = Path(path)
    if is_parquet(path):
        return None
    with open(path, "rb") as stream:
        return read_header(path, stream.readline(MAX_LINE_BYTES + 1), needed)


def read_all(path: str | Path, needed: tuple[str, ...]) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """The needed columns of a whole (small) table: ``(values, malformed, line numbers)``."""
    values: dict[str, list] = {n: [] for n in needed}
    malformed, lines = [], []
    for chunk in read_chunks(path, needed):
        for n in needed:
            values[n].append(chunk.values[n])
        malformed.append(chunk.malformed)
        lines.append(chunk.first_line + np.arange(chunk.num_rows))
    if not malformed:
        raise TableError(f"{path}: no data rows below the header")
    return ({n: np.concatenate(v) for n, v in values.items()}, np.concatenate(malformed), np.concatenate(lines))


#: Readings and forces beyond this magnitude are refused by :func:`read_clean`: a 24-bit ADC gives
#: 8.4e6 counts, and squares of 1e150 already overflow float64 in a fit.
MAX_ABS_VALUE = 1e12


def table_names(path: str | Path) -> list[str]:
    """The column names of a CSV or Parquet table."""
    header = csv_header(path, ())
    return header.names if header is not None else list(parquet_schema(Path(path), ()).names)


def read_clean(path: str | Path, needed: tuple[str, ...], what: str, *, sparse: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """Every ``needed`` column of a calibration-type table, which must be clean: the first bad row is refused.

    A row is bad when it is malformed (a wrong number of fields) or a needed
    field is missing, not a number, or beyond :data:`MAX_ABS_VALUE`; a
    ``sparse`` column may be empty (NaN: a multi-rate table's loads between
    conversions), not beyond the bound.  ``what`` names the table in the
    message (``"Calibration data"``).
    """
    values, malformed, lines = read_all(path, needed)
    bad = malformed.copy()
    for name in needed:
        within = np.abs(values[name]) <= MAX_ABS_VALUE
        bad |= ~(within | np.isnan(values[name])) if name in sparse else ~within
    if bad.any():
        i = int(np.argmax(bad))
        text = lambda v: "missing or not a number" if np.isnan(v) else f"{v:g}"
        fields = ", ".join(f"{n}={text(values[n][i])}" for n in needed)
        raise TableError(
            f"{path}, line {lines[i]}: not a complete row of numbers within ±{MAX_ABS_VALUE:g} ({fields}"
            f"{'; wrong number of fields' if malformed[i] else ''}); {int(bad.sum())} such row(s). "
            f"{what} must be clean: fix or remove them"
        )
    return values


def read_header(source: object, raw: bytes, needed: tuple[str, ...]) -> Header:
    """Parse and check a header line (bytes as read, line end included); ``source`` names it in messages."""
    if not raw.strip():
        raise TableError(f"{source}: empty; expected a header line naming the columns, then one reading per line")
    if len(raw) > MAX_LINE_BYTES:
        raise TableError(f"{source}: the header line is longer than {MAX_LINE_BYTES} bytes; is this a CSV table?")
    line = _strip_line_end(raw.removeprefix(_BOM))
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError:
        raise TableError(f"{source}: the header is not UTF-8 text; is this a CSV file?") from None
    fields, ok = _split(text)
    if not ok:
        raise TableError(f"{source}: the header line cannot be read as CSV")
    names = [n.strip() for n in fields]
    check_columns(source, names, needed)
    return Header(names, line)


def check_columns(source: object, names: list[str], needed: tuple[str, ...]) -> None:
    missing = [n for n in needed if n not in names]
    if missing:
        raise TableError(f"{source}: missing column(s) {', '.join(missing)}; the header has {', '.join(names) or 'nothing'}")
    duplicated = {n for n in names if names.count(n) > 1}
    if duplicated:
        raise TableError(f"{source}: duplicated column(s) {', '.join(sorted(duplicated))} in the header")


def csv_chunks(source: object, header: Header, needed: tuple[str, ...], blocks: Iterable[bytes], *,
               fast: bool = True) -> Iterator[Chunk]:  # fmt: skip
    """Chunks from blocks of whole lines (each block ends with ``\\n``); lines are numbered from 2.

    ``fast=False`` skips the Arrow parser, cheaper for blocks of one line;
    the rows are the same either way.
    """
    line = 2
    for block in blocks:
        chunk = _csv_chunk(block, header.names, needed, line, fast)
        line += chunk.num_rows
        yield chunk


def _csv_chunk(block: bytes, names: list[str], needed: tuple[str, ...], first_line: int, fast: bool) -> Chunk:
    chunk = parse_lines(block, names, needed, first_line) if fast else _parse_slowly(block, names, needed, first_line)
    return replace(chunk, input_size=len(block))


def _line_blocks(stream: BinaryIO, chunk_bytes: int) -> Iterator[bytes]:
    """Blocks of whole lines, each ending with ``\\n``; a line over :data:`MAX_LINE_BYTES` becomes :data:`_OVERLONG`."""
    tail, skipping = b"", False
    while block := stream.read(chunk_bytes):
        if skipping:  # the rest of an over-long line: drop it
            end = block.find(b"\n")
            if end < 0:
                continue
            block, skipping = block[end + 1 :], False
        data = tail + block
        cut = data.rfind(b"\n") + 1
        data, tail = data[:cut], data[cut:]
        if len(tail.removesuffix(b"\r")) > MAX_LINE_BYTES:  # the line so far is too long: stop keeping it
            data, tail, skipping = data + _OVERLONG, b"", True
        if data:
            yield data
    if tail:
        yield tail + b"\n"


def read_line(stream: BinaryIO) -> bytes:
    """One line from a live stream (line end included; ``b""`` at its end), cut as :func:`_line_blocks` cuts."""
    line = stream.readline(MAX_LINE_BYTES + 2)
    if len(line) == MAX_LINE_BYTES + 2 and not line.endswith(b"\n"):  # over-long whatever follows: drop the rest
        while (rest := stream.readline(MAX_LINE_BYTES)) and not rest.endswith(b"\n"):
            pass
        return _OVERLONG
    return line


def parse_lines(data: bytes, names: list[str], needed: tuple[str, ...], first_line: int) -> Chunk:
    """Rows from whole lines (``data`` ends with ``\\n``): Arrow's parser where it splits as :func:`_split`, else line by line."""
    return _parse_fast(data, names, needed, first_line) or _parse_slowly(data, names, needed, first_line)


def _parse_fast(data: bytes, names: list[str], needed: tuple[str, ...], first_line: int) -> Chunk | None:
    """Arrow's CSV parser, for the common chunk with no quote, no stray CR and no over-long line."""
    if b'"' in data or not _is_utf8(data):  # Arrow's row handler cannot take invalid UTF-8
        return None
    ends = np.flatnonzero(np.frombuffer(data, np.uint8) == 10)
    carriage_returns = data.count(b"\r") if b"\r" in data else 0  # counting costs; looking does not
    crlf = carriage_returns == ends.size and data.count(b"\r\n") == ends.size
    if carriage_returns and not crlf:
        return None
    lengths = np.diff(ends, prepend=-1) - (2 if crlf else 1)
    if lengths.min() == 0 or lengths.max() > MAX_FIELD_CHARS:  # a blank line, or a field that might be too long
        return None
    invalid = []
    try:
        table = pacsv.read_csv(
            io.BytesIO(data),
            read_options=pacsv.ReadOptions(column_names=names),  # lines under 128 KiB: any block size will do
            parse_options=pacsv.ParseOptions(quote_char=False, ignore_empty_lines=False,
                                             invalid_row_handler=lambda row: invalid.append(row) or "skip"),
            convert_options=pacsv.ConvertOptions(column_types={n: pa.string() for n in names}, strings_can_be_null=False),
        )  # fmt: skip
    except (pa.ArrowInvalid, UnicodeDecodeError):
        return None
    if invalid or table.num_rows != ends.size:
        return None
    values = _floats(table, needed)
    return Chunk(table, values, np.zeros(table.num_rows, dtype=bool), first_line, verbatim=True)


def _parse_slowly(data: bytes, names: list[str], needed: tuple[str, ...], first_line: int) -> Chunk:
    """Line by line, each line one row whatever it holds."""
    width = len(names)
    kept, rows, malformed = [], [], []
    for raw in data.split(b"\n")[:-1]:
        line = raw[:-1] if raw.endswith(b"\r") else raw
        if len(line) > MAX_LINE_BYTES:
            line, fields, ok = b"", [""], False
        else:
            fields, ok = _split(line.decode("utf-8", errors="replace"))
        if len(fields) < width and (ok or not line):  # a short row: empty fields keep the columns in place
            line += b"," * (width - len(fields))
        kept.append(line)
        malformed.append(not ok or len(fields) != width)
        rows.append((fields + [""] * width)[:width])
    n = len(rows)
    flat = pa.array([field for column in zip(*rows) for field in column], type=pa.string())  # column after column
    table = pa.Table.from_arrays([flat.slice(k * n, n) for k in range(width)], names)  # one array: a few lines' cost is the calls
    values = _floats(table, needed)
    return Chunk(table, values, np.array(malformed, dtype=bool), first_line, pa.array(kept, type=pa.binary()))


def _floats(table: pa.Table, needed: tuple[str, ...]) -> dict[str, np.ndarray]:
    """:func:`to_float` of each needed column, in one cast when every one is all numbers (a few lines' cost is the
    calls), else column by column."""
    n = table.num_rows
    together = pa.chunked_array([chunk for name in needed for chunk in table.column(name).chunks], pa.string())
    try:
        flat = pc.cast(together, pa.float64()).to_numpy(zero_copy_only=False).astype(float, copy=False)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return {name: to_float(table.column(name)) for name in needed}
    return {name: flat[k * n : (k + 1) * n] for k, name in enumerate(needed)}


def _is_utf8(data: bytes) -> bool:
    try:  # Arrow validates in place, without building a str of the chunk
        pa.array([data], pa.binary()).cast(pa.string())
        return True
    except pa.ArrowInvalid:
        return False


def _split(text: str) -> tuple[list[str], bool]:
    """The fields of one line, and whether it is a line of fields at all (none too long)."""
    if '"' not in text:
        fields = text.split(",")
    else:
        try:
            fields = next(csv.reader([text]), [""])
        except csv.Error:  # a CR inside quotes, a field over csv.field_size_limit()
            return [""], False
    return fields, len(text) <= MAX_FIELD_CHARS or max(map(len, fields)) <= MAX_FIELD_CHARS


def _strip_line_end(line: bytes) -> bytes:
    line = line.removesuffix(b"\n")
    return line.removesuffix(b"\r")


def to_float(column: pa.ChunkedArray | pa.Array) -> np.ndarray:
    """Text to float64; NaN for anything that is not a number (the caller flags it invalid).

    A number is what Arrow's cast reads, with blanks around it allowed: the
    whole column is cast at once, and only a column that fails is sifted
    value by value through :data:`_NUMBER`, which accepts the same spellings.
    """
    try:
        return pc.cast(column, pa.float64()).to_numpy(zero_copy_only=False).astype(float, copy=False)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        pass
    text = pc.utf8_trim(column, " \t")
    numbers = pc.if_else(pc.match_substring_regex(text, _NUMBER, ignore_case=True), text, pa.scalar(None, pa.string()))
    return pc.cast(numbers, pa.float64()).to_numpy(zero_copy_only=False).astype(float, copy=False)


def parquet_schema(path: Path, needed: tuple[str, ...]) -> pa.Schema:
    """The schema of a Parquet table, checked for the needed columns and their types."""
    try:
        schema = pq.read_schema(path)
    except (pa.ArrowInvalid, OSError) as exc:
        raise TableError(f"{path}: not a readable Parquet file ({exc})") from None
    check_columns(path, list(schema.names), needed)
    for name in needed:
        kind = schema.field(name).type
        if not (pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_string(kind)
                or pa.types.is_large_string(kind) or pa.types.is_decimal(kind)):  # fmt: skip
            raise TableError(f"{path}: column {name!r} holds {kind}, not numbers")
    return schema


def _parquet_chunks(path: Path, needed: tuple[str, ...]) -> Iterator[Chunk]:
    parquet_schema(path, needed)
    line = 1
    try:
        for batch in pq.ParquetFile(path).iter_batches(batch_size=1 << 18):
            table = pa.Table.from_batches([batch])
            values = {n: to_float(table.column(n)) for n in needed}
            yield Chunk(table, values, np.zeros(table.num_rows, dtype=bool), line, input_size=table.num_rows)
            line += table.num_rows
    except (pa.ArrowInvalid, OSError) as exc:
        raise TableError(f"{path}: corrupt Parquet data after row {line - 1} ({exc})") from None
