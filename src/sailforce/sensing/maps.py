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
from typing import Protocol

import numpy as np

from .._validate import as_float_arrays
from ..errors import CompensationError
from ..kernel import Entries, torque_entries
from ..kinematics import Links, jacobian
from .polynomial import PolynomialFit


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
    least-squares fit over every angle, not peak picking: with
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
        """M's entries: C(delta) times J^T, with C = sum_k c_k T_k(x) summed term by term.

        Term by term, not as one BLAS product: a product's summation order
        depends on how many rows it is given, and a stream cut into other
        chunks would then differ from its file in the last digit.
        """
        x = _chebyshev_argument(np.asarray(delta, dtype=float), self.delta_range)
        basis = np.polynomial.chebyshev.chebvander(x, self.order).reshape(x.shape + (self.order + 1,))  # (..., K)
        coefficients = self.coefficients.reshape(self.order + 1, 4)
        c = basis[..., 0, None] * coefficients[0]  # (..., 4): C00 C01 C10 C11
        for k in range(1, self.order + 1):
            c = c + basis[..., k, None] * coefficients[k]
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
