"""The force kernel: solve M F = s for a batch of poses, the one place it is computed.

Every force in sailforce is the solution of a 2x2 system at each pose,

    M(theta1, theta2) F = s,

by Cramer's rule (cf. seed Eq. 8):

- statics (:func:`sailforce.statics.end_effector_force`): M = J^T and s = T,
  the joint torques (seed Eqs. 3 and 7, with the corrected inverse of
  docs/errata.md);
- the estimator (:mod:`sailforce.estimate.estimator`, and through it
  :func:`sailforce.estimate.estimate_force` and
  :meth:`sailforce.Calibration.estimate`): M is the calibration's sensing
  matrix and s the offset-free readings.

Both go through :func:`torque_entries` (J^T), :func:`solve_2x2` (Cramer's
rule) and the singularity predicate :func:`sailforce.kinematics.is_singular`.

Two back-ends compute it, with the same arithmetic:

- ``"compiled"``: numba (:mod:`sailforce.kernel._compiled`), one pose at a
  time with a polynomial sine and cosine; about 5-20 times numpy's speed
  (``make bench``).  Used when numba imports, by a call of at least
  :data:`COMPILED_MIN_POSES` poses, and by every call once it is loaded:
  loading numba and the cached kernel costs about 0.6 s, which only such a
  call repays.
- ``"numpy"``: numpy ufuncs on blocks that stay in the cache.  The
  reference, and the fallback without numba.

They agree to rounding (within 1e-13 relative, tested), and on every
singular verdict exactly: a pose within :data:`VERDICT_BAND` of the
threshold is settled by the numpy path.  Choose with the environment
variable ``SAILFORCE_KERNEL`` (``numpy`` or ``compiled``) or
:func:`use_backend` (either, chosen so, serves every call whatever its
size); the default is ``compiled`` when numba is installed, with the size
rule above.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from ..errors import InputError, MissingExtraError
from ..kinematics import SINGULAR_SIN_DELTA, is_singular, sin_delta_from_trig, transposed_jacobian_entries
from .verdict import NEAR, VERDICT_BAND  # noqa: F401 (re-exported)

#: The four entries (m00, m01, m10, m11) of a batch of 2x2 matrices, each of the batch shape.
Entries = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]

__all__ = ["BACKENDS", "BACKEND_ENV", "Entries", "backend", "compiled", "entries", "force_from_torques", "inverse_entries",
           "matrix", "prefer_backend", "solve_2x2", "solve_at_poses", "torque_entries", "use_backend"]

BACKENDS = ("compiled", "numpy")
#: The environment variable that picks the back-end.
BACKEND_ENV = "SAILFORCE_KERNEL"

#: A call of fewer poses runs on numpy until the compiled module is loaded (unless it was chosen explicitly): loading
#: numba and the cached kernel costs about 0.6 s, and the compiled kernel saves about 75 ms per million poses
#: (measured on the two back-ends: 96 against 21 ms for 1e6 poses), so only a call of several million repays it.
COMPILED_MIN_POSES = 5_000_000

_module = None  # the compiled module, once imported
_chosen: str | None = None


#: J^T as entries from the joint angles' sines and cosines (seed Eq. 4): :func:`sailforce.kinematics.transposed_jacobian_entries`.
torque_entries = transposed_jacobian_entries


def entries(matrix) -> Entries:
    """The entries ``(m00, m01, m10, m11)`` of a batch of 2x2 matrices ``(..., 2, 2)``."""
    matrix = np.asarray(matrix, dtype=float)
    return matrix[..., 0, 0], matrix[..., 0, 1], matrix[..., 1, 0], matrix[..., 1, 1]


def matrix(m: Entries) -> np.ndarray:
    """The batch of 2x2 matrices ``(..., 2, 2)`` with entries ``m``."""
    m00, m01, m10, m11 = np.broadcast_arrays(*m)
    return np.stack([np.stack([m00, m01], axis=-1), np.stack([m10, m11], axis=-1)], axis=-2)


def inverse_entries(m: Entries, skip=False) -> Entries:
    """M^-1 as entries, the adjugate over det M (Cramer's rule); NaN where ``skip`` or det M = 0."""
    m00, m01, m10, m11 = m
    det = m00 * m11 - m01 * m10
    det = np.where(skip | (det == 0.0), np.nan, det)
    return m11 / det, -m01 / det, -m10 / det, m00 / det


def solve_2x2(m: Entries, b1, b2, skip) -> tuple[np.ndarray, np.ndarray]:
    """Solve M x = b by Cramer's rule (cf. seed Eq. 8); NaN where ``skip`` or det M = 0.

    ``m`` is M's entries ``(m00, m01, m10, m11)``.  The only place sailforce solves its 2x2 systems.
    """
    m00, m01, m10, m11 = m
    det = m00 * m11 - m01 * m10
    det = np.where(skip | (det == 0.0), np.nan, det)
    return (m11 * b1 - m01 * b2) / det, (m00 * b2 - m10 * b1) / det


def solve_at_poses(m: Entries, b1, b2, theta1, theta2, min_sin_delta: float = SINGULAR_SIN_DELTA):
    """Solve M x = b at poses [rad] with the singularity predicate: ``(x1, x2, singular)``.

    ``singular`` is :func:`sailforce.kinematics.is_singular` of sin(theta1 -
    theta2), or a map that cannot be inverted there; x is NaN where it is set.
    The force inversion of a sensing map that is not a calibration's (a
    physics fit's frame map, for one) goes through here.
    """
    theta1, theta2 = np.asarray(theta1, dtype=float), np.asarray(theta2, dtype=float)
    singular = is_singular(sin_delta_from_trig(np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)), min_sin_delta)
    x1, x2 = solve_2x2(m, b1, b2, singular)
    singular = singular | np.isnan(x1) & np.isfinite(b1) & np.isfinite(b2)
    return x1, x2, singular


