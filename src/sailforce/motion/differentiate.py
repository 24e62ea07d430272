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

**Blocks and live use.**  :class:`RateTracker` takes the samples in
blocks of any size (file chunks, or one line at a time from a live stream)
and gives each sample's values once half a window has followed it, from
the same window: so a live stream gets the offline values
:meth:`RateTracker.delay` samples (half a window, 50 ms at 1 kHz) late, and
the loads are held back by the same count to stay aligned with them.

**Gaps.**  A step in time that is not positive or is longer than
:data:`GAP_FACTOR` sampling periods, or a sample whose time or angle is
not a number, cuts the stream; a sample closer than half a window to a cut,
or to the start or end, has no full window, so its motion is unknown (NaN),
and callers mark it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._blocks import THREADS, for_each_block
from ..errors import MotionDataError

#: A time step longer than this many median steps is a gap: the recording stopped, or samples were lost.
GAP_FACTOR = 3.0

#: Sampling counts as uniform when every step is within this fraction of the median step; the
#: fixed-coefficient filter then differs from the timestamp fit by about this fraction.
UNIFORM_RTOL = 1e-6

#: Samples per block of the timestamp fit: its (block, window, order + 1) arrays stay ~10 MB.
FIT_BLOCK = 4096

#: Windows per block of the fixed-coefficient filter, run on :data:`THREADS` threads (numpy's loops release the GIL).
UNIFORM_BLOCK = 1 << 16

#: Valid time steps whose median sets the sampling period of a stream whose rate is not given.
PROBE_STEPS = 64

#: Fastest joint rate an arm that a hand holds can reach [rad/s]: five turns a second (a fast reach is ~5 rad/s).
#: A fitted rate beyond it is an encoder glitch or a unit error, never a motion: the row's motion is unknown.
MAX_JOINT_RATE = 30.0

#: Largest plausible joint acceleration [rad/s^2]: 900 m/s^2 at 0.3 m, an impact; reaches reach ~20 rad/s^2.
MAX_JOINT_ACCEL = 3000.0

#: The rate fit needs this many more samples in its window than its polynomial has coefficients minus one,
#: or it follows the encoder quantization instead of the motion.
MIN_WINDOW_MARGIN = 3



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


def unwrapped(q: np.ndarray, carry: tuple[np.ndarray, np.ndarray] | None = None):
    """``q`` ``(n, k)`` [rad] with every step of more than half a turn between samples undone as a wrap; and the carry.

    An angle written modulo 360 deg jumps by a turn where it crosses 0; no
    arm moves half a turn between two samples, so such a step is a wrap, and
    a rate fitted across it would be thousands of degrees a second.  Each
    jump adds the nearest whole turns to every later sample; steps next to a
    missing (NaN) sample are left as they are (the rate fit never spans one).
    Rates do not depend on the whole turns added.  ``carry``, from the
    previous block (its last raw angles and their correction), makes blocks
    fed one after another give the numbers of one pass.  Without a wrap
    ``q`` itself comes back, unchanged.
    """
    q = np.asarray(q, float)
    previous, offset = carry if carry is not None else (np.full(q.shape[1], np.nan), np.zeros(q.shape[1]))
    if not q.shape[0]:
        return q, (previous, offset)
    steps = np.diff(np.concatenate([previous[None], q]), axis=0)
    wraps = np.abs(steps) > math.pi  # NaN compares False
    if not wraps.any():
        return (q if not offset.any() else q + offset), (q[-1], offset)
    turns = np.where(wraps, -np.round(steps / (2 * math.pi)), 0.0)
    correction = offset + 2 * math.pi * np.cumsum(turns, axis=0)
    return q + correction, (q[-1], correction[-1])


def implausible(rate: np.ndarray, accel: np.ndarray) -> np.ndarray:
    """Rows ``(n,)`` whose rate or acceleration no arm reaches (:data:`MAX_JOINT_RATE`, :data:`MAX_JOINT_ACCEL`)."""
    with np.errstate(invalid="ignore"):
        return (np.abs(rate) > MAX_JOINT_RATE).any(axis=-1) | (np.abs(accel) > MAX_JOINT_ACCEL).any(axis=-1)


