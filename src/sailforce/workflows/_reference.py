"""A recording against a reference F/T sensor: its hand force at every robot sample, a calibration from it.

The recipe (:func:`reference_rows`, then :func:`reference_calibration_run`):

1. the robot's recording (``t_s, theta1_deg, theta2_deg, load1, load2``, a
   reading at every tick) and the sensor's (:func:`sailforce.reference.read_reference`);
2. the sensor's clock against the robot's (:func:`sailforce.reference.align_clocks`);
   only the robot's samples the sensor covers are kept;
3. the rows at rest: joint rates and accelerations (the differentiator of
   ``sail estimate``) under :data:`REST_RATE` and :data:`REST_ACCEL`;
4. the sensor's mount and offsets from the rows at rest
   (:func:`sailforce.reference.fit_frame`), and so the hand force in the base
   frame at every kept sample;
5. the static map from the rows at rest, as from weights over pulleys
   (:func:`sailforce.workflows.calibration_run`), at most
   :data:`STATIC_ROWS` of them, evenly spread;
6. the dynamic term from every kept sample with a known motion: with the
   hand's force known, ``loads - c - M(theta) F`` are the loads a free
   motion would give, and :func:`sailforce.fit.fit_dynamic_term` fits them.

:func:`validation` registers the reference the same way (steps 1-4) and
sets a calibration's force against it (:mod:`sailforce.reference.validate`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..calibration.file import Calibration
from ..errors import InputError
from ..estimate.dynamic import estimate_moving
from ..fit.dynamic import DynamicFit, fit_dynamic_term, prior_term
from ..kernel import torque_entries
from ..kinematics import forward
from ..motion.differentiate import Differentiator, derivatives
from ..reference.align import MAX_CLOCK_OFFSET_S, ClockAlignment, align_clocks
from ..reference.frame import SensorFrame, fit_frame, refine_clock
from ..reference.sensor import ReferenceRecording, read_reference
from ..reference.validate import DELTA_BIN_DEG, REGION_M, Agreement, Binned, agreement, by_bins
from ..robot import Robot
from ..status import EXTRAPOLATED, OK
from ._calibrate import FREE_MOTION_COLUMNS, CalibrationRun, Readings, _columns, calibration_run

#: A sample is at rest when both joints turn slower than this [rad/s]...
REST_RATE = 0.01
#: ...and accelerate less than this [rad/s^2]: an inertial shear of about 0.01 N on the default arm.
REST_ACCEL = 0.05

#: The model's clock refinement searches this many samples (the grid's or the sensor's, the longer) either side of
#: the correlation's offset, and at least this long [s]: a slow push's broad correlation peak can miss by several
#: milliseconds (8 ms measured on a short session), while the model's residual stays unimodal over a quarter period
#: of the push's fastest band (2 Hz: 125 ms).
CLOCK_SPAN_SAMPLES = 3
CLOCK_SPAN_S = 0.03
#: Refinements of the clock, each followed by a frame fit.
CLOCK_PASSES = 2

#: The static fit takes at most this many rows at rest, evenly spread (at 1 kHz neighbours add nothing new).
STATIC_ROWS = 2000
#: The frame fit likewise.
FRAME_ROWS = 4000


@dataclass(frozen=True)
class ReferenceRows:
    """A robot recording with the reference's hand force beside it: the samples the sensor covers."""

    t: np.ndarray  #: ``(n,)`` the robot's time [s]
    theta: np.ndarray  #: ``(n, 2)`` [rad]
    loads: np.ndarray  #: ``(n, 2)`` raw
    force: np.ndarray  #: ``(n, 2)`` the hand force in the base frame [N], from the sensor
    rest: np.ndarray  #: ``(n,)`` at rest (recipe step 3)
    alignment: ClockAlignment
    frame: SensorFrame
    dropped: int  #: the robot's samples outside the sensor's recording
    sha256: str  #: the robot recording's


def _evenly(mask: np.ndarray, most: int) -> np.ndarray:
    index = np.flatnonzero(mask)
    return index if index.size <= most else index[np.linspace(0, index.size - 1, most).round().astype(int)]


