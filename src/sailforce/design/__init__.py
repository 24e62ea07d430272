"""Design a SAIL arm before building it: what each pose of the workspace will give.

- :mod:`.maps`: resolution, overload and compensation need at each pose, from
  the frame's sensing map; the natural modes come from :mod:`sailforce.fem.modes`;
- :mod:`.study`: the x-y grid of reachable poses, every map on it, and the summary.
"""

from .._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "maps": (
        "DEFAULT_SAFETY_FACTOR", "OVERLOAD_DIRECTIONS", "CompensationNeed", "Overload", "Resolution",
        "compensation_need", "element_peaks", "overload", "resolution",
    ),
    "study": (
        "BOUNDS_SAMPLES", "DEFAULT_DELTA_DEG", "DEFAULT_GRID", "DEFAULT_THETA1_DEG", "DEFAULT_THETA2_DEG", "WORST",
        "Design", "DesignGrid", "design_grid", "run_design", "summarise",
    ),
    "sweep": (
        "CATALOGUE_KEYS", "CATALOGUE_REQUIRED", "DEFAULT_MIN_FREQUENCY_HZ", "DEFAULT_REQUIRED_FORCE_N", "MAX_VARIANTS",
        "METRICS", "OBJECTIVES", "PARETO_DIGITS", "RANK_DIGITS", "Axis", "GridSpec", "Requirements", "SweepResult",
        "Task", "Variant", "evaluate", "evaluate_safely", "pareto_mask", "parse_sweep", "read_catalogue", "run_sweep",
        "variants",
    ),
})
