"""A guided calibration on the live page: a plan's holds (``sail plan-calibration``) walked through, one at a time.

:class:`Guide` listens to the live pipeline (every row, on the estimating
thread) and moves through phases, for each hold of the plan in turn:

1. ``move``: the arm goes to the hold's pose; it is there when both angles
   are within :data:`POSE_TOL_DEG` of it;
2. ``hang``: the weight goes on, over the pulley in the hold's direction; it
   is on when the estimated force is within :data:`LOAD_MATCH` of the
   hold's (the calibration the page runs on: the user's, or the robot
   file's nominal one after the first step's tare);
3. ``settle``: the filter refills and the weight stops swinging: the ADC's
   settling time and :data:`sailforce.plan.protocol.STILL_S`, the pose and the
   force held.  The readings are then still when, over that window, each
   force component's standard deviation is within :data:`STILL_SD_N` (and
   :data:`STILL_FRACTION` of the hold's force) and neither angle moved more
   than :data:`STILL_DEG`;
4. ``record``: the plan's conversions, at the ADC's period, the pose and the
   force still held.  Anything that breaks a condition sends the hold back
   to the phase it broke (a bumped weight back to ``hang``).

Before the first hold, a ``tare`` step: no weight on, the arm still, the
offsets re-estimated (the estimate then reads zero at rest).  ``skip`` moves
on without the hold (or without the tare), ``redo`` makes the last recorded
hold again.

After the last hold the rows of every recorded hold (its settle and record
windows, each row with the hold's mean pose and the plan's force) are written
as an ordinary calibration recording (``theta1_deg, theta2_deg, load1,
load2, fx_N, fy_N``, what ``sail calibrate`` reads), the plan's model is
fitted to it (:func:`sailforce.workflows.calibration_run`) and saved, and the
achieved accuracy map is computed beside the planned one: the same
linearised model (:func:`sailforce.plan.predicted_map`) at the holds as they
were made, each with the reading noise its rows showed.

The guide reads synchronous streams (both loads on every row): ``sail live
--calibrate`` refuses a calibration with a real ADC's multi-rate estimate.  Rows
that are not numbers neither start nor break a window.
"""

from __future__ import annotations

import json
import logging
import math
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..adc import ADC, adc_model
from ..errors import CommandError, InputError, SailError, TableError
from ..io.files import write_json, write_numeric_table
from ..io.tables import read_clean, table_names
from ..kinematics import joint_positions
from ..loadcell import STANDARD_GRAVITY
from ..plan.design import Candidates, ErrorMap, map_deltas, predicted_map
from ..plan.linear import linearise
from ..plan.protocol import DEFAULT_CONVERSIONS, STILL_S, reading_noise
from ..robot import Robot
from .pipeline import Rows
from .recorder import fresh_file

log = logging.getLogger(__name__)

#: The arm is at a hold's pose when both angles are within this of it [deg].
POSE_TOL_DEG = 0.5
#: The weight is on when the estimated force is within this fraction of the hold's force of it.
LOAD_MATCH = 0.25
#: Still: each force component's standard deviation over the settle window within this [N] ...
STILL_SD_N = 0.05
#: ... or within this fraction of the hold's force, whichever is larger (a heavy weight swings more in newtons).
STILL_FRACTION = 0.01
#: Still: neither angle moves more than this over the window [deg].
STILL_DEG = 0.1
#: The tare's samples: those of one record window, at least this many.
MIN_TARE_SAMPLES = 50
#: The columns a plan must have (``sail plan-calibration``'s plan.csv has them).
PLAN_COLUMNS = ("theta1_deg", "theta2_deg", "fx_N", "fy_N")
#: The calibration recording's columns.
RECORDING_COLUMNS = ("hold", "t_s", "theta1_deg", "theta2_deg", "load1", "load2", "fx_N", "fy_N")

PHASES = ("tare", "taring", "move", "hang", "settle", "record", "fitting", "done", "failed")


