"""The frame solve compiled by numba: :func:`sailforce.fem.frame.solve`'s arithmetic, one configuration at a time.

Imported only when numba is installed (:mod:`sailforce.fem.frame` falls back
to its stacked numpy solve otherwise).  For each configuration:

1. the stiffness over the free DOFs, ``K = sum_m monomial_m G_m`` (the basis
   of :mod:`sailforce.fem.frame`), only at its structural nonzeros, in an
   order that keeps them near the diagonal (reverse Cuthill-McKee);
2. K = L L^T by a profile (envelope) Cholesky: the fill of L stays inside
   the envelope of K, so only the envelope is factorised (George and Liu,
   *Computer Solution of Large Sparse Positive Definite Systems*, 1981,
   Ch. 4), the storage scheme of OpenSees' ProfileSPD as well;
3. the load cases by forward and back substitution on the one factor;
4. each member's end forces ``k T u`` in its local axes.

K is symmetric positive definite for every frame that can stand (its supports
hold it, the joints' springs are positive); a frame that cannot gives NaN
where the factor's pivot is not positive, as the numpy path's solve would
fail.  Every function releases the GIL (``nogil``) and is cached on disk
(``cache``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(nogil=True, cache=True)
def _assemble(mono, rows, cols, coef, first, K):
    """K's envelope (lower triangle) at the monomials ``mono``."""
    n = first.size
    for i in range(n):
        for j in range(first[i], i + 1):
            K[i, j] = 0.0
    for k in range(rows.size):
        total = 0.0
        for m in range(mono.size):
            total += coef[k, m] * mono[m]
        K[rows[k], cols[k]] = total


@njit(nogil=True, cache=True)
def _cholesky(first, K):
    """K = L L^T in place, row by row inside the envelope (module docstring); NaN on a pivot that is not positive."""
    n = first.size
    for i in range(n):
        fi = first[i]
        for j in range(fi, i):
            total = K[i, j]
            for k in range(max(fi, first[j]), j):
                total -= K[i, k] * K[j, k]
            K[i, j] = total / K[j, j]
        total = K[i, i]
        for k in range(fi, i):
            total -= K[i, k] * K[i, k]
        K[i, i] = math.sqrt(total) if total > 0.0 else math.nan


@njit(nogil=True, cache=True)
def _substitute(first, L, x, q):
    """x[:, q] <- (L L^T)^-1 x[:, q]."""
    n = first.size
    for i in range(n):
        total = x[i, q]
        for k in range(first[i], i):
            total -= L[i, k] * x[k, q]
        x[i, q] = total / L[i, i]
    for i in range(n - 1, -1, -1):
        x[i, q] /= L[i, i]
        value = x[i, q]
        for k in range(first[i], i):
            x[k, q] -= L[i, k] * value


@njit(nogil=True, cache=True)
def solve_frames(angles, rows, cols, coef, first, loads, free_dofs, n_dofs, element_dofs, element_axis, local_k,
                 displacements, end_forces):  # fmt: skip
    """Solve every configuration of ``angles`` ``(N, n_axes)`` into ``displacements`` ``(N, n_dofs, L)`` and
    ``end_forces`` ``(N, E, 6, L)``.

    ``rows``, ``cols``, ``coef``: K's lower-triangle nonzeros in the solve's order and their monomial
    coefficients ``(nnz, 5 n_axes + 1)``; ``first``: each row's first column inside the envelope; ``loads``
    ``(n, L)`` in the solve's order; ``free_dofs``: the DOF number of each of the solve's unknowns.
    """
    n_conf, n_axes = angles.shape
    n = first.size
    n_loads = loads.shape[1]
    n_mono = coef.shape[1]
    mono = np.empty(n_mono)
    trig = np.empty((n_axes, 2))
    K = np.zeros((n, n))
    x = np.empty((n, n_loads))
    local = np.empty((6, n_loads))
    for p in range(n_conf):
        for a in range(n_axes):
            c, s = math.cos(angles[p, a]), math.sin(angles[p, a])
            trig[a, 0], trig[a, 1] = c, s
            mono[5 * a], mono[5 * a + 1], mono[5 * a + 2], mono[5 * a + 3], mono[5 * a + 4] = c * c, c * s, s * s, c, s
        mono[n_mono - 1] = 1.0
        _assemble(mono, rows, cols, coef, first, K)  # the envelope only: the factor's fill stays inside it
        _cholesky(first, K)  # L overwrites K's lower triangle
        for i in range(n):
            for q in range(n_loads):
                x[i, q] = loads[i, q]
        for q in range(n_loads):
            _substitute(first, K, x, q)
        for d in range(n_dofs):
            for q in range(n_loads):
                displacements[p, d, q] = 0.0
        for i in range(n):
            for q in range(n_loads):
                displacements[p, free_dofs[i], q] = x[i, q]
        for e in range(element_dofs.shape[0]):  # k T u in each member's local axes (fem.elements.rotation)
            c, s = trig[element_axis[e], 0], trig[element_axis[e], 1]
            for q in range(n_loads):
                for o in range(0, 6, 3):
                    u = displacements[p, element_dofs[e, o], q]
                    v = displacements[p, element_dofs[e, o + 1], q]
                    local[o, q] = c * u + s * v
                    local[o + 1, q] = -s * u + c * v
                    local[o + 2, q] = displacements[p, element_dofs[e, o + 2], q]
                for r in range(6):
                    total = 0.0
                    for k in range(6):
                        total += local_k[e, r, k] * local[k, q]
                    end_forces[p, e, r, q] = total


