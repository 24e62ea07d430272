"""The live estimate: a source's lines through ``sail estimate``'s own stream code, on a thread of its own.

:class:`LivePipeline` reads a source (:mod:`sailforce.live.sources`) on one
thread into a bounded queue, and estimates on another with
:func:`sailforce.stream.pipeline.estimate_lines`, the very code of
``sail estimate -``: the same lines give the same rows, the same statuses,
the same filter and the same dynamic term.  Every row goes, as numbers, to
the listeners (the page's state, a Lab Streaming Layer outlet) and, as the
CSV bytes ``sail estimate`` writes, to the recorder when one is on.

A new calibration (a tare) takes effect between blocks: the running
estimate ends (rows waiting for their rate window go out with their motion
unknown) and a new one starts on the same stream, the header fed again.
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from dataclasses import dataclass

import numpy as np

from ..calibration.file import Calibration
from ..calibration.tare import Tare, tare
from ..errors import InputError, SailError
from ..estimate.estimator import STATUS_NAMES
from ..estimate.filters import LowPass
from ..io.tables import Chunk, TableError
from ..status import count_statuses
from ..stream.pipeline import estimate_lines
from .recorder import Recorder
from .sources import Block

log = logging.getLogger(__name__)

#: Blocks the source may run ahead of the estimate before it waits (a serial port's driver then buffers): about
#: 40 s at 1 kHz in 5 ms blocks, so memory stays bounded whatever the input does.
QUEUE_BLOCKS = 8192

#: One estimate takes at most this many lines: a backlog is worked off in pieces that keep the page fresh.
MAX_BLOCK_LINES = 2000

#: One estimate at most this often [s]: lines that come one by one (a serial port at 1 kHz) are gathered into
#: blocks of about ten, each estimate's fixed cost shared, for at most 10 ms of added delay.
MIN_ESTIMATE_PERIOD_S = 0.01

_END = object()


@dataclass(frozen=True)
class Rows:
    """One block of estimated rows, in order: what listeners receive."""

    stamps: np.ndarray  #: ``(n,)`` wall-clock time of each reading [s]
    values: dict[str, np.ndarray]  #: the input's numbers: theta1_deg, theta2_deg, load1, load2 (and t_s, rates ...)
    columns: dict[str, np.ndarray]  #: fx_N, fy_N, force_N, angle_deg (and inertial1, inertial2)
    status: np.ndarray  #: ``(n,)`` status codes, :data:`sailforce.estimate.estimator.STATUS_NAMES`

    def __len__(self) -> int:
        return self.status.size


Listener = Callable[[Rows], None]


class StampedLines:
    """Blocks of stamped lines as the byte blocks ``estimate_lines`` reads, keeping each line's stamp for its row.

    Every line gives exactly one row, in order, so :meth:`take` pairs the
    rows of an estimated chunk with the stamps of the lines that made them.
    """

    def __init__(self) -> None:
        self._stamps: deque[float] = deque()
        self.header: bytes | None = None

    def block(self, lines: Block) -> bytes | None:
        """The bytes of a block (the header line kept aside, the first time); None when nothing is left."""
        if self.header is None and lines:
            self.header = lines[0][0]
            lines = lines[1:]
        if not lines:
            return None
        self._stamps.extend(stamp for _, stamp in lines)
        return b"".join(line if line.endswith(b"\n") else line + b"\n" for line, _ in lines)

    def take(self, n: int) -> np.ndarray:
        """The stamps of the next ``n`` rows."""
        return np.array([self._stamps.popleft() for _ in range(n)], dtype=float)

    def feed(self, block: Block) -> list[bytes]:
        """What ``estimate_lines`` reads of a block: the header line when it first comes, then the data lines."""
        had_header = self.header is not None
        data = self.block(block)
        return ([self.header] if not had_header and self.header is not None else []) + ([data] if data is not None else [])

    def lines(self, blocks: Iterator[Block]) -> Iterator[bytes]:
        """Header, then data blocks: the lines ``estimate_lines`` reads, from blocks read in the caller's thread."""
        for block in blocks:
            yield from self.feed(block)


