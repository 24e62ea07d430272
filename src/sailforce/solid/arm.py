"""One pose of the arm as a solid: mesh, tie, load, solve, read.

**Joints** (seed Sec. 3.2 modelled "bonded"; we offer three):

- ``bonded``: the bodies fused: every node of both within a hub of
  :data:`BONDED_HUB_FRACTION` x depth of the joint's centre moves as one rigid
  body (``*RIGID BODY``), so the joint passes force and moment;
- ``pin``: the mean translation of one rim equals the other's, two
  ``*EQUATION`` s per joint: force passes, moment does not (the rim nodes are
  equally spaced, so an evenly spread force has no moment about the centre);
- ``spring``: not available in the solid (a rotational spring between rims);
  the error says so.

**Loads.**  Two unit load cases, F = (1, 0) and (0, 1) N at A, each spread
evenly over the handle rim; any phi follows by superposition (as in
:mod:`sailforce.fem.response`).

**Readings.**

- torques: T_i = -sum over the shaft rim of r x RF (RF the reaction the
  clamp exerts), the sign of T = J^T F (seed Eq. 3);
- deflection: the mean displacement of a cell's far face along the link's
  counter-clockwise normal, the frame's ``deflection``;
- relative deflection: far face less near face, what a gauge across the cell sees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kinematics import forward
from ..robot import Robot
from .ccx import Block, Deck, Step, run_ccx, select
from .layout import HANDLE_RIM, HOLE_FRACTION, JOINT_RIMS, MOTOR_RIMS, arm_layout, hole_radius
from .mesh import Mesh, mesh_layout

#: Joint models the solid offers (sailforce.robot.JOINT_MODELS less "spring").
SOLID_JOINTS = ("pin", "bonded")
#: Coincident rim nodes of two bodies are paired within this distance [m].
#: A bonded joint's rigid hub: the nodes of both bodies within this fraction of the shallowest link depth of the
#: joint's centre move as one rigid body.  Two stacked plates bonded over their overlap are far stiffer there than
#: either bar; the frame takes the joint as a rigid point.  Measured against the frame with the fitted cell at
#: theta1 = 75 deg, theta2 = 0, 4 mm mesh: 0.2 (the rim only) reads +2.4 % / +1.1 %, 0.35 -1.2 % / -1.1 %, 0.5 -3.1 % / -2.6 %.
BONDED_HUB_FRACTION = 0.35


@dataclass(frozen=True)
class SolidResponse:
    """Unit-load responses of the solid at one pose: the last axis is the load case (Fx, Fy) = 1 N.

    - ``torques``: ``(2, 2)``, T_i per unit F_j [N m/N];
    - ``deflection``: ``(2, 2)``, far-face deflection of cell i [m/N];
    - ``relative``: ``(2, 2)``, far face less near face [m/N];
    - ``moment_balance``: ``(2,)``, |T1 + T2 - A x F| per unit load [N m/N] (equilibrium, zero up to print rounding);
    - ``stresses``: ``(m, 3, 2)`` element-mean (sxx, syy, sxy) [Pa/N] and ``triangles`` ``(m, 3, 2)`` corners [m],
      when asked for.
    """

    theta1: float
    theta2: float
    torques: np.ndarray
    deflection: np.ndarray
    relative: np.ndarray
    moment_balance: np.ndarray
    dofs: int
    stresses: np.ndarray | None = None
    triangles: np.ndarray | None = None

    def as_dict(self) -> dict:
        return {"theta1": self.theta1, "theta2": self.theta2, "torques": self.torques.tolist(),
                "deflection": self.deflection.tolist(), "relative": self.relative.tolist(),
                "moment_balance": self.moment_balance.tolist(), "dofs": self.dofs}  # fmt: skip

    @classmethod
    def from_dict(cls, data: dict) -> SolidResponse:
        return cls(float(data["theta1"]), float(data["theta2"]), np.array(data["torques"]),
                   np.array(data["deflection"]), np.array(data["relative"]), np.array(data["moment_balance"]),
                   int(data["dofs"]))  # fmt: skip


def check_joints(robot: Robot) -> None:
    """Refuse joint models the solid does not offer, naming the joint."""
    for name, _, _ in JOINT_RIMS:
        model = robot.joints.at(name).model
        if model not in SOLID_JOINTS:
            raise InputError(f"joint {name} is {model!r}: the solid model offers {' and '.join(SOLID_JOINTS)} joints; "
                            "use --joints pin or --joints bonded")  # fmt: skip


def solve_pose(robot: Robot, theta1: float, theta2: float, *, cell_depth: float, mesh_size: float,
               stresses: bool = False, workdir=None) -> SolidResponse:  # fmt: skip
    """Mesh and solve ``robot`` at (theta1, theta2) [rad] for the two unit loads (module docstring).

    ``cell_depth`` [m] is the load cell's calibrated in-plane depth (:func:`sailforce.solid.cell.calibrate_depth`).
    """
    check_joints(robot)
    layout = arm_layout(robot, theta1, theta2, cell_depth)
    mesh = mesh_layout(layout, mesh_size)
    sections = {p.name: (p.material.E * p.modulus_scale, p.material.nu, p.thickness) for p in layout.parts}
    rim = mesh.sets[HANDLE_RIM]
    cases = []
    for direction in (0, 1):
        loads = tuple((int(n), direction + 1, 1.0 / len(rim)) for n in rim)
        cases.append(Step(loads, forces=MOTOR_RIMS, displacements=tuple(f.name for f in layout.faces),
                          stresses=("EALL",) if stresses else ()))  # fmt: skip
    extra, rigid, sets = [], [], {}
    top = int(mesh.ids.max())
    hub = BONDED_HUB_FRACTION * hole_radius(robot) / HOLE_FRACTION
    for joint, first, _ in JOINT_RIMS:
        if robot.joints.at(joint).model == "bonded":
            centre = mesh.coordinates(mesh.sets[first])[:, :2].mean(axis=0)
            extra += [(top + 1, *centre), (top + 2, *centre)]
            near = np.linalg.norm(mesh.nodes[:, :2] - centre, axis=1) <= hub
            sets[f"J_{joint}"] = tuple(int(n) for n in mesh.ids[near])
            rigid.append((f"J_{joint}", top + 1, top + 2))
            top += 2
    deck = Deck(sections, clamped=MOTOR_RIMS, equations=tuple(_joint_equations(robot, mesh)), steps=tuple(cases),
                extra_nodes=tuple(extra), rigid=tuple(rigid), extra_sets=sets)
    blocks = run_ccx(mesh, deck, workdir=workdir)

    torques = np.zeros((2, 2))
    deflection = np.zeros((2, 2))
    relative = np.zeros((2, 2))
    for j in range(2):
        for i, rim_name in enumerate(MOTOR_RIMS):
            block = select(blocks, "forces", rim_name, j + 1)
            xy = mesh.coordinates(block.ids)[:, :2]
            torques[i, j] = -np.sum(xy[:, 0] * block.values[:, 1] - xy[:, 1] * block.values[:, 0])
        for i, angle in enumerate((theta1, theta2)):
            normal = np.array([-math.sin(angle), math.cos(angle)])
            near, far = (_mean(select(blocks, "displacements", f"C{i + 1}{side}", j + 1)) @ normal for side in "AB")
            deflection[i, j] = far
            relative[i, j] = far - near
    a = np.array(forward(robot.arm, theta1, theta2), dtype=float)  # the end effector A (seed Eq. 1)
    moment = np.array([-a[1], a[0]])  # A x (1, 0) and A x (0, 1)
    balance = np.abs(torques.sum(axis=0) - moment)
    field = triangles = None
    if stresses:
        field, triangles = _element_stresses(blocks, mesh)
    return SolidResponse(float(theta1), float(theta2), torques, deflection, relative, balance, mesh.dofs, field, triangles)


def _mean(block: Block) -> np.ndarray:
    return block.values[:, :2].mean(axis=0)


def _joint_equations(robot: Robot, mesh: Mesh):
    """The ``*EQUATION`` terms tying each joint's two rims (module docstring)."""
    for joint, first, second in JOINT_RIMS:
        a, b = mesh.sets[first], mesh.sets[second]
        if robot.joints.at(joint).model == "pin":
            for dof in (1, 2):
                yield tuple((int(n), dof, 1.0 / len(a)) for n in a) + tuple((int(n), dof, -1.0 / len(b)) for n in b)


def _element_stresses(blocks: list[Block], mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Element-mean (sxx, syy, sxy) per unit load ``(m, 3, 2)`` and each element's corner triangle ``(m, 3, 2)``."""
    conn = np.concatenate(list(mesh.elements.values()))
    per_case = []
    for j in (1, 2):
        block = select(blocks, "stresses", "EALL", j)
        ids = block.ids - 1  # elements are numbered 1.. in the order of mesh.elements
        sums = np.zeros((len(conn), 3))
        np.add.at(sums, ids, block.values[:, [0, 1, 3]])
        counts = np.bincount(ids, minlength=len(conn))[:, None]
        per_case.append(sums / np.maximum(counts, 1))
    corners = mesh.coordinates(conn[:, :3].ravel())[:, :2].reshape(-1, 3, 2)
    return np.stack(per_case, axis=-1), corners
