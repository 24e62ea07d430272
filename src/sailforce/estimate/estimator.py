"""The run-time force estimator: one calibrated estimate and one status per reading.

The statuses and their precedence are those of :mod:`sailforce.status`
(the same codes as libsail's ``enum``).  The static estimate is the force
kernel's (:mod:`sailforce.kernel`); with a dynamic term
(:mod:`sailforce.estimate.dynamic`) the inertial load is subtracted too.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np

from .. import kernel
from .._blocks import BLOCK, THREADS, for_each_block
from .._validate import as_float_arrays
from ..kernel import solve_2x2, torque_entries
from ..kinematics import SINGULAR_SIN_DELTA, is_singular, sin_delta_from_trig
from ..sensing.maps import SensingModel
from ..statics import ForceResult, check_on_singular, force_result
from ..status import EXTRAPOLATED, INVALID, MOTION_UNKNOWN, OK, SATURATED, SINGULAR, STATUS_NAMES, count_statuses  # noqa: F401 (re-exported)

#: Delta may leave the calibrated range by this much [rad] before the estimate
#: counts as extrapolated: 0.01 deg, below encoder resolution of a held pose.
DELTA_RANGE_SLACK = np.radians(0.01)



class Sensing(NamedTuple):
    """What the run-time estimate needs of a calibration: its sensing map, and the limits it was calibrated within.

    A :class:`sailforce.calibration.Calibration` has these attributes, and is passed itself.
    """

    model: SensingModel  #: the sensing map (``sensing_entries``, ``arm``)
    offsets: tuple[float, float]  #: raw reading of each cell at no load
    capacity: tuple[float, float]  #: |load - offset| beyond this is saturated [raw]
    delta_range: tuple[float, float]  #: calibrated delta [rad]


def estimate_calibrated(cal, theta1, theta2, load1, load2, *, threads: int | None = None,
                        min_sin_delta: float = SINGULAR_SIN_DELTA):  # fmt: skip
    """Vectorized estimate: ``(fx, fy, status)`` for arrays of readings (angles [rad], raw loads).

    ``cal`` is a :class:`Sensing` or a calibration (its ``model``,
    ``offsets``, ``capacity``, ``delta_range``).  Inputs broadcast; nothing
    raises on bad readings: they get their status.  The work is split into
    blocks of :data:`~sailforce._blocks.BLOCK` readings, on ``threads``
    (default :data:`~sailforce._blocks.THREADS`) threads when there are
    several blocks; the result does not depend on it.  Poses with
    |sin(theta1 - theta2)| < ``min_sin_delta`` are :data:`SINGULAR`.
    """
    fx, fy, status, _ = _run_blocks(cal, (theta1, theta2, load1, load2), None, threads, min_sin_delta=min_sin_delta)
    return fx, fy, status


def estimate(model, offsets, capacity, delta_range, theta1, theta2, load1, load2, *, threads: int | None = None,
             min_sin_delta: float = SINGULAR_SIN_DELTA):  # fmt: skip
    """:func:`estimate_calibrated` of the :class:`Sensing` ``(model, offsets, capacity, delta_range)``."""
    return estimate_calibrated(Sensing(model, offsets, capacity, delta_range), theta1, theta2, load1, load2, threads=threads,
                               min_sin_delta=min_sin_delta)  # fmt: skip


def estimate_with_rates(cal, shear_model, theta1, theta2, load1, load2, omega1, omega2, alpha1, alpha2, *,
                        threads: int | None = None):  # fmt: skip
    """:func:`estimate_calibrated` while the arm moves, at known rates: ``(fx, fy, status, inertial)``.

    ``shear_model`` (:class:`sailforce.motion.dynamics.ShearModel`) gives the
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
    return estimate_moving_blocks(cal, shear_model, arrays[0], arrays[1], arrays[2], arrays[3],
                                  lambda start, stop: [a[start:stop] for a in motion], threads=threads)  # fmt: skip


