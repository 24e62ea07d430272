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

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np

from . import kernel
from ._blocks import BLOCK, THREADS, for_each_block
from ._validate import as_float_arrays
from .errors import InputError, SingularPoseError
from .kinematics import SINGULAR_SIN_DELTA, Links, is_singular, sin_delta, singular_poses, transposed_jacobian_entries  # noqa: F401 (re-exported)


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
    m00, m01, m10, m11 = transposed_jacobian_entries(arm.l2, arm.l3, np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2))
    return m00 * fx + m01 * fy, m10 * fx + m11 * fy


#: What ``on_singular`` may be: raise :class:`SingularPoseError`, or mask the singular poses with NaN.
ON_SINGULAR = ("raise", "mask")


def check_on_singular(on_singular: str) -> None:
    """Refuse an ``on_singular`` that is not one of :data:`ON_SINGULAR`."""
    if on_singular not in ON_SINGULAR:
        raise InputError(f"on_singular: expected 'raise' or 'mask', got {on_singular!r}")


@dataclass(frozen=True)
class ForceResult:
    """An end-effector force at each pose: ``fx``, ``fy`` [N] and the boolean mask ``singular``.

    What :func:`end_effector_force` and :func:`sailforce.estimate.estimate_force`
    return, whatever ``on_singular``.  It unpacks as those functions' tuples
    did, so that ``fx, fy = ...`` (``on_singular="raise"``) and ``fx, fy,
    singular = ...`` (``"mask"``) keep working: ``masked`` says which.
    """

    fx: np.ndarray
    fy: np.ndarray
    singular: np.ndarray
    masked: bool = False  #: unpacks as (fx, fy, singular) when True, else as (fx, fy)

    def _values(self) -> tuple[np.ndarray, ...]:
        return (self.fx, self.fy, self.singular) if self.masked else (self.fx, self.fy)

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter(self._values())

    def __len__(self) -> int:
        return len(self._values())

    def __getitem__(self, index):
        return self._values()[index]


def force_result(theta1, theta2, fx, fy, singular, on_singular: str, min_sin_delta: float) -> ForceResult:
    """The result of a force inversion: raise for singular poses (``"raise"``), or mask them (``"mask"``)."""
    if on_singular == "raise" and np.any(singular):
        raise_singular_pose(theta1, theta2, np.asarray(singular), min_sin_delta)
    return ForceResult(fx, fy, singular, masked=on_singular == "mask")


def end_effector_force(
    arm: Links,
    theta1,
    theta2,
    t1,
    t2,
    *,
    on_singular: Literal["raise", "mask"] = "raise",
    min_sin_delta: float = SINGULAR_SIN_DELTA,
) -> ForceResult:
    """End-effector force F = (J^T)^-1 T [N] from joint torques (t1, t2) [N m].

    Uses the corrected inverse (module docstring, docs/errata.md), not the seed's
    Eq. 10-12, computed by the force kernel (:mod:`sailforce.kernel`).  Where
    |sin(theta1 - theta2)| < ``min_sin_delta``:

    - ``on_singular="raise"`` (default) raises :class:`SingularPoseError`
      naming the first such pose and the threshold;
    - ``on_singular="mask"`` gives NaN in fx and fy where the boolean mask
      ``singular`` is True.

    The result is a :class:`ForceResult` (``.fx``, ``.fy``, ``.singular``),
    which unpacks as ``fx, fy`` or, masked, as ``fx, fy, singular``.

    >>> from sailforce import Arm
    >>> fx, fy = end_effector_force(Arm(), np.pi / 2, 0.0, 0.0, 3.0)
    >>> round(float(fx), 12), round(float(fy), 12)
    (0.0, 10.0)
    """
    check_on_singular(on_singular)
    theta1, theta2, t1, t2 = as_float_arrays(theta1=theta1, theta2=theta2, t1=t1, t2=t2)
    shape = theta1.shape
    flat = [np.ravel(a) for a in (theta1, theta2, t1, t2)]
    fx, fy = np.empty(theta1.size), np.empty(theta1.size)
    singular = np.empty(theta1.size, dtype=bool)

    def run(start: int) -> None:
        block = slice(start, start + BLOCK)
        th1, th2, tq1, tq2 = (a[block] for a in flat)
        fx[block], fy[block], singular[block] = kernel.force_from_torques(arm.l2, arm.l3, th1, th2, tq1, tq2, min_sin_delta,
                                                                          theta1.size)  # fmt: skip

    for_each_block(theta1.size, BLOCK, THREADS, run)
    return force_result(theta1, theta2, fx.reshape(shape)[()], fy.reshape(shape)[()], singular.reshape(shape)[()], on_singular,
                        min_sin_delta)  # fmt: skip


#: What a singular-pose error suggests to a Python caller.
MASK_HINT = " Pass on_singular='mask' to get NaN and a mask instead."


def singular_pose_error(theta1, theta2, singular, min_sin_delta, hint: str = MASK_HINT) -> SingularPoseError:
    """The :class:`SingularPoseError` naming the first pose flagged in ``singular`` and the threshold: the one wording."""
    theta1, theta2, singular = np.broadcast_arrays(np.asarray(theta1, float), np.asarray(theta2, float), np.asarray(singular))
    idx = tuple(int(i) for i in np.argwhere(singular)[0]) if singular.ndim else ()
    where = f" (first at index {idx})" if idx else ""
    sd = sin_delta(theta1[idx], theta2[idx])
    return SingularPoseError(
        f"{int(np.count_nonzero(singular))} singular pose(s){where}: "
        f"theta1 = {np.degrees(theta1[idx]):.6g} deg, theta2 = {np.degrees(theta2[idx]):.6g} deg "
        f"gives |sin(theta1 - theta2)| = {abs(sd):.3g}, below the threshold "
        f"{min_sin_delta:.3g}; the parallelogram is collapsed there.{hint}"
    )


def raise_singular_pose(theta1, theta2, singular, min_sin_delta) -> None:
    """Raise :func:`singular_pose_error`."""
    raise singular_pose_error(theta1, theta2, singular, min_sin_delta)


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
