"""SAIL's force against a reference sensor's: the agreement a paper reports.

- **Agreement** of two methods (Bland & Altman, *Lancet* 327(8476), 1986):
  per axis, the bias (mean difference, SAIL less reference), the standard
  deviation of the differences, and the 95 % limits of agreement
  ``bias +- 1.96 sd``; beside them the RMS of the error vector and its
  95th percentile.
- **Where**: the same, per Δ bin (:data:`DELTA_BIN_DEG`), per square of the
  workspace (:data:`REGION_M`), and at rest against in motion.

The reference's own noise is in every difference: a sensor of 0.05 N rms
per axis adds 0.07 N in quadrature to the error vector's RMS.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError

#: The Bland-Altman limits of agreement: bias +- this many standard deviations (95 % of a normal spread).
LIMITS_SD = 1.96

#: Δ bins [deg] of the report, from 0.
DELTA_BIN_DEG = 15.0

#: The workspace's squares [m] of the error map.
REGION_M = 0.05

#: A bin or square with fewer samples than this is left out of the tables (its numbers would be noise).
MIN_BIN_SAMPLES = 100


@dataclass(frozen=True)
class Agreement:
    """Bland-Altman agreement of SAIL's force with the reference's over some samples (module docstring)."""

    samples: int
    bias_N: tuple[float, float]  #: mean of SAIL less reference, per axis
    sd_N: tuple[float, float]  #: standard deviation of the differences, per axis
    rmse_N: float  #: RMS of the error vector's length
    p95_N: float  #: 95th percentile of the error vector's length
    max_N: float

    @property
    def limits_N(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The 95 % limits of agreement per axis, ``((low_x, high_x), (low_y, high_y))``."""
        return tuple((b - LIMITS_SD * s, b + LIMITS_SD * s) for b, s in zip(self.bias_N, self.sd_N))  # type: ignore[return-value]

    def to_dict(self) -> dict:
        return {**asdict(self), "limits_N": [list(v) for v in self.limits_N]}


def agreement(estimate, reference) -> Agreement:
    """:class:`Agreement` of ``estimate`` ``(n, 2)`` with ``reference`` ``(n, 2)`` [N]; both finite."""
    estimate, reference = np.asarray(estimate, float), np.asarray(reference, float)
    if estimate.shape != reference.shape or estimate.ndim != 2 or estimate.shape[1] != 2:
        raise InputError(f"agreement needs two (n, 2) force arrays, got {estimate.shape} and {reference.shape}")
    if estimate.shape[0] < 2:
        raise InputError(f"agreement needs at least 2 samples, got {estimate.shape[0]}")
    d = estimate - reference
    length = np.hypot(d[:, 0], d[:, 1])
    bias, sd = d.mean(axis=0), d.std(axis=0, ddof=1)
    return Agreement(int(d.shape[0]), (float(bias[0]), float(bias[1])), (float(sd[0]), float(sd[1])),
                     float(np.sqrt(np.mean(length**2))), float(np.percentile(length, 95)), float(length.max()))  # fmt: skip


@dataclass(frozen=True)
class Binned:
    """Agreement per bin: each bin's label (its low edge or edges) and its :class:`Agreement`."""

    edges: tuple[tuple[float, ...], ...]
    agreements: tuple[Agreement, ...]


def by_bins(estimate, reference, keys, width) -> Binned:
    """:class:`Binned` over bins of ``width`` in each column of ``keys`` ``(n, k)`` (the low edges label them);
    bins with fewer than :data:`MIN_BIN_SAMPLES` samples are left out."""
    keys = np.asarray(keys, float)
    if keys.shape[0] != np.shape(estimate)[0]:
        raise InputError(f"by_bins: {keys.shape[0]} keys for {np.shape(estimate)[0]} samples; give one per sample")
    keys = keys.reshape(keys.shape[0], -1)
    index = np.floor(keys / width).astype(int)
    labels, inverse = np.unique(index, axis=0, return_inverse=True)
    edges, found = [], []
    for k, label in enumerate(labels):
        mask = inverse.ravel() == k
        if mask.sum() >= MIN_BIN_SAMPLES:
            edges.append(tuple(float(v) * width for v in label))
            found.append(agreement(np.asarray(estimate)[mask], np.asarray(reference)[mask]))
    return Binned(tuple(edges), tuple(found))
