"""Shared test vectors for libsail, made by the Python toolkit.

Usage: ``python c/tests/make_vectors.py OUTDIR``

For each model kind that ``sail calibrate`` produces (matrix, seed) it:

1. synthesizes a pulley-and-weights session on a spring-jointed arm
   (:func:`sailforce.synthetic.calibration_session`) and writes it as CSV;
2. runs ``sail calibrate --model KIND`` and ``sail export-c`` on it, giving
   ``cal_KIND.json`` and ``cal_KIND.h`` (constant ``sail_cal_KIND``);
3. writes ``vectors_KIND.csv``: readings and what
   :meth:`sailforce.calibration.file.Calibration.estimate` returns for them, covering
   every status, status precedence, and NaN and infinite fields.

For the dynamic term it runs a simulated rig's static and free-motion
sessions (``sail simulate-motion``, 1 kg handle, 3 deg tilt) through ``sail
calibrate --free-motion`` and ``sail export-c --sample-rate-hz 1000``
(``cal_motion.h``, ``sail_cal_motion`` and ``sail_cal_motion_dynamics``),
and writes ``motion.csv``: a task session with a gap, a step back in time,
an invalid angle, an invalid load and saturated readings, and what
:func:`sailforce.estimate.dynamic.estimate_moving` returns for each row.

For real ADCs it records a simulated rig with HX711s at 80 SPS (holds, free
motion, a task; :mod:`sailforce.motion.multirate`), calibrates it
(``sailforce.calibrate(..., adc=...)``), exports ``cal_multirate.h``
(``sail_cal_multirate``, ``_dynamics`` and ``_adc``) and writes
``multirate.csv``: the task's ticks with a gap, an invalid angle on a tick
with a conversion, a saturated conversion and the conversions' data-ready
times, and what :class:`sailforce.estimate.multirate.MultiRateEstimator`
returns for each row (rates from the same Savitzky-Golay tracker as the
stream).  ``multirate_static.csv`` is the same without the dynamic term, and
``multirate_sinc3.csv`` a session of sinc^3 conversions at 320 SPS (NAU7802)
on the same map (``cal_sinc3.h``).

``rezero.csv`` and ``rezero_contact.csv`` run a drifting, held and
released session through :class:`sailforce.estimate.rezero.ReZero`, without
and with a contact sensor, for ``sail_rezero_step``.

``temperature.csv`` holds readings at temperatures and the estimate after
:meth:`sailforce.drift.TemperatureCompensation.corrected`, for
``sail_temperature_correct`` (``cal_temperature.h``).

``frames.csv`` holds ticks and their bytes on the wire from
:func:`sailforce.io.frames.encode_tick` (and a hello), for the sketch's frame
encoder (``c/tests/test_acq.c``).

It also writes ``lowpass.csv``, a reading sequence with invalid rows and the
loads :class:`sailforce.estimate.filters.LowPass` makes of it, for the filter exported
with the matrix calibration (``sail_cal_matrix_lowpass``).

Readings keep clear of every status threshold (relative margins of 1e-3 or
more), so that a float build, whose inputs are rounded to 24 bits, must give
the same statuses; offset-free loads are at least 5 % of capacity, so forces
compare norm-wise (|dF| <= rtol |F|).
"""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from sailforce.calibration.file import Calibration
from sailforce.estimate.estimator import DELTA_RANGE_SLACK
from sailforce.estimate.filters import LowPass
from sailforce.robot import Robot
from sailforce.statics import SINGULAR_SIN_DELTA
from sailforce.synthetic import calibration_session

KINDS = ("matrix", "seed")
LOWPASS = {"cutoff_hz": 5.0, "sample_rate_hz": 100.0, "order": 4}
N_REGULAR = 400


def _sail(*args: str) -> None:
    _sail_together(list(args))


