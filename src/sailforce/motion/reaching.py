"""Reaching movements and what a recording of them holds: joint states, hand forces and cell readings.

- **Trajectories**: minimum-jerk reaches between workspace points (Flash &
  Hogan, *J. Neurosci.* 5(7), 1985):
  ``x(t) = x0 + (x1 - x0)(10 s^3 - 15 s^4 + 6 s^5)``, ``s = t / T``, whose
  peak speed is ``1.875 D / T`` and peak acceleration ``5.7735 D / T^2``
  for a reach of length D.  Joint states follow exactly:
  ``qd = J^-1 xd`` and ``qdd = J^-1 (xdd - Jd qd)`` (seed Eq. 4's J).
- **Recordings**: what the cells read, ``offset + k V`` with ``V`` the
  shears of :mod:`sailforce.motion.dynamics` (inertia, gravity and the hand's
  force) and ``k`` the HX711 counts per newton of shear of the robot's cell,
  with the noise model of :mod:`sailforce.synthetic`; encoder angles
  quantized to ``counts_per_rev``.  For pin joints this is exact (the frame
  is statically determinate, so a cell reads its shear); for joints that
  carry moment the static part is still the rigid one, a stated
  approximation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import kernel
from ..kinematics import forward, inverse, jacobian
from ..robot import Robot
from ..synthetic import HX711_COUNTS_PER_MV_V, NoiseModel
from .dynamics import cell_shears, inertial_parameters

#: Peak speed / (D / T) and peak acceleration / (D / T^2) of a minimum-jerk reach.
MINJERK_PEAK_SPEED = 1.875
MINJERK_PEAK_ACCELERATION = 10.0 / np.sqrt(3.0)


@dataclass(frozen=True)
class JointMotion:
    """Sampled joint states: time [s] ``(n,)``; angles [rad], rates [rad/s], accelerations [rad/s^2] ``(n, 2)``."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    target: np.ndarray  #: ``(n, 2)`` the current reach's end point [m], for hand-force profiles