@njit(nogil=True, cache=True)
def _symmetric_eigen(A, values, vectors):
    """Eigenvalues (ascending) and eigenvectors (columns) of a small symmetric ``A`` by cyclic Jacobi rotations
    (Golub and Van Loan, *Matrix Computations*, Sec. 8.5); ``A`` is overwritten."""
    w = A.shape[0]
    for i in range(w):
        for j in range(w):
            vectors[i, j] = 1.0 if i == j else 0.0
    for _ in range(60):
        off, scale = 0.0, 0.0
        for i in range(w):
            scale += A[i, i] * A[i, i]
            for j in range(i + 1, w):
                off += A[i, j] * A[i, j]
        if off <= 1e-32 * scale:
            break
        for p in range(w - 1):
            for r in range(p + 1, w):
                if A[p, r] == 0.0:
                    continue
                theta = (A[r, r] - A[p, p]) / (2.0 * A[p, r])
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(w):  # A <- J^T A J, columns then rows
                    akp, akr = A[k, p], A[k, r]
                    A[k, p], A[k, r] = c * akp - s * akr, s * akp + c * akr
                for k in range(w):
                    apk, ark = A[p, k], A[r, k]
                    A[p, k], A[r, k] = c * apk - s * ark, s * apk + c * ark
                for k in range(w):
                    vkp, vkr = vectors[k, p], vectors[k, r]
                    vectors[k, p], vectors[k, r] = c * vkp - s * vkr, s * vkp + c * vkr
    for i in range(w):
        values[i] = A[i, i]
    for i in range(w):  # ascending, by selection (w is a few)
        best = i
        for j in range(i + 1, w):
            if values[j] < values[best]:
                best = j
        if best != i:
            values[i], values[best] = values[best], values[i]
            for k in range(w):
                vectors[k, i], vectors[k, best] = vectors[k, best], vectors[k, i]


@njit(nogil=True, cache=True)
def _times(A, Q, tmp):
    """A <- A Q, through ``tmp``."""
    n, width = A.shape
    for i in range(n):
        for j in range(width):
            total = 0.0
            for k in range(width):
                total += A[i, k] * Q[k, j]
            tmp[i, j] = total
    for i in range(n):
        for j in range(width):
            A[i, j] = tmp[i, j]


@njit(nogil=True, cache=True)
def _symmetric_matvec(rows, cols, values, X, out):
    """out <- M X for the symmetric M given by its lower triangle's nonzeros."""
    n, width = X.shape
    for i in range(n):
        for j in range(width):
            out[i, j] = 0.0
    for k in range(rows.size):
        r, c = rows[k], cols[k]
        for j in range(width):
            out[r, j] += values[k] * X[c, j]
            if r != c:
                out[c, j] += values[k] * X[r, j]