def _sail_together(*commands: list[str]) -> None:
    """``sail`` commands that need none of each other's files, in processes side by side (each start is a third of a
    second of imports: ten in a row were 7 s of ``make c-test``'s 13)."""
    processes = [subprocess.Popen([sys.executable, "-m", "sailforce.cli", *args], stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True) for args in commands]  # fmt: skip
    failed = []
    for args, process in zip(commands, processes):
        out, _ = process.communicate()
        if process.returncode != 0:
            failed.append((args, out))
    if failed:
        sys.exit("\n".join(f"sail {' '.join(args)} failed:\n{out}" for args, out in failed))


def _write_csv(path: Path, header: list[str], rows: np.ndarray) -> None:
    with open(path, "w", encoding="utf-8") as out:
        out.write(",".join(header) + "\n")
        for row in rows:
            out.write(",".join(repr(float(v)) for v in row) + "\n")


def _readings(cal: Calibration, rng: np.random.Generator) -> np.ndarray:
    """``(n, 4)`` readings (theta1, theta2, load1, load2): every status, clear of the thresholds."""
    lo, hi = cal.delta_range
    offsets, capacity = np.asarray(cal.offsets), np.asarray(cal.capacity)

    def loads(n, low=0.05, high=0.9):  # offset-free magnitude as a fraction of capacity, random sign
        return offsets + rng.choice([-1.0, 1.0], (n, 2)) * rng.uniform(low, high, (n, 2)) * capacity

    def poses(delta):
        theta2 = rng.uniform(-1.0, 1.0, delta.size)
        return np.column_stack([theta2 + delta, theta2])

    margin = 1e-3
    inside = rng.uniform(lo + margin, hi - margin, N_REGULAR)
    below = rng.uniform(np.radians(2.5), lo - DELTA_RANGE_SLACK - margin, 40)  # extrapolated, not singular
    above = rng.uniform(hi + DELTA_RANGE_SLACK + margin, np.pi - np.radians(2.5), 40)
    negative = -rng.uniform(np.radians(5.0), np.radians(175.0), 20)  # the other assembly: extrapolated
    limit = np.arcsin(SINGULAR_SIN_DELTA) * (1.0 - 0.05)
    singular = np.concatenate([rng.uniform(-limit, limit, 20), np.pi + rng.uniform(-limit, limit, 10)])
    blocks = [
        np.column_stack([poses(inside), loads(N_REGULAR)]),
        np.column_stack([poses(np.concatenate([below, above, negative])), loads(100)]),
        np.column_stack([poses(singular), loads(30)]),
        np.column_stack([poses(inside[:30]), loads(30, 1.01, 1.5)]),  # saturated
        np.column_stack([poses(below[:10]), loads(10, 1.01, 1.5)]),  # saturated beats extrapolated
        np.column_stack([poses(singular[:10]), loads(10, 1.01, 1.5)]),  # singular beats saturated
    ]
    invalid = np.column_stack([poses(inside[:24]), loads(24)])
    for i, bad in enumerate((np.nan, np.inf, -np.inf)):
        for field in range(4):
            invalid[8 * i + 2 * field : 8 * i + 2 * field + 2, field] = bad
    invalid[-2:, 0] = 0.0  # invalid beats singular
    invalid[-2:, 1] = 0.0
    invalid[-2:, 2] = np.nan
    return np.vstack(blocks + [invalid])


