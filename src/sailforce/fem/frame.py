"""Assembly, solution and recovery of a 2-D frame over a batch of configurations.

A :class:`Frame` fixes the topology and the members' local stiffness, which do
not change with the pose; only the members' directions do, and every member
points along one of a few *axes* (for the SAIL arm: theta1 or theta2).

**Assembly by basis.**  With T = c Tc + s Ts + T1 (Tc, Ts and T1 constant
0/1 patterns of the rotation matrix), each member's global stiffness
T^T k T is a fixed combination of the monomials (c^2, cs, s^2, c, s, 1) of
its axis angle.  So the stacked global stiffness of N configurations is

    K(pose) = sum_m  monomial_m(pose) * G_m,

with the basis matrices G_m assembled once, when the frame is made, and the
sum for all poses done as one matrix product.  The solve is one stacked
LAPACK call; recovery rotates translations elementwise.  Nothing loops in
Python over the batch, except that very large batches are cut into chunks of
:data:`CHUNK` configurations to bound memory.

**Two back-ends**:

- ``"compiled"`` (:mod:`sailforce.fem._compiled`): one configuration at a
  time, K at its nonzeros only, in reverse Cuthill-McKee order, factorised by
  a profile Cholesky and shared by the load cases; about 5 times the numpy
  path's speed (``make bench``), once numba is loaded (about 0.45 s);
- ``"numpy"``: the stacked solve above, the reference.

A call solves on the compiled back-end when the force kernel's is compiled
(:func:`sailforce.kernel.backend`: ``SAILFORCE_KERNEL``, default compiled
when numba imports) and either the call has at least
:data:`COMPILED_MIN_POSES` configurations or the process asked for it
(:func:`prefer_compiled`: a design sweep's workers, which solve thousands of
variants).  A command that solves a few thousand poses once does not wait
for numba.

They agree to :data:`BACKENDS_RTOL` of each load case's largest value
(``tests/test_fem.py``).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from ..errors import ShapeError
from .elements import rotation_patterns, to_global, to_local

#: Configurations per stacked solve: a chunk of 33-DOF systems is ~36 MB;
#: larger chunks bring no speed, smaller ones lose to per-call overhead.
CHUNK = 4096

GROUND = -1  #: the second DOF of a spring anchored to the ground
#: Configurations (poses x frames) from which one call pays for loading numba: 0.45 s at about 17 us saved a pose.
COMPILED_MIN_POSES = 25_000
#: The two back-ends' agreement, relative to each load case's largest displacement or end force: both are
#: backward stable, and the frame's stiffnesses span about eight decades (a cell against a link's axial).
BACKENDS_RTOL = 1e-9

_MONOMIALS = 5  # c^2, cs, s^2, c, s per axis; the constant term is shared


@dataclass(frozen=True)
class Frame:
    """Topology and pose-independent stiffness of a 2-D frame; make one with :func:`make_frame`.

    - ``element_dofs``: ``(E, 6)`` global DOF numbers of each member's
      (u_i, v_i, r_i, u_j, v_j, r_j);
    - ``element_axis``: ``(E,)`` which axis angle each member points along;
    - ``local_k``: ``(E, 6, 6)`` member stiffness in local axes;
    - ``fixed``: ``(n_dofs,)`` True where a DOF is held at zero;
    - ``springs``: ``(S, 2)`` DOF pairs joined by linear springs, the second
      :data:`GROUND` for a spring to ground, with stiffness ``spring_k (S,)``;
    - ``basis``: ``(5 n_axes + 1, n_free, n_free)`` the stiffness basis
      restricted to the free DOFs.
    """

    n_dofs: int
    n_axes: int
    element_dofs: np.ndarray
    element_axis: np.ndarray
    local_k: np.ndarray
    fixed: np.ndarray
    springs: np.ndarray
    spring_k: np.ndarray
    basis: np.ndarray

    @property
    def n_elements(self) -> int:
        return self.element_dofs.shape[0]

    @cached_property
    def profile(self) -> Profile:
        """The compiled solve's plan for this frame (:class:`Profile`), made on first use."""
        return make_profile(self.basis, self.fixed)