@dataclass(frozen=True)
class GuidePlan:
    """The holds to make, in order: poses [rad], forces [N], masses [kg], conversions; the model they plan for."""

    theta1: np.ndarray
    theta2: np.ndarray
    fx: np.ndarray
    fy: np.ndarray
    mass_kg: np.ndarray
    conversions: np.ndarray
    model: str = "physics"
    free: tuple[str, ...] | None = None  #: physics: the free keys (None: the fit's default)
    order: int | None = None  #: matrix: the series' order
    adc: str | None = None  #: the ADC the plan was made for (None: the robot file's)
    delta_range: tuple[float, float] = (math.radians(30.0), math.radians(120.0))
    planned: ErrorMap | None = None  #: the plan's own predicted map (predicted.csv), when it sits beside the plan
    source: str = "the plan"

    def __len__(self) -> int:
        return int(self.theta1.size)


def read_plan(path: str | Path) -> GuidePlan:
    """A plan from ``plan.csv`` (``sail plan-calibration``), with ``plan.json`` and ``predicted.csv`` beside it when there."""
    path = Path(path)
    what = f"the plan {path}"
    names = table_names(path)
    optional = tuple(c for c in ("mass_kg", "conversions") if c in names)
    values = read_clean(path, PLAN_COLUMNS + optional, what)
    n = values["fx_N"].size
    if n == 0:
        raise TableError(f"{what}: no holds; make one with `sail plan-calibration`")
    force = np.hypot(values["fx_N"], values["fy_N"])
    if np.any(force <= 0):
        raise TableError(f"{what}: hold {int(np.argmin(force)) + 1} has no force; every hold hangs a weight")
    mass = values.get("mass_kg", force / STANDARD_GRAVITY)
    conversions = values.get("conversions", np.full(n, DEFAULT_CONVERSIONS))
    if np.any(conversions < 1) or np.any(conversions != np.round(conversions)):
        raise TableError(f"{what}: the conversions column must hold whole numbers of 1 or more")
    extra: dict = {}
    summary = path.with_name("plan.json")
    if summary.is_file():
        try:
            info = json.loads(summary.read_text(encoding="utf-8"))
            model = str(info["model"])
            parameters = [str(p) for p in info.get("parameters", [])]
            extra["model"] = model
            if model == "physics":
                extra["free"] = tuple(parameters[4:]) or None
            elif parameters:
                extra["order"] = (len(parameters) - 2) // 4 - 1
            extra["adc"] = info.get("adc")
            low, high = info.get("delta_range_deg", (30.0, 120.0))
            extra["delta_range"] = (math.radians(float(low)), math.radians(float(high)))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise TableError(f"{summary}: not the plan.json that `sail plan-calibration` writes ({exc})") from None
    predicted = path.with_name("predicted.csv")
    if predicted.is_file():
        table = read_clean(predicted, ("delta_deg", "plan_worst_N", "plan_rms_N"), f"the plan's {predicted.name}")
        extra["planned"] = ErrorMap(np.radians(table["delta_deg"]), table["plan_worst_N"], table["plan_rms_N"], math.nan)
    return GuidePlan(np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"]), values["fx_N"], values["fy_N"],
                     np.asarray(mass, float), conversions.astype(int), source=str(path), **extra)  # fmt: skip


@dataclass
class _Hold:
    """One hold's rows as they came: time [s], angles [rad], loads, and its noise."""

    t: list[np.ndarray] = field(default_factory=list)
    theta: list[np.ndarray] = field(default_factory=list)
    loads: list[np.ndarray] = field(default_factory=list)
    force: list[np.ndarray] = field(default_factory=list)

    def add(self, t, theta, loads, force) -> None:
        self.t.append(t)
        self.theta.append(theta)
        self.loads.append(loads)
        self.force.append(force)

    def arrays(self):
        if not self.t:
            return np.empty(0), np.empty((0, 2)), np.empty((0, 2)), np.empty((0, 2))
        return (np.concatenate(self.t), np.concatenate(self.theta), np.concatenate(self.loads), np.concatenate(self.force))


