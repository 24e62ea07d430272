"""The dynamic term identified from a free-motion recording (nobody holding the handle).

With ``F = 0`` the readings are ``G Y beta`` alone (:mod:`sailforce.estimate.dynamic`,
``docs/dynamics.md``): a linear least-squares problem for the base parameters ``beta``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..estimate.dynamic import DynamicTerm, reading_gain
from ..kernel import solve_2x2, torque_entries
from ..motion.differentiate import Differentiator, MotionDataError, check_period, derivatives, sampling_period
from ..motion.dynamics import PARAMETERS, base_parameters, shear_regressor

#: Largest condition number of the (column-scaled) identification problem: beyond it some base parameter
#: is barely excited, and its estimate is noise.  Measured: a session of 8 reaches in 8 directions gives ~30.
MAX_CONDITION = 1e3

#: Contiguous blocks of the recording left out in turn for the cross-validated residual.
CV_FOLDS = 5

@dataclass(frozen=True)
class DynamicFit:
    """What :func:`fit_dynamic_term` reports."""

    term: DynamicTerm
    rmse_N: float  #: RMS force the residual readings stand for
    cv_rmse_N: float  #: the same, each block of the recording predicted by a fit to the others
    condition: float  #: of the column-scaled problem
    samples: int  #: samples used (with a known motion)
    base_names: tuple[str, ...] = field(default=())


def fit_dynamic_term(cal, t, theta1, theta2, load1, load2, *, differentiator: Differentiator = Differentiator(),
                     max_condition: float = MAX_CONDITION) -> DynamicFit:  # fmt: skip
    """Identify the base parameters from a free-motion recording (nobody holding the handle).

    ``cal`` is the static :class:`sailforce.calibration.file.Calibration` (its map and
    offsets); ``t`` [s], angles [rad], raw loads.  Rates and accelerations
    come from ``differentiator`` (zero-phase).  Refuses too little
    excitation (condition above ``max_condition``).
    """
    arm = cal.arm
    q = np.column_stack([theta1, theta2]).astype(float)
    check_period(differentiator, sampling_period(np.asarray(t, float)))
    qd, qdd = derivatives(t, q, differentiator)
    loads = np.column_stack([load1, load2]).astype(float) - np.asarray(cal.offsets)
    known = np.all(np.isfinite(qd) & np.isfinite(qdd) & np.isfinite(loads) & np.isfinite(q), axis=1)
    if known.sum() < 10 * len(PARAMETERS):
        raise MotionDataError(f"only {int(known.sum())} samples with a known motion; record at least a few seconds "
                              "of the motors moving the arm through its workspace")  # fmt: skip
    q, qd, qdd, loads = q[known], qd[known], qdd[known], loads[known]
    base = base_parameters(arm)
    Y = shear_regressor(arm, q[:, 0], q[:, 1], qd[:, 0], qd[:, 1], qdd[:, 0], qdd[:, 1])[..., list(base.columns)]
    G = reading_gain(cal.model, arm, q[:, 0], q[:, 1])
    A = G @ Y  # (n, 2, p)
    rows, target = A.reshape(-1, A.shape[-1]), loads.reshape(-1)
    scale = np.linalg.norm(rows, axis=0)
    scale[scale == 0] = 1.0
    singular = np.linalg.svd(rows / scale, compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
    if condition > max_condition:
        raise MotionDataError(
            f"too little excitation to identify the dynamics (condition number {condition:.3g} > {max_condition:g}): "
            "record the motors moving the arm quickly through its whole workspace, in every direction, for a minute"
        )
    beta = np.linalg.lstsq(rows / scale, target, rcond=None)[0] / scale
    rmse = _force_rmse(cal, q, loads - A @ beta)
    n = q.shape[0]
    cv = []
    for fold in range(CV_FOLDS):
        test = np.zeros(n, dtype=bool)
        test[fold * n // CV_FOLDS : (fold + 1) * n // CV_FOLDS] = True
        train_rows = A[~test].reshape(-1, A.shape[-1])
        b = np.linalg.lstsq(train_rows / scale, loads[~test].reshape(-1), rcond=None)[0] / scale
        cv.append(_force_rmse(cal, q[test], loads[test] - A[test] @ b) ** 2)
    term = DynamicTerm(base.columns, tuple(float(v) for v in beta), differentiator, base.names)
    return DynamicFit(term, rmse, float(np.sqrt(np.mean(cv))), condition, n, base.names)


def _force_rmse(cal, q: np.ndarray, residual: np.ndarray) -> float:
    """RMS of the force ``M^-1 residual`` [N]: what a reading residual does to the estimate."""
    s1, c1, s2, c2 = np.sin(q[:, 0]), np.cos(q[:, 0]), np.sin(q[:, 1]), np.cos(q[:, 1])
    m = cal.model.sensing_entries(q[:, 0] - q[:, 1], torque_entries(cal.arm.l2, cal.arm.l3, s1, c1, s2, c2))
    fx, fy = solve_2x2(m, residual[:, 0], residual[:, 1], np.zeros(q.shape[0], dtype=bool))
    return float(np.sqrt(np.nanmean(fx**2 + fy**2)))




def prior_term(robot, differentiator: Differentiator = Differentiator()) -> DynamicTerm:
    """The dynamic term the robot file predicts (sections, densities, cells, handle, tilt), unidentified."""
    from ..motion.dynamics import inertial_parameters, parameter_vector

    base = base_parameters(robot.arm)
    values = base.of(parameter_vector(robot.arm, inertial_parameters(robot), robot.plane.gravity))
    return DynamicTerm(base.columns, tuple(float(v) for v in values), differentiator, base.names)
