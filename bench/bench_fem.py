"""Frame FE throughput on the default arm (two load cases, the cells' signals), against OpenSeesPy and PyNite.

Every peer is warmed up first (imported, its model built, one pose solved) and run as its users would run
it well: OpenSees with one model moved pose by pose (:mod:`sailforce.fem.opensees_check`: setNodeCoord and
updateElementDomain, ProfileSPD with RCM numbering, one factorisation for both load cases); PyNite builds
its model per pose, which is how it is used.  Ours on one core, as OpenSees runs.
"""

from __future__ import annotations

import numpy as np
from _timing import best_of

from sailforce.fem.model import build_model
from sailforce.fem.opensees_check import OpenSeesArm, solve_poses
from sailforce.fem.pynite_check import solve_with_pynite
from sailforce.fem.response import simulate_model
from sailforce.kernel import use_backend
from sailforce.robot import Robot
from sailforce.sweep import pose_grid, sweep_rows

N_BATCH = 50_000
N_PYNITE = 10  # PyNite builds and solves one model per pose; a few give its rate
N_OPENSEES = 3_000
TARGET_PER_S = 50_000
#: issue 32: ours at least ten times OpenSees used well, Euler-Bernoulli and Timoshenko alike
TARGET_OPENSEES_RATIO = 10.0


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
    rates = {}
    for name, model in (("Timoshenko", timoshenko), ("Euler-Bernoulli", euler)):
        _full_outputs(model, theta1[:8], theta2[:8])  # warm-up (the compiled solve loads once)
        with use_backend("numpy"):
            _full_outputs(model, theta1[:8], theta2[:8])
            rates[name, "numpy"] = N_BATCH / best_of(3, lambda: _full_outputs(model, theta1, theta2))  # noqa: B023
        rates[name, "ours"] = N_BATCH / best_of(3, lambda: _full_outputs(model, theta1, theta2))  # noqa: B023
        arm = OpenSeesArm(model)
        solve_poses(arm, theta1[:8], theta2[:8])  # warm-up
        n = N_OPENSEES
        rates[name, "opensees"] = n / best_of(3, lambda: solve_poses(arm, theta1[:n], theta2[:n]))  # noqa: B023
        arm.ops.wipe()
    solve_with_pynite(euler, theta1[0], theta2[0])  # warm-up: its import (about 1 s) and first model
    rates["Euler-Bernoulli", "pynite"] = N_PYNITE / best_of(1, lambda: [solve_with_pynite(euler, theta1[i], theta2[i])
                                                                          for i in range(N_PYNITE)])  # fmt: skip
    for name in ("Timoshenko", "Euler-Bernoulli"):
        rows += [(f"sailforce, {name}, default arm, 5e4 poses (compiled, one core)", f"{rates[name, 'ours']:10.0f} poses/s"),
                 (f"sailforce, {name}, the stacked numpy solve", f"{rates[name, 'numpy']:10.0f} poses/s"),
                 (f"OpenSeesPy, {name}, one model moved pose by pose", f"{rates[name, 'opensees']:10.0f} poses/s"),
                 (f"ratio sailforce / OpenSeesPy, {name}", f"{rates[name, 'ours'] / rates[name, 'opensees']:10.1f} x")]  # fmt: skip
    pynite = rates["Euler-Bernoulli", "pynite"]
    rows += [
        ("PyNite, Euler-Bernoulli, a model per pose (warmed up)", f"{pynite:10.1f} poses/s"),
        ("ratio sailforce / PyNite, Euler-Bernoulli", f"{rates['Euler-Bernoulli', 'ours'] / pynite:10.0f} x"),
        ("target", f">= {TARGET_PER_S} poses/s and >= {TARGET_OPENSEES_RATIO:g}x OpenSeesPy (both models): " +
                   ("met" if rates["Timoshenko", "ours"] >= TARGET_PER_S and all(
                       rates[m, "ours"] / rates[m, "opensees"] >= TARGET_OPENSEES_RATIO
                       for m in ("Timoshenko", "Euler-Bernoulli")) else "NOT met")),
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
