"""The dynamic term over a table read in chunks: each row's joint rates, in order, and what to subtract.

A table gives a motion when it has a time column ``t_s`` [s] (rates and
accelerations are then derived from the angles by the calibration's
differentiator, zero-phase: :class:`sailforce.motion.differentiate.RateTracker`),
or measured rates ``omega1_dps, omega2_dps`` [deg/s] and accelerations
``alpha1_dps2, alpha2_dps2`` [deg/s^2].  Measured columns replace the
derived ones wherever they are present.

Rows wait in :class:`MotionStage` until half a window of rows has followed
them (zero-phase needs the future); a file therefore gets exactly the
numbers of one pass over it, and a live stream gets each row's estimate
:meth:`MotionStage.delay` rows late, the loads held back with it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ..estimate.estimator import estimate_with_rates
from ..io.files import TableError
from ..io.tables import Chunk
from ..motion.differentiate import RateTracker, implausible
from ..motion.dynamics import ShearModel

TIME_COLUMN = "t_s"
RATE_COLUMNS = ("omega1_dps", "omega2_dps")
ACCELERATION_COLUMNS = ("alpha1_dps2", "alpha2_dps2")


@dataclass(frozen=True)
class MotionColumns:
    """Which motion columns a table has: time, measured rates, measured accelerations."""

    time: bool
    rates: bool
    accelerations: bool

    @property
    def names(self) -> tuple[str, ...]:
        return ((TIME_COLUMN,) if self.time else ()) + (RATE_COLUMNS if self.rates else ()) + (
            ACCELERATION_COLUMNS if self.accelerations else ())  # fmt: skip

    @property
    def derived(self) -> bool:
        """Whether rates or accelerations are derived from the angles (so rows wait half a window)."""
        return not (self.rates and self.accelerations)


def motion_columns(source: object, names: list[str]) -> MotionColumns | None:
    """The motion columns of a header, or None when it gives no motion (then estimates are static)."""
    have = set(names)
    for pair in (RATE_COLUMNS, ACCELERATION_COLUMNS):
        if len(have & set(pair)) == 1:
            given, missing = sorted(have & set(pair))[0], sorted(set(pair) - have)[0]
            raise TableError(f"{source}: column {given} needs {missing} beside it (measured rates come in pairs)")
    columns = MotionColumns(TIME_COLUMN in have, RATE_COLUMNS[0] in have, ACCELERATION_COLUMNS[0] in have)
    if columns.derived and not columns.time:
        return None
    return columns


@dataclass(frozen=True)
class MotionRows:
    """The joint rates [rad/s] and accelerations [rad/s^2] ``(n, 2)`` of a chunk's rows; NaN where unknown."""

    cal: object  #: the :class:`sailforce.calibration.file.Calibration`
    shear_model: ShearModel
    rate: np.ndarray
    accel: np.ndarray

    def estimate(self, cal, theta1, theta2, loads):
        """``(fx, fy, status, inertial)`` with the dynamic term (:func:`sailforce.estimate.estimator.estimate_with_rates`)."""
        return estimate_with_rates(cal, self.shear_model, theta1, theta2, loads[:, 0], loads[:, 1], self.rate[:, 0],
                                   self.rate[:, 1], self.accel[:, 0], self.accel[:, 1], threads=1)  # fmt: skip

    def inertial(self, values: dict[str, np.ndarray]) -> np.ndarray:
        """The dynamic load in reading units ``(n, 2)`` (NaN where unknown), whatever the loads."""
        theta1, theta2 = np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"])
        at_offsets = np.broadcast_to(np.asarray(self.cal.offsets, float), (theta1.size, 2))
        return self.estimate(self.cal, theta1, theta2, at_offsets)[3]


class MotionStage:
    """Chunks in, in order; ``(chunk, MotionRows)`` out, in order, as soon as every row's motion is decided."""

    def __init__(self, cal, columns: MotionColumns, dt: float | None = None):
        self.cal, self.columns = cal, columns
        self.shear_model = cal.dynamics.shear_model(cal.arm)
        self.tracker = RateTracker(cal.dynamics.differentiator, dt) if columns.derived else None
        self.pending: deque[tuple[Chunk, list[np.ndarray], list[np.ndarray]]] = deque()

    def delay(self) -> int | None:
        """Rows a live stream's output lags its input (half a window; 0 with measured rates; None until known)."""
        if self.tracker is None:
            return 0
        return None if self.tracker.dt is None else self.tracker.delay()

    def push(self, chunk: Chunk) -> list[tuple[Chunk, MotionRows]]:
        if self.tracker is None:
            return [(chunk, self._rows(chunk, np.full((chunk.num_rows, 2), np.nan), np.full((chunk.num_rows, 2), np.nan)))]
        values = chunk.values
        t = np.where(chunk.malformed, np.nan, values[TIME_COLUMN])
        q = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
        self.pending.append((chunk, [], []))
        return self._take(*self.tracker.feed(t, q))

    def finish(self) -> list[tuple[Chunk, MotionRows]]:
        """The rows still waiting (the last half window: the recording ended, their motion is unknown)."""
        if self.tracker is None:
            return []
        ready = self._take(*self.tracker.finish())
        assert not self.pending, "every row fed comes out"
        return ready

    def _take(self, rate: np.ndarray, accel: np.ndarray) -> list[tuple[Chunk, MotionRows]]:
        ready, used = [], 0
        while used < rate.shape[0]:
            chunk, rates, accels = self.pending[0]
            need = chunk.num_rows - sum(r.shape[0] for r in rates)
            take = min(need, rate.shape[0] - used)
            rates.append(rate[used : used + take])
            accels.append(accel[used : used + take])
            used += take
            if take == need:
                self.pending.popleft()
                ready.append((chunk, self._rows(chunk, np.concatenate(rates), np.concatenate(accels))))
        return ready

    def _rows(self, chunk: Chunk, rate: np.ndarray, accel: np.ndarray) -> MotionRows:
        values = chunk.values
        if self.columns.rates:
            rate = np.radians(np.column_stack([values[c] for c in RATE_COLUMNS]))
        if self.columns.accelerations:
            accel = np.radians(np.column_stack([values[c] for c in ACCELERATION_COLUMNS]))
        wild = implausible(rate, accel)
        if wild.any():  # a measured rate no arm reaches: the row's motion is unknown, never ok
            rate, accel = rate.copy(), accel.copy()
            rate[wild], accel[wild] = np.nan, np.nan
        return MotionRows(self.cal, self.shear_model, rate, accel)
