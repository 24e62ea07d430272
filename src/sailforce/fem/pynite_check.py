"""The same SAIL arm frame solved by PyNite, an established FE library, for cross-checks.

PyNite (``pip install pynitefea``, MIT licence) is a test-time dependency:
this module imports it only when called.  PyNite has no shear deformation,
so compare it with ``build_model(robot, shear_deformation=False)``.

The planar frame is embedded in 3-D: every node is held out of plane (DZ, RX,
RY), and each member gets Iy = Iz so the in-plane axis needs no bookkeeping.
A pin is a moment release (Ry, Rz) at the member end that meets the joint
(l4 at P1 and P3, l3 at P2); bonded joints release nothing; a gearbox is a
rotational support spring at B1 and B2.  Spring joints are not built, since
PyNite's springs are axial only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, MissingExtraError
from .model import MEMBERS, NODES, ArmModel, node_positions

LOAD_CASES = ("Fx", "Fy")

#: Members whose end meets a pin, by joint model "pin": (member, end).
PIN_RELEASES = (("l4", "i"), ("l4", "j"), ("l3 inner", "i"))


@dataclass(frozen=True)
class PyNiteResult:
    """Displacements ``(n_nodes, 3, 2)`` (DX, DY, RZ per load case) and reactions at B1, B2 ``(2, 3, 2)``."""

    displacements: np.ndarray
    reactions: np.ndarray


def solve_with_pynite(model: ArmModel, theta1: float, theta2: float) -> PyNiteResult:
    """Build and solve the arm in PyNite at one pose, for a unit Fx and a unit Fy at A."""
    try:
        from Pynite import FEModel3D
    except ImportError:  # pragma: no cover - exercised only without the dev extra
        raise MissingExtraError("the PyNite cross-check needs `pip install pynitefea` (in the dev extra)") from None
    robot = model.robot
    if model.shear_deformation:
        raise InputError("PyNite has no shear deformation: build the model with shear_deformation=False")
    if robot.joints.model == "spring" or not robot.joints.uniform:
        raise InputError("the PyNite cross-check covers pin and bonded joints only, the same at P1, P2 and P3")

    fe = FEModel3D()
    positions = node_positions(model, theta1, theta2)
    for node in NODES:
        x, y = positions[node]
        fe.add_node(node, float(x), float(y), 0.0)
        fe.def_support(node, support_DZ=True, support_RX=True, support_RY=True)
    for base in ("B1", "B2"):
        locked = robot.motors.model == "locked"
        fe.def_support(base, True, True, True, True, True, locked)
        if not locked:
            fe.def_support_spring(base, "RZ", robot.motors.stiffness)

    E_ref = robot.link_material.E  # one modulus; each member's section carries its own rigidities
    fe.add_material("ref", E_ref, E_ref / 2.6, 0.3, 1.0)
    EA = model.frame.local_k[:, 0, 0] * model.lengths
    EI = model.frame.local_k[:, 2, 2] * model.lengths / 4.0  # 4 EI / L for Euler-Bernoulli
    for e, (name, i, j, _, _) in enumerate(MEMBERS):
        second_moment = EI[e] / E_ref
        fe.add_section(f"s{e}", EA[e] / E_ref, second_moment, second_moment, 2.0 * second_moment)
        fe.add_member(name, i, j, "ref", f"s{e}")
    if robot.joints.model == "pin":
        flags: dict[str, dict[str, bool]] = {}
        for member, end in PIN_RELEASES:  # def_releases resets unnamed flags: one call per member
            flags.setdefault(member, {}).update({f"Ry{end}": True, f"Rz{end}": True})
        for member, released in flags.items():
            fe.def_releases(member, **released)

    for case, direction in zip(LOAD_CASES, ("FX", "FY")):
        fe.add_node_load("A", direction, 1.0, case=case)
        fe.add_load_combo(case, {case: 1.0})
    fe.analyze_linear(check_stability=False)

    displacements = np.array(
        [[[getattr(fe.nodes[n], k)[c] for c in LOAD_CASES] for k in ("DX", "DY", "RZ")] for n in NODES]
    )
    reactions = np.array(
        [[[getattr(fe.nodes[n], k)[c] for c in LOAD_CASES] for k in ("RxnFX", "RxnFY", "RxnMZ")] for n in ("B1", "B2")]
    )
    return PyNiteResult(displacements, reactions)
