"""The arm in motion: its dynamics, joint rates from sampled angles, and reaching movements.

- :mod:`.dynamics`: the shear each cell carries from link inertia, gravity
  and the hand's force (:class:`ShearModel`, the base parameters);
- :mod:`.differentiate`: zero-phase joint rates and accelerations from
  encoder angles (Savitzky-Golay windows), in files and live;
- :mod:`.reaching`: minimum-jerk reaches and the recordings they produce.
"""

from .._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "multirate": ("HoldRecording", "MultiRateRecording", "hand_anchor", "multirate_columns", "record_holds", "record_multirate"),
    "differentiate": (
        "FIT_BLOCK", "GAP_FACTOR", "MAX_JOINT_ACCEL", "MAX_JOINT_RATE", "MIN_WINDOW_MARGIN", "PROBE_STEPS", "THREADS",
        "UNIFORM_BLOCK", "UNIFORM_RTOL", "Differentiator", "RatePlan", "RateTracker", "check_period", "derivatives",
        "implausible", "kernel_polynomials", "sampling_period", "unwrapped",
    ),
    "dynamics": (
        "BODIES", "BODY_PARAMETERS", "GRAVITY_PARAMETERS", "INERTIAL_PARAMETERS", "PARAMETERS", "RANK_RTOL",
        "SHEAR_TERMS", "BaseParameters", "BodyInertia", "InertialParameters", "ShearModel", "bar", "base_parameters",
        "cell_shears", "gravity_coefficients", "inertial_parameters", "parameter_vector", "point_mass",
        "shear_regressor", "stacked_regressor",
    ),
    "reaching": (
        "MINJERK_PEAK_ACCELERATION", "MINJERK_PEAK_SPEED", "TARGET_STEP", "JointMotion", "MotionRecording",
        "counts_per_newton", "minimum_jerk", "reaching", "record",
    ),
    "session": ("PUSH_BAND_HZ", "TREMOR_BAND_HZ", "TherapySession", "release_mask", "therapy_session", "tremor"),
})