@dataclass(frozen=True)
class Profile:
    """K's structure for the compiled solve: its free DOFs in reverse Cuthill-McKee order (``free_dofs``, the
    DOF number of each unknown), the lower triangle's nonzeros (``rows``, ``cols``) with their monomial
    coefficients ``coef`` ``(nnz, 5 n_axes + 1)``, and each row's first column in the envelope (``first``)."""

    order: np.ndarray
    free_dofs: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    coef: np.ndarray
    first: np.ndarray


def make_profile(basis: np.ndarray, fixed: np.ndarray) -> Profile:
    """The :class:`Profile` of a stiffness basis ``(M, n_free, n_free)`` over the DOFs not ``fixed``: the order
    of the smaller envelope, the natural one or reverse Cuthill-McKee's (George and Liu 1981, Sec. 4.3).  The
    order depends on the nonzero pattern alone, and is made once per pattern (a fit's robots share one)."""
    pattern = np.any(basis != 0.0, axis=0)
    order, rows, cols, first = _symbolic(pattern.tobytes(), pattern.shape[0])
    coef = np.ascontiguousarray(basis[:, order][:, :, order][:, rows, cols].T)
    free_dofs = np.flatnonzero(~fixed)[order].astype(np.int64)
    return Profile(order, free_dofs, rows, cols, coef, first)


