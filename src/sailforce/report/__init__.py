"""Figures and reports.  Plotting lives here and nowhere else in the package.

Needs the ``report`` extra (matplotlib, markdown-it-py): ``pip install 'sailforce[report]'``.
"""

from .._extras import require
from .._lazy import lazy_exports

require("matplotlib", "report", "sailforce's figures and reports")
require("markdown_it", "report", "sailforce's figures and reports")

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "document": ("write_report",),
    "results": ("write_results", "write_table4"),
    "design_report": ("write_design",),
    "sweep_report": ("write_sweep",),
    "seed_model": ("write_seed_model",),
    "solid_figure": ("write_table4_comparison",),
    "study_figures": ("compensated_figure", "sweeps_figure", "table4_figure", "workspace_figure"),
    "stress_figure": ("stress_figure",),
    "identify_figure": ("identify_figure",),
})
