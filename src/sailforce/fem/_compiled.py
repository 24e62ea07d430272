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
        for i in range(n):  # the envelope only: the factor's fill stays inside it
            for j in range(first[i], i + 1):
                K[i, j] = 0.0
        for k in range(rows.size):
            total = 0.0
            for m in range(n_mono):
                total += coef[k, m] * mono[m]
            K[rows[k], cols[k]] = total
        for i in range(n):  # profile Cholesky, row by row: L overwrites K's lower triangle
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
        for q in range(n_loads):
            for i in range(n):  # L y = b
                total = loads[i, q]
                for k in range(first[i], i):
                    total -= K[i, k] * x[k, q]
                x[i, q] = total / K[i, i]
            for i in range(n - 1, -1, -1):  # L^T x = y, column by column of L
                x[i, q] /= K[i, i]
                value = x[i, q]
                for k in range(first[i], i):
                    x[k, q] -= K[i, k] * value
        for d in range(n_dofs):
            for q in range(n_loads):
                displacements[p, d, q] = 0.0
        for i in range(n):
            for q in range(n_loads):
                displacements[p, free_dofs[i], q] = x[i, q]
        for e in range(element_dofs.shape[0]):  # k T u in each member's local axes (fem.elements.rotation)
            c, s = trig[element_axis[e], 0], trig[element_axis[e], 1]
            for q in range(n_loads):
                for o in (0, 3):
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
