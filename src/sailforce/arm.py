"""The robot: a frozen dataclass of link lengths, with the kinematics and statics as methods.

The methods are thin wrappers over the pure functions in
:mod:`sailforce.kinematics` and :mod:`sailforce.statics`, so that the public
API reads ``arm.forward(theta1, theta2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import kinematics, statics
from .errors import GeometryError

#: Relative tolerance for the parallelogram condition l4 == l2: lengths typed
#: to nine significant figures must agree, a real mismatch (>= 1 um on 0.3 m)
#: must not.
PARALLELOGRAM_RTOL = 1e-9

#: Link lengths outside this range [m] are refused: far beyond any planar
#: robot, and products of such lengths (l2 l3 sin delta, second moments of
#: area) overflow or underflow float64 in the statics and the FE.
LINK_LENGTH_RANGE = (1e-4, 100.0)


@dataclass(frozen=True)
class Arm:
    """Link lengths of a SAIL parallelogram arm [m].

    - ``l1``: B to P1, driven by theta1;
    - ``l2``: B to P2, driven by theta2;
    - ``l3``: P2 through P3 to the end effector A, parallel to l1 (|P2 P3| = l1);
    - ``l4``: P1 to P3, parallel to l2, so l4 must equal l2.

    The defaults are *our assumption*, not the seed's (its Table 1 is garbled,
    docs/errata.md): a desk-top rehabilitation arm with a 0.75 m reach.

    >>> Arm()
    Arm(l1=0.2, l2=0.3, l3=0.45, l4=0.3)
    >>> Arm(l4=0.31)
    Traceback (most recent call last):
    ...
    sailforce.errors.GeometryError: l4 = 0.31 m must equal l2 = 0.3 m: l4 is the side of the parallelogram opposite l2
    """

    l1: float = 0.20
    l2: float = 0.30
    l3: float = 0.45
    l4: float = 0.30

    def __post_init__(self) -> None:
        for name in ("l1", "l2", "l3", "l4"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise GeometryError(f"{name}: expected a length in metres, got {value!r}")
            if not math.isfinite(value) or value <= 0.0:
                raise GeometryError(f"{name} = {value!r} m: link lengths must be positive and finite")
            low, high = LINK_LENGTH_RANGE
            if not low <= value <= high:
                raise GeometryError(f"{name} = {value:g} m: link lengths must lie between {low:g} m and {high:g} m")
            object.__setattr__(self, name, float(value))
        if not math.isclose(self.l4, self.l2, rel_tol=PARALLELOGRAM_RTOL):
            raise GeometryError(
                f"l4 = {self.l4:g} m must equal l2 = {self.l2:g} m: "
                "l4 is the side of the parallelogram opposite l2"
            )
        if self.l3 <= self.l1:
            raise GeometryError(
                f"l3 = {self.l3:g} m must exceed l1 = {self.l1:g} m: l3 runs from P2 "
                f"through P3 (at {self.l1:g} m, since |P2 P3| = l1) out to the end effector A"
            )

    # -- kinematics (seed Eqs. 1, 4) ------------------------------------
    def forward(self, theta1, theta2):
        """End-effector position (x, y) [m]; see :func:`sailforce.kinematics.forward`."""
        return kinematics.forward(self, theta1, theta2)

    def joint_positions(self, theta1, theta2):
        """P1, P2, P3 and A, each ``(..., 2)`` [m]; see :func:`sailforce.kinematics.joint_positions`."""
        return kinematics.joint_positions(self, theta1, theta2)

    def jacobian(self, theta1, theta2):
        """J, shape ``(..., 2, 2)``; see :func:`sailforce.kinematics.jacobian`."""
        return kinematics.jacobian(self, theta1, theta2)

    def inverse(self, x, y, branch: int = 1):
        """(theta1, theta2) [rad] reaching (x, y); see :func:`sailforce.kinematics.inverse`."""
        return kinematics.inverse(self, x, y, branch=branch)

    def condition(self, theta1, theta2):
        """Condition number of J; see :func:`sailforce.kinematics.jacobian_condition`."""
        return kinematics.jacobian_condition(self, theta1, theta2)

    def workspace(self, **kwargs):
        """Sampled workspace; see :func:`sailforce.kinematics.workspace`."""
        return kinematics.workspace(self, **kwargs)

    @property
    def reach(self) -> tuple[float, float]:
        """Inner and outer radius of the reachable annulus [m]."""
        return abs(self.l2 - self.l3), self.l2 + self.l3

    # -- statics (seed Eqs. 3, 6-8, corrected per docs/errata.md) --------------
    def joint_torques(self, theta1, theta2, fx, fy):
        """T = J^T F [N m]; see :func:`sailforce.statics.joint_torques`."""
        return statics.joint_torques(self, theta1, theta2, fx, fy)

    def end_effector_force(self, theta1, theta2, t1, t2, **kwargs):
        """F = J^-T T [N]; see :func:`sailforce.statics.end_effector_force`."""
        return statics.end_effector_force(self, theta1, theta2, t1, t2, **kwargs)
