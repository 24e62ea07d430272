"""Calibration from measurements: offsets and the sensing map over delta, fitted, validated, saved.

A lab hangs known weights at known angles and records raw load-cell readings
and joint angles.  The model of a reading is

    load = offset + M(theta1, theta2) F,

linear in the force; docs/errata.md (Physics) shows M depends on delta only, up
to a rotation by theta2.  Two forms of M are fitted (``--model``):

- ``seed``: the paper's amplitude and phase polynomials per load cell
  (:class:`~sailforce.sensing.maps.AmplitudePhaseCompensator`), fitted from
  per-pose sinusoid rows; needs several force directions at each pose;
- ``matrix``: C(delta) J^T as Chebyshev series
  (:class:`~sailforce.sensing.maps.MatrixCompensator`), fitted on all samples;
- ``physics``: the robot's frame model with fitted gains, offsets and joint
  stiffnesses (:mod:`sailforce.fit.physics`), stored as a matrix model
  over the whole map range; needs the robot;
- ``auto``: whichever cross-validates best.

Offsets come from the matrix fit (jointly with the map) for seed and matrix,
from the physics fit for physics.
Cross-validation always scores the force-vector RMSE [N] on held-out deltas.
The calibration file format lives in :mod:`sailforce.calibration.file`; the per-row
estimator with statuses in :mod:`sailforce.estimate.estimator`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import kernel
from .._validate import as_float_arrays
from ..arm import Arm
from ..estimate.estimator import estimate_force
from ..robot import Robot
from ..sensing.maps import AmplitudePhaseCompensator, CompensationError, MatrixCompensator, amplitude_phase, torque_rows
from ..sensing.polynomial import fit_polynomial
from .matrix import CV_FOLDS, CV_TIE_ATOL_N, CV_TIE_RTOL, delta_groups, fit_matrix_with_offsets

MODEL_KINDS = ("seed", "matrix", "physics")

#: A calibration must span at least this range of delta [rad]: over less, the
#: delta dependence cannot be separated from noise (a sixth of the seed's 105 deg).
MIN_DELTA_SPAN = np.radians(15.0)

#: Highest polynomial order tried for the seed model's amplitude and phase columns.
MAX_SEED_ORDER = 5


@dataclass(frozen=True)
class FitReport:
    """How well a calibration fits: in newtons of end-effector force."""

    kind: str
    fit_rmse_N: float  #: force-vector RMSE on the calibration samples
    cv_rmse_N: float  #: cross-validated over delta
    cv_rmse_by_kind: dict[str, float]
    n_samples: int
    n_deltas: int
    delta_range: tuple[float, float]  #: [rad] of the data
    physics: Any = None  #: the :class:`~sailforce.fit.physics.PhysicsFit`, when one was made

    @property
    def model_delta_range(self) -> tuple[float, float]:
        """The delta range [rad] the chosen model is valid over: the physics map's, or the data's."""
        if self.kind == "physics" and self.physics is not None:
            return self.physics.compensator.delta_range
        return self.delta_range


@dataclass(frozen=True)
class CalibrationFit:
    """What :func:`fit_calibration` returns: the sensing map, the offsets and the report.

    It unpacks as ``model, offsets, report``, the tuple the function used to return.
    """

    model: MatrixCompensator | AmplitudePhaseCompensator
    offsets: np.ndarray  #: (2,) raw
    report: FitReport

    def __iter__(self) -> Iterator:
        return iter((self.model, self.offsets, self.report))


def fit_calibration(arm: Arm, theta1, theta2, fx, fy, load1, load2, *, kind: str = "auto", robot: Robot | None = None,
                    free: tuple[str, ...] | None = None, transduction: str | None = None, progress=None) -> CalibrationFit:  # fmt: skip
    """Fit offsets and a sensing map of ``kind`` (seed | matrix | physics | auto) to samples.

    Angles [rad], forces [N], loads raw.  Returns a :class:`CalibrationFit` (``model, offsets, report``).
    ``physics`` (and ``auto`` with it) needs ``robot``; ``free`` and
    ``transduction`` override :mod:`sailforce.fit.physics`'s defaults and
    ``progress(done, total)`` follows its starts.
    Raises :class:`CompensationError`, saying what to record, on data that
    cannot determine the map: too few distinct deltas, a delta span below
    :data:`MIN_DELTA_SPAN`, collinear forces, or (seed) poses with one
    force direction.
    """
    if kind not in (*MODEL_KINDS, "auto"):
        raise CompensationError(f"model = {kind!r}: expected seed, matrix, physics or auto")
    if kind == "physics" and robot is None:
        raise CompensationError("the physics model needs the robot: give its robot file")
    theta1, theta2, fx, fy, load1, load2 = (np.ravel(a) for a in as_float_arrays(
        theta1=theta1, theta2=theta2, fx=fx, fy=fy, load1=load1, load2=load2))  # fmt: skip
    delta = theta1 - theta2
    span = float(np.ptp(delta)) if delta.size else 0.0
    if span < MIN_DELTA_SPAN:
        raise CompensationError(
            f"the data span delta = {np.degrees(span):.3g} deg; at least {np.degrees(MIN_DELTA_SPAN):g} deg is "
            "needed to fit the delta dependence: record poses with more varied theta1 - theta2"
        )
    matrix, offsets = fit_matrix_with_offsets(arm, theta1, theta2, fx, fy, load1, load2)
    candidates: dict[str, tuple] = {"matrix": (matrix, min(matrix.cv_rmse), offsets)}
    if kind in ("seed", "auto"):
        try:
            seed = _fit_seed(arm, theta1, theta2, fx, fy, load1 - offsets[0], load2 - offsets[1])
            candidates["seed"] = (*seed, offsets)
        except CompensationError:
            if kind == "seed":
                raise
    physics = None
    if robot is not None and kind in ("physics", "auto"):
        from .physics import DEFAULT_FREE, DEFAULT_TRANSDUCTION, fit_physics

        physics = fit_physics(robot, theta1, theta2, fx, fy, load1, load2, free=free or DEFAULT_FREE,
                              transduction=transduction or DEFAULT_TRANSDUCTION, progress=progress)  # fmt: skip
        candidates["physics"] = (physics.compensator, physics.cv_rmse_N, physics.offsets)
    chosen = kind if kind != "auto" else min(candidates, key=lambda k: candidates[k][1])
    model, cv, offsets = candidates[chosen]
    fx_hat, fy_hat = estimate_force(model, theta1, theta2, load1 - offsets[0], load2 - offsets[1])
    fit_rmse = float(np.sqrt(np.mean((fx_hat - fx) ** 2 + (fy_hat - fy) ** 2)))
    report = FitReport(chosen, fit_rmse, float(cv), {k: float(v[1]) for k, v in candidates.items()},
                       int(theta1.size), int(delta_groups(delta).max() + 1), (float(delta.min()), float(delta.max())),
                       physics)  # fmt: skip
    return CalibrationFit(model, np.asarray(offsets, dtype=float), report)


def _pose_rows(theta1, theta2, fx, fy, load1, load2):
    """Per distinct delta: delta [rad] and both cells' least-squares sensing rows at theta2 = 0, (G,), (G, 2, 2).

    Forces are rotated into link 2's frame, R(-theta2) F, so poses that share
    delta but not theta2 pool into one fit (the delta-only law).
    """
    groups = delta_groups(theta1 - theta2)
    c, s = np.cos(theta2), np.sin(theta2)
    fx_link, fy_link = c * fx + s * fy, -s * fx + c * fy
    deltas, rows = [], []
    for g in range(int(groups.max()) + 1):
        sel = groups == g
        forces = np.column_stack([fx_link[sel], fy_link[sel]])
        if np.linalg.matrix_rank(forces) < 2:
            raise CompensationError(
                f"the seed model needs at least two force directions at each pose; delta = "
                f"{np.degrees(np.mean(theta1[sel] - theta2[sel])):.4g} deg has {'one' if sel.sum() else 'none'}"
            )
        rows.append(np.linalg.lstsq(forces, np.column_stack([load1[sel], load2[sel]]), rcond=None)[0].T)
        deltas.append(np.mean(theta1[sel] - theta2[sel]))
    return np.array(deltas), np.array(rows)


def _fit_seed(arm: Arm, theta1, theta2, fx, fy, load1, load2) -> tuple[AmplitudePhaseCompensator, float]:
    """Amplitude/phase polynomials of delta, one order for all four, chosen by cross-validation."""
    deltas, rows = _pose_rows(theta1, theta2, fx, fy, load1, load2)
    amplitude, phase = amplitude_phase(rows, torque_rows(arm, deltas, 0.0))  # (G, 2) each
    delta_deg = np.degrees(deltas)
    n = delta_deg.size
    highest = min(n - 2, MAX_SEED_ORDER)
    groups = delta_groups(theta1 - theta2)
    folds_of_group = np.arange(n) % min(CV_FOLDS, n)
    delta_range = (float(np.min(theta1 - theta2)), float(np.max(theta1 - theta2)))
    scores = []
    for order in range(highest + 1):
        squared = 0.0
        for fold in range(int(folds_of_group.max()) + 1):
            train = folds_of_group != fold
            if np.count_nonzero(train) < order + 2:
                squared = np.inf
                break
            model = _seed_model(arm, delta_deg[train], amplitude[train], phase[train], order, delta_range)
            test = np.isin(groups, np.flatnonzero(~train))
            fx_hat, fy_hat, _ = estimate_force(model, theta1[test], theta2[test], load1[test], load2[test], on_singular="mask")
            squared += float(np.nansum((fx_hat - fx[test]) ** 2 + (fy_hat - fy[test]) ** 2))
        scores.append(np.sqrt(squared / theta1.size))
    best = int(np.argmax(np.asarray(scores) <= min(scores) * (1.0 + CV_TIE_RTOL) + CV_TIE_ATOL_N))
    return _seed_model(arm, delta_deg, amplitude, phase, best, delta_range), float(min(scores))


def _seed_model(arm, delta_deg, amplitude, phase, order: int, delta_range) -> AmplitudePhaseCompensator:
    unwrapped = np.unwrap(phase, axis=0)
    a = (fit_polynomial(delta_deg, amplitude[:, 0], order, threshold=0.5),
         fit_polynomial(delta_deg, amplitude[:, 1], order, threshold=0.5))
    p = (fit_polynomial(delta_deg, np.degrees(unwrapped[:, 0]), order, threshold=0.5),
         fit_polynomial(delta_deg, np.degrees(unwrapped[:, 1]), order, threshold=0.5))
    return AmplitudePhaseCompensator(arm, a, p, delta_range)


def equivalent_capacity(model, arm: Arm, capacity_N: float, delta_range: tuple[float, float]) -> np.ndarray:
    """Raw reading (offset removed) at which each cell reaches its rated force, ``(2,)``.

    A driven link of a determinate linkage carries the shear T_i / l_i
    (docs/errata.md, Physics), so the cell's rated shear corresponds to the torque
    capacity_N * l_i; the fitted map at mid-range delta converts that torque
    to raw units.  It is an estimate: bending frames share load differently.
    Override it with explicit capacities when the cell's raw full scale is known.
    """
    mid = 0.5 * (delta_range[0] + delta_range[1])
    m = model.sensing_matrix(mid, 0.0)  # raw per N of F
    j = torque_rows(arm, mid, 0.0)  # N m per N of F
    raw_per_torque = np.abs(np.diag(m @ kernel.matrix(kernel.inverse_entries(kernel.entries(j)))))
    return raw_per_torque * capacity_N * np.array([arm.l1, arm.l2])

