"""The load cell in the solid: its depth calibrated to the datasheet, and its in-situ compliance fitted for the frame.

**Depth** (:func:`calibrate_depth`).  The cell is a block of the datasheet's
length and out-of-plane thickness whose in-plane depth d is chosen so that,
under the datasheet's own test (near face clamped, the rated load F_cap spread
over the far face), the far face moves the rated deflection delta_cap on
average.  Beam theory gives the first d (E I = F_cap L^3 / (3 delta_cap), the
frame's datasheet cell, :mod:`sailforce.loadcell`); since delta ~ d^-3, each
ccx solve corrects it by d <- d (delta / delta_cap)^(1/3) until it holds within
:data:`DEPTH_RTOL`.

**In-situ compliance** (:func:`fit_compliance`).  In the arm the cell is not
clamped: its faces are bonded to link bars far deeper than itself, and the bar
around each junction yields too (the solid's readings then differ
from the datasheet beam by -20 % to +35 %).  A solid of the cell between two
link stubs, the near stub's root clamped, is loaded at the far stub's tip by a
shear V and a moment M.  The tip's (v, r) per (V, M) is the chain

    C_tip = sum_s A_s^T C_s A_s,   A_s = [[1, 0], [x_tip - x_s, 1]]

over the segments s (stub, cell, stub) ending at x_s, each C_s its own
cantilever flexibility (:attr:`sailforce.loadcell.LoadCell.flexibility`).  The
stubs' C_s are the frame's link beams, so the cell's in-situ C_cell follows by
subtracting them: the 2x2 the frame's ``matrix`` cell takes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ToolError
from ..loadcell import LoadCell
from ..robot import Robot
from .ccx import Deck, Step, run_ccx, select
from .layout import Face, Layout, Part
from .mesh import mesh_layout

#: Relative tolerance on the calibrated cell's rated deflection.
DEPTH_RTOL = 1e-3
#: ccx solves allowed to reach :data:`DEPTH_RTOL` (each cuts the error about tenfold).
DEPTH_ITERATIONS = 8
#: Length of each link stub in the cell-fit solid, in link depths: St-Venant end effects decay within one.
STUB_DEPTHS = 2.0


@dataclass(frozen=True)
class CellDepth:
    """A calibrated cell: ``depth`` [m] and the rated deflection it gives [m] (``achieved``) after ``solves`` runs."""

    depth: float
    achieved: float
    target: float
    solves: int


def calibrate_depth(cell: LoadCell, mesh_size: float) -> CellDepth:
    """The block depth that reproduces ``cell``'s rated deflection under its datasheet test (module docstring)."""
    b = cell.block.thickness
    depth = float(np.cbrt(12.0 * cell.bending_rigidity / (cell.material.E * b)))
    target = cell.rated_deflection
    for solve in range(1, DEPTH_ITERATIONS + 1):
        achieved = _datasheet_test(cell, depth, mesh_size)
        if abs(achieved / target - 1.0) < DEPTH_RTOL:
            return CellDepth(depth, achieved, target, solve)
        depth *= (achieved / target) ** (1.0 / 3.0)
    raise ToolError(f"the load cell's depth did not settle within {DEPTH_ITERATIONS} solves "
                    f"(last {depth * 1e3:.4g} mm gives {achieved * 1e3:.4g} mm, not {target * 1e3:.4g} mm)")  # fmt: skip


def _datasheet_test(cell: LoadCell, depth: float, mesh_size: float) -> float:
    """Mean far-face deflection [m] of a ``depth``-deep block, near face clamped, F_cap spread over the far face."""
    part = Part("CELL", "cell", (0.0, 0.0), 0.0, 0.0, cell.length, depth, cell.block.thickness, cell.material)
    layout = Layout((part,), (Face("NEAR", "CELL", 0.0, depth), Face("FAR", "CELL", cell.length, depth)))
    mesh = mesh_layout(layout, mesh_size)
    far = mesh.sets["FAR"]
    step = Step(tuple((int(n), 2, cell.capacity_N / len(far)) for n in far), displacements=("FAR",))
    deck = Deck({"CELL": (cell.material.E, cell.material.nu, cell.block.thickness)}, clamped=("NEAR",), steps=(step,))
    return float(select(run_ccx(mesh, deck), "displacements", "FAR", 1).values[:, 1].mean())


