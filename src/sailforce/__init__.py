"""sailforce: end-effector force sensing via arm-integrated load cells (SAIL).

Conventions
-----------
- SI units inside: metres, newtons, newton-metres, pascals.
- Angles are radians in the Python API, counter-clockwise from +x; degrees
  appear only at the edges (CLI flags and file columns ending in ``_deg``).
- Batch dimensions lead: vectors are ``(..., 2)``, matrices ``(..., 2, 2)``.
- T = J^T F is the torque the end-effector force induces at the motors,
  counter-clockwise positive; a motor's holding torque is -T.

>>> from sailforce import Arm
>>> arm = Arm()
>>> t1, t2 = arm.joint_torques(1.0, 0.2, 3.0, -4.0)
>>> fx, fy = arm.end_effector_force(1.0, 0.2, t1, t2)
>>> round(float(fx), 12), round(float(fy), 12)
(3.0, -4.0)
"""

from ._lazy import lazy_exports
from ._version import __version__

_EXPORTS = {
    "arm": ("Arm",),
    "robot": ("Handle", "Joint", "Joints", "LinkBodies", "LinkBody", "Motors", "Plane", "Robot"),
    "loadcell": ("LoadCell",),
    "drift": ("Drift", "TemperatureProfile"),
    "materials": ("Material", "RectangularSection"),
    "kinematics": ("forward", "inverse", "jacobian", "joint_positions", "sin_delta", "workspace"),
    "statics": ("SINGULAR_SIN_DELTA", "ForceResult", "cartesian", "end_effector_force", "joint_torques", "polar"),
    "status": ("EXTRAPOLATED", "INVALID", "MOTION_UNKNOWN", "OK", "SATURATED", "SINGULAR", "STATUS_NAMES"),
    "errors": ("CalibrationFileError", "ClusterError", "CommandError", "CompensationError", "DesignError", "DynamicsError",
               "ExportError", "FilterError", "GeometryError", "IdentifyError", "InputError", "MeshError", "MissingExtraError",
               "MotionDataError", "NonFiniteInputError", "OutputPathError", "RecordingError", "RegressorError", "RobotFileError",
               "SailError", "ShapeError", "SingularPoseError", "SolverError", "SpecError", "TableError", "ToolError",
               "UnreachablePointError"),
    "synthetic": ("NoiseModel", "calibration_session", "recording", "session_offsets"),
    "calibration": ("Calibration", "Tare", "tare"),
    "estimate": ("DynamicTerm", "LowPass", "ReZero", "ReZeroPolicy", "estimate", "estimate_force", "estimate_moving"),
    "fit": ("fit_calibration", "fit_dynamic_term", "fit_physics", "identify", "prior_term"),
    "workflows": ("calibrate", "calibration_run", "check_solid", "identify_robot", "reproduce"),
    "paper": ("ModelId", "Protocol", "identify_table4", "run_study", "seed_table4"),
    "design": ("GridSpec", "design_grid", "parse_sweep", "run_design", "run_sweep"),
    "stream": ("estimate_lines", "stream_estimate"),
    "motion": ("Differentiator", "base_parameters", "inertial_parameters", "parameter_vector", "reaching", "record",
               "therapy_session"),
    "fem": ("build_model", "simulate", "simulate_model"),
    "io": ("load_robot_file", "read_all"),
}

#: The objects and workflows a user needs; each is imported on first use (``from sailforce import calibrate``).
__all__, __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = [*__all__, "__version__"]
