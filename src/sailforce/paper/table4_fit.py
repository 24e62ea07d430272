"""Identification against a seed-style Table 4: the target, its residuals, and :func:`identify_table4`.

The residuals are each cell's phase at each delta [deg] and, with
``amplitude_weight`` > 0, each amplitude divided by its mean over delta (its
shape, free of the signal unit) times ``amplitude_weight`` [deg per unit
shape] (:mod:`sailforce.fit.identify`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..fit.identify import AMPLITUDE_WEIGHT, Identification, IdentifyError, _rms2, identify
from ..robot import Robot
from .study import Protocol, table4, table4_many


def table4_residuals(model: np.ndarray, target: np.ndarray, amplitude_weight: float = AMPLITUDE_WEIGHT) -> np.ndarray:
    """(n, 4) residuals: both phases [deg], then both amplitude shapes times ``amplitude_weight``."""
    _check_grid(model, target)
    return _residuals(model, target, amplitude_weight)


def _check_grid(model: np.ndarray, target: np.ndarray) -> None:
    if model.shape != target.shape or not np.allclose(model[:, 0], target[:, 0]):
        raise IdentifyError(f"the target's Table 4 has delta = {target[:, 0].tolist()} deg; the protocol's sweeps "
                            f"give {model[:, 0].tolist()}: give a Protocol with the target's grid")  # fmt: skip


def _residuals(model: np.ndarray, target: np.ndarray, amplitude_weight: float) -> np.ndarray:
    phases = model[:, [2, 4]] - target[:, [2, 4]]
    shape = lambda t: t[:, [1, 3]] / np.mean(t[:, [1, 3]], axis=0)
    return np.column_stack([phases, amplitude_weight * (shape(model) - shape(target))])


@dataclass(frozen=True)
class Table4Target:
    """A Table 4 to match: ``table`` ``(n, 5)`` in :data:`~sailforce.paper.study.TABLE4_COLUMNS`."""

    table: np.ndarray
    transduction: str = "deflection"
    amplitude_weight: float = AMPLITUDE_WEIGHT
    protocol: Protocol = field(default_factory=Protocol)
    _grid_checked: bool = field(default=False, init=False, repr=False, compare=False)

    columns = ("phase 1 [deg]", "phase 2 [deg]", "shape 1 (weighted)", "shape 2 (weighted)")

    def residuals(self, robot: Robot) -> np.ndarray:
        """(n, 4) (or (n, 2), phases only, with ``amplitude_weight`` 0); a target off the protocol's delta grid is refused."""
        return self._of(table4(robot, self.transduction, protocol=self.protocol))

    def residuals_many(self, robots: Sequence[Robot]) -> list[np.ndarray]:
        """:meth:`residuals` of each of ``robots``, their frames solved together (a finite-difference Jacobian's columns)."""
        return [self._of(model) for model in table4_many(robots, self.transduction, protocol=self.protocol)]

    def _of(self, model: np.ndarray) -> np.ndarray:
        if model.shape != self.table.shape:
            _check_grid(model, self.table)
        elif not self._grid_checked:  # the grid is the protocol's, the same at every evaluation: checked once
            _check_grid(model, self.table)
            object.__setattr__(self, "_grid_checked", True)
        full = _residuals(model, self.table, self.amplitude_weight)
        return full if self.amplitude_weight > 0 else full[:, :2]

    def metrics(self, residuals: np.ndarray) -> dict[str, tuple[float, float]]:
        out = {"phase_rms_deg": _rms2(residuals[:, :2])}
        if self.amplitude_weight > 0:
            out["shape_rms"] = _rms2(residuals[:, 2:] / self.amplitude_weight)
        return out


def identify_table4(
    robot: Robot,
    target: np.ndarray,
    free: Sequence[str],
    *,
    transduction: str = "deflection",
    amplitude_weight: float = AMPLITUDE_WEIGHT,
    protocol: Protocol = Protocol(),
    bounds: Mapping[str, tuple[float, float]] | None = None,
    starts: int | None = None,
) -> Identification:
    """:func:`identify` against a Table 4 ``(n, 5)``."""
    table = Table4Target(np.asarray(target, dtype=float), transduction, amplitude_weight, protocol)
    return identify(robot, table, free, bounds=bounds, starts=starts)
