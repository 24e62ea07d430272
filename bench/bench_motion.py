"""Force in motion (issue 11): the offline estimate with the dynamic term, against the static one, side by side.

A simulated free-motion recording identifies the term (1 kg handle, 3 deg
tilt); the task session is then tiled to 2e6 samples at 1 kHz and estimated
by :func:`sailforce.estimate.dynamic.estimate_moving` (rates from the angles, the
zero-phase rate filter, the dynamic term) and by the static
``Calibration.estimate`` on the same samples, alternately, best of 3.
"""

from __future__ import annotations

import numpy as np
from _timing import best_of

from sailforce.calibration.file import Calibration
from sailforce.estimate.dynamic import estimate_moving
from sailforce.fit.calibration import fit_calibration
from sailforce.fit.dynamic import fit_dynamic_term
from sailforce.motion.reaching import reaching, record
from sailforce.robot import Handle, Plane, Robot
from sailforce.synthetic import calibration_session

TARGET = 5e6  #: samples/s, the issue's figure for the offline estimate with dynamics
N = 2_000_000


def run() -> list[tuple[str, str]]:
    robot = Robot(handle=Handle(mass=1.0), plane=Plane(tilt_deg=3.0))
    t1, t2, fx, fy, counts, offsets = calibration_session(robot)
    model, fitted, report = fit_calibration(robot.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="matrix")
    cal = Calibration(arm=robot.arm, model=model, offsets=tuple(fitted), capacity=(1e9, 1e9), delta_range=report.delta_range)
    free = record(robot, reaching(robot, reaches=16), offsets=offsets, seed=3)
    term = fit_dynamic_term(cal, free.t, free.theta[:, 0], free.theta[:, 1], free.loads[:, 0], free.loads[:, 1]).term
    task = record(robot, reaching(robot, reaches=8), hand_stiffness=100.0, offsets=offsets, seed=7)
    reps = -(-N // task.t.size)
    t = np.arange(reps * task.t.size)[:N] * 1e-3
    theta = np.tile(task.theta, (reps, 1))[:N]
    loads = np.tile(task.loads, (reps, 1))[:N]
    moving = best_of(3, lambda: estimate_moving(cal, term, t, theta[:, 0], theta[:, 1], loads[:, 0], loads[:, 1], dt=1e-3))
    static = best_of(3, lambda: cal.estimate(theta[:, 0], theta[:, 1], loads[:, 0], loads[:, 1]))
    rate = N / moving
    return [
        (f"estimate_moving (rates, dynamic term), {N:.0e} samples", f"{rate / 1e6:10.2f} M samples/s"),
        ("Calibration.estimate (static), same samples", f"{N / static / 1e6:10.2f} M samples/s"),
        ("cost of the dynamic term", f"{moving / static:10.2f} x the static estimate"),
        ("target", f">= {TARGET / 1e6:g} M samples/s: {'met' if rate >= TARGET else 'NOT met'}"),
    ]
