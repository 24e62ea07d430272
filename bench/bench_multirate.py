"""Real ADCs: the multi-rate estimate against the synchronous one on the same ticks, side by side, and its live budget.

The motion guide's task through two HX711s at 80 SPS and through an
ADS131M02 at 1 kSPS (1 kHz ticks, the dynamic term from the robot file),
tiled to 60 s; each estimated by :class:`sailforce.estimate.multirate.MultiRateEstimator`
in chunks of 4,096 rows (as a file or a stream is), against the synchronous
:func:`sailforce.estimate.estimate_moving` on the same ticks, alternately,
best of 3.  A 1 kHz stream leaves 1 ms a tick.
"""

from __future__ import annotations

import numpy as np
from _timing import best_of

from sailforce import Handle, Plane, Robot
from sailforce.adc import PRESETS
from sailforce.design.adc import exact_calibration
from sailforce.estimate import estimate_moving
from sailforce.estimate.multirate import MultiRateEstimator, held_loads
from sailforce.motion.differentiate import derivatives
from sailforce.motion.multirate import record_multirate

SECONDS = 60.0
CHUNK = 4096


def _session(robot, adc):
    task = record_multirate(robot, adc, reaches=8, hand_stiffness=100.0, seed=7)
    reps = int(np.ceil(SECONDS * 1000 / task.t.size))
    n = int(SECONDS * 1000)
    t = np.arange(n) * 1e-3
    shift = np.repeat(np.arange(reps) * task.t.size * 1e-3, task.t.size)[:n]
    return (t, np.tile(task.theta, (reps, 1))[:n], np.tile(task.loads, (reps, 1))[:n],
            (np.tile(task.load_t, (reps, 1))[:n] + shift[:, None]))  # fmt: skip


def _figures(name: str) -> list[tuple[str, str]]:
    robot = Robot(handle=Handle(mass=1.0), plane=Plane(tilt_deg=3.0), adc=PRESETS[name])
    cal = exact_calibration(robot)
    t, theta, loads, load_t = _session(robot, robot.adc)
    qd, qdd = derivatives(t, theta, cal.dynamics.differentiator)
    held = held_loads(loads)

    def multirate():
        est = MultiRateEstimator(cal)
        for a in range(0, t.size, CHUNK):
            b = a + CHUNK
            est.rows(t[a:b], theta[a:b], loads[a:b], load_t[a:b], np.zeros(t[a:b].size, bool), qd[a:b], qdd[a:b])

    synchronous = lambda: estimate_moving(replace_ideal(cal), cal.dynamics, t, theta[:, 0], theta[:, 1], held[:, 0], held[:, 1],
                                          rates=(qd, qdd))  # fmt: skip
    multi, sync = best_of(3, multirate), best_of(3, synchronous)
    per_tick = multi / t.size
    return [(f"{name}: multi-rate estimate, {t.size:,} ticks", f"{per_tick * 1e6:10.1f} us a tick"),
            (f"{name}: against the synchronous estimate, same ticks", f"{multi / sync:10.1f} x"),
            (f"{name}: share of a 1 kHz tick", f"{per_tick / 1e-3:10.1%}")]  # fmt: skip


def run() -> list[tuple[str, str]]:
    return _figures("hx711-80") + _figures("ads131m02-1000")


def replace_ideal(cal):
    from dataclasses import replace

    from sailforce.adc import ADC

    return replace(cal, adc=ADC())
