"""Kinematics of the SAIL parallelogram arm (seed paper Eqs. 1 and 4).

Geometry (docs/index.md, "The linkage"): the motors sit at B, the origin.  Link l1
runs from B to P1 at angle theta1, link l2 from B to P2 at angle theta2.  Link
l3 runs from P2 through P3 to the end effector A, parallel to l1, with
|P2 P3| = l1.  Link l4 runs from P1 to P3, parallel to l2, with |P1 P3| = l2.

All functions are pure, take the arm as their first argument, accept angle
arrays of any broadcastable shape (radians, counter-clockwise from +x) and
return arrays of the broadcast shape, with any new axes trailing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ._validate import as_float_arrays
from .errors import ShapeError, UnreachablePointError

#: Relative slack on the law-of-cosines argument in :func:`inverse`.  Points on
#: the workspace boundary make |cos(delta)| exceed 1 by a few ulps of rounding;
#: 1e-12 admits that and nothing a user could notice (a 0.5 um overshoot on a
#: 0.75 m arm).
REACH_RTOL = 1e-12


class Links(Protocol):
    """Anything with the four link lengths [m]; :class:`sailforce.Arm` is one."""

    @property
    def l1(self) -> float: ...
    @property
    def l2(self) -> float: ...
    @property
    def l3(self) -> float: ...
    @property
    def l4(self) -> float: ...


def _unit(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.cos(theta), np.sin(theta)


def joint_positions(arm: Links, theta1, theta2) -> dict[str, np.ndarray]:
    """Positions of P1, P2, P3 and A [m], each of shape ``(..., 2)``.

    B is the origin.  Eq. 1 of the seed gives A; P1, P2 and P3 follow from
    the same parallelogram.

    >>> from sailforce import Arm
    >>> p = joint_positions(Arm(), np.pi / 2, 0.0)
    >>> np.round(p["A"], 12).tolist()
    [0.3, 0.45]
    """
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    c1, s1 = _unit(theta1)
    c2, s2 = _unit(theta2)
    p1 = np.stack([arm.l1 * c1, arm.l1 * s1], axis=-1)
    p2 = np.stack([arm.l2 * c2, arm.l2 * s2], axis=-1)
    return {
        "P1": p1,
        "P2": p2,
        "P3": p1 + p2,
        "A": np.stack(_forward(arm, c1, s1, c2, s2), axis=-1),
    }


def forward(arm: Links, theta1, theta2) -> tuple[np.ndarray, np.ndarray]:
    """End-effector position A = (x, y) [m] (seed Eq. 1).

    >>> from sailforce import Arm
    >>> x, y = forward(Arm(), 0.0, 0.0)
    >>> float(x), float(y)
    (0.75, 0.0)
    """
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    c1, s1 = _unit(theta1)
    c2, s2 = _unit(theta2)
    return _forward(arm, c1, s1, c2, s2)


def _forward(arm: Links, c1, s1, c2, s2):
    """A = l2 (cos th2, sin th2) + l3 (cos th1, sin th1) (seed Eq. 1), from the sines and cosines: the one place it is written."""
    return arm.l2 * c2 + arm.l3 * c1, arm.l2 * s2 + arm.l3 * s1


def jacobian(arm: Links, theta1, theta2) -> np.ndarray:
    """The Jacobian J[..., i, j] = d x_i / d theta_j, shape ``(..., 2, 2)`` (seed Eq. 4).

    Column 0 belongs to theta1 and column 1 to theta2:
    ``[[-l3 sin th1, -l2 sin th2], [l3 cos th1, l2 cos th2]]``.
    """
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    c1, s1 = _unit(theta1)
    c2, s2 = _unit(theta2)
    jt00, jt01, jt10, jt11 = transposed_jacobian_entries(arm.l2, arm.l3, s1, c1, s2, c2)
    return np.stack([np.stack([jt00, jt10], axis=-1), np.stack([jt01, jt11], axis=-1)], axis=-2)


def transposed_jacobian_entries(l2: float, l3: float, sin1, cos1, sin2, cos2):
    """J^T as its entries ``(m00, m01, m10, m11)``, from the joint angles' sines and cosines (seed Eqs. 3, 4, 7).

    Rows ``l3 (-sin th1, cos th1)`` and ``l2 (-sin th2, cos th2)``: the torques
    are ``T = J^T F``.  The one place sailforce writes J^T (:func:`jacobian` is
    its transpose; :mod:`sailforce.kernel` compiles this same function with
    numba); plain arithmetic, so it takes scalars or arrays alike.
    """
    return (-l3 * sin1, l3 * cos1, -l2 * sin2, l2 * cos2)


#: Poses with |sin(theta1 - theta2)| below this are refused by the force
#: inversion.  sin(2 deg): there the error in F is amplified ~29x relative to
#: a square pose (delta = 90 deg), which no load cell's accuracy survives; the
#: seed's study stays at |delta| >= 7.5 deg.
SINGULAR_SIN_DELTA = float(np.sin(np.radians(2.0)))


def is_singular(sin_delta, min_sin_delta: float = SINGULAR_SIN_DELTA) -> np.ndarray:
    """The singularity predicate, used everywhere: ``|sin(theta1 - theta2)| < min_sin_delta``.

    ``sin_delta`` comes from :func:`sin_delta_from_trig` (or :func:`sin_delta`),
    the same formula as libsail's.
    """
    return np.abs(sin_delta) < min_sin_delta


def singular_poses(theta1, theta2, min_sin_delta: float = SINGULAR_SIN_DELTA) -> np.ndarray:
    """:func:`is_singular` of poses given by their angles [rad]."""
    return is_singular(sin_delta(theta1, theta2), min_sin_delta)


def sin_delta(theta1, theta2) -> np.ndarray:
    """The singularity measure sin(theta1 - theta2).

    det J = -l2 l3 sin(theta1 - theta2) (seed Eq. 9), so the arm is singular
    where this is zero: the parallelogram has collapsed (delta = 0 or pi).
    """
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    return sin_delta_from_trig(np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2))


def sin_delta_from_trig(sin1, cos1, sin2, cos2):
    """sin(theta1 - theta2) = sin1 cos2 - cos1 sin2, from the sines and cosines every caller already has.

    The one formula for the singularity measure, in Python and in libsail
    (``sail_estimate.c``), so that a pose at the threshold gets the same
    verdict everywhere.
    """
    return sin1 * cos2 - cos1 * sin2


def jacobian_condition(arm: Links, theta1, theta2) -> np.ndarray:
    """The 2-norm condition number sigma_max / sigma_min of J; ``inf`` where singular.

    Closed form for a 2x2 matrix with squared Frobenius norm f and determinant
    d: sigma^2 = (f +- sqrt(f^2 - 4 d^2)) / 2.

    >>> from sailforce import Arm
    >>> float(jacobian_condition(Arm(l2=0.45, l3=0.45, l1=0.2, l4=0.45), np.pi / 2, 0.0))
    1.0
    """
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    f = arm.l2**2 + arm.l3**2  # ||J||_F^2: each column is a rotated link vector
    d = arm.l2 * arm.l3 * np.abs(np.sin(theta1 - theta2))
    root = np.sqrt(np.maximum(f * f - 4.0 * d * d, 0.0))
    small = f - root
    with np.errstate(divide="ignore"):
        return np.where(small > 0.0, np.sqrt((f + root) / np.where(small > 0, small, 1.0)), np.inf)


def inverse(arm: Links, x, y, branch: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Joint angles (theta1, theta2) [rad] that put A at (x, y) [m].

    By the law of cosines |A|^2 = l2^2 + l3^2 + 2 l2 l3 cos(delta), with
    delta = theta1 - theta2.  Two assemblies reach each interior point:

    - ``branch=+1`` (default): sin(delta) >= 0, i.e. theta1 is counter-clockwise
      of theta2, as in every pose of the seed's study (theta1 > theta2);
    - ``branch=-1``: sin(delta) <= 0, the mirror assembly.

    Angles are returned wrapped to (-pi, pi].  Raises
    :class:`UnreachablePointError` for points outside the annulus
    |l2 - l3| <= |A| <= l2 + l3.

    >>> from sailforce import Arm
    >>> t1, t2 = inverse(Arm(), 0.3, 0.45)
    >>> np.round([float(t1), float(t2)], 12).tolist()
    [1.570796326795, 0.0]
    """
    if branch not in (1, -1):
        raise ShapeError(f"branch: expected +1 or -1, got {branch!r}")
    x, y = as_float_arrays(x=x, y=y)
    l2, l3 = arm.l2, arm.l3
    r2 = x * x + y * y
    cos_delta = (r2 - l2 * l2 - l3 * l3) / (2.0 * l2 * l3)
    outside = np.abs(cos_delta) > 1.0 + REACH_RTOL
    if np.any(outside):
        first = np.argwhere(outside)[0] if outside.ndim else ()
        idx = tuple(int(i) for i in first)
        px, py = float(x[idx]), float(y[idx])
        where = f" (first at index {idx})" if idx else ""
        raise UnreachablePointError(
            f"{int(np.count_nonzero(outside))} point(s) outside the workspace{where}: "
            f"A = ({px:.6g}, {py:.6g}) m lies at r = {np.hypot(px, py):.6g} m, but this arm "
            f"reaches only {abs(l2 - l3):.6g} m <= r <= {l2 + l3:.6g} m"
        )
    delta = branch * np.arccos(np.clip(cos_delta, -1.0, 1.0))
    theta2 = np.arctan2(y, x) - np.arctan2(l3 * np.sin(delta), l2 + l3 * np.cos(delta))
    theta1 = theta2 + delta
    return _wrap(theta1), _wrap(theta2)


