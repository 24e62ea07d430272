"""Run-time estimation: a force and a status for every reading, at rest or while the arm moves.

- :func:`estimate_force`: the plain inversion of a sensing map, ``F = M^-1 s``;
- :func:`estimate_calibrated`: the calibrated estimate (offsets, capacity, calibrated range), one status per reading;
- :func:`estimate_with_rates`: the same while the arm moves, at known joint rates;
- :class:`DynamicTerm` and :func:`estimate_moving`: the links' inertia and weight subtracted while moving;
- :class:`LowPass`: a causal low-pass for the readings whose state carries across chunks;
- :class:`ReZero`: the offsets re-estimated whenever the handle is free, within a :class:`ReZeroPolicy`'s limits.
"""

from ..status import EXTRAPOLATED, INVALID, MOTION_UNKNOWN, OK, SATURATED, SINGULAR, STATUS_NAMES
from .dynamic import DynamicTerm, estimate_moving, motion_states, reading_gain
from .estimator import Sensing, estimate, estimate_calibrated, estimate_force, estimate_with_rates, status_counts
from .filters import FilterError, LowPass
from .multirate import MultiRateEstimator, held_loads
from .rezero import REZERO_COLUMNS, ReZero, ReZeroEvent, ReZeroPolicy

__all__ = [
    "EXTRAPOLATED",
    "INVALID",
    "MOTION_UNKNOWN",
    "OK",
    "SATURATED",
    "SINGULAR",
    "STATUS_NAMES",
    "DynamicTerm",
    "FilterError",
    "LowPass",
    "MultiRateEstimator",
    "REZERO_COLUMNS",
    "ReZero",
    "ReZeroEvent",
    "ReZeroPolicy",
    "Sensing",
    "estimate",
    "estimate_calibrated",
    "estimate_with_rates",
    "held_loads",
    "estimate_force",
    "estimate_moving",
    "motion_states",
    "reading_gain",
    "status_counts",
]