@dataclass(frozen=True)
class GuideResult:
    """What the guided calibration made: its files, the fit's numbers, and the planned and achieved maps."""

    recording: Path
    calibration: Path
    achieved_csv: Path
    fit_rmse_N: float
    cv_rmse_N: float
    holds: int
    skipped: int
    achieved: ErrorMap
    planned: ErrorMap | None


class Guide:
    """The guided calibration's state: a pipeline listener; see the module docstring.  Thread-safe.

    ``tare(samples)`` starts a tare (the pipeline's, a future of its result); ``record_dir`` is where the
    recording, the calibration and the achieved map go.
    """

    def __init__(self, plan: GuidePlan, robot: Robot, record_dir: Path, tare: Callable[[int], Future], *,
                 adc: ADC | None = None, clock: Callable[[], float] = time.monotonic) -> None:  # fmt: skip
        self.plan = plan
        self.robot = robot
        self.record_dir = Path(record_dir)
        self._tare = tare
        self.adc = adc if adc is not None else adc_model(plan.adc) if plan.adc else robot.adc
        self.settle_s = self.adc.settling_s + STILL_S
        self.record_s = np.array([c * self.adc.period_s if not self.adc.ideal else 0.0 for c in plan.conversions], float)
        self.record_s = np.maximum(self.record_s, 0.1)  # an ideal ADC converts every row: 0.1 s of them
        self._lock = threading.Lock()
        self.index = 0
        self.phase = "tare"
        self.done: list[int] = []  #: the holds recorded, in order
        self.skipped: list[int] = []
        self.records: dict[int, _Hold] = {}
        self._window = _Hold()
        self._since = math.nan  #: when the current settle (or settle and record) window began [s of the stream]
        self._record_since = math.nan  #: when the record window began
        self.message = "remove every weight and let go of the handle: the offsets are measured first"
        self.result: GuideResult | None = None
        self.error: str | None = None
        self._clock = clock
        self._tare_future: Future | None = None
        self.tared: tuple[float, float] | None = None  #: the offsets the first step measured (None: skipped, failed)

    # -- what the page shows ----------------------------------------------------------------------
    def info(self) -> dict:
        """The guide's state for the page, JSON-ready."""
        with self._lock:
            k = min(self.index, len(self.plan) - 1)
            p = self.plan
            theta1, theta2 = float(p.theta1[k]), float(p.theta2[k])
            joints = joint_positions(self.robot.arm, theta1, theta2)
            direction = math.degrees(math.atan2(p.fy[k], p.fx[k])) % 360.0
            elapsed = None
            if self.phase in ("settle", "record") and self._window.t:
                span = self.settle_s if self.phase == "settle" else float(self.record_s[k])
                elapsed = min(1.0, (float(self._window.t[-1][-1]) - self._since) / span)
            info = {"phase": self.phase, "hold": k + 1, "holds": len(p), "recorded": len(self.done),
                    "skipped": len(self.skipped), "message": self.message, "progress": elapsed,
                    "target": {"theta1_deg": math.degrees(theta1), "theta2_deg": math.degrees(theta2),
                               "fx_N": float(p.fx[k]), "fy_N": float(p.fy[k]), "mass_kg": float(p.mass_kg[k]),
                               "direction_deg": direction,
                               "joints": {"B": [0.0, 0.0]} | {n: [float(v) for v in joints[n]] for n in ("P1", "P2", "P3", "A")}},
                    "tared": None if self.tared is None else list(self.tared), "error": self.error, "result": None}  # fmt: skip
            if self.result is not None:
                r = self.result
                info["result"] = {"recording": r.recording.name, "calibration": r.calibration.name,
                                  "achieved": r.achieved_csv.name, "fit_rmse_N": r.fit_rmse_N, "cv_rmse_N": r.cv_rmse_N,
                                  "holds": r.holds, "skipped": r.skipped,
                                  "map": {"delta_deg": [float(d) for d in np.degrees(r.achieved.delta)],
                                          "achieved_N": [float(v) for v in r.achieved.worst_N],
                                          "planned_N": None if r.planned is None else [float(v) for v in r.planned.worst_N]}}  # fmt: skip
            return info

    def want(self) -> tuple[str, int, float, float, float, float]:
        """The phase, the hold's index, its pose [rad] and force [N]: what a simulated rig does next."""
        with self._lock:
            k = min(self.index, len(self.plan) - 1)
            p = self.plan
            return self.phase, k, float(p.theta1[k]), float(p.theta2[k]), float(p.fx[k]), float(p.fy[k])

    # -- the page's commands ----------------------------------------------------------------------
    def skip(self) -> dict:
        """Go on without the current hold (or the tare)."""
        with self._lock:
            if self.phase in ("fitting", "done", "failed"):
                raise CommandError("the guided calibration has ended: there is nothing to skip")
            if self.phase in ("tare", "taring"):
                self._start_hold(0, "tare skipped: the offsets stay as they are")
                return {"skipped": "tare"}
            skipped = self.index + 1
            self.skipped.append(self.index)
            self._next(f"hold {skipped} skipped")
        return {"skipped": skipped}

    def redo(self) -> dict:
        """Make the last recorded hold again (its rows are dropped)."""
        with self._lock:
            if self.phase in ("fitting", "done"):
                raise CommandError("the guided calibration has ended: there is nothing to redo")
            if not self.done:
                raise CommandError("no hold has been recorded yet: there is nothing to redo")
            last = self.done.pop()
            self.records.pop(last, None)
            self.error = None
            self._start_hold(last, f"redo hold {last + 1}")
        return {"redo": last + 1}

    # -- the rows ---------------------------------------------------------------------------------
    def __call__(self, rows: Rows) -> None:
        if not len(rows):
            return
        values = rows.values
        t = values["t_s"] if "t_s" in values else rows.stamps
        theta = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
        loads = np.column_stack([values["load1"], values["load2"]])
        force = np.column_stack([rows.columns["fx_N"], rows.columns["fy_N"]])
        finished = False
        with self._lock:
            for i in range(len(rows)):
                finished |= self._row(float(t[i]), theta[i], loads[i], force[i])
        if finished:
            threading.Thread(target=self._finish, name="sail-guide-fit", daemon=True).start()

    def _row(self, t: float, theta: np.ndarray, loads: np.ndarray, force: np.ndarray) -> bool:
        """One row through the phases; True when it completed the last hold."""
        if self.phase in ("taring", "fitting", "done", "failed"):
            if self.phase == "taring" and self._tare_future is not None and self._tare_future.done():
                self._tared()
            return False
        if not (np.all(np.isfinite(loads)) and np.all(np.isfinite(theta)) and math.isfinite(t)):
            return False  # an invalid row (the estimate flags it) neither starts nor breaks a window
        if self.phase == "tare":
            return self._tare_row(t, theta, loads, force)
        k = self.index
        target = np.array([self.plan.theta1[k], self.plan.theta2[k]])
        at_pose = bool(np.all(np.abs(np.degrees(theta - target)) <= POSE_TOL_DEG))
        wanted = np.array([self.plan.fx[k], self.plan.fy[k]])
        loaded = bool(np.all(np.isfinite(force)) and np.hypot(*(force - wanted)) <= LOAD_MATCH * np.hypot(*wanted))
        mass, direction = self.plan.mass_kg[k], math.degrees(math.atan2(wanted[1], wanted[0])) % 360.0
        if not at_pose:
            self._phase("move", f"hold {k + 1}: move the arm to theta1 = {math.degrees(target[0]):.1f} deg, "
                                f"theta2 = {math.degrees(target[1]):.1f} deg")  # fmt: skip
            return False
        if not loaded:
            self._phase("hang", f"hold {k + 1}: at the pose; hang {mass:g} kg over the pulley toward {direction:.0f} deg "
                                f"({np.hypot(*wanted):.2f} N), and nothing else")  # fmt: skip
            return False
        if self.phase in ("move", "hang"):
            self._phase("settle", f"hold {k + 1}: {mass:g} kg on; wait for it to settle, hands off")
            self._begin(t)
        self._window.add(np.array([t]), theta[None], loads[None], force[None])
        elapsed = t - self._since
        if self.phase == "settle" and elapsed >= self.settle_s:
            if self._still(wanted):
                self._phase("record", f"hold {k + 1}: recording, keep still")
                self._record_since = t
            else:
                self._begin(t)  # not still yet: a fresh window
        elif self.phase == "record" and t - self._record_since >= self.record_s[k]:
            if not self._still(wanted):
                self._phase("settle", f"hold {k + 1}: it moved while recording; settling again")
                self._begin(t)
                return False
            self.records[k] = self._window
            self.done.append(k)
            return self._next(f"hold {k + 1} recorded")
        return False

    def _tare_row(self, t, theta, loads, force) -> bool:
        if not self._window.t:
            self._begin(t)
        self._window.add(np.array([t]), theta[None], loads[None], force[None])
        if t - self._since >= self.settle_s:
            _, th, ld, _ = self._window.arrays()
            still_angles = bool(np.all(np.ptp(np.degrees(th), axis=0) <= STILL_DEG))
            if still_angles:
                samples = max(MIN_TARE_SAMPLES, int(np.ceil(ld.shape[0] * self.record_s[0] / self.settle_s)))
                self.phase, self.message = "taring", f"measuring the offsets on {samples} samples: hands off"
                self._tare_future = self._tare(samples)
            else:
                self._begin(t)
        return False

    def _tared(self) -> None:
        future, self._tare_future = self._tare_future, None
        try:
            result = future.result()  # type: ignore[union-attr]
            self.tared = (float(result.offsets[0]), float(result.offsets[1]))
            note = f"tared: offsets {result.offsets[0]:.7g}, {result.offsets[1]:.7g}"
        except Exception as exc:  # the tare failed (too few samples, noisy): the page says why, the guide goes on
            note = f"the tare failed ({exc}); the offsets stay as they are"
        self._start_hold(0, note)

    def _still(self, wanted: np.ndarray) -> bool:
        _, theta, _, force = self._window.arrays()
        bound = max(STILL_SD_N, STILL_FRACTION * float(np.hypot(*wanted)))
        return bool(np.all(np.std(force, axis=0) <= bound) and np.all(np.ptp(np.degrees(theta), axis=0) <= STILL_DEG))

    def _begin(self, t: float) -> None:
        self._window, self._since = _Hold(), t

    def _phase(self, phase: str, message: str) -> None:
        if phase != self.phase or message != self.message:
            self.phase, self.message = phase, message
        if phase in ("move", "hang"):
            self._window = _Hold()

    def _start_hold(self, index: int, note: str) -> None:
        self.index, self.phase, self._window = index, "move", _Hold()
        self.message = note

    def _next(self, note: str) -> bool:
        left = [k for k in range(len(self.plan)) if k not in self.done and k not in self.skipped]
        if not left:
            self.phase, self.message = "fitting", f"{note}; every hold made: fitting the calibration"
            return True
        self._start_hold(left[0], f"{note}; next: hold {left[0] + 1}")
        return False

    # -- the end ----------------------------------------------------------------------------------
    def _finish(self) -> None:
        try:
            result = self.fit()
        except (SailError, OSError, ValueError) as exc:
            with self._lock:
                self.phase, self.error = "failed", f"the calibration could not be fitted: {exc}"
                self.message = self.error + " (redo a hold, or fit the recording with `sail calibrate`)"
            log.warning("guided calibration: %s", exc)
            return
        with self._lock:
            self.result, self.phase = result, "done"
            self.message = (f"calibrated from {result.holds} holds: fit {1e3 * result.fit_rmse_N:.1f} mN RMS; wrote "
                            f"{result.recording.name}, {result.calibration.name} and {result.achieved_csv.name}")  # fmt: skip

    def fit(self) -> GuideResult:
        """Write the recording, fit and save the calibration, and compute the achieved map (module docstring)."""
        from ..workflows import calibration_run

        with self._lock:
            holds = [(k, self.records[k]) for k in sorted(self.records)]
            skipped = len(self.skipped)
        if not holds:
            raise InputError("no hold was recorded")
        table, samples, poses, sigma = [], [], [], []
        for k, hold in holds:
            t, theta, loads, _ = hold.arrays()
            pose = theta.mean(axis=0)
            poses.append(pose)
            sigma.append(float(np.sqrt(np.mean(np.var(loads, axis=0, ddof=1)) / loads.shape[0])))
            columns = [np.full(t.size, k + 1), t, np.full(t.size, math.degrees(pose[0])), np.full(t.size, math.degrees(pose[1])),
                       loads, np.full(t.size, self.plan.fx[k]), np.full(t.size, self.plan.fy[k])]  # fmt: skip
            table.append(np.column_stack(columns))
            blocks = min(int(self.plan.conversions[k]), t.size)  # one sample per conversion the plan asked for
            samples.append(np.array([part.mean(axis=0) for part in np.array_split(table[-1], blocks)]))
        rows = np.concatenate(table)
        stem = "guided-" + time.strftime("%Y%m%d-%H%M%S")
        recording = self._fresh(stem, ".csv")
        write_numeric_table(recording, RECORDING_COLUMNS, rows, csv_format="%.10g")
        fitted = np.concatenate(samples)
        readings = {name: fitted[:, i] for i, name in enumerate(RECORDING_COLUMNS)}
        run = calibration_run(readings, robot=self.robot, model=self.plan.model, free=self.plan.free, adc=adc_model("ideal"))
        calibration = self._fresh(stem, ".json")
        run.calibration.save(calibration)
        index = [k for k, _ in holds]
        linear = linearise(self.robot, self.plan.model, free=self.plan.free, order=self.plan.order,
                           delta_range=self.plan.delta_range)  # fmt: skip
        pose = np.array(poses)
        made = Candidates(pose[:, 0], pose[:, 1], self.plan.fx[index], self.plan.fy[index], self.plan.mass_kg[index],
                          np.maximum(np.array(sigma), 1e-12))  # fmt: skip
        achieved = predicted_map(linear, made)
        planned = self.plan.planned
        if planned is None or planned.delta.size != achieved.delta.size:
            noise = reading_noise(linear.robot, self.adc if not self.adc.ideal else adc_model("hx711-10"))
            planned_holds = Candidates(self.plan.theta1, self.plan.theta2, self.plan.fx, self.plan.fy, self.plan.mass_kg,
                                       noise * np.sqrt(DEFAULT_CONVERSIONS / self.plan.conversions))  # fmt: skip
            planned = predicted_map(linear, planned_holds, achieved.force_N)
        achieved_csv = self._fresh(stem + "-achieved", ".csv")
        write_numeric_table(achieved_csv, ("delta_deg", "achieved_worst_N", "achieved_rms_N", "planned_worst_N"),
                            np.column_stack([np.degrees(map_deltas()), achieved.worst_N, achieved.rms_N, planned.worst_N]),
                            csv_format="%.8g")  # fmt: skip
        write_json(calibration.with_suffix(".guide.json"), {
            "plan": self.plan.source, "holds": len(holds), "skipped": skipped, "recording": recording.name,
            "fit_rmse_N": run.fit.fit_rmse_N, "cv_rmse_N": run.fit.cv_rmse_N, "force_N": achieved.force_N,
            "achieved_worst_N": float(achieved.worst_N.max()), "planned_worst_N": float(planned.worst_N.max())})  # fmt: skip
        return GuideResult(recording, calibration, achieved_csv, float(run.fit.fit_rmse_N), float(run.fit.cv_rmse_N),
                           len(holds), skipped, achieved, planned)  # fmt: skip

    def _fresh(self, stem: str, suffix: str) -> Path:
        path, handle = fresh_file(self.record_dir, stem, suffix)
        os.close(handle)
        return path
