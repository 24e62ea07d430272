"""A whole therapy session: reaching for half an hour, the handle let go now and then, the cells drifting.

:func:`therapy_session` strings minimum-jerk reaches
(:func:`~sailforce.motion.reaching.reaching`) over ``minutes``.  The robot
moves the arm along them all the time.  A hand holds the handle, pulling
toward each target with ``hand_stiffness`` and a tremor (band-limited noise
of ``tremor_N`` rms per axis, 1 to 12 Hz: physiological tremor and postural
sway, which a held handle always shows), except for ``release_s`` at the end
of every ``release_every_s``, when nobody holds it (force 0, ``contact`` 0).
The cells' readings drift by :func:`sailforce.drift.drifted` along the
temperature profile.  What :func:`~sailforce.motion.reaching.record` does for
one recording it does here, and the result carries the truth: the force, the
temperature, the contact and the drift itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..drift import Drift, TemperatureProfile, cell_signs, drifted
from ..kinematics import forward
from ..robot import Robot
from ..synthetic import HX711_COUNTS_PER_MV_V, NoiseModel
from .reaching import MINJERK_PEAK_SPEED, MotionRecording, cell_counts, reaching

#: A hand's tremor band [Hz]: postural sway to physiological tremor (Elble & Koller, "Tremor", 1990: 8-12 Hz).
TREMOR_BAND_HZ = (1.0, 12.0)


@dataclass(frozen=True)
class TherapySession:
    """A simulated session and its truth."""

    recording: MotionRecording  #: its loads include the drift
    temperature_C: np.ndarray  #: ``(n,)`` the cells' temperature
    contact: np.ndarray  #: ``(n,)`` 1 while a hand holds the handle, 0 while it is let go
    drift_counts: np.ndarray  #: ``(n, 2)`` the drift in each cell's reading


def release_mask(t, release_every_s: float, release_s: float) -> np.ndarray:
    """Where the handle is let go: the last ``release_s`` of every ``release_every_s``."""
    t = np.asarray(t, float)
    if release_s <= 0:
        return np.zeros(t.shape, bool)
    return np.mod(t, release_every_s) >= release_every_s - release_s


#: Band-limited noise is drawn this many periods of the band's low edge longer at each end (:func:`tremor`).
SETTLING_PERIODS = 3.0

#: A person pushing the handle about, slowly and in every direction, for a reference-sensor calibration [Hz].
PUSH_BAND_HZ = (0.1, 2.0)


def tremor(t, rms_N: float, rng: np.random.Generator, band_Hz: tuple[float, float] = TREMOR_BAND_HZ) -> np.ndarray:
    """``(n, 2)`` band-limited noise [N] of ``rms_N`` per axis in ``band_Hz`` (a 2nd-order Butterworth band-pass,
    zero-phase)."""
    n = np.asarray(t).size
    if rms_N <= 0 or n < 32:
        return np.zeros((n, 2))
    rate = 1.0 / float(t[1] - t[0])
    from scipy.signal import butter, sosfiltfilt  # here: scipy.signal takes over a second to import

    sos = butter(2, [band_Hz[0], min(band_Hz[1], 0.45 * rate)], btype="bandpass", fs=rate, output="sos")
    # the filter settles over a few periods of its low edge: noise drawn that much longer at both ends, then cut
    # off, leaves no start-up transient in the signal (which, unpadded, held most of a 0.1 Hz band's power)
    lead = int(np.ceil(SETTLING_PERIODS * rate / band_Hz[0]))
    shaped = sosfiltfilt(sos, rng.normal(size=(n + 2 * lead, 2)), axis=0)[lead : lead + n]
    return rms_N * shaped / np.sqrt(np.mean(shaped**2, axis=0))


def therapy_session(robot: Robot, *, minutes: float = 30.0, release_every_s: float = 60.0, release_s: float = 10.0,
                    hand_stiffness: float = 100.0, tremor_N: float = 0.3, drift: Drift | None = None,
                    temperature: TemperatureProfile | None = None, reach: float = 0.3,
                    peak_speed: float = 0.75, dwell: float = 1.0, sample_rate_hz: float = 1000.0,
                    noise: NoiseModel = NoiseModel(), counts_per_rev: int = 1 << 16, seed: int = 0, rig: int = 1,
                    offsets=None) -> TherapySession:  # fmt: skip
    """A session of ``minutes`` (see the module docstring); ``drift`` (default :class:`~sailforce.drift.Drift`'s
    datasheet values; ``Drift.none()`` for none) along ``temperature`` (default :class:`~sailforce.drift.TemperatureProfile`);
    ``rig`` draws the signs of each cell's drift."""
    drift = Drift() if drift is None else drift
    temperature = TemperatureProfile() if temperature is None else temperature
    per_reach = MINJERK_PEAK_SPEED * reach / peak_speed + dwell
    motion = reaching(robot, reach=reach, reaches=max(1, math.ceil(minutes * 60.0 / per_reach)), peak_speed=peak_speed,
                      dwell=dwell, sample_rate_hz=sample_rate_hz)  # fmt: skip
    keep = motion.t < minutes * 60.0
    motion = type(motion)(*(np.ascontiguousarray(a[keep]) for a in (motion.t, motion.q, motion.qd, motion.qdd, motion.target)))
    rng = np.random.default_rng(seed)
    held = ~release_mask(motion.t, release_every_s, release_s)
    x = np.column_stack(forward(robot.arm, motion.q[:, 0], motion.q[:, 1]))
    force = (hand_stiffness * (motion.target - x) + tremor(motion.t, tremor_N, rng)) * held[:, None]
    counts, offsets, gain = cell_counts(robot, motion, force, offsets, rng, noise)
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    celsius = temperature.at(motion.t)
    drift_counts = drifted(motion.t, counts - offsets, celsius, drift, rated, cell_signs(rig))
    loads = counts + drift_counts + rng.normal(0.0, noise.noise_fraction * rated, counts.shape)
    if noise.quantize:
        loads = np.round(loads)
    step = 2 * np.pi / counts_per_rev
    theta = np.round(motion.q / step) * step
    recording = MotionRecording(motion.t, theta, loads, force, motion, np.asarray(offsets, float), gain)
    return TherapySession(recording, celsius, held.astype(float), drift_counts)