def bag_listener(bag) -> Listener:
    """A listener writing each block into ``bag`` (:class:`sailforce.io.rosbag.BagWriter`), stamped with the rows'
    ``t_s``, or, for a stream without one, with their arrival time (the wall clock)."""

    def write(rows: Rows) -> None:
        values = rows.values if "t_s" in rows.values else {**rows.values, "t_s": rows.stamps}
        bag.write(values, rows.columns, rows.status)

    return write


def rows_of(stamps: StampedLines, chunk: Chunk, columns: dict[str, np.ndarray], status: np.ndarray) -> Rows:
    return Rows(stamps.take(chunk.num_rows), chunk.values, columns, status)


class _Output:
    """Where ``estimate_lines`` writes: the header kept (each run writes it again), the rows to the recorder."""

    def __init__(self) -> None:
        self.header: bytes | None = None
        self.expect_header = True
        self.lock = threading.Lock()
        self.recorder: Recorder | None = None
        self.failed: Recorder | None = None  #: the last recording that stopped itself, for the page to report

    def write(self, data: bytes) -> int:
        if self.expect_header:
            self.expect_header = False
            self.header = self.header or data
            return len(data)
        with self.lock:
            if self.recorder is not None:
                self.recorder.write(data)
                if getattr(self.recorder, "error", None) is not None:  # it stopped itself (disk full): the stream goes on
                    self.failed, self.recorder = self.recorder, None
        return len(data)

    def flush(self) -> None:
        pass

    @property
    def discarding(self) -> bool:
        """With no recording on, the header is all this sink wants (``estimate_lines`` then formats no row)."""
        return not self.expect_header and self.recorder is None


