"""The physics calibration (``sail calibrate --model physics``).

Instead of a curve in delta, the robot's frame model is fitted to the
calibration data: each cell's offset and gain, and a few physical parameters
(by default the three joint stiffnesses, :data:`DEFAULT_FREE`), with
:func:`sailforce.fit.identify.identify` and a :class:`~sailforce.fit.identify.ReadingsTarget`.
Where the model's structure is right, the fitted map extrapolates beyond the
calibrated delta range, because it is physics rather than a series.

The estimator and libsail need no frame model at run time: the fitted map
(gains times the frame's signals) is written as a :class:`MatrixCompensator`,
C(delta) = diag(g) S0(delta) J0^T(delta)^-1, a Chebyshev series interpolating
it over the whole map range (:data:`MAP_DELTA_RANGE_DEG`, widened to the data's)
to :data:`MAP_RTOL`.

Cross-validation is the same leave-deltas-out scheme as the matrix model's
(:data:`~sailforce.fit.matrix.CV_FOLDS`), each fold refitted from
the full fit's optimum, so ``auto`` compares like with like and does not pick
a physics model whose free set cannot represent the data.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .. import kernel
from ..robot import JOINT_NAMES, Robot
from ..sensing.maps import CompensationError, MatrixCompensator, rotation, torque_rows
from .identify import Identification, ReadingsTarget, identify, sensing_map, with_free_springs
from .matrix import CV_FOLDS, delta_groups

#: The free parameters of ``--model physics`` unless ``--free`` says otherwise (besides offsets and gains).
DEFAULT_FREE = tuple(f"joints.{name}.stiffness" for name in JOINT_NAMES)
#: The reading a real cell gives: its bridge, which sees the shear (and its crosstalk).
DEFAULT_TRANSDUCTION = "bridge"
#: The delta range [deg] over which the fitted map is stored: the useful workspace, where |sin delta| >= 0.26.
MAP_DELTA_RANGE_DEG = (15.0, 165.0)
#: The stored series reproduces the fitted map to this fraction of its largest entry.
MAP_RTOL = 1e-6
#: Highest Chebyshev order tried for the stored map.
MAX_MAP_ORDER = 23
#: Points of the fine grid the stored map is checked on.
MAP_CHECK_POINTS = 721


@dataclass(frozen=True)
class PhysicsFit:
    """A physics calibration: the identification, the stored map, and its cross-validated force error."""

    identification: Identification
    compensator: MatrixCompensator
    offsets: np.ndarray  #: (2,) raw
    cv_rmse_N: float  #: force-vector RMSE at held-out deltas [N]
    map_error: float  #: largest error of the stored series against the fitted map, relative to its largest entry


def force_from_map(robot: Robot, gains: np.ndarray, offsets: np.ndarray, theta1, theta2, load1, load2,
                   transduction: str) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(fx, fy) [N] from readings through the frame model's map: solve diag(g) S0(delta) R(-theta2) F = load - o."""
    delta = np.asarray(theta1, float) - np.asarray(theta2, float)
    unique, index = np.unique(delta, return_inverse=True)
    maps = gains[:, None] * sensing_map(robot, unique, transduction)[index] @ rotation(-np.asarray(theta2, float))
    loads = np.stack([load1 - offsets[0], load2 - offsets[1]], axis=-1)
    fx, fy, _ = kernel.solve_at_poses(kernel.entries(maps), loads[:, 0], loads[:, 1], theta1, theta2)  # NaN where singular
    return fx, fy


