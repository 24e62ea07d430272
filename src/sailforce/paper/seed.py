"""The seed paper's formulas *as printed*, kept only to compare against, and its published numbers.

Nothing in sailforce computes with these.  They exist so that tests and the
report can show where the paper goes wrong (docs/errata.md) and so that nobody
"fixes" the correct code back to the paper.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import numpy as np

from .._validate import as_float_arrays
from ..kinematics import Links


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


#: The seed's published regressors (Section 3, after Table 4), highest power first.
SEED_REGRESSORS = {
    "amplitude_1": (6.836e-06, -0.002404, 0.325, -19.43, 1145.0),
    "phase_1_deg": (1.33e-07, -4.438e-05, 0.004638, -0.1106, 3.479),
    "amplitude_2": (1.262e-05, -0.003925, 0.4893, -26.68, 1040.0),
    "phase_2_deg": (0.0009928, -0.4999, 6.749),
}
#: The seed's validation RMSEs (Section 3), torque units, its curves pre-scaled by 740 and 528.
SEED_RMSE = {"before": {"t1": 0.436, "t2": 0.696, "mean": 0.566}, "after": {"t1": 0.016, "t2": 0.09, "mean": 0.053}}
SEED_PRESCALE = (740.0, 528.0)


def seed_table4() -> np.ndarray:
    """The seed's Table 4, shipped as ``sailforce/data/seed_table4.csv``: (8, 5), :data:`TABLE4_COLUMNS`."""
    from ..io.files import read_numeric_csv
    from .study import TABLE4_COLUMNS

    path = files("sailforce") / "data" / "seed_table4.csv"
    names, table = read_numeric_csv(Path(str(path)))
    assert tuple(names) == TABLE4_COLUMNS, names
    return table
