"""Optimal calibration holds: the predicted force error of a set of holds, and the holds that make it smallest.

**The prediction.**  With the model linearised (:mod:`sailforce.plan.linear`),
holds ``h`` with regressors ``A_h`` (2 x p) and reading noise ``sigma_h``
[counts] give the fitted parameters the covariance (Gauss-Markov)

    Sigma = (sum_h A_h^T A_h / sigma_h^2)^-1,

and a force ``F`` estimated at a pose the error covariance
``B Sigma B^T`` with ``B = M^-1 A(theta, F)``.  The *predicted force error*
at a pose is ``sqrt(trace(B Sigma B^T))`` [N], the RMS length of the error
vector, for a force of :data:`DEFAULT_FORCE_N` in its worst direction.  It
is the calibration's own error: the run-time reading noise comes on top.

**The noise floor, and the error seen at run time.**  An oracle that knew
the map exactly would still read each conversion's noise ``sigma_r``
[counts, both cells, independent]: a force error of
``sigma_r sqrt(trace(M^-1 M^-T))`` [N], the same for every force
(:func:`noise_floor`).  A calibrated arm adds its calibration's error,
independent of that noise, so the error seen at run time is the two in
quadrature (:func:`seen_map`).  Beyond the calibrated deltas the
calibration's error of a physics model grows about fivefold (the stiffnesses
alone carry the map there, whatever holds inside the range are chosen:
docs/guide/calibrate.md), and the seen error stays within a few per cent
of the floor as long as the calibration's is well below it.
The map depends on delta alone: the frame turns rigidly with theta2, and a
direction that turns with it has the same error.

**The criterion: I-optimal.**  The holds minimise the predicted error
variance averaged over the map: every delta of :data:`MAP_DELTA_RANGE_DEG`
and :data:`MAP_DIRECTIONS` force directions, ``trace(Sigma W)`` with
``W = mean B^T B`` (Atkinson, Donev & Tobias, *Optimum Experimental
Designs*, 2007, Sec. 10.6).  A lab asks how well the force is measured over
the workspace, and that is what I-optimality averages.  D-optimality would
shrink the parameters' joint uncertainty, weighting parameters by how well
they are determined rather than by what they cost the force, and
A-optimality depends on the parameters' units.

**The search.**  Greedy forward selection from the candidates (each addition
a rank-2 update of Sigma, Sherman-Morrison-Woodbury, scored for every
candidate at once), then Fedorov exchange passes until no swap of a hold
for a candidate lowers the criterion by :data:`EXCHANGE_RTOL`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .linear import Linearised

#: The deltas the predicted map covers [deg]: the useful workspace, where |sin delta| >= 0.26 (as the physics map).
MAP_DELTA_RANGE_DEG = (15.0, 165.0)
#: Deltas on the map.
MAP_POINTS = 61
#: Force directions at each delta of the map: the worst is reported, the mean enters the criterion.
MAP_DIRECTIONS = 24
#: The force the predicted error is for [N]: the seed's calibration force.
DEFAULT_FORCE_N = 20.0
#: The search's ridge, a fraction of each parameter's information per candidate hold: lets the first holds be scored
#: before the parameters are all determined.  The predicted maps have none.
START_RIDGE = 1e-6
#: An exchange must lower the criterion by this fraction to be taken.
EXCHANGE_RTOL = 1e-9
#: Exchange passes at most.
MAX_EXCHANGE_PASSES = 20
#: The smallest singular value, relative to the largest, of a usable information matrix (scaled to unit diagonal).
IDENTIFIABLE_RCOND = 1e-10


@dataclass(frozen=True)
class Candidates:
    """Holds the rig can make: poses [rad], forces [N], the hung mass [kg] and each one's reading noise [counts]."""

    theta1: np.ndarray
    theta2: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    mass_kg: np.ndarray
    sigma: np.ndarray
    weight: np.ndarray | None = None  #: how many chosen holds each stands for (None: one each)

    def __len__(self) -> int:
        return int(self.theta1.size)

    def take(self, index) -> Candidates:
        index = np.asarray(index, int)
        weight = None if self.weight is None else self.weight[index]
        return Candidates(self.theta1[index], self.theta2[index], self.fx[index], self.fy[index], self.mass_kg[index],
                          self.sigma[index], weight)  # fmt: skip


