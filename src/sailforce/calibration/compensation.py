"""Compensators: the map from end-effector force to load-cell signals, and its inversion.

Every sensing model here is linear in the force,

    s = M(theta1, theta2) F,        s = (load1, load2),  F = (Fx, Fy),

with the 2x2 *sensing matrix* M whose row i is the load cell i's response to
a unit force.  Estimating the force is solving this 2x2 system
(:func:`estimate_force`).  Three models of M are offered:

- :class:`TorqueScale`: the uncompensated estimator, s_i = T_i / k_i with
  T = J^T F (seed Eq. 7) and one constant k_i per cell (the seed's
  "pre-scaling" by 740 and 528).
- :class:`AmplitudePhaseCompensator`: the seed's compensator (Table 4 and
  its regressors).  Row i of J^T is rescaled by 1/A_i(delta) and rotated by
  -P_i(delta).
- :class:`MatrixCompensator`: the whole map as M = C(delta) J^T, a smooth
  2x2 mix of both predicted torques, the extension "beyond the seed".

Amplitude and phase (sign convention)
-------------------------------------
For a force of magnitude F at angle phi, a row r gives a sinusoid
s(phi) = F |r| cos(phi - angle(r)).  Write j_i for row i of J^T, so that the
predicted torque is T_i(phi) = F |j_i| cos(phi - angle(j_i)).  The amplitude
A_i and phase P_i of load cell i are defined by

    s_i(phi) = T_i(phi + P_i) / A_i,     i.e.   A_i s_i(phi - P_i) = T_i(phi),

so A_i = |j_i| / |r_i| (torque per signal unit) and P_i = angle(j_i) -
angle(r_i): a positive P_i means the load-cell curve reaches its peak P_i
*earlier* in phi than the predicted torque.  Equivalently r_i = R(-P_i) j_i /
A_i, which is how the compensator rebuilds the sensing matrix.  The seed
does not state its sign convention; the report compares magnitudes and
trends with that caveat.

Delta-only dependence (docs/errata.md, Physics): with locked motors and no
gravity, M(theta1, theta2) = M0(delta) R(-theta2).  Both compensators are
functions of delta alone in that frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol, overload

import numpy as np

from .._validate import as_float_arrays
from ..errors import SailError
from ..kernel import Entries, torque_entries
from ..kinematics import SINGULAR_SIN_DELTA, Links, jacobian
from ..statics import raise_singular_pose
from .regressors import PolynomialFit


class CompensationError(SailError):
    """Data that cannot determine a compensator."""


class SensingModel(Protocol):
    """Anything that gives the sensing matrix M (``(..., 2, 2)``) at a pose [rad]."""

    def sensing_matrix(self, theta1, theta2) -> np.ndarray: ...

    def sensing_entries(self, delta: np.ndarray, jt: Entries) -> Entries: ...


def rotation(angle) -> np.ndarray:
    """Counter-clockwise rotation matrices R(angle), shape ``(..., 2, 2)``."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)


def torque_rows(arm: Links, theta1, theta2) -> np.ndarray:
    """J^T, shape ``(..., 2, 2)``: row i maps F to the predicted torque T_i (seed Eqs. 3 and 7)."""
    return np.swapaxes(jacobian(arm, theta1, theta2), -1, -2)


def _matrix_from(model, theta1, theta2) -> np.ndarray:
    """``(..., 2, 2)`` sensing matrices from a model's :meth:`sensing_entries`."""
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    jt = torque_entries(model.arm.l2, model.arm.l3, np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2))
    m00, m01, m10, m11 = model.sensing_entries(theta1 - theta2, jt)
    return np.stack([np.stack([m00, m01], axis=-1), np.stack([m10, m11], axis=-1)], axis=-2)


def sinusoid_rows(phi, force: float, signal) -> np.ndarray:
    """Least-squares sensing rows r from curves s(phi) = F (r_x cos phi + r_y sin phi).

    ``phi`` [rad] has shape ``(P,)``; ``signal`` has shape ``(..., P)``, one
    curve per leading index; returns ``(..., 2)``, signal per newton.  A
    least-squares fit over every angle, not peak picking (issue 4): with
    noise-free linear data it is exact, and with noise it uses all samples.
    """
    phi = np.asarray(phi, dtype=float)
    design = np.stack([np.cos(phi), np.sin(phi)], axis=-1) * force  # (P, 2)
    if phi.size < 2 or np.linalg.matrix_rank(design) < 2:
        raise CompensationError(f"force angles {np.degrees(phi).round(3).tolist()} deg cannot separate Fx from Fy")
    return np.asarray(signal, dtype=float) @ np.linalg.pinv(design).T


