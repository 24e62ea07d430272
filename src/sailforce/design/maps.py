"""What a design gives at each pose: resolution, overload and how much compensation it needs.

All three follow from the frame's response to a unit hand force
(:class:`~sailforce.fem.response.ArmResponse`), batch dimensions leading.

**Resolution.** The bridge readings are s = S F (S, 2x2 [mV/V per N], the
sensing map).  The estimator inverts it, F = S^-1 s, so reading noise of
covariance diag(sigma_1^2, sigma_2^2) gives the force covariance

    C_F = S^-1 diag(sigma^2) S^-T,

an ellipse whose semi-axes are the square roots of C_F's eigenvalues [N, 1 sigma].
With pin joints S = g diag(1/l1, 1/l2) J^T (each cell reads the shear T_i / l_i,
g the bridge gain), so C_F = (sigma/g)^2 J^-T diag(l1^2, l2^2) J^-1: its area
goes as 1/|sin delta| (det J = l2 l3 sin delta), its worst axis does not.

**Overload.** For a hand force of direction phi, each cell's reading and each
link's von Mises stress grow in proportion to |F|.  The largest |F| before a
cell reaches its rated output, or a link its yield strength divided by the
safety factor, is the overload in that direction; the minimum over directions
is the pose's overload, with the element that limits it named.  Cells are
checked by their reading (crosstalk included), not by the block's nominal stress.

**Compensation need.** Each cell's row of S against the ideal row of a pin-
jointed arm, g/l_i times row i of J^T: as complex numbers in (x, y), their
ratio's argument is the phase [deg] and its modulus the relative amplitude.
Pin joints need none (phase 0, amplitude 1); bonded joints need what the
seed's Table 4 compensates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fem.model import LOADCELL_MEMBERS, MEMBERS
from ..fem.response import ArmResponse, member_stresses
from ..kinematics import jacobian

#: Default safety factor on the links' yield strength.
DEFAULT_SAFETY_FACTOR = 2.0
#: Hand-force directions the overload is searched over (every 5 deg).
OVERLOAD_DIRECTIONS = 72


@dataclass(frozen=True)
class Resolution:
    covariance: np.ndarray  #: (..., 2, 2) [N^2]
    axes: np.ndarray  #: (..., 2) 1-sigma semi-axes [N], ascending
    worst_direction: np.ndarray  #: (...,) direction of the larger axis [rad], in [0, pi)

    @property
    def worst(self) -> np.ndarray:
        """(...,) the 1-sigma force noise in the worst direction [N]."""
        return self.axes[..., 1]


def resolution(sensing: np.ndarray, noise) -> Resolution:
    """Force noise from reading noise ``noise`` (scalar or ``(2,)`` [mV/V]) through ``sensing`` ``(..., 2, 2)``."""
    inverse = np.linalg.inv(sensing)
    sigma2 = np.broadcast_to(np.asarray(noise, dtype=float) ** 2, (2,))
    covariance = inverse @ (sigma2[:, None] * np.swapaxes(inverse, -1, -2))
    eigenvalues, vectors = np.linalg.eigh(covariance)
    worst = vectors[..., :, 1]
    return Resolution(covariance, np.sqrt(np.clip(eigenvalues, 0.0, None)), np.mod(np.arctan2(worst[..., 1], worst[..., 0]), np.pi))


@dataclass(frozen=True)
class Overload:
    directions: np.ndarray  #: (D,) [rad]
    per_direction: np.ndarray  #: (..., D) the largest hand force in each direction [N]
    limiting: np.ndarray  #: (..., D) index into :data:`~sailforce.fem.model.MEMBERS` of the element that limits it
    worst: np.ndarray  #: (...,) the smallest over directions [N]
    worst_direction: np.ndarray  #: (...,) [rad]
    worst_limiting: np.ndarray  #: (...,) member index

    def limiting_names(self) -> np.ndarray:
        """(...,) the name of the element that limits each pose's worst direction."""
        return np.array([name for name, *_ in MEMBERS])[self.worst_limiting]


def overload(response: ArmResponse, safety_factor: float = DEFAULT_SAFETY_FACTOR,
             directions: int = OVERLOAD_DIRECTIONS) -> Overload:  # fmt: skip
    """The largest hand force before a cell saturates or a link yields, per direction and at the worst (module docstring)."""
    robot = response.model.robot
    phi = np.linspace(0.0, 2.0 * np.pi, directions, endpoint=False)
    bridge = response.signal("bridge")  # (..., 2, 2) mV/V per N
    links = np.array([kind != "cell" for *_, kind in MEMBERS])
    limits = []
    for angle in phi:
        c, s = np.cos(angle), np.sin(angle)
        reading = np.abs(bridge[..., 0] * c + bridge[..., 1] * s)  # (..., 2) per N
        with np.errstate(divide="ignore"):
            cells = robot.loadcell.rated_output_mV_V / reading
            stresses = member_stresses(response, c, s)
            per_member = stresses.yield_strength / (safety_factor * stresses.von_mises.max(axis=-1))  # (..., E)
        allowed = np.where(links, per_member, np.inf)
        allowed[..., list(LOADCELL_MEMBERS)] = cells
        limits.append(allowed)
    stacked = np.stack(limits, axis=-2)  # (..., D, E)
    limiting = np.argmin(stacked, axis=-1)
    per_direction = np.take_along_axis(stacked, limiting[..., None], axis=-1)[..., 0]
    k = np.argmin(per_direction, axis=-1)
    take = lambda a: np.take_along_axis(a, k[..., None], axis=-1)[..., 0]
    return Overload(phi, per_direction, limiting, take(per_direction), phi[k], take(limiting))


@dataclass(frozen=True)
class CompensationNeed:
    phase_deg: np.ndarray  #: (..., 2) each cell's phase against the pin-jointed ideal [deg]
    amplitude: np.ndarray  #: (..., 2) each cell's gain against the ideal (1: none needed)

    @property
    def worst_phase_deg(self) -> np.ndarray:
        return np.abs(self.phase_deg).max(axis=-1)

    @property
    def worst_amplitude(self) -> np.ndarray:
        """(...,) the larger |amplitude - 1| of the two cells."""
        return np.abs(self.amplitude - 1.0).max(axis=-1)


def compensation_need(response: ArmResponse) -> CompensationNeed:
    """Each cell's sensing row against the pin-jointed arm's g/l_i (J^T)_i (module docstring)."""
    robot = response.model.robot
    cell = robot.loadcell
    gain = cell.rated_output_mV_V / cell.capacity_N
    jt = np.swapaxes(jacobian(robot.arm, response.theta1, response.theta2), -1, -2)  # (..., 2, 2): rows j_i
    lengths = np.array([robot.arm.l1, robot.arm.l2])
    ideal = gain * jt / lengths[:, None]
    actual = response.signal("bridge")
    ratio = (actual[..., 0] + 1j * actual[..., 1]) / (ideal[..., 0] + 1j * ideal[..., 1])
    return CompensationNeed(np.degrees(np.angle(ratio)), np.abs(ratio))