def check_period(differentiator: Differentiator, dt: float, what: str = "t_s") -> None:
    """Refuse a sampling period that leaves the rate window too few samples to fit, naming the likely unit error.

    A ``t_s`` column in milliseconds has steps of about 1 at 1 kHz: the
    0.1 s window then spans a tenth of a sample, and every rate would come out
    a thousand times too small, the dynamic term silently near zero.
    """
    if differentiator.window(dt) >= differentiator.order + MIN_WINDOW_MARGIN:
        return
    n = int(round(differentiator.window_s / dt))
    hint = (f"; is {what} in milliseconds? It must be in seconds" if 0.5 <= dt <= 100 else
            f"; record at {(differentiator.order + MIN_WINDOW_MARGIN) / differentiator.window_s:.3g} Hz or faster")
    raise MotionDataError(f"{what} steps by {dt:.4g} (median), which leaves {max(n, 0)} samples in the "
                          f"{differentiator.window_s:g} s window that rates are fitted over (at least "
                          f"{differentiator.order + MIN_WINDOW_MARGIN} are needed){hint}")  # fmt: skip


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


def derivatives(t, q, differentiator: Differentiator = Differentiator(), *, dt: float | None = None
                ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Rates and accelerations of ``q`` ``(n, k)`` sampled at times ``t`` ``(n,)``; NaN where unknown.

    Zero-phase: each sample's values come from the window centred on it.
    ``dt`` defaults to the median step, after checking that time increases.
    """
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if q.ndim == 1:
        q = q[:, None]
    tracker = RateTracker(differentiator, sampling_period(t) if dt is None else dt)
    parts = [tracker.feed(t, q), tracker.finish()]
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(2))  # type: ignore[return-value]


@dataclass(frozen=True)
class RatePlan:
    """A whole recording's rates, computable block by block: the numbers :class:`RateTracker` gives, in any order.

    Each sample's values depend on its own window alone, so a block of rows
    needs only the samples half a window either side of it.  The offline
    estimate (:func:`sailforce.estimate.dynamic.estimate_moving`) computes each
    block's rates in the thread that then estimates the block's forces,
    while they are still in the cache.  ``dt`` is ``None`` when no
    sampling period can be found (no two valid samples in a row): every
    value is then NaN, as the tracker gives.
    """

    t: np.ndarray
    q: np.ndarray
    dt: float | None
    width: int
    order: int
    linked: np.ndarray

    @classmethod
    def of(cls, t, q, differentiator: Differentiator = Differentiator(), dt: float | None = None) -> RatePlan:
        """The plan for angles ``q`` ``(n, k)`` at times ``t``; the period as :class:`RateTracker` chooses it."""
        t = np.asarray(t, float).reshape(-1)
        q = unwrapped(np.asarray(q, float).reshape(t.size, -1))[0]
        if dt is None:
            steps = _valid_steps(t, q)
            dt = float(np.median(steps[:PROBE_STEPS])) if steps.size else None
        elif not (math.isfinite(dt) and dt > 0):
            raise MotionDataError(f"sampling period {dt!r} s must be a positive time")
        if dt is None:
            return cls(t, q, None, 1, differentiator.order, np.zeros(max(t.size - 1, 0), dtype=bool))
        check_period(differentiator, dt)
        valid = _valid_rows(t, q)
        with np.errstate(invalid="ignore"):
            steps = np.diff(t)
            linked = valid[1:] & valid[:-1] & (steps > 0) & (steps <= GAP_FACTOR * dt)
        return cls(t, q, dt, differentiator.window(dt), differentiator.order, linked)

    def block(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """``(rate, acceleration)`` of rows ``start:stop``, each ``(stop - start, k)``; NaN where unknown."""
        if self.dt is None:
            shape = (stop - start, self.q.shape[1])
            return np.full(shape, np.nan), np.full(shape, np.nan)
        half = self.width // 2
        lo, hi = max(start - half, 0), min(stop + half, self.t.size)
        return _window_fits(self.t[lo:hi], self.q[lo:hi], self.linked[lo : max(hi - 1, lo)], self.dt, self.width,
                            self.order, start - lo, stop - lo, threads=1)  # fmt: skip


class RateTracker:
    """Rates and accelerations of a stream of samples fed in blocks of any size: the same numbers as one pass.

    :meth:`feed` appends samples and returns ``(rate, acceleration)`` for
    the next samples whose motion is decided: those whose window is complete
    (known), or cut by a gap, an invalid sample or the start (unknown, NaN).
    A sample is decided once half a window of samples has followed it, so a
    stream fed one sample at a time gets each sample's values
    :meth:`delay` samples late: the causal use, with the loads held back
    by the same count.  :meth:`finish` decides the rest (unknown: the
    recording ended).  Row counts add up: every sample fed comes out once,
    in order.

    A sample is invalid when its time or an angle is not finite; a step in
    time that is not positive or longer than :data:`GAP_FACTOR` ``dt`` is a
    gap.  ``dt`` None takes the median of the first :data:`PROBE_STEPS`
    valid steps (samples wait until then).
    """

    def __init__(self, differentiator: Differentiator = Differentiator(), dt: float | None = None):
        self.differentiator = differentiator
        self.dt: float | None = None
        self._t = np.empty(0)
        self._q: np.ndarray | None = None
        self._context = 0  # leading buffered samples already returned, kept as the next windows' start
        self._carry: tuple[np.ndarray, np.ndarray] | None = None  # the last block's last angles and their whole turns
        if dt is not None:
            self._set_period(dt)

    def _set_period(self, dt: float) -> None:
        if not (math.isfinite(dt) and dt > 0):
            raise MotionDataError(f"sampling period {dt!r} s must be a positive time")
        check_period(self.differentiator, dt)
        self.dt = float(dt)
        self.width = self.differentiator.window(self.dt)

    def delay(self) -> int:
        """Samples between a sample's arrival and its values (half a window); needs the period."""
        if self.dt is None:
            raise MotionDataError("the sampling period is not known yet")
        return self.width // 2

    def feed(self, t, q) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, float).reshape(-1)
        q, self._carry = unwrapped(np.asarray(q, float).reshape(t.size, -1), self._carry)
        if self._t.size:
            self._t, self._q = np.concatenate([self._t, t]), np.concatenate([self._q, q])
        else:  # nothing held: no copy
            self._t, self._q = t, q
        if self.dt is None:
            steps = _valid_steps(self._t, self._q)
            if steps.size < PROBE_STEPS:
                return self._none()
            self._set_period(float(np.median(steps[:PROBE_STEPS])))
        return self._emit(final=False)

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        """Values of every sample still held (those within half a window of the end are unknown)."""
        if self._q is None:
            return self._none()
        if self.dt is None:
            steps = _valid_steps(self._t, self._q)
            if steps.size == 0:  # no two valid samples in a row: nothing can be differentiated
                n, k = self._q.shape
                self._t, self._q = np.empty(0), None
                return np.full((n, k), np.nan), np.full((n, k), np.nan)
            self._set_period(float(np.median(steps)))
        return self._emit(final=True)

    def _none(self) -> tuple[np.ndarray, np.ndarray]:
        k = 0 if self._q is None else self._q.shape[1]
        return np.empty((0, k)), np.empty((0, k))

    def _emit(self, final: bool) -> tuple[np.ndarray, np.ndarray]:
        t, q, dt, width = self._t, self._q, self.dt, self.width
        half, m = width // 2, t.size
        valid = _valid_rows(t, q)
        steps = np.diff(t)
        with np.errstate(invalid="ignore"):
            linked = valid[1:] & valid[:-1] & (steps > 0) & (steps <= GAP_FACTOR * dt)
        if final:
            stop = m
        else:
            breaks = np.flatnonzero(~linked)
            stop = max(m - half, int(breaks[-1]) + 1 if breaks.size else 0)
            if m and not valid[-1]:
                stop = m
        start = self._context
        rate, accel = _window_fits(t, q, linked, dt, width, self.differentiator.order, start, stop)
        keep = max(stop - half, 0)
        self._t, self._q = t[keep:], q[keep:]
        self._context = stop - keep
        return rate, accel


