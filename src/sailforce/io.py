"""Reading tables and writing results: atomic files, so a failed run never leaves half a file."""

from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from contextlib import contextmanager
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import IO, Iterator

import numpy as np

from .errors import SailError


class TableError(SailError):
    """A table that cannot be read: missing, empty, ragged, a bad header or cell, missing columns, corrupt Parquet."""


@contextmanager
def atomic_writer(path: str | Path, mode: str = "w") -> Iterator[IO]:
    """Write to a temporary file beside ``path`` and rename it into place on success."""
    path = Path(path)
    handle, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or ".")
    try:
        with os.fdopen(handle, mode, encoding=None if "b" in mode else "utf-8", newline="" if "b" not in mode else None) as stream:
            yield stream
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates 0600; give the file the mode open() would
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_json(path: str | Path, data: object) -> None:
    """Write ``data`` (dataclasses allowed) as indented JSON, atomically."""
    with atomic_writer(path) as stream:
        json.dump(data, stream, indent=2, default=_jsonable)
        stream.write("\n")


def _jsonable(value: object) -> object:
    if is_dataclass(value) and not isinstance(value, type):
        return asdict(value)
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def read_numeric_csv(path: str | Path, *, min_columns: int = 1) -> tuple[list[str], np.ndarray]:
    """A small all-numeric CSV table with a header row: (column names, (rows, columns) array).

    Refuses, naming the file, row and column: a missing header, fewer than
    ``min_columns`` columns, a row of the wrong length, an empty, non-numeric
    or non-finite cell, and a table without data rows.  Blank lines are skipped.
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as stream:
            rows = [(n, row) for n, row in enumerate(csv.reader(stream), start=1) if any(c.strip() for c in row)]
    except UnicodeDecodeError as exc:
        raise TableError(f"{path}: not a UTF-8 text table (byte {exc.start} cannot be decoded)") from None
    except csv.Error as exc:
        raise TableError(f"{path}: malformed CSV ({exc})") from None
    if not rows:
        raise TableError(f"{path}: the file is empty; expected a header row and data rows")
    (_, header), body = rows[0], rows[1:]
    names = [h.strip() for h in header]
    if len(names) < min_columns:
        raise TableError(f"{path}: expected at least {min_columns} columns, found {len(names)} ({', '.join(names)})")
    if not body:
        raise TableError(f"{path}: no data rows below the header")
    table = np.empty((len(body), len(names)))
    for r, (line, row) in enumerate(body):
        if len(row) != len(names):
            raise TableError(f"{path}, line {line}: {len(row)} fields, expected {len(names)} ({', '.join(names)})")
        for c, cell in enumerate(row):
            try:
                value = float(cell)
            except ValueError:
                raise TableError(f"{path}, line {line}, column {names[c]!r}: {cell.strip()!r} is not a number") from None
            if not math.isfinite(value):
                raise TableError(f"{path}, line {line}, column {names[c]!r}: {cell.strip()!r} is not finite")
            table[r, c] = value
    return names, table
