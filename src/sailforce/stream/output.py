"""The estimate's output: each input row with its force fields appended, as CSV bytes or as an Arrow table for Parquet.

Output columns: the input's, then ``fx_N, fy_N, force_N, angle_deg,
status``; with a dynamic term also ``inertial1, inertial2`` before
``status``.  CSV output copies each input line byte for byte and appends the
fields, so ``status`` is always a row's last field, even on a malformed line.
Parquet output holds typed columns: the needed ones as float64 (null where
the text was not a number), and every other CSV column as int64 or float64
when its first chunk's values are all numbers, else as text.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from ..errors import TableError
from ..io.tables import READING_COLUMNS, Chunk, Header, parquet_schema
from ..status import STATUS_NAMES

OUTPUT_COLUMNS = ("fx_N", "fy_N", "force_N", "angle_deg", "status")
#: With a dynamic term: the subtracted inertial and gravity load of each cell, in reading units, before status.
MOTION_OUTPUT_COLUMNS = ("fx_N", "fy_N", "force_N", "angle_deg", "inertial1", "inertial2", "status")
#: With a real ADC (multi-rate input): the instant each estimate refers to [s], before status (sailforce.estimate.multirate).
MULTIRATE_OUTPUT_COLUMNS = ("fx_N", "fy_N", "force_N", "angle_deg", "force_t_s", "status")
MULTIRATE_MOTION_OUTPUT_COLUMNS = ("fx_N", "fy_N", "force_N", "angle_deg", "inertial1", "inertial2", "force_t_s", "status")


def output_columns(motion: bool, multirate: bool) -> tuple[str, ...]:
    """The columns the estimate appends to each row."""
    if multirate:
        return MULTIRATE_MOTION_OUTPUT_COLUMNS if motion else MULTIRATE_OUTPUT_COLUMNS
    return MOTION_OUTPUT_COLUMNS if motion else OUTPUT_COLUMNS


_STATUS_TEXT = pa.array(STATUS_NAMES).cast(pa.binary())
_STATUS_BYTES = tuple(name.encode() for name in STATUS_NAMES)
#: Rows up to which :func:`csv_rows` joins the fields in Python: a live block's ten rows cost 40 us so, 130 us through
#: Arrow's kernels (their calls, not the numbers); Arrow's join is ahead from about 100 rows.
SMALL_BLOCK_ROWS = 64


def csv_rows(lines: pa.Array, columns: dict[str, np.ndarray], status: np.ndarray) -> bytes:
    """Each input line, then ``,fx,fy,force,angle,status``; numbers in shortest round-trip form, NaN empty.

    The numbers' text is Arrow's cast however many rows there are; only the
    joining differs, so a block of any size gives the same bytes.
    """
    n = len(lines)
    if n == 0:
        return b""
    if n <= SMALL_BLOCK_ROWS:
        return _joined_in_python(lines, columns, status)
    parts = [lines]
    if columns:  # every column formatted in one cast: a small block's cost is the calls, not the numbers
        values = np.concatenate([np.asarray(v, float) for v in columns.values()])
        text = pc.fill_null(pc.cast(pa.array(values, mask=np.isnan(values)), pa.string()), "").cast(pa.binary())
        n = len(lines)
        parts += [text.slice(k * n, n) for k in range(len(columns))]
    parts.append(_STATUS_TEXT.take(pa.array(status.astype(np.int32))))
    rows = pc.binary_join_element_wise(*parts, b",")
    whole = pc.binary_join(pa.ListArray.from_arrays(pa.array([0, len(rows)], pa.int32()), rows), b"\n")
    return whole[0].as_py() + b"\n"


def _joined_in_python(lines: pa.Array, columns: dict[str, np.ndarray], status: np.ndarray) -> bytes:
    """:func:`csv_rows` of a few rows: the numbers cast by Arrow in one call, the rows joined here."""
    n = len(lines)
    fields: list[bytes] = [b""] * n
    if columns:
        values = np.concatenate([np.asarray(v, float) for v in columns.values()])
        text = pc.cast(pa.array(values, mask=np.isnan(values)), pa.string()).to_pylist()
        fields = [("," + ",".join(["" if v is None else v for v in text[k::n]])).encode() for k in range(n)]
    names = _STATUS_BYTES
    return b"".join([line + row + b"," + names[s] + b"\n"
                     for line, row, s in zip(lines.to_pylist(), fields, status.tolist())])  # fmt: skip


def output_table(table: pa.Table, columns: dict[str, np.ndarray], status: np.ndarray) -> pa.Table:
    for name, values in columns.items():
        table = table.append_column(name, pa.array(values, mask=np.isnan(values)))
    return table.append_column("status", pa.array(STATUS_NAMES).take(pa.array(status.astype(np.int32))))


class ParquetTypes:
    """The Parquet types of a CSV table's text columns, chosen on its first chunk and held for the rest."""

    def __init__(self) -> None:
        self.types: dict[str, pa.DataType] | None = None

    def convert(self, chunk: Chunk) -> pa.Table:
        table = chunk.table
        if self.types is None:
            self.types = {n: pa.float64() if n in chunk.values else _numeric_type(table.column(n)) for n in table.column_names}
        columns = {}
        for name, kind in self.types.items():
            if name in chunk.values:
                values = chunk.values[name]
                columns[name] = pa.array(values, mask=np.isnan(values))
            elif kind == pa.string():
                columns[name] = table.column(name)
            else:
                columns[name] = self._cast(chunk, name, kind)
        return pa.table(columns)

    @staticmethod
    def _cast(chunk: Chunk, name: str, kind: pa.DataType) -> pa.ChunkedArray:
        column = _empty_to_null(chunk.table.column(name))
        try:
            return pc.cast(column, kind)
        except pa.ArrowInvalid:
            bad = next(i for i, v in enumerate(column.to_pylist()) if v is not None and _cast_fails(v, kind))
            raise TableError(
                f"line {chunk.first_line + bad}, column {name!r}: {column[bad].as_py()!r} is not a number, but the "
                f"column's first rows were, so its Parquet column is {kind}; write CSV output instead"
            ) from None


def _empty_to_null(column: pa.ChunkedArray) -> pa.ChunkedArray:
    return pc.if_else(pc.equal(pc.utf8_trim_whitespace(column), ""), pa.scalar(None, pa.string()), column)


def _numeric_type(column: pa.ChunkedArray) -> pa.DataType:
    """int64 or float64 if every non-empty text of ``column`` is such a number, else string."""
    column = _empty_to_null(column)
    for kind in (pa.int64(), pa.float64()):
        try:
            pc.cast(column, kind)
            return kind
        except pa.ArrowInvalid:
            continue
    return pa.string()


def _cast_fails(value: str, kind: pa.DataType) -> bool:
    try:
        pc.cast(pa.array([value]), kind)
        return False
    except pa.ArrowInvalid:
        return True


def output_header(names: tuple[str, ...]) -> bytes:
    return ("," + ",".join(names) + "\n").encode()


def csv_output_header(source: Path, header: Header | None, names: tuple[str, ...]) -> bytes:
    if header is not None:
        return header.line + output_header(names)
    schema = parquet_schema(source, READING_COLUMNS)
    nested = [f"{f.name!r} ({f.type})" for f in schema if pa.types.is_nested(f.type)]
    if nested:
        raise TableError(f"{source}: column(s) {', '.join(nested)} cannot be written as CSV; write Parquet output instead")
    sink = pa.BufferOutputStream()
    pacsv.write_csv(schema.empty_table(), sink)
    return sink.getvalue().to_pybytes().rstrip(b"\n") + output_header(names)
