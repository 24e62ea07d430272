"""Natural frequencies and mode shapes of a frame, batched over poses.

Each member carries the consistent mass matrix of a prismatic Euler-Bernoulli
beam with axial motion (Przemieniecki 1968, Sec. 11.4; Cook et al.,
*Concepts and Applications of FEA*, 4th ed., Eq. 11.3-5), per unit length
m = rho A, in the local DOFs (u_i, v_i, r_i, u_j, v_j, r_j):

    axial      m L / 6   [[2, 1], [1, 2]]                          on (u_i, u_j)
    bending    m L / 420 [[156, 22L, 54, -13L], [22L, 4L^2, 13L, -3L^2],
                          [54, 13L, 156, -22L], [-13L, -3L^2, -22L, 4L^2]]  on (v_i, r_i, v_j, r_j)

It is rotated to global axes exactly as the stiffness is (T^T m T, by the same
monomial basis, :func:`~sailforce.fem.frame.matrix_basis`), so one matrix
product gives the mass of every pose.  The stiffness keeps its exact
Timoshenko form; with slender links (L / depth > 10) the shear correction of
the mass is below 1 %.  The handle is a point mass on l3, shared between the
two nodes of its member by the lever rule.

The generalised symmetric eigenproblem K phi = omega^2 M phi is solved for all
poses at once by Cholesky reduction, M = L L^T and (L^-1 K L^-T) y = omega^2 y
(Golub & Van Loan, *Matrix Computations*, Sec. 8.7.2), each a stacked LAPACK
call; :func:`scipy.linalg.eigh` per pose gives the same (tested).

Sweeps that need only the lowest frequencies use subspace iteration instead
(Bathe, *Finite Element Procedures*, 2nd ed., Sec. 11.6): a block of
``count + 2`` vectors X <- K^-1 M X, each step followed by a Rayleigh-Ritz
projection, until every wanted Ritz pair's residual is below
:data:`SUBSPACE_RESIDUAL`.  It converges as (omega_count / omega_(count+3))^2 per
step; the arm's third mode is an order of magnitude above its first, so three
or four steps do, at half the cost of the full reduction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import as_float_arrays
from .frame import Frame, _compiled, assemble, assemble_basis, matrix_basis
from .model import LOADCELL_MEMBERS, MEMBER_LINK, ArmModel

#: Modes :func:`arm_modes` returns by default: the first three are the arm's bending modes that matter for haptics.
DEFAULT_MODES = 3
#: Poses per stacked eigenproblem: ~2 MB per 27-DOF matrix stack stays in cache (measured: 512 is 1.3x faster than
#: 4096 on the default arm; bench/bench_design.py).
MODES_CHUNK = 512
#: Subspace iteration stops when each wanted Ritz pair's residual |K x - w M x| is below this fraction of |K x|:
#: the eigenvalue's error goes as the residual's square (Rayleigh quotient), ~1e-12 relative here.
SUBSPACE_RESIDUAL = 1e-6
#: ... or after this many steps; a pose still moving then is solved by the full reduction.
SUBSPACE_MAX_STEPS = 30
#: Extra vectors in the subspace beyond those wanted (they set the convergence rate).
SUBSPACE_GUARD = 2


def local_mass(mass_per_length, L) -> np.ndarray:
    """Consistent mass of a prismatic beam, ``(..., 6, 6)`` [kg, kg m, kg m^2] (module docstring).

    >>> m = local_mass(1.0, 1.0)
    >>> round(float(m[0, 0] + m[0, 3] + m[3, 0] + m[3, 3]), 12)   # rigid axial motion carries the member's mass
    1.0
    """
    m, L = np.broadcast_arrays(np.asarray(mass_per_length, dtype=float), np.asarray(L, dtype=float))
    out = np.zeros(m.shape + (6, 6))
    axial = m * L / 6.0
    out[..., 0, 0] = out[..., 3, 3] = 2.0 * axial
    out[..., 0, 3] = out[..., 3, 0] = axial
    b = m * L / 420.0
    bending = {
        (1, 1): 156.0, (1, 2): 22.0 * L, (1, 4): 54.0, (1, 5): -13.0 * L,
        (2, 2): 4.0 * L * L, (2, 4): 13.0 * L, (2, 5): -3.0 * L * L,
        (4, 4): 156.0, (4, 5): -22.0 * L,
        (5, 5): 4.0 * L * L,
    }  # fmt: skip
    for (i, j), coefficient in bending.items():
        out[..., i, j] = out[..., j, i] = b * coefficient
    return out


@dataclass(frozen=True)
class Modes:
    """The lowest natural modes at each pose, batch dimensions leading."""

    frequencies_Hz: np.ndarray  #: (..., k) ascending
    shapes: np.ndarray  #: (..., n_dofs, k) mass-normalised (phi^T M phi = 1), zero at held DOFs


def frame_modes(frame: Frame, mass_basis: np.ndarray, angles: np.ndarray, count: int = DEFAULT_MODES) -> Modes:
    """The ``count`` lowest modes of ``frame`` with the mass ``mass_basis`` at axis angles ``(N, n_axes)``."""
    angles = np.asarray(angles, dtype=float)
    parts = [_modes_chunk(frame, mass_basis, angles[s : s + MODES_CHUNK], count) for s in range(0, len(angles), MODES_CHUNK)]
    if not parts:
        return Modes(np.zeros((0, count)), np.zeros((0, frame.n_dofs, count)))
    frequencies, shapes = (np.concatenate(arrays) for arrays in zip(*parts))
    return Modes(frequencies, shapes)


def _modes_chunk(frame: Frame, mass_basis: np.ndarray, angles: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    K = assemble(frame, angles)
    M = assemble_basis(mass_basis, angles)
    lower = np.linalg.cholesky(M)
    inverse = np.linalg.inv(lower)
    reduced = inverse @ K @ np.swapaxes(inverse, -1, -2)
    reduced = 0.5 * (reduced + np.swapaxes(reduced, -1, -2))  # symmetric to rounding, for eigh
    eigenvalues, vectors = np.linalg.eigh(reduced)
    eigenvalues, vectors = eigenvalues[:, :count], vectors[:, :, :count]
    free = ~frame.fixed
    shapes = np.zeros((len(angles), frame.n_dofs, eigenvalues.shape[1]))
    shapes[:, free] = np.swapaxes(inverse, -1, -2) @ vectors
    return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2.0 * math.pi), shapes


def lowest_frequencies(frame: Frame, mass_basis: np.ndarray, angles: np.ndarray, count: int = 1) -> np.ndarray:
    """The ``count`` lowest natural frequencies ``(N, count)`` [Hz] by subspace iteration (module docstring).

    Frequencies only, no shapes: what a design sweep needs.  Agrees with
    :func:`frame_modes` to the eigensolver's rounding (tested).
    """
    angles = np.asarray(angles, dtype=float)
    n = mass_basis.shape[-1]
    compiled = _compiled(len(angles))
    if compiled is not None and count + SUBSPACE_GUARD < n and len(angles):
        return _subspace_compiled(compiled, frame, mass_basis, angles, count)
    parts = [_subspace_chunk(frame, mass_basis, angles[s : s + MODES_CHUNK], count) for s in range(0, len(angles), MODES_CHUNK)]
    return np.concatenate(parts) if parts else np.zeros((0, count))


def _subspace_compiled(compiled, frame: Frame, mass_basis: np.ndarray, angles: np.ndarray, count: int) -> np.ndarray:
    """:func:`lowest_frequencies` one pose at a time (:func:`sailforce.fem._compiled.lowest_eigenvalues`): the same
    start, steps and stopping rule as :func:`_subspace_chunk`, K factorised by the static solve's profile Cholesky."""
    plan = frame.profile
    order = plan.order
    mass = mass_basis[:, order][:, :, order]
    rows, cols = np.nonzero(np.tril(np.any(mass != 0.0, axis=0)))
    mcoef = np.ascontiguousarray(mass[:, rows, cols].T)
    n = mass.shape[-1]
    start = np.ascontiguousarray(np.random.default_rng(0).standard_normal((n, count + SUBSPACE_GUARD))[order])
    eigenvalues = np.empty((len(angles), count))
    late = np.zeros(len(angles), dtype=np.bool_)
    compiled.lowest_eigenvalues(np.ascontiguousarray(angles), plan.rows, plan.cols, plan.coef, plan.first,
                                rows.astype(np.int64), cols.astype(np.int64), mcoef, start, count, SUBSPACE_MAX_STEPS,
                                SUBSPACE_RESIDUAL, eigenvalues, late)  # fmt: skip
    if late.any():  # still moving after the last step, or a subspace that lost rank: the full reduction
        eigenvalues[late] = (2.0 * math.pi * _modes_chunk(frame, mass_basis, angles[late], count)[0]) ** 2
    return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2.0 * math.pi)


