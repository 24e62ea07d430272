"""What a user reads off the frame solution: torques at B, load-cell signals,
internal forces and stresses.

Everything is computed for a unit Fx and a unit Fy at the end effector (the
last axis, of length 2), so the response to any force follows by
superposition: a sweep over phi costs two solves per pose, not one per angle.

Sign conventions:

- ``torques[..., i, :]`` is T_i, the torque the end-effector force induces at
  motor i, the same convention as T = J^T F; the motor's holding torque (the
  support reaction) is its negative.
- A member's internal forces are those its node j exerts on it, in its local
  axes (x from i to j, y counter-clockwise normal): axial N (tension
  positive), shear V, and bending moment M(x) = M_j - V (L - x).
- ``deflection``: the transverse displacement of a load cell's far face (away
  from B), along the link's counter-clockwise normal [m] (the seed's surrogate).
- ``bridge``: the bridge output [mV/V] of :meth:`sailforce.loadcell.LoadCell.bridge_signal`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_float_arrays
from ..errors import InputError
from ..loadcell import READINGS
from ..robot import Robot
from .frame import solve, solve_many
from .model import LOADCELL_MEMBERS, MEMBER_LINK, MEMBERS, ROOT_MEMBERS, ArmModel, build_model

TRANSDUCTIONS = READINGS  #: the cells' readings (:data:`sailforce.loadcell.READINGS`)
TRANSDUCTION_UNITS = {"deflection": "m", "bridge": "mV/V"}


@dataclass(frozen=True)
class ArmResponse:
    """Unit-load responses for a batch of poses, batch dimensions leading.

    - ``torques``: ``(..., 2, 2)``, T_i per unit F_j [N m/N];
    - ``deflection``: ``(..., 2, 2)``, far-face deflection of cell i per unit F_j [m/N];
    - ``cell_forces``: ``(..., 2, 3, 2)``, (N, V, M at the centre) in cell i per unit F_j;
    - ``end_forces``: ``(..., E, 6, 2)``, member end forces in local axes;
    - ``displacements``: ``(..., n_dofs, 2)``, global axes [m/N].
    """

    model: ArmModel
    theta1: np.ndarray
    theta2: np.ndarray
    torques: np.ndarray
    deflection: np.ndarray
    cell_forces: np.ndarray
    end_forces: np.ndarray
    displacements: np.ndarray

    def signal(self, transduction: str) -> np.ndarray:
        """Load-cell signal per unit force, ``(..., 2, 2)``, in :data:`TRANSDUCTION_UNITS` per N."""
        if transduction == "deflection":
            return self.deflection
        if transduction == "bridge":
            cell = self.model.robot.loadcell
            axial, shear, moment = (self.cell_forces[..., k, :] for k in range(3))
            return cell.bridge_signal(shear, axial, moment)
        raise InputError(f"transduction = {transduction!r}: expected one of {', '.join(TRANSDUCTIONS)}")


def simulate(robot: Robot, theta1, theta2, *, shear_deformation: bool = True) -> ArmResponse:
    """Solve the SAIL frame of ``robot`` at every pose, for a unit Fx and a unit Fy at A.

    ``theta1`` and ``theta2`` [rad] broadcast to the batch shape.
    """
    model = build_model(robot, shear_deformation=shear_deformation)
    return simulate_model(model, theta1, theta2)


def simulate_model(model: ArmModel, theta1, theta2) -> ArmResponse:
    """:func:`simulate` for an already built model (saves rebuilding it in loops over robots)."""
    return simulate_models([model], theta1, theta2)[0]


def simulate_models(models, theta1, theta2) -> list[ArmResponse]:
    """:func:`simulate_model` for each of ``models`` at the same poses: one stacked solve when their frames
    share a topology (:func:`~sailforce.fem.frame.solve_many`; a fit's finite-difference Jacobian)."""
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    shape = theta1.shape
    angles = np.stack([theta1.ravel(), theta2.ravel()], axis=-1)  # (N, 2): the frame's two axes
    models = list(models)
    same = len(models) > 1 and all(m.dof == models[0].dof for m in models[1:])
    if same:
        solutions = solve_many([m.frame for m in models], angles, models[0].loads)
    else:
        solutions = [solve(m.frame, angles, m.loads) for m in models]
    cos, sin = np.cos(angles)[..., None], np.sin(angles)[..., None]  # (N, 2, 1): each link's axis

    def batch(a: np.ndarray) -> np.ndarray:
        return a.reshape(shape + a.shape[1:])

    out = []
    for model, solution in zip(models, solutions):
        dof = model.dof
        # The motor at B_i holds the inner member of link i, whose i-end moment is
        # the support reaction there (node equilibrium); T_i is its negative.
        torques = -solution.end_forces[:, list(ROOT_MEMBERS), 2]
        u = solution.displacements[:, [dof["C1b.u"], dof["C2b.u"]]]
        v = solution.displacements[:, [dof["C1b.v"], dof["C2b.v"]]]
        deflection = -sin * u + cos * v  # the far face's local v: row v of the member transformation T times (u, v)
        f = solution.end_forces[:, list(LOADCELL_MEMBERS)]  # (N, 2, 6, 2)
        cell_forces = np.stack([f[:, :, 3], f[:, :, 4], 0.5 * (f[:, :, 5] - f[:, :, 2])], axis=2)
        out.append(ArmResponse(model=model, theta1=theta1, theta2=theta2, torques=batch(torques), deflection=batch(deflection),
                               cell_forces=batch(cell_forces), end_forces=batch(solution.end_forces),
                               displacements=batch(solution.displacements)))  # fmt: skip
    return out


@dataclass(frozen=True)
class MemberStresses:
    """Internal forces and beam-theory stresses at points along every member.

    Arrays are ``(..., E, P)``: P equally spaced points from each member's
    node i (first) to node j (last).  N and V are constant along a member
    without interior load and M is linear, so the values are exact.
    ``von_mises`` is the larger of the extreme fibre (|N|/A + |M|/S, no shear
    there) and the neutral axis (sqrt((N/A)^2 + 3 (1.5 V/A)^2)) of a solid
    rectangle.  Load cells use their solid block, so their stress is nominal:
    check their load against capacity instead.
    """

    axial: np.ndarray  #: N [N], tension positive
    shear: np.ndarray  #: V [N]
    moment: np.ndarray  #: M [N m]
    normal_stress: np.ndarray  #: |N|/A + |M|/S at the extreme fibre [Pa]
    von_mises: np.ndarray  #: [Pa]
    yield_strength: np.ndarray  #: (E,) [Pa]

    @property
    def safety_factor(self) -> np.ndarray:
        """Yield strength over the largest von Mises stress of each member, ``(..., E)``."""
        worst = self.von_mises.max(axis=-1)
        with np.errstate(divide="ignore"):
            return np.where(worst > 0, self.yield_strength / np.where(worst > 0, worst, 1.0), np.inf)


def member_stresses(response: ArmResponse, fx, fy, points: int = 2) -> MemberStresses:
    """Internal forces and stresses of every member for the end-effector force (fx, fy) [N].

    ``points`` >= 2 samples per member, ends included (2: just the ends).
    """
    fx = np.asarray(fx, dtype=float)[..., None, None]  # broadcast over (member, end-force component)
    fy = np.asarray(fy, dtype=float)[..., None, None]
    f = response.end_forces[..., 0] * fx + response.end_forces[..., 1] * fy  # (..., E, 6)
    t = np.linspace(0.0, 1.0, max(int(points), 2))
    ones = np.ones_like(t)
    axial = f[..., 3:4] * ones
    shear = f[..., 4:5] * ones
    moment = -f[..., 2:3] * (1.0 - t) + f[..., 5:6] * t
    area, modulus, strength = (a[:, None] for a in _section_table(response.model.robot))
    sigma_axial = np.abs(axial) / area
    normal = sigma_axial + np.abs(moment) / modulus
    tau = 1.5 * np.abs(shear) / area
    von_mises = np.maximum(normal, np.sqrt(sigma_axial**2 + 3.0 * tau**2))
    return MemberStresses(axial, shear, moment, normal, von_mises, strength[:, 0])


def _section_table(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    cell = robot.loadcell.block
    rows = [
        (cell.area, cell.section_modulus, robot.loadcell.material.yield_strength)
        if kind == "cell"
        else (robot.section(name).area, robot.section(name).section_modulus, robot.material(name).yield_strength)
        for (*_, kind), name in zip(MEMBERS, MEMBER_LINK)
    ]
    return tuple(np.array(column) for column in zip(*rows))
