"""Joint rates and accelerations from encoder angles: local polynomial fits (Savitzky-Golay).

Each sample's rate and acceleration are those of a polynomial of
:attr:`Differentiator.order` fitted by least squares to the samples within
half a window either side (Savitzky & Golay, *Anal. Chem.* 36(8), 1964),
on the samples' own timestamps.  On uniform sampling this is the
Savitzky-Golay filter; on irregular sampling the fit uses the real times.

**Why this filter.**  On a simulated session (0.3 m minimum-jerk reaches at
3 m/s^2, 1 kHz, 16-bit encoders; ``docs/dynamics.md``), the acceleration
error was 0.049 rad/s^2 RMS (of a 4.06 rad/s^2 signal) for a 0.1 s window
of order 4, against 0.051 for 81 samples, 0.052 for central differences
after a 20 Hz Butterworth filtfilt, and 0.068 or more for the other windows
tried (21 to 151 samples, orders 2 to 4), as ``bench/choose_differentiator.py``
prints.  A window fit, unlike a recursive filter, has a causal twin with
the very same output.

**Live use.**  The causal twin (:class:`CausalDifferentiator`) fits the
same window and so reports a sample's rate and acceleration
:attr:`Differentiator.delay_samples` samples late (half a window); the loads
are delayed by the same count, so the dynamic term and the loads stay
aligned, and offline and live estimates agree sample for sample.

**Gaps.**  A step in time longer than :data:`GAP_FACTOR` sampling periods
(the median step) starts a new segment; a sample closer than half a window
to a segment's start or end has no full window, so its motion is unknown
(NaN), and callers mark it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from .errors import SailError

#: A time step longer than this many median steps is a gap: the recording stopped, or samples were lost.
GAP_FACTOR = 3.0

#: Sampling counts as uniform when every step is within this fraction of the median step; the
#: fixed-coefficient filter then differs from the timestamp fit by about this fraction.
UNIFORM_RTOL = 1e-6

#: Samples per block of the timestamp fit: its (block, window, order + 1) arrays stay ~10 MB.
FIT_BLOCK = 4096


class MotionDataError(SailError):
    """Timestamps or angles that no rate can be derived from."""


@dataclass(frozen=True)
class Differentiator:
    """A centred local polynomial fit: ``window_s`` seconds wide, of order ``order``."""

    window_s: float = 0.1
    order: int = 4

    def __post_init__(self) -> None:
        if not (math.isfinite(self.window_s) and self.window_s > 0):
            raise MotionDataError(f"differentiator window {self.window_s!r} s must be a positive time")
        if not 2 <= self.order <= 6:
            raise MotionDataError(f"differentiator order {self.order!r} must be 2 to 6 (acceleration needs 2)")

    def window(self, dt: float) -> int:
        """The window in samples at sampling period ``dt``: odd, and longer than the order."""
        n = int(round(self.window_s / dt))
        n += 1 - n % 2
        return max(n, self.order + 1 + self.order % 2)  # the smallest odd window that fits the polynomial

    def delay_samples(self, dt: float) -> int:
        return self.window(dt) // 2


def sampling_period(t: np.ndarray) -> float:
    """The median time step [s]; refuses timestamps that do not increase."""
    t = np.asarray(t, float)
    if t.ndim != 1 or t.size < 2:
        raise MotionDataError("need at least two timestamps (column t_s) to derive rates")
    steps = np.diff(t)
    if not np.all(np.isfinite(steps)):
        i = int(np.flatnonzero(~np.isfinite(steps))[0])
        raise MotionDataError(f"timestamp {i + 1} is not a number; t_s must hold the time of every sample [s]")
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0])
        raise MotionDataError(f"time does not increase at sample {i + 1} (t_s {t[i]:g} then {t[i + 1]:g} s); "
                              "record the timestamp of each sample in order")  # fmt: skip
    return float(np.median(steps))


def segments(t: np.ndarray, dt: float) -> list[slice]:
    """Runs of samples without a gap (a step over :data:`GAP_FACTOR` ``dt``)."""
    breaks = np.flatnonzero(np.diff(t) > GAP_FACTOR * dt) + 1
    edges = np.concatenate(([0], breaks, [t.size]))
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def derivatives(t, q, differentiator: Differentiator = Differentiator()) -> tuple[np.ndarray, np.ndarray]:
    """Rates and accelerations of ``q`` ``(n, k)`` sampled at times ``t`` ``(n,)``; NaN where unknown.

    Zero-phase: each sample's values come from the window centred on it.
    """
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if q.ndim == 1:
        q = q[:, None]
    dt = sampling_period(t)
    width = differentiator.window(dt)
    half = width // 2
    rate, accel = np.full(q.shape, np.nan), np.full(q.shape, np.nan)
    for part in segments(t, dt):
        n = part.stop - part.start
        if n < width:
            continue
        ts, qs = t[part], q[part]
        inner = slice(part.start + half, part.stop - half)
        steps = np.diff(ts)
        if np.all(np.abs(steps - dt) <= UNIFORM_RTOL * dt):
            rate[inner], accel[inner] = _uniform(qs, dt, width, differentiator.order)
        else:
            rate[inner], accel[inner] = _timestamp_fit(ts, qs, width, differentiator.order)
    return rate, accel


def _uniform(q: np.ndarray, dt: float, width: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    from scipy.signal import savgol_coeffs

    windows = np.lib.stride_tricks.sliding_window_view(q, width, axis=0)  # (n - width + 1, k, width)
    first = savgol_coeffs(width, order, deriv=1, delta=dt, use="dot")
    second = savgol_coeffs(width, order, deriv=2, delta=dt, use="dot")
    return windows @ first, windows @ second


def _timestamp_fit(t: np.ndarray, q: np.ndarray, width: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares polynomial on each centred window's own timestamps; rate = c1, acceleration = 2 c2."""
    half = width // 2
    centres = np.arange(half, t.size - half)
    rate, accel = np.empty((centres.size, q.shape[1])), np.empty((centres.size, q.shape[1]))
    offsets = np.arange(-half, half + 1)
    powers = np.arange(order + 1)
    for start in range(0, centres.size, FIT_BLOCK):
        c = centres[start : start + FIT_BLOCK]
        index = c[:, None] + offsets
        span = t[c + half] - t[c - half]
        tau = (t[index] - t[c][:, None]) / span[:, None]  # in (-1, 1): a well-conditioned basis
        V = tau[..., None] ** powers  # (b, width, order + 1)
        coef = np.linalg.solve(np.swapaxes(V, 1, 2) @ V, np.swapaxes(V, 1, 2) @ q[index])  # (b, order + 1, k)
        rate[start : start + c.size] = coef[:, 1] / span[:, None]
        accel[start : start + c.size] = 2 * coef[:, 2] / span[:, None] ** 2
    return rate, accel