@njit(nogil=True, cache=True)
def lowest_eigenvalues(angles, rows, cols, coef, first, mrows, mcols, mcoef, start, count, max_steps, tolerance,
                       values_out, late):  # fmt: skip
    """The ``count`` lowest eigenvalues of K x = w M x at every configuration, by subspace iteration on the
    columns of ``start`` ``(n, width)`` (:mod:`sailforce.fem.modes`): K factorised once per configuration by the
    profile Cholesky, each step X <- K^-1 M X and a Rayleigh-Ritz projection.  ``mrows``, ``mcols``, ``mcoef``: M's
    lower-triangle nonzeros in the solve's order.  A configuration not converged in ``max_steps`` is marked in
    ``late``."""
    n_conf, n_axes = angles.shape
    n, width = start.shape
    n_mono = coef.shape[1]
    mono = np.empty(n_mono)
    K = np.zeros((n, n))
    mval = np.empty(mrows.size)
    X = np.empty((n, width))
    Y = np.empty((n, width))  # K X
    MX = np.empty((n, width))
    Q = np.empty((width, width))
    C = np.empty((width, width))
    A = np.empty((width, width))
    V = np.empty((width, width))
    values = np.empty(width)
    tmp = np.empty((n, width))
    for p in range(n_conf):
        for a in range(n_axes):
            c, s = math.cos(angles[p, a]), math.sin(angles[p, a])
            mono[5 * a], mono[5 * a + 1], mono[5 * a + 2], mono[5 * a + 3], mono[5 * a + 4] = c * c, c * s, s * s, c, s
        mono[n_mono - 1] = 1.0
        _assemble(mono, rows, cols, coef, first, K)
        _cholesky(first, K)
        for k in range(mrows.size):
            total = 0.0
            for m in range(n_mono):
                total += mcoef[k, m] * mono[m]
            mval[k] = total
        _symmetric_matvec(mrows, mcols, mval, start, MX)
        late[p] = True
        for _ in range(max_steps):
            for i in range(n):  # X <- K^-1 (M X); then K X = M X_old
                for j in range(width):
                    X[i, j] = MX[i, j]
                    Y[i, j] = MX[i, j]
            for j in range(width):
                _substitute(first, K, X, j)
            _symmetric_matvec(mrows, mcols, mval, X, MX)
            for i in range(width):  # the projections X^T K X = X^T Y and X^T M X, symmetrised
                for j in range(i + 1):
                    kr, mr = 0.0, 0.0
                    for k in range(n):
                        kr += X[k, i] * Y[k, j] + X[k, j] * Y[k, i]
                        mr += X[k, i] * MX[k, j] + X[k, j] * MX[k, i]
                    A[i, j] = A[j, i] = 0.5 * kr
                    C[i, j] = 0.5 * mr
                    C[j, i] = 0.0 if i != j else C[i, j]
            ok = True
            for i in range(width):  # X^T M X = C C^T (lower C)
                for j in range(i + 1):
                    total = C[i, j]
                    for k in range(j):
                        total -= C[i, k] * C[j, k]
                    if i == j:
                        if total <= 0.0:
                            ok = False
                            total = 1.0
                        C[i, i] = math.sqrt(total)
                    else:
                        C[i, j] = total / C[j, j]
            if not ok:
                break
            for j in range(width):  # A <- C^-1 A C^-T, by columns then rows
                for i in range(width):
                    total = A[i, j]
                    for k in range(i):
                        total -= C[i, k] * A[k, j]
                    A[i, j] = total / C[i, i]
            for i in range(width):
                for j in range(width):
                    total = A[i, j]
                    for k in range(j):
                        total -= C[j, k] * A[i, k]
                    A[i, j] = total / C[j, j]
            for i in range(width):
                for j in range(i):
                    A[i, j] = A[j, i] = 0.5 * (A[i, j] + A[j, i])
            _symmetric_eigen(A, values, V)
            for j in range(width):  # Q = C^-T V: the Ritz vectors' coefficients, M-orthonormal
                for i in range(width - 1, -1, -1):
                    total = V[i, j]
                    for k in range(i + 1, width):
                        total -= C[k, i] * Q[k, j]
                    Q[i, j] = total / C[i, i]
            _times(X, Q, tmp)  # X, K X and M X times Q
            _times(Y, Q, tmp)
            _times(MX, Q, tmp)
            done = True
            for j in range(count):  # |K x - w M x| against |K x|
                res, ref = 0.0, 0.0
                for i in range(n):
                    d = Y[i, j] - values[j] * MX[i, j]
                    res += d * d
                    ref += Y[i, j] * Y[i, j]
                if not res <= tolerance * tolerance * ref:
                    done = False
            if done:
                late[p] = False
                break
        for j in range(count):
            values_out[p, j] = values[j]
