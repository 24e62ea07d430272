"""A reference six-axis force/torque sensor at the handle: simulated, aligned, registered, and the force it gives.

- :mod:`~sailforce.reference.sensor`: its frame, clock and recording, and a simulated one;
- :mod:`~sailforce.reference.align`: its clock against the robot's, by canonical cross-correlation;
- :mod:`~sailforce.reference.frame`: its mount angle and offsets, from the cells' readings at rest;
- :mod:`~sailforce.reference.validate`: SAIL's force against it, overall, by region and Δ, at rest and moving.
"""

from .align import ClockAlignment, align_clocks
from .frame import SensorFrame, fit_frame, shear_map
from .sensor import (
    REFERENCE_SENSOR_COLUMNS,
    ReferenceRecording,
    ReferenceSensor,
    read_reference,
    rotate,
    sensor_angle,
    simulate_reference,
    to_base,
)

__all__ = [
    "REFERENCE_SENSOR_COLUMNS",
    "ClockAlignment",
    "ReferenceRecording",
    "ReferenceSensor",
    "SensorFrame",
    "align_clocks",
    "fit_frame",
    "read_reference",
    "rotate",
    "sensor_angle",
    "shear_map",
    "simulate_reference",
    "to_base",
]