class CausalDifferentiator:
    """The live twin of :func:`derivatives`: push samples one by one, get each one's rate half a window later.

    ``push(t, q)`` returns ``(t', q', rate, acceleration)`` for the sample
    :meth:`delay` samples back, or None while the window fills.  A gap
    restarts the window.  Its outputs equal :func:`derivatives`'s for the
    same samples (uniform sampling at ``dt``).
    """

    def __init__(self, dt: float, differentiator: Differentiator = Differentiator()):
        from scipy.signal import savgol_coeffs

        self.dt = dt
        self.width = differentiator.window(dt)
        self.first = savgol_coeffs(self.width, differentiator.order, deriv=1, delta=dt, use="dot")
        self.second = savgol_coeffs(self.width, differentiator.order, deriv=2, delta=dt, use="dot")
        self.times: deque[float] = deque(maxlen=self.width)
        self.values: deque[np.ndarray] = deque(maxlen=self.width)

    @property
    def delay(self) -> int:
        return self.width // 2

    def push(self, t: float, q) -> tuple[float, np.ndarray, np.ndarray, np.ndarray] | None:
        if self.times and t - self.times[-1] > GAP_FACTOR * self.dt:
            self.times.clear()
            self.values.clear()
        self.times.append(t)
        self.values.append(np.asarray(q, float))
        if len(self.times) < self.width:
            return None
        window = np.array(self.values)  # (width, k)
        return self.times[self.delay], window[self.delay], self.first @ window, self.second @ window
