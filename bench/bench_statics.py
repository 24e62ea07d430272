"""Throughput of Arm.end_effector_force on 10^7 poses: compiled kernel against numpy, and against a per-pose Python loop."""

from __future__ import annotations

import numpy as np
from _timing import best_of

from sailforce import Arm, kernel

N_BATCH = 10_000_000
N_LOOP = 20_000  # the loop is ~10^4 times slower; a subset gives its rate
TARGET_PER_S = 50e6


def run() -> list[tuple[str, str]]:
    rng = np.random.default_rng(0)
    arm = Arm()
    theta2 = rng.uniform(-np.pi, np.pi, N_BATCH)
    theta1 = theta2 + rng.uniform(0.3, 2.8, N_BATCH)
    t1, t2 = rng.normal(size=N_BATCH), rng.normal(size=N_BATCH)

    with kernel.use_backend("numpy"):
        numpy_s = best_of(3, lambda: arm.end_effector_force(theta1, theta2, t1, t2))
    batch_s = best_of(3, lambda: arm.end_effector_force(theta1, theta2, t1, t2))  # the default back-end
    s1, s2, st1, st2 = (a[:N_LOOP].tolist() for a in (theta1, theta2, t1, t2))

    def loop():
        for i in range(N_LOOP):
            arm.end_effector_force(s1[i], s2[i], st1[i], st2[i])

    loop_s = best_of(1, loop)
    batch_rate = N_BATCH / batch_s
    loop_rate = N_LOOP / loop_s
    return [
        (f"end_effector_force, batched, 1e7 poses ({kernel.backend()})", f"{batch_rate / 1e6:8.1f} M poses/s ({batch_s * 1e3:.0f} ms)"),
        ("end_effector_force, batched, 1e7 poses (numpy)", f"{N_BATCH / numpy_s / 1e6:8.1f} M poses/s ({numpy_s * 1e3:.0f} ms)"),
        (f"ratio {kernel.backend()} / numpy (same run)", f"{numpy_s / batch_s:8.1f} x"),
        ("end_effector_force, per-pose Python loop", f"{loop_rate / 1e6:8.3f} M poses/s"),
        ("ratio batched / loop (same run)", f"{batch_rate / loop_rate:8.0f} x"),
        ("target", f"{TARGET_PER_S / 1e6:8.1f} M poses/s: {'met' if batch_rate >= TARGET_PER_S else 'NOT met'}"),
    ]
