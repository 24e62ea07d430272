"""Calibration from multi-rate recordings: settled conversions of held loads, and the dynamic term through the ADC.

**Holds** (static calibration).  A hold is a run of ticks with the same pose
*and* the same known force; two holds at one pose differ only in
``fx_N, fy_N``.  A conversion counts when its whole filter window lies inside
one hold (its start no earlier than the hold's first tick, allowing the
clock's tolerance); each hold then gives one sample per cell, the mean of its
settled conversions (:func:`hold_samples`).

**Free motion** (the dynamic term).  With nobody holding the handle each
conversion reads ``r - o_i = sum_j w_j (G Y)_i(t_j) beta``: the regressor of
:mod:`sailforce.fit.dynamic` passed through the same filter window and
sampled at the conversion, one linear equation per conversion
(:func:`fit_dynamic_multirate`).  The filter's effective delay is identified
beside it: the windows are shifted by ``delay`` and the residual is minimised
over a grid within one period, then refined by a parabola through the best
three; its standard error follows from the parabola's curvature,
``se^2 = 2 s^2 / RSS''`` with ``s^2 = RSS / (m - p)``.  Each chip's rate and
phase are measured from its conversion instants (a straight-line fit of
instant against conversion number, :func:`measure_clock`).

**What the ADC cannot resolve.**  Reaching motion has its acceleration's
energy below a few hertz; a dynamic term needs the filter to pass it and the
conversions to sample it.  The fit is refused when the ADC's -3 dB bandwidth
or its Nyquist frequency lies below :data:`MOTION_ENERGY` of the
acceleration's energy (:func:`motion_bandwidth`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..adc import ADC
from ..errors import MotionDataError
from ..estimate.dynamic import DynamicTerm, reading_gain
from ..motion.differentiate import Differentiator, check_period, derivatives, sampling_period
from ..motion.dynamics import PARAMETERS, base_parameters, shear_regressor
from .dynamic import MAX_CONDITION

#: The share of the joint accelerations' energy below the motion's bandwidth (:func:`motion_bandwidth`).
MOTION_ENERGY = 0.99
#: Delays tried on the grid, over [-T, T] (the refinement then finds the minimum between two of them).
DELAY_GRID = 41
#: A chip's measured rate may differ from the nominal by its tolerance; beyond this multiple of it, a warning.
RATE_WARNING = 1.0


@dataclass(frozen=True)
class HoldSamples:
    """One sample per hold: pose [rad] ``(k, 2)``, force [N] ``(k, 2)``, and each cell's mean settled conversion ``(k, 2)``."""

    pose: np.ndarray
    force: np.ndarray
    loads: np.ndarray
    holds: int  #: holds in the recording
    used_holds: int  #: holds with a settled conversion of each cell
    conversions: tuple[int, int]  #: each cell's conversions in the recording
    settled: tuple[int, int]  #: ... of which whole windows lay inside a hold


