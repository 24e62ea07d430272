"""Reading tables and writing results: atomic files, so a failed run never leaves half a file."""

from __future__ import annotations

import csv
import json
import math
import os
import secrets
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import IO

import numpy as np

from ..errors import OutputPathError, TableError

#: Table formats a command may write, by file extension.
CSV_SUFFIXES = (".csv",)
PARQUET_SUFFIXES = (".parquet", ".pq")



@contextmanager
def atomic_writer(path: str | Path, mode: str = "w", *, keep_on_interrupt: bool = False) -> Iterator[IO]:
    """Write to a temporary file beside ``path`` and rename it into place on success.

    Only regular files are written: a ``path`` that is (or links to) a
    device, a FIFO, a socket or a folder is refused with
    :class:`OutputPathError` before anything is written, and checked again
    just before the rename, since replacing ``/dev/null`` with a file breaks
    a machine.  A symlink at ``path`` to a regular file (or to a name not
    yet taken) stays a symlink: its target is replaced, as the user who made
    the link asked.  The data reach the disk (fsync) before the rename, and
    the file gets the mode ``open()`` would give it.  On any error the
    temporary file is removed and ``path`` is untouched; with
    ``keep_on_interrupt`` (live recordings) an interrupt (Ctrl-C, SIGTERM)
    still puts into place what was written, if anything was.
    """
    check_regular_output(path)
    target = Path(os.path.realpath(path))
    tmp = target.parent / f".{target.name}.{secrets.token_hex(6)}.tmp"
    try:
        handle = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies, as for open()
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    committed = False
    try:
        binary = "b" in mode
        with os.fdopen(handle, mode, encoding=None if binary else "utf-8", newline=None if binary else "") as stream:
            try:
                yield stream
            except KeyboardInterrupt:
                if keep_on_interrupt and stream.tell() > 0:
                    _commit(stream, tmp, target)
                    committed = True
                raise
            _commit(stream, tmp, target)
            committed = True
    except OSError as exc:
        if exc.filename and str(exc.filename) == str(tmp):  # never show the temporary name
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        raise
    finally:
        if not committed:
            tmp.unlink(missing_ok=True)


def _commit(stream: IO, tmp: Path, target: Path) -> None:
    stream.flush()
    os.fsync(stream.fileno())
    check_regular_output(target)  # it may have changed while we wrote
    os.replace(tmp, target)


#: What a path that is not a regular file is, for the message.
_FILE_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
               (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))  # fmt: skip


def check_regular_output(path: str | Path, flag: str = "-o") -> None:
    """Refuse an output that exists and is not a regular file (following symlinks): see :func:`atomic_writer`."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    if stat.S_ISREG(mode):
        return
    kind = next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")
    via = f" (the symlink's target, {os.path.realpath(path)})" if os.path.islink(path) else ""
    raise OutputPathError(f"{flag} {path}{via}: that is {kind}, not a regular file, and writing would replace it; "
                          "name a regular file")  # fmt: skip


def check_output(output: str | Path | None, inputs: dict[str, str | Path | None], flag: str = "-o") -> None:
    """Refuse an output that is one of the ``inputs`` (by resolved path or by inode, so links count).

    ``inputs`` maps a description ("the input table", "--calibration") to a
    path; None entries and ``-`` (stdin/stdout) are skipped.
    """
    if output is None or str(output) == "-":
        return
    for what, path in inputs.items():
        if path is not None and str(path) != "-" and _same_file(Path(output), Path(path)):
            raise OutputPathError(f"{flag} {output}: that is {what} ({path}); writing it would destroy it. Choose another name")


def _same_file(a: Path, b: Path) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return False


def table_format(output: str | Path, flag: str = "-o", *, parquet: bool = True) -> str:
    """``"csv"`` or ``"parquet"`` from an output's extension; refuses any other (and Parquet where not written)."""
    suffix = Path(output).suffix.lower()
    if suffix in CSV_SUFFIXES:
        return "csv"
    if suffix in PARQUET_SUFFIXES:
        if not parquet:
            raise OutputPathError(f"{flag} {output}: this output is written line by line as CSV; name it .csv")
        return "parquet"
    known = ", ".join(CSV_SUFFIXES + (PARQUET_SUFFIXES if parquet else ()))
    raise OutputPathError(f"{flag} {output}: unknown table format {suffix or '(no extension)'!r}; use one of {known}")


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
        with open(path, newline="", encoding="utf-8-sig") as stream:  # a byte-order mark is not a column name
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


