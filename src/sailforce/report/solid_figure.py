"""Figures of the solid model: its stress field (the seed's Fig. 4 from a solid), its readings against the frame's,
and its Table 4 beside the frame's and the seed's."""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.collections import PolyCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from ..errors import InputError
from ..solid.arm import SolidResponse
from .stress_figure import panel_label

#: Panels per row of the stress figure.
COLUMNS = 4


def von_mises(stresses: np.ndarray, fx, fy) -> np.ndarray:
    """Plane-stress von Mises [Pa] of each element under (fx, fy) [N]: sqrt(sx^2 - sx sy + sy^2 + 3 txy^2)."""
    s = stresses[..., 0] * fx + stresses[..., 1] * fy  # (m, 3): sxx, syy, sxy
    sx, sy, txy = s[:, 0], s[:, 1], s[:, 2]
    return np.sqrt(sx * sx - sx * sy + sy * sy + 3.0 * txy * txy)


def solid_stress_figure(response: SolidResponse, phi: np.ndarray, force: float, title: str = "") -> Figure:
    """One panel per force angle: the solid's elements coloured by von Mises stress [MPa] on one shared scale."""
    if response.stresses is None or response.triangles is None:
        raise InputError("the response holds no stresses: solve the pose with stresses=True")
    fields = [von_mises(response.stresses, force * np.cos(p), force * np.sin(p)) / 1e6 for p in phi]
    top = max(float(np.percentile(f, 99.5)) for f in fields)  # a pin hole's rim spikes; the scale shows the arm
    rows = -(-len(phi) // COLUMNS)
    fig = Figure(figsize=(3.2 * min(len(phi), COLUMNS), 3.0 * rows + 0.6), layout="constrained")
    axes = fig.subplots(rows, min(len(phi), COLUMNS), squeeze=False)
    norm, cmap = Normalize(0.0, top), colormaps["viridis"]
    xy = response.triangles
    for k, ax in enumerate(axes.flat):
        ax.set_axis_off()
        if k >= len(phi):
            continue
        ax.add_collection(PolyCollection(xy, array=fields[k], cmap=cmap, norm=norm, edgecolors="face", linewidths=0.1))
        ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_title(f"{panel_label(k)} φ = {np.degrees(phi[k]):.0f}°, peak {fields[k].max():.3g} MPa", fontsize=8)
    fig.colorbar(ScalarMappable(norm, cmap), ax=axes, shrink=0.8, label="von Mises stress [MPa] (99.5th percentile cap)")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def readings_figure(phi: np.ndarray, solid: dict[str, np.ndarray], frame: dict[str, np.ndarray], title: str = "") -> Figure:
    """Torques and cell deflections over the force angle: the solid (lines) over the frame (dashed)."""
    fig = Figure(figsize=(10, 3.4), layout="constrained")
    axes = fig.subplots(1, 3)
    units = {"torques": ("T [N·m]", 1.0), "deflection": ("far-face deflection [µm]", 1e6),
             "relative": ("relative deflection [µm]", 1e6)}  # fmt: skip
    degrees = np.degrees(phi)
    for ax, (name, (label, scale)) in zip(axes, units.items()):
        for i, colour in enumerate(("C0", "C1")):
            ax.plot(degrees, scale * solid[name][i], color=colour, label=f"cell {i + 1} solid" if name != "torques" else f"T{i + 1} solid")
            ax.plot(degrees, scale * frame[name][i], color=colour, linestyle="--", label="frame")
        ax.set_xlabel("force angle φ [deg]")
        ax.set_ylabel(label)
        ax.set_xticks(np.arange(0, 361, 90))
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def write_table4_comparison(directory, tables: dict[str, np.ndarray], dpi: int) -> None:
    """``table4_comparison.csv`` (delta, then each source's four columns) and ``table4.png`` into ``directory``."""
    from ..io.files import write_figure, write_numeric_table
    from ..paper.study import TABLE4_COLUMNS

    head = [TABLE4_COLUMNS[0]] + [f"{c}_{name}" for name in tables for c in TABLE4_COLUMNS[1:]]
    delta = next(iter(tables.values()))[:, :1]
    write_numeric_table(directory / "table4_comparison.csv", head, np.column_stack([delta] + [t[:, 1:] for t in tables.values()]),
                        csv_format="%.8g")  # fmt: skip
    write_figure(directory / "table4.png", table4_figure(tables), dpi=dpi)


def table4_figure(tables: dict[str, np.ndarray]) -> Figure:
    """Table 4's four columns over delta, one line per source (solid, frame, seed)."""
    fig = Figure(figsize=(9, 5.5), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    titles = ("amplitude, cell 1", "phase, cell 1 [deg]", "amplitude, cell 2", "phase, cell 2 [deg]")
    styles = {"solid": dict(marker="o"), "frame": dict(linestyle="--"), "seed": dict(marker="x", linestyle=":")}
    for k, ax in enumerate(axes.flat):
        for name, table in tables.items():
            ax.plot(table[:, 0], table[:, k + 1], label=name, **styles.get(name, {}))
        ax.set_title(titles[k], fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("δ = θ1 − θ2 [deg]")
    axes[0, 0].legend(fontsize=8)
    return fig
