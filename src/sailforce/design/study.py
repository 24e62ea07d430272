"""``sail design``'s computation: every map on an x-y grid of reachable poses, and the summary."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DesignError
from ..fem.model import build_model
from ..fem.modes import DEFAULT_MODES, Modes, arm_modes
from ..fem.response import simulate_model
from ..kinematics import forward, inverse, jacobian_condition
from ..robot import Robot
from .maps import DEFAULT_SAFETY_FACTOR, CompensationNeed, Overload, Resolution, compensation_need, overload, resolution

#: Grid points per side of the x-y grid (50 x 50 = 2,500 points before the reach and joint limits cut it).
DEFAULT_GRID = 50
#: Default joint limits [deg]: theta1 over the upper half-plane, theta2 within +-90 deg, and delta kept off the
#: singularities as in the seed's workspace (15...165 deg).
DEFAULT_THETA1_DEG = (0.0, 180.0)
DEFAULT_THETA2_DEG = (-90.0, 90.0)
DEFAULT_DELTA_DEG = (15.0, 165.0)
#: Joint-space samples per axis used to find the workspace's bounding box.
BOUNDS_SAMPLES = 181



@dataclass(frozen=True)
class DesignGrid:
    """An x-y grid over the reachable workspace; ``mask`` marks the nodes that are poses."""

    x: np.ndarray  #: (nx,) [m]
    y: np.ndarray  #: (ny,) [m]
    mask: np.ndarray  #: (nx, ny) bool
    theta1: np.ndarray  #: (P,) [rad], the poses at the masked nodes in C order
    theta2: np.ndarray  #: (P,)

    def to_map(self, values: np.ndarray) -> np.ndarray:
        """(nx, ny) with ``values`` (P,) at the poses and NaN elsewhere, for plotting."""
        out = np.full(self.mask.shape, np.nan)
        out[self.mask] = values
        return out


def _check_range(name: str, pair: tuple[float, float]) -> tuple[float, float]:
    low, high = (float(v) for v in pair)
    if not (np.isfinite(low) and np.isfinite(high) and low < high):
        raise DesignError(f"{name} range {low:g}...{high:g} deg: expected two finite numbers, low < high")
    return low, high


def design_grid(robot: Robot, n: int = DEFAULT_GRID, theta1_deg=DEFAULT_THETA1_DEG, theta2_deg=DEFAULT_THETA2_DEG,
                delta_deg=DEFAULT_DELTA_DEG) -> DesignGrid:  # fmt: skip
    """The n x n grid over the bounding box of the poses within the joint limits, kept where a pose reaches it.

    Each node is solved by :func:`~sailforce.kinematics.inverse` on the seed's
    branch (theta1 > theta2) and kept when its angles lie within the limits.
    """
    if n < 2:
        raise DesignError(f"grid = {n}: expected at least 2 points per side")
    t1r, t2r, dr = (np.radians(_check_range(name, r)) for name, r in
                    (("theta1", theta1_deg), ("theta2", theta2_deg), ("delta", delta_deg)))  # fmt: skip
    arm = robot.arm
    s1, s2 = np.meshgrid(np.linspace(t1r[0], t1r[1], BOUNDS_SAMPLES), np.linspace(t2r[0], t2r[1], BOUNDS_SAMPLES),
                         indexing="ij")  # fmt: skip
    inside = (s1 - s2 >= dr[0]) & (s1 - s2 <= dr[1])
    if not inside.any():
        raise DesignError("no pose satisfies the theta1, theta2 and delta limits together")
    bx, by = forward(arm, s1[inside], s2[inside])
    x, y = np.linspace(bx.min(), bx.max(), n), np.linspace(by.min(), by.max(), n)
    gx, gy = np.meshgrid(x, y, indexing="ij")
    r = np.hypot(gx, gy)
    reach = (r > abs(arm.l2 - arm.l3)) & (r < arm.l2 + arm.l3)
    theta1 = np.full(gx.shape, np.nan)
    theta2 = np.full(gx.shape, np.nan)
    theta1[reach], theta2[reach] = inverse(arm, gx[reach], gy[reach])
    # angles wrapped to (-pi, pi]: theta1 in the upper half-plane may come back near -pi
    theta1 = np.where(theta1 < t1r[0] - np.pi, theta1 + 2 * np.pi, theta1)
    delta = theta1 - theta2
    tol = 1e-9
    mask = reach & (theta1 >= t1r[0] - tol) & (theta1 <= t1r[1] + tol) & (theta2 >= t2r[0] - tol) & (theta2 <= t2r[1] + tol)
    mask &= (delta >= dr[0] - tol) & (delta <= dr[1] + tol)
    if not mask.any():
        raise DesignError("no grid point is a reachable pose within the limits: refine the grid or widen the limits")
    return DesignGrid(x, y, mask, theta1[mask], theta2[mask])


@dataclass(frozen=True)
class Design:
    """Every map of a design at the grid's poses (flat, ``(P,)`` leading)."""

    robot: Robot
    grid: DesignGrid
    safety_factor: float
    resolution: Resolution
    overload: Overload
    need: CompensationNeed
    modes: Modes
    condition: np.ndarray  #: (P,) condition number of J

    def poses(self) -> dict[str, np.ndarray]:
        """The per-pose arrays of ``design.json``, all of length P."""
        return {
            "theta1_deg": np.degrees(self.grid.theta1), "theta2_deg": np.degrees(self.grid.theta2),
            "resolution_N": self.resolution.worst, "resolution_minor_N": self.resolution.axes[..., 0],
            "resolution_direction_deg": np.degrees(self.resolution.worst_direction),
            "overload_N": self.overload.worst, "overload_direction_deg": np.degrees(self.overload.worst_direction),
            "overload_limit": self.overload.limiting_names(),
            "first_frequency_Hz": self.modes.frequencies_Hz[:, 0],
            "phase_need_deg": self.need.worst_phase_deg, "amplitude_need": self.need.worst_amplitude,
            "condition": self.condition,
        }  # fmt: skip

    def summary(self) -> dict[str, dict[str, float]]:
        """Worst and median of each map, and the reach."""
        return summarise(self.robot, self.grid, {
            "resolution_N": self.resolution.worst, "overload_N": self.overload.worst,
            "first_frequency_Hz": self.modes.frequencies_Hz[:, 0], "phase_need_deg": self.need.worst_phase_deg,
            "amplitude_need": self.need.worst_amplitude, "condition": self.condition,
        })  # fmt: skip