def _subspace_chunk(frame: Frame, mass_basis: np.ndarray, angles: np.ndarray, count: int) -> np.ndarray:
    K = assemble(frame, angles)
    M = assemble_basis(mass_basis, angles)
    n = K.shape[-1]
    width = min(count + SUBSPACE_GUARD, n)
    if width == n:  # nothing to gain over the full reduction
        return _modes_chunk(frame, mass_basis, angles, count)[0]
    step = np.linalg.solve(K, M)  # K^-1 M, once per pose
    start = np.random.default_rng(0).standard_normal((n, width))  # a fixed start: results are reproducible
    X = np.broadcast_to(start, (len(angles), n, width))
    previous = np.full((len(angles), count), np.inf)
    done = np.zeros((len(angles), count), dtype=bool)
    for _ in range(SUBSPACE_MAX_STEPS):
        X = step @ X
        Xt = np.swapaxes(X, -1, -2)
        lower = np.linalg.cholesky(Xt @ M @ X)  # Rayleigh-Ritz on span(X): (X^T K X) q = w (X^T M X) q
        inverse = np.linalg.inv(lower)
        reduced = inverse @ (Xt @ K @ X) @ np.swapaxes(inverse, -1, -2)
        values, vectors = np.linalg.eigh(0.5 * (reduced + np.swapaxes(reduced, -1, -2)))
        X = X @ (np.swapaxes(inverse, -1, -2) @ vectors)  # M-orthonormal Ritz vectors, ascending
        wanted = X[..., :count]
        stiff = K @ wanted
        residual = stiff - (M @ wanted) * values[:, None, :count]  # K x - w M x: the eigenvalue's error ~ its square
        done = np.linalg.norm(residual, axis=1) <= SUBSPACE_RESIDUAL * np.linalg.norm(stiff, axis=1)
        previous = values[:, :count]
        if done.all():
            break
    eigenvalues = previous.copy()
    late = ~done.all(axis=-1)
    if late.any():
        eigenvalues[late] = (2.0 * math.pi * _modes_chunk(frame, mass_basis, angles[late], count)[0]) ** 2
    return np.sqrt(np.clip(eigenvalues, 0.0, None)) / (2.0 * math.pi)


