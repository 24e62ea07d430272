"""The SAIL arm as a 2-D frame.

Ten nodes: B1 and B2 (the two motor shafts, both at B), the near and far
faces of each load cell (C1a, C1b, C2a, C2b), P1, P2, P3 and the end effector
A.  Nine members, each a single exact Timoshenko element:

=============  ======  ======  =========  ==========
member         from    to      axis       section
=============  ======  ======  =========  ==========
l1 inner       B1      C1a     theta1     link
load cell 1    C1a     C1b     theta1     load cell
l1 outer       C1b     P1      theta1     link
l2 inner       B2      C2a     theta2     link
load cell 2    C2a     C2b     theta2     load cell
l2 outer       C2b     P2      theta2     link
l3 inner       P2      P3      theta1     link
l3 outer       P3      A       theta1     link
l4             P1      P3      theta2     link
=============  ======  ======  =========  ==========

At each passive joint (P1, P2, P3) the two bodies that meet have rotations of
their own, tied by the joint model: ``pin`` leaves them independent,
``bonded`` makes them one DOF, ``spring`` joins them by a rotational spring.
l3 is one continuous body through P3.  At B both translations are held; the
rotation is held (``locked`` motors) or sprung to ground (``gearbox``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kinematics import joint_positions
from ..robot import JOINT_NAMES, Robot
from .elements import flexibility_stiffness, local_stiffness, shear_parameter
from .frame import GROUND, Frame, make_frames

NODES = ("B1", "B2", "C1a", "C1b", "P1", "C2a", "C2b", "P2", "P3", "A")

#: (name, node i, node j, axis 0 = theta1 / 1 = theta2, section kind)
MEMBERS = (
    ("l1 inner", "B1", "C1a", 0, "link"),
    ("load cell 1", "C1a", "C1b", 0, "cell"),
    ("l1 outer", "C1b", "P1", 0, "link"),
    ("l2 inner", "B2", "C2a", 1, "link"),
    ("load cell 2", "C2a", "C2b", 1, "cell"),
    ("l2 outer", "C2b", "P2", 1, "link"),
    ("l3 inner", "P2", "P3", 0, "link"),
    ("l3 outer", "P3", "A", 0, "link"),
    ("l4", "P1", "P3", 1, "link"),
)
#: The link each member belongs to (its section and material, :meth:`~sailforce.robot.Robot.section`)
MEMBER_LINK = ("l1", "l1", "l1", "l2", "l2", "l2", "l3", "l3", "l4")
LOADCELL_MEMBERS = (1, 4)  #: member index of load cell 1 and 2
ROOT_MEMBERS = (0, 3)  #: the members held by motor 1 and 2 at B
MEMBER_AXIS = np.array([axis for _, _, _, axis, _ in MEMBERS])

#: Rotation slots at the passive joints: (node, body) -> slot; the member ends
#: not listed use their node's own rotation.
JOINT_SLOTS = {("l1 outer", "j"): "P1/l1", ("l4", "i"): "P1/l4",
               ("l2 outer", "j"): "P2/l2", ("l3 inner", "i"): "P2/l3",
               ("l3 inner", "j"): "P3/l3", ("l3 outer", "i"): "P3/l3", ("l4", "j"): "P3/l4"}  # fmt: skip
JOINTS = (("P1/l1", "P1/l4"), ("P2/l2", "P2/l3"), ("P3/l3", "P3/l4"))  #: the bodies each joint of JOINT_NAMES joins


@dataclass(frozen=True)
class ArmModel:
    """A :class:`Robot` turned into a :class:`Frame`, with the names needed to read results."""

    robot: Robot
    frame: Frame
    lengths: np.ndarray  #: (E,) member lengths [m]
    offsets: np.ndarray  #: (E,) distance of each member's node i from B along its link body [m]
    dof: dict  #: named DOFs: "A.u", "A.v", "B1.r", ...
    shear_deformation: bool

    @property
    def loads(self) -> np.ndarray:
        """``(n_dofs, 2)``: a unit Fx and a unit Fy at the end effector A."""
        loads = np.zeros((self.frame.n_dofs, 2))
        loads[self.dof["A.u"], 0] = 1.0
        loads[self.dof["A.v"], 1] = 1.0
        return loads


def member_lengths(robot: Robot) -> np.ndarray:
    """Lengths of the nine members [m], in :data:`MEMBERS` order."""
    arm, cell = robot.arm, robot.loadcell
    parts = []
    for link in (arm.l1, arm.l2):
        centre = cell.position * link
        parts += [centre - cell.length / 2, cell.length, link - centre - cell.length / 2]
    return np.array(parts + [arm.l1, arm.l3 - arm.l1, arm.l2])


def _member_offsets(lengths: np.ndarray) -> np.ndarray:
    """Where each member starts along its body, measured from B (or from P1/P2 for l3, l4)."""
    return np.array([0.0, lengths[0], lengths[0] + lengths[1],
                     0.0, lengths[3], lengths[3] + lengths[4],
                     0.0, lengths[6], 0.0])  # fmt: skip


def _rigidities(robot: Robot, shear_deformation: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    def link(name: str) -> tuple[float, float, float]:
        section, material = robot.section(name), robot.material(name)
        return (material.E * section.area, material.E * section.second_moment,
                section.shear_coefficient(material.nu) * material.G * section.area)  # fmt: skip

    cell = robot.loadcell
    loadcell = (cell.axial_rigidity, cell.bending_rigidity, cell.shear_rigidity)
    rows = np.array([loadcell if kind == "cell" else link(name) for (*_, kind), name in zip(MEMBERS, MEMBER_LINK)])
    EA, EI, kGA = rows.T
    if not shear_deformation:
        kGA = np.full_like(kGA, np.inf)
    return EA, EI, kGA


def build_model(robot: Robot, *, shear_deformation: bool = True) -> ArmModel:
    """Build the frame for ``robot``.  ``shear_deformation=False`` gives Euler-Bernoulli members."""
    return build_models([robot], shear_deformation=shear_deformation)[0]


def build_models(robots, *, shear_deformation: bool = True) -> list[ArmModel]:
    """:func:`build_model` for each of ``robots``; those whose joints and motors are modelled alike share one
    layout of DOFs, and their stiffness bases are assembled as one stack (a fit's finite-difference Jacobian)."""
    robots = list(robots)
    out: list[ArmModel | None] = [None] * len(robots)
    groups: dict[tuple, list[int]] = {}
    for k, robot in enumerate(robots):
        key = (robot.motors.model, *(robot.joints.at(name).model for name in JOINT_NAMES))
        groups.setdefault(key, []).append(k)
    for members in groups.values():
        layout = _layout(robots[members[0]])
        numbers = [_numbers(robots[k], layout, shear_deformation) for k in members]
        frames = make_frames(layout.n_dofs, 2, layout.element_dofs, MEMBER_AXIS, np.stack([n[1] for n in numbers]),
                             layout.fixed, layout.springs, np.array([n[2] for n in numbers]).reshape(len(members), -1))  # fmt: skip
        for k, (lengths, _, _), frame in zip(members, numbers, frames):
            out[k] = ArmModel(robots[k], frame, lengths, _member_offsets(lengths), layout.dof, shear_deformation)
    return out  # type: ignore[return-value]


@dataclass(frozen=True)
class _Layout:
    """The DOFs of a robot's frame, which its joints' and motors' models decide (not their numbers)."""

    dof: dict
    element_dofs: list
    n_dofs: int
    fixed: np.ndarray
    springs: list  #: (DOF, DOF or GROUND) of each spring
    spring_keys: list  #: which stiffness each spring has: "motors" or a joint's name


def _layout(robot: Robot) -> _Layout:
    dof: dict[str, int] = {}
    for node in NODES:
        dof[f"{node}.u"], dof[f"{node}.v"] = len(dof), len(dof) + 1
    slot = {f"{node}.r": f"{node}.r" for node in NODES if node not in ("P1", "P2", "P3")}
    for body_slot in JOINT_SLOTS.values():
        slot[body_slot] = body_slot
    for name, (first, second) in zip(JOINT_NAMES, JOINTS):
        if robot.joints.at(name).model == "bonded":
            slot[second] = first
    for name in dict.fromkeys(slot.values()):
        dof[name] = len(dof)
    for name, target in slot.items():
        dof[name] = dof[target]

    element_dofs = []
    for name, i, j, _, _ in MEMBERS:
        ri = JOINT_SLOTS.get((name, "i"), f"{i}.r")
        rj = JOINT_SLOTS.get((name, "j"), f"{j}.r")
        element_dofs.append([dof[f"{i}.u"], dof[f"{i}.v"], dof[ri], dof[f"{j}.u"], dof[f"{j}.v"], dof[rj]])

    n_dofs = max(dof.values()) + 1
    fixed = np.zeros(n_dofs, dtype=bool)
    fixed[[dof["B1.u"], dof["B1.v"], dof["B2.u"], dof["B2.v"]]] = True
    springs, keys = [], []
    if robot.motors.model == "locked":
        fixed[[dof["B1.r"], dof["B2.r"]]] = True
    else:
        for motor in ("B1.r", "B2.r"):
            springs.append((dof[motor], GROUND))
            keys.append("motors")
    for name, (first, second) in zip(JOINT_NAMES, JOINTS):
        if robot.joints.at(name).model == "spring":
            springs.append((dof[first], dof[second]))
            keys.append(name)
    return _Layout(dof, element_dofs, n_dofs, fixed, springs, keys)


def _numbers(robot: Robot, layout: _Layout, shear_deformation: bool) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """A robot's member lengths, members' local stiffness ``(E, 6, 6)`` and its springs' stiffnesses."""
    lengths = member_lengths(robot)
    EA, EI, kGA = _rigidities(robot, shear_deformation)
    local_k = local_stiffness(EA, EI, lengths, shear_parameter(EI, kGA, lengths))
    if robot.loadcell.compliance == "matrix":  # the cell as its measured 2x2 cantilever flexibility
        for member in LOADCELL_MEMBERS:
            local_k[member] = flexibility_stiffness(EA[member], lengths[member], robot.loadcell.flexibility)
    spring_k = [robot.motors.stiffness if key == "motors" else robot.joints.at(key).stiffness for key in layout.spring_keys]
    return lengths, local_k, spring_k


def node_positions(model: ArmModel, theta1, theta2) -> dict[str, np.ndarray]:
    """Undeformed node positions ``(..., 2)`` [m] for drawing."""
    joints = joint_positions(model.robot.arm, theta1, theta2)  # P1, P2, P3, A (seed Eq. 1)
    arm, L = model.robot.arm, model.lengths
    u1, u2 = joints["P1"] / arm.l1, joints["P2"] / arm.l2
    zero = np.zeros_like(u1)
    return {
        "B1": zero, "B2": zero,
        "C1a": L[0] * u1, "C1b": (L[0] + L[1]) * u1, "P1": joints["P1"],
        "C2a": L[3] * u2, "C2b": (L[3] + L[4]) * u2, "P2": joints["P2"],
        "P3": joints["P3"], "A": joints["A"],
    }  # fmt: skip
