"""The whole robot for structural simulation: geometry, sections, materials,
load cells, joints and motors.

:class:`sailforce.Arm` holds only the link lengths, which is all the
kinematics and rigid statics need; :class:`Robot` adds what the frame model
needs.  Every field has a default, so ``Robot(arm)`` is a complete robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from .arm import Arm
from .errors import GeometryError
from .loadcell import LoadCell
from .materials import CARBON_STEEL, Material, RectangularSection

JOINT_MODELS = ("pin", "bonded", "spring")
MOTOR_MODELS = ("locked", "gearbox")


@dataclass(frozen=True)
class Joints:
    """How the passive joints P1, P2 and P3 carry moment.

    - ``pin``: an ideal revolute joint, no moment;
    - ``bonded``: rigid, as SolidWorks' default bonded contact;
    - ``spring``: a rotational spring of ``stiffness`` [N m/rad].
    """

    model: str = "pin"
    stiffness: float = 50.0

    def __post_init__(self) -> None:
        if self.model not in JOINT_MODELS:
            raise GeometryError(f"joints model = {self.model!r}: expected one of {', '.join(JOINT_MODELS)}")
        if not (math.isfinite(self.stiffness) and self.stiffness >= 0):
            raise GeometryError(f"joints stiffness = {self.stiffness!r} N m/rad must be >= 0 and finite")


@dataclass(frozen=True)
class Motors:
    """How the motors at B hold the driven links.

    - ``locked``: clamped (the seed's assumption of high motor impedance);
    - ``gearbox``: a torsional stiffness ``stiffness`` [N m/rad] to ground.
    """

    model: str = "locked"
    stiffness: float = 1.0e4

    def __post_init__(self) -> None:
        if self.model not in MOTOR_MODELS:
            raise GeometryError(f"motors model = {self.model!r}: expected one of {', '.join(MOTOR_MODELS)}")
        if not (math.isfinite(self.stiffness) and self.stiffness > 0):
            raise GeometryError(f"motors stiffness = {self.stiffness!r} N m/rad must be positive and finite")


@dataclass(frozen=True)
class Robot:
    """A SAIL arm as a structure.

    Links default to a 25 mm deep, 10 mm thick bar of plain carbon steel
    (seed Table 2; the section is our assumption since Table 1 is garbled).
    """

    arm: Arm = field(default_factory=Arm)
    link_section: RectangularSection = field(default_factory=lambda: RectangularSection(0.025, 0.010))
    link_material: Material = CARBON_STEEL
    loadcell: LoadCell = field(default_factory=LoadCell)
    joints: Joints = field(default_factory=Joints)
    motors: Motors = field(default_factory=Motors)

    def __post_init__(self) -> None:
        cell = self.loadcell
        for name, length in (("l1", self.arm.l1), ("l2", self.arm.l2)):
            near = cell.position * length - cell.length / 2
            far = cell.position * length + cell.length / 2
            if near <= 0.0 or far >= length:
                raise GeometryError(
                    f"the {cell.length * 1e3:g} mm load-cell gap centred at {cell.position:g} x {name} "
                    f"({cell.position * length:.4g} m) does not fit inside {name} = {length:g} m"
                )

    def with_joints(self, model: str) -> "Robot":
        """A copy with another joint model, keeping the spring stiffness."""
        return replace(self, joints=replace(self.joints, model=model))
