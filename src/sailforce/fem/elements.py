"""The 2-D Timoshenko beam element: exact stiffness of a prismatic member.

Local degrees of freedom, in order: (u_i, v_i, r_i, u_j, v_j, r_j), with u
along the member from node i to node j, v the counter-clockwise normal, and r
the rotation (counter-clockwise).  For a prismatic member without interior
load, the Timoshenko element below is exact (Przemieniecki, *Theory of Matrix
Structural Analysis*, 1968, Sec. 5.6), so each straight segment is one element.
"""

from __future__ import annotations

from functools import cache

import numpy as np


def shear_parameter(EI, kappa_G_A, L):
    """Phi = 12 E I / (kappa G A L^2); zero recovers Euler-Bernoulli.

    Pass ``kappa_G_A = inf`` for a shear-rigid (Euler-Bernoulli) member.
    """
    EI, kappa_G_A, L = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (EI, kappa_G_A, L)))
    return 12.0 * EI / (kappa_G_A * L * L)


def local_stiffness(EA, EI, L, phi) -> np.ndarray:
    """Local 6x6 stiffness of a Timoshenko beam, shape ``(..., 6, 6)``.

    ``EA`` axial rigidity [N], ``EI`` bending rigidity [N m^2], ``L`` length
    [m], ``phi`` the shear parameter from :func:`shear_parameter`.

    >>> k = local_stiffness(1.0, 1.0, 1.0, 0.0)
    >>> k[1, [1, 2, 4, 5]].tolist()    # Euler-Bernoulli row: 12, 6L, -12, 6L
    [12.0, 6.0, -12.0, 6.0]
    """
    EA, EI, L, phi = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (EA, EI, L, phi)))
    k = np.zeros(EA.shape + (6, 6))
    a = EA / L
    b = EI / (L**3 * (1.0 + phi))
    k[..., 0, 0] = k[..., 3, 3] = a
    k[..., 0, 3] = k[..., 3, 0] = -a
    bending = {
        (1, 1): 12.0, (1, 2): 6.0 * L, (1, 4): -12.0, (1, 5): 6.0 * L,
        (2, 2): (4.0 + phi) * L * L, (2, 4): -6.0 * L, (2, 5): (2.0 - phi) * L * L,
        (4, 4): 12.0, (4, 5): -6.0 * L,
        (5, 5): (4.0 + phi) * L * L,
    }  # fmt: skip
    for (i, j), coefficient in bending.items():
        k[..., i, j] = k[..., j, i] = b * coefficient
    return k


def flexibility_stiffness(EA, L, flexibility) -> np.ndarray:
    """Local 6x6 stiffness of a member given by its cantilever flexibility, shape ``(6, 6)``.

    ``flexibility`` C (2x2) maps the shear and moment at node j to the
    transverse displacement and rotation of j relative to a clamped node i.
    Those relative motions are d = H q with H = [[-1, -L, 1, 0], [0, -1, 0, 1]]
    on (v_i, r_i, v_j, r_j); equilibrium gives the end forces H^T C^-1 d, so
    k = H^T C^-1 H (the flexibility method; Przemieniecki 1968, Sec. 6.2).
    For a Timoshenko cantilever's C it is :func:`local_stiffness` exactly.
    """
    h = np.array([[-1.0, -L, 1.0, 0.0], [0.0, -1.0, 0.0, 1.0]])
    bending = h.T @ np.linalg.solve(np.asarray(flexibility, dtype=float), h)
    k = np.zeros((6, 6))
    k[np.ix_([0, 3], [0, 3])] = EA / L * np.array([[1.0, -1.0], [-1.0, 1.0]])
    k[np.ix_([1, 2, 4, 5], [1, 2, 4, 5])] = bending
    return k


def rotation(cos, sin) -> np.ndarray:
    """Transformation T with u_local = T u_global, shape ``(..., 6, 6)``.

    ``cos`` and ``sin`` are the direction cosines of the member axis i -> j.
    """
    cos, sin = np.broadcast_arrays(np.asarray(cos, dtype=float), np.asarray(sin, dtype=float))
    t = np.zeros(cos.shape + (6, 6))
    for o in (0, 3):
        t[..., o, o] = t[..., o + 1, o + 1] = cos
        t[..., o, o + 1] = sin
        t[..., o + 1, o] = -sin
        t[..., o + 2, o + 2] = 1.0
    return t


@cache
def rotation_patterns() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Tc, Ts, T1), each ``(6, 6)``, with ``rotation(c, s) = c Tc + s Ts + T1`` (made once; read-only).

    :func:`rotation` is affine in (c, s), so its values at (1, 0), (0, 1)
    and (0, 0) give the three patterns: the one transformation from which
    the frame's stiffness basis and its force recovery are derived.
    """
    t1 = rotation(0.0, 0.0)
    patterns = (rotation(1.0, 0.0) - t1, rotation(0.0, 1.0) - t1, t1)
    for pattern in patterns:
        pattern.flags.writeable = False
    return patterns


def to_local(cos, sin, vectors: np.ndarray) -> np.ndarray:
    """T v for member vectors ``(..., 6, L)`` in global axes; ``cos``, ``sin`` broadcast against ``(..., 1, 1)``."""
    tc, ts, t1 = rotation_patterns()
    return cos * (tc @ vectors) + sin * (ts @ vectors) + t1 @ vectors


def to_global(cos, sin, vectors: np.ndarray) -> np.ndarray:
    """T^T f for member vectors ``(..., 6, L)`` in local axes (the inverse of :func:`to_local`: T is orthogonal)."""
    tc, ts, t1 = rotation_patterns()
    return cos * (tc.T @ vectors) + sin * (ts.T @ vectors) + t1.T @ vectors