def _lowpass_vectors(cal: Calibration, rng: np.random.Generator) -> np.ndarray:
    """Readings with steps, noise and invalid rows; the loads after the Python filter."""
    n = 600
    theta2 = rng.uniform(-0.5, 0.5, n)
    theta1 = theta2 + np.radians(90.0)
    step = np.where(np.arange(n) > n // 3, 0.4, -0.2)[:, None] * np.asarray(cal.capacity)
    load = np.asarray(cal.offsets) + step + rng.normal(0.0, 1e-3, (n, 2)) * np.asarray(cal.capacity)
    readings = np.column_stack([theta1, theta2, load])
    readings[[0, 1, 50, 51, 52, 300], [2, 0, 3, 1, 2, 3]] = [np.nan, np.inf, np.nan, -np.inf, np.nan, np.inf]
    valid = np.all(np.isfinite(readings), axis=1)
    filtered = LowPass(**LOWPASS).process(readings[:, 2:], valid)
    return np.column_stack([readings, filtered])


MOTION_RATE_HZ = 1000.0


def _motion_vectors(outdir: Path) -> None:
    """The rig's calibration with its dynamic term, and a task session's rows with Python's estimates."""
    (outdir / "rig.toml").write_text("[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[handle]\nmass = 1.0\n"
                                     "[plane]\ntilt_deg = 3\n")  # fmt: skip
    robot = ["--robot", str(outdir / "rig.toml")]
    _sail_together(*(["simulate-motion", "--session", session, *robot, *extra, "-o", str(outdir / f"rig_{session}.csv")]
                     for session, extra in (("static", []), ("free", []), ("task", ["--reaches", "4", "--seed", "9"]))))
    _sail("calibrate", str(outdir / "rig_static.csv"), *robot, "--model", "matrix", "--free-motion",
          str(outdir / "rig_free.csv"), "-o", str(outdir / "cal_motion.json"))  # fmt: skip
    _sail("export-c", str(outdir / "cal_motion.json"), "-o", str(outdir / "cal_motion.h"), "--name", "sail_cal_motion",
          "--sample-rate-hz", str(MOTION_RATE_HZ))  # fmt: skip
    from sailforce.estimate.dynamic import estimate_moving

    cal = Calibration.load(outdir / "cal_motion.json")
    task = np.genfromtxt(outdir / "rig_task.csv", delimiter=",", names=True)
    t = task["t_s"].copy()
    rows = np.column_stack([np.radians(task["theta1_deg"]), np.radians(task["theta2_deg"]), task["load1"], task["load2"]])
    step = 2 * np.pi / 65536  # the 16-bit encoders' angles, exact again after the CSV's 12 digits (libsail reads
    rows[:, :2] = np.round(rows[:, :2] / step) * step  # angles on a 2^24 grid: see SAIL_COUNTS_PER_TURN)
    t[1500:] += 0.02  # a gap of 20 samples
    t[2500:] -= 1.0 / MOTION_RATE_HZ  # a step that does not advance (the sampling stays uniform after it)
    rows[3000, 1] = np.nan  # an invalid angle cuts the window
    rows[3300, 2] = np.nan  # an invalid load does not
    rows[3400:3405, 3] = cal.offsets[1] + 1.2 * cal.capacity[1]  # saturated
    fx, fy, status, inertial = estimate_moving(cal, cal.dynamics, t, *rows.T, dt=1.0 / MOTION_RATE_HZ)
    _write_csv(outdir / "motion.csv", ["t", "theta1", "theta2", "load1", "load2", "fx", "fy", "status", "inertial1",
               "inertial2"], np.column_stack([t, rows, fx, fy, status, inertial]))  # fmt: skip


def _temperature_vectors(outdir: Path) -> None:
    """The matrix calibration with temperature coefficients (``cal_temperature.h``, ``sail_cal_temperature`` and
    ``_temperature``), and ``temperature.csv``: readings at 10..40 degC (one at a NaN temperature) with the loads
    :meth:`sailforce.drift.TemperatureCompensation.corrected` makes of them and the estimate on those, for
    ``sail_temperature_correct`` then ``sail_estimate``.  Loads and poses keep far from every status threshold."""
    from sailforce.drift import TemperatureCompensation
    from sailforce.export_c import calibration_header

    cal = replace(Calibration.load(outdir / "cal_matrix.json"),
                  temperature=TemperatureCompensation(24.0, (216.0, -217.0), (-4.5e-5, 5.5e-5)))  # fmt: skip
    (outdir / "cal_temperature.h").write_text(calibration_header(cal, "sail_cal_temperature"))
    rng = np.random.default_rng(13)
    n = 200
    lo, hi = cal.delta_range
    theta2 = rng.uniform(-0.5, 0.5, n)
    theta1 = theta2 + rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), n)
    loads = np.asarray(cal.offsets) + rng.uniform(-1e5, 1e5, (n, 2))
    celsius = rng.uniform(10.0, 40.0, n)
    celsius[7] = np.nan
    corrected = cal.temperature.corrected(loads, celsius, cal.offsets)
    fx, fy, status = cal.estimate(theta1, theta2, corrected[:, 0], corrected[:, 1])
    _write_csv(outdir / "temperature.csv", ["theta1", "theta2", "load1", "load2", "celsius", "fx", "fy", "status"],
               np.column_stack([theta1, theta2, loads, celsius, fx, fy, status]))  # fmt: skip


