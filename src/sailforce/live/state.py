"""What the live page shows: the newest row, and the last seconds of force decimated for plotting.

:class:`LiveState` listens to the pipeline (every row, on the estimating
thread) and keeps only what a display needs, in bounded memory: the newest
row, one plotted point per :data:`HISTORY_STEP_S` over :data:`HISTORY_S`,
the count of rows per status and the input rate.  The server reads it
whenever it sends an update, so a page always gets the newest sample,
however fast the input, and nothing queues up behind a slow page.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable

import numpy as np

from ..calibration.file import Calibration
from ..estimate.estimator import STATUS_NAMES
from ..kinematics import joint_positions
from ..status import count_statuses
from . import sources
from .pipeline import Rows

#: The time plots span this much of the past [s].
HISTORY_S = 10.0

#: One plotted point per this much time [s]: the first row of each step (1 kHz input: one row in 10).
HISTORY_STEP_S = 0.01

#: The input rate is counted over this much of the past [s].
RATE_WINDOW_S = 1.0

#: The numbers of a row that the page receives (when the input has them).  With a real ADC (a multi-rate stream)
#: ``force_t_s`` is the instant the force refers to, and the page shows its age, ``t_s - force_t_s``.
SAMPLE_FIELDS = ("t_s", "theta1_deg", "theta2_deg", "load1", "load2", "fx_N", "fy_N", "force_N", "angle_deg",
                 "inertial1", "inertial2", "force_t_s")  # fmt: skip


def _number(value) -> float | None:
    """A float for JSON: None where it is not a finite number."""
    value = float(value)
    return value if math.isfinite(value) else None


class LiveState:
    """The page's view of the live estimate; a pipeline listener.  Thread-safe."""

    def __init__(self, notify: Callable[[], None] | None = None) -> None:
        self._lock = threading.Lock()
        self.notify = notify  #: called after each block of rows (from the estimating thread)
        self.latest: dict | None = None
        self.counts = np.zeros(len(STATUS_NAMES), dtype=np.int64)
        self._history: deque[tuple[int, float, float | None, float | None, float | None]] = deque(
            maxlen=int(round(HISTORY_S / HISTORY_STEP_S)) + 1)  # fmt: skip
        self._next_point = 0
        self._last_bin = -math.inf
        self._arrivals: deque[tuple[float, int]] = deque()

    def __call__(self, rows: Rows) -> None:
        if not len(rows):
            return
        bins = np.floor(rows.stamps / HISTORY_STEP_S)
        first = np.flatnonzero(np.diff(bins, prepend=self._last_bin) > 0)
        fx, fy, force = rows.columns["fx_N"], rows.columns["fy_N"], rows.columns["force_N"]
        now = sources.now()
        with self._lock:
            self.latest = self._row(rows, -1)
            self.counts += count_statuses(rows.status)
            for i in first:
                self._history.append((self._next_point, float(rows.stamps[i]), _number(fx[i]), _number(fy[i]),
                                      _number(force[i])))  # fmt: skip
                self._next_point += 1
            self._last_bin = float(bins[-1])
            self._arrivals.append((now, len(rows)))
            while self._arrivals and self._arrivals[0][0] < now - RATE_WINDOW_S:
                self._arrivals.popleft()
        if self.notify is not None:
            self.notify()

    @staticmethod
    def _row(rows: Rows, i: int) -> dict:
        row = {name: _number(source[name][i]) for name in SAMPLE_FIELDS
               for source in (rows.values, rows.columns) if name in source}  # fmt: skip
        return row | {"status": STATUS_NAMES[int(rows.status[i])], "stamp": float(rows.stamps[i])}

    def snapshot(self, cal: Calibration, since: int = -1) -> tuple[dict | None, list, int, dict[str, int], float]:
        """The newest row (with the arm's joints and the cells' fractions of capacity), the plotted points
        after point ``since``, the last point's number, the count of rows per status and the input rate [Hz]."""
        with self._lock:
            latest = None if self.latest is None else dict(self.latest)
            first = self._history[0][0] if self._history else self._next_point
            points = [list(p[1:]) for p in list(self._history)[max(0, since + 1 - first):]]
            counts = {name: int(n) for name, n in zip(STATUS_NAMES, self.counts) if n}
            rate = sum(n for _, n in self._arrivals) / RATE_WINDOW_S
            last = self._next_point - 1
        if latest is not None:
            latest |= _geometry(cal, latest)
        return latest, points, last, counts, rate


def _geometry(cal: Calibration, row: dict) -> dict:
    """The arm's joints [m] at the row's pose, and each cell's reading as a fraction of its capacity."""
    extra: dict = {"joints": None, "cells": [None, None]}
    if row.get("theta1_deg") is not None and row.get("theta2_deg") is not None:
        p = joint_positions(cal.arm, math.radians(row["theta1_deg"]), math.radians(row["theta2_deg"]))
        extra["joints"] = {"B": [0.0, 0.0]} | {name: [float(v) for v in p[name]] for name in ("P1", "P2", "P3", "A")}
    for i, name in enumerate(("load1", "load2")):
        if row.get(name) is not None:
            extra["cells"][i] = (row[name] - cal.offsets[i]) / cal.capacity[i]
    return extra
