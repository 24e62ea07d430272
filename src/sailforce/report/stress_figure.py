"""The analogue of the seed's Fig. 4: the arm coloured by von Mises stress, one panel per force angle."""

from __future__ import annotations

import math

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from ..errors import InputError
from ..fem.model import MEMBERS, node_positions
from ..fem.response import ArmResponse, member_stresses
from .grid import Margins, panel_grid

SAMPLES_PER_MEMBER = 24  #: points along each member at which stress colours the drawing

#: Panels one figure may hold: 36 panels of a 4-wide grid are already a poster.
MAX_PANELS = 36


def panel_label(k: int) -> str:
    """(a), (b), ... (z), (aa), (ab), ...: a panel's letter, for any count."""
    letters = ""
    k += 1
    while k:
        k, r = divmod(k - 1, 26)
        letters = chr(97 + r) + letters
    return f"({letters})"


def stress_figure(response: ArmResponse, phi, force: float, title: str = "") -> Figure:
    """One panel per force angle ``phi`` [rad] at the single pose of ``response``.

    Every member is drawn coloured by von Mises stress [MPa], on one shared
    colour scale; an arrow shows the force at A.  Returns the figure.
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    if phi.size > MAX_PANELS:
        raise InputError(f"{phi.size} force angles: at most {MAX_PANELS} panels fit a figure")
    theta1, theta2 = float(response.theta1), float(response.theta2)
    positions = node_positions(response.model, theta1, theta2)
    mpa = [
        member_stresses(response, force * math.cos(p), force * math.sin(p), SAMPLES_PER_MEMBER).von_mises / 1e6
        for p in phi
    ]
    norm = Normalize(0.0, max(float(np.max(m)) for m in mpa) or 1.0)
    cols = min(4, phi.size)
    rows = math.ceil(phi.size / cols)
    fig = Figure(figsize=(3.4 * cols + 0.9, 3.2 * rows + 0.8))
    axes, bar = panel_grid(fig, rows, cols, Margins(left=0.6, wgap=0.55, hgap=0.75), colorbar=0.9)
    reach = response.model.robot.arm.l2 + response.model.robot.arm.l3
    t = np.linspace(0.0, 1.0, SAMPLES_PER_MEMBER)
    corners = np.array(list(positions.values()))
    low = corners.min(axis=0) - 0.22 * reach  # room for the force arrow
    high = corners.max(axis=0) + 0.22 * reach
    for k, ax in enumerate(axes.flat):
        if k >= phi.size:
            ax.axis("off")
            continue
        for e, (_, i, j, _, kind) in enumerate(MEMBERS):
            points = positions[i] + t[:, None] * (positions[j] - positions[i])
            segments = np.stack([points[:-1], points[1:]], axis=1)
            lines = LineCollection(segments, cmap="turbo", norm=norm, linewidths=7 if kind == "cell" else 4)
            lines.set_array(0.5 * (mpa[k][e, :-1] + mpa[k][e, 1:]))
            ax.add_collection(lines)
        joints = np.array([positions[n] for n in ("P1", "P2", "P3", "A")])
        ax.plot(*joints.T, "o", color="black", markersize=3)
        ax.plot(0, 0, "s", color="black", markersize=6)
        a = positions["A"]
        arrow = 0.18 * reach
        ax.annotate("", xy=a + arrow * np.array([math.cos(phi[k]), math.sin(phi[k])]), xytext=a,
                    arrowprops={"arrowstyle": "->", "color": "crimson", "lw": 1.5})  # fmt: skip
        ax.set_title(f"{panel_label(k)} φ = {math.degrees(phi[k]):g}°", fontsize=9)
        ax.set_xlabel("x [m]", fontsize=8)
        ax.set_ylabel("y [m]", fontsize=8)
        ax.set_aspect("equal")
        ax.set_xlim(low[0], high[0])
        ax.set_ylim(low[1], high[1])
        ax.tick_params(labelsize=7)
    fig.colorbar(ScalarMappable(norm=norm, cmap=colormaps["turbo"]), cax=bar, label="von Mises stress [MPa]")
    fig.suptitle(title or f"{force:g} N at the end effector, θ1 = {math.degrees(theta1):g}°, "
                 f"θ2 = {math.degrees(theta2):g}°", fontsize=10)  # fmt: skip
    return fig
