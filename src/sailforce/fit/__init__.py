"""Fitting from measurements: sensing maps, the arm's physical parameters, and the dynamic term.

- :func:`fit_calibration`: offsets and a sensing map (seed, matrix or physics) from calibration rows;
- :func:`fit_matrix_compensator`: the matrix map, its order chosen by cross-validation over delta;
- :func:`fit_physics`: the robot's frame model fitted to the readings;
- :func:`identify`: any robot-file keys that enter the sensing map, with their uncertainty;
- :func:`fit_dynamic_term`: the base inertial parameters from a free-motion recording.
"""

from .calibration import CalibrationFit, FitReport, equivalent_capacity, fit_calibration
from .dynamic import DynamicFit, fit_dynamic_term, prior_term
from .identify import (
    Identification,
    IdentifyError,
    Parameter,
    ReadingsTarget,
    Target,
    get_parameter,
    identify,
    parameter,
    parameter_names,
    sensing_map,
    with_free_springs,
    with_parameter,
)
from .matrix import delta_groups, fit_matrix_compensator, fit_matrix_with_offsets
from .physics import PhysicsFit, fit_physics, force_from_map, stored_map

__all__ = [
    "CalibrationFit",
    "DynamicFit",
    "FitReport",
    "Identification",
    "IdentifyError",
    "Parameter",
    "PhysicsFit",
    "ReadingsTarget",
    "Target",
    "delta_groups",
    "equivalent_capacity",
    "fit_calibration",
    "fit_dynamic_term",
    "fit_matrix_compensator",
    "fit_matrix_with_offsets",
    "fit_physics",
    "force_from_map",
    "get_parameter",
    "identify",
    "parameter",
    "parameter_names",
    "prior_term",
    "sensing_map",
    "stored_map",
    "with_free_springs",
    "with_parameter",
]
