"""The figures of ``sail validate``: Bland-Altman plots per axis, and where in the workspace the error lies."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..reference.validate import DELTA_BIN_DEG, LIMITS_SD, REGION_M
from ..workflows import Validation

#: At most this many points are drawn in a Bland-Altman plot (evenly chosen): a 1 kHz hour is millions.
MAX_POINTS = 20_000


def bland_altman_figure(v: Validation) -> Figure:
    """Per axis: the difference (SAIL less reference) against the mean of the two, at rest and moving, with the bias
    and the 95 % limits of agreement (Bland & Altman 1986)."""
    fig = Figure(figsize=(10.0, 4.0), layout="constrained")
    used = np.flatnonzero(v.used)
    if used.size > MAX_POINTS:
        used = used[np.linspace(0, used.size - 1, MAX_POINTS).round().astype(int)]
    rest = v.rows.rest[used]
    for axis, ax in enumerate(fig.subplots(1, 2, sharey=True)):
        sail, ref = v.estimate[used, axis], v.rows.force[used, axis]
        mean, diff = 0.5 * (sail + ref), sail - ref
        ax.plot(mean[~rest], diff[~rest], ".", ms=1.5, color="C1", alpha=0.4, label="moving")
        ax.plot(mean[rest], diff[rest], ".", ms=1.5, color="C0", alpha=0.4, label="at rest")
        bias, sd = v.overall.bias_N[axis], v.overall.sd_N[axis]
        ax.axhline(bias, color="k", lw=1.0, label=f"bias {bias * 1e3:+.1f} mN")
        for sign in (-1, 1):
            ax.axhline(bias + sign * LIMITS_SD * sd, color="k", lw=0.8, ls="--",
                       label=f"95 % limits ±{LIMITS_SD * sd * 1e3:.0f} mN" if sign > 0 else None)  # fmt: skip
        name = "xy"[axis]
        ax.set(xlabel=f"mean of SAIL and reference, f{name} [N]", title=f"f{name}: {v.overall.samples:,} samples")
        ax.legend(fontsize=8, markerscale=6, loc="upper right")
    fig.axes[0].set_ylabel("SAIL − reference [N]")
    return fig


def error_map_figure(v: Validation) -> Figure:
    """Left: the RMS error over squares of the workspace, the arm's base at the origin.  Right: the RMS error per Δ
    bin, at rest and moving."""
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    edges = np.array(v.by_region.edges)
    if edges.size:
        index = np.round(edges / REGION_M).astype(int)
        low = index.min(axis=0)
        grid = np.full(tuple(index.max(axis=0) - low + 1)[::-1], np.nan)
        for (i, j), a in zip(index - low, v.by_region.agreements):
            grid[j, i] = a.rmse_N * 1e3
        x = (low[0] + np.arange(grid.shape[1] + 1)) * REGION_M
        y = (low[1] + np.arange(grid.shape[0] + 1)) * REGION_M
        mesh = left.pcolormesh(x, y, np.ma.masked_invalid(grid), cmap="viridis", vmin=0.0)
        fig.colorbar(mesh, ax=left, label="RMS error [mN]")
    left.plot([0], [0], "k^", ms=8)
    left.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title="RMS force error over the workspace (ok samples)")
    delta = np.degrees(v.rows.theta[:, 0] - v.rows.theta[:, 1])
    ok = v.used
    for mask, label, colour in ((ok & v.rows.rest, "at rest", "C0"), (ok & ~v.rows.rest, "moving", "C1")):
        bins = np.floor(delta[mask] / DELTA_BIN_DEG).astype(int)
        err2 = np.sum((v.estimate[mask] - v.rows.force[mask]) ** 2, axis=1)
        if bins.size:
            found = np.unique(bins)
            rms = [np.sqrt(err2[bins == b].mean()) for b in found]
            right.plot((found + 0.5) * DELTA_BIN_DEG, 1e3 * np.array(rms), "o-", color=colour, label=label)
    right.set(xlabel="Δ = θ1 − θ2 [deg]", ylabel="RMS force error [mN]", title="by Δ",
              ylim=(0, None))  # fmt: skip
    right.legend(fontsize=8)
    return fig