def arm_mass_basis(model: ArmModel) -> np.ndarray:
    """The SAIL arm's mass basis: links rho A of their material and section, cells of their block, the handle."""
    robot = model.robot
    per_length = np.array([robot.material(name).rho * robot.section(name).area for name in MEMBER_LINK])
    per_length[list(LOADCELL_MEMBERS)] = robot.loadcell.material.rho * robot.loadcell.block.area
    point = np.zeros(model.frame.n_dofs)
    mass = robot.handle.mass
    if mass > 0:
        # l3 runs P2 -> P3 (length l1) -> A; the handle sits at position * l3 from P2
        arm = robot.arm
        s = robot.handle.position * arm.l3
        a, b, length, along = ("P2", "P3", arm.l1, s) if s <= arm.l1 else ("P3", "A", arm.l3 - arm.l1, s - arm.l1)
        share = along / length
        for node, weight in ((a, 1.0 - share), (b, share)):
            point[model.dof[f"{node}.u"]] += weight * mass
            point[model.dof[f"{node}.v"]] += weight * mass
    return matrix_basis(model.frame, local_mass(per_length, model.lengths), point)


def arm_frequencies(model: ArmModel, theta1, theta2, count: int = 1) -> np.ndarray:
    """The ``count`` lowest natural frequencies ``(..., count)`` [Hz] at every pose, without shapes (sweeps)."""
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    angles = np.stack([theta1.ravel(), theta2.ravel()], axis=-1)
    return lowest_frequencies(model.frame, arm_mass_basis(model), angles, count).reshape(theta1.shape + (count,))


def load_compiled() -> bool:
    """Compile the frame's compiled solves (static and modes) into numba's on-disk cache, or load them from it: the
    first compilation takes about 8 s, a load 0.5 s.  ``make install`` runs it once (``python -m
    sailforce.fem.modes``), so that no test or command compiles them.  False without numba."""
    from ..robot import Robot
    from .frame import compiled_solves
    from .model import build_model
    from .response import simulate_model

    model = build_model(Robot())
    with compiled_solves():
        if _compiled(1) is None:
            return False
        arm_frequencies(model, np.array([1.2, 1.5]), np.array([0.0, 0.3]))
        simulate_model(model, 1.2, 0.0)
    return True


def arm_modes(model: ArmModel, theta1, theta2, count: int = DEFAULT_MODES) -> Modes:
    """The ``count`` lowest natural modes of the arm at every pose [rad], with its cells' compliance and the handle."""
    theta1, theta2 = as_float_arrays(theta1=theta1, theta2=theta2)
    shape = theta1.shape
    angles = np.stack([theta1.ravel(), theta2.ravel()], axis=-1)
    modes = frame_modes(model.frame, arm_mass_basis(model), angles, count)
    return Modes(modes.frequencies_Hz.reshape(shape + (-1,)), modes.shapes.reshape(shape + modes.shapes.shape[1:]))


if __name__ == "__main__":  # pragma: no cover - make install's warm-up
    load_compiled()
