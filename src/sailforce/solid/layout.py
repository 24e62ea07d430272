"""The arm as plane regions: what the solid model meshes, in plain numbers (no gmsh here).

Each link is a bar of its section's depth along its centre line, run on by
half a depth past its end joints so that a joint hole has material around it.
Every joint is a hole of radius :data:`HOLE_FRACTION` x the shallowest link's depth:

- at B, the motor shaft: the hole's rim is clamped (the motors are locked);
- at P1, P2 and P3, the pin: the two bodies' rims are tied (``solid.arm``);
- at A, the handle: the end-effector force is spread over the rim.

l1 and l2 are each three *parts*: the link up to the load cell's near face,
the load cell (a block of the calibrated depth, ``solid.cell``), and the link
beyond its far face.  The parts of one link share nodes on their interfaces;
the bodies do not (they overlap at B and at the joints, as stacked plates do).

Thicknesses out of the plane differ between the links and the cells.  In plane
stress a part's stiffness is E t, so each part is meshed at its body's link
thickness with its modulus scaled by t_part / t_body (:attr:`Part.modulus_scale`):
the parts that share nodes share a thickness, as CalculiX's expansion of
plane-stress elements into a layer of solids requires.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..kinematics import joint_positions
from ..materials import Material
from ..robot import Robot

#: Joint-hole radius as a fraction of the link depth: 5 mm in a 25 mm bar, leaving 7.5 mm of rim.
HOLE_FRACTION = 0.2
#: How far a link runs on past its end joints, as a fraction of its depth (a rounded boss's half-width).
END_FRACTION = 0.5


@dataclass(frozen=True)
class Hole:
    """A joint hole in a part: its centre along the part's axis [m], radius [m], and its rim's set name."""

    at: float
    radius: float
    name: str


@dataclass(frozen=True)
class Part:
    """A rectangle along the axis of angle ``angle`` [rad] from ``origin``: x in [start, stop], |y| <= depth / 2."""

    name: str  #: element set (upper case: CalculiX returns names in upper case)
    body: str  #: "l1" ... "l4"
    origin: tuple[float, float]
    angle: float
    start: float
    stop: float
    depth: float
    thickness: float  #: the body's meshed thickness [m]
    material: Material
    modulus_scale: float = 1.0  #: the part's own thickness / ``thickness`` (module docstring)
    holes: tuple[Hole, ...] = ()

    def point(self, x: float, y: float = 0.0) -> tuple[float, float]:
        """The plane point at (x, y) in the part's axes."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        return self.origin[0] + c * x - s * y, self.origin[1] + s * x + c * y


@dataclass(frozen=True)
class Face:
    """A load cell face: the interface between the cell and a link part, at ``at`` along its axis."""

    name: str
    part: str
    at: float
    depth: float


@dataclass(frozen=True)
class Layout:
    """All parts, and the cell faces whose displacements are the readings."""

    parts: tuple[Part, ...]
    faces: tuple[Face, ...]  #: C1A, C1B, C2A, C2B (near and far face of each cell)

    def part(self, name: str) -> Part:
        return next(p for p in self.parts if p.name == name)


def arm_layout(robot: Robot, theta1: float, theta2: float, cell_depth: float) -> Layout:
    """The parts of ``robot`` at the pose (theta1, theta2) [rad], the cells ``cell_depth`` [m] deep."""
    arm, cell = robot.arm, robot.loadcell
    radius = hole_radius(robot)
    parts: list[Part] = []
    faces: list[Face] = []
    for i, (link, length, angle) in enumerate((("l1", arm.l1, theta1), ("l2", arm.l2, theta2)), start=1):
        section, material = robot.section(link), robot.material(link)
        h, t = section.depth, section.thickness
        end = END_FRACTION * h
        near = cell.position * length - cell.length / 2
        far = near + cell.length
        joint = f"P{i}_L{i}"
        parts += [
            Part(f"L{i}A", link, (0.0, 0.0), angle, 0.0, near, h, t, material),
            Part(f"C{i}", link, (0.0, 0.0), angle, near, far, cell_depth, t, cell.material, cell.block.thickness / t),
            Part(f"L{i}B", link, (0.0, 0.0), angle, far, length + end, h, t, material, 1.0, (Hole(length, radius, joint),)),
        ]  # fmt: skip
        faces += [Face(f"B{i}", f"L{i}A", 0.0, h),
                  Face(f"C{i}A", f"C{i}", near, cell_depth), Face(f"C{i}B", f"C{i}", far, cell_depth)]
    joints = joint_positions(arm, theta1, theta2)
    p1 = (float(joints["P1"][0]), float(joints["P1"][1]))
    p2 = (float(joints["P2"][0]), float(joints["P2"][1]))
    h3, h4 = robot.section("l3"), robot.section("l4")
    parts.append(Part("L3", "l3", p2, theta1, -END_FRACTION * h3.depth, arm.l3 + END_FRACTION * h3.depth, h3.depth,
                      h3.thickness, robot.material("l3"), 1.0,
                      (Hole(0.0, radius, "P2_L3"), Hole(arm.l1, radius, "P3_L3"),
                       Hole(arm.l3, radius, "A"))))  # fmt: skip
    parts.append(Part("L4", "l4", p1, theta2, -END_FRACTION * h4.depth, arm.l2 + END_FRACTION * h4.depth, h4.depth,
                      h4.thickness, robot.material("l4"), 1.0,
                      (Hole(0.0, radius, "P1_L4"), Hole(arm.l2, radius, "P3_L4"))))  # fmt: skip
    return Layout(tuple(parts), tuple(faces))


def hole_radius(robot: Robot) -> float:
    """Every joint hole's radius [m]: :data:`HOLE_FRACTION` of the shallowest link, so that the rims a joint ties match."""
    return HOLE_FRACTION * min(robot.section(name).depth for name in ("l1", "l2", "l3", "l4"))


#: Which rims each passive joint ties: (joint of sailforce.robot.JOINT_NAMES, rim of the first body, of the second).
JOINT_RIMS = (("P1", "P1_L1", "P1_L4"), ("P2", "P2_L2", "P2_L3"), ("P3", "P3_L3", "P3_L4"))
#: The motor shaft rims, clamped: motor 1 holds l1, motor 2 holds l2.
MOTOR_RIMS = ("B1", "B2")
#: The handle rim, where the end-effector force is applied.
HANDLE_RIM = "A"
