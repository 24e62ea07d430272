"""The force from real ADCs: a conversion now and then from each cell, each its filter's average, asynchronous to the ticks.

Each cell i converts on its own clock; a conversion ready at ``tau`` reads
(:mod:`sailforce.adc.models`)

    r = o_i + sum_j w_j [ (M(q_j) F(t_j))_i + d_i(t_j) ],      t_j = tau - lag_j in the window,

with ``w`` the filter's weights over the ticks in its window (sum 1), ``M``
the calibration's sensing map and ``d = M (J^T)^-1 diag(l) V`` the dynamic
term's reading (:mod:`sailforce.estimate.dynamic`) at each tick.  For a force
that is smooth over the window,

    u_i = r - o_i - sum_j w_j d_i(t_j)  =  Mbar_i F(c),      Mbar_i = sum_j w_j M_i(q_j),

to second order in the window's width, at the window's centroid
``c = tau - N T / 2 - delay`` (``delay``: what the free-motion calibration
identified beyond the model, :attr:`sailforce.calibration.Calibration.adc_delay_s`).
So each conversion gives one equation at its own instant.  At every
conversion of either cell the estimate is made at ``c* = min(c_1, c_2)``,
the older of the two cells' latest centroids: the other cell's ``u`` and
``Mbar`` are interpolated linearly to ``c*`` between its two conversions
around it (an interpolation, never an extrapolation), and ``Mbar F = u`` is
solved there (Cramer's rule, :mod:`sailforce.kernel`).  ``force_t_s = c*``
is the instant the estimate refers to; the rows between conversions carry
the latest estimate and its ``force_t_s``, so that a control loop always
has the freshest force and knows its age, ``t_s - force_t_s``.

Each chip's period T is measured from its conversions (the mean of its last
:data:`PERIOD_MEMORY` intervals, a missed conversion's double interval left
out), not taken from the datasheet: two chips drift apart.

Statuses, per estimate, in the estimator's precedence
(:mod:`sailforce.status`): ``invalid`` (a reading or an angle not finite),
``singular`` (at ``c*``, or an averaged map that cannot be inverted),
``saturated`` (a conversion used beyond the capacity), ``motion-unknown``
(a window not covered by known ticks and rates: the recording's start,
gaps, unknown rates; and every row before both cells have one), and
``extrapolated`` (delta at ``c*`` outside the calibrated range).  A row
whose own time or angles are not numbers (or that is malformed) is
``invalid`` and carries no force, though the estimate it would carry lives on.

The estimator is fed the table's rows in order (:meth:`MultiRateEstimator.rows`)
and keeps only a window's worth of them.  Every sum over a window or a run of
periods is sequential, oldest first, and no matrix product is taken over a
chunk's rows, so a file and a live stream cut into other chunks give the same
numbers to the last digit.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..adc import ADC
from ..errors import InputError
from ..kernel import solve_2x2, torque_entries
from ..kinematics import SINGULAR_SIN_DELTA, is_singular, sin_delta_from_trig
from ..status import EXTRAPOLATED, INVALID, MOTION_UNKNOWN, OK, SATURATED, SINGULAR
from .estimator import DELTA_RANGE_SLACK, Sensing, estimate_with_rates

#: Conversion intervals a chip's period is measured over (a drifting clock is followed within a fraction of a second).
PERIOD_MEMORY = 16
#: An interval beyond this many nominal periods is a missed conversion: it does not enter the measured period.
MISSED_CONVERSION = 1.5
#: A tick step beyond this many median steps inside a window is a gap: the window's motion is unknown.
GAP_STEPS = 2.5
#: Conversions each cell keeps for the interpolation to c* (the older cell's centroid is at most a few behind).
HISTORY = 8


@dataclass
class _Cell:
    """One cell's recent conversions: centroids [s], static part u, averaged map row (2,), dynamic part, raw reading."""

    centroid: np.ndarray
    u: np.ndarray
    row: np.ndarray
    dynamic: np.ndarray
    raw: np.ndarray
    known: np.ndarray  #: the window had known ticks and rates
    intervals: np.ndarray  #: the last conversion intervals [s]
    last_time: float = np.nan


def _empty_cell() -> _Cell:
    return _Cell(np.empty(0), np.empty(0), np.empty((0, 2)), np.empty(0), np.empty(0), np.empty(0, dtype=bool), np.empty(0))


