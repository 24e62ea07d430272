"""Figures of the reproduced study: the analogues of the seed's Figs. 5 and 6, Table 4 and the workspace error."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ..paper.study import Curves, StudyResult
from .grid import panel_grid
from .labels import MODEL_COLOURS, model_label

SEED_STYLE = {"color": "0.35", "linestyle": "--", "marker": "s", "markersize": 3}  #: the seed's published values
#: Table 4's amplitudes are drawn relative to their value at this Delta [deg], so ours and the seed's
#: (in different signal units) share one axis.
NORMALISE_AMPLITUDE_AT_DEG = 90.0
#: Relative force errors below this (rounding, as with pin joints) are drawn at it on the log axis.
ERROR_FLOOR = 1e-7


def _pose_title(curves: Curves, k: int) -> str:
    t1, t2 = math.degrees(curves.theta1[k]), math.degrees(curves.theta2[k])
    return f"Δ = {t1 - t2:g}° (θ1 = {t1:g}°, θ2 = {t2:g}°)"


def _curve_grid(result: StudyResult, grids: tuple[Curves, Curves], draw, suptitle: str) -> Figure:
    """Two rows of panels per load cell (one panel per pose), as the seed's Figs. 5 and 6."""
    n = max(g.theta1.size for g in grids)
    cols = 4
    rows_per_cell = math.ceil(n / cols)
    fig = Figure(figsize=(3.3 * cols, 2.3 * 2 * rows_per_cell + 0.8))
    axes = panel_grid(fig, 2 * rows_per_cell, cols, sharex=True)
    phi_deg = np.asarray(result.protocol.phi_deg)
    for i, grid in enumerate(grids):
        for k in range(n):
            ax = axes[i * rows_per_cell + k // cols, k % cols]
            draw(ax, i, grid, k, phi_deg)
            ax.set_title(f"cell {i + 1}: {_pose_title(grid, k)}", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
            if k % cols == 0:
                ax.set_ylabel(f"T{i + 1} [N m]", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("φ [deg]", fontsize=8)
        ax.set_xticks(np.arange(0, 361, 90))
    axes[0, 0].legend(fontsize=7, loc="lower left")
    fig.suptitle(suptitle, fontsize=10)
    return fig


def sweeps_figure(result: StudyResult) -> Figure:
    """Fig. 5: load-cell curves of sweeps 1 and 2 (pre-scaled by the fitted k_i) against Eq. 7."""
    k = result.prescale

    def draw(ax, i, grid, j, phi_deg):
        ax.plot(phi_deg, grid.torque[j, i], color="black", lw=1.2, label="predicted (Eq. 7)")
        ax.plot(phi_deg, k[i] * grid.signal[j, i], "o", color="tab:red", ms=3, label=f"k{i + 1} × load {i + 1}")

    return _curve_grid(result, result.sweeps, draw,
                       f"Sweeps 1 and 2 ({result.robot.joints.label} joints, {result.transduction}): load-cell curves "
                       f"scaled by k1 = {k[0]:.4g}, k2 = {k[1]:.4g} (least squares) against the predicted torque")  # fmt: skip


def compensated_figure(result: StudyResult) -> Figure:
    """Fig. 6: validation curves before (k_i s_i) and after (A_i s_i(φ − P_i)) compensation."""
    k = result.prescale

    def draw(ax, i, grid, j, phi_deg):
        ax.plot(phi_deg, grid.torque[j, i], color="black", lw=1.2, label="predicted (Eq. 7)")
        ax.plot(phi_deg, k[i] * grid.signal[j, i], ".", color="tab:red", ms=3, label="before (k × load)")
        ax.plot(phi_deg, result.compensated[i][j], "o", mfc="none", color="tab:blue", ms=4, label="after (compensated)")

    return _curve_grid(result, result.validation, draw,
                       "Validation on the offset grids: before and after the seed's compensator "
                       f"({result.robot.joints.label} joints)")  # fmt: skip


def table4_figure(result: StudyResult, seed_table: np.ndarray) -> Figure:
    """Table 4 as curves: amplitude (normalised at :data:`NORMALISE_AMPLITUDE_AT_DEG`) and phase against delta."""
    fig = Figure(figsize=(10, 3.8), layout="constrained")
    axes = fig.subplots(1, 2)
    delta = result.table4[:, 0]
    fine = np.linspace(delta.min(), delta.max(), 200)
    for i, colour in enumerate(("tab:blue", "tab:orange")):
        a_col, p_col = 1 + 2 * i, 2 + 2 * i
        names = ("amplitude_1", "phase_1_deg") if i == 0 else ("amplitude_2", "phase_2_deg")
        ref = np.interp(NORMALISE_AMPLITUDE_AT_DEG, delta, result.table4[:, a_col])
        seed_ref = np.interp(NORMALISE_AMPLITUDE_AT_DEG, seed_table[:, 0], seed_table[:, a_col])
        axes[0].plot(delta, result.table4[:, a_col] / ref, "o", color=colour, label=f"A{i + 1} ours")
        axes[0].plot(fine, result.regressors[names[0]](fine) / ref, "-", color=colour, lw=1)
        axes[0].plot(seed_table[:, 0], seed_table[:, a_col] / seed_ref, **{**SEED_STYLE, "color": colour},
                     mfc="none", label=f"A{i + 1} seed")  # fmt: skip
        axes[1].plot(delta, result.table4[:, p_col], "o", color=colour, label=f"P{i + 1} ours")
        axes[1].plot(fine, result.regressors[names[1]](fine), "-", color=colour, lw=1)
        axes[1].plot(seed_table[:, 0], seed_table[:, p_col], **{**SEED_STYLE, "color": colour}, mfc="none",
                     label=f"P{i + 1} seed")  # fmt: skip
    axes[0].set_ylabel(f"amplitude / amplitude at Δ = {NORMALISE_AMPLITUDE_AT_DEG:g}°")
    axes[1].set_ylabel("phase [deg]")
    for ax in axes:
        ax.set_xlabel("Δ [deg]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"Table 4 ({result.robot.joints.label} joints): points, with the selected regressors as lines; "
                 "dashed: the seed's published values", fontsize=10)  # fmt: skip
    return fig


def workspace_figure(result: StudyResult) -> Figure:
    """Force-vector error (RMS over φ, relative to |F|) of every model across delta = 15..165 deg."""
    fig = Figure(figsize=(8, 4.2), layout="constrained")
    ax = fig.subplots()
    delta_deg = np.degrees(result.workspace.delta)
    floor = ERROR_FLOOR
    top = max(max(float(e.max()) for e in result.workspace.relative_error.values()) * 100 * 3, 1e-3)
    ax.set_yscale("log")
    ax.set_ylim(floor * 100 / 3, top)  # before plotting: flat pin-joint curves would collapse autoscaling
    for model, error in result.workspace.relative_error.items():
        ax.plot(delta_deg, np.maximum(error, floor) * 100, label=model_label(model, result.protocol),
                color=MODEL_COLOURS[model])  # fmt: skip
    low, high = np.degrees(result.compensator.delta_range)
    ax.axvspan(delta_deg.min(), low, color="0.9")
    ax.axvspan(high, delta_deg.max(), color="0.9", label="outside the seed's fitted Δ range")
    last = max(float(np.degrees(grid.delta).max()) for grid in result.validation)  # the furthest validation pose
    ax.axvline(last, color="0.4", lw=0.8, ls=":")
    ax.text(last + 1.0, ax.get_ylim()[0] * 2, f"Δ = {last:g}° (validation)", fontsize=8, color="0.3")
    ax.set_xlabel("Δ [deg]")
    ax.set_ylabel("force error, RMS over φ [% of |F|]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title(f"Force-vector error over the workspace ({result.robot.joints.label} joints, "
                 f"{result.protocol.force_N:g} N)", fontsize=10)  # fmt: skip
    return fig
