"""Synthetic calibration and test recordings from the structural simulation, with a stated noise model.

Noise model (what a lab's recording would contain):

- **Transduction**: the bridge output of each cell [mV/V]
  (:meth:`sailforce.loadcell.LoadCell.bridge_signal`) from the frame model.
- **HX711 conversion**: 24-bit, gain 128, excitation = AVDD, so full scale
  +-0.5 AVDD / 128 is 2^23 counts: 2^23 * 128 / 500 = 2,147,484 counts per mV/V.
  Readings are rounded to whole counts (the quantization).
- **Noise**: Gaussian, ``noise_fraction`` of the cell's rated output
  (default 0.01%, the order of a C3 cell's combined error, far above the
  HX711's ~20 counts of input noise at 10 SPS).
- **Offsets**: each cell's zero balance, drawn uniformly within
  +-``offset_fraction`` of rated output (default 2%, a typical datasheet limit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fem.model import build_model
from .fem.response import simulate_model
from .robot import Robot

HX711_COUNTS_PER_MV_V = 2**23 * 128 / 500.0  #: see the module docstring


@dataclass(frozen=True)
class NoiseModel:
    """The recording's imperfections; see the module docstring."""

    noise_fraction: float = 1e-4  #: Gaussian noise, fraction of rated output
    offset_fraction: float = 0.02  #: zero-balance offsets, fraction of rated output
    quantize: bool = True  #: round to whole HX711 counts


def recording(robot: Robot, theta1, theta2, fx, fy, *, noise: NoiseModel = NoiseModel(), seed: int = 0,
              offsets=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Raw counts (load1, load2) for forces (fx, fy) [N] at poses [rad], and the offsets used, ``(2,)``.

    Also returns the noise-free counts ``(n, 2)`` (offset included) for computing the noise floor.
    """
    rng = np.random.default_rng(seed)
    theta1, theta2, fx, fy = np.broadcast_arrays(*(np.asarray(a, float) for a in (theta1, theta2, fx, fy)))
    if offsets is None:
        offsets = session_offsets(robot, noise, seed)
    unit = simulate_model(build_model(robot), theta1, theta2).signal("bridge")  # (n, 2, 2) mV/V per N
    signal = (unit @ np.stack([fx, fy], axis=-1)[..., None])[..., 0]  # mV/V
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    rng.uniform(-1, 1, 2)  # the draw that once made the offsets: keeps the noise of every seed as it was
    clean = offsets + signal * HX711_COUNTS_PER_MV_V
    counts = clean + rng.normal(0.0, noise.noise_fraction * rated, clean.shape)
    if noise.quantize:
        counts = np.round(counts)
    return counts, np.asarray(offsets, float), clean


def session_offsets(robot: Robot, noise: NoiseModel, seed: int) -> np.ndarray:
    """The cells' zero offsets [counts] of the simulated rig numbered ``seed``: the same in every recording made with it."""
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    return np.random.default_rng(seed).uniform(-1, 1, 2) * noise.offset_fraction * rated


def calibration_session(robot: Robot, *, seed: int = 1, step_deg: float = 7.5, directions: int = 12,
                        force_N: float = 20.0, noise: NoiseModel = NoiseModel(), offsets=None):  # fmt: skip
    """A pulley-and-weights session: poses every ``step_deg`` over delta = 15..165 deg at random theta2,
    ``directions`` forces of ``force_N`` at each.

    Returns ``(theta1, theta2, fx, fy, counts, offsets)``: angles [rad], forces [N],
    raw counts ``(n, 2)`` from :func:`recording`, and the offsets used
    (``offsets`` given: that rig's, e.g. :func:`session_offsets`).
    """
    rng = np.random.default_rng(seed)
    delta = np.radians(np.arange(15.0, 165.0 + 1e-9, step_deg))
    theta2 = rng.uniform(-0.5, 0.5, delta.size)
    phi = np.radians(np.arange(0.0, 360.0, 360.0 / directions))
    t1, t2 = np.repeat(delta + theta2, phi.size), np.repeat(theta2, phi.size)
    fx, fy = np.tile(force_N * np.cos(phi), delta.size), np.tile(force_N * np.sin(phi), delta.size)
    counts, offsets, _ = recording(robot, t1, t2, fx, fy, noise=noise, seed=seed + 1, offsets=offsets)
    return t1, t2, fx, fy, counts, offsets
