"""Frame FE throughput on the default arm (two load cases, full outputs), against PyNite."""

from __future__ import annotations

import numpy as np
from _timing import best_of

from sailforce.fem.model import build_model
from sailforce.fem.pynite_check import solve_with_pynite
from sailforce.fem.response import simulate_model
from sailforce.robot import Robot
from sailforce.sweep import pose_grid, sweep_rows

N_BATCH = 50_000
N_PYNITE = 10  # PyNite builds and solves one model per pose; a few give its rate
TARGET_PER_S = 50_000
TARGET_RATIO = 1_000


def _full_outputs(model, theta1, theta2):
    response = simulate_model(model, theta1, theta2)
    return response.signal("bridge"), response.signal("deflection")


def run() -> list[tuple[str, str]]:
    rng = np.random.default_rng(1)
    theta2 = rng.uniform(-np.pi, np.pi, N_BATCH)
    theta1 = theta2 + rng.uniform(0.3, 2.8, N_BATCH)
    rows = []
    robot = Robot()  # default: pin joints, locked motors
    timoshenko = build_model(robot)
    euler = build_model(robot, shear_deformation=False)
    _full_outputs(timoshenko, theta1[:8], theta2[:8])  # warm-up
    t_timo = best_of(3, lambda: _full_outputs(timoshenko, theta1, theta2))
    t_euler = best_of(3, lambda: _full_outputs(euler, theta1, theta2))
    t_pynite = best_of(1, lambda: [solve_with_pynite(euler, theta1[i], theta2[i]) for i in range(N_PYNITE)])
    rate_timo, rate_euler, rate_pynite = N_BATCH / t_timo, N_BATCH / t_euler, N_PYNITE / t_pynite
    rows += [
        ("sailforce, Timoshenko, default arm, 5e4 poses", f"{rate_timo:10.0f} poses/s"),
        ("sailforce, Euler-Bernoulli (PyNite's model)", f"{rate_euler:10.0f} poses/s"),
        ("PyNite, same Euler-Bernoulli frame, per pose", f"{rate_pynite:10.1f} poses/s"),
        ("ratio sailforce / PyNite (same model, same run)", f"{rate_euler / rate_pynite:10.0f} x"),
        ("target", f">= {TARGET_PER_S} poses/s and >= {TARGET_RATIO}x: "
                   f"{'met' if rate_timo >= TARGET_PER_S and rate_euler / rate_pynite >= TARGET_RATIO else 'NOT met'}"),
    ]  # fmt: skip
    for joints in ("bonded",):
        model = build_model(robot.with_joints(joints))
        t = best_of(3, lambda: _full_outputs(model, theta1, theta2))  # noqa: B023 (called at once)
        rows.append((f"sailforce, Timoshenko, {joints} joints", f"{N_BATCH / t:10.0f} poses/s"))

    # The seed's two sweeps: 8 poses x 24 force angles each, 384 runs in all.
    phi = np.radians(np.arange(0.0, 346.0, 15.0))
    sweep1 = pose_grid(np.radians(np.arange(15.0, 121.0, 15.0)), [0.0])
    sweep2 = pose_grid([np.radians(120.0)], np.radians(np.arange(0.0, 106.0, 15.0)))
    bonded = build_model(robot.with_joints("bonded"))

    def seed_study():
        for t1, t2 in (sweep1, sweep2):
            sweep_rows(simulate_model(bonded, t1, t2), phi, 10.0, "deflection")

    t_seed = best_of(5, seed_study)
    rows.append(("seed's 384-run sweep (SolidWorks: 384 FE runs)", f"{t_seed * 1e3:10.1f} ms"))
    return rows
