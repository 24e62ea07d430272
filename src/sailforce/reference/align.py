"""The reference sensor's clock against the robot's, by cross-correlation.

Nothing is known yet of how the two are related beyond linearity: the cells
read ``c + M(theta) F`` and the sensor ``R(-phi) F + b``, with the map M, the
mount and the offsets all unknown.  So the score of a lag is what stays the
same under any of those: the **canonical correlations** of the two pairs of
signals (Hotelling, *Biometrika* 28, 1936), invariant to offsets and to any
invertible 2x2 map on either side.  Both pairs are resampled to one grid,
their means removed, each whitened by its covariance (``C^-1/2``); the four
cross-correlations of the whitened channels (by FFT) give, at each lag,
``C_xy(lag)``, and the score is its squared Frobenius norm, the sum of the
squared canonical correlations.  The peak's lag is refined by a parabola
through it and its neighbours.

M varies with the pose and, on the handle's link, so does the sensor's
angle; over a recording they only lower the peak.  For a sensor on the link
a second pass turns the sensor's forces by the robot's theta1 at the first
pass's lag, which takes the second effect away.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .sensor import ReferenceRecording, rotate

#: The clock offsets searched, at most [s], unless given: the start of a reference recording is usually a hand
#: pressing two "record" buttons, seconds apart.
MAX_CLOCK_OFFSET_S = 30.0

#: The lowest peak score accepted (the sum of two squared canonical correlations, at most 2): below it the two
#: recordings share too little of the hand's force to be aligned (nobody pushed, or they are not of one session).
MIN_ALIGNMENT_SCORE = 0.2

#: The overlap of the two recordings at the peak must hold this many seconds at least.
MIN_OVERLAP_S = 5.0


@dataclass(frozen=True)
class ClockAlignment:
    """The reference's clock less the robot's, ``offset_s``: a robot sample at ``t`` is the sensor's at ``t + offset_s``."""

    offset_s: float
    score: float  #: the peak's sum of squared canonical correlations (0 to 2)
    step_s: float  #: the grid the lags were searched on [s]
    second_score: float  #: the best score at least a second from the peak: a clear peak stands well above it
    coarse_offset_s: float = float("nan")  #: the correlation's offset, where ``offset_s`` is a model's refinement


def _whitened(x: np.ndarray) -> np.ndarray:
    x = x - x.mean(axis=0)
    c = np.cov(x, rowvar=False)
    w, v = np.linalg.eigh(c)
    if not w[0] > 1e-12 * w[-1]:
        raise InputError("a recording's two channels move together (or not at all) over the whole recording: "
                         "push the handle in more than one direction")  # fmt: skip
    return x @ (v / np.sqrt(w)) @ v.T


def _scores(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``score[k]``, the squared norm of the whitened cross-covariance with ``y`` ``k - (x.size - 1)`` samples later."""
    from scipy.signal import correlate

    xw, yw = _whitened(x), _whitened(y)
    n = _overlaps(x.shape[0], y.shape[0])
    total = np.zeros(x.shape[0] + y.shape[0] - 1)
    for i in range(2):
        for j in range(2):
            c = correlate(yw[:, j], xw[:, i], mode="full", method="fft")  # c[k]: sum x(m) y(m + k - (nx - 1))
            total += (c / np.maximum(n, 1.0)) ** 2
    return total


def _overlaps(nx: int, ny: int) -> np.ndarray:
    """The samples that overlap at each lag ``L = -(nx - 1) ... ny - 1`` (y's index less x's)."""
    lags = np.arange(-(nx - 1), ny)
    return np.maximum(0, np.minimum(nx, ny - lags) - np.maximum(0, -lags)).astype(float)


def align_clocks(t_robot, loads, reference: ReferenceRecording, *, theta1=None, on: str = "base",
                 max_offset_s: float = MAX_CLOCK_OFFSET_S) -> ClockAlignment:  # fmt: skip
    """The clock offset of ``reference`` against a robot recording (``t_robot`` [s], ``loads`` ``(n, 2)``).

    With ``on="link"`` and ``theta1`` [rad] at ``t_robot``, a second pass
    turns the sensor's forces into a frame fixed to the base (module
    docstring).  Refuses recordings that do not overlap by
    :data:`MIN_OVERLAP_S` within ``max_offset_s``, or whose best score is
    under :data:`MIN_ALIGNMENT_SCORE`.
    """
    t_robot, loads = np.asarray(t_robot, float), np.asarray(loads, float)
    step = float(min(np.median(np.diff(t_robot)), np.median(np.diff(reference.t))))
    grid_r = np.arange(t_robot[0], t_robot[-1], step)
    grid_s = np.arange(reference.t[0], reference.t[-1], step)
    x = np.column_stack([np.interp(grid_r, t_robot, loads[:, k]) for k in range(2)])
    force = reference.force
    alignment = _align(x, grid_r[0], force, reference.t, grid_s, step, max_offset_s)
    if on == "link" and theta1 is not None:
        turned = rotate(np.interp(reference.t - alignment.offset_s, t_robot, np.asarray(theta1, float)), force)
        alignment = _align(x, grid_r[0], turned, reference.t, grid_s, step, max_offset_s)
    return alignment


def _align(x, start_r, force, t_s, grid_s, step, max_offset_s) -> ClockAlignment:
    y = np.column_stack([np.interp(grid_s, t_s, force[:, k]) for k in range(2)])
    scores = _scores(x, y)
    lags = np.arange(scores.size) - (x.shape[0] - 1)  # y index less x index
    offsets = lags * step + grid_s[0] - start_r
    overlap = _overlaps(x.shape[0], y.shape[0]) * step
    allowed = (np.abs(offsets) <= max_offset_s) & (overlap >= MIN_OVERLAP_S)
    if not allowed.any():
        raise InputError(f"the reference recording and the robot's never overlap by {MIN_OVERLAP_S:g} s with the "
                         f"clocks within {max_offset_s:g} s of each other: are they of one session? (a larger "
                         "--max-clock-offset-s searches further)")  # fmt: skip
    masked = np.where(allowed, scores, -np.inf)
    k = int(np.argmax(masked))
    score = float(scores[k])
    if score < MIN_ALIGNMENT_SCORE:
        raise InputError(f"the reference recording and the robot's loads share too little to align their clocks (best "
                         f"score {score:.3g} of 2, under {MIN_ALIGNMENT_SCORE:g}): record the hand pushing the handle "
                         "in every direction while both record")  # fmt: skip
    shift = 0.0
    if 0 < k < scores.size - 1 and np.isfinite(masked[k - 1]) and np.isfinite(masked[k + 1]):
        a, b, c = scores[k - 1], scores[k], scores[k + 1]
        curvature = a - 2 * b + c
        if curvature < 0:
            shift = float(np.clip(0.5 * (a - c) / curvature, -0.5, 0.5))
    far = allowed & (np.abs(offsets - offsets[k]) >= 1.0)
    second = float(scores[far].max()) if far.any() else 0.0
    return ClockAlignment(float(offsets[k] + shift * step), score, step, second)