@dataclass(frozen=True)
class ErrorMap:
    """The predicted force error over delta: worst over directions and RMS over them [N], for ``force_N``."""

    delta: np.ndarray  #: [rad]
    worst_N: np.ndarray
    rms_N: np.ndarray
    force_N: float

    def worst_within(self, low: float, high: float) -> float:
        """The largest worst-direction error over the deltas from low to high [rad]."""
        inside = (self.delta >= low - 1e-12) & (self.delta <= high + 1e-12)
        return float(self.worst_N[inside].max())


def map_deltas() -> np.ndarray:
    """The map's deltas [rad]."""
    return np.radians(np.linspace(*MAP_DELTA_RANGE_DEG, MAP_POINTS))


def noise_floor(model: Linearised, sigma_counts: float) -> np.ndarray:
    """The noise-floor oracle's force error at the map's deltas [N]: one reading noise ``sigma_counts`` [counts] on
    each cell through the exact map, ``sigma sqrt(trace(M^-1 M^-T))`` (the RMS length of ``M^-1 n``, any force)."""
    delta = map_deltas()
    inverse = np.linalg.inv(model.sensing(delta, np.zeros_like(delta)))
    return sigma_counts * np.sqrt(np.einsum("dij,dij->d", inverse, inverse))


def seen_map(calibration: ErrorMap, floor_N: np.ndarray) -> ErrorMap:
    """The force error seen at run time: a calibration's predicted error and the reading noise's floor
    (:func:`noise_floor`), independent, in quadrature.  The floor is the same in every direction, so the worst
    direction stays the calibration's."""
    return ErrorMap(calibration.delta, np.hypot(calibration.worst_N, floor_N), np.hypot(calibration.rms_N, floor_N),
                    calibration.force_N)  # fmt: skip


