"""Panel grids laid out by fixed margins, for figures of many like panels.

matplotlib's constrained layout measures every panel's labels before it
draws, which cost half of each 16-panel figure's time (``sail reproduce``'s
Figs. 5 and 6: 2.7 of 5.3 s under cProfile).  A grid of like panels needs
no measuring: its margins are known in inches, from the font sizes its
panels use.
"""

from __future__ import annotations

from dataclasses import dataclass

from matplotlib.figure import Figure


@dataclass(frozen=True)
class Margins:
    """A grid's margins and gaps [inches]: room for tick labels, axis labels, titles and a suptitle."""

    left: float = 0.62  #: y tick labels and the y label
    right: float = 0.15
    bottom: float = 0.5  #: x tick labels and the x label
    top: float = 0.65  #: the suptitle
    wgap: float = 0.5  #: between columns: the next panel's y tick labels
    hgap: float = 0.42  #: between rows: a panel's title, and the x tick labels of the one above


def panel_grid(fig: Figure, rows: int, cols: int, margins: Margins = Margins(), *, colorbar: float = 0.0, **subplots):
    """``fig.subplots(rows, cols, **subplots)`` placed by ``margins``; ``colorbar`` [in] kept free on the right.

    Returns the axes array (``squeeze=False``), and, with ``colorbar`` > 0, an axes for the colour bar.
    """
    width, height = fig.get_size_inches()
    right = margins.right + colorbar
    panel_w = (width - margins.left - right - (cols - 1) * margins.wgap) / cols
    panel_h = (height - margins.bottom - margins.top - (rows - 1) * margins.hgap) / rows
    grid = {"left": margins.left / width, "right": 1.0 - right / width, "bottom": margins.bottom / height,
            "top": 1.0 - margins.top / height, "wspace": margins.wgap / panel_w, "hspace": margins.hgap / panel_h}
    axes = fig.subplots(rows, cols, squeeze=False, gridspec_kw=grid, **subplots)
    if colorbar <= 0:
        return axes
    bar_left = 1.0 - (right - 0.25) / width
    bar = fig.add_axes((bar_left, grid["bottom"] + 0.1 * (grid["top"] - grid["bottom"]), 0.16 / width,
                        0.8 * (grid["top"] - grid["bottom"])))  # fmt: skip
    return axes, bar
