"""The figure of ``sail identify``: the fitted model against its target."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..fit.identify import Identification, ReadingsTarget
from ..paper.study import table4
from ..paper.table4_fit import Table4Target


def identify_figure(fit: Identification, target: Table4Target | ReadingsTarget, start_table: np.ndarray | None = None) -> Figure:
    """Table 4 target: each cell's phase and amplitude shape against delta, target, start and fit.
    Readings target: each cell's residual (reading spreads) against delta."""
    if isinstance(target, ReadingsTarget):
        fig = Figure(figsize=(9.0, 3.6), layout="constrained")
        delta = np.degrees(target.delta)
        for i, ax in enumerate(fig.subplots(1, 2, sharey=True)):
            ax.plot(delta, fit.residuals[:, i], ".", ms=3, color="C0")
            ax.axhline(0.0, color="0.5", lw=0.8)
            ax.set(xlabel="Δ = θ1 − θ2 [deg]", title=f"cell {i + 1}: reading − model")
        fig.axes[0].set_ylabel("residual [reading spreads]")
        return fig
    fitted = table4(fit.robot, target.transduction, protocol=target.protocol)
    fig = Figure(figsize=(9.0, 6.4), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    shape = lambda t, i: t[:, 1 + 2 * i] / t[:, 1 + 2 * i].mean()
    for i in range(2):
        curves = [("target", target.table, "k", "o"), ("identified", fitted, "C0", "s")]
        if start_table is not None:
            curves.insert(1, ("start", start_table, "0.6", "^"))
        for label, t, colour, marker in curves:
            axes[0, i].plot(t[:, 0], t[:, 2 + 2 * i], marker=marker, color=colour, label=label, ms=4)
            axes[1, i].plot(t[:, 0], shape(t, i), marker=marker, color=colour, label=label, ms=4)
        axes[0, i].set(title=f"cell {i + 1}: phase P{i + 1}", ylabel="phase [deg]")
        axes[1, i].set(title=f"cell {i + 1}: amplitude A{i + 1} / mean", xlabel="Δ = θ1 − θ2 [deg]", ylabel="shape [-]")
    axes[0, 0].legend(fontsize=8)
    return fig
