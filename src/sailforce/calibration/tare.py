"""Tare: new zero offsets from readings taken with nothing touching the end effector.

Shared by ``sail tare`` (a no-load recording) and ``sail live``'s tare
button (the next N samples of the stream): the offsets are the mean raw
loads, the spread their standard deviation, and the shift how far each
offset moves, as a fraction of the cell's capacity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .file import Calibration

#: A tare warns when the no-load readings scatter by more than this
#: fraction of the cell's capacity (standard deviation): the arm was touched,
#: moved, or the cell is drifting.
TARE_SPREAD_WARNING = 0.005

#: A tare needs at least this many no-load samples: with fewer, the
#: spread that tells a touched or drifting arm cannot be seen (an HX711 at
#: 10 Hz gives them in one second).
MIN_TARE_SAMPLES = 10

#: ``sail tare`` refuses, without --force, new offsets that move by more than
#: this fraction of a cell's capacity from the calibration's (``sail live``
#: warns): zero drift of a load cell is a fraction of a percent, so such a
#: shift means a load on the arm, a damaged cell or the wrong calibration file.
TARE_MAX_SHIFT = 0.1


@dataclass(frozen=True)
class Tare:
    """A tare's result: raw offsets, their spread and shift, and the samples behind them."""

    offsets: tuple[float, float]  #: mean raw loads [raw]
    previous: tuple[float, float]  #: the calibration's offsets [raw]
    spread: tuple[float, float]  #: standard deviation of the loads [raw]
    capacity: tuple[float, float]  #: the calibration's capacities [raw]
    samples: int

    @property
    def shift(self) -> tuple[float, float]:
        """How far each offset moves, as a fraction of its cell's capacity."""
        return (abs(self.offsets[0] - self.previous[0]) / self.capacity[0],
                abs(self.offsets[1] - self.previous[1]) / self.capacity[1])  # fmt: skip

    @property
    def noisy(self) -> list[int]:
        """Cells (1, 2) whose readings scattered by more than :data:`TARE_SPREAD_WARNING` of capacity."""
        return [i + 1 for i in range(2) if self.spread[i] > TARE_SPREAD_WARNING * self.capacity[i]]

    @property
    def too_far(self) -> list[int]:
        """Cells (1, 2) whose offset moved by more than :data:`TARE_MAX_SHIFT` of capacity."""
        return [i + 1 for i in range(2) if self.shift[i] > TARE_MAX_SHIFT]

    def shift_warnings(self, unit: str = "raw") -> list[str]:
        """A sentence for each cell whose offset moved too far (:data:`TARE_MAX_SHIFT`)."""
        return [f"cell {cell}'s offset would move by {self.shift[cell - 1]:.0%} of its capacity "
                f"({self.previous[cell - 1]:.6g} -> {self.offsets[cell - 1]:.6g} {unit}), more than {TARE_MAX_SHIFT:.0%}: "
                "was something touching the arm, or is this the wrong calibration file?" for cell in self.too_far]  # fmt: skip

    def spread_warning(self) -> str | None:
        """A sentence when the readings scattered (:data:`TARE_SPREAD_WARNING`), else None."""
        if not self.noisy:
            return None
        return (f"cell(s) {', '.join(map(str, self.noisy))} scatter by more than {TARE_SPREAD_WARNING:.1%} of capacity: "
                "was the arm touched or moving during the tare?")

    def warnings(self, unit: str = "raw") -> list[str]:
        """Every sentence for people about a doubtful tare (empty when it looks right)."""
        spread = self.spread_warning()
        return self.shift_warnings(unit) + ([spread] if spread else [])


def tare(cal: Calibration, loads: np.ndarray, source: object = "the tare") -> Tare:
    """The offsets from no-load raw ``loads`` ``(n, 2)``; rows with a non-finite load are left out.

    Raises :class:`sailforce.errors.SailError` with fewer than
    :data:`MIN_TARE_SAMPLES` usable rows.
    """
    loads = np.asarray(loads, float).reshape(-1, 2)
    loads = loads[np.all(np.isfinite(loads), axis=1)]
    if len(loads) < MIN_TARE_SAMPLES:
        raise InputError(f"{source}: {len(loads)} usable sample(s); a tare needs at least {MIN_TARE_SAMPLES}, so that "
                        "their spread shows whether the arm was still. Record for longer")  # fmt: skip
    offsets, spread = loads.mean(axis=0), loads.std(axis=0, ddof=1)
    pair = lambda a: (float(a[0]), float(a[1]))
    return Tare(pair(offsets), pair(cal.offsets), pair(spread), pair(cal.capacity), len(loads))
