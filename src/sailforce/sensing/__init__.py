"""The sensing maps: how a hand force becomes the two load-cell signals, ``s = M(theta1, theta2) F``.

- :class:`TorqueScale`: ``M = diag(1/k) J^T``, the uncompensated map (seed Eq. 7 and its pre-scaling);
- :class:`AmplitudePhaseCompensator`: the seed's amplitude and phase per cell (Table 4 and its regressors);
- :class:`MatrixCompensator`: ``M = C(delta) J^T``, a Chebyshev mix of both torques;
- :class:`PolynomialFit` and :func:`select_order`: the seed's polynomial regressors in delta.
"""

from .maps import (
    AmplitudePhaseCompensator,
    CompensationError,
    MatrixCompensator,
    SensingModel,
    TorqueScale,
    amplitude_phase,
    rotation,
    rows_from_amplitude_phase,
    sinusoid_rows,
    torque_rows,
)
from .polynomial import PolynomialFit, RegressorError, adjusted_r_squared, fit_polynomial, r_squared, select_order

__all__ = [
    "AmplitudePhaseCompensator",
    "CompensationError",
    "MatrixCompensator",
    "PolynomialFit",
    "RegressorError",
    "SensingModel",
    "TorqueScale",
    "adjusted_r_squared",
    "amplitude_phase",
    "fit_polynomial",
    "r_squared",
    "rotation",
    "rows_from_amplitude_phase",
    "select_order",
    "sinusoid_rows",
    "torque_rows",
]