def amplitude_phase(measured_rows, predicted_rows) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude A = |j| / |r| and phase P = angle(j) - angle(r) [rad, in (-pi, pi]].

    ``measured_rows`` r and ``predicted_rows`` j have shape ``(..., 2)``; see
    the module docstring for the convention.
    """
    r, j = np.asarray(measured_rows, dtype=float), np.asarray(predicted_rows, dtype=float)
    amplitude = np.hypot(j[..., 0], j[..., 1]) / np.hypot(r[..., 0], r[..., 1])
    phase = np.arctan2(j[..., 1], j[..., 0]) - np.arctan2(r[..., 1], r[..., 0])
    return amplitude, -np.remainder(-phase + np.pi, 2.0 * np.pi) + np.pi


def rows_from_amplitude_phase(predicted_rows, amplitude, phase) -> np.ndarray:
    """The sensing rows r = R(-P) j / A; inverse of :func:`amplitude_phase`, shape ``(..., 2)``."""
    j = np.asarray(predicted_rows, dtype=float)
    return (rotation(-np.asarray(phase)) @ j[..., None])[..., 0] / np.asarray(amplitude)[..., None]


@dataclass(frozen=True)
class TorqueScale:
    """The uncompensated model s_i = T_i / k_i: the seed's pre-scaled curves (Fig. 5)."""

    arm: Links
    scale: tuple[float, float]  #: k_i, torque [N m] per signal unit

    def sensing_entries(self, delta, jt: Entries) -> Entries:
        """M's entries from delta [rad] and J^T's entries: row i of J^T over k_i."""
        k1, k2 = self.scale
        return (jt[0] / k1, jt[1] / k1, jt[2] / k2, jt[3] / k2)

    def matrix_series(self) -> tuple[np.ndarray, tuple[float, float]]:
        """This model as a :class:`MatrixCompensator`'s series: the constant C = diag(1/k1, 1/k2) (order 0)."""
        return np.diag([1.0 / self.scale[0], 1.0 / self.scale[1]])[None], (-1.0, 1.0)

    def sensing_matrix(self, theta1, theta2) -> np.ndarray:
        return _matrix_from(self, theta1, theta2)


@dataclass(frozen=True)
class AmplitudePhaseCompensator:
    """The seed's compensator: per load cell, A_i(delta) and P_i(delta) polynomials.

    The polynomials take delta in degrees and return the phase in degrees,
    exactly as the seed prints them and as Table 4 lists them; the methods
    take radians and convert at this boundary.
    """

    arm: Links
    amplitude: tuple[PolynomialFit, PolynomialFit]
    phase_deg: tuple[PolynomialFit, PolynomialFit]
    delta_range: tuple[float, float]  #: delta [rad] covered by the fit; outside it the polynomials extrapolate

    def parameters(self, delta) -> tuple[np.ndarray, np.ndarray]:
        """A (``(..., 2)``, torque per signal unit) and P (``(..., 2)`` [rad]) at ``delta`` [rad]."""
        delta_deg = np.degrees(np.asarray(delta, dtype=float))
        amplitude = np.stack([fit(delta_deg) for fit in self.amplitude], axis=-1)
        phase = np.radians(np.stack([fit(delta_deg) for fit in self.phase_deg], axis=-1))
        return amplitude, phase

    def sensing_entries(self, delta, jt: Entries) -> Entries:
        """M's entries: row i = R(-P_i) j_i / A_i, j_i row i of J^T (see the module docstring)."""
        delta_deg = np.degrees(delta)
        rows = []
        for i in range(2):
            a = self.amplitude[i](delta_deg)
            p = np.radians(self.phase_deg[i](delta_deg))
            cos_p, sin_p = np.cos(p), np.sin(p)
            jx, jy = jt[2 * i], jt[2 * i + 1]
            rows += [(cos_p * jx + sin_p * jy) / a, (cos_p * jy - sin_p * jx) / a]
        return tuple(rows)

    def sensing_matrix(self, theta1, theta2) -> np.ndarray:
        return _matrix_from(self, theta1, theta2)


