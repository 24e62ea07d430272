"""Statics of the SAIL arm: joint torques from end-effector force and back.

With the motors locked (q_dot = 0) and the plane horizontal (no gravity), the
seed's dynamic model (Eq. 2) reduces to T = J^T F (Eq. 3).  T is the torque
the end-effector force *induces* at the motor axes B, counter-clockwise
positive; the motors' holding torque is -T.

Departure from the seed (docs/errata.md, Statics): the seed's inverse of J^T
(Eq. 10) is the transpose of the true inverse, and Eqs. 11-12 inherit that
error; Eq. 13 (polar form) is garbled.  Here

    (J^T)^-1 = 1 / (l2 l3 sin(th1 - th2)) [[-l2 cos th2,  l3 cos th1],
                                           [-l2 sin th2,  l3 sin th1]]

and the polar form is |F| = hypot(Fx, Fy), phi = atan2(Fy, Fx).
"""

from __future__ import annotations

import os
from typing import Literal, overload

import numpy as np

from . import kernel
from ._blocks import for_each_block
from ._validate import as_float_arrays
from .errors import SingularPoseError
from .kinematics import SINGULAR_SIN_DELTA, Links, is_singular, sin_delta, singular_poses  # noqa: F401 (re-exported)

#: Poses per block in :func:`end_effector_force`: every temporary of a block
#: stays in L2 cache.  Measured on 10^7 poses (numpy back-end): ~12 M poses/s
#: blocked against 3.5-9 M poses/s unblocked, where fresh 80 MB temporaries page-fault.
BLOCK = 1 << 15

#: Threads for inputs of several blocks (the kernel releases the GIL).
THREADS = min(4, os.cpu_count() or 1)


def joint_torques(arm: Links, theta1, theta2, fx, fy) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques T = J^T F [N m] induced by the end-effector force (fx, fy) [N].

    Seed Eqs. 3, 6 and 7, which reduce to T1 = l3 |F| sin(phi - theta1) and
    T2 = l2 |F| sin(phi - theta2) (docs/errata.md).

    >>> from sailforce import Arm
    >>> t1, t2 = joint_torques(Arm(), np.pi / 2, 0.0, 0.0, 10.0)
    >>> round(float(t1), 12), round(float(t2), 12)
    (0.0, 3.0)
    """
    theta1, theta2, fx, fy = as_float_arrays(theta1=theta1, theta2=theta2, fx=fx, fy=fy)
    c1, s1 = np.cos(theta1), np.sin(theta1)
    c2, s2 = np.cos(theta2), np.sin(theta2)
    t1 = arm.l3 * (c1 * fy - s1 * fx)
    t2 = arm.l2 * (c2 * fy - s2 * fx)
    return t1, t2


@overload
def end_effector_force(arm: Links, theta1, theta2, t1, t2, *, on_singular: Literal["raise"] = ...,
                       min_sin_delta: float = ...) -> tuple[np.ndarray, np.ndarray]: ...  # fmt: skip
@overload
def end_effector_force(arm: Links, theta1, theta2, t1, t2, *, on_singular: Literal["mask"],
                       min_sin_delta: float = ...) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...  # fmt: skip
def end_effector_force(
    arm: Links,
    theta1,
    theta2,
    t1,
    t2,
    *,
    on_singular: Literal["raise", "mask"] = "raise",
    min_sin_delta: float = SINGULAR_SIN_DELTA,
):
    """End-effector force F = (J^T)^-1 T [N] from joint torques (t1, t2) [N m].

    Uses the corrected inverse (module docstring, docs/errata.md), not the seed's
    Eq. 10-12, computed by the force kernel (:mod:`sailforce.kernel`).  Where
    |sin(theta1 - theta2)| < ``min_sin_delta``:

    - ``on_singular="raise"`` (default) raises :class:`SingularPoseError`
      naming the first such pose and the threshold, and the result is ``(fx, fy)``;
    - ``on_singular="mask"`` returns ``(fx, fy, singular)`` with NaN in fx and
      fy where the boolean mask ``singular`` is True.

    >>> from sailforce import Arm
    >>> fx, fy = end_effector_force(Arm(), np.pi / 2, 0.0, 0.0, 3.0)
    >>> round(float(fx), 12), round(float(fy), 12)
    (0.0, 10.0)
    """
    if on_singular not in ("raise", "mask"):
        raise ValueError(f"on_singular: expected 'raise' or 'mask', got {on_singular!r}")
    theta1, theta2, t1, t2 = as_float_arrays(theta1=theta1, theta2=theta2, t1=t1, t2=t2)
    shape = theta1.shape
    flat = [np.ravel(a) for a in (theta1, theta2, t1, t2)]
    fx, fy = np.empty(theta1.size), np.empty(theta1.size)
    singular = np.empty(theta1.size, dtype=bool)

    def run(start: int) -> None:
        block = slice(start, start + BLOCK)
        th1, th2, tq1, tq2 = (a[block] for a in flat)
        fx[block], fy[block], singular[block] = kernel.force_from_torques(arm.l2, arm.l3, th1, th2, tq1, tq2, min_sin_delta)

    for_each_block(theta1.size, BLOCK, THREADS, run)
    if on_singular == "raise" and singular.any():
        raise_singular_pose(theta1, theta2, singular.reshape(shape), min_sin_delta)
    fx, fy = fx.reshape(shape)[()], fy.reshape(shape)[()]
    if on_singular == "raise":
        return fx, fy
    return fx, fy, singular.reshape(shape)[()]


def raise_singular_pose(theta1, theta2, singular, min_sin_delta) -> None:
    """Raise :class:`SingularPoseError` naming the first pose flagged in ``singular`` and the threshold."""
    idx = tuple(int(i) for i in np.argwhere(singular)[0]) if singular.ndim else ()
    where = f" (first at index {idx})" if idx else ""
    sd = sin_delta(theta1[idx], theta2[idx])
    raise SingularPoseError(
        f"{int(np.count_nonzero(singular))} singular pose(s){where}: "
        f"theta1 = {np.degrees(theta1[idx]):.6g} deg, theta2 = {np.degrees(theta2[idx]):.6g} deg "
        f"gives |sin(theta1 - theta2)| = {abs(sd):.3g}, below the threshold "
        f"{min_sin_delta:.3g}; the parallelogram is collapsed there. "
        f"Pass on_singular='mask' to get NaN and a mask instead."
    )


def polar(fx, fy) -> tuple[np.ndarray, np.ndarray]:
    """Magnitude [N] and direction phi [rad, CCW from +x] of a force (replaces seed Eq. 13).

    >>> m, phi = polar(0.0, -2.0)
    >>> float(m), float(np.degrees(phi))
    (2.0, -90.0)
    """
    fx, fy = as_float_arrays(fx=fx, fy=fy)
    return np.hypot(fx, fy), np.arctan2(fy, fx)


def cartesian(magnitude, phi) -> tuple[np.ndarray, np.ndarray]:
    """Force components (fx, fy) [N] from magnitude [N] and direction phi [rad]."""
    magnitude, phi = as_float_arrays(magnitude=magnitude, phi=phi)
    return magnitude * np.cos(phi), magnitude * np.sin(phi)
