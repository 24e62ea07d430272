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
is the pose's overload, with the element that limits it named.  That minimum
is exact: each element's worst direction has a closed form
(:func:`element_peaks`), and the pose's worst is the weakest element at its
own worst.  Cells are checked by their reading (crosstalk included), not by
the block's nominal stress.

**Compensation need.** Each cell's row of S against the ideal row of a pin-
jointed arm, g/l_i times row i of J^T: as complex numbers in (x, y), their
ratio's argument is the phase [deg] and its modulus the relative amplitude.
Pin joints need none (phase 0, amplitude 1); bonded joints need what the
seed's Table 4 compensates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import kernel
from ..fem.model import LOADCELL_MEMBERS, MEMBERS
from ..fem.response import ArmResponse, _section_table
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
    inverse = kernel.matrix(kernel.inverse_entries(kernel.entries(sensing)))
    sigma2 = np.broadcast_to(np.asarray(noise, dtype=float) ** 2, (2,))
    covariance = inverse @ (sigma2[:, None] * np.swapaxes(inverse, -1, -2))
    eigenvalues, vectors = np.linalg.eigh(covariance)
    worst = vectors[..., :, 1]
    return Resolution(covariance, np.sqrt(np.clip(eigenvalues, 0.0, None)), np.mod(np.arctan2(worst[..., 1], worst[..., 0]), np.pi))


@dataclass(frozen=True)
class Overload:
    worst: np.ndarray  #: (...,) the largest hand force in the worst direction [N], exact
    worst_direction: np.ndarray  #: (...,) that direction [rad], in [0, pi)
    worst_limiting: np.ndarray  #: (...,) index into :data:`~sailforce.fem.model.MEMBERS` of the element that limits it
    directions: np.ndarray  #: (D,) [rad] the sampled directions (D = 0: not sampled)
    per_direction: np.ndarray  #: (..., D) the largest hand force in each sampled direction [N]
    limiting: np.ndarray  #: (..., D) the element that limits each

    def limiting_names(self) -> np.ndarray:
        """(...,) the name of the element that limits each pose's worst direction."""
        return np.array([name for name, *_ in MEMBERS])[self.worst_limiting]


