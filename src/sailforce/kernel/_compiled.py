"""The force kernel compiled by numba: the arithmetic of the numpy path (:mod:`sailforce.kernel`), one pose at a time.

Imported only when numba is installed (:mod:`sailforce.kernel` falls back to
numpy otherwise).  Every function releases the GIL (``nogil``), so the
blocks of :func:`sailforce._blocks.for_each_block` run on threads, and is
cached on disk after its first compilation (``cache``).  ``error_model="numpy"``:
a division by zero gives inf or NaN, as in numpy, never an exception.

The one departure from the numpy path is the sine and cosine: numpy calls
libm once per value, which is most of its time; here :func:`sincos` is a
polynomial that LLVM inlines (and vectorises where the loop allows), within
1 ulp of libm.  A pose whose |sin(delta)| lies within :data:`VERDICT_BAND` of the singular
threshold is flagged ``NEAR`` so that the caller settles its verdict with
libm's values: every entry point then gives the verdict numpy gives.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kinematics import transposed_jacobian_entries
from ..status import EXTRAPOLATED, INVALID, OK, SATURATED, SINGULAR
from .verdict import NEAR, VERDICT_BAND

#: J^T, compiled from the one Python definition (seed Eqs. 3, 4, 7).
_transposed_jacobian = njit(inline="always", nogil=True, cache=True)(transposed_jacobian_entries)

# x = k pi/2 + r with |r| <= pi/4 (Cody and Waite): pi/2 in three parts of 33 significant bits, so k P1 and
# k P2 are exact for |k| < 2^20, |x| < 1.6e6 rad.
_PIO2_1 = 1.5707963267341256
_PIO2_2 = 6.077100506303966e-11
_PIO2_3 = 2.0222662487959506e-21
_TWO_OVER_PI = 0.6366197723675814
_ROUNDING_SHIFT = 6755399441055744.0  # 1.5 2^52: adding and subtracting it rounds to the nearest integer
#: |x| [rad] below which :func:`sincos` is accurate; any joint angle (beyond it, numpy settles the pose).
REDUCTION_LIMIT = 1.6e6
# Taylor coefficients (-1)^k / (2k+1)! and (-1)^k / (2k)!: on |r| <= pi/4 the first omitted terms,
# (pi/4)^19 / 19! and (pi/4)^20 / 20!, are below 1e-19, far under an ulp of the result.
_S3, _S5, _S7, _S9, _S11, _S13, _S15, _S17 = (
    (-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 9))  # fmt: skip
_C2, _C4, _C6, _C8, _C10, _C12, _C14, _C16, _C18 = (
    (-1.0) ** k / math.factorial(2 * k) for k in range(1, 10))  # fmt: skip


@njit(inline="always", nogil=True, cache=True)
def sincos(x):
    """(sin x, cos x) within 1 ulp for |x| < :data:`REDUCTION_LIMIT` rad (branch-free, so that loops vectorise).

    Beyond the limit, and for NaN or inf, the values are meaningless: the
    callers flag such poses for numpy (:func:`in_range`).
    """
    k = (x * _TWO_OVER_PI + _ROUNDING_SHIFT) - _ROUNDING_SHIFT
    r = ((x - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    sr = r + r * z * (_S3 + z * (_S5 + z * (_S7 + z * (_S9 + z * (_S11 + z * (_S13 + z * (_S15 + z * _S17)))))))
    cr = 1.0 + z * (_C2 + z * (_C4 + z * (_C6 + z * (_C8 + z * (_C10 + z * (_C12 + z * (_C14 + z * (_C16 + z * _C18))))))))
    q = np.int64(k) & 3
    s = cr if q & 1 else sr  # quadrant q: (sin, cos) = (sr, cr), (cr, -sr), (-sr, -cr), (-cr, sr)
    c = sr if q & 1 else cr
    return (-s if q & 2 else s), (-c if (q + 1) & 2 else c)


@njit(inline="always", nogil=True, cache=True)
def in_range(x):
    """True where :func:`sincos` is accurate: |x| < :data:`REDUCTION_LIMIT` (False for NaN)."""
    return abs(x) < REDUCTION_LIMIT


@njit(nogil=True, cache=True)
def sincos_array(x, s, c):
    """``s, c = sin x, cos x`` elementwise (1-D arrays)."""
    for i in range(x.size):
        s[i], c[i] = sincos(x[i])
        if not in_range(x[i]):
            s[i], c[i] = math.sin(x[i]), math.cos(x[i])


@njit(inline="always", nogil=True, cache=True)
def _verdict(sd, min_sin_delta, trig_ok):
    """0 (regular), 1 (singular) or NEAR (for numpy to settle: at the threshold, or the angles out of range)."""
    a = abs(sd)
    near = (abs(a - min_sin_delta) < VERDICT_BAND) | (not trig_ok)
    return NEAR if near else (1 if a < min_sin_delta else 0)


@njit(nogil=True, cache=True, error_model="numpy")
def force_from_torques(l2, l3, theta1, theta2, t1, t2, min_sin_delta, fx, fy, singular):
    """F = (J^T)^-1 T (seed Eq. 8, corrected: docs/errata.md) for 1-D arrays; ``singular`` gets 0, 1 or NEAR."""
    for i in range(theta1.size):
        s1, c1 = sincos(theta1[i])
        s2, c2 = sincos(theta2[i])
        sd = s1 * c2 - c1 * s2  # det J^T = -l2 l3 sin(delta) (seed Eq. 9)
        singular[i] = _verdict(sd, min_sin_delta, in_range(theta1[i]) & in_range(theta2[i]))
        j00, j01, j10, j11 = _transposed_jacobian(l2, l3, s1, c1, s2, c2)
        det = j00 * j11 - j01 * j10
        gx = (j11 * t1[i] - j01 * t2[i]) / det  # Cramer's rule (seed Eq. 8)
        gy = (j00 * t2[i] - j10 * t1[i]) / det
        fx[i] = np.nan if singular[i] == 1 else gx
        fy[i] = np.nan if singular[i] == 1 else gy


@njit(nogil=True, cache=True, error_model="numpy")
def estimate_matrix(l2, l3, coefficients, cheb_lo, cheb_hi, offsets, capacity, delta_lo, delta_hi, min_sin_delta,
                    theta1, theta2, load1, load2, fx, fy, status, near):  # fmt: skip
    """The static estimate with M = C(delta) J^T, C a Chebyshev series (``coefficients`` ``(K, 2, 2)``).

    Mirrors the numpy path (``estimator._estimate_numpy`` without motion)
    and libsail's ``sail_estimate``: statuses in the order INVALID,
    SINGULAR, SATURATED, EXTRAPOLATED; ``delta_lo``/``delta_hi`` include
    the slack.  ``near`` is set where numpy must settle the pose (the
    singular verdict at the threshold, or an angle beyond :data:`REDUCTION_LIMIT`).
    Three passes over the block, each a loop without branches that LLVM vectorises.
    """
    n = theta1.size
    x = np.empty(n)
    jt = np.empty((4, n))
    flag = np.empty(n, dtype=np.int8)
    for i in range(n):  # J^T (seed Eqs. 3, 4, 7), the singular verdict, the Chebyshev argument
        sn1, cs1 = sincos(theta1[i])
        sn2, cs2 = sincos(theta2[i])
        jt[0, i], jt[1, i], jt[2, i], jt[3, i] = _transposed_jacobian(l2, l3, sn1, cs1, sn2, cs2)
        flag[i] = _verdict(sn1 * cs2 - cs1 * sn2, min_sin_delta, in_range(theta1[i]) & in_range(theta2[i]))
        x[i] = (2.0 * (theta1[i] - theta2[i]) - (cheb_lo + cheb_hi)) / (cheb_hi - cheb_lo)

    c = np.empty((4, n))  # C(delta) = sum_k c_k T_k(x), with T_{k+1} = 2 x T_k - T_{k-1}
    t_prev = np.ones(n)
    t_k = x.copy()
    for e in range(4):
        c[e, :] = coefficients[0, e >> 1, e & 1]
    for k in range(1, coefficients.shape[0]):
        a00, a01, a10, a11 = coefficients[k, 0, 0], coefficients[k, 0, 1], coefficients[k, 1, 0], coefficients[k, 1, 1]
        for i in range(n):
            t = t_k[i]
            c[0, i] += a00 * t
            c[1, i] += a01 * t
            c[2, i] += a10 * t
            c[3, i] += a11 * t
            t_k[i] = 2.0 * x[i] * t - t_prev[i]
            t_prev[i] = t

    for i in range(n):  # M = C J^T, Cramer's rule (cf. seed Eq. 8), the status
        m00 = c[0, i] * jt[0, i] + c[1, i] * jt[2, i]
        m01 = c[0, i] * jt[1, i] + c[1, i] * jt[3, i]
        m10 = c[2, i] * jt[0, i] + c[3, i] * jt[2, i]
        m11 = c[2, i] * jt[1, i] + c[3, i] * jt[3, i]
        det = m00 * m11 - m01 * m10
        u1 = load1[i] - offsets[0]
        u2 = load2[i] - offsets[1]
        gx = (m11 * u1 - m01 * u2) / det
        gy = (m00 * u2 - m10 * u1) / det
        delta = theta1[i] - theta2[i]
        finite = math.isfinite(theta1[i]) & math.isfinite(theta2[i]) & math.isfinite(load1[i]) & math.isfinite(load2[i])
        degenerate = (det == 0.0) | (not math.isfinite(det))  # a fitted map that cannot be inverted is singular too
        st = EXTRAPOLATED if (delta < delta_lo) | (delta > delta_hi) else OK
        st = SATURATED if (abs(u1) > capacity[0]) | (abs(u2) > capacity[1]) else st
        st = SINGULAR if (flag[i] == 1) | degenerate else st
        st = INVALID if not finite else st
        no_estimate = (st == SINGULAR) | (st == INVALID)
        fx[i] = np.nan if no_estimate else gx
        fy[i] = np.nan if no_estimate else gy
        status[i] = st
        near[i] = finite & (flag[i] == NEAR)
