"""The reference sensor's mount angle and offsets, fitted to the cells' readings at rest.

At rest a cell reads its shear through its gain (seed Eqs. 6-7; with no motion
and no gravity, Eqs. D1-D2 of docs/dynamics.md):

    load_i = c_i + g_i [S(theta) F_base]_i,   F_base = R(phi) (F_sensor - b)

with ``S(theta)`` the rigid statics' shear per unit hand force
(:func:`sailforce.motion.dynamics.cell_shears`), ``phi`` the sensor's angle
(:func:`sailforce.reference.sensor.sensor_angle`), and unknowns the mount,
the sensor's offsets ``b``, the cells' offsets ``c`` and gains ``g``: 7
numbers, by nonlinear least squares (``scipy.optimize.least_squares``) from
the best mount of a scan over the circle (each step a linear fit).

Why the rigid statics and not the calibration's own map: a map fitted
freely (``matrix``) takes any constant rotation of the force into itself, so
it cannot see the mount; the rigid statics with one gain per cell can.  Where
the arm's joints carry moment the statics are a few percent off with Δ
(the seed's FE study), and the mount fitted with them is off by a fraction of
that; the residual says how well they fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kinematics import Links
from ..motion.dynamics import InertialParameters, cell_shears
from .sensor import ReferenceRecording, rotate, rotation, sensor_angle

#: The mount scan's step [rad] before the least-squares polish: 2 degrees, well inside the polish's reach.
MOUNT_SCAN_STEP = np.radians(2.0)

#: The clock refinement stops within this of the best offset [s].
CLOCK_XTOL_S = 1e-6

#: At least this many rows at rest for a frame fit: 7 unknowns, and poses and directions enough to separate them.
MIN_FRAME_ROWS = 50


@dataclass(frozen=True)
class SensorFrame:
    """What :func:`fit_frame` found: the sensor's mount and offsets, and the cells' offsets and gains beside them."""

    mount_rad: float
    mount_se_rad: float  #: its standard error, from the fit's Jacobian
    offsets_N: tuple[float, float]  #: ``b``, what the sensor reads in-plane with no force
    offsets_se_N: tuple[float, float]
    cell_offsets: tuple[float, float]  #: ``c``, raw
    cell_gains: tuple[float, float]  #: ``g``, raw per newton of shear
    rmse_raw: float  #: the readings' residual
    rows: int
    on: str
    offsets_fitted: bool = True  #: False: the offsets were given (a tared sensor), their errors 0

    def to_base(self, theta1, f_sensor) -> np.ndarray:
        """The hand force in the base frame ``(n, 2)`` [N] from the sensor's ``(n, 2)`` at ``theta1`` [rad]."""
        phi = sensor_angle(self.mount_rad, theta1, self.on)
        return rotate(phi, np.asarray(f_sensor, float) - np.asarray(self.offsets_N))


    def residual(self, arm: Links, theta1, theta2, loads, f_sensor) -> np.ndarray:
        """The readings less what this frame predicts of them, ``(n, 2)`` raw (rows at rest)."""
        p = np.array([self.mount_rad, *self.offsets_N, *self.cell_offsets, *self.cell_gains])
        return np.asarray(loads, float) - _predicted(p, shear_map(arm, theta1, theta2), np.asarray(theta1, float),
                                                     np.asarray(f_sensor, float), self.on)  # fmt: skip


def refine_clock(arm: Links, frame: SensorFrame, t, theta, loads, reference: ReferenceRecording, offset_s: float,
                 span_s: float) -> float:  # fmt: skip
    """The clock offset within ``offset_s +- span_s`` that leaves the least residual to ``frame``: the readings
    at rest ``t`` [s], ``theta`` ``(n, 2)`` [rad], ``loads`` ``(n, 2)``, against the sensor's forces read at
    ``t + offset``.  The canonical correlation finds the peak; the model, which knows the map, sharpens it (a
    hand's slow push gives a broad peak)."""
    from scipy.optimize import minimize_scalar

    t, theta = np.asarray(t, float), np.asarray(theta, float)

    def cost(offset: float) -> float:
        f = np.column_stack([np.interp(t + offset, reference.t, reference.force[:, k]) for k in range(2)])
        return float(np.mean(frame.residual(arm, theta[:, 0], theta[:, 1], loads, f) ** 2))

    best = minimize_scalar(cost, bounds=(offset_s - span_s, offset_s + span_s), method="bounded",
                           options={"xatol": CLOCK_XTOL_S})  # fmt: skip
    return float(best.x)