def _principal(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest eigenvalue of [[a, b], [b, c]] and the angle of its eigenvector, in closed form."""
    mean, half = 0.5 * (a + c), np.hypot(0.5 * (a - c), b)
    return mean + half, 0.5 * np.arctan2(2.0 * b, a - c)


@dataclass(frozen=True)
class _Forms:
    """Each element's load per newton of hand force as linear forms in u = (cos phi, sin phi), ``(..., E, 2)`` each."""

    fibre: tuple[np.ndarray, ...]  #: n/A +- m/S at both ends: |w.u| is the extreme-fibre stress [Pa/N]
    neutral: tuple[np.ndarray, np.ndarray]  #: n/A and 1.5 sqrt(3) v/A: the neutral axis's von Mises is |(n.u, v.u)|
    bridge: np.ndarray  #: (..., 2 cells, 2) bridge reading per N [mV/V]
    strength: np.ndarray  #: (E,) yield strength [Pa]
    rated: float  #: the cells' rated output [mV/V]


def _forms(response: ArmResponse) -> _Forms:
    robot = response.model.robot
    ef = response.end_forces  # (..., E, 6, 2)
    area, modulus, strength = (a[:, None] for a in _section_table(robot))
    n, v = ef[..., 3, :] / area, 1.5 * math.sqrt(3.0) * ef[..., 4, :] / area
    ends = (-ef[..., 2, :] / modulus, ef[..., 5, :] / modulus)  # the moment at end i and end j
    fibre = tuple(n + sign * m for m in ends for sign in (1.0, -1.0))
    return _Forms(fibre, (n, v), response.signal("bridge"), strength[:, 0], robot.loadcell.rated_output_mV_V)


def element_peaks(response: ArmResponse) -> tuple[np.ndarray, np.ndarray]:
    """Each element's largest load ratio per newton of hand force over all directions, and that direction.

    Returns ``(..., E)`` arrays: for a cell, its bridge reading per N over
    its rated output; for a link member, its peak von Mises stress per N
    over its yield strength.  Every internal force is linear in the hand
    force's direction u = (cos phi, sin phi): N = n.u, V = v.u, M = m.u at
    each end.  The extreme fibre's |N|/A + |M|/S = max over the sign of
    |(n/A +- m/S).u| peaks at the larger |n/A +- m/S|, along it; the neutral
    axis's sqrt((N/A)^2 + 3 (1.5 V/A)^2) = |G u|, G = [n/A; 1.5 sqrt(3) v/A],
    peaks at G's largest singular value, along its principal direction.
    """
    forms = _forms(response)
    candidates = [(np.hypot(w[..., 0], w[..., 1]), np.arctan2(w[..., 1], w[..., 0])) for w in forms.fibre]
    n, v = forms.neutral
    gram = (n[..., 0] ** 2 + v[..., 0] ** 2, n[..., 0] * n[..., 1] + v[..., 0] * v[..., 1], n[..., 1] ** 2 + v[..., 1] ** 2)
    peak, angle = _principal(*gram)
    candidates.append((np.sqrt(np.clip(peak, 0.0, None)), angle))
    values = np.stack([c[0] for c in candidates])
    angles = np.stack([c[1] for c in candidates])
    k = np.argmax(values, axis=0)
    ratio = np.take_along_axis(values, k[None], axis=0)[0] / forms.strength
    direction = np.take_along_axis(angles, k[None], axis=0)[0]
    cells, bridge = list(LOADCELL_MEMBERS), forms.bridge
    ratio[..., cells] = np.hypot(bridge[..., 0], bridge[..., 1]) / forms.rated
    direction[..., cells] = np.arctan2(bridge[..., 1], bridge[..., 0])
    return ratio, np.mod(direction, np.pi)


def _sampled(response: ArmResponse, safety_factor: float, phi: np.ndarray, links: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The allowed hand force along each direction ``phi``, ``(..., D)``, and the element that limits it."""
    forms = _forms(response)
    u = np.stack([np.cos(phi), np.sin(phi)])  # (2, D)
    fibre = np.max([np.abs(w @ u) for w in forms.fibre], axis=0)  # (..., E, D)
    n, v = forms.neutral
    stress = np.maximum(fibre, np.hypot(n @ u, v @ u))
    ratio = np.where(links[:, None], safety_factor * stress / forms.strength[:, None], 0.0)
    ratio[..., list(LOADCELL_MEMBERS), :] = np.abs(forms.bridge @ u) / forms.rated
    limiting = np.argmax(ratio, axis=-2)  # (..., D)
    with np.errstate(divide="ignore"):
        return 1.0 / np.take_along_axis(ratio, limiting[..., None, :], axis=-2)[..., 0, :], limiting


def overload(response: ArmResponse, safety_factor: float = DEFAULT_SAFETY_FACTOR,
             directions: int = OVERLOAD_DIRECTIONS) -> Overload:  # fmt: skip
    """The largest hand force before a cell saturates or a link yields: exact at the worst direction, sampled per direction.

    Links are allowed their yield strength over ``safety_factor``, cells their
    rated output.  The worst direction is exact (:func:`element_peaks`); the
    per-direction map samples ``directions`` directions over the circle (0:
    skip it, as sweeps do).
    """
    ratio, direction = element_peaks(response)  # (..., E)
    links = np.array([kind != "cell" for *_, kind in MEMBERS])
    ratio = np.where(links, ratio * safety_factor, ratio)
    with np.errstate(divide="ignore"):
        allowed = 1.0 / ratio
    worst_limiting = np.argmin(allowed, axis=-1)
    take = lambda a: np.take_along_axis(a, worst_limiting[..., None], axis=-1)[..., 0]
    phi = np.linspace(0.0, 2.0 * np.pi, directions, endpoint=False)
    per_direction, limiting = _sampled(response, safety_factor, phi, links)
    return Overload(take(allowed), take(direction), worst_limiting, phi, per_direction, limiting)


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


def adc_noise_at_hand(robot, theta1: float = np.pi / 2, theta2: float = 0.0) -> float:
    """The 1-sigma force noise in the worst direction [N] that the ADC's input noise alone gives at a pose [rad].

    The cells read the shears of a pin-jointed arm, ``V_i = (J^T F)_i / l_i``
    (docs/errata.md, Physics), through their rated output
    (``rated_output_mV_V / capacity_N`` per newton of shear); the ADC's noise
    (:attr:`sailforce.adc.ADC.noise_mV_V`) goes back through that map
    (:func:`resolution`).  The ideal ADC has none.
    """
    cell = robot.loadcell
    if robot.adc.noise_nV == 0:
        return 0.0
    jt = np.swapaxes(jacobian(robot.arm, theta1, theta2), -1, -2)
    sensing = cell.rated_output_mV_V / cell.capacity_N * jt / np.array([robot.arm.l1, robot.arm.l2])[:, None]
    return float(resolution(sensing, robot.adc.noise_mV_V).worst)
