"""The README's force-in-motion figure: ``python docs/motion_figure.py`` writes docs/figures/motion.png.

A simulated rig (the default robot with a 1 kg handle, its plane tilted
3 deg): a static calibration, a free-motion recording (16 reaches) that
identifies the dynamic term, and a task (8 reaches of 0.3 m, 3 m/s^2 peak,
a 100 N/m hand spring) estimated with and without it.  Prints the figures
it draws.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from sailforce import (
    OK,
    Calibration,
    Handle,
    Plane,
    Robot,
    base_parameters,
    calibration_session,
    estimate_moving,
    fit_calibration,
    fit_dynamic_term,
    inertial_parameters,
    parameter_vector,
    reaching,
    record,
)


def main(output: Path) -> None:
    robot = Robot(handle=Handle(mass=1.0), plane=Plane(tilt_deg=3.0))
    t1, t2, fx, fy, counts, offsets = calibration_session(robot)
    model, fitted, report = fit_calibration(robot.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="matrix")
    cal = Calibration(arm=robot.arm, model=model, offsets=tuple(fitted), capacity=(1e9, 1e9), delta_range=report.delta_range)
    free = record(robot, reaching(robot, reaches=16), offsets=offsets, seed=3)
    fit = fit_dynamic_term(cal, free.t, free.theta[:, 0], free.theta[:, 1], free.loads[:, 0], free.loads[:, 1])
    task = record(robot, reaching(robot, reaches=8), hand_stiffness=100.0, offsets=offsets, seed=7)
    sx, sy, _ = cal.estimate(task.theta[:, 0], task.theta[:, 1], task.loads[:, 0], task.loads[:, 1])
    mx, my, status, _ = estimate_moving(cal, fit.term, task.t, task.theta[:, 0], task.theta[:, 1], task.loads[:, 0],
                                        task.loads[:, 1])  # fmt: skip
    ok = status == OK
    static_error = np.hypot(sx - task.force[:, 0], sy - task.force[:, 1])
    moving_error = np.hypot(mx - task.force[:, 0], my - task.force[:, 1])
    truth = base_parameters(robot.arm).of(parameter_vector(robot.arm, inertial_parameters(robot), robot.plane.gravity))
    values = np.array(fit.term.values)

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), gridspec_kw={"height_ratios": [3, 2]})
    top.plot(task.t, static_error, color="tab:red", lw=0.8,
             label=f"static estimate: {np.sqrt(np.mean(static_error[ok] ** 2)):.2f} N RMS")  # fmt: skip
    top.plot(task.t[ok], moving_error[ok], color="tab:blue", lw=0.8,
             label=f"with the identified dynamic term: {np.sqrt(np.mean(moving_error[ok] ** 2)):.3f} N RMS")  # fmt: skip
    top.set_yscale("log")
    top.set_xlabel("time [s]")
    top.set_ylabel("|force error| [N]")
    top.set_title("8 reaches of 0.3 m at 3 m/s² peak, 1 kHz, 16-bit encoders, 1 kg handle, plane tilted 3°")
    top.legend(loc="lower right")
    index = np.arange(values.size)
    bottom.bar(index - 0.2, truth, 0.4, label="simulation", color="0.6")
    bottom.bar(index + 0.2, values, 0.4, label="identified (free motion, 16 reaches)", color="tab:blue")
    bottom.set_xticks(index, [f"β{i + 1}" for i in index])
    bottom.set_ylabel("base parameter [SI]")
    bottom.legend()
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, dpi=110)
    big = np.abs(truth) > 0.05
    print(f"static {np.sqrt(np.mean(static_error[ok] ** 2)):.3f} N RMS, compensated {np.sqrt(np.mean(moving_error[ok] ** 2)):.4f} N RMS; "
          f"largest relative parameter error {np.max(np.abs(values[big] / truth[big] - 1)):.2%}; wrote {output}")  # fmt: skip
    for name, a, b in zip(fit.base_names, truth, values):
        print(f"  {name:<45} {a:12.6g} {b:12.6g}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "figures" / "motion.png")
