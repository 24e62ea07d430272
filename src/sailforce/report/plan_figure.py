"""The figure of ``sail plan-calibration``: the predicted force error of the plan and the baselines, and the holds."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..plan import ErrorMap, Plan


def plan_figure(plan: Plan, simulated: ErrorMap | None = None) -> Figure:
    """Left: the worst-direction predicted force error against delta for the plan, the seed's grid and a uniform
    grid (and the simulated calibrations' spread), the noise floor (an exact calibration's error from one
    conversion's noise) and the plan's error at run time; the planned range shaded.  Right: the holds, by delta and the
    force's direction in the world, sized by mass."""
    fig = Figure(figsize=(10.0, 5.0), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=(1.6, 1.0))
    low, high = np.degrees(plan.rig.delta_range)
    left.axvspan(low, high, color="0.92", label="planned deltas")
    n = plan.budget
    for label, m, style in ((f"the plan ({n} holds)", plan.predicted, "C0-"),
                            (f"the seed's grid ({len(plan.seed_holds)})", plan.seed_grid, "C3--"),
                            (f"a uniform grid ({len(plan.uniform_holds)})", plan.uniform, "C2:")):  # fmt: skip
        if np.all(np.isfinite(m.worst_N)):
            left.plot(np.degrees(m.delta), 1e3 * m.worst_N, style, lw=1.6, label=label)
    if simulated is not None:
        left.plot(np.degrees(simulated.delta), 1e3 * simulated.worst_N, "k.", ms=4, label="simulated calibrations")
    left.plot(np.degrees(plan.predicted.delta), 1e3 * plan.floor_N, color="0.45", lw=1.2,
              label=f"noise floor: one {plan.adc.model} conversion, exact map")  # fmt: skip
    left.plot(np.degrees(plan.predicted.delta), 1e3 * plan.seen(plan.predicted).worst_N, "C0", lw=0.9, alpha=0.5,
              label="the plan at run time (with that noise)")  # fmt: skip
    left.set_yscale("log")
    left.set(xlabel="Δ = θ1 − θ2 [deg]", ylabel=f"force error, worst direction [mN] at {plan.predicted.force_N:g} N",
             title=f"predicted force error ({plan.model.model} model)")  # fmt: skip
    left.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    delta = np.degrees(plan.holds.theta1 - plan.holds.theta2)
    direction = np.degrees(np.mod(np.arctan2(plan.holds.fy, plan.holds.fx), 2 * np.pi))
    right.scatter(delta, direction, s=12 * plan.conversions / plan.conversions_per_hold * plan.holds.mass_kg / plan.holds.mass_kg.max(),
                  color="C0", alpha=0.6)
    right.plot(delta, direction, color="0.7", lw=0.6, zorder=0)
    right.set(xlabel="Δ [deg]", ylabel="force direction in the world [deg]", title="the holds, in order (area: mass x time)",
              xlim=(min(low, delta.min()) - 5, max(high, delta.max()) + 5), ylim=(-10, 370), yticks=range(0, 361, 90))  # fmt: skip
    return fig