@contextmanager
def numeric_table_writer(path: str | Path, columns: tuple[str, ...], *, csv_format: str = "%.12g",
                         missing: str | None = None) -> Iterator:  # fmt: skip
    """Yield ``write(values)`` appending rows (a dict of equal-length arrays) to a CSV or Parquet file.

    The format follows the extension (:func:`table_format`); the file is
    written atomically.  CSV numbers use ``csv_format``; Parquet columns are
    float64.  With ``missing`` (``""``: an empty field), NaN is written as it
    in CSV and as null in Parquet.
    """
    if table_format(path) == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        schema = pa.schema([(name, pa.float64()) for name in columns])
        with atomic_writer(path, "wb") as stream, pq.ParquetWriter(stream, schema) as writer:
            def write_parquet(values) -> None:
                arrays = {n: np.asarray(values[n], float) for n in columns}
                if missing is not None:
                    arrays = {n: pa.array(a, mask=np.isnan(a)) for n, a in arrays.items()}
                writer.write_table(pa.table(arrays, schema=schema))

            yield write_parquet
        return
    with atomic_writer(path) as stream:
        stream.write(",".join(columns) + "\n")
        if missing is None:
            yield lambda values: np.savetxt(stream, np.column_stack([values[n] for n in columns]), fmt=csv_format, delimiter=",")
            return

        def write_csv(values) -> None:
            table = np.column_stack([np.asarray(values[n], float) for n in columns])
            text = np.char.mod(csv_format, table)
            text[np.isnan(table)] = missing
            stream.write("".join(",".join(row) + "\n" for row in text.tolist()))

        yield write_csv


def write_numeric_table(path: str | Path, columns, table, *, csv_format: str = "%.12g") -> None:
    """Write ``table`` ``(n, len(columns))`` under the header ``columns``: the one numeric table writer.

    CSV or Parquet by the extension, atomically (:func:`numeric_table_writer`);
    CSV numbers in ``csv_format`` (NaN as ``nan``).
    """
    columns = tuple(columns)
    table = np.asarray(table, dtype=float).reshape(-1, len(columns))
    with numeric_table_writer(path, columns, csv_format=csv_format) as write:
        write({name: table[:, i] for i, name in enumerate(columns)})


def write_figure(path: str | Path, figure, *, dpi: float = 150) -> None:
    """Save a matplotlib ``figure`` to ``path`` through :func:`atomic_writer`, in the format its extension names."""
    suffix = Path(path).suffix.lstrip(".").lower() or "png"
    with atomic_writer(path, "wb") as stream:
        figure.savefig(stream, format=suffix, dpi=dpi)


def sidecar_path(output: str | Path) -> Path:
    """``OUT.csv.json`` for ``OUT.csv``: the output's name plus ``.json``."""
    output = Path(output)
    return output.with_name(output.name + ".json")


def check_sidecar(output: str | Path) -> Path:
    """The sidecar of ``output``, refused unless it is new or a sidecar sailforce wrote before (never through a link).

    A sidecar replaces only its own earlier self: a regular file holding a
    JSON object whose ``software`` is sailforce's.  Anything else there (a
    user's file, a symlink to a calibration) is left alone and the command
    refused before it writes anything.
    """
    sidecar = sidecar_path(output)
    if os.path.islink(sidecar):
        raise OutputPathError(f"{sidecar} (the sidecar of -o {output}) is a symlink; sailforce never writes a sidecar "
                              "through a link. Remove it or choose another -o")  # fmt: skip
    if not os.path.lexists(sidecar):
        return sidecar
    check_regular_output(sidecar, f"the sidecar of -o {output},")
    try:
        with open(sidecar, encoding="utf-8") as stream:
            earlier = json.loads(stream.read(1 << 20))
        ours = isinstance(earlier, dict) and str(earlier.get("software", "")).startswith("sailforce")
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        ours = False
    if not ours:
        raise OutputPathError(f"{sidecar} exists and is not a sidecar sailforce wrote; -o {output} would replace it. "
                              "Move it or choose another -o")  # fmt: skip
    return sidecar


@contextmanager
def output_set(directory: str | Path, names: tuple[str, ...]) -> Iterator[Path]:
    """Yield a staging folder for a set of outputs; move them into ``directory`` together once all are written.

    A command whose outputs belong together (a report and the tables it
    describes) writes them into the staging folder; only when the block ends
    without error do they replace ``directory``'s, one rename each, and the
    files of ``names`` that this run did not write (a previous run's
    ``sweep.csv`` beside a report without a sweep) are removed, so the folder
    never mixes two runs.  An interrupt or an error leaves the previous set as
    it was and removes the staging folder.
    """
    import shutil

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    for name in names:
        check_regular_output(directory / name)
    staging = directory / f".sail-staging-{secrets.token_hex(6)}"
    staging.mkdir()
    try:
        yield staging
        written = {p.name for p in staging.iterdir()}
        for name in sorted(written):
            check_regular_output(directory / name)
            os.replace(staging / name, Path(os.path.realpath(directory / name)))
        for name in set(names) - written:
            stale = directory / name
            if stale.is_file() or stale.is_symlink():
                stale.unlink()
    finally:
        shutil.rmtree(staging, ignore_errors=True)