def reference_rows(data: Readings, reference: str | Path | ReferenceRecording, *, robot: Robot, on: str = "link",
                   max_offset_s: float = MAX_CLOCK_OFFSET_S, offsets_N=None,
                   differentiator: Differentiator = Differentiator()) -> ReferenceRows:  # fmt: skip
    """Recipe steps 1-4 (module docstring); ``on`` says where the sensor sits (:data:`sailforce.reference.sensor.MOUNTS`);
    ``offsets_N`` fixes the sensor's offsets instead of fitting them (:func:`~sailforce.reference.fit_frame`)."""
    if not robot.adc.ideal:
        raise InputError(f"the reference calibration reads a recording with a reading at every tick; the robot file's "
                         f"[adc] is {robot.adc.model}, whose multi-rate recordings it does not read yet")  # fmt: skip
    values, sha256 = _columns(data, FREE_MOTION_COLUMNS, "The robot's recording")
    ref = reference if isinstance(reference, ReferenceRecording) else read_reference(reference)
    t = values["t_s"]
    theta = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
    loads = np.column_stack([values["load1"], values["load2"]])
    alignment = align_clocks(t, loads, ref, theta1=theta[:, 0], on=on, max_offset_s=max_offset_s)
    at = t + alignment.offset_s
    covered = (at >= ref.t[0]) & (at <= ref.t[-1])
    if covered.sum() < 2:
        raise InputError("the reference sensor's recording covers none of the robot's")
    t, theta, loads, at = t[covered], theta[covered], loads[covered], at[covered]
    f_sensor = np.column_stack([np.interp(at, ref.t, ref.force[:, k]) for k in range(2)])
    qd, qdd = derivatives(t, theta, differentiator)
    rest = np.all((np.abs(qd) < REST_RATE) & (np.abs(qdd) < REST_ACCEL), axis=1)
    pick = _evenly(rest, FRAME_ROWS)
    frame = fit_frame(robot.arm, theta[pick, 0], theta[pick, 1], loads[pick], f_sensor[pick], on=on, offsets_N=offsets_N)
    # the model sharpens the correlation's offset (refine_clock), and the frame is fitted again at it: twice, the
    # second pass with the better frame
    span = max(CLOCK_SPAN_S, CLOCK_SPAN_SAMPLES * max(alignment.step_s, 1.0 / ref.rate_Hz))
    refined = alignment.offset_s
    for _ in range(CLOCK_PASSES):
        refined = refine_clock(robot.arm, frame, t[pick], theta[pick], loads[pick], ref, refined, span)
        f_sensor = np.column_stack([np.interp(t + refined, ref.t, ref.force[:, k]) for k in range(2)])
        frame = fit_frame(robot.arm, theta[pick, 0], theta[pick, 1], loads[pick], f_sensor[pick], on=on, offsets_N=offsets_N)
    alignment = replace(alignment, offset_s=refined, coarse_offset_s=alignment.offset_s)
    force = frame.to_base(theta[:, 0], f_sensor)
    return ReferenceRows(t, theta, loads, force, rest, alignment, frame, int((~covered).sum()), sha256)


@dataclass(frozen=True)
class ReferenceCalibrationRun:
    """What :func:`reference_calibration_run` made: the calibration run, and how the reference was registered."""

    run: CalibrationRun
    rows: ReferenceRows
    static_rows: int  #: rows at rest the static fit took
    dynamic_fit: DynamicFit | None = None


def reference_calibration_run(data: Readings, reference: str | Path | ReferenceRecording, *, robot: Robot,
                              model: str = "auto", free: tuple[str, ...] | None = None, transduction: str | None = None,
                              capacity: tuple[float, float] | None = None, load_unit: str = "raw",
                              dynamics: str = "fit", on: str = "link", max_offset_s: float = MAX_CLOCK_OFFSET_S,
                              offsets_N=None, progress: Callable[[int, int], None] | None = None) -> ReferenceCalibrationRun:  # fmt: skip
    """A calibration from a recording against a reference sensor (module docstring).

    ``dynamics``: ``"fit"`` identifies the dynamic term from the same
    recording, ``"prior"`` stores the robot file's, ``"none"`` none.  The
    other arguments are :func:`~sailforce.workflows.calibration_run`'s.
    """
    if dynamics not in ("fit", "prior", "none"):
        raise InputError(f"dynamics = {dynamics!r}: expected 'fit', 'prior' or 'none'")
    rows = reference_rows(data, reference, robot=robot, on=on, max_offset_s=max_offset_s, offsets_N=offsets_N)
    pick = _evenly(rows.rest, STATIC_ROWS)
    static = {"theta1_deg": np.degrees(rows.theta[pick, 0]), "theta2_deg": np.degrees(rows.theta[pick, 1]),
              "load1": rows.loads[pick, 0], "load2": rows.loads[pick, 1], "fx_N": rows.force[pick, 0],
              "fy_N": rows.force[pick, 1]}  # fmt: skip
    run = calibration_run(static, robot=robot, model=model, free=free, transduction=transduction, capacity=capacity,
                          load_unit=load_unit, dynamics=None if dynamics == "fit" else dynamics, progress=progress)  # fmt: skip
    a, f = rows.alignment, rows.frame
    metrics = {"reference": {"clock_offset_s": a.offset_s, "alignment_score": a.score, "mount_deg": float(np.degrees(f.mount_rad)),
                             "mount_se_deg": float(np.degrees(f.mount_se_rad)), "offsets_N": list(f.offsets_N),
                             "offsets_se_N": list(f.offsets_se_N), "offsets_fitted": f.offsets_fitted,
                             "on": f.on, "frame_rmse_raw": f.rmse_raw, "rows": int(rows.t.size),
                             "rows_at_rest": int(rows.rest.sum()), "static_rows": int(pick.size)}}  # fmt: skip
    cal = replace(run.calibration, data_sha256=rows.sha256, metrics={**run.calibration.metrics, **metrics})
    fit = None
    if dynamics == "fit":
        m = cal.model.sensing_entries(rows.theta[:, 0] - rows.theta[:, 1], torque_entries(
            cal.arm.l2, cal.arm.l3, *_trig(rows.theta)))  # fmt: skip
        hand = np.column_stack([m[0] * rows.force[:, 0] + m[1] * rows.force[:, 1],
                                m[2] * rows.force[:, 0] + m[3] * rows.force[:, 1]])  # fmt: skip
        free_loads = rows.loads - hand  # what the cells would read with nobody holding the handle
        fit = fit_dynamic_term(cal, rows.t, rows.theta[:, 0], rows.theta[:, 1], free_loads[:, 0], free_loads[:, 1])
        cal = replace(cal, dynamics=fit.term, dynamics_source="reference",
                      metrics={**cal.metrics, "dynamics_rmse_N": fit.rmse_N, "dynamics_cv_rmse_N": fit.cv_rmse_N,
                               "dynamics_condition": fit.condition, "dynamics_samples": fit.samples})  # fmt: skip
        run = replace(run, dynamic_fit=fit, prior=prior_term(robot))
    return ReferenceCalibrationRun(replace(run, calibration=cal), rows, int(pick.size), fit)


