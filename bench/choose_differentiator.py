"""Why sailforce.motion.differentiate uses a 0.1 s, order-4 local polynomial fit: the error of each candidate.

    .venv/bin/python bench/choose_differentiator.py

A simulated session (sailforce.motion.reaching: 8 reaches of 0.3 m at 3 m/s^2, 1 kHz,
16-bit encoders, a 1 kg handle) is differentiated by Savitzky-Golay fits of
several windows and orders, and by central differences after a zero-phase
Butterworth low-pass; the RMS errors of the rates and accelerations against
the exact joint states are printed, best first.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from sailforce.motion.reaching import reaching, record
from sailforce.robot import Handle, Robot

EDGE = 200  #: samples left out at each end, where the filters run off the data


def rms(estimate: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean((estimate[EDGE:-EDGE] - truth[EDGE:-EDGE]) ** 2)))


def main() -> None:
    robot = Robot(handle=Handle(mass=1.0))
    motion = reaching(robot, reaches=8)
    q = record(robot, motion).theta
    dt = motion.t[1] - motion.t[0]
    results = []
    for order in (2, 3, 4):
        for width in (21, 41, 61, 81, 101, 151):
            qd = signal.savgol_filter(q, width, order, deriv=1, delta=dt, axis=0)
            qdd = signal.savgol_filter(q, width, order, deriv=2, delta=dt, axis=0)
            results.append((rms(qdd, motion.qdd), rms(qd, motion.qd), f"Savitzky-Golay {width} samples, order {order}"))
    for cutoff in (5, 10, 20, 40):
        b, a = signal.butter(2, cutoff, fs=1 / dt)
        smooth = signal.filtfilt(b, a, q, axis=0)
        qd = np.gradient(smooth, dt, axis=0)
        results.append((rms(np.gradient(qd, dt, axis=0), motion.qdd), rms(qd, motion.qd),
                        f"Butterworth-2 {cutoff} Hz filtfilt + central differences"))  # fmt: skip
    print(f"acceleration RMS of the session: {np.sqrt(np.mean(motion.qdd**2)):.3f} rad/s^2")
    for accel, rate, name in sorted(results):
        print(f"{name:58s} acceleration {accel:.4f} rad/s^2, rate {rate:.5f} rad/s")


if __name__ == "__main__":
    main()