def _rezero_vectors(outdir: Path) -> None:
    """A still-ish arm under drift, held and let go, through :class:`sailforce.estimate.rezero.ReZero` on the motion
    calibration's static map: ``rezero.csv`` without a contact sensor (contact -1), ``rezero_contact.csv`` with one.

    4 minutes at 25 Hz: the offsets drift linearly (800 and -600 counts); a hand holds the handle with a tremor
    (0.3 N white), lets go for the last 10 s of every 40, once pushes steadily (2 N, no tremor, for 30 s: refused
    without the sensor), and there are invalid rows inside a release, a 1 s gap and rows with the contact unknown.
    """
    from sailforce.estimate.rezero import ReZero

    cal = Calibration.load(outdir / "cal_motion.json")
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 240.0, 0.04)
    t = t[(t < 200.0) | (t >= 201.0)]
    theta1 = np.radians(80.0 + 5.0 * np.sin(2 * np.pi * t / 40.0))
    theta2 = np.radians(10.0 + 3.0 * np.cos(2 * np.pi * t / 50.0))
    released = np.mod(t, 40.0) >= 30.0
    steady = (t >= 120.0) & (t < 150.0) & ~released
    true = np.where(released[:, None], 0.0, 3.0 + 0.3 * rng.normal(size=(t.size, 2)))
    true[steady] = [2.0, 0.0]
    drift = np.column_stack([800.0 * t / 240.0, -600.0 * t / 240.0])

    def force_of(a, b, c, d):
        return cal.estimate(a, b, c, d, static=True)[:2]

    dx, dy = force_of(theta1, theta2, cal.offsets[0] + drift[:, 0], cal.offsets[1] + drift[:, 1])
    fx = true[:, 0] + dx + 0.005 * rng.normal(size=t.size)
    fy = true[:, 1] + dy + 0.005 * rng.normal(size=t.size)
    status = np.zeros(t.size)
    bad = (t >= 35.0) & (t < 35.1)
    status[bad], fx[bad], fy[bad] = 4, np.nan, np.nan
    contact = np.where(released, 0.0, 1.0)
    contact[(t >= 75.0) & (t < 75.5)] = np.nan  # the sensor unknown: not free
    for name, sensor in (("rezero", None), ("rezero_contact", contact)):
        zero = ReZero(force_of, tuple(cal.offsets))
        out = zero.process(t, theta1, theta2, fx, fy, status, sensor)
        column = np.full(t.size, -1.0) if sensor is None else np.where(np.isnan(contact), 1.0, contact)
        _write_csv(outdir / f"{name}.csv", ["t", "theta1", "theta2", "fx", "fy", "status", "contact", "fx_out", "fy_out",
                   "begins"], np.column_stack([t, theta1, theta2, fx, fy, status, column, out["fx_N"], out["fy_N"],
                                               out["rezero"]]))  # fmt: skip