def _trig(theta: np.ndarray):
    return np.sin(theta[:, 0]), np.cos(theta[:, 0]), np.sin(theta[:, 1]), np.cos(theta[:, 1])


@dataclass(frozen=True)
class Validation:
    """SAIL's force against the reference's (:func:`validation`): the samples, and the agreement tables."""

    rows: ReferenceRows
    estimate: np.ndarray  #: ``(n, 2)`` SAIL's force [N]
    status: np.ndarray  #: ``(n,)`` its status codes (:mod:`sailforce.status`)
    position: np.ndarray  #: ``(n, 2)`` the hand's position [m]
    overall: Agreement  #: over the samples with status ok
    at_rest: Agreement | None
    moving: Agreement | None
    extrapolated: Agreement | None  #: beyond the calibration's Δ range (status extrapolated), if any
    by_delta: Binned  #: ok samples per Δ bin [deg]
    by_region: Binned  #: ok samples per square of the workspace [m]
    dynamics: bool  #: whether the calibration subtracted a dynamic term

    @property
    def used(self) -> np.ndarray:
        """The samples the overall agreement takes: status ok."""
        return self.status == OK


def validation(data: Readings, reference: str | Path | ReferenceRecording, calibration: Calibration, *,
               robot: Robot | None = None, on: str = "link", max_offset_s: float = MAX_CLOCK_OFFSET_S,
               offsets_N=None) -> Validation:  # fmt: skip
    """SAIL's force by ``calibration`` along ``data`` against the reference sensor's.

    The reference is registered as for a calibration (:func:`reference_rows`:
    the clock, and the mount and offsets from the rigid statics at rest, not
    from ``calibration``); the estimate subtracts the calibration's dynamic
    term when it has one.  ``robot`` (default: the calibration's arm on
    :class:`~sailforce.robot.Robot`'s defaults) gives the arm and the ADC.
    Fitted, the sensor's offsets carry an uncertainty (their standard
    errors, ``rows.frame.offsets_se_N``) into every bias; ``offsets_N`` fixes
    them, as for a sensor tared before the session.
    """
    robot = Robot(arm=calibration.arm) if robot is None else replace(robot, arm=calibration.arm)
    rows = reference_rows(data, reference, robot=robot, on=on, max_offset_s=max_offset_s, offsets_N=offsets_N)
    t1, t2 = rows.theta[:, 0], rows.theta[:, 1]
    if calibration.dynamics is not None:
        fx, fy, status, _ = estimate_moving(calibration, calibration.dynamics, rows.t, t1, t2, rows.loads[:, 0],
                                            rows.loads[:, 1])  # fmt: skip
    else:
        fx, fy, status = calibration.estimate(t1, t2, rows.loads[:, 0], rows.loads[:, 1])
    estimate, status = np.column_stack([fx, fy]), np.asarray(status)
    ok = status == OK
    if ok.sum() < 2:
        raise InputError(f"only {int(ok.sum())} of {status.size} samples have an estimate with status ok: is the "
                         "calibration of this arm?")  # fmt: skip
    position = np.column_stack(forward(calibration.arm, t1, t2))
    delta = np.degrees(t1 - t2)

    def part(mask):
        return agreement(estimate[mask], rows.force[mask]) if mask.sum() >= 2 else None

    return Validation(rows, estimate, status, position, agreement(estimate[ok], rows.force[ok]), part(ok & rows.rest),
                      part(ok & ~rows.rest), part((status == EXTRAPOLATED) & np.all(np.isfinite(estimate), axis=1)),
                      by_bins(estimate[ok], rows.force[ok], delta[ok], DELTA_BIN_DEG),
                      by_bins(estimate[ok], rows.force[ok], position[ok], REGION_M), calibration.dynamics is not None)  # fmt: skip