def hold_id(theta: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Which hold each tick belongs to: a new hold starts wherever the pose or the force changes."""
    state = np.column_stack([theta, force])
    change = np.any(state[1:] != state[:-1], axis=1)
    return np.concatenate([[0], np.cumsum(change)])


def hold_samples(adc: ADC, t, theta, force, loads, load_t) -> HoldSamples:
    """The settled conversions of each hold, averaged (module docstring).  Arrays as the multi-rate format's rows."""
    t, theta, force, loads, load_t = (np.asarray(a, dtype=float) for a in (t, theta, force, loads, load_t))
    ids = hold_id(theta, force)
    count = int(ids[-1]) + 1 if ids.size else 0
    start = np.full(count, np.inf)
    end = np.full(count, -np.inf)
    np.minimum.at(start, ids, t)
    np.maximum.at(end, ids, t)
    window = adc.settling_s * (1.0 + adc.rate_tolerance)
    means = np.full((count, 2), np.nan)
    converted, settled = [0, 0], [0, 0]
    for i in range(2):
        rows = np.flatnonzero(np.isfinite(loads[:, i]))
        ready = np.where(np.isfinite(load_t[rows, i]), load_t[rows, i], t[rows])
        hold = ids[rows]
        ok = (ready - window >= start[hold] - 1e-9) & (ready <= end[hold] + 1e-9)
        converted[i], settled[i] = int(rows.size), int(ok.sum())
        sums = np.bincount(hold[ok], weights=loads[rows[ok], i], minlength=count)
        numbers = np.bincount(hold[ok], minlength=count)
        with np.errstate(invalid="ignore", divide="ignore"):
            means[:, i] = np.where(numbers > 0, sums / numbers, np.nan)
    first = np.searchsorted(ids, np.arange(count))
    keep = np.all(np.isfinite(means), axis=1)
    pose, held = theta[first][keep], force[first][keep]
    return HoldSamples(pose, held, means[keep], count, int(keep.sum()), (converted[0], converted[1]), (settled[0], settled[1]))


@dataclass(frozen=True)
class Clock:
    """A chip's clock measured from its conversions: rate [Hz], phase [s] in [0, 1 / rate), and the fit's residual."""

    rate_Hz: float
    phase_s: float
    jitter_s: float  #: RMS residual of the instants about the straight line


def measure_clock(times: np.ndarray, nominal_period: float) -> Clock:
    """Rate and phase of conversion instants ``times`` [s] (missed conversions allowed: numbered by the nominal period)."""
    times = np.asarray(times, dtype=float)
    if times.size < 3:
        raise MotionDataError(f"{times.size} conversions: too few to measure a clock (three or more are needed)")
    steps = np.diff(times)
    period = float(np.median(steps))
    number = np.concatenate([[0], np.cumsum(np.maximum(np.round(steps / period), 1))])
    slope, intercept = np.polyfit(number, times, 1)
    residual = times - (intercept + slope * number)
    del nominal_period
    return Clock(float(1.0 / slope), float(np.mod(intercept, slope)), float(np.sqrt(np.mean(residual**2))))


def motion_bandwidth(t: np.ndarray, accel: np.ndarray, energy: float = MOTION_ENERGY) -> float:
    """The frequency [Hz] below which ``energy`` of the accelerations' ``(n, k)`` energy lies (their joint spectrum)."""
    accel = np.nan_to_num(np.asarray(accel, dtype=float))
    dt = float(np.median(np.diff(t)))
    spectrum = np.sum(np.abs(np.fft.rfft(accel - accel.mean(axis=0), axis=0)) ** 2, axis=1)
    frequency = np.fft.rfftfreq(accel.shape[0], dt)
    cumulative = np.cumsum(spectrum)
    if not cumulative[-1] > 0:
        return 0.0
    return float(frequency[int(np.searchsorted(cumulative, energy * cumulative[-1]))])


def window_average(adc: ADC, t: np.ndarray, values: np.ndarray, times: np.ndarray, periods: np.ndarray,
                   shift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The filter's average of ``values`` ``(n, k)`` at ticks ``t`` for conversions at ``times`` (window moved back by
    ``shift`` [s]); and which windows lay inside known ticks.  The vectorised twin of the run-time estimator's sums."""
    values = np.asarray(values, dtype=float)
    if values.ndim == 1:
        values = values[:, None]
    centre = times - shift
    span = adc.sinc_order * periods
    first = np.searchsorted(t, centre - span - 1e-12, side="left")
    last = np.searchsorted(t, centre + 1e-12, side="right")
    width = int(max(2, (last - first).max(initial=2)))
    index = first[:, None] + np.arange(width)[None, :]
    inside = index < last[:, None]
    index = np.minimum(index, t.size - 1)
    from scipy.interpolate import BSpline

    spline = BSpline.basis_element(np.arange(adc.sinc_order + 1), extrapolate=False)
    w = np.nan_to_num(spline((centre[:, None] - t[index]) / periods[:, None]), nan=0.0) * inside
    total = w.sum(axis=1)
    gathered = values[index]
    finite = np.all(np.isfinite(gathered) | ~inside[:, :, None], axis=(1, 2))
    known = (first > 0) & (last < t.size) & (total > 0) & finite
    with np.errstate(invalid="ignore", divide="ignore"):
        average = np.einsum("mk,mkc->mc", w, np.where(inside[:, :, None], np.nan_to_num(gathered), 0.0)) / total[:, None]
    average[~known] = np.nan
    return average, known


@dataclass(frozen=True)
class MultiRateDynamicFit:
    """What :func:`fit_dynamic_multirate` reports."""

    term: DynamicTerm
    delay_s: float  #: the filter's delay beyond N T / 2, identified [s]
    delay_se_s: float  #: its standard error [s]
    rmse: float  #: residual of a conversion [raw units]
    condition: float
    conversions: int  #: conversions used
    clocks: tuple[Clock, Clock]
    motion_bandwidth_Hz: float
    warnings: tuple[str, ...]


def fit_dynamic_multirate(cal, adc: ADC, t, theta, loads, load_t, *, differentiator: Differentiator = Differentiator(),
                          max_condition: float = MAX_CONDITION) -> MultiRateDynamicFit:  # fmt: skip
    """Base parameters and the filter's delay from a multi-rate free-motion recording (module docstring)."""
    t, theta, loads, load_t = (np.asarray(a, dtype=float) for a in (t, theta, loads, load_t))
    check_period(differentiator, sampling_period(t))
    qd, qdd = derivatives(t, theta, differentiator)
    bandwidth = motion_bandwidth(t[np.all(np.isfinite(qdd), axis=1)], qdd[np.all(np.isfinite(qdd), axis=1)])
    if adc.bandwidth_Hz < bandwidth or adc.rate_Hz / 2.0 < bandwidth:
        raise MotionDataError(
            f"the {adc.model} ADC cannot resolve the dynamic term: its -3 dB bandwidth is {adc.bandwidth_Hz:.3g} Hz and "
            f"its Nyquist frequency {adc.rate_Hz / 2:.3g} Hz, but {MOTION_ENERGY:.0%} of this motion's acceleration "
            f"lies below {bandwidth:.3g} Hz. Use a faster ADC (an HX711 at 80 SPS: RATE pin high, [adc] model = "
            '"hx711-80"), or trust the force only while the arm is still'
        )  # fmt: skip
    arm = cal.arm
    base = base_parameters(arm)
    known_tick = np.all(np.isfinite(qd) & np.isfinite(qdd) & np.isfinite(theta), axis=1)
    q0 = np.where(known_tick[:, None], theta, 0.0)
    Y = shear_regressor(arm, q0[:, 0], q0[:, 1], *np.where(known_tick[:, None], qd, 0.0).T,
                        *np.where(known_tick[:, None], qdd, 0.0).T)[..., list(base.columns)]  # fmt: skip
    G = reading_gain(cal.model, arm, q0[:, 0], q0[:, 1])
    A = G @ Y  # (n, 2, p): each tick's readings per unit of each base parameter
    A[~known_tick] = np.nan
    clocks, equations = [], []
    warnings = []
    for i in range(2):
        rows = np.flatnonzero(np.isfinite(loads[:, i]))
        ready = np.where(np.isfinite(load_t[rows, i]), load_t[rows, i], t[rows])
        clock = measure_clock(ready, adc.period_s)
        clocks.append(clock)
        off = clock.rate_Hz / adc.rate_Hz - 1.0
        if abs(off) > RATE_WARNING * max(adc.rate_tolerance, 1e-6):
            warnings.append(f"cell {i + 1}'s ADC converts at {clock.rate_Hz:.4g} Hz, {off:+.2%} from the nominal "
                            f"{adc.rate_Hz:g} Hz, beyond the datasheet's ±{adc.rate_tolerance:.1%}")  # fmt: skip
        equations.append((ready, loads[rows, i] - cal.offsets[i], A[:, i, :], 1.0 / clock.rate_Hz))

    def solve(shift: float):
        design, target = [], []
        for ready, reading, regressor, period in equations:
            average, known = window_average(adc, t, regressor, ready, np.full(ready.size, period), shift)
            design.append(average[known])
            target.append(reading[known])
        X, y = np.concatenate(design), np.concatenate(target)
        scale = np.linalg.norm(X, axis=0)
        scale[scale == 0] = 1.0
        beta, *_ = np.linalg.lstsq(X / scale, y, rcond=None)
        residual = y - (X / scale) @ beta
        return beta / scale, float(residual @ residual), X, y

    period = adc.period_s
    grid = np.linspace(-period, period, DELAY_GRID)
    rss = np.array([solve(s)[1] for s in grid])
    k = int(np.clip(np.argmin(rss), 1, grid.size - 2))
    a, b, c = np.polyfit(grid[k - 1 : k + 2], rss[k - 1 : k + 2], 2)
    delay = float(np.clip(-b / (2 * a), grid[0], grid[-1])) if a > 0 else float(grid[k])
    beta, best, X, y = solve(delay)
    m, p = X.shape
    if m < 10 * len(PARAMETERS) // 2:
        raise MotionDataError(f"only {m} conversions with a known motion; record at least a minute of the motors "
                              "moving the arm through its workspace")  # fmt: skip
    singular = np.linalg.svd(X / np.where(np.linalg.norm(X, axis=0) > 0, np.linalg.norm(X, axis=0), 1.0), compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
    if condition > max_condition:
        raise MotionDataError(f"too little excitation to identify the dynamics (condition number {condition:.3g} > "
                              f"{max_condition:g}): move the arm quickly through its whole workspace, in every direction")  # fmt: skip
    s2 = best / max(m - p, 1)
    delay_se = float(np.sqrt(2 * s2 / (2 * a))) if a > 0 else float("inf")
    term = DynamicTerm(base.columns, tuple(float(v) for v in beta), differentiator, base.names)
    return MultiRateDynamicFit(term, delay, delay_se, float(np.sqrt(s2)), condition, m, (clocks[0], clocks[1]), bandwidth,
                               tuple(warnings))  # fmt: skip


def with_measured_rate(adc: ADC, clocks: tuple[Clock, Clock]) -> ADC:
    """The ADC at the mean of its chips' measured rates (the model's other fields kept)."""
    return replace(adc, rate_Hz=float(np.mean([c.rate_Hz for c in clocks])))
