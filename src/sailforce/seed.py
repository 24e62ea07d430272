"""The seed paper's formulas *as printed*, kept only to compare against.

Nothing in sailforce computes with these.  They exist so that tests and the
report can show where the paper goes wrong (docs/errata.md) and so that nobody
"fixes" the correct code back to the paper.
"""

from __future__ import annotations

import numpy as np

from ._validate import as_float_arrays
from .kinematics import Links


def printed_inverse_jt(arm: Links, theta1, theta2) -> np.ndarray:
    """Seed Eq. 10 as printed, shape ``(..., 2, 2)``.  It is wrong: it is the
    transpose of the true (J^T)^-1, so ``printed_inverse_jt @ J^T != I``.
    """
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    l2, l3 = arm.l2, arm.l3
    scale = -1.0 / (l2 * l3 * np.sin(theta1 - theta2))
    row0 = np.stack([l2 * np.cos(theta2), l2 * np.sin(theta2)], axis=-1)
    row1 = np.stack([-l3 * np.cos(theta1), -l3 * np.sin(theta1)], axis=-1)
    return scale[..., None, None] * np.stack([row0, row1], axis=-2)


def printed_end_effector_force(arm: Links, theta1, theta2, t1, t2) -> tuple[np.ndarray, np.ndarray]:
    """Seed Eq. 11 as printed: the printed Eq. 10 applied to (T1, T2)."""
    t1, t2 = as_float_arrays(t1=t1, t2=t2)
    m = printed_inverse_jt(arm, theta1, theta2)
    return m[..., 0, 0] * t1 + m[..., 0, 1] * t2, m[..., 1, 0] * t1 + m[..., 1, 1] * t2
