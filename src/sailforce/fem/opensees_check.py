"""The same SAIL arm frame in OpenSees (OpenSeesPy), the strongest open frame solver, for cross-checks and speed.

OpenSeesPy (``pip install openseespy``, in the dev extra) is imported only
when called.  Its licence allows research, education and internal use:
sailforce calls it in its tests and benchmarks and neither ships nor needs it.

It is used as its users would use it well, one model for every pose
(:class:`OpenSeesArm`):

- a 2-D model (``-ndm 2 -ndf 3``), one node per body end: a pin joint is two
  nodes at one point, their translations tied by ``equalDOF``; a bonded joint
  ties the rotation too; a spring joint is a ``zeroLength`` rotational spring
  between the two; a gearbox is a ``zeroLength`` rotational spring to a
  fixed node;
- ``elasticBeamColumn`` members (Euler-Bernoulli) or ``ElasticTimoshenkoBeam``
  (with the members' shear rigidity), E = G = 1 and the sections' rigidities
  as A, I and Avy;
- ``constraints Transformation``, ``numberer RCM``, ``system ProfileSPD``
  (a profile Cholesky), ``algorithm Linear -factorOnce``,
  ``integrator LoadControl 1``;
- the two load cases as two steps of one analysis: a unit Fx at A whose time
  series is 1 at t = 1 and 0 at t = 2, a unit Fy the other way round.  The
  frame is linear, so the second step's displacement is K^-1 Fy however the
  first left it, and ``-factorOnce`` shares one factorisation;
- each pose: with ``zeroLength`` springs, ``reset()`` (the displacements
  back to zero: ``updateElementDomain`` takes a spring's present deformation
  as its new zero, so a spring joint or a gearbox would be off by tens of per
  cent without it), ``setNodeCoord`` on every node, then ``updateElementDomain()`` (without it
  OpenSees keeps the members' old geometry, silently), a fresh
  ``algorithm Linear -factorOnce`` (one factorisation for the new geometry),
  the time back to 0, and two ``analyze(1)``.

Load cells with a measured compliance matrix are not built.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, MissingExtraError
from ..robot import JOINT_NAMES
from .model import JOINT_SLOTS, JOINTS, MEMBERS, NODES, ArmModel, _rigidities, node_positions

_GROUND_TAG = 99
#: The pose [rad] the model is built at, before :meth:`OpenSeesArm.move` puts it anywhere.
START_POSE = (np.pi / 2, 0.0)


@dataclass(frozen=True)
class OpenSeesResult:
    """Displacements ``(n_nodes, 3, 2)`` (u, v, r of each node of :data:`~sailforce.fem.model.NODES`, the joints'
    first body's rotation) and member end forces ``(E, 6, 2)`` in local axes, per unit Fx and Fy at A."""

    displacements: np.ndarray
    end_forces: np.ndarray


def _opensees():
    try:
        import openseespy.opensees as ops
    except ImportError:  # pragma: no cover - exercised only without the dev extra
        raise MissingExtraError("the OpenSees cross-check needs `pip install openseespy` (in the dev extra)") from None
    return ops


class OpenSeesArm:
    """One OpenSees model of ``model``'s arm, moved to each pose in turn (module docstring).  OpenSees keeps one
    domain per process: make one at a time."""

    def __init__(self, model: ArmModel):
        robot = model.robot
        if robot.loadcell.compliance == "matrix":
            raise InputError("the OpenSees cross-check builds beam load cells only, not a measured compliance matrix")
        ops = self.ops = _opensees()
        self.model = model
        ops.wipe()
        ops.model("basic", "-ndm", 2, "-ndf", 3)
        tags = {name: k + 1 for k, name in enumerate(NODES)}
        for k, (first, second) in enumerate(JOINTS):  # a joint's first body keeps its node, the second has its own
            tags[first] = tags[first.split("/")[0]]
            tags[second] = len(NODES) + 1 + k
        self.tags = tags
        self._moving = sorted({tag: name.split("/")[0] for name, tag in tags.items()}.items())  # (tag, node), each once
        start = node_positions(model, START_POSE[0], START_POSE[1])  # members of zero length cannot be made
        for tag, node in self._moving:
            ops.node(tag, *(float(x) for x in start[node]))
        locked = robot.motors.model == "locked"
        self.springs = not locked or any(robot.joints.at(name).model == "spring" for name in JOINT_NAMES)
        for base in ("B1", "B2"):
            ops.fix(tags[base], 1, 1, 1 if locked else 0)
        if not locked:
            ops.node(_GROUND_TAG, 0.0, 0.0)
            ops.fix(_GROUND_TAG, 1, 1, 1)
            ops.uniaxialMaterial("Elastic", 1, robot.motors.stiffness)
            for k, base in enumerate(("B1", "B2")):
                ops.element("zeroLength", 100 + k, _GROUND_TAG, tags[base], "-mat", 1, "-dir", 3)
        for k, (name, (first, second)) in enumerate(zip(JOINT_NAMES, JOINTS)):
            joint = robot.joints.at(name)
            a, b = tags[first], tags[second]
            if joint.model == "bonded":
                ops.equalDOF(a, b, 1, 2, 3)
                continue
            ops.equalDOF(a, b, 1, 2)
            if joint.model == "spring":
                ops.uniaxialMaterial("Elastic", 10 + k, joint.stiffness)
                ops.element("zeroLength", 200 + k, a, b, "-mat", 10 + k, "-dir", 3)
        ops.geomTransf("Linear", 1)
        EA, EI, kGA = _rigidities(robot, model.shear_deformation)
        self.members = []
        for e, (name, i, j, _, _) in enumerate(MEMBERS):
            ti, tj = tags[JOINT_SLOTS.get((name, "i"), i)], tags[JOINT_SLOTS.get((name, "j"), j)]
            if model.shear_deformation:
                ops.element("ElasticTimoshenkoBeam", e + 1, ti, tj, 1.0, 1.0, EA[e], EI[e], kGA[e], 1)
            else:
                ops.element("elasticBeamColumn", e + 1, ti, tj, EA[e], 1.0, EI[e], 1)
            self.members.append(e + 1)
        for case, (fx, fy) in enumerate(((1.0, 0.0), (0.0, 1.0)), start=1):
            values = (0.0, 1.0, 0.0) if case == 1 else (0.0, 0.0, 1.0)
            ops.timeSeries("Path", case, "-time", 0.0, 1.0, 2.0, "-values", *values)
            ops.pattern("Plain", case, case)
            ops.load(tags["A"], fx, fy, 0.0)
        ops.constraints("Transformation")
        ops.numberer("RCM")
        ops.system("ProfileSPD")
        ops.algorithm("Linear", "-factorOnce")
        ops.integrator("LoadControl", 1.0)
        ops.analysis("Static")

    def move(self, theta1: float, theta2: float) -> None:
        """Put every node at the pose, and the members' geometry with them."""
        ops = self.ops
        positions = node_positions(self.model, theta1, theta2)
        if self.springs:  # displacements to zero first: updateElementDomain takes a zeroLength's deformation as its zero
            ops.reset()
        for tag, node in self._moving:
            x, y = positions[node]
            ops.setNodeCoord(tag, 1, float(x))
            ops.setNodeCoord(tag, 2, float(y))
        ops.updateElementDomain()
        ops.algorithm("Linear", "-factorOnce")  # factorise once more, for this geometry
        ops.setTime(0.0)

    def step(self) -> None:
        """The next load case (Fx, then Fy)."""
        if self.ops.analyze(1) != 0:
            raise InputError("OpenSees could not solve the frame at this pose")

    def cells(self) -> tuple[list[float], list[float], list[float], list[float]]:
        """What the cells' readings need, for the case just solved: each cell's local end forces and the
        displacement of its far face."""
        ops, tags = self.ops, self.tags
        return (ops.eleResponse(2, "localForce"), ops.eleResponse(5, "localForce"), ops.nodeDisp(tags["C1b"]),
                ops.nodeDisp(tags["C2b"]))  # fmt: skip

    def everything(self) -> tuple[np.ndarray, np.ndarray]:
        """Every node's displacement ``(n_nodes, 3)`` and every member's local end forces ``(E, 6)``."""
        ops, tags = self.ops, self.tags
        u = np.array([ops.nodeDisp(tags[node]) for node in NODES])
        forces = np.array([ops.eleResponse(tag, "localForce") for tag in self.members])
        return u, forces


def solve_poses(arm: OpenSeesArm, theta1, theta2) -> tuple[np.ndarray, np.ndarray]:
    """The cells' signals at every pose, as :meth:`~sailforce.fem.response.ArmResponse.signal` gives them: bridge
    [mV/V per N] and far-face deflection [m/N], each ``(N, 2, 2)``, from one model moved pose by pose."""
    theta1, theta2 = np.asarray(theta1, dtype=float).ravel(), np.asarray(theta2, dtype=float).ravel()
    raw = np.empty((theta1.size, 2, 2, 9))  # pose, case, cell, (6 local end forces, u, v, r of the far face)
    for k in range(theta1.size):
        arm.move(theta1[k], theta2[k])
        for case in range(2):
            arm.step()
            f1, f2, u1, u2 = arm.cells()
            raw[k, case, 0, :6], raw[k, case, 1, :6], raw[k, case, 0, 6:], raw[k, case, 1, 6:] = f1, f2, u1, u2
    f = raw.transpose(0, 2, 3, 1)  # (N, cell, value, case)
    axis = np.stack([theta1, theta2], axis=-1)[..., None]  # each cell's link axis
    deflection = -np.sin(axis) * f[:, :, 6] + np.cos(axis) * f[:, :, 7]
    bridge = arm.model.robot.loadcell.bridge_signal(f[:, :, 4], f[:, :, 3], 0.5 * (f[:, :, 5] - f[:, :, 2]))
    return bridge, deflection


def solve_with_opensees(model: ArmModel, theta1: float, theta2: float) -> OpenSeesResult:
    """Build the arm in OpenSees and solve it at one pose, for a unit Fx and a unit Fy at A."""
    arm = OpenSeesArm(model)
    arm.move(theta1, theta2)
    cases = []
    for _ in range(2):
        arm.step()
        cases.append(arm.everything())
    arm.ops.wipe()
    return OpenSeesResult(np.stack([c[0] for c in cases], axis=-1), np.stack([c[1] for c in cases], axis=-1))
