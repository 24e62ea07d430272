"""The run-time force estimator: one calibrated estimate and one status per reading.

Statuses (the same codes as libsail's ``enum``):

- ``OK`` (0);
- ``SINGULAR`` (1): |sin(theta1 - theta2)| < :data:`sailforce.SINGULAR_SIN_DELTA`;
  no estimate (NaN);
- ``SATURATED`` (2): a reading, offset removed, is beyond its cell's capacity;
  the estimate is given but must not be trusted;
- ``EXTRAPOLATED`` (3): delta lies outside the calibrated range (by more
  than :data:`DELTA_RANGE_SLACK`); the estimate is given;
- ``INVALID`` (4): a field is NaN or infinite (or, in files, missing or not a
  number); no estimate;
- ``MOTION_UNKNOWN`` (5): with a dynamic term (:mod:`sailforce.inertial`),
  the joint rates are not known yet (the first half window of a recording,
  around a gap), so the inertial load cannot be subtracted; no estimate.
  Appended after the static codes, whose numbers stay as they were.

When several apply, the first in the order INVALID, SINGULAR, SATURATED,
MOTION_UNKNOWN, EXTRAPOLATED wins.
"""

from __future__ import annotations

import os

import numpy as np

from ._blocks import for_each_block
from .compensation import solve_sensing, torque_entries
from .kinematics import sin_delta_from_trig
from .statics import is_singular

OK, SINGULAR, SATURATED, EXTRAPOLATED, INVALID, MOTION_UNKNOWN = range(6)
STATUS_NAMES = ("ok", "singular", "saturated", "extrapolated", "invalid", "motion-unknown")

#: Delta may leave the calibrated range by this much [rad] before the estimate
#: counts as extrapolated: 0.01 deg, below encoder resolution of a held pose.
DELTA_RANGE_SLACK = np.radians(0.01)

#: Readings per block: the ~20 temporaries of a block (8 bytes each) stay in
#: the L2 cache; measured 14 M/s against 12 M/s for blocks of 65536 (one thread).
BLOCK = 16384

#: Threads for large inputs; numpy's ufuncs release the GIL, so blocks run in parallel.
THREADS = min(4, os.cpu_count() or 1)


def estimate(model, offsets, capacity, delta_range, theta1, theta2, load1, load2, *, threads: int | None = None):
    """Vectorized estimate: ``(fx, fy, status)`` for arrays of readings (angles [rad], raw loads).

    ``model`` is a sensing model (``sensing_entries``, ``arm``), ``offsets``
    and ``capacity`` are ``(2,)`` raw units, ``delta_range`` [rad].  Inputs
    broadcast; nothing raises on bad readings: they get their status.  The
    work is split into blocks of :data:`BLOCK` readings, on ``threads``
    (default :data:`THREADS`) threads when there are several blocks; the
    result does not depend on it.
    """
    fx, fy, status, _ = _run_blocks(model, offsets, capacity, delta_range, (theta1, theta2, load1, load2), None, threads)
    return fx, fy, status


def estimate_moving(model, offsets, capacity, delta_range, shear_model, theta1, theta2, omega1, omega2, alpha1, alpha2,
                    load1, load2, *, threads: int | None = None):  # fmt: skip
    """:func:`estimate` while the arm moves: ``(fx, fy, status, inertial)``.

    ``shear_model`` (:class:`sailforce.dynamics.ShearModel`) gives the
    cells' dynamic shears ``V`` from the joint rates [rad/s] and
    accelerations [rad/s^2]; the force is (``docs/dynamics.md``)::

        F = M^-1 (s - offsets) - w,      w = (J^T)^-1 diag(l1, l2) V

    and ``inertial = M w`` ``(..., 2)`` is the subtracted load in reading
    units.  Where a rate or acceleration is NaN (motion unknown), the
    status is :data:`MOTION_UNKNOWN` unless a static status outranks it,
    and fx, fy and inertial are NaN.  Saturation is judged on the raw
    readings: the cell carries the inertial load too.
    """
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in
                                   (theta1, theta2, load1, load2, omega1, omega2, alpha1, alpha2)))  # fmt: skip
    motion = [a.reshape(-1) for a in arrays[4:]]
    return estimate_moving_blocks(model, offsets, capacity, delta_range, shear_model, *arrays[:4],
                                  lambda start, stop: [a[start:stop] for a in motion], threads=threads)  # fmt: skip