def _frame_vectors(outdir: Path) -> None:
    """Ticks and their bytes on the wire from :func:`sailforce.io.frames.encode_tick`, for the sketch's encoder.

    The fields reach the limits of their types (a wrapping sequence and clock, negative counts and loads, the
    24-bit limits), and some bytes are zero, so that COBS has runs to stuff.  The row with sequence 65535 and
    flags 255 is the hello frame, its counts per turn in the counts columns.
    """
    from sailforce.io.frames import Tick, encode_hello, encode_tick

    ticks = [
        Tick(0, 0, (0, 0), (False, False), (0, 0), (0, 0), 0),
        Tick(1, 1000, (1565, 134), (True, False), (200000, 0), (-437, 0), 0x01),
        Tick(2, 2000, (-1, -2048), (False, True), (0, -150000), (0, -999), 0x20),
        Tick(65534, 0xFFFFFC18, (2**31 - 1, -(2**31)), (True, True), (8388607, -8388608), (-1, -32768), 0x12),
        Tick(65535, 0xFFFFFFFF, (256, 65536), (True, True), (-1, 1), (-500, -250), 0xFF),
        Tick(0, 1000, (0x01000000, 0x00FF00FF), (False, False), (0, 0), (0, 0), 0x04),
        Tick(17, 123456789, (-123456, 654321), (True, False), (-123456, 0), (-32767, 0), 0x08),
        Tick(4660, 0x00010000, (0, 0), (False, True), (0, 0x00000100), (0, -256), 0),
    ]
    rows = [(t.sequence, t.time_us, *t.theta_counts, int(t.new[0]) | int(t.new[1]) << 1, *t.load, *t.ready_us,
             t.status, encode_tick(t).hex()) for t in ticks]  # fmt: skip
    rows.append((65535, 0, 8192, 2**24, 255, 0, 0, 0, 0, 0, encode_hello((8192, 2**24)).hex()))
    header = "sequence,time_us,counts1,counts2,fresh,load1,load2,ready1,ready2,status,frame"
    (outdir / "frames.csv").write_text(header + "\n" + "".join(",".join(map(str, row)) + "\n" for row in rows))


def _multirate_vectors(outdir: Path) -> None:
    """A multi-rate rig's calibration with its ADC, and a task session's ticks with Python's estimates."""
    from sailforce import Handle, Plane, calibrate
    from sailforce.adc import PRESETS
    from sailforce.estimate.multirate import MultiRateEstimator
    from sailforce.export_c import calibration_header
    from sailforce.motion.differentiate import derivatives
    from sailforce.motion.multirate import multirate_columns, record_holds, record_multirate
    from sailforce.synthetic import NoiseModel, session_offsets

    robot = Robot(handle=Handle(mass=1.0), plane=Plane(tilt_deg=3.0))
    adc = PRESETS["hx711-80"]
    offsets = session_offsets(robot, NoiseModel(), 1)
    t1, t2, fx, fy, _, _ = calibration_session(robot, seed=2, offsets=offsets)
    holds = record_holds(robot, adc, t1, t2, fx, fy, hold_s=0.5, offsets=offsets, seed=1)
    free = record_multirate(robot, adc, reaches=16, offsets=offsets, seed=3)

    cal = calibrate(multirate_columns(holds, ("fx_N", "fy_N")), robot=robot, model="matrix", adc=adc,
                    free_motion=multirate_columns(free))  # fmt: skip
    (outdir / "cal_multirate.h").write_text(calibration_header(cal, "sail_cal_multirate", sample_rate_hz=MOTION_RATE_HZ))
    task = record_multirate(robot, adc, reaches=4, hand_stiffness=100.0, offsets=offsets, seed=7)
    t, q, loads, ready = task.t.copy(), task.theta.copy(), task.loads.copy(), task.load_t.copy()
    t[2000:] += 0.02  # a gap of 20 ticks
    ready[2000:] += 0.02
    first = int(np.flatnonzero(np.isfinite(loads[2600:, 0]))[0]) + 2600
    q[first, 1] = np.nan  # an invalid angle on a tick with a conversion
    later = int(np.flatnonzero(np.isfinite(loads[3000:, 1]))[0]) + 3000
    loads[later, 1] = cal.offsets[1] + 1.3 * cal.capacity[1]  # a saturated conversion
    ready[3500:3800, 0] = np.nan  # conversions stamped with their tick only
    # a sinc^3 chip at 320 SPS (NAU7802) on the same map, without the dynamic term: the filter's other orders
    sinc3 = replace(cal, adc=PRESETS["nau7802-320"], adc_delay_s=0.0, dynamics=None)
    (outdir / "cal_sinc3.h").write_text(calibration_header(sinc3, "sail_cal_sinc3", sample_rate_hz=MOTION_RATE_HZ))
    other = record_multirate(robot, sinc3.adc, reaches=2, hand_stiffness=100.0, offsets=offsets, seed=8)
    other.theta[1000, 0] = np.nan  # an invalid angle
    saturated = int(np.flatnonzero(np.isfinite(other.loads[1500:, 0]))[0]) + 1500
    other.loads[saturated, 0] = cal.offsets[0] - 1.3 * cal.capacity[0]  # a saturated conversion
    sets = [("multirate", cal, True, (t, q, loads, ready)), ("multirate_static", cal, False, (t, q, loads, ready)),
            ("multirate_sinc3", sinc3, False, (other.t, other.theta, other.loads, other.load_t))]
    for name, c_cal, dynamic, (t, q, loads, ready) in sets:
        estimator = MultiRateEstimator(c_cal, dynamic=dynamic)
        rate = accel = None
        if dynamic:
            rate, accel = derivatives(t, q, c_cal.dynamics.differentiator, dt=1.0 / MOTION_RATE_HZ)
        out = estimator.rows(t, q, loads, ready, np.zeros(t.size, bool), rate, accel)
        c = out.columns
        broken = np.where(np.isfinite(t) & np.all(np.isfinite(q), axis=1), 0.0, np.nan)  # libsail: 0 without the term
        inertial = (c["inertial1"], c["inertial2"]) if dynamic else (broken, broken)
        _write_csv(outdir / f"{name}.csv", ["t", "theta1", "theta2", "load1", "load2", "ready1", "ready2", "fx", "fy",
                   "status", "inertial1", "inertial2", "force_t"],
                   np.column_stack([t, q, loads, ready, c["fx_N"], c["fy_N"], out.status, *inertial, c["force_t_s"]]))  # fmt: skip