#: How each map's worst is taken: the largest noise, the smallest overload and frequency ...
WORST = {"resolution_N": np.max, "overload_N": np.min, "first_frequency_Hz": np.min, "phase_need_deg": np.max,
         "amplitude_need": np.max, "condition": np.max}  # fmt: skip


def summarise(robot: Robot, grid: DesignGrid, maps: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Worst (:data:`WORST`) and median of each map ``(P,)``, and the reach of the grid's poses."""
    out = {name: {"worst": float(WORST[name](v)), "median": float(np.median(v))} for name, v in maps.items()}
    x, y = forward(robot.arm, grid.theta1, grid.theta2)
    r = np.hypot(x, y)
    cell = (grid.x[1] - grid.x[0]) * (grid.y[1] - grid.y[0])
    out["reach_m"] = {"min": float(r.min()), "max": float(r.max()), "area_m2": float(grid.mask.sum() * cell)}
    return out


def run_design(robot: Robot, grid: DesignGrid | None = None, *, safety_factor: float = DEFAULT_SAFETY_FACTOR,
               modes: int = DEFAULT_MODES) -> Design:  # fmt: skip
    """Resolution, overload, compensation need and natural modes of ``robot`` at every pose of ``grid``."""
    if not (np.isfinite(safety_factor) and safety_factor > 0):
        raise DesignError(f"safety factor = {safety_factor!r}: expected a positive number")
    grid = design_grid(robot) if grid is None else grid
    model = build_model(robot)
    response = simulate_model(model, grid.theta1, grid.theta2)
    return Design(
        robot=robot, grid=grid, safety_factor=safety_factor,
        resolution=resolution(response.signal("bridge"), robot.loadcell.noise_mV_V),
        overload=overload(response, safety_factor), need=compensation_need(response),
        modes=arm_modes(model, grid.theta1, grid.theta2, modes),
        condition=jacobian_condition(robot.arm, grid.theta1, grid.theta2),
    )  # fmt: skip
