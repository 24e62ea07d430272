"""Automatic re-zero: each release of the handle is a free tare (docs/reference/drift.md).

A cell's zero drifts over a session (temperature, creep, warm-up:
:mod:`sailforce.drift`), and a calibration's offsets go stale.  Each time
nobody holds the handle, the estimate is the drift alone, seen through the
sensing map: the offsets can be re-estimated then, online, with limits.

**The estimate, re-zeroed.**  The estimate is affine in the loads, ``F = W(q)
(r - o - d)`` (seed Eq. 8 with the calibrated map; ``d`` the dynamic term),
so a change ``D`` of the offsets moves it by ``W(q) D``:

    F_c = F - W(q) D = F - F(o + D),

where ``F(o + D)`` is the estimate of a reading ``o + D`` at the row's angles
(the static map, without the dynamic term, which cancels).  Nothing else of
the estimator changes, and libsail's ``sail_rezero_*`` does the same sums.

**When the handle is free.**  Time is cut into blocks of ``window_s /
blocks`` seconds.  A block is *free* when every row in it has status ``ok``
and, with a ``contact`` column, says 0 (nobody touching).  At the end of each
block, the last ``blocks`` blocks form the window.  It is *quiet* when all of
them are free and consecutive, and the corrected estimate's wander there is
within ``quiet_N``:

    sqrt(var F_cx + var F_cy) <= quiet_N.

A held handle is never quiet: a hand's force wanders by tenths of a newton
(physiological tremor and postural sway), while a free handle's residual
wanders only by the cells' noise and the dynamic model's error.

**The re-zero.**  In a quiet window with mean corrected force ``F̄_c``, the
offsets move by ``dD = W(q)^-1 F̄_c`` (``W`` at the window's last row), so
that the window would have read zero, when:

- ``|F̄_c| >= min_step_N`` (else there is nothing to do);
- ``|F̄_c| <= max_step_N``: a larger step is a hand holding still with a
  steady push, or a knock, and is refused;
- the whole change, the raw estimate's mean ``|F̄|``, stays within
  ``max_total_N`` of the calibration's offsets: beyond that the cell has
  drifted too far to trust, re-tare or recalibrate; refused.

It takes effect from the next block's first row, and the next decision waits
until the window holds only blocks under the new offsets.  Each decision,
made or refused, is a :class:`ReZeroEvent`; the output marks the row where
new offsets begin (``rezero`` 1) and carries the offsets in use.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..status import OK

#: The static map: ``(fx, fy)`` of readings ``(theta1, theta2, load1, load2)``, vectorized (a calibration's
#: ``estimate(..., static=True)`` less its status).
ForceMap = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
#: The reading [raw] each cell is probed with to read the map W(q) off the estimate: small beside any capacity, large
#: beside a float's rounding of the offsets (libsail's SAIL_REZERO_PROBE).
PROBE_COUNTS = 1000.0
#: The output columns a re-zeroed estimate adds before ``status``.
REZERO_COLUMNS = ("offset1", "offset2", "rezero")


@dataclass(frozen=True)
class ReZeroPolicy:
    """When a re-zero is made (see the module docstring); the defaults suit a hand on an HX711 rig."""

    window_s: float = 2.0  #: a free, quiet window this long [s]
    blocks: int = 8  #: it is judged in this many blocks
    quiet_N: float = 0.08  #: the corrected force's wander over the window at most [N]
    min_step_N: float = 0.01  #: a re-zero moves the estimate by at least this [N]
    max_step_N: float = 1.5  #: and at most this [N]
    max_total_N: float = 5.0  #: the offsets stay within this of the calibration's, as force [N]

    def __post_init__(self) -> None:
        if not (self.window_s > 0 and self.blocks >= 1 and self.quiet_N > 0 and 0 <= self.min_step_N
                <= self.max_step_N <= self.max_total_N):  # fmt: skip
            raise InputError(f"a re-zero policy needs a positive window, blocks and quiet limit, and min_step_N <= "
                             f"max_step_N <= max_total_N: {self}")  # fmt: skip

    @property
    def block_s(self) -> float:
        return self.window_s / self.blocks


@dataclass(frozen=True)
class ReZeroEvent:
    """One decision in a quiet window."""

    t_s: float  #: the window's end (the new offsets begin on the next row)
    applied: bool
    delta: tuple[float, float]  #: the offsets' change from the calibration's after it [raw]
    step_N: float  #: |F̄_c|: how far it moves the estimate
    total_N: float  #: |F̄|: how far the offsets are from the calibration's, as force
    reason: str = ""  #: why it was refused


@dataclass
class _Block:
    index: int
    n: int = 0
    free: bool = True
    sums: np.ndarray = field(default_factory=lambda: np.zeros(6))  # F_cx, F_cy, F_cx^2, F_cy^2, F_x, F_y
    last_theta: tuple[float, float] = (math.nan, math.nan)


class ReZero:
    """The re-zero, fed rows in order (:meth:`process`); ``events`` is its log, ``delta`` the offsets' change."""

    def __init__(self, force_of: ForceMap, offsets: tuple[float, float], policy: ReZeroPolicy = ReZeroPolicy()) -> None:
        self.force_of, self.offsets, self.policy = force_of, np.asarray(offsets, float), policy
        self.delta = np.zeros(2)
        self.events: list[ReZeroEvent] = []
        self._t0: float | None = None
        self._block: _Block | None = None
        self._window: list[_Block] = []
        self._wait_until = -1  # the first block index a decision may end on
        self._refused = False  # the current quiet stretch's refusal is logged
        self._begins = False  # the next row is the first under new offsets

    def process(self, t, theta1, theta2, fx, fy, status, contact=None) -> dict[str, np.ndarray]:
        """Rows in order: times [s], angles [rad], the estimate [N] with its statuses, and the optional contact
        (nonzero or NaN: someone may hold the handle).  Returns ``fx_N, fy_N`` corrected and ``offset1, offset2,
        rezero`` for each row."""
        t, fx, fy = (np.asarray(a, float) for a in (t, fx, fy))
        theta1, theta2, status = np.asarray(theta1, float), np.asarray(theta2, float), np.asarray(status)
        n = t.size
        free_row = (status == OK) & np.isfinite(fx) & np.isfinite(fy) & np.isfinite(t)
        if contact is not None:
            free_row &= np.asarray(contact, float) == 0
        if self._t0 is None and np.any(np.isfinite(t)):
            self._t0 = float(t[np.isfinite(t)][0])
        index = np.full(n, -1, dtype=np.int64)
        finite = np.isfinite(t)
        if self._t0 is not None:
            index[finite] = np.floor((t[finite] - self._t0) / self.policy.block_s).astype(np.int64)
        current = self._block.index if self._block is not None else (index[finite][0] if finite.any() else 0)
        index = np.maximum.accumulate(np.where(finite, index, current).clip(min=current))  # a step back stays in its block
        out_fx, out_fy = fx.copy(), fy.copy()
        offsets = np.empty((n, 2))
        begins = np.zeros(n)
        starts = np.flatnonzero(np.diff(index, prepend=index[0] - 1 if n else 0))
        for a, b in zip(starts, [*starts[1:], n]):
            if self._block is None or index[a] != self._block.index:
                if self._block is not None:
                    self._finish(self._block)
                self._block = _Block(int(index[a]))
            begins[a] = float(self._begins)
            self._begins = False
            cx, cy = self._corrected(theta1[a:b], theta2[a:b], fx[a:b], fy[a:b])
            out_fx[a:b], out_fy[a:b] = cx, cy
            offsets[a:b] = self.offsets + self.delta
            self._add(self._block, cx, cy, fx[a:b], fy[a:b], free_row[a:b], theta1[a:b], theta2[a:b])
        return {"fx_N": out_fx, "fy_N": out_fy, "offset1": offsets[:, 0], "offset2": offsets[:, 1], "rezero": begins}

    def _corrected(self, theta1, theta2, fx, fy) -> tuple[np.ndarray, np.ndarray]:
        if not np.any(self.delta):
            return fx.copy(), fy.copy()
        o = self.offsets + self.delta
        dx, dy = self.force_of(theta1, theta2, np.full(theta1.size, o[0]), np.full(theta1.size, o[1]))
        return fx - dx, fy - dy

    @staticmethod
    def _add(block: _Block, cx, cy, fx, fy, free, theta1, theta2) -> None:
        block.free &= bool(np.all(free))
        if not np.all(free):
            return
        block.n += cx.size
        block.sums += [cx.sum(), cy.sum(), (cx * cx).sum(), (cy * cy).sum(), fx.sum(), fy.sum()]
        block.last_theta = (float(theta1[-1]), float(theta2[-1]))

    def _finish(self, block: _Block) -> None:
        """The block is whole: judge the window that ends with it."""
        p = self.policy
        if self._window and block.index != self._window[-1].index + 1:
            self._window = []  # a gap: the window starts again
        self._window = [*self._window, block][-p.blocks:]
        ready = (len(self._window) == p.blocks and block.index >= self._wait_until
                 and all(b.free and b.n > 0 for b in self._window))  # fmt: skip
        if not ready:
            if not all(b.free for b in self._window):
                self._refused = False  # someone holds it: the next quiet stretch logs afresh
            return
        n = sum(b.n for b in self._window)
        cx, cy, cxx, cyy, sx, sy = (float(v) for v in np.sum([b.sums for b in self._window], axis=0) / n)
        wander = math.sqrt(max(cxx - cx * cx, 0.0) + max(cyy - cy * cy, 0.0))
        if wander > p.quiet_N:
            self._refused = False
            return
        step, total = math.hypot(cx, cy), math.hypot(sx, sy)
        t_end = (self._t0 or 0.0) + (block.index + 1) * p.block_s
        if step > p.max_step_N or total > p.max_total_N:
            if not self._refused:
                reason = (f"the step {step:.3g} N is over {p.max_step_N:g} N: a steady hand, or a knock"
                          if step > p.max_step_N else
                          f"the offsets would be {total:.3g} N from the calibration's, over {p.max_total_N:g} N: "
                          f"re-tare or recalibrate")  # fmt: skip
                delta = (float(self.delta[0]), float(self.delta[1]))
                self.events.append(ReZeroEvent(t_end, False, delta, step, total, reason))
                self._refused = True
            return
        if step < p.min_step_N:
            return
        self.delta = self.delta + self._loads_of(block.last_theta, cx, cy)
        self.events.append(ReZeroEvent(t_end, True, (float(self.delta[0]), float(self.delta[1])), step, total))
        self._wait_until = block.index + p.blocks  # a window wholly under the new offsets
        self._begins = True

    def _loads_of(self, theta: tuple[float, float], fx: float, fy: float) -> np.ndarray:
        """The readings' change [raw] that the estimate at ``theta`` reads as ``(fx, fy)``: W(q)^-1 F."""
        w = force_per_count(self.force_of, self.offsets, np.array([theta[0]]), np.array([theta[1]]))[0]
        return np.linalg.solve(w, [fx, fy])


def force_per_count(force_of: ForceMap, offsets, theta1, theta2) -> np.ndarray:
    """``(n, 2, 2)``: W(q), the estimate's force [N] per raw unit of each cell at the angles ``(n,)``, read off the
    estimate of :data:`PROBE_COUNTS` on each cell (the estimate is affine in the loads, and F(o) = 0)."""
    theta1, theta2 = np.asarray(theta1, float), np.asarray(theta2, float)
    n = theta1.size
    o1, o2 = (np.full(n, float(o)) for o in offsets)
    w = np.empty((n, 2, 2))
    for j, (l1, l2) in enumerate(((o1 + PROBE_COUNTS, o2), (o1, o2 + PROBE_COUNTS))):
        gx, gy = force_of(theta1, theta2, l1, l2)
        w[:, 0, j], w[:, 1, j] = np.asarray(gx) / PROBE_COUNTS, np.asarray(gy) / PROBE_COUNTS
    return w