def main(outdir: Path) -> None:
    outdir.mkdir(parents=True, exist_ok=True)
    robot = Robot().with_joints("spring")  # moment-carrying joints: a delta-dependent map
    t1, t2, fx, fy, counts, _ = calibration_session(robot, seed=11)
    session = outdir / "session.csv"
    _write_csv(session, ["theta1_deg", "theta2_deg", "load1", "load2", "fx_N", "fy_N"],
               np.column_stack([np.degrees(t1), np.degrees(t2), counts, fx, fy]))  # fmt: skip
    rng = np.random.default_rng(5)
    lowpass = ["--lowpass-hz", str(LOWPASS["cutoff_hz"]), "--sample-rate-hz", str(LOWPASS["sample_rate_hz"]),
               "--lowpass-order", str(LOWPASS["order"])]  # fmt: skip
    _sail_together(*(["calibrate", str(session), "-o", str(outdir / f"cal_{kind}.json"), "--model", kind] for kind in KINDS))
    _sail_together(*(["export-c", str(outdir / f"cal_{kind}.json"), "-o", str(outdir / f"cal_{kind}.h"), "--name",
                      f"sail_cal_{kind}", *(lowpass if kind == "matrix" else [])] for kind in KINDS))  # fmt: skip
    for kind in KINDS:
        cal = Calibration.load(outdir / f"cal_{kind}.json")
        readings = _readings(cal, rng)
        fx_hat, fy_hat, status = cal.estimate(*readings.T)
        _write_csv(outdir / f"vectors_{kind}.csv", ["theta1", "theta2", "load1", "load2", "fx", "fy", "status"],
                   np.column_stack([readings, fx_hat, fy_hat, status]))  # fmt: skip
        if kind == "matrix":
            _write_csv(outdir / "lowpass.csv", ["theta1", "theta2", "load1", "load2", "out1", "out2"],
                       _lowpass_vectors(cal, rng))  # fmt: skip
    _motion_vectors(outdir)
    _multirate_vectors(outdir)
    _frame_vectors(outdir)
    _rezero_vectors(outdir)
    _temperature_vectors(outdir)
    print(f"wrote libsail test vectors to {outdir}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: make_vectors.py OUTDIR")
    main(Path(sys.argv[1]))