def estimate_moving(model, offsets, capacity, delta_range, shear_model, theta1, theta2, omega1, omega2, alpha1, alpha2,
                    load1, load2, *, threads: int | None = None):  # fmt: skip
    """The old name and argument order of :func:`estimate_with_rates`, kept for one release."""
    return estimate_with_rates(Sensing(model, offsets, capacity, delta_range), shear_model, theta1, theta2, load1, load2,
                               omega1, omega2, alpha1, alpha2, threads=threads)  # fmt: skip


def estimate_moving_blocks(cal, shear_model, theta1, theta2, load1, load2, motion, *, threads: int | None = None):
    """:func:`estimate_with_rates` with the motion computed block by block: ``motion(start, stop)`` gives
    ``(omega1, omega2, alpha1, alpha2)`` of the flattened readings ``start:stop``.

    Each block's motion is computed in the thread that estimates the block,
    while its readings are in the cache (:class:`sailforce.motion.differentiate.RatePlan`).
    """
    return _run_blocks(cal, (theta1, theta2, load1, load2), shear_model, threads, motion)


def _run_blocks(cal, arrays, shear_model, threads, motion=None, min_sin_delta=SINGULAR_SIN_DELTA):
    threads = THREADS if threads is None else threads
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in arrays))
    shape = arrays[0].shape
    flat = [a.reshape(-1) for a in arrays]  # a view where it can be (a column of an (n, 2) table is one): blocks are sliced
    n = flat[0].size
    fx, fy, status = np.empty(n), np.empty(n), np.empty(n, dtype=np.int8)
    inertial = np.empty((n, 2)) if shear_model is not None else None

    module = kernel.compiled(n)

    def run(start: int) -> None:
        stop = min(start + BLOCK, n)
        rates = motion(start, stop) if shear_model is not None else ()
        out = _estimate_block(module, cal, shear_model, min_sin_delta, *(a[start:stop] for a in flat), *rates)
        fx[start:stop], fy[start:stop], status[start:stop] = out[:3]
        if inertial is not None:
            inertial[start:stop, 0], inertial[start:stop, 1] = out[3]

    for_each_block(n, BLOCK, threads, run)
    return (fx.reshape(shape), fy.reshape(shape), status.reshape(shape),
            None if inertial is None else inertial.reshape(shape + (2,)))  # fmt: skip


def _estimate_block(module, cal, shear_model, min_sin_delta, theta1, theta2, load1, load2, *motion):
    series = getattr(cal.model, "matrix_series", None)
    if module is not None and shear_model is None and series is not None:
        return _estimate_compiled(module, cal, series(), min_sin_delta, theta1, theta2, load1, load2)
    return _estimate_numpy(cal, shear_model, min_sin_delta, theta1, theta2, load1, load2, *motion)


def _estimate_compiled(module, cal, series, min_sin_delta, theta1, theta2, load1, load2):
    """The static estimate of a model M = C(delta) J^T on the compiled kernel; verdicts at the threshold from numpy."""
    coefficients, (cheb_lo, cheb_hi) = series
    model, offsets, capacity, delta_range = cal.model, cal.offsets, cal.capacity, cal.delta_range
    n = theta1.size
    fx, fy, status, near = np.empty(n), np.empty(n), np.empty(n, dtype=np.int8), np.empty(n, dtype=bool)
    module.estimate_matrix(model.arm.l2, model.arm.l3, coefficients, cheb_lo, cheb_hi,
                           np.asarray(offsets, dtype=float), np.asarray(capacity, dtype=float),
                           delta_range[0] - DELTA_RANGE_SLACK, delta_range[1] + DELTA_RANGE_SLACK, min_sin_delta,
                           *_owned(theta1, theta2, load1, load2), fx, fy, status, near)  # fmt: skip
    rows = np.flatnonzero(near)
    if rows.size:
        fx[rows], fy[rows], status[rows], _ = _estimate_numpy(cal, None, min_sin_delta,
                                                              *(a[rows] for a in (theta1, theta2, load1, load2)))  # fmt: skip
    return fx, fy, status, None


