"""The seed paper: its printed numbers and formulas, its virtual study, and what its SolidWorks model could have been.

- :func:`run_study` and :class:`Protocol`: the study of Section 3 on the frame model (Tables 4 and 5, Figs. 5-8);
- :func:`seed_table4` and the printed formulas (:mod:`sailforce.paper.seed`), kept only to compare against;
- :func:`identify_table4`: identification against a seed-style Table 4;
- :func:`seed_model_study`: structure families fitted to the seed's Table 4, and three checks.
"""

from .seed import printed_end_effector_force, printed_inverse_jt, seed_table4
from .seed_model import FAMILIES, Family, FamilyFit, SeedModelResult, fit_families, seed_model_study
from .study import TABLE4_COLUMNS, ModelId, Protocol, StudyResult, run_study, table4, table4_from_rows
from .table4_fit import Table4Target, identify_table4, table4_residuals

__all__ = [
    "FAMILIES",
    "TABLE4_COLUMNS",
    "Family",
    "FamilyFit",
    "ModelId",
    "Protocol",
    "SeedModelResult",
    "StudyResult",
    "Table4Target",
    "fit_families",
    "identify_table4",
    "printed_end_effector_force",
    "printed_inverse_jt",
    "run_study",
    "seed_model_study",
    "seed_table4",
    "table4",
    "table4_from_rows",
    "table4_residuals",
]
