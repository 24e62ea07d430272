"""The record button's files: the live estimate's rows, as ``sail estimate`` writes them, never clobbering a file.

A recording is written to a new file in the recording folder, named by the
server (``sail-live-YYYYmmdd-HHMMSS.csv``, with ``-2``, ``-3``... when a
name is taken): the client names nothing.  The file is created exclusively
(an existing file is never opened for writing) and every block of rows is
flushed as it comes, so that a crash or a pulled plug keeps everything up to
the last block.  Parquet recordings are written as CSV while they run and
converted when they stop (a Parquet file without its footer, after a crash,
would be unreadable); the CSV is removed only once the Parquet file is
complete.

A write that fails (the disk full, the folder gone) stops the recording, not
the stream: the file is cut back to its last complete row, closed, and the
error kept in :attr:`Recorder.error` for the page; the estimate, the page and
any Lab Streaming Layer outlet go on.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from ..errors import InputError, RecordingError
from ..io.files import atomic_writer

RECORD_FORMATS = ("csv", "parquet")

#: Names tried for a recording made in the same second as another, before giving up.
MAX_NAME_TRIES = 1000



def fresh_file(directory: Path, stem: str, suffix: str) -> tuple[Path, int]:
    """A new file ``directory/stem{suffix}`` (or ``stem-2{suffix}`` ...), created exclusively: its path and descriptor."""
    directory.mkdir(parents=True, exist_ok=True)
    for n in range(1, MAX_NAME_TRIES + 1):
        path = directory / f"{stem}{'' if n == 1 else f'-{n}'}{suffix}"
        try:
            return path, os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
    raise FileExistsError(f"{directory}: {MAX_NAME_TRIES} files named {stem}*{suffix} already; clear some out")


class Recorder:
    """One recording: see the module docstring.  :meth:`write` may be called from another thread than :meth:`stop`."""

    def __init__(self, directory: Path, header: bytes, fmt: str = "csv") -> None:
        if fmt not in RECORD_FORMATS:
            raise InputError(f"record format {fmt!r}: expected one of {', '.join(RECORD_FORMATS)}")
        self.format = fmt
        self.started = time.time()
        stem = "sail-live-" + time.strftime("%Y%m%d-%H%M%S", time.localtime(self.started))
        self.path, handle = fresh_file(Path(directory), stem, ".csv")
        self._file = os.fdopen(handle, "wb")
        self._lock = threading.Lock()
        self.rows = 0
        self.error: str | None = None  #: why the recording stopped by itself, if it did
        self._good = 0  # bytes known to be whole rows on disk
        self.write(header, rows=False)

    def write(self, data: bytes, *, rows: bool = True) -> None:
        """Append whole rows; a failing write cuts the file back to its last whole row and stops the recording."""
        with self._lock:
            if self._file.closed:
                return
            try:
                self._file.write(data)
                self._file.flush()
            except OSError as exc:
                self._fail(exc)
                return
            self._good += len(data)
            if rows:
                self.rows += data.count(b"\n")

    def _fail(self, exc: OSError) -> None:
        self.error = f"{exc.strerror or exc} while writing {self.path.name}; it keeps the {self.rows:,} rows before"
        try:
            os.ftruncate(self._file.fileno(), self._good)  # no half row; truncating needs no free space
        except OSError:
            pass
        try:
            self._file.close()
        except OSError:  # the buffer's rest cannot be written either: it is the half row already cut
            pass

    def stop(self) -> Path:
        """Close the recording (synced to disk); for Parquet, convert it. Returns the file that holds it."""
        with self._lock:
            if not self._file.closed:
                try:
                    self._file.flush()
                    os.fsync(self._file.fileno())
                    self._file.close()
                except OSError as exc:
                    self._fail(exc)
        if self.format == "csv":
            return self.path
        target, handle = fresh_file(self.path.parent, self.path.stem, ".parquet")
        os.close(handle)  # reserved; atomic_writer puts the complete file in its place
        try:
            table = pacsv.read_csv(self.path)
            with atomic_writer(target, "wb") as stream:
                pq.write_table(table, stream)
        except pa.ArrowException as exc:  # a row the stream passed through as it came (a stray comma): keep the CSV
            target.unlink(missing_ok=True)
            first = str(exc).splitlines()[0][:200]
            raise RecordingError(f"{self.path.name} could not be converted to Parquet ({first}); the CSV is kept") from None
        except BaseException:
            target.unlink(missing_ok=True)
            raise
        self.path.unlink()
        self.path = target
        return target

    def info(self) -> dict:
        """For the page: the file's name (not its folder), rows and seconds so far."""
        return {"file": self.path.name, "rows": self.rows, "seconds": time.time() - self.started, "format": self.format,
                "error": self.error}  # fmt: skip