@lru_cache(maxsize=64)
def _symbolic(pattern_bytes: bytes, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The order, the lower triangle's nonzeros and the envelope of a nonzero pattern (``n`` x ``n`` booleans)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    pattern = np.frombuffer(pattern_bytes, dtype=bool).reshape(n, n)
    best: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    for order in (np.arange(n), np.asarray(reverse_cuthill_mckee(csr_matrix(pattern), symmetric_mode=True), dtype=np.int64)):
        lower = np.tril(pattern[np.ix_(order, order)])
        first = np.argmax(lower, axis=1).astype(np.int64)  # the diagonal is always there: a free DOF has stiffness
        if best is None or np.sum(np.arange(n) - first) < np.sum(np.arange(n) - best[1]):
            best = (order, first, lower)
    assert best is not None
    order, first, lower = best
    rows, cols = np.nonzero(lower)
    return order, rows.astype(np.int64), cols.astype(np.int64), first


@dataclass(frozen=True)
class FrameSolution:
    """Stacked results for N configurations and L load cases.

    - ``displacements``: ``(N, n_dofs, L)``, global axes;
    - ``end_forces``: ``(N, E, 6, L)``, the forces the nodes exert on each
      member, in the member's local axes, ordered as its DOFs;
    - ``angles``: ``(N, n_axes)``, the configurations solved.
    """

    displacements: np.ndarray
    end_forces: np.ndarray
    angles: np.ndarray


def member_basis(local_k: np.ndarray) -> np.ndarray:
    """The six matrices B_m with T^T k T = sum_m monomial_m B_m, monomials (c^2, cs, s^2, c, s, 1).

    ``local_k`` is ``(..., 6, 6)``; the result is ``(..., 6, 6, 6)`` with the
    monomial axis third from last.
    """
    tc, ts, t1 = rotation_patterns()

    def sandwich(a, b):
        return a.T @ local_k @ b

    terms = [
        sandwich(tc, tc),
        sandwich(tc, ts) + sandwich(ts, tc),
        sandwich(ts, ts),
        sandwich(tc, t1) + sandwich(t1, tc),
        sandwich(ts, t1) + sandwich(t1, ts),
        sandwich(t1, t1),
    ]
    return np.stack(terms, axis=-3)


def make_frame(n_dofs, n_axes, element_dofs, element_axis, local_k, fixed, springs=(), spring_k=()) -> Frame:
    """Check a frame's description and assemble its stiffness basis."""
    local_k = np.asarray(local_k, dtype=float)
    return make_frames(n_dofs, n_axes, element_dofs, element_axis, local_k[None], fixed, springs,
                       np.asarray(spring_k, dtype=float).reshape(1, -1))[0]  # fmt: skip


def make_frames(n_dofs, n_axes, element_dofs, element_axis, local_k, fixed, springs=(), spring_k=()) -> list[Frame]:
    """:func:`make_frame` for frames that differ only in their numbers: ``local_k`` ``(B, E, 6, 6)`` and
    ``spring_k`` ``(B, S)``; their bases are assembled as one stack, each as it would be alone."""
    element_dofs = np.asarray(element_dofs, dtype=int)
    element_axis = np.asarray(element_axis, dtype=int)
    local_k = np.asarray(local_k, dtype=float)
    fixed = np.asarray(fixed, dtype=bool)
    springs = np.asarray(springs, dtype=int).reshape(-1, 2)
    spring_k = np.asarray(spring_k, dtype=float).reshape(len(local_k), -1)
    if element_dofs.ndim != 2 or element_dofs.shape[1] != 6 or local_k.shape[1:] != (len(element_dofs), 6, 6):
        raise ShapeError(f"expected element_dofs (E, 6) and local_k (B, E, 6, 6), got {element_dofs.shape}, {local_k.shape}")
    if fixed.shape != (n_dofs,) or spring_k.shape[1] != len(springs):
        raise ShapeError("fixed must have one flag per DOF and springs one stiffness each")

    full = _element_basis(n_dofs, n_axes, element_dofs, element_axis, local_k)  # (B, M, n, n)
    for s, (a, b) in enumerate(springs):
        k = spring_k[:, s]
        full[:, -1, a, a] += k
        if b != GROUND:
            full[:, -1, b, b] += k
            full[:, -1, a, b] -= k
            full[:, -1, b, a] -= k
    free = ~fixed
    basis = full[:, :, free][:, :, :, free]
    return [Frame(n_dofs, n_axes, element_dofs, element_axis, local_k[i], fixed, springs, spring_k[i], basis[i])
            for i in range(len(local_k))]  # fmt: skip


def _element_basis(n_dofs: int, n_axes: int, element_dofs: np.ndarray, element_axis: np.ndarray,
                   local: np.ndarray) -> np.ndarray:
    """``(..., 5 n_axes + 1, n_dofs, n_dofs)``: the members' local matrices ``local (..., E, 6, 6)`` in global axes, by monomial."""
    batch = local.shape[:-3]
    full = np.zeros(batch + (_MONOMIALS * n_axes + 1, n_dofs, n_dofs))
    blocks = member_basis(local)  # (..., E, 6, 6, 6)
    # every member's block into its rows at once; np.add.at adds in index order (member, monomial, entry), so each
    # entry sums its members in order, as a loop over them would (a member's six DOFs are distinct)
    rows = np.concatenate([_MONOMIALS * element_axis[:, None] + np.arange(_MONOMIALS)[None, :],
                           np.full((len(element_dofs), 1), _MONOMIALS * n_axes)], axis=1)  # fmt: skip
    dofs = np.asarray(element_dofs, dtype=int)
    flat = full.reshape((-1,) + full.shape[-3:])
    for b, stack in enumerate(blocks.reshape((-1,) + blocks.shape[-4:])):
        np.add.at(flat[b], (rows[:, :, None, None], dofs[:, None, :, None], dofs[:, None, None, :]), stack)
    return full


def matrix_basis(frame: Frame, local: np.ndarray, point: np.ndarray | None = None) -> np.ndarray:
    """Another matrix over the frame's members (a mass matrix, say) as a basis like ``frame.basis``.

    ``local`` ``(E, 6, 6)`` in each member's local axes, transformed as T^T m T
    exactly as the stiffness is; ``point`` ``(n_dofs,)`` adds a pose-independent
    diagonal (point masses on translations).  Restricted to the free DOFs;
    evaluate it at poses with :func:`assemble_basis`.
    """
    local = np.asarray(local, dtype=float)
    if local.shape != frame.local_k.shape:
        raise ShapeError(f"local: expected shape {frame.local_k.shape}, got {local.shape}")
    full = _element_basis(frame.n_dofs, frame.n_axes, frame.element_dofs, frame.element_axis, local)
    if point is not None:
        full[-1] += np.diag(np.asarray(point, dtype=float))
    free = ~frame.fixed
    return full[:, free][:, :, free]


def monomials(angles: np.ndarray) -> np.ndarray:
    """``(N, 5 n_axes + 1)``: (c^2, cs, s^2, c, s) for each axis angle, then 1."""
    c, s = np.cos(angles), np.sin(angles)
    per_axis = np.stack([c * c, c * s, s * s, c, s], axis=-1).reshape(len(angles), -1)
    return np.concatenate([per_axis, np.ones((len(angles), 1))], axis=1)


def assemble(frame: Frame, angles: np.ndarray) -> np.ndarray:
    """Stacked stiffness over the free DOFs, ``(N, n_free, n_free)``, for axis angles ``(N, n_axes)``."""
    return assemble_basis(frame.basis, angles)


def assemble_basis(basis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``(N, n, n)``: the matrix whose monomial basis is ``basis`` at axis angles ``(N, n_axes)``."""
    n_free = basis.shape[-1]
    flat = monomials(angles) @ basis.reshape(len(basis), -1)
    return flat.reshape(len(angles), n_free, n_free)


def solve(frame: Frame, angles, loads) -> FrameSolution:
    """Solve K u = F for every configuration and load case.

    ``angles``: ``(N, n_axes)`` axis angles [rad]; ``loads``: ``(n_dofs, L)``,
    the same for every configuration.
    """
    angles = np.asarray(angles, dtype=float)
    if angles.ndim != 2 or angles.shape[1] != frame.n_axes:
        raise ShapeError(f"angles: expected shape (N, {frame.n_axes}), got {angles.shape}")
    loads = np.asarray(loads, dtype=float)
    if loads.ndim != 2 or loads.shape[0] != frame.n_dofs:
        raise ShapeError(f"loads: expected shape ({frame.n_dofs}, L), got {loads.shape}")
    compiled = _compiled(len(angles))
    if compiled is not None:
        return _solve_compiled(compiled, frame, angles, loads)
    parts = [_solve_chunk(frame, angles[s : s + CHUNK], loads) for s in range(0, len(angles), CHUNK)]
    if not parts:
        n_loads = loads.shape[1]
        return FrameSolution(np.zeros((0, frame.n_dofs, n_loads)), np.zeros((0, frame.n_elements, 6, n_loads)), angles)
    displacements, forces = (np.concatenate(arrays) for arrays in zip(*parts))
    return FrameSolution(displacements, forces, angles)


def same_topology(frames) -> bool:
    """Whether ``frames`` differ only in their numbers (stiffnesses, springs' values): :func:`solve_many` stacks them."""
    first = frames[0]
    return all(f.n_dofs == first.n_dofs and f.n_axes == first.n_axes and np.array_equal(f.element_dofs, first.element_dofs)
               and np.array_equal(f.element_axis, first.element_axis) and np.array_equal(f.fixed, first.fixed)
               and np.array_equal(f.springs, first.springs) for f in frames[1:])  # fmt: skip


def solve_many(frames, angles, loads) -> list[FrameSolution]:
    """:func:`solve` for each of ``frames`` at the same ``angles`` and ``loads``, as one stacked solve.

    On the numpy back-end, frames of the same topology (:func:`same_topology`: the robots of a fit's
    finite-difference Jacobian) are assembled, solved and recovered together, in chunks of :data:`CHUNK`
    systems; others, and every frame on the compiled back-end, are solved one by one.  Each frame's solution
    is :func:`solve`'s (one stacked LAPACK call solves each system as it would alone).
    """
    frames = list(frames)
    if not frames:
        return []
    angles = np.asarray(angles, dtype=float)
    loads = np.asarray(loads, dtype=float)
    if len(frames) == 1 or not same_topology(frames):
        return [solve(frame, angles, loads) for frame in frames]
    first = frames[0]
    if angles.ndim != 2 or angles.shape[1] != first.n_axes:
        raise ShapeError(f"angles: expected shape (N, {first.n_axes}), got {angles.shape}")
    if loads.ndim != 2 or loads.shape[0] != first.n_dofs:
        raise ShapeError(f"loads: expected shape ({first.n_dofs}, L), got {loads.shape}")
    compiled = _compiled(len(frames) * len(angles))  # the whole call's configurations decide, as one solve's do
    if compiled is not None:
        return [_solve_compiled(compiled, frame, angles, loads) for frame in frames]
    step = max(1, CHUNK // max(len(angles), 1))
    out: list[FrameSolution] = []
    for start in range(0, len(frames), step):
        group = frames[start : start + step]
        basis = np.stack([f.basis for f in group])  # (B, M, n_free, n_free)
        local_k = np.stack([f.local_k for f in group])  # (B, E, 6, 6)
        free = ~first.fixed
        n_free = basis.shape[-1]
        K = (monomials(angles) @ basis.reshape(len(group), basis.shape[1], -1)).reshape(len(group), len(angles), n_free, n_free)
        u = np.zeros((len(group), len(angles), first.n_dofs, loads.shape[1]))
        u[:, :, free] = np.linalg.solve(K, np.broadcast_to(loads[free], K.shape[:2] + loads[free].shape))
        theta = angles[:, first.element_axis][..., None, None]  # (N, E, 1, 1)
        forces = local_k[:, None] @ to_local(np.cos(theta), np.sin(theta), u[:, :, first.element_dofs])  # (B, N, E, 6, L)
        out += [FrameSolution(u[b], forces[b], angles) for b in range(len(group))]
    return out


_prefer_compiled = False


def prefer_compiled(on: bool = True) -> None:
    """Solve every call of this process on the compiled back-end, whatever its size (unless the force kernel's is
    numpy): for a long workload of small calls, a sweep's variants or a fit's Jacobians."""
    global _prefer_compiled
    _prefer_compiled = bool(on)


@contextmanager
def compiled_solves(on: bool = True) -> Iterator[None]:
    """A block whose solves prefer the compiled back-end whatever their size (:func:`prefer_compiled`) when ``on``;
    the preference before it comes back after."""
    global _prefer_compiled
    previous = _prefer_compiled
    _prefer_compiled = previous or bool(on)
    try:
        yield
    finally:
        _prefer_compiled = previous


def _compiled(configurations: int):
    """The compiled solve's module for a call of ``configurations``, or None (module docstring)."""
    if configurations < COMPILED_MIN_POSES and not _prefer_compiled:
        return None
    from ..kernel import backend

    if backend() != "compiled":
        return None
    from . import _compiled as module

    return module


def _solve_compiled(compiled, frame: Frame, angles: np.ndarray, loads: np.ndarray) -> FrameSolution:
    plan = frame.profile
    free_loads = np.ascontiguousarray(loads[plan.free_dofs])
    n_loads = loads.shape[1]
    displacements = np.empty((len(angles), frame.n_dofs, n_loads))
    forces = np.empty((len(angles), frame.n_elements, 6, n_loads))
    compiled.solve_frames(np.ascontiguousarray(angles), plan.rows, plan.cols, plan.coef, plan.first, free_loads,
                          plan.free_dofs, frame.n_dofs, np.ascontiguousarray(frame.element_dofs, dtype=np.int64),
                          np.ascontiguousarray(frame.element_axis, dtype=np.int64), np.ascontiguousarray(frame.local_k),
                          displacements, forces)  # fmt: skip
    return FrameSolution(displacements, forces, angles)


def _solve_chunk(frame: Frame, angles: np.ndarray, loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    free = ~frame.fixed
    K = assemble(frame, angles)
    u = np.zeros((len(angles), frame.n_dofs, loads.shape[1]))
    u[:, free] = np.linalg.solve(K, np.broadcast_to(loads[free], (len(angles),) + loads[free].shape))
    return u, end_forces(frame, angles, u)


def end_forces(frame: Frame, angles: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Member end forces in local axes ``(N, E, 6, L)`` from global displacements ``(N, n_dofs, L)``: k T u."""
    theta = angles[:, frame.element_axis][..., None, None]  # (N, E, 1, 1)
    local = to_local(np.cos(theta), np.sin(theta), u[:, frame.element_dofs])  # (N, E, 6, L)
    return frame.local_k @ local  # (E, 6, 6) @ (N, E, 6, L): one stacked product, no einsum path to plan per call


def reactions(frame: Frame, solution: FrameSolution, loads: np.ndarray) -> np.ndarray:
    """Support reactions ``(N, n_dofs, L)``: the force each support or ground spring
    exerts on the frame; zero at DOFs with neither.

    By node equilibrium, a support's reaction is the sum of the end forces its
    members carry there, rotated to global axes, less the applied load.
    """
    n, _, n_loads = solution.displacements.shape
    theta = solution.angles[:, frame.element_axis][..., None, None]
    glob = to_global(np.cos(theta), np.sin(theta), solution.end_forces)  # F_global = T^T F_local
    total = np.zeros((n, frame.n_dofs, n_loads))
    for e, dofs in enumerate(frame.element_dofs):
        total[:, dofs] += glob[:, e]
    supported = frame.fixed.copy()
    supported[frame.springs[frame.springs[:, 1] == GROUND, 0]] = True
    return np.where(supported[None, :, None], total - loads, 0.0)