def estimate_moving_blocks(model, offsets, capacity, delta_range, shear_model, theta1, theta2, load1, load2, motion,
                           *, threads: int | None = None):  # fmt: skip
    """:func:`estimate_moving` with the motion computed block by block: ``motion(start, stop)`` gives
    ``(omega1, omega2, alpha1, alpha2)`` of the flattened readings ``start:stop``.

    Each block's motion is computed in the thread that estimates the block,
    while its readings are in the cache (:class:`sailforce.differentiate.RatePlan`).
    """
    return _run_blocks(model, offsets, capacity, delta_range, (theta1, theta2, load1, load2), shear_model, threads,
                       motion)  # fmt: skip


def _run_blocks(model, offsets, capacity, delta_range, arrays, shear_model, threads, motion=None):
    threads = THREADS if threads is None else threads
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in arrays))
    shape = arrays[0].shape
    flat = [a.reshape(-1) for a in arrays]  # a view where it can be (a column of an (n, 2) table is one): blocks are sliced
    n = flat[0].size
    fx, fy, status = np.empty(n), np.empty(n), np.empty(n, dtype=np.int8)
    inertial = np.empty((n, 2)) if shear_model is not None else None

    def run(start: int) -> None:
        stop = min(start + BLOCK, n)
        rates = motion(start, stop) if shear_model is not None else ()
        out = _estimate_block(model, offsets, capacity, delta_range, shear_model, *(a[start:stop] for a in flat), *rates)
        fx[start:stop], fy[start:stop], status[start:stop] = out[:3]
        if inertial is not None:
            inertial[start:stop, 0], inertial[start:stop, 1] = out[3]

    for_each_block(n, BLOCK, threads, run)
    return (fx.reshape(shape), fy.reshape(shape), status.reshape(shape),
            None if inertial is None else inertial.reshape(shape + (2,)))  # fmt: skip


def _estimate_block(model, offsets, capacity, delta_range, shear_model, theta1, theta2, load1, load2, *motion):
    invalid = ~(np.isfinite(theta1) & np.isfinite(theta2) & np.isfinite(load1) & np.isfinite(load2))
    if invalid.any():  # keep NaN out of the arithmetic; these rows are masked below
        theta1, theta2, load1, load2 = (np.where(invalid, 0.0, a) for a in (theta1, theta2, load1, load2))
    sin1, cos1, sin2, cos2 = np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)
    delta = theta1 - theta2
    singular = is_singular(sin_delta_from_trig(sin1, cos1, sin2, cos2))  # det J = -l2 l3 sin(delta) (seed Eq. 9)
    jt = torque_entries(model.arm, sin1, cos1, sin2, cos2)
    m = model.sensing_entries(delta, jt)
    s1, s2 = load1 - offsets[0], load2 - offsets[1]
    saturated = (np.abs(s1) > capacity[0]) | (np.abs(s2) > capacity[1])
    extrapolated = (delta < delta_range[0] - DELTA_RANGE_SLACK) | (delta > delta_range[1] + DELTA_RANGE_SLACK)

    fx, fy = solve_sensing(m, s1, s2, invalid | singular)
    singular |= np.isnan(fx) & ~invalid  # a degenerate fitted map cannot be inverted either

    status = np.zeros(fx.shape, dtype=np.int8)
    status[extrapolated] = EXTRAPOLATED
    inertial = None
    if shear_model is not None:
        v1, v2 = shear_model.shears_from_trig(sin1, cos1, sin2, cos2, *motion)
        # V1 takes every rate and acceleration, and NaN or inf * 0 is NaN: not finite where the motion is unknown
        unknown = ~np.isfinite(v1)
        v1 *= model.arm.l1
        v2 *= model.arm.l2
        wx, wy = solve_sensing(jt, v1, v2, singular)  # J^T w = diag(l) V
        fx -= wx
        fy -= wy
        inertial = (m[0] * wx + m[1] * wy, m[2] * wx + m[3] * wy)
        if invalid.any():
            inertial[0][invalid], inertial[1][invalid] = np.nan, np.nan
        status[unknown] = MOTION_UNKNOWN
    status[saturated] = SATURATED
    status[singular] = SINGULAR
    status[invalid] = INVALID
    return fx, fy, status, inertial


def status_counts(status: np.ndarray) -> dict[str, int]:
    """How many readings have each status, by name."""
    counts = np.bincount(np.ravel(status).astype(np.intp), minlength=len(STATUS_NAMES))
    return {name: int(n) for name, n in zip(STATUS_NAMES, counts)}