class LivePipeline:
    """A live source estimated on its own threads; see the module docstring.

    ``blocks`` is a source's iterator (:mod:`sailforce.live.sources`); it is
    read on the reader thread.  Listeners run on the estimating thread.
    """

    def __init__(self, cal: Calibration, blocks: Iterator[Block], *, source: str = "the stream",
                 lowpass: LowPass | None = None, dt: float | None = None, also: tuple[str, ...] = ()) -> None:  # fmt: skip
        self._cal = cal
        self._also = also  # columns the listeners want among the values, when the stream has them
        self._next_cal: Calibration | None = None
        self._blocks = blocks
        self.source = source
        self._lowpass = lowpass
        self._dt = dt
        self._queue: queue.Queue = queue.Queue(maxsize=QUEUE_BLOCKS)
        self._lock = threading.Lock()
        self._stamps = StampedLines()
        self._listeners: list[Listener] = []
        self._tare: tuple[int, list[np.ndarray], Future] | None = None
        self.output = _Output()
        self.counts = np.zeros(len(STATUS_NAMES), dtype=np.int64)
        self.error: BaseException | None = None  #: what ended the stream, if not its end
        self.ended = threading.Event()  #: set when the source has ended and every row is out
        self.rows = 0
        self._source_done = False
        self._restarting = False
        self._last_block = -math.inf
        self._stopping = threading.Event()

    # -- the user's side -----------------------------------------------------------------------
    @property
    def calibration(self) -> Calibration:
        with self._lock:
            return self._next_cal or self._cal

    def listen(self, listener: Listener) -> None:
        """Call ``listener`` with every block of rows from now on (on the estimating thread)."""
        self._listeners.append(listener)

    def start(self) -> LivePipeline:
        threading.Thread(target=self._read, name="sail-live-source", daemon=True).start()
        threading.Thread(target=self._estimate, name="sail-live-estimate", daemon=True).start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        """End the stream as if the source had ended (an endless source too), and wait up to ``timeout`` [s]."""
        self._stopping.set()
        self.ended.wait(timeout)

    def set_calibration(self, cal: Calibration) -> None:
        """Estimate with ``cal`` from the next block on."""
        with self._lock:
            self._next_cal = cal

    def tare(self, samples: int) -> Future:
        """Average the next ``samples`` rows' loads into new offsets, and estimate with them once done.

        Returns a future of the :class:`sailforce.calibration.tare.Tare`
        (or the error that stopped it: too few usable samples, the stream
        ended).
        """
        done: Future = Future()
        with self._lock:
            if self._tare is not None:
                done.set_exception(SailError("a tare is already under way; wait for it to finish"))
                return done
            self._tare = (int(samples), [], done)
        if self.ended.is_set():
            self._finish_tare(InputError("the stream has ended: there are no samples to tare on"))
        return done

    def cancel_tare(self) -> bool:
        """Stop the tare under way, if any (its future gets an error; the offsets stay); whether one was."""
        with self._lock:
            running = self._tare is not None
        self._finish_tare(InputError("the tare was cancelled; the offsets are unchanged"))
        return running

    # -- the threads ----------------------------------------------------------------------------
    def _read(self) -> None:
        try:
            for block in self._blocks:
                if self._stopping.is_set():
                    break
                self._queue.put(block)
        except BaseException as exc:  # a source's error ends the stream; the estimating thread reports it
            self._queue.put(exc)
        finally:
            self._queue.put(_END)

    def _lines(self) -> Iterator[bytes]:
        """The lines of one run: the header, then blocks, until the stream ends or a new calibration waits."""
        if self._stamps.header is not None:
            yield self._stamps.header
        while True:
            with self._lock:
                if self._next_cal is not None:
                    self._restarting = True
                    return
            wait = self._last_block + MIN_ESTIMATE_PERIOD_S - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            item = self._queue.get()
            self._last_block = time.monotonic()
            lines: Block = []
            while True:
                if item is _END or isinstance(item, BaseException):
                    self._end(item)
                    break
                lines.extend(item)
                if len(lines) >= MAX_BLOCK_LINES:
                    break
                try:
                    item = self._queue.get_nowait()
                except queue.Empty:
                    break
            yield from self._stamps.feed(lines)
            if self._source_done:
                return

    def _end(self, item) -> None:
        self._source_done = True
        if isinstance(item, BaseException):
            self.error = item

    def _estimate(self) -> None:
        try:
            while not self._source_done:
                with self._lock:
                    self._cal, self._next_cal = self._next_cal or self._cal, None
                    cal = self._cal
                self.output.expect_header = True
                before, self._restarting = self.rows, False
                try:
                    estimate_lines(cal, self._lines(), lambda: self.output, lowpass=self._lowpass, source=self.source,
                                   dt=self._dt, on_rows=self._on_rows, also=self._also)  # fmt: skip
                except TableError:
                    if self.rows == before and self._restarting:
                        continue  # a new calibration came before any row of this run
                    if self.rows == before and self._source_done and self.error is not None:
                        break  # the source failed: that is the error to report
                    raise
        except BaseException as exc:
            if not self._stopping.is_set():  # asked to stop: whatever ends the run is no error
                log.error("the live estimate stopped: %s", exc)
                self.error = self.error or exc
        finally:
            self._finish_tare(InputError("the stream ended before the tare had its samples"))
            self.ended.set()

    def _on_rows(self, chunk: Chunk, columns: dict[str, np.ndarray], status: np.ndarray) -> None:
        rows = rows_of(self._stamps, chunk, columns, status)
        self.rows += len(rows)
        self.counts += count_statuses(status)
        self._collect_tare(rows)
        for listener in self._listeners:
            try:
                listener(rows)
            except Exception:  # a display's bug must not stop the estimate, nor the recording
                log.exception("a listener of the live estimate failed")

    def _collect_tare(self, rows: Rows) -> None:
        with self._lock:
            if self._tare is None:
                return
            wanted, loads, _ = self._tare
        loads.append(np.column_stack([rows.values["load1"], rows.values["load2"]]))
        taken = sum(len(block) for block in loads)
        if taken < wanted:
            return
        samples = np.concatenate(loads)[:wanted]
        try:
            result = tare(self.calibration, samples, f"the tare on {self.source}")
        except SailError as exc:
            self._finish_tare(exc)
            return
        self.set_calibration(self.calibration.with_offsets(result.offsets))
        self._finish_tare(result)

    def _finish_tare(self, outcome: Tare | BaseException) -> None:
        with self._lock:
            pending, self._tare = self._tare, None
        if pending is None:
            return
        if isinstance(outcome, BaseException):
            pending[2].set_exception(outcome)
        else:
            pending[2].set_result(outcome)
