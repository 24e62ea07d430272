"""The estimator's status codes, one per reading: the same numbers as libsail's ``enum sail_status``.

- ``OK`` (0);
- ``SINGULAR`` (1): |sin(theta1 - theta2)| < :data:`sailforce.SINGULAR_SIN_DELTA`,
  or a fitted map that cannot be inverted; no estimate (NaN);
- ``SATURATED`` (2): a reading, offset removed, is beyond its cell's capacity;
  the estimate is given but must not be trusted;
- ``EXTRAPOLATED`` (3): delta lies outside the calibrated range; the estimate is given;
- ``INVALID`` (4): a field is NaN or infinite (or, in files, missing or not a
  number); no estimate;
- ``MOTION_UNKNOWN`` (5): the joint rates are not known yet, so the inertial
  load cannot be subtracted; no estimate.  Appended after the static codes,
  whose numbers stay as they were.

When several apply, the first in the order INVALID, SINGULAR, SATURATED,
MOTION_UNKNOWN, EXTRAPOLATED wins.
"""

from __future__ import annotations

import numpy as np

OK, SINGULAR, SATURATED, EXTRAPOLATED, INVALID, MOTION_UNKNOWN = range(6)
STATUS_NAMES = ("ok", "singular", "saturated", "extrapolated", "invalid", "motion-unknown")


def count_statuses(status) -> np.ndarray:
    """How many readings have each status code, ``(len(STATUS_NAMES),)`` in the codes' order."""
    return np.bincount(np.ravel(status).astype(np.intp), minlength=len(STATUS_NAMES))
