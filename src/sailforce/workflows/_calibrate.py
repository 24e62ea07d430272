"""``calibrate``: a :class:`~sailforce.calibration.Calibration` from calibration readings, as ``sail calibrate`` makes it.

The recipe, in order:

1. the readings (a table, or columns in memory) must be clean
   (:func:`sailforce.io.tables.read_clean`);
2. :func:`sailforce.fit.fit_calibration` fits the offsets and the sensing map
   (``model``: seed, matrix, physics or the best cross-validated);
3. the capacity, unless given, is the load cell's rating seen through the
   fitted map (:func:`sailforce.fit.equivalent_capacity`);
4. the calibration covers the *model's* delta range (a physics map's is wider
   than the data's), records the readings' range, the fit's metrics and the
   data file's SHA-256;
5. a dynamic term is identified from a free-motion recording
   (:func:`sailforce.fit.fit_dynamic_term`), or the robot file's prior is
   stored (``dynamics="prior"``), or none.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..adc import ADC
from ..calibration.file import MAX_RAW, Calibration
from ..drift import MIN_TEMPERATURE_SPAN_C, fit_temperature
from ..errors import InputError, TableError
from ..estimate.dynamic import DynamicTerm
from ..estimate.multirate import LOAD_TIME_COLUMNS
from ..estimate.rezero import force_per_count
from ..fit.calibration import FitReport, equivalent_capacity, fit_calibration
from ..fit.dynamic import DynamicFit, fit_dynamic_term, prior_term
from ..fit.multirate import HoldSamples, MultiRateDynamicFit, fit_dynamic_multirate, hold_samples
from ..fit.physics import DEFAULT_TRANSDUCTION
from ..io.tables import READING_COLUMNS, REFERENCE_COLUMNS, read_clean, table_names
from ..robot import Robot

#: Where the readings come from: a CSV or Parquet file, or columns in memory (angles in degrees, as in the files).
Readings = str | Path | Mapping[str, np.ndarray]

#: The optional column of the cells' temperature [°C]: calibration data spanning temperatures identify their
#: coefficients (sailforce.drift.TemperatureCompensation).
TEMPERATURE_COLUMN = "temperature_C"
#: Map and temperature coefficients are fitted in turn this many times (_temperature_pass).
TEMPERATURE_PASSES = 3
#: The columns of a free-motion recording: the time [s] and the readings.
FREE_MOTION_COLUMNS = ("t_s",) + READING_COLUMNS


@dataclass(frozen=True)
class CalibrationRun:
    """What :func:`calibration_run` made: the calibration, and the reports of its fits."""

    calibration: Calibration
    fit: FitReport  #: the static fit (its physics identification in ``fit.physics``)
    dynamic_fit: DynamicFit | None = None  #: the dynamic term's identification, from a free-motion recording
    prior: DynamicTerm | None = None  #: the robot file's predicted dynamic term, beside an identified one
    multirate: MultiRateDynamicFit | None = None  #: the same through a real ADC: with its delay and measured clocks
    holds: HoldSamples | None = None  #: a multi-rate static recording's holds, and the conversions used
    notes: tuple[str, ...] = ()  #: what the run could not do with the data, for people (a narrow temperature span)


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, as a calibration records its data's."""
    with open(path, "rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


def _columns(readings: Readings, needed: tuple[str, ...], what: str, *, sparse: tuple[str, ...] = (),
             optional: tuple[str, ...] = ()) -> tuple[dict[str, np.ndarray], str]:  # fmt: skip
    """The needed columns (and the ``optional`` ones present) and the data's SHA-256 (a file's; empty in memory).

    ``sparse`` columns may be empty (NaN): a multi-rate table's loads and their instants.
    """
    if isinstance(readings, str | Path):
        present = tuple(c for c in optional if c in table_names(readings)) if optional else ()
        return read_clean(readings, needed + present, what, sparse=sparse + present), file_sha256(readings)
    missing = [name for name in needed if name not in readings]
    if missing:
        raise TableError(f"{what}: missing column(s) {', '.join(missing)}; expected {', '.join(needed)}")
    names = needed + tuple(c for c in optional if c in readings)
    values = {name: np.asarray(readings[name], dtype=float).ravel() for name in names}
    for name, v in values.items():
        if not np.all(np.isfinite(v) | (np.isnan(v) & (name in sparse or name in optional))):
            raise TableError(f"{what}: column {name} holds a value that is not a finite number; it must be clean")
    return values, ""


def _multirate_columns(readings: Readings, needed: tuple[str, ...], what: str):
    """A multi-rate table's columns: ``t_s``, the angles, the sparse loads, their instants (NaN where absent)."""
    values, sha256 = _columns(readings, ("t_s",) + needed, what, sparse=("load1", "load2"), optional=LOAD_TIME_COLUMNS)
    n = values["t_s"].size
    load_t = np.column_stack([values.get(c, np.full(n, np.nan)) for c in LOAD_TIME_COLUMNS])
    return values, load_t, sha256


def calibration_run(
    readings: Readings,
    *,
    robot: Robot,
    model: str = "auto",
    free: tuple[str, ...] | None = None,
    transduction: str | None = None,
    capacity: tuple[float, float] | None = None,
    load_unit: str = "raw",
    free_motion: Readings | None = None,
    dynamics: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    adc: ADC | None = None,
) -> CalibrationRun:
    """:func:`calibrate`, with the reports of the fits (what ``sail calibrate`` prints)."""
    if free_motion is not None and dynamics is not None:
        raise InputError("dynamics chooses a dynamic term without a free-motion recording; give one or the other")
    if dynamics not in (None, "prior", "none"):
        raise InputError(f"dynamics = {dynamics!r}: expected 'prior' or 'none'")
    adc = robot.adc if adc is None else adc
    holds = None
    notes: list[str] = []
    temperature = None
    if adc.ideal:
        values, sha256 = _columns(readings, READING_COLUMNS + REFERENCE_COLUMNS, "Calibration data",
                                  optional=(TEMPERATURE_COLUMN,))  # fmt: skip
        temperature = values.pop(TEMPERATURE_COLUMN, None)
    else:  # held poses and forces through a real ADC: one sample per hold, from its settled conversions
        values, load_t, sha256 = _multirate_columns(readings, READING_COLUMNS + REFERENCE_COLUMNS, "Calibration data")
        theta = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
        holds = hold_samples(adc, values["t_s"], theta, np.column_stack([values["fx_N"], values["fy_N"]]),
                             np.column_stack([values["load1"], values["load2"]]), load_t)  # fmt: skip
        if holds.used_holds == 0:
            raise TableError(f"Calibration data: none of its {holds.holds} holds has a settled conversion of each cell "
                             f"(a whole {adc.settling_s * 1e3:g} ms filter window inside the hold): hold each pose and "
                             "force longer")  # fmt: skip
        values = {"theta1_deg": np.degrees(holds.pose[:, 0]), "theta2_deg": np.degrees(holds.pose[:, 1]),
                  "fx_N": holds.force[:, 0], "fy_N": holds.force[:, 1], "load1": holds.loads[:, 0], "load2": holds.loads[:, 1]}  # fmt: skip
    if transduction is None and model in ("physics", "auto"):  # what the cells read: the robot file's, else the fit's default
        transduction = robot.loadcell.reading or DEFAULT_TRANSDUCTION
    theta1, theta2 = np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"])

    def fit(load1, load2):
        return fit_calibration(robot.arm, theta1, theta2, values["fx_N"], values["fy_N"], load1, load2, kind=model,
                               robot=robot, free=free, transduction=transduction, progress=progress)  # fmt: skip

    fitted = fit(values["load1"], values["load2"])
    identified, uncompensated = None, None
    if temperature is not None:
        identified, corrected, note = _temperature_pass(robot, fitted, theta1, theta2, values, temperature)
        notes.extend(note)
        if identified is not None:
            uncompensated = fitted.report.fit_rmse_N
            fitted = fit(corrected[:, 0], corrected[:, 1])
    compensation = identified.compensation if identified is not None else None
    report = fitted.report
    if capacity is None:
        capacity = tuple(equivalent_capacity(fitted.model, robot.arm, robot.loadcell.capacity_N, report.delta_range))
    loads = (values["load1"], values["load2"])
    cal = Calibration(
        arm=robot.arm, model=fitted.model, offsets=(float(fitted.offsets[0]), float(fitted.offsets[1])),
        capacity=(float(capacity[0]), float(capacity[1])), delta_range=report.model_delta_range,
        load_range=((float(loads[0].min()), float(loads[0].max())), (float(loads[1].min()), float(loads[1].max()))),
        load_unit=load_unit, metrics=_metrics(report, model), data_sha256=sha256, adc=adc, temperature=compensation,
    )  # fmt: skip
    if identified is not None:
        cal = replace(cal, metrics={**cal.metrics, "temperature_range_C": [float(temperature.min()), float(temperature.max())],
                                    "fit_rmse_uncompensated_N": uncompensated,
                                    "temperature_se": {"zero_per_C": list(identified.zero_se),
                                                       "span_per_C": list(identified.span_se)}})  # fmt: skip
    if holds is not None:
        cal = replace(cal, metrics={**cal.metrics, "holds": holds.holds, "holds_used": holds.used_holds,
                                    "conversions": list(holds.conversions), "conversions_settled": list(holds.settled)})  # fmt: skip
    if free_motion is not None:
        return replace(_with_dynamics(cal, report, robot, free_motion, holds), notes=tuple(notes))
    if dynamics == "prior":
        cal = replace(cal, dynamics=prior_term(robot), dynamics_source="prior")
    return CalibrationRun(cal, report, holds=holds, notes=tuple(notes))


def _temperature_pass(robot: Robot, fitted, theta1, theta2, values, temperature):
    """The cells' temperature coefficients (:func:`sailforce.drift.fit_temperature`): ``(compensation, loads as at the
    reference temperature (n, 2), notes)``, or ``(None, None, notes)`` when the data span too few degrees.

    The signal each reading should show comes from a fitted map, and a map fitted on drifting loads is itself off
    by the drift's share that it absorbs: so the map (a matrix fit, fast) and the coefficients are fitted in turn,
    :data:`TEMPERATURE_PASSES` times, each map on the loads the last coefficients corrected.
    """
    if not np.all(np.isfinite(temperature)):
        raise TableError(f"Calibration data: column {TEMPERATURE_COLUMN} holds a value that is not a finite number")
    spread = float(np.ptp(temperature))
    if spread < MIN_TEMPERATURE_SPAN_C:
        return None, None, (f"{TEMPERATURE_COLUMN} spans {spread:.3g} degC, under {MIN_TEMPERATURE_SPAN_C:g}: no "
                            "temperature coefficients identified (calibrate over a wider range for them)",)  # fmt: skip
    loads = np.column_stack([values["load1"], values["load2"]])
    force = np.column_stack([values["fx_N"], values["fy_N"]])
    corrected = loads
    for _ in range(TEMPERATURE_PASSES):
        offsets = np.asarray(fitted.offsets, float)
        provisional = Calibration(arm=robot.arm, model=fitted.model, offsets=(float(offsets[0]), float(offsets[1])),
                                  capacity=(MAX_RAW, MAX_RAW), delta_range=fitted.report.model_delta_range)  # fmt: skip
        w = force_per_count(lambda a, b, c, d, cal=provisional: cal.estimate(a, b, c, d)[:2], offsets, theta1, theta2)
        signal = np.linalg.solve(w, force[..., None])[..., 0]
        identified = fit_temperature(temperature, loads, signal, offsets)
        corrected = identified.compensation.corrected(loads, temperature, offsets + np.asarray(identified.intercept))
        fitted = fit_calibration(robot.arm, theta1, theta2, force[:, 0], force[:, 1], corrected[:, 0], corrected[:, 1],
                                 kind="matrix")  # fmt: skip
    return identified, corrected, ()


def calibrate(readings: Readings, *, robot: Robot, model: str = "auto", free: tuple[str, ...] | None = None,
              transduction: str | None = None, capacity: tuple[float, float] | None = None, load_unit: str = "raw",
              free_motion: Readings | None = None, dynamics: str | None = None,
              progress: Callable[[int, int], None] | None = None, adc: ADC | None = None) -> Calibration:  # fmt: skip
    """A calibration from calibration readings (module docstring): what ``sail calibrate`` writes.

    ``readings`` is a CSV or Parquet file, or a mapping of columns, with
    ``theta1_deg, theta2_deg, load1, load2, fx_N, fy_N``.  ``model`` is
    ``seed``, ``matrix``, ``physics`` or ``auto``; ``free`` and
    ``transduction`` set up the physics fit; ``capacity`` is each cell's raw
    reading at its rating (default: from the robot's load cell);
    ``free_motion`` (``t_s, theta1_deg, theta2_deg, load1, load2``, nobody
    holding the handle) identifies the dynamic term; else ``dynamics="prior"``
    stores the robot file's.  ``progress(done, total)`` follows the physics
    fit's starts.  ``adc`` (default: the robot's) says how the readings were
    converted: a real one makes them multi-rate tables (``t_s`` and sparse
    loads, :mod:`sailforce.fit.multirate`).  Save it with :meth:`Calibration.save`.
    """
    return calibration_run(readings, robot=robot, model=model, free=free, transduction=transduction, capacity=capacity,
                           load_unit=load_unit, free_motion=free_motion, dynamics=dynamics, progress=progress,
                           adc=adc).calibration  # fmt: skip


#: The deltas a nominal calibration's map covers [deg]: the whole workspace the plans' maps span.
NOMINAL_DELTA_RANGE_DEG = (15.0, 165.0)


def nominal_calibration(robot: Robot, *, transduction: str | None = None) -> Calibration:
    """A calibration from the robot file alone: its frame model's map in HX711 counts, zero offsets, no fit.

    What a guided calibration estimates with before there is one (``sail live --calibrate`` without
    ``--calibration``): a tare sets the offsets, and the force it shows is then as right as the robot file
    (the cells' gains within their datasheet tolerance).  The map is the physics model's at unit gains
    (:func:`sailforce.fit.physics.stored_map`, the counts of :data:`sailforce.synthetic.HX711_COUNTS_PER_MV_V`
    per mV/V), over :data:`NOMINAL_DELTA_RANGE_DEG`.
    """
    from ..fit.physics import stored_map
    from ..synthetic import HX711_COUNTS_PER_MV_V

    transduction = transduction or robot.loadcell.reading or DEFAULT_TRANSDUCTION
    delta_range = (float(np.radians(NOMINAL_DELTA_RANGE_DEG[0])), float(np.radians(NOMINAL_DELTA_RANGE_DEG[1])))
    model, error = stored_map(robot, np.full(2, HX711_COUNTS_PER_MV_V), delta_range, transduction)
    capacity = equivalent_capacity(model, robot.arm, robot.loadcell.capacity_N, delta_range)
    return Calibration(arm=robot.arm, model=model, offsets=(0.0, 0.0), capacity=(float(capacity[0]), float(capacity[1])),
                       delta_range=delta_range, metrics={"model_selection": "nominal", "map_error": error},
                       adc=robot.adc)  # fmt: skip


def _metrics(report: FitReport, selection: str) -> dict:
    metrics = {"fit_rmse_N": report.fit_rmse_N, "cv_rmse_N": report.cv_rmse_N, "cv_rmse_by_model_N": report.cv_rmse_by_kind,
               "n_samples": report.n_samples, "n_deltas": report.n_deltas, "model_selection": selection,
               "data_delta_range_deg": [float(v) for v in np.degrees(report.delta_range)]}  # fmt: skip
    if report.physics is not None:
        metrics["physics"] = physics_metrics(report.physics)
    return metrics


def physics_metrics(physics) -> dict:
    """What the calibration file records of a physics fit: each parameter with its standard error."""
    fit = physics.identification
    return {"parameters": {name: {"value": float(v), "standard_error": float(se), "identifiable": bool(ok)}
                           for name, v, se, ok in zip(fit.names, fit.values, fit.standard_errors, fit.identifiable)},
            "cv_rmse_N": physics.cv_rmse_N, "map_order": physics.compensator.order, "map_error": physics.map_error}  # fmt: skip


def _with_dynamics(cal: Calibration, report: FitReport, robot: Robot, free_motion: Readings,
                   holds: HoldSamples | None = None) -> CalibrationRun:  # fmt: skip
    """The dynamic term from a free-motion recording, on top of the static calibration ``cal``."""
    if cal.multirate:
        values, load_t, _ = _multirate_columns(free_motion, READING_COLUMNS, "A free-motion recording")
        theta = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
        multi = fit_dynamic_multirate(cal, cal.adc, values["t_s"], theta, np.column_stack([values["load1"], values["load2"]]),
                                      load_t)  # fmt: skip
        metrics = {**cal.metrics, "dynamics_rmse_raw": multi.rmse, "dynamics_condition": multi.condition,
                   "dynamics_conversions": multi.conversions, "adc_delay_s": multi.delay_s,
                   "adc_delay_se_s": multi.delay_se_s, "adc_rates_Hz": [c.rate_Hz for c in multi.clocks],
                   "adc_phases_s": [c.phase_s for c in multi.clocks], "motion_bandwidth_Hz": multi.motion_bandwidth_Hz}  # fmt: skip
        cal = replace(cal, dynamics=multi.term, dynamics_source="free-motion", metrics=metrics, adc_delay_s=multi.delay_s)
        return CalibrationRun(cal, report, prior=prior_term(robot), multirate=multi, holds=holds)
    try:
        values, _ = _columns(free_motion, FREE_MOTION_COLUMNS, "A free-motion recording")
    except TableError as exc:
        if "missing column(s) t_s" in str(exc):
            raise TableError(f"{exc}. A free-motion recording needs t_s, the time of each sample [s], to derive "
                             "the joint rates: record it with the readings") from None  # fmt: skip
        raise
    fit = fit_dynamic_term(cal, values["t_s"], np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"]),
                           values["load1"], values["load2"])  # fmt: skip
    metrics = {**cal.metrics, "dynamics_rmse_N": fit.rmse_N, "dynamics_cv_rmse_N": fit.cv_rmse_N,
               "dynamics_condition": fit.condition, "dynamics_samples": fit.samples}  # fmt: skip
    cal = replace(cal, dynamics=fit.term, dynamics_source="free-motion", metrics=metrics)
    return CalibrationRun(cal, report, fit, prior_term(robot))