def backend() -> str:
    """The back-end in use: ``"compiled"`` or ``"numpy"``."""
    global _chosen
    if _chosen is None:
        wanted = os.environ.get(BACKEND_ENV, "").strip().lower() or None
        if wanted is not None and wanted not in BACKENDS:
            raise InputError(f"{BACKEND_ENV}={wanted!r}: expected one of {', '.join(BACKENDS)}")
        _chosen = "compiled" if wanted != "numpy" and _load_compiled(required=wanted == "compiled") else "numpy"
    return _chosen


@contextmanager
def use_backend(name: str) -> Iterator[None]:
    """Run a block of code on one back-end (``"compiled"`` or ``"numpy"``), then restore the previous one.

    ``"compiled"`` raises :class:`SailError` if numba is not installed.
    """
    global _chosen
    if name not in BACKENDS:
        raise InputError(f"kernel back-end {name!r}: expected one of {', '.join(BACKENDS)}")
    previous = _chosen  # None: chosen again on first use, without importing numba to switch to numpy
    if name == "compiled":
        _load_compiled(required=True)
    _chosen = name
    try:
        yield
    finally:
        _chosen = previous


def prefer_backend(name: str) -> None:
    """Use ``name`` for the rest of the process unless :data:`BACKEND_ENV` says otherwise.

    ``sail estimate`` prefers numpy: its time is parsing and formatting,
    and numba's LLVM would add about 116 MB to a 300 MB memory budget.
    """
    global _chosen
    if name not in BACKENDS:
        raise InputError(f"kernel back-end {name!r}: expected one of {', '.join(BACKENDS)}")
    if not os.environ.get(BACKEND_ENV, "").strip():
        _chosen = name if name == "numpy" or _load_compiled(required=False) else "numpy"


def compiled(poses: int | None = None):
    """The compiled module for a call of ``poses`` poses, or None on the numpy back-end.

    Also None for a call of fewer than :data:`COMPILED_MIN_POSES` while the
    module is not loaded, unless the compiled back-end was chosen
    explicitly (:data:`BACKEND_ENV`, :func:`use_backend`).
    """
    if poses is not None and poses < COMPILED_MIN_POSES and _module is None and not _explicit():
        return None
    return _module if backend() == "compiled" else None


def _explicit() -> bool:
    """Whether the compiled back-end was asked for by name."""
    return _chosen == "compiled" or os.environ.get(BACKEND_ENV, "").strip().lower() == "compiled"


def _load_compiled(required: bool) -> bool:
    global _module
    if _module is None:
        try:
            from . import _compiled as module
        except ImportError as exc:
            if required:
                raise MissingExtraError(f"the compiled kernel needs numba, which does not import here ({exc}); "
                                f"install it (pip install numba) or set {BACKEND_ENV}=numpy") from None  # fmt: skip
            return False
        _module = module
    return True


def force_from_torques(l2: float, l3: float, theta1, theta2, t1, t2, min_sin_delta: float, poses: int | None = None):
    """F = (J^T)^-1 T [N] on one block of 1-D arrays: ``(fx, fy, singular)``, NaN where singular.

    J^T from :func:`torque_entries`, solved by :func:`solve_2x2` (seed Eqs. 3
    and 8 with the corrected inverse, docs/errata.md); ``singular`` is
    :func:`sailforce.kinematics.is_singular` of sin(theta1 - theta2).
    ``poses`` is the size of the whole call the block belongs to (the
    block's own by default), for :func:`compiled`'s size rule.
    """
    module = compiled(theta1.size if poses is None else poses)
    if module is None:
        return _force_numpy(l2, l3, theta1, theta2, t1, t2, min_sin_delta)
    n = theta1.size
    fx, fy, flag = np.empty(n), np.empty(n), np.empty(n, dtype=np.int8)
    module.force_from_torques(l2, l3, theta1, theta2, t1, t2, min_sin_delta, fx, fy, flag)
    singular = flag == 1
    fx[singular] = np.nan
    fy[singular] = np.nan
    near = np.flatnonzero(flag == NEAR)
    if near.size:  # verdicts at the threshold: numpy's
        fx[near], fy[near], singular[near] = _force_numpy(l2, l3, theta1[near], theta2[near], t1[near], t2[near], min_sin_delta)
    return fx, fy, singular


def _force_numpy(l2, l3, theta1, theta2, t1, t2, min_sin_delta):
    trig = np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)
    singular = is_singular(sin_delta_from_trig(*trig), min_sin_delta)
    fx, fy = solve_2x2(torque_entries(l2, l3, *trig), t1, t2, singular)
    return fx, fy, singular
