"""The run-time force estimator: one calibrated estimate and one status per reading.

Statuses (the same codes as libsail's ``enum``):

- ``OK`` (0);
- ``SINGULAR`` (1): |sin(theta1 - theta2)| < :data:`sailforce.SINGULAR_SIN_DELTA`;
  no estimate (NaN);
- ``SATURATED`` (2): a reading, offset removed, is beyond its cell's capacity;
  the estimate is given but must not be trusted;
- ``EXTRAPOLATED`` (3): delta lies outside the calibrated range (by more
  than :data:`DELTA_RANGE_SLACK`); the estimate is given;
- ``INVALID`` (4): a field is NaN or infinite (or, in files, missing or not a
  number); no estimate.

When several apply, the first in the order INVALID, SINGULAR, SATURATED,
EXTRAPOLATED wins.
"""

from __future__ import annotations

import numpy as np

from .compensation import solve_sensing
from .statics import SINGULAR_SIN_DELTA

OK, SINGULAR, SATURATED, EXTRAPOLATED, INVALID = range(5)
STATUS_NAMES = ("ok", "singular", "saturated", "extrapolated", "invalid")

#: Delta may leave the calibrated range by this much [rad] before the estimate
#: counts as extrapolated: 0.01 deg, below encoder resolution of a held pose.
DELTA_RANGE_SLACK = np.radians(0.01)


def estimate(model, offsets, capacity, delta_range, theta1, theta2, load1, load2):
    """Vectorized estimate: ``(fx, fy, status)`` for arrays of readings (angles [rad], raw loads).

    ``model`` is a sensing model (``sensing_matrix``), ``offsets`` and
    ``capacity`` are ``(2,)`` raw units, ``delta_range`` [rad].  Inputs
    broadcast; nothing raises on bad readings: they get their status.
    """
    theta1, theta2, load1, load2 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (theta1, theta2, load1, load2)))
    invalid = ~(np.isfinite(theta1) & np.isfinite(theta2) & np.isfinite(load1) & np.isfinite(load2))
    if invalid.any():  # keep NaN out of the arithmetic; these rows are masked below
        theta1, theta2, load1, load2 = (np.where(invalid, 0.0, a) for a in (theta1, theta2, load1, load2))
    delta = theta1 - theta2
    singular = np.abs(np.sin(delta)) < SINGULAR_SIN_DELTA
    s1, s2 = load1 - offsets[0], load2 - offsets[1]
    saturated = (np.abs(s1) > capacity[0]) | (np.abs(s2) > capacity[1])
    extrapolated = (delta < delta_range[0] - DELTA_RANGE_SLACK) | (delta > delta_range[1] + DELTA_RANGE_SLACK)

    fx, fy = solve_sensing(model.sensing_matrix(theta1, theta2), s1, s2, invalid | singular)
    singular = singular | (np.isnan(fx) & ~invalid)  # a degenerate fitted map cannot be inverted either

    status = np.full(fx.shape, OK, dtype=np.int8)
    status[extrapolated] = EXTRAPOLATED
    status[saturated] = SATURATED
    status[singular] = SINGULAR
    status[invalid] = INVALID
    return fx, fy, status


def status_counts(status: np.ndarray) -> dict[str, int]:
    """How many readings have each status, by name."""
    counts = np.bincount(np.ravel(status).astype(np.intp), minlength=len(STATUS_NAMES))
    return {name: int(n) for name, n in zip(STATUS_NAMES, counts)}