def _wrap(angle: np.ndarray) -> np.ndarray:
    """Wrap to (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


@dataclass(frozen=True)
class Workspace:
    """A sampled joint-space grid with what a designer wants to see at each node.

    Arrays share the grid shape ``(n_theta1, n_theta2)``.
    """

    theta1: np.ndarray  #: [rad]
    theta2: np.ndarray  #: [rad]
    x: np.ndarray  #: end effector x [m]
    y: np.ndarray  #: end effector y [m]
    sin_delta: np.ndarray  #: singularity measure, sin(theta1 - theta2)
    condition: np.ndarray  #: Jacobian condition number (inf where singular)


def workspace(
    arm: Links,
    theta1_range: tuple[float, float] = (0.0, np.pi),
    theta2_range: tuple[float, float] = (-np.pi / 2, np.pi / 2),
    n: int = 181,
) -> Workspace:
    """Sample the workspace on an n x n joint-angle grid (ranges in radians, inclusive).

    The reachable set in Cartesian space is the annulus
    |l2 - l3| <= |A| <= l2 + l3; joint limits cut it down, which is why this
    samples joint space rather than the plane.
    """
    if n < 2:
        raise ShapeError(f"n: expected at least 2 samples per axis, got {n}")
    t1 = np.linspace(*theta1_range, n)
    t2 = np.linspace(*theta2_range, n)
    theta1, theta2 = np.meshgrid(t1, t2, indexing="ij")
    x, y = forward(arm, theta1, theta2)
    return Workspace(
        theta1=theta1,
        theta2=theta2,
        x=x,
        y=y,
        sin_delta=sin_delta(theta1, theta2),
        condition=jacobian_condition(arm, theta1, theta2),
    )