@dataclass(frozen=True)
class MultiRateRows:
    """What the estimator gives for a chunk of rows: the output columns and each row's status."""

    columns: dict[str, np.ndarray]  #: fx_N, fy_N, force_N, angle_deg, [inertial1, inertial2], force_t_s
    status: np.ndarray


class MultiRateEstimator:
    """Rows of a multi-rate table in, in order; each row's latest estimate and its instant out (module docstring)."""

    def __init__(self, cal, *, dynamic: bool = True):
        if not cal.multirate:
            raise InputError("this calibration has the ideal ADC: its estimate is the synchronous one")
        self.cal = cal
        self.adc: ADC = cal.adc
        self.sensing = Sensing(cal.model, cal.offsets, cal.capacity, cal.delta_range)
        self.shear_model = cal.dynamics.shear_model(cal.arm) if dynamic and cal.dynamics is not None else None
        self.cells = [_empty_cell(), _empty_cell()]
        self.keep_s = 2.0 * self.adc.settling_s * (1.0 + self.adc.rate_tolerance) + 4.0 * self.adc.period_s
        self.ticks = {"t": np.empty(0), "q": np.empty((0, 2)), "m": np.empty((0, 4)), "d": np.empty((0, 2))}
        self.current: tuple[float, ...] = (np.nan, np.nan, np.nan, np.nan, np.nan, float(MOTION_UNKNOWN))  # fx, fy, d1, d2, force_t, status

    @property
    def inertial(self) -> bool:
        """Whether the output has the subtracted dynamic loads (``inertial1, inertial2``)."""
        return self.shear_model is not None

    # -- ticks --------------------------------------------------------------------------------
    def _append_ticks(self, t, q, rate, accel, malformed) -> None:
        bad = malformed | ~np.isfinite(t) | ~np.all(np.isfinite(q), axis=1)
        q0 = np.where(bad[:, None], 0.0, q)
        s1, c1, s2, c2 = np.sin(q0[:, 0]), np.cos(q0[:, 0]), np.sin(q0[:, 1]), np.cos(q0[:, 1])
        jt = torque_entries(self.cal.arm.l2, self.cal.arm.l3, s1, c1, s2, c2)
        m = np.column_stack(self.cal.model.sensing_entries(q0[:, 0] - q0[:, 1], jt))
        if self.shear_model is not None:
            at_offsets = np.broadcast_to(np.asarray(self.cal.offsets, float), (t.size, 2))
            d = estimate_with_rates(self.sensing, self.shear_model, q0[:, 0], q0[:, 1], at_offsets[:, 0], at_offsets[:, 1],
                                    rate[:, 0], rate[:, 1], accel[:, 0], accel[:, 1], threads=1)[3]  # fmt: skip
        else:
            d = np.zeros((t.size, 2))
        m[bad], d[bad] = np.nan, np.nan
        buffer = self.ticks
        for name, value in (("t", np.where(bad, np.nan, t)), ("q", np.where(bad[:, None], np.nan, q)), ("m", m), ("d", d)):
            buffer[name] = np.concatenate([buffer[name], value])

    def _trim(self) -> None:
        t = self.ticks["t"]
        finite = t[np.isfinite(t)]
        if finite.size:
            keep = np.flatnonzero(~(t < finite[-1] - self.keep_s))
            first = keep[0] if keep.size else t.size
            for name in self.ticks:
                self.ticks[name] = self.ticks[name][first:]

    # -- conversions --------------------------------------------------------------------------
    def _periods(self, cell: _Cell, times: np.ndarray) -> np.ndarray:
        """Each conversion's measured period: the mean of the chip's last intervals (nominal until it has one).

        The mean is a sequential sum of at most :data:`PERIOD_MEMORY` intervals, oldest first, so that a chunk
        boundary cannot change a digit.
        """
        nominal = self.adc.period_s
        steps = np.diff(np.concatenate([[cell.last_time], times]))
        with np.errstate(invalid="ignore"):
            good = (steps > 0) & (steps < MISSED_CONVERSION * nominal)  # NaN (no last yet) and missed conversions out
        kept = np.concatenate([cell.intervals, steps[good]])
        have = cell.intervals.size + np.cumsum(good)  # intervals known at each conversion
        if kept.size:
            lags = np.arange(PERIOD_MEMORY)[None, :]
            index = (have[:, None] - PERIOD_MEMORY) + lags  # the last PERIOD_MEMORY of them, oldest first
            use = index >= 0
            values = np.where(use, kept[np.clip(index, 0, kept.size - 1)], 0.0)
            n = use.sum(axis=1)
            sums = np.cumsum(values, axis=1)[:, -1]
            periods = np.where(n > 0, sums / np.maximum(n, 1), nominal)
        else:
            periods = np.full(times.size, nominal)
        cell.intervals = kept[-PERIOD_MEMORY:]
        if times.size:
            cell.last_time = float(times[-1])
        return periods

    def _windows(self, cell: int, times: np.ndarray, periods: np.ndarray):
        """Averaged map rows ``(m, 2)``, dynamic parts ``(m,)`` and known flags of conversions at ``times``.

        The weights are the filter's at the ticks in each window, normalised to sum 1; the window is unknown when
        it reaches before the kept ticks, crosses an invalid tick or a gap, or a tick in it has no known rates.
        Each window is summed oldest tick first by :func:`numpy.cumsum` (a sequential sum): its digits depend on
        the window's own values only, never on how many rows a chunk held.
        """
        t, m, d = self.ticks["t"], self.ticks["m"], self.ticks["d"]
        rows = np.full((times.size, 2), np.nan)
        dynamic = np.full(times.size, np.nan)
        known = np.zeros(times.size, dtype=bool)
        if not times.size or t.size < 2:
            return rows, dynamic, known
        valid_t = np.where(np.isfinite(t), t, -np.inf)
        # searched on the latest valid time at each tick (an invalid tick's -inf would unsort the times)
        ordered = np.maximum.accumulate(valid_t)
        first = np.searchsorted(ordered, times - self.adc.sinc_order * periods - 1e-12, side="left")
        last = np.searchsorted(ordered, times + 1e-12, side="right")  # one past the newest tick in the window
        count = last - first
        width = int(max(2, count.max()))
        index = first[:, None] + np.arange(width)[None, :]
        inside = index < last[:, None]
        index = np.minimum(index, t.size - 1)
        tk = np.where(inside, t[index], np.nan)
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a window of one tick has no step: it is refused below
            steps = np.diff(tk, axis=1)
            median = np.nanmedian(np.where(np.isfinite(steps), steps, np.nan), axis=1)
            gap = np.nanmax(np.where(np.isfinite(steps), steps, -np.inf), axis=1) > GAP_STEPS * median
        before = np.isneginf(valid_t[np.maximum(first - 1, 0)])  # the tick before the window must be known too
        bad_tick = np.any(inside & np.isneginf(valid_t[index]), axis=1)
        mm = np.where(inside[:, :, None], m[index][:, :, 2 * cell : 2 * cell + 2], 0.0)
        dd = np.where(inside, d[index][:, :, cell], 0.0)
        unknown_tick = np.any(inside & (~np.isfinite(dd) | ~np.all(np.isfinite(mm), axis=2)), axis=1)
        w = np.nan_to_num(self._spline(np.where(inside, (times[:, None] - tk) / periods[:, None], np.inf)), nan=0.0)
        w = np.where(inside, w, 0.0)
        mm, dd = np.nan_to_num(mm), np.nan_to_num(dd)
        end = np.maximum(count - 1, 0)[:, None]
        take = lambda x: np.take_along_axis(np.cumsum(x, axis=1), end, axis=1)[:, 0]
        total = take(w)
        ok = (first > 0) & (count >= 2) & ~before & ~bad_tick & ~gap & ~unknown_tick & (total > 0)
        with np.errstate(invalid="ignore", divide="ignore"):
            rows[ok, 0] = (take(w * mm[:, :, 0]) / total)[ok]
            rows[ok, 1] = (take(w * mm[:, :, 1]) / total)[ok]
            dynamic[ok] = (take(w * dd) / total)[ok]
        known[ok] = True
        return rows, dynamic, known

    def _convert(self, i: int, times: np.ndarray, raw: np.ndarray) -> None:
        """Add a cell's conversions to its history."""
        cell = self.cells[i]
        periods = self._periods(cell, times)
        late = times - self.cal.adc_delay_s  # the window as the free-motion calibration found it
        rows, dynamic, known = self._windows(i, late, periods)
        centroid = late - 0.5 * self.adc.sinc_order * periods
        u = raw - self.cal.offsets[i] - dynamic
        cell.centroid = np.concatenate([cell.centroid, centroid])
        cell.u = np.concatenate([cell.u, u])
        cell.row = np.concatenate([cell.row, rows])
        cell.dynamic = np.concatenate([cell.dynamic, dynamic])
        cell.raw = np.concatenate([cell.raw, raw])
        cell.known = np.concatenate([cell.known, known])

    def _forget(self) -> None:
        for cell in self.cells:
            for name in ("centroid", "u", "row", "dynamic", "raw", "known"):
                setattr(cell, name, getattr(cell, name)[-HISTORY:])

    def _at(self, cell: _Cell, latest: np.ndarray, instant: np.ndarray):
        """Each event's u, map row, dynamic part, raws (pair) and known flag of a cell, interpolated at ``instant``.

        ``latest`` is the index of the cell's newest conversion at each event (-1: none yet).
        """
        c = cell.centroid
        j = np.searchsorted(c, instant, side="right") - 1
        j = np.minimum(j, latest)
        have = (latest >= 0) & (j >= 0)
        j = np.clip(j, 0, max(c.size - 1, 0))
        nxt = np.minimum(j + 1, np.maximum(latest, 0))
        exact = ~have | (nxt == j) | (c[j] == instant) if c.size else np.ones(instant.size, dtype=bool)
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(exact, 0.0, (instant - c[j]) / (c[nxt] - c[j]))
        mix = lambda x: (1.0 - a) * x[j] + a * x[nxt]
        u = mix(cell.u)
        row = (1.0 - a)[:, None] * cell.row[j] + a[:, None] * cell.row[nxt]
        dyn = mix(cell.dynamic)
        raw = np.column_stack([cell.raw[j], np.where(exact, cell.raw[j], cell.raw[nxt])])
        known = cell.known[j] & cell.known[nxt]
        return have, u, row, dyn, raw, known

    def _estimates(self, latest: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """``(e, 6)`` estimates at each event: fx, fy, d1, d2, force_t (c*) and the status."""
        e = latest[0].size
        out = np.full((e, 6), np.nan)
        out[:, 5] = MOTION_UNKNOWN
        both = (latest[0] >= 0) & (latest[1] >= 0)
        if not both.any():
            return out
        c1 = np.where(latest[0] >= 0, self.cells[0].centroid[np.maximum(latest[0], 0)], np.nan)
        c2 = np.where(latest[1] >= 0, self.cells[1].centroid[np.maximum(latest[1], 0)], np.nan)
        instant = np.fmin(c1, c2)
        have1, u1, row1, d1, raw1, known1 = self._at(self.cells[0], latest[0], instant)
        have2, u2, row2, d2, raw2, known2 = self._at(self.cells[1], latest[1], instant)
        q = self._angles(instant)
        known = known1 & known2 & have1 & have2
        fx, fy = solve_2x2((row1[:, 0], row1[:, 1], row2[:, 0], row2[:, 1]), u1, u2, ~known)
        with np.errstate(invalid="ignore"):
            sd = sin_delta_from_trig(np.sin(q[:, 0]), np.cos(q[:, 0]), np.sin(q[:, 1]), np.cos(q[:, 1]))
            delta = q[:, 0] - q[:, 1]
            s1, s2 = raw1 - self.cal.offsets[0], raw2 - self.cal.offsets[1]
            full1, full2 = np.abs(s1) > self.cal.capacity[0], np.abs(s2) > self.cal.capacity[1]
            saturated = np.any(full1, axis=1) | np.any(full2, axis=1)
            low, high = self.cal.delta_range[0] - DELTA_RANGE_SLACK, self.cal.delta_range[1] + DELTA_RANGE_SLACK
            extrapolated = ~((delta >= low) & (delta <= high))
        invalid = ~(np.all(np.isfinite(s1), axis=1) & np.all(np.isfinite(s2), axis=1) & np.all(np.isfinite(q), axis=1))
        singular = is_singular(sd, SINGULAR_SIN_DELTA) | (known & ~np.isfinite(fx))
        status = np.full(e, OK, dtype=float)
        status[extrapolated] = EXTRAPOLATED
        status[~known] = MOTION_UNKNOWN
        status[saturated] = SATURATED
        status[singular] = SINGULAR
        status[invalid] = INVALID
        status[~both] = MOTION_UNKNOWN
        no_force = np.isin(status, (SINGULAR, INVALID, MOTION_UNKNOWN))
        fx, fy = np.where(no_force, np.nan, fx), np.where(no_force, np.nan, fy)
        out[:] = np.column_stack([fx, fy, d1, d2, np.where(both, instant, np.nan), status])
        return out

    def _angles(self, instant: np.ndarray) -> np.ndarray:
        t, q = self.ticks["t"], self.ticks["q"]
        ok = np.isfinite(t)
        result = np.full((instant.size, 2), np.nan)
        if ok.sum() < 2:
            return result
        inside = (instant >= t[ok][0]) & (instant <= t[ok][-1])
        for k in range(2):
            result[:, k] = np.where(inside, np.interp(instant, t[ok], q[ok, k]), np.nan)
        return result

    # -- rows ---------------------------------------------------------------------------------
    def rows(self, t, q, loads, load_t, malformed, rate=None, accel=None) -> MultiRateRows:
        """The output of a chunk of rows, given in order: ticks [s], angles [rad] ``(n, 2)``, loads ``(n, 2)`` (NaN: no
        conversion), their data-ready instants ``(n, 2)`` (NaN: the tick's), the malformed rows, and the rates."""
        n = t.size
        if self.shear_model is not None and (rate is None or accel is None):
            raise InputError("a calibration with a dynamic term needs each row's joint rates")
        nan2 = np.full((n, 2), np.nan)
        self._append_ticks(t, q, nan2 if rate is None else rate, nan2 if accel is None else accel, malformed)
        fresh = np.isfinite(loads) & ~malformed[:, None]
        ready = np.where(np.isfinite(load_t), load_t, t[:, None])
        # events in row order, cell 1 before cell 2 on one row; each cell's latest conversion index at each event
        rows_, cells_ = np.nonzero(fresh)
        latest = []
        for i in (0, 1):
            mine = cells_ == i
            self._convert(i, ready[rows_[mine], i], loads[rows_[mine], i])
            before = self.cells[i].centroid.size - mine.sum() - 1  # the newest before this chunk (-1: none)
            latest.append(before + np.cumsum(mine))
        estimates = self._estimates((latest[0], latest[1]))
        # each row carries the estimate of its last event, or the one before the chunk
        table = np.vstack([np.array([self.current], dtype=float), estimates])
        event_row = np.full(n, -1)
        event_row[rows_] = np.arange(rows_.size)  # several events on one row: the later wins
        index = np.maximum.accumulate(np.where(event_row >= 0, event_row + 1, 0))
        out = table[index]
        if estimates.shape[0]:
            self.current = tuple(float(v) for v in estimates[-1])
        self._forget()
        self._trim()
        status = out[:, 5].astype(np.int8)
        fx, fy = out[:, 0].copy(), out[:, 1].copy()
        malformed = malformed | ~np.isfinite(t) | ~np.all(np.isfinite(q), axis=1)  # a row of its own that is broken
        status[malformed] = INVALID
        fx[malformed], fy[malformed] = np.nan, np.nan
        columns = {"fx_N": fx, "fy_N": fy, "force_N": np.hypot(fx, fy), "angle_deg": np.degrees(np.arctan2(fy, fx))}
        if self.inertial:
            d1, d2 = out[:, 2].copy(), out[:, 3].copy()
            d1[malformed], d2[malformed] = np.nan, np.nan
            columns |= {"inertial1": d1, "inertial2": d2}
        force_t = out[:, 4].copy()
        force_t[malformed] = np.nan
        columns["force_t_s"] = force_t
        return MultiRateRows(columns, status)

    def _spline(self, x: np.ndarray) -> np.ndarray:
        """The cardinal B-spline of the filter's order at ``x`` (in periods), 0 outside [0, N]."""
        from scipy.interpolate import BSpline

        if not hasattr(self, "_basis"):
            self._basis = BSpline.basis_element(np.arange(self.adc.sinc_order + 1), extrapolate=False)
        return self._basis(x)


def _with_period(adc: ADC, period: float) -> ADC:
    from dataclasses import replace

    return replace(adc, rate_Hz=1.0 / period)


#: The conversion-time columns of the multi-rate format (optional: without them a conversion is the tick's).
LOAD_TIME_COLUMNS: Sequence[str] = ("load1_t_s", "load2_t_s")


def held_loads(loads: np.ndarray) -> np.ndarray:
    """Each cell's latest conversion held on every row (NaN before the first): what a timing-blind pipeline reads."""
    loads = np.asarray(loads, dtype=float)
    out = np.empty_like(loads)
    for i in range(loads.shape[1]):
        have = np.isfinite(loads[:, i])
        index = np.maximum.accumulate(np.where(have, np.arange(loads.shape[0]), -1))
        out[:, i] = np.where(index >= 0, loads[np.maximum(index, 0), i], np.nan)
    return out
