"""The dynamic term of a calibration: identified from a free-motion recording, subtracted while the arm moves.

Readings model, for a calibration's sensing map ``M`` (``s = M F`` at rest)::

    s - offsets = M F + G V_dyn,     G = M (J^T)^-1 diag(l1, l2)

``V_dyn = Y(q, qd, qdd) beta`` are the cells' inertial and gravity shears
(:mod:`sailforce.motion.dynamics`, base parameters ``beta``) and ``G`` turns a
shear into readings the way the static map turns the shears ``T_i / l_i``
of a force into readings (exact for pin joints).  So the estimate while
moving is ``F = M^-1 (s - offsets) - (J^T)^-1 diag(l) V_dyn``.

With nobody holding the handle (``F = 0``), the readings are ``G Y beta``
alone: a linear least-squares problem for ``beta`` (:func:`fit_dynamic_term`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kernel import solve_2x2, torque_entries
from ..motion.differentiate import Differentiator, MotionDataError, RatePlan, RateTracker, check_period, derivatives, sampling_period
from ..motion.dynamics import PARAMETERS, ShearModel, base_parameters, shear_regressor

#: Largest condition number of the (column-scaled) identification problem: beyond it some base parameter
#: is barely excited, and its estimate is noise.  Measured: a session of 8 reaches in 8 directions gives ~30.
MAX_CONDITION = 1e3

#: Contiguous blocks of the recording left out in turn for the cross-validated residual.
CV_FOLDS = 5


@dataclass(frozen=True)
class DynamicTerm:
    """Identified base parameters (``values`` in :data:`sailforce.motion.dynamics.PARAMETERS` ``columns``) and the differentiator."""

    columns: tuple[int, ...]
    values: tuple[float, ...]
    differentiator: Differentiator = Differentiator()
    combinations: tuple[str, ...] = ()  #: what each value stands for, e.g. ``l4.hx + 1.5 l3.hx`` (for people)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(PARAMETERS[c] for c in self.columns)

    def parameters(self) -> np.ndarray:
        """A full parameter vector (20,) equivalent to the base parameters for every motion."""
        pi = np.zeros(len(PARAMETERS))
        pi[list(self.columns)] = self.values
        return pi

    def shear_model(self, arm) -> ShearModel:
        """The closed-form shears of these base parameters on ``arm``."""
        return ShearModel.from_parameters(arm, self.parameters())


def reading_gain(model, arm, theta1, theta2) -> np.ndarray:
    """``G = M (J^T)^-1 diag(l1, l2)`` ``(n, 2, 2)``: readings per newton of shear in each cell."""
    s1, c1, s2, c2 = np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)
    jt = torque_entries(arm.l2, arm.l3, s1, c1, s2, c2)
    m = model.sensing_entries(theta1 - theta2, jt)
    M = np.stack([np.stack(m[:2], -1), np.stack(m[2:], -1)], -2)
    JT = np.stack([np.stack(jt[:2], -1), np.stack(jt[2:], -1)], -2)
    return np.linalg.solve(JT.swapaxes(-1, -2), M.swapaxes(-1, -2)).swapaxes(-1, -2) * np.array([arm.l1, arm.l2])


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


def motion_states(term: DynamicTerm, t, q, *, dt: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Joint rates and accelerations ``(n, 2)`` of angles ``q`` ``(n, 2)`` at times ``t``, as ``sail estimate`` derives them.

    Zero-phase, with the period ``dt`` given or probed from the first
    steps (:class:`sailforce.motion.differentiate.RateTracker`); NaN where the
    motion is unknown (start, end, gaps, invalid samples): nothing raises.
    """
    tracker = RateTracker(term.differentiator, dt)
    parts = [tracker.feed(t, q), tracker.finish()]
    return np.concatenate([parts[0][0], parts[1][0]]), np.concatenate([parts[0][1], parts[1][1]])


def estimate_moving(cal, term: DynamicTerm, t, theta1, theta2, load1, load2, *, rates=None, dt: float | None = None):
    """Offline force estimate with the dynamic term: ``(fx, fy, status, inertial)``.

    ``rates`` ``(omega, alpha)``, each ``(n, 2)`` [rad/s, rad/s^2], are
    used when measured; otherwise they are derived from ``t`` and the
    angles, block by block (:class:`~sailforce.motion.differentiate.RatePlan`: the numbers of
    :func:`motion_states`).  ``inertial`` ``(n, 2)`` is the
    subtracted dynamic load in reading units; samples whose motion is
    unknown (start, end, around gaps) get NaN there and the status
    :data:`sailforce.calibration.estimator.MOTION_UNKNOWN` unless a static status
    outranks it.
    """
    from .estimator import estimate_moving as run
    from .estimator import estimate_moving_blocks

    q = np.column_stack([np.asarray(theta1, dtype=float), np.asarray(theta2, dtype=float)])  # one copy
    shear_model = term.shear_model(cal.arm)
    if rates is not None:
        qd, qdd = rates
        return run(cal.model, cal.offsets, cal.capacity, cal.delta_range, shear_model, q[:, 0], q[:, 1],
                   qd[:, 0], qd[:, 1], qdd[:, 0], qdd[:, 1], load1, load2)  # fmt: skip
    plan = RatePlan.of(t, q, term.differentiator, dt)  # the rates of each block computed where it is estimated

    def motion(start: int, stop: int):
        rate, accel = plan.block(start, stop)
        return rate[:, 0], rate[:, 1], accel[:, 0], accel[:, 1]

    return estimate_moving_blocks(cal.model, cal.offsets, cal.capacity, cal.delta_range, shear_model, q[:, 0], q[:, 1],
                                  load1, load2, motion)  # fmt: skip


def prior_term(robot, differentiator: Differentiator = Differentiator()) -> DynamicTerm:
    """The dynamic term the robot file predicts (sections, densities, cells, handle, tilt), unidentified."""
    from ..motion.dynamics import inertial_parameters, parameter_vector

    base = base_parameters(robot.arm)
    values = base.of(parameter_vector(robot.arm, inertial_parameters(robot), robot.plane.gravity))
    return DynamicTerm(base.columns, tuple(float(v) for v in values), differentiator, base.names)
