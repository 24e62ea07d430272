"""The matrix sensing model fitted to calibration samples, its order chosen by cross-validation over delta.

``s = o + C(delta) J^T F`` is linear in the Chebyshev coefficients ``C`` and
the offsets ``o`` (:class:`sailforce.sensing.MatrixCompensator`): one least-squares
design matrix serves both cells.
"""

from __future__ import annotations

import numpy as np

from .._validate import as_float_arrays
from ..estimate.estimator import estimate_force
from ..kinematics import Links
from ..sensing.maps import CompensationError, MatrixCompensator, _chebyshev_argument, torque_rows

#: Highest Chebyshev order :func:`fit_matrix_compensator` tries by default.
#: Beyond it the series starts fitting mesh or measurement noise rather than
#: the smooth delta dependence of a frame (the study picks 4-6).
MAX_MATRIX_ORDER = 8


#: Cross-validation scores within this fraction of the best count as ties,
#: broken towards the lower order: a 5% gain does not justify a term that
#: extrapolates worse.
CV_TIE_RTOL = 0.05
#: ... and scores below this [N] are all rounding (the pin-joint study scores ~1e-11 N).
CV_TIE_ATOL_N = 1e-9


#: Cross-validation folds: samples are grouped by delta and the groups dealt
#: round-robin in delta order into at most this many folds, so each fold
#: interpolates.  With at most this many distinct deltas it is leave-one-delta-out.
CV_FOLDS = 8

#: Distinct deltas closer than this [rad] are one group (encoder jitter of a held pose).
DELTA_GROUP_TOL = 1e-6


def delta_groups(delta: np.ndarray) -> np.ndarray:
    """Index of each sample's delta among the distinct deltas (ascending), merging those within :data:`DELTA_GROUP_TOL`."""
    order = np.argsort(delta)
    new_group = np.concatenate([[True], np.diff(delta[order]) > DELTA_GROUP_TOL])
    groups = np.empty(delta.size, dtype=int)
    groups[order] = np.cumsum(new_group) - 1
    return groups


def fit_matrix_compensator(arm: Links, theta1, theta2, fx, fy, load1, load2, *, max_order: int | None = None) -> MatrixCompensator:
    """Least-squares :class:`MatrixCompensator` on samples, order chosen by cross-validation.

    Every argument is a 1-D array of samples (angles [rad], forces [N],
    loads in signal units); both load cells are fitted at once, from every
    sample.  Samples are grouped by delta, and each candidate order is
    scored by cross-validation over delta (:data:`CV_FOLDS`): the RMSE of the
    force vector [N] estimated at the held-out deltas.  The lowest order
    whose score ties with the best (:data:`CV_TIE_RTOL`) is refitted on all samples.
    """
    return fit_matrix_with_offsets(arm, theta1, theta2, fx, fy, load1, load2, max_order=max_order, fit_offsets=False)[0]


def fit_matrix_with_offsets(
    arm: Links, theta1, theta2, fx, fy, load1, load2, *, max_order: int | None = None, fit_offsets: bool = True
) -> tuple[MatrixCompensator, np.ndarray]:
    """:func:`fit_matrix_compensator` with a constant offset per cell fitted jointly: load = o + C(delta) J^T F.

    Returns the compensator (for offset-free loads) and the offsets ``(2,)``
    in load units (zeros when ``fit_offsets`` is False).
    """
    theta1, theta2, fx, fy, load1, load2 = (np.ravel(a) for a in as_float_arrays(
        theta1=theta1, theta2=theta2, fx=fx, fy=fy, load1=load1, load2=load2))  # fmt: skip
    delta = theta1 - theta2
    groups = delta_groups(delta)
    n_groups = int(groups.max()) + 1
    if n_groups < 3:
        raise CompensationError(f"the samples cover {n_groups} distinct delta value(s); at least 3 are needed")
    highest = min(n_groups - 2, MAX_MATRIX_ORDER) if max_order is None else int(max_order)
    if highest > n_groups - 2:
        raise CompensationError(f"order {highest} needs at least {highest + 2} distinct delta values, got {n_groups}")
    delta_range = (float(delta.min()), float(delta.max()))
    torque = (torque_rows(arm, theta1, theta2) @ np.stack([fx, fy], axis=-1)[..., None])[..., 0]  # (N, 2), Eq. 7
    if np.linalg.matrix_rank(torque) < 2:
        raise CompensationError("the reference forces are collinear in the link frame: they cannot separate the map's columns")
    loads = np.stack([load1, load2], axis=-1)
    folds = groups % min(CV_FOLDS, n_groups)

    scores = []
    for order in range(highest + 1):
        squared = 0.0
        for fold in range(int(folds.max()) + 1):
            test = folds == fold
            model, offsets = _lstsq_matrix(arm, delta[~test], torque[~test], loads[~test], order, delta_range, fit_offsets)
            fx_hat, fy_hat, _ = estimate_force(model, theta1[test], theta2[test], load1[test] - offsets[0],
                                               load2[test] - offsets[1], on_singular="mask")  # fmt: skip
            squared += float(np.nansum((fx_hat - fx[test]) ** 2 + (fy_hat - fy[test]) ** 2))
        scores.append(np.sqrt(squared / theta1.size))
    best = int(np.argmax(np.asarray(scores) <= min(scores) * (1.0 + CV_TIE_RTOL) + CV_TIE_ATOL_N))
    model, offsets = _lstsq_matrix(arm, delta, torque, loads, best, delta_range, fit_offsets)
    return MatrixCompensator(arm, model.coefficients, delta_range, tuple(scores)), offsets


def fit_matrix_at_order(arm: Links, theta1, theta2, fx, fy, load1, load2, order: int,
                        delta_range: tuple[float, float]) -> tuple[MatrixCompensator, np.ndarray]:  # fmt: skip
    """The least-squares series of one ``order`` over ``delta_range`` [rad], with the offsets: no cross-validation
    (a calibration plan's model, :mod:`sailforce.plan`)."""
    theta1, theta2, fx, fy, load1, load2 = (np.ravel(a) for a in as_float_arrays(
        theta1=theta1, theta2=theta2, fx=fx, fy=fy, load1=load1, load2=load2))  # fmt: skip
    torque = (torque_rows(arm, theta1, theta2) @ np.stack([fx, fy], axis=-1)[..., None])[..., 0]  # (N, 2), Eq. 7
    return _lstsq_matrix(arm, theta1 - theta2, torque, np.stack([load1, load2], axis=-1), order, delta_range, True)


def _lstsq_matrix(arm: Links, delta, torque, loads, order: int, delta_range, fit_offsets: bool):
    # s_i = o_i + sum_k sum_a c[k, i, a] T_k(x) T_a is linear in (c, o): one design matrix serves both cells.
    basis = np.polynomial.chebyshev.chebvander(_chebyshev_argument(delta, delta_range), order)  # (N, K+1)
    design = (basis[:, :, None] * torque[:, None, :]).reshape(delta.size, -1)
    if fit_offsets:
        design = np.column_stack([design, np.ones(delta.size)])
    solution = np.linalg.lstsq(design, loads, rcond=None)[0]  # ((K+1) * 2 [+ 1], 2 cells)
    offsets = solution[-1] if fit_offsets else np.zeros(2)
    coefficients = solution[: 2 * (order + 1)].reshape(order + 1, 2, 2).transpose(0, 2, 1)  # [k, cell i, component a]
    return MatrixCompensator(arm, coefficients, delta_range), offsets
