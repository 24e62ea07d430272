"""Calibration planning: which holds to make on a real rig, and how accurate the calibration will be.

- :mod:`.linear`: the calibration models linearised about the robot file;
- :mod:`.design`: the predicted force error of a set of holds, the noise floor, and the I-optimal holds;
- :mod:`.protocol`: the rig's candidate holds, hold times from the ADC, the plan in a short order, the baselines.

``sail plan-calibration`` is a thin layer over :func:`plan_calibration`.
"""

from .design import Candidates, ErrorMap, noise_floor, optimal_holds, predicted_map, seen_map
from .linear import Linearised, linearise
from .protocol import Plan, Rig, hold_time, plan_calibration, reading_noise

__all__ = ["Candidates", "ErrorMap", "Linearised", "Plan", "Rig", "hold_time", "linearise", "noise_floor", "optimal_holds",
           "plan_calibration", "predicted_map", "reading_noise", "seen_map"]  # fmt: skip