def map_points(force_N: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The map's points, deltas then directions: delta [rad] (theta2 = 0) and the force (fx, fy) [N] of each."""
    psi = np.linspace(0.0, 2.0 * np.pi, MAP_DIRECTIONS, endpoint=False)
    d, p = (a.ravel() for a in np.meshgrid(map_deltas(), psi, indexing="ij"))
    return d, force_N * np.cos(p), force_N * np.sin(p)


def map_b(model: Linearised, force_N: float) -> np.ndarray:
    """B = M^-1 A at every map point, ``(points, 2, p)``, in :func:`map_points`' order."""
    d, fx, fy = map_points(force_N)
    zero = np.zeros_like(d)
    return np.linalg.solve(model.sensing(d, zero), model.regressor(d, zero, fx, fy))


def _map_b(model: Linearised, force_N: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`map_b` as ``(deltas, directions, 2, p)``, and the deltas [rad]."""
    delta = map_deltas()
    return map_b(model, force_N).reshape(delta.size, MAP_DIRECTIONS, 2, model.size), delta


def _criterion_weights(model: Linearised, force_N: float) -> np.ndarray:
    """W = mean B^T B over the map, ``(p, p)``: the I-criterion is trace(Sigma W)."""
    b, _ = _map_b(model, force_N)
    return np.einsum("dkip,dkiq->pq", b, b) / (b.shape[0] * b.shape[1])


def i_criterion(model: Linearised, holds: Candidates, force_N: float = DEFAULT_FORCE_N) -> float:
    """trace(Sigma W) [N^2]: the predicted force error's variance averaged over the map."""
    return float(np.trace(covariance(model, holds) @ _criterion_weights(model, force_N)))


def information(model: Linearised, holds: Candidates) -> np.ndarray:
    """sum_h A_h^T A_h / sigma_h^2, ``(p, p)``."""
    a = model.regressor(holds.theta1, holds.theta2, holds.fx, holds.fy) / holds.sigma[:, None, None]
    return np.einsum("nip,niq->pq", a, a)


def covariance(model: Linearised, holds: Candidates) -> np.ndarray:
    """Sigma, the fitted parameters' covariance; refuses holds that cannot determine every parameter."""
    info = information(model, holds)
    scale = np.sqrt(np.diag(info))
    if np.any(scale == 0):
        missing = [model.names[i] for i in np.flatnonzero(scale == 0)]
        raise InputError(f"these holds say nothing about {', '.join(missing)}: add holds that load the cells")
    unit = info / np.outer(scale, scale)
    singular = np.linalg.svd(unit, compute_uv=False)
    if singular[-1] < IDENTIFIABLE_RCOND * singular[0]:
        raise InputError(f"{len(holds)} holds cannot determine the {model.model} model's {model.size} parameters "
                         "(their information matrix is singular): use more holds, more deltas or more directions")  # fmt: skip
    return np.linalg.inv(unit) / np.outer(scale, scale)


def predicted_map(model: Linearised, holds: Candidates, force_N: float = DEFAULT_FORCE_N) -> ErrorMap:
    """The predicted force error of a calibration from ``holds`` (module docstring), over the map."""
    b, delta = _map_b(model, force_N)
    var = np.einsum("dkip,pq,dkiq->dk", b, covariance(model, holds), b)  # trace(B Sigma B^T)
    return ErrorMap(delta, np.sqrt(var.max(axis=1)), np.sqrt(var.mean(axis=1)), force_N)


def optimal_holds(model: Linearised, candidates: Candidates, n: int, force_N: float = DEFAULT_FORCE_N,
                  progress=None) -> np.ndarray:  # fmt: skip
    """Indices of ``n`` candidates minimising the I-criterion (module docstring).  A candidate may come more than
    once: the same hold made k times is one hold k times as long (:func:`sailforce.plan.protocol.plan_calibration`
    merges them)."""
    if n < 1:
        raise InputError(f"a plan needs at least one hold, got {n}")
    w = _criterion_weights(model, force_N)
    a = model.regressor(candidates.theta1, candidates.theta2, candidates.fx, candidates.fy) / candidates.sigma[:, None, None]
    ridge = np.diag(START_RIDGE * np.einsum("nip,nip->p", a, a) / len(candidates))  # each parameter's own scale
    sigma = np.linalg.inv(ridge)
    chosen: list[int] = []
    for step in range(n):  # greedy: the largest drop of trace(Sigma W)
        gains = _gain(sigma, w, a)
        best = int(np.argmax(gains))
        sigma = _update(sigma, a[best])
        chosen.append(best)
        if progress:
            progress(step + 1, n + MAX_EXCHANGE_PASSES)
    for sweep in range(MAX_EXCHANGE_PASSES):  # Fedorov exchange, each hold's removal inverted afresh (no drift)
        improved = False
        for slot in range(n):
            others = chosen[:slot] + chosen[slot + 1 :]
            without = _inverse(np.einsum("nip,niq->pq", a[others], a[others]) + ridge)
            gains = _gain(without, w, a)
            best = int(np.argmax(gains))
            if best != chosen[slot] and gains[best] > gains[chosen[slot]] + EXCHANGE_RTOL * float(np.trace(without @ w)):
                chosen[slot], improved = best, True
        if progress:
            progress(n + sweep + 1, n + MAX_EXCHANGE_PASSES)
        if not improved:
            break
    if progress:
        progress(n + MAX_EXCHANGE_PASSES, n + MAX_EXCHANGE_PASSES)
    return np.asarray(chosen)


def _inverse(info: np.ndarray) -> np.ndarray:
    """The inverse of a positive definite matrix, scaled to unit diagonal first (its entries span decades)."""
    scale = np.sqrt(np.diag(info))
    return np.linalg.inv(info / np.outer(scale, scale)) / np.outer(scale, scale)


def _gain(sigma: np.ndarray, w: np.ndarray, a: np.ndarray) -> np.ndarray:
    """How much adding each hold ``a`` (c, 2, p) lowers trace(Sigma W): tr((I + a Sigma a^T)^-1 a Sigma W Sigma a^T)."""
    s_a = np.einsum("pq,ciq->cip", sigma, a)  # a Sigma, per hold (Sigma is symmetric)
    k = np.eye(2) + np.einsum("cip,cjp->cij", a, s_a)  # a is noise-scaled: the readings' covariance is I
    g = np.einsum("cip,pq,cjq->cij", s_a, w, s_a)
    return np.einsum("cii->c", np.linalg.solve(k, g))


def _update(sigma: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Sigma after adding one hold's two noise-scaled rows ``a`` (2, p) (Woodbury)."""
    s_a = sigma @ a.T
    k = np.eye(2) + a @ s_a
    return sigma - s_a @ np.linalg.solve(k, s_a.T)