def _owned(*arrays: np.ndarray) -> list[np.ndarray]:
    """Each array as one that owns its strided memory: a broadcast scalar (stride 0) is copied out, as numba will
    refuse views of broadcasts (its FutureWarning)."""
    return [a if a.strides != (0,) or a.size <= 1 else np.ascontiguousarray(a) for a in arrays]


def _estimate_numpy(cal, shear_model, min_sin_delta, theta1, theta2, load1, load2, *motion):
    model, offsets, capacity, delta_range = cal.model, cal.offsets, cal.capacity, cal.delta_range
    invalid = ~(np.isfinite(theta1) & np.isfinite(theta2) & np.isfinite(load1) & np.isfinite(load2))
    if invalid.any():  # keep NaN out of the arithmetic; these rows are masked below
        theta1, theta2, load1, load2 = (np.where(invalid, 0.0, a) for a in (theta1, theta2, load1, load2))
    sin1, cos1, sin2, cos2 = np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)
    delta = theta1 - theta2
    singular = is_singular(sin_delta_from_trig(sin1, cos1, sin2, cos2), min_sin_delta)  # det J = -l2 l3 sin(delta) (seed Eq. 9)
    jt = torque_entries(model.arm.l2, model.arm.l3, sin1, cos1, sin2, cos2)
    m = model.sensing_entries(delta, jt)
    s1, s2 = load1 - offsets[0], load2 - offsets[1]
    saturated = (np.abs(s1) > capacity[0]) | (np.abs(s2) > capacity[1])
    extrapolated = (delta < delta_range[0] - DELTA_RANGE_SLACK) | (delta > delta_range[1] + DELTA_RANGE_SLACK)

    fx, fy = solve_2x2(m, s1, s2, invalid | singular)
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
        wx, wy = solve_2x2(jt, v1, v2, singular)  # J^T w = diag(l) V
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
    return {name: int(n) for name, n in zip(STATUS_NAMES, count_statuses(status))}


def estimate_force(model: SensingModel, theta1, theta2, load1, load2, *, on_singular: Literal["raise", "mask"] = "raise",
                   min_sin_delta: float = SINGULAR_SIN_DELTA) -> ForceResult:  # fmt: skip
    """End-effector force (fx, fy) [N] from the two load-cell signals: solve M F = s.

    Angles in radians; loads in the model's signal unit (offset-free).  The
    force kernel's estimate (:mod:`sailforce.estimate.estimator`) without offsets,
    capacity or range.  Poses with |sin(theta1 - theta2)| < ``min_sin_delta``
    are singular: raise :class:`SingularPoseError` (default), or with
    ``on_singular="mask"`` give NaN there.  The result is a
    :class:`sailforce.statics.ForceResult`, which unpacks as ``fx, fy`` or,
    masked, as ``fx, fy, singular``.

    >>> from sailforce import Arm
    >>> from sailforce.sensing import TorqueScale
    >>> model = TorqueScale(Arm(), (1.0, 1.0))          # signals are the torques themselves
    >>> fx, fy = estimate_force(model, np.pi / 2, 0.0, 0.0, 3.0)
    >>> round(float(fx), 12), round(float(fy), 12)
    (0.0, 10.0)
    """
    check_on_singular(on_singular)
    theta1, theta2, load1, load2 = as_float_arrays(theta1=theta1, theta2=theta2, load1=load1, load2=load2)
    unlimited = Sensing(model, (0.0, 0.0), (np.inf, np.inf), (-np.inf, np.inf))
    fx, fy, status = estimate_calibrated(unlimited, theta1, theta2, load1, load2, min_sin_delta=min_sin_delta)
    return force_result(theta1, theta2, fx[()], fy[()], (status == SINGULAR)[()], on_singular, min_sin_delta)