@dataclass(frozen=True)
class CellFit:
    """The cell's in-situ flexibility in link ``link``: ``compliance`` (2, 2) [[m/N, 1/N], [1/N, 1/(N m)]].

    ``tip`` is the stub-cell-stub solid's measured tip flexibility; ``datasheet`` the frame's beam cell's, for comparison.
    """

    link: str
    compliance: np.ndarray
    tip: np.ndarray
    datasheet: np.ndarray
    depth: CellDepth


def fit_compliance(robot: Robot, depth: CellDepth, mesh_size: float, link: str = "l1") -> CellFit:
    """The in-situ 2x2 compliance of ``robot``'s load cell mounted in ``link`` (module docstring)."""
    cell = robot.loadcell
    section, material = robot.section(link), robot.material(link)
    h, t = section.depth, section.thickness
    stub = STUB_DEPTHS * h
    x = np.array([stub, stub + cell.length, 2 * stub + cell.length])  # where each segment ends
    parts = (Part("S1", link, (0.0, 0.0), 0.0, 0.0, x[0], h, t, material),
             Part("CELL", link, (0.0, 0.0), 0.0, x[0], x[1], depth.depth, t, cell.material, cell.block.thickness / t),
             Part("S2", link, (0.0, 0.0), 0.0, x[1], x[2], h, t, material))  # fmt: skip
    layout = Layout(parts, (Face("ROOT", "S1", 0.0, h), Face("TIP", "S2", x[2], h)))
    mesh = mesh_layout(layout, mesh_size)
    tip = mesh.sets["TIP"]
    y = mesh.coordinates(tip)[:, 1]
    shear = tuple((int(n), 2, 1.0 / len(tip)) for n in tip)
    couple = tuple((int(n), 1, float(-yk / np.sum(y * y))) for n, yk in zip(tip, y))  # sum(-y f_x) = 1 N m
    sections = {p.name: (p.material.E * p.modulus_scale, p.material.nu, p.thickness) for p in parts}
    steps = (Step(shear, displacements=("TIP",)), Step(couple, displacements=("TIP",)))
    blocks = run_ccx(mesh, Deck(sections, clamped=("ROOT",), steps=steps))
    measured = np.zeros((2, 2))
    for j in (0, 1):
        u = select(blocks, "displacements", "TIP", j + 1).values
        measured[:, j] = [u[:, 1].mean(), -np.sum(y * u[:, 0]) / np.sum(y * y)]  # (v, r): r from u_x = -r y
    stub_beam = cantilever_flexibility(stub, material.E * section.second_moment,
                                       section.shear_coefficient(material.nu) * material.G * section.area)
    lever = lambda d: np.array([[1.0, 0.0], [d, 1.0]])  # A_s of the chain
    rest = lever(x[2] - x[0]).T @ stub_beam @ lever(x[2] - x[0]) + stub_beam
    inverse = np.linalg.inv(lever(x[2] - x[1]))
    compliance = inverse.T @ (measured - rest) @ inverse
    compliance = 0.5 * (compliance + compliance.T)
    return CellFit(link, compliance, measured, cell.flexibility, depth)


def cantilever_flexibility(length: float, EI: float, kGA: float) -> np.ndarray:
    """A Timoshenko cantilever's tip (v, r) per (V, M): [[L^3/3EI + L/kGA, L^2/2EI], [L^2/2EI, L/EI]], as the frame's beams."""
    L = length
    return np.array([[L**3 / (3 * EI) + L / kGA, L**2 / (2 * EI)], [L**2 / (2 * EI), L / EI]])


def with_compliance(robot: Robot, fit: CellFit) -> Robot:
    """``robot`` with its cells given the fitted in-situ compliance (the robot file's ``compliance = "matrix"``)."""
    (vv, vm), (_, mm) = fit.compliance
    cell = replace(robot.loadcell, compliance="matrix", compliance_vv=float(vv), compliance_vm=float(vm), compliance_mm=float(mm))
    return replace(robot, loadcell=cell)
