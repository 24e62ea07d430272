"""sailforce: end-effector force sensing via arm-integrated load cells (SAIL).

Conventions
-----------
- SI units inside: metres, newtons, newton-metres, pascals.
- Angles are radians in the Python API, counter-clockwise from +x; degrees
  appear only at the edges (CLI flags and file columns ending in ``_deg``).
- Batch dimensions lead: vectors are ``(..., 2)``, matrices ``(..., 2, 2)``.
- T = J^T F is the torque the end-effector force induces at the motors,
  counter-clockwise positive; a motor's holding torque is -T.

>>> from sailforce import Arm
>>> arm = Arm()
>>> t1, t2 = arm.joint_torques(1.0, 0.2, 3.0, -4.0)
>>> fx, fy = arm.end_effector_force(1.0, 0.2, t1, t2)
>>> round(float(fx), 12), round(float(fy), 12)
(3.0, -4.0)
"""

from importlib.metadata import PackageNotFoundError, version

from .arm import Arm
from .errors import (
    GeometryError,
    RobotFileError,
    SailError,
    SingularPoseError,
    UnreachablePointError,
)
from .statics import SINGULAR_SIN_DELTA

try:
    __version__ = version("sailforce")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = [
    "Arm",
    "GeometryError",
    "RobotFileError",
    "SailError",
    "SingularPoseError",
    "UnreachablePointError",
    "SINGULAR_SIN_DELTA",
    "__version__",
]