@dataclass(frozen=True)
class MatrixCompensator:
    """The whole sensing map as M = C(delta) J^T, with C(delta) a Chebyshev series over the calibrated range.

    Each signal is a delta-dependent mix of the two predicted torques,
    s = C(delta) T with T = J^T F (seed Eq. 7).  Any M0(delta) R(-theta2)
    can be written so while sin(delta) != 0, because J^T = J0^T(delta)
    R(-theta2) too.  For a statically determinate linkage (pin joints) C is
    the constant diag(1/k1, 1/k2); moment-carrying joints add the delta
    dependence and the cross terms.  Fitting C rather than M0 makes the
    determinate case exact at order 0 and measured 2-60x more accurate at
    equal order on spring joints (the bonded frame is limited by the 15 deg
    sampling instead).

    ``coefficients[k]`` (shape ``(order + 1, 2, 2)``) multiplies T_k(x), with
    x = delta mapped linearly from ``delta_range`` [rad] onto [-1, 1]; the
    series is evaluated beyond the range too (extrapolation).
    """

    arm: Links
    coefficients: np.ndarray
    delta_range: tuple[float, float]
    cv_rmse: tuple[float, ...] = field(default=(), compare=False)  #: cross-validated force RMSE [N] per order tried

    @property
    def order(self) -> int:
        return self.coefficients.shape[0] - 1

    def correction(self, delta) -> np.ndarray:
        """C(delta), shape ``(..., 2, 2)``: signal per unit predicted torque."""
        x = _chebyshev_argument(np.asarray(delta, dtype=float), self.delta_range)
        return np.moveaxis(np.polynomial.chebyshev.chebval(x, self.coefficients, tensor=True), (0, 1), (-2, -1))

    def sensing_entries(self, delta, jt: Entries) -> Entries:
        """M's entries: C(delta) times J^T, with C from the Chebyshev basis times the coefficients (one BLAS product)."""
        x = _chebyshev_argument(np.asarray(delta, dtype=float), self.delta_range)
        basis = np.polynomial.chebyshev.chebvander(x, self.order).reshape(x.shape + (self.order + 1,))  # (..., K)
        c = basis @ self.coefficients.reshape(self.order + 1, 4)  # (..., 4): C00 C01 C10 C11
        c00, c01, c10, c11 = (c[..., k] for k in range(4))
        return (c00 * jt[0] + c01 * jt[2], c00 * jt[1] + c01 * jt[3], c10 * jt[0] + c11 * jt[2], c10 * jt[1] + c11 * jt[3])

    def matrix_series(self) -> tuple[np.ndarray, tuple[float, float]]:
        """``(coefficients, delta_range)``: what the compiled kernel evaluates (:mod:`sailforce.kernel`)."""
        return np.ascontiguousarray(self.coefficients, dtype=float), self.delta_range

    def sensing_matrix(self, theta1, theta2) -> np.ndarray:
        return _matrix_from(self, theta1, theta2)


def _chebyshev_argument(delta: np.ndarray, delta_range: tuple[float, float]) -> np.ndarray:
    low, high = delta_range
    return (2.0 * delta - (low + high)) / (high - low)


@overload
def estimate_force(model: SensingModel, theta1, theta2, load1, load2, *, on_singular: Literal["raise"] = ...,
                   min_sin_delta: float = ...) -> tuple[np.ndarray, np.ndarray]: ...  # fmt: skip
@overload
def estimate_force(model: SensingModel, theta1, theta2, load1, load2, *, on_singular: Literal["mask"],
                   min_sin_delta: float = ...) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...  # fmt: skip
def estimate_force(
    model: SensingModel,
    theta1,
    theta2,
    load1,
    load2,
    *,
    on_singular: Literal["raise", "mask"] = "raise",
    min_sin_delta: float = SINGULAR_SIN_DELTA,
):
    """End-effector force (fx, fy) [N] from the two load-cell signals: solve M F = s.

    Angles in radians; loads in the model's signal unit (offset-free).  The
    force kernel's estimate (:mod:`sailforce.calibration.estimator`) without offsets,
    capacity or range.  Poses with |sin(theta1 - theta2)| < ``min_sin_delta``
    are singular: raise :class:`SingularPoseError` (default, result
    ``(fx, fy)``), or with ``on_singular="mask"`` return ``(fx, fy, singular)``
    with NaN there.

    >>> from sailforce import Arm
    >>> model = TorqueScale(Arm(), (1.0, 1.0))          # signals are the torques themselves
    >>> fx, fy = estimate_force(model, np.pi / 2, 0.0, 0.0, 3.0)
    >>> round(float(fx), 12), round(float(fy), 12)
    (0.0, 10.0)
    """
    from .estimator import SINGULAR, estimate

    if on_singular not in ("raise", "mask"):
        raise ValueError(f"on_singular = {on_singular!r}: expected 'raise' or 'mask'")
    theta1, theta2, load1, load2 = as_float_arrays(theta1=theta1, theta2=theta2, load1=load1, load2=load2)
    fx, fy, status = estimate(model, (0.0, 0.0), (np.inf, np.inf), (-np.inf, np.inf), theta1, theta2, load1, load2,
                              min_sin_delta=min_sin_delta)  # fmt: skip
    singular = status == SINGULAR
    if on_singular == "raise":
        if singular.any():
            raise_singular_pose(theta1, theta2, singular, min_sin_delta)
        return fx[()], fy[()]
    return fx[()], fy[()], singular[()]


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
