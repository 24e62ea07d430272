"""The whole robot for structural simulation: geometry, sections, materials,
load cells, joints and motors.

:class:`sailforce.Arm` holds only the link lengths, which is all the
kinematics and rigid statics need; :class:`Robot` adds what the frame model
needs.  Every field has a default, so ``Robot(arm)`` is a complete robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from .adc import ADC
from .arm import Arm
from .errors import GeometryError
from .loadcell import STANDARD_GRAVITY, LoadCell
from .materials import CARBON_STEEL, Material, RectangularSection

JOINT_MODELS = ("pin", "bonded", "spring")
MOTOR_MODELS = ("locked", "gearbox")


#: The passive joints, in the order the frame model lists them.
JOINT_NAMES = ("P1", "P2", "P3")
#: The four links, each of which may have its own section and material.
LINK_NAMES = ("l1", "l2", "l3", "l4")


@dataclass(frozen=True)
class Joint:
    """How one passive joint carries moment.

    - ``pin``: an ideal revolute joint, no moment;
    - ``bonded``: rigid, as SolidWorks' default bonded contact;
    - ``spring``: a rotational spring of ``stiffness`` [N m/rad].
    """

    model: str = "pin"
    stiffness: float = 50.0

    def __post_init__(self) -> None:
        if self.model not in JOINT_MODELS:
            raise GeometryError(f"joints model = {self.model!r}: expected one of {', '.join(JOINT_MODELS)}")
        if not (isinstance(self.stiffness, (int, float)) and math.isfinite(self.stiffness) and self.stiffness >= 0):
            raise GeometryError(f"joints stiffness = {self.stiffness!r} N m/rad must be >= 0 and finite")


@dataclass(frozen=True)
class Joints(Joint):
    """The passive joints P1, P2 and P3: one :class:`Joint` for all, and optional per-joint ones.

    ``model`` and ``stiffness`` serve every joint that ``P1``, ``P2`` or ``P3``
    does not override (a robot file's ``[joints]`` and ``[joints.P1]`` ...).
    """

    P1: Joint | None = None
    P2: Joint | None = None
    P3: Joint | None = None

    def at(self, name: str) -> Joint:
        """The joint at ``name`` (``"P1"``, ``"P2"`` or ``"P3"``): its own, or the shared one."""
        if name not in JOINT_NAMES:
            raise GeometryError(f"joint {name!r}: expected one of {', '.join(JOINT_NAMES)}")
        own = getattr(self, name)
        return own if own is not None else Joint(self.model, self.stiffness)

    @property
    def uniform(self) -> bool:
        """True when every joint has the shared model and stiffness."""
        return len({self.at(name) for name in JOINT_NAMES}) == 1

    @property
    def label(self) -> str:
        """``"bonded"``, or per joint where they differ: ``"P1 spring 170, P2 bonded, P3 pin"``."""
        if self.uniform:
            return self.at(JOINT_NAMES[0]).model
        parts = []
        for name in JOINT_NAMES:
            joint = self.at(name)
            parts.append(f"{name} {joint.model}" + (f" {joint.stiffness:g}" if joint.model == "spring" else ""))
        return ", ".join(parts)


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
class Handle:
    """What the patient holds at A: a point mass on l3."""

    mass: float = 0.0  #: [kg]
    position: float = 1.0  #: along l3 from P2, as a fraction of l3 (1 = at A)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.mass) and self.mass >= 0):
            raise GeometryError(f"handle mass = {self.mass!r} kg must be a non-negative number")
        if not (math.isfinite(self.position) and 0.0 <= self.position <= 1.0):
            raise GeometryError(f"handle position = {self.position!r} must lie between 0 (at P2) and 1 (at A)")


@dataclass(frozen=True)
class Plane:
    """The plane the arm moves in: tilted from horizontal, gravity has a component in it."""

    tilt_deg: float = 0.0  #: [deg] angle between the arm's plane and the horizontal
    axis_deg: float = -90.0  #: [deg] direction in the plane, CCW from +x, in which that component points

    def __post_init__(self) -> None:
        if not (math.isfinite(self.tilt_deg) and 0.0 <= self.tilt_deg <= 90.0):
            raise GeometryError(f"plane tilt_deg = {self.tilt_deg!r} must lie between 0 and 90")
        if not math.isfinite(self.axis_deg):
            raise GeometryError(f"plane axis_deg = {self.axis_deg!r} must be finite")

    @property
    def gravity(self) -> tuple[float, float]:
        """The in-plane gravity vector [m/s^2]: g sin(tilt) along the axis."""
        magnitude = STANDARD_GRAVITY * math.sin(math.radians(self.tilt_deg))
        axis = math.radians(self.axis_deg)
        return magnitude * math.cos(axis), magnitude * math.sin(axis)


@dataclass(frozen=True)
class LinkBody:
    """One link's own section and material; ``None`` keeps the robot's shared one."""

    section: RectangularSection | None = None
    material: Material | None = None


@dataclass(frozen=True)
class LinkBodies:
    """Per-link overrides of the shared link section and material (a robot file's ``[sections.l3]``, ``[materials.l3]``)."""

    l1: LinkBody | None = None
    l2: LinkBody | None = None
    l3: LinkBody | None = None
    l4: LinkBody | None = None


@dataclass(frozen=True)
class Robot:
    """A SAIL arm as a structure.

    Links default to a 25 mm deep, 10 mm thick bar of plain carbon steel
    (seed Table 2; the section is our assumption since Table 1 is garbled).
    ``link_section`` and ``link_material`` serve every link that ``bodies``
    does not override; :meth:`section` and :meth:`material` give each link's.
    """

    arm: Arm = field(default_factory=Arm)
    link_section: RectangularSection = field(default_factory=lambda: RectangularSection(0.025, 0.010))
    link_material: Material = CARBON_STEEL
    loadcell: LoadCell = field(default_factory=LoadCell)
    joints: Joints = field(default_factory=Joints)
    motors: Motors = field(default_factory=Motors)
    handle: Handle = field(default_factory=Handle)
    plane: Plane = field(default_factory=Plane)
    bodies: LinkBodies = field(default_factory=LinkBodies)
    adc: ADC = field(default_factory=ADC)  #: the cells' ADC (sailforce.adc): its rate, filter and noise

    def section(self, link: str) -> RectangularSection:
        """The cross-section of ``link`` (``"l1"`` ... ``"l4"``): its own, or the shared one."""
        own = self._body(link)
        return own.section if own is not None and own.section is not None else self.link_section

    def material(self, link: str) -> Material:
        """The material of ``link``: its own, or the shared one."""
        own = self._body(link)
        return own.material if own is not None and own.material is not None else self.link_material

    def _body(self, link: str) -> LinkBody | None:
        if link not in LINK_NAMES:
            raise GeometryError(f"link {link!r}: expected one of {', '.join(LINK_NAMES)}")
        return getattr(self.bodies, link)

    @property
    def uniform_links(self) -> bool:
        """True when every link has the shared section and material."""
        return all(self.section(n) == self.link_section and self.material(n) == self.link_material for n in LINK_NAMES)

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

    def with_joints(self, model: str) -> Robot:
        """A copy with ``model`` at every joint (per-joint overrides dropped), keeping the spring stiffness."""
        return replace(self, joints=Joints(model, self.joints.stiffness))
