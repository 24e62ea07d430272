"""The workflows: what each ``sail`` command does, as library functions that return result objects.

- :func:`calibrate` (``sail calibrate``): a :class:`~sailforce.calibration.Calibration` from readings;
- :func:`reference_calibration_run` (``sail calibrate --reference``): the same against a reference F/T sensor;
- :func:`nominal_calibration`: a calibration from the robot file alone, before there is a fitted one;
- :func:`validation` (``sail validate``): a calibration's force against a reference sensor's;
- :func:`identify_robot` (``sail identify``): the robot's physical parameters fitted to a target;
- :func:`reproduce` (``sail reproduce``): the seed's study, its model's families, its solid check;
- :func:`check_solid` (``sail solid``): the solid against the frame at one pose.

``sail design`` is :func:`sailforce.design.run_design` and :func:`sailforce.design.run_sweep`.
Each command parses its options, calls one of these, and prints or writes what it returns.
"""

from ._calibrate import CalibrationRun, calibrate, calibration_run, file_sha256, nominal_calibration
from ._identify import IdentifyRun, identify_robot, readings_target, table4_target
from ._reference import (
    ReferenceCalibrationRun,
    ReferenceRows,
    Validation,
    reference_calibration_run,
    reference_rows,
    validation,
)
from ._reproduce import Reproduction, SolidStudy, reproduce, solid_pass
from ._solid import SolidCheck, check_solid

__all__ = [
    "CalibrationRun",
    "IdentifyRun",
    "ReferenceCalibrationRun",
    "ReferenceRows",
    "Reproduction",
    "SolidCheck",
    "SolidStudy",
    "Validation",
    "calibrate",
    "calibration_run",
    "check_solid",
    "file_sha256",
    "identify_robot",
    "nominal_calibration",
    "readings_target",
    "reference_calibration_run",
    "reference_rows",
    "reproduce",
    "solid_pass",
    "table4_target",
    "validation",
]