def fit_physics(robot: Robot, theta1, theta2, fx, fy, load1, load2, *, free: Sequence[str] = DEFAULT_FREE,
                transduction: str = DEFAULT_TRANSDUCTION, cross_validate: bool = True,
                progress: Callable[[int, int], None] | None = None) -> PhysicsFit:  # fmt: skip
    """Fit offsets, gains and the ``free`` keys of ``robot`` to calibration samples (module docstring)."""
    target = ReadingsTarget(theta1, theta2, fx, fy, load1, load2, transduction)
    start = with_free_springs(robot, free)
    fit = identify(start, target, free, progress=progress)
    gains, offsets = fit.gains, fit.offsets
    cv = _cross_validate(fit, target, free) if cross_validate else float("nan")
    low, high = target.delta.min(), target.delta.max()
    map_range = (min(float(low), np.radians(MAP_DELTA_RANGE_DEG[0])), max(float(high), np.radians(MAP_DELTA_RANGE_DEG[1])))
    compensator, error = stored_map(fit.robot, gains, map_range, transduction)
    return PhysicsFit(fit, compensator, offsets, cv, error)


def _cross_validate(fit: Identification, target: ReadingsTarget, free: Sequence[str]) -> float:
    """Force RMSE [N] at held-out deltas, each fold refitted from the full fit's optimum (one start)."""
    groups = delta_groups(target.delta)
    n_groups = int(groups.max()) + 1
    folds = groups % min(CV_FOLDS, n_groups)
    squared = 0.0
    for fold in range(int(folds.max()) + 1):
        test = folds == fold
        rows = lambda sel: ReadingsTarget(target.theta1[sel], target.theta2[sel], target.fx[sel], target.fy[sel],
                                          target.load1[sel], target.load2[sel], target.transduction)  # fmt: skip
        refit = identify(fit.robot, rows(~test), free, starts=0, polish=False)
        fx_hat, fy_hat = force_from_map(refit.robot, refit.gains, refit.offsets, target.theta1[test], target.theta2[test],
                                        target.load1[test], target.load2[test], target.transduction)  # fmt: skip
        squared += float(np.sum((fx_hat - target.fx[test]) ** 2 + (fy_hat - target.fy[test]) ** 2))
    return float(np.sqrt(squared / target.theta1.size))


def stored_map(robot: Robot, gains: np.ndarray, delta_range: tuple[float, float],
               transduction: str) -> tuple[MatrixCompensator, float]:  # fmt: skip
    """The fitted map diag(g) S0(delta) as a :class:`MatrixCompensator` over ``delta_range`` [rad], and its error.

    The lowest Chebyshev order whose interpolant on Chebyshev points meets
    :data:`MAP_RTOL` on a fine grid; raises if none up to :data:`MAX_MAP_ORDER` does.
    """
    low, high = delta_range
    check = np.linspace(low, high, MAP_CHECK_POINTS)

    def correction(delta: np.ndarray) -> np.ndarray:  # C = diag(g) S0 (J0^T)^-1, J0^T at theta2 = 0
        s0 = gains[:, None] * sensing_map(robot, delta, transduction)
        return s0 @ kernel.matrix(kernel.inverse_entries(kernel.entries(torque_rows(robot.arm, delta, np.zeros_like(delta)))))

    exact = correction(check)
    scale = float(np.abs(exact).max())
    x_check = (2.0 * check - (low + high)) / (high - low)
    error = np.inf
    for order in range(2, MAX_MAP_ORDER + 1):
        nodes = np.polynomial.chebyshev.chebpts1(order + 1)
        values = correction(low + (nodes + 1.0) * (high - low) / 2.0).reshape(-1, 4)
        series = np.polynomial.chebyshev.chebfit(nodes, values, order)  # (order + 1, 4)
        approx = np.polynomial.chebyshev.chebval(x_check, series).T.reshape(-1, 2, 2)
        error = float(np.abs(approx - exact).max()) / scale
        if error <= MAP_RTOL:
            return MatrixCompensator(robot.arm, series.reshape(order + 1, 2, 2), (float(low), float(high))), error
    raise CompensationError(
        f"the fitted map is not smooth enough to store: order {MAX_MAP_ORDER} still misses it by "
        f"{error:.2g} of its size over delta = {np.degrees(low):.4g}..{np.degrees(high):.4g} deg"
    )
