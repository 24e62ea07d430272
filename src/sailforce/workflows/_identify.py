"""``identify``: a robot's physical parameters fitted to a Table 4 or to calibration readings, as ``sail identify`` does.

A free joint stiffness needs a spring: the robot's pin or bonded joints become
springs first (:func:`sailforce.fit.with_free_springs`), and the result says
so.  A Table 4 target sets the study's calibration sweeps to its own deltas
(:meth:`sailforce.paper.Protocol.with_table4_deltas`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..fit.identify import AMPLITUDE_WEIGHT, Identification, ReadingsTarget, identify, with_free_springs
from ..io.tables import READING_COLUMNS, REFERENCE_COLUMNS
from ..paper.study import TABLE4_COLUMNS, Protocol
from ..paper.table4_fit import Table4Target
from ..robot import Robot
from ._calibrate import Readings, _columns


@dataclass(frozen=True)
class IdentifyRun:
    """What :func:`identify_robot` made: the identification, on the robot it started from."""

    identification: Identification
    robot: Robot  #: the robot fitted (its joints made springs where a stiffness is free)
    target: Table4Target | ReadingsTarget
    springs_added: bool  #: the robot's joints became springs so that a stiffness could be fitted


def table4_target(table, transduction: str = "deflection", amplitude_weight: float = AMPLITUDE_WEIGHT) -> Table4Target:
    """A Table 4 ``(n, 5)`` in :data:`~sailforce.paper.study.TABLE4_COLUMNS` as a target; its deltas set the sweeps."""
    table = np.asarray(table, dtype=float)
    if table.ndim != 2 or table.shape[1] < len(TABLE4_COLUMNS):
        raise InputError(f"a Table 4 has the columns {', '.join(TABLE4_COLUMNS)}; got an array of shape {table.shape}")
    protocol = Protocol().with_table4_deltas(table[:, 0])
    return Table4Target(table[:, : len(TABLE4_COLUMNS)], transduction, amplitude_weight, protocol)


def readings_target(readings: Readings, transduction: str = "bridge") -> ReadingsTarget:
    """Calibration readings (``theta1_deg, theta2_deg, load1, load2, fx_N, fy_N``, a file or columns) as a target."""
    values, _ = _columns(readings, READING_COLUMNS + REFERENCE_COLUMNS, "Calibration data")
    return ReadingsTarget(np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"]), values["fx_N"],
                          values["fy_N"], values["load1"], values["load2"], transduction)  # fmt: skip


def identify_robot(robot: Robot, target: Table4Target | ReadingsTarget, free: Sequence[str], *,
                   bounds: Mapping[str, tuple[float, float]] | None = None, starts: int | None = None,
                   progress: Callable[[int, int], None] | None = None) -> IdentifyRun:  # fmt: skip
    """Fit the robot-file keys ``free`` to ``target`` (:func:`sailforce.fit.identify`), springs added where needed."""
    springs = with_free_springs(robot, tuple(free))
    added = springs.joints != robot.joints
    fit = identify(springs, target, tuple(free), bounds=bounds, starts=starts, progress=progress)
    return IdentifyRun(fit, springs, target, added)