def minimum_jerk(start, stop, duration: float, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration ``(n, 2)`` of a minimum-jerk reach at times ``t`` in [0, duration]."""
    s = np.clip(np.asarray(t, float) / duration, 0.0, 1.0)[:, None]
    d = np.asarray(stop, float) - np.asarray(start, float)
    shape = 10 * s**3 - 15 * s**4 + 6 * s**5
    rate = (30 * s**2 - 60 * s**3 + 30 * s**4) / duration
    curvature = (60 * s - 180 * s**2 + 120 * s**3) / duration**2
    return np.asarray(start, float) + d * shape, d * rate, d * curvature


#: Successive targets on the circle are this far apart [rad]: 135 deg, so that 8 reaches visit 8 directions.
TARGET_STEP = 3 * np.pi / 4


def reaching(robot: Robot, *, reach: float = 0.3, reaches: int = 8, peak_speed: float = 0.75, dwell: float = 0.3,
             sample_rate_hz: float = 1000.0, centre=None) -> JointMotion:  # fmt: skip
    """Point-to-point reaches of length ``reach`` [m] between targets on a circle, one after the other.

    Target k sits at angle 135 deg x k on a circle about ``centre`` [m]
    (default: A at theta1 = 90 deg, theta2 = 0), so each reach is a chord of
    length ``reach`` and 8 reaches visit 8 directions.  Each takes
    ``1.875 reach / peak_speed`` seconds and is followed by ``dwell``
    seconds at rest.
    """
    arm = robot.arm
    centre = np.array(forward(arm, np.pi / 2, 0.0) if centre is None else centre, dtype=float)
    radius = reach / (2 * np.sin(TARGET_STEP / 2))
    duration = MINJERK_PEAK_SPEED * reach / peak_speed
    dt = 1.0 / sample_rate_hz
    local = np.arange(0.0, duration + dwell, dt)
    points = centre + radius * np.column_stack([np.cos(TARGET_STEP * np.arange(reaches + 1)),
                                                np.sin(TARGET_STEP * np.arange(reaches + 1))])  # fmt: skip
    pieces = [(*minimum_jerk(a, b, duration, local), np.broadcast_to(b, (local.size, 2))) for a, b in zip(points, points[1:])]
    x, xd, xdd, target = (np.concatenate(p) for p in zip(*pieces))
    t = np.arange(x.shape[0]) * dt
    theta1, theta2 = inverse(arm, x[:, 0], x[:, 1])
    q = np.unwrap(np.column_stack([theta1, theta2]), axis=0)
    J = kernel.entries(jacobian(arm, q[:, 0], q[:, 1]))
    qd = np.column_stack(kernel.solve_2x2(J, xd[:, 0], xd[:, 1], False))
    c, s = np.cos(q), np.sin(q)
    jd_qd = np.column_stack([-arm.l3 * c[:, 0] * qd[:, 0] ** 2 - arm.l2 * c[:, 1] * qd[:, 1] ** 2,
                             -arm.l3 * s[:, 0] * qd[:, 0] ** 2 - arm.l2 * s[:, 1] * qd[:, 1] ** 2])  # fmt: skip
    qdd = np.column_stack(kernel.solve_2x2(J, *(xdd - jd_qd).T, False))
    return JointMotion(t, q, qd, qdd, np.ascontiguousarray(target))


def counts_per_newton(robot: Robot) -> float:
    """HX711 counts per newton of shear in a cell: rated output at capacity, through the HX711."""
    return robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V / robot.loadcell.capacity_N


def cell_counts(robot: Robot, motion: JointMotion, force: np.ndarray, offsets, rng: np.random.Generator,
                noise: NoiseModel) -> tuple[np.ndarray, np.ndarray, float]:  # fmt: skip
    """Each cell's noise-free counts ``(n, 2)`` along ``motion`` under the hand's ``force``, the offsets, the gain.

    ``offset + k V`` with ``V`` the shears of :func:`~sailforce.motion.dynamics.cell_shears` and ``k``
    :func:`counts_per_newton`; the offsets are drawn from ``rng`` when None (within ``noise.offset_fraction``).
    """
    v1, v2 = cell_shears(robot.arm, inertial_parameters(robot), motion.q[:, 0], motion.q[:, 1], motion.qd[:, 0],
                         motion.qd[:, 1], motion.qdd[:, 0], motion.qdd[:, 1], gravity=robot.plane.gravity,
                         fx=force[:, 0], fy=force[:, 1])  # fmt: skip
    gain = counts_per_newton(robot)
    if offsets is None:
        offsets = rng.uniform(-1, 1, 2) * noise.offset_fraction * robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    return np.asarray(offsets, float) + gain * np.column_stack([v1, v2]), np.asarray(offsets, float), gain


@dataclass(frozen=True)
class MotionRecording:
    """A simulated session: what the lab records, and the truth behind it."""

    t: np.ndarray  #: [s]
    theta: np.ndarray  #: ``(n, 2)`` encoder angles [rad], quantized
    loads: np.ndarray  #: ``(n, 2)`` raw counts
    force: np.ndarray  #: ``(n, 2)`` the hand's true force [N]
    motion: JointMotion  #: the true joint states
    offsets: np.ndarray  #: ``(2,)`` the cells' zero offsets [counts]
    gain: float  #: counts per newton of shear


def record(robot: Robot, motion: JointMotion, *, hand_stiffness: float = 0.0, noise: NoiseModel = NoiseModel(),
           counts_per_rev: int = 1 << 16, seed: int = 0, offsets=None, force=None) -> MotionRecording:  # fmt: skip
    """Cell readings and encoder angles along ``motion``.

    The hand pulls toward the current reach's end point with
    ``hand_stiffness`` [N/m] (0: free motion, nobody holding the handle),
    unless its ``force`` ``(n, 2)`` [N] is given.
    """
    rng = np.random.default_rng(seed)
    if force is None:
        x = np.column_stack(forward(robot.arm, motion.q[:, 0], motion.q[:, 1]))
        force = hand_stiffness * (motion.target - x)
    force = np.asarray(force, float)
    loads, offsets, gain = cell_counts(robot, motion, force, offsets, rng, noise)
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    loads = loads + rng.normal(0.0, noise.noise_fraction * rated, loads.shape)
    if noise.quantize:
        loads = np.round(loads)
    step = 2 * np.pi / counts_per_rev
    theta = np.round(motion.q / step) * step
    return MotionRecording(motion.t, theta, loads, force, motion, np.asarray(offsets, float), gain)
