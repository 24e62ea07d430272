"""``sail design``'s figures, ``design.json`` and report."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from .._version import __version__
from ..design.study import Design
from ..fem.model import MEMBERS, build_model, node_positions
from ..io.files import atomic_writer, write_figure, write_json
from .document import markdown_to_html
from .labels import links_label

#: Ellipses drawn per side of the grid in the resolution figure (the rest would overlap).
ELLIPSES_PER_SIDE = 12


def _map(ax, design: Design, values: np.ndarray, label: str, cmap: str = "viridis"):
    grid = design.grid
    mesh = ax.pcolormesh(grid.x, grid.y, grid.to_map(values).T, shading="nearest", cmap=cmap)
    ax.plot(0.0, 0.0, "k^", ms=8)
    ax.set(aspect="equal", xlabel="x [m]", ylabel="y [m]")
    ax.figure.colorbar(mesh, ax=ax, label=label, shrink=0.85)
    return mesh


def resolution_figure(design: Design) -> Figure:
    """Left: 1-sigma force-noise ellipses over the workspace; right: the worst direction's value as a map."""
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    grid = design.grid
    step = max(1, len(grid.x) // ELLIPSES_PER_SIDE)
    from ..kinematics import forward

    x, y = forward(design.robot.arm, grid.theta1, grid.theta2)
    ix = np.searchsorted(grid.x, x - 1e-12)
    iy = np.searchsorted(grid.y, y - 1e-12)
    pick = (ix % step == 0) & (iy % step == 0)
    scale = 0.4 * step * (grid.x[1] - grid.x[0]) / design.resolution.worst.max()
    t = np.linspace(0.0, 2.0 * np.pi, 40)
    for k in np.flatnonzero(pick):
        w, v = np.linalg.eigh(design.resolution.covariance[k])
        pts = v @ (np.sqrt(np.clip(w, 0, None))[:, None] * np.stack([np.cos(t), np.sin(t)]))
        left.plot(x[k] + scale * pts[0], y[k] + scale * pts[1], color="C0", lw=0.8)
    left.plot(0.0, 0.0, "k^", ms=8)
    left.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
             title=f"1σ force-noise ellipses (largest = {design.resolution.worst.max():.3g} N)")  # fmt: skip
    _map(right, design, design.resolution.worst, "1σ force noise, worst direction [N]", "magma_r")
    right.set_title("resolution")
    return fig


def overload_figure(design: Design) -> Figure:
    """Left: the largest hand force in the worst direction; right: the element that limits it."""
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    _map(left, design, design.overload.worst, f"overload, worst direction [N] (safety factor {design.safety_factor:g} on links)")
    left.set_title("overload")
    names = [name for name, *_ in MEMBERS]
    used = sorted(set(design.overload.worst_limiting.tolist()))
    codes = np.searchsorted(used, design.overload.worst_limiting)
    grid = design.grid
    right.pcolormesh(grid.x, grid.y, grid.to_map(codes.astype(float)).T, shading="nearest", cmap="tab10",
                     vmin=-0.5, vmax=9.5)  # fmt: skip
    from matplotlib import colormaps
    from matplotlib.patches import Patch

    cmap = colormaps["tab10"]
    right.legend(handles=[Patch(color=cmap(k / 10 + 0.05), label=names[m]) for k, m in enumerate(used)], fontsize=8)
    right.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title="the element that limits it")
    return fig


def compensation_figure(design: Design) -> Figure:
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    _map(left, design, design.need.worst_phase_deg, "worst cell phase against Jᵀ [deg]", "cividis")
    left.set_title("compensation need: phase")
    _map(right, design, 100 * design.need.worst_amplitude, "worst cell |gain − 1| [%]", "cividis")
    right.set_title("compensation need: amplitude")
    return fig


