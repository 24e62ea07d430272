"""Figures and reports.  Plotting lives here and nowhere else in the package.

Needs the ``report`` extra (matplotlib, markdown-it-py): ``pip install 'sailforce[report]'``.
"""

from .._extras import require

require("matplotlib", "report", "sailforce's figures and reports")
require("markdown_it", "report", "sailforce's figures and reports")