def shear_map(arm: Links, theta1, theta2) -> np.ndarray:
    """``S(theta)`` ``(n, 2, 2)``: each cell's shear [N] per newton of hand force along x and along y, at rest."""
    none = InertialParameters()
    columns = [np.column_stack(cell_shears(arm, none, theta1, theta2, fx=fx, fy=fy)) for fx, fy in ((1.0, 0.0), (0.0, 1.0))]
    return np.stack(columns, axis=-1)


def _predicted(p, S, theta1, f_sensor, on):
    mount, b, c, g = p[0], p[1:3], p[3:5], p[5:7]
    force = rotate(sensor_angle(mount, theta1, on), f_sensor - b)
    return c + g * np.einsum("nij,nj->ni", S, force)


def _scan_start(S, theta1, f_sensor, loads, on) -> np.ndarray:
    """The best mount on a scan, each with its linear fit of ``c``, ``g`` and ``g b`` (``b`` per cell, then shared)."""
    best_cost, best_mount, best = np.inf, 0.0, np.zeros((2, 4))
    for mount in np.arange(-np.pi, np.pi, MOUNT_SCAN_STEP):
        phi = sensor_angle(mount, theta1, on)
        R = rotation(phi)
        cost, solution = 0.0, np.zeros((2, 4))
        for i in range(2):
            u = np.einsum("nj,nj->n", S[:, i, :], rotate(phi, f_sensor))  # shear of F_sensor turned to the base
            # load_i = c_i + g_i u - g_i [S R(phi)]_i b: linear in c_i, g_i and h = g_i b
            w = -np.einsum("nj,njk->nk", S[:, i, :], R)
            A = np.column_stack([np.ones(u.size), u, w])
            x, *_ = np.linalg.lstsq(A, loads[:, i], rcond=None)
            cost += float(np.sum((A @ x - loads[:, i]) ** 2))
            solution[i] = x
        if cost < best_cost:
            best_cost, best_mount, best = cost, float(mount), solution
    c, g, h = best[:, 0], best[:, 1], best[:, 2:]
    b = 0.5 * (h[0] / g[0] + h[1] / g[1])
    return np.array([best_mount, *b, *c, *g])


def fit_frame(arm: Links, theta1, theta2, loads, f_sensor, *, on: str = "link", offsets_N=None) -> SensorFrame:
    """The sensor's frame from rows at rest: angles [rad], raw ``loads`` ``(n, 2)``, the sensor's forces ``(n, 2)``
    at the same instants (module docstring).

    ``offsets_N`` fixes the sensor's offsets instead (``(0, 0)`` for a sensor
    tared before the session).  Fitted, they are the frame's least certain
    part: on the link, cell 1 sees them as a constant, like its own offset
    (``S_1 R(theta1)`` does not change with the pose), so only cell 2 over
    the Δ range separates them; their standard errors say how well.
    """
    from scipy.optimize import least_squares

    theta1, theta2 = np.asarray(theta1, float), np.asarray(theta2, float)
    loads, f_sensor = np.asarray(loads, float), np.asarray(f_sensor, float)
    if theta1.size < MIN_FRAME_ROWS:
        raise InputError(f"only {theta1.size} samples at rest to fit the reference sensor's mount (at least "
                         f"{MIN_FRAME_ROWS}): hold the arm still at several poses while pushing the handle")  # fmt: skip
    S = shear_map(arm, theta1, theta2)
    start = _scan_start(S, theta1, f_sensor, loads, on)
    free = np.arange(7)
    if offsets_N is not None:
        start[1:3] = np.asarray(offsets_N, float)
        free = np.array([0, 3, 4, 5, 6])
    scale = np.array([1.0, 1.0, 1.0, *np.maximum(np.abs(start[3:5]), 1.0), *np.maximum(np.abs(start[5:7]), 1e-9)])
    full = start.copy()

    def residual(x):
        full[free] = x
        return (_predicted(full, S, theta1, f_sensor, on) - loads).ravel()

    fit = least_squares(residual, start[free], x_scale=scale[free], method="lm")
    p = start.copy()
    p[free] = fit.x
    if p[5] < 0 and p[6] < 0:  # the same fit with the force turned half a turn: keep positive gains
        p[0] += np.pi
        p[5:7] *= -1
    dof = max(fit.fun.size - fit.x.size, 1)
    rss = float(np.sum(fit.fun**2))
    se = np.zeros(7)
    se[free] = np.sqrt(np.maximum(np.diag(np.linalg.pinv(fit.jac.T @ fit.jac) * rss / dof), 0.0))
    mount = float(np.angle(np.exp(1j * p[0])))
    return SensorFrame(mount, float(se[0]), (float(p[1]), float(p[2])), (float(se[1]), float(se[2])),
                       (float(p[3]), float(p[4])), (float(p[5]), float(p[6])), float(np.sqrt(rss / fit.fun.size)),
                       int(theta1.size), on, offsets_N is None)  # fmt: skip