def _valid_rows(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Rows whose time and angles are all finite (column by column: ``all(axis=1)`` over two columns is ten times slower)."""
    valid = np.isfinite(t)
    for column in q.T:
        valid &= np.isfinite(column)
    return valid


def _valid_steps(t: np.ndarray, q: np.ndarray) -> np.ndarray:
    valid = _valid_rows(t, q)
    steps = np.diff(t)[valid[1:] & valid[:-1]]
    return steps[steps > 0]


def _window_fits(t, q, linked, dt, width, order, start, stop, threads=THREADS) -> tuple[np.ndarray, np.ndarray]:
    """Rates and accelerations of samples ``start:stop`` from their centred windows; NaN where a window is cut.

    A window is known when its ``width - 1`` steps are all linked; the
    fixed Savitzky-Golay coefficients apply where those steps are also all
    within :data:`UNIFORM_RTOL` of ``dt``, the timestamp fit elsewhere.
    Each sample's values depend on its window alone, so any split of a
    stream into blocks gives the same numbers.
    """
    half = width // 2
    n, k = stop - start, q.shape[1]
    # the rows whose window lies inside the buffer: centres lo..hi - 1, the window of centre c is [c - half, c + half]
    lo, hi = max(start, half), min(stop, t.size - half)
    if hi <= lo:
        return np.full((n, k), np.nan), np.full((n, k), np.nan)
    jitter = np.abs(np.diff(t) - dt) > UNIFORM_RTOL * dt  # NaN compares False
    inner_rate, inner_accel = _uniform(q[lo - half : hi + half], dt, width, order, threads)  # every inner row, corrected below
    if not linked.all() or jitter.any():  # else the common case: every window known and uniform
        # a window is cut (or uneven) when a cut (or uneven) step lies between its ends: counted by cumulative sums
        cut = np.concatenate(([0], np.cumsum(~linked)))
        uneven = np.concatenate(([0], np.cumsum(jitter)))
        known = cut[lo + half : hi + half] == cut[lo - half : hi - half]
        uniform = known & (uneven[lo + half : hi + half] == uneven[lo - half : hi - half])
        inner_rate[~known], inner_accel[~known] = np.nan, np.nan
        rows = np.flatnonzero(known & ~uniform)
        if rows.size:
            inner_rate[rows], inner_accel[rows] = _timestamp_fit(t, q, lo + rows, width, order)
        wild = implausible(inner_rate, inner_accel)
        if wild.any():  # no arm moves so: a glitch, not a motion
            inner_rate[wild], inner_accel[wild] = np.nan, np.nan
    if lo == start and hi == stop:
        return inner_rate, inner_accel
    rate, accel = np.full((n, k), np.nan), np.full((n, k), np.nan)
    rate[lo - start : hi - start], accel[lo - start : hi - start] = inner_rate, inner_accel
    return rate, accel


@lru_cache(maxsize=16)
def kernel_polynomials(width: int, order: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The Savitzky-Golay kernels as polynomials in the sample's offset ``i`` from the centre (``-h..h``).

    The least-squares fit of order ``p`` to a centred window gives rate and
    acceleration coefficients ``c_i = sum_k b_k i^k`` with
    ``b^(d) = d! (V^T V)^-1 [d, :] / dt^d``, ``V[i, k] = i^k``
    (Savitzky & Golay 1964); computed on ``u = i / h`` for conditioning.  The
    exact kernels are odd (rate) and even (acceleration) in ``i``, and the
    acceleration's sums to zero; those are imposed, rounding aside.  Returns
    ``(b_rate, b_accel)``, each ``(order + 1,)``: libsail evaluates the
    filter from them as ``sum_k b_k T_k`` with moments ``T_k = sum_i i^k q_i``.
    """
    half = width // 2
    i = np.arange(-half, half + 1)
    k = np.arange(order + 1)
    u = i / half
    P = np.linalg.inv((u[:, None] ** k).T @ (u[:, None] ** k))
    b_rate = P[1] / half ** (1 + k) / dt
    b_accel = 2 * P[2] / half ** (2 + k) / dt**2
    b_rate[k % 2 == 0] = 0.0
    b_accel[k % 2 == 1] = 0.0
    b_accel[0] = -(b_accel[1:] @ np.sum(i[:, None] ** k[1:], axis=0)) / width
    return b_rate, b_accel


@lru_cache(maxsize=16)
def _coefficients(width: int, order: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Savitzky-Golay rate and acceleration coefficients, oldest sample first (computed once per stream)."""
    b_rate, b_accel = kernel_polynomials(width, order, dt)
    powers = np.arange(-(width // 2), width // 2 + 1)[:, None] ** np.arange(order + 1)
    return powers @ b_rate, powers @ b_accel


def _uniform(q: np.ndarray, dt: float, width: int, order: int, threads: int = THREADS) -> tuple[np.ndarray, np.ndarray]:
    """Savitzky-Golay rate and acceleration of each full window of ``q``, in blocks on ``threads`` threads."""
    q = np.ascontiguousarray(q)
    rows, k = q.shape[0] - width + 1, q.shape[1]
    # sliding_window_view's view, made directly: its checks cost a live block of ten rows 50 us
    windows = np.lib.stride_tricks.as_strided(q, (rows, k, width), (q.strides[0], q.strides[1], q.strides[0]), writeable=False)
    first, second = _coefficients(width, order, dt)
    rate, accel = np.empty(windows.shape[:2]), np.empty(windows.shape[:2])

    def run(i: int) -> None:
        block = windows[i : i + UNIFORM_BLOCK]
        np.matmul(block, first, out=rate[i : i + UNIFORM_BLOCK])
        np.matmul(block, second, out=accel[i : i + UNIFORM_BLOCK])

    for_each_block(windows.shape[0], UNIFORM_BLOCK, threads, run)
    return rate, accel


def _timestamp_fit(t: np.ndarray, q: np.ndarray, centres: np.ndarray, width: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares polynomial on each centred window's own timestamps; rate = c1, acceleration = 2 c2."""
    half = width // 2
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