def modes_figure(design: Design) -> Figure:
    """Left: the first natural frequency over the workspace; right: the first mode at the lowest pose."""
    fig = Figure(figsize=(11.0, 4.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    first = design.modes.frequencies_Hz[:, 0]
    _map(left, design, first, "first natural frequency [Hz]", "plasma")
    left.set_title("bandwidth")
    k = int(np.argmin(first))
    model = build_model(design.robot)
    nodes = node_positions(model, design.grid.theta1[k], design.grid.theta2[k])
    shape = design.modes.shapes[k, :, 0]
    span = max(np.ptp(np.array(list(nodes.values()))[:, 0]), 1e-9)
    disp = {n: np.array([shape[model.dof[f"{n}.u"]], shape[model.dof[f"{n}.v"]]]) for n in nodes}
    scale = 0.15 * span / max(np.hypot(*d).max() for d in disp.values())
    for _, i, j, *_ in MEMBERS:
        right.plot(*zip(nodes[i], nodes[j]), color="0.6", lw=3)
        right.plot(*zip(nodes[i] + scale * disp[i], nodes[j] + scale * disp[j]), color="C3", lw=1.5)
    right.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
              title=f"first mode where lowest: {first[k]:.3g} Hz\n(θ1 = {np.degrees(design.grid.theta1[k]):.0f}°, "
                    f"θ2 = {np.degrees(design.grid.theta2[k]):.0f}°)")  # fmt: skip
    return fig


FIGURES = {
    "resolution.png": resolution_figure,
    "overload.png": overload_figure,
    "compensation.png": compensation_figure,
    "modes.png": modes_figure,
}


def design_json(design: Design) -> dict:
    robot = design.robot
    return {
        "software": f"sailforce {__version__}",
        "robot": {"links_m": [robot.arm.l1, robot.arm.l2, robot.arm.l3, robot.arm.l4], "joints": robot.joints.label,
                  "capacity_kg": robot.loadcell.capacity_kg, "cell_position": robot.loadcell.position,
                  "noise_mV_V": robot.loadcell.noise_mV_V},
        "safety_factor": design.safety_factor,
        "summary": design.summary(),
        "grid": {"x_m": design.grid.x, "y_m": design.grid.y},
        "poses": design.poses(),
    }  # fmt: skip


def report_markdown(design: Design, seconds: float, sections: Sequence[str] = ()) -> str:
    s = design.summary()
    robot = design.robot
    limit_names, counts = np.unique(design.overload.limiting_names(), return_counts=True)
    limits = ", ".join(f"{name} at {100 * c / counts.sum():.0f} % of poses" for name, c in zip(limit_names, counts))
    rows = [
        ("resolution, 1σ worst direction [N]", "resolution_N", "largest"),
        ("overload, worst direction [N]", "overload_N", "smallest"),
        ("first natural frequency [Hz]", "first_frequency_Hz", "lowest"),
        ("compensation need: phase [deg]", "phase_need_deg", "largest"),
        ("compensation need: |gain − 1|", "amplitude_need", "largest"),
        ("condition number of J", "condition", "largest"),
    ]
    table = ["| quantity | worst | which | median |", "|---|---|---|---|"]
    table += [f"| {label} | {s[key]['worst']:.4g} | {which} | {s[key]['median']:.4g} |" for label, key, which in rows]
    return "\n\n".join([
        "# SAIL design report",
        f"sailforce {__version__} · {design.grid.theta1.size} poses on a {len(design.grid.x)} × {len(design.grid.y)} "
        f"x–y grid · computed in {seconds:.2f} s",
        f"Robot: l1 = {robot.arm.l1:g} m, l2 = {robot.arm.l2:g} m, l3 = {robot.arm.l3:g} m; {links_label(robot)}; joints "
        f"**{robot.joints.label}**; cells {robot.loadcell.capacity_kg:g} kg at {robot.loadcell.position:g} of each "
        f"link, {robot.loadcell.rated_output_mV_V:g} mV/V, reading noise {robot.loadcell.noise_mV_V:g} mV/V (1σ); "
        f"handle {robot.handle.mass:g} kg. Reach {s['reach_m']['min']:.3g}…{s['reach_m']['max']:.3g} m, "
        f"{s['reach_m']['area_m2']:.3g} m².",
        "\n".join(table),
        "## Resolution",
        "The 1σ force noise of the estimate F = S⁻¹ s at each pose, from the cells' reading noise through the "
        "sensing map S: an ellipse per pose, and its largest semi-axis as a map.",
        "![Resolution](resolution.png)",
        "## Overload",
        "The largest hand force in the worst direction (exact: each element's worst direction in closed form) "
        f"before a cell reaches its rated output or a link reaches its yield strength / {design.safety_factor:g}. "
        f"Limited by: {limits}.",
        "![Overload](overload.png)",
        "## Compensation need",
        "How far each cell's reading departs from the pin-jointed ideal (g/l_i)·(Jᵀ F)_i: its phase and gain. "
        "Zero for pin joints; bonded or sprung joints need a compensator of this size.",
        "![Compensation need](compensation.png)",
        "## Bandwidth",
        "The first natural frequency of the arm (consistent mass, the cells' compliance, the handle mass; motors "
        "locked), and the first mode shape where it is lowest.",
        "![Modes](modes.png)",
        "## Files\n\n- `design.json`: the summary and, per pose, `theta1_deg`, `theta2_deg`, `resolution_N`, "
        "`overload_N`, `overload_limit`, `first_frequency_Hz`, `phase_need_deg`, `amplitude_need`, `condition`.\n"
        "- `resolution.png`, `overload.png`, `compensation.png`, `modes.png`.",
        *sections,
    ]) + "\n"  # fmt: skip


def design_outputs() -> tuple[str, ...]:
    """Every file :func:`write_design` writes."""
    return ("design.json", *FIGURES, "report.md", "report.html")


def write_design(directory: Path, design: Design, seconds: float, dpi: int, sections: Sequence[str] = ()) -> None:
    """``design.json``, the figures, ``report.md`` and the self-contained ``report.html`` into ``directory``;
    ``sections`` (Markdown, a sweep's) are appended to the report."""
    directory.mkdir(parents=True, exist_ok=True)
    write_json(directory / "design.json", design_json(design))
    for name, make in FIGURES.items():
        write_figure(directory / name, make(design), dpi=dpi)
    markdown = report_markdown(design, seconds, sections)
    with atomic_writer(directory / "report.md") as stream:
        stream.write(markdown)
    with atomic_writer(directory / "report.html") as stream:
        stream.write(markdown_to_html(markdown, directory, "SAIL design report"))
