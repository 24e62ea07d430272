"""Which ADC?  Each one's latency, bandwidth, resolution at its rate, and the force error it leaves in a reach.

The error in a reach is measured, not guessed: one minimum-jerk reach of the
asked peak acceleration (a 0.3 m chord, the hand pulling toward its target
with :data:`HAND_STIFFNESS` rising over :data:`sailforce.motion.multirate.HAND_RISE_S`)
is simulated through the robot's ADC without noise, and estimated at each
conversion (:mod:`sailforce.estimate.multirate`) with the calibration the
simulation implies exactly (the pin-jointed arm's map, the robot file's
dynamic term).  What is left is the ADC's timing: the window's smear of a
changing force and the interpolation between the cells' conversions.
"""

from __future__ import annotations

import numpy as np

from ..calibration.file import Calibration
from ..estimate.multirate import MultiRateEstimator
from ..fit.dynamic import prior_term
from ..motion.differentiate import derivatives
from ..motion.multirate import HAND_RISE_S, record_multirate
from ..motion.reaching import MINJERK_PEAK_ACCELERATION, counts_per_newton
from ..robot import Robot
from ..sensing.maps import MatrixCompensator
from ..status import OK
from ..synthetic import NoiseModel
from .maps import adc_noise_at_hand

#: The reach's length [m] and the hand's pull toward its target [N/m] (the motion guide's task).
REACH_M = 0.3
HAND_STIFFNESS = 100.0
#: The peak hand acceleration [m/s^2] a reach is judged at by default (the motion guide's 3 m/s^2).
DEFAULT_PEAK_ACCELERATION = 3.0

#: The columns `sail design` adds for a robot with a real ADC.
ADC_METRICS = ("adc_latency_ms", "adc_bandwidth_Hz", "adc_resolution_N", "reach_error_N")


def exact_calibration(robot: Robot) -> Calibration:
    """The calibration a simulated rig implies: the pin-jointed arm's map in counts, its dynamic term, its ADC."""
    gain = counts_per_newton(robot)
    delta_range = (0.05, np.pi - 0.05)
    # the cells read their shears T_i / l_i through the HX711's gain: M = diag(gain / l) J^T, a constant C (order 0)
    model = MatrixCompensator(robot.arm, np.diag([gain / robot.arm.l1, gain / robot.arm.l2])[None], delta_range)
    capacity = 4.0 * robot.loadcell.capacity_N * gain
    return Calibration(arm=robot.arm, model=model, offsets=(0.0, 0.0), capacity=(capacity, capacity),
                       delta_range=delta_range, dynamics=prior_term(robot), dynamics_source="prior", adc=robot.adc)  # fmt: skip


def reach_error(robot: Robot, peak_acceleration: float = DEFAULT_PEAK_ACCELERATION, seed: int = 0,
                hand_rise_s: float = HAND_RISE_S) -> float:
    """The RMS force error [N] at each estimate's instant over one reach of ``peak_acceleration`` [m/s^2] (module docstring)."""
    if robot.adc.ideal:
        return 0.0
    duration = np.sqrt(MINJERK_PEAK_ACCELERATION * REACH_M / peak_acceleration)
    speed = 1.875 * REACH_M / duration
    rec = record_multirate(robot, robot.adc, reach=REACH_M, reaches=2, peak_speed=speed, dwell=0.3,
                           hand_stiffness=HAND_STIFFNESS, hand_rise_s=hand_rise_s, noise=NoiseModel(0.0, 0.0, False),
                           offsets=(0.0, 0.0), seed=seed)  # fmt: skip
    cal = exact_calibration(robot)
    term = prior_term(robot)
    qd, qdd = derivatives(rec.t, rec.theta, term.differentiator)
    out = MultiRateEstimator(cal).rows(rec.t, rec.theta, rec.loads, rec.load_t, np.zeros(rec.t.size, bool), qd, qdd)
    ok = out.status == OK
    ft = out.columns["force_t_s"]
    true = np.column_stack([np.interp(ft, rec.t, rec.force[:, i]) for i in range(2)])
    error = np.hypot(out.columns["fx_N"] - true[:, 0], out.columns["fy_N"] - true[:, 1])[ok]
    return float(np.sqrt(np.mean(error**2))) if error.size else float("nan")


def adc_summary(robot: Robot, peak_acceleration: float = DEFAULT_PEAK_ACCELERATION) -> dict[str, float]:
    """:data:`ADC_METRICS` of the robot's ADC: latency [ms], -3 dB bandwidth [Hz], its noise at the hand [N], a reach's error [N]."""
    adc = robot.adc
    return {"adc_latency_ms": 1e3 * adc.group_delay_s, "adc_bandwidth_Hz": adc.bandwidth_Hz,
            "adc_resolution_N": adc_noise_at_hand(robot), "reach_error_N": reach_error(robot, peak_acceleration)}  # fmt: skip
