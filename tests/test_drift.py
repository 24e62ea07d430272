"""Drift over a session (sailforce.drift, sailforce.motion.session) and the automatic re-zero (sailforce.estimate.rezero).

The drift terms against their closed forms; a simulated 30-minute therapy session with drift and a release of the
handle every minute, estimated with the re-zero and without, side by side with the same session drift-free; and each
refusal the re-zero must make.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce.calibration.file import Calibration
from sailforce.cli import cli
from sailforce.drift import CREEP_SPAN_S, HX711_COUNTS_PER_V, Drift, TemperatureProfile, creep_lag, drifted
from sailforce.estimate.dynamic import estimate_moving
from sailforce.estimate.rezero import ReZero, ReZeroPolicy
from sailforce.motion.session import release_mask, therapy_session
from sailforce.robot import Robot
from sailforce.synthetic import NoiseModel, session_offsets

RATE_HZ = 500.0  #: the sessions' sampling: drift is slow, and half the rows of 1 kHz keep the test short
#: The issue's target: with the re-zero, the force error within 1.5 x a drift-free session's.
TARGET_RATIO = 1.5


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


# ---- the drift terms ---------------------------------------------------------------------------------------------


def test_creep_reaches_its_datasheet_fraction_in_30_minutes_and_recovers():
    drift = Drift(creep=5e-4, creep_time_s=600.0)
    t = np.arange(0.0, 3600.0, 0.05)
    load = np.where(t[:, None] < CREEP_SPAN_S, 1e5, 0.0) * np.ones((1, 2))
    c = creep_lag(t, load, drift)
    at_30 = np.searchsorted(t, CREEP_SPAN_S) - 1
    assert c[at_30, 0] == pytest.approx(5e-4 * 1e5, rel=1e-3)  # the datasheet's "creep (30 min)"
    # unloaded: an exponential decay with the creep's time constant
    later = np.searchsorted(t, CREEP_SPAN_S + 600.0) - 1
    assert c[later, 0] / c[at_30, 0] == pytest.approx(np.exp(-(t[later] - t[at_30]) / 600.0), rel=1e-3)
    # uneven steps take the row-by-row recursion, to the same result
    jittered = t + np.random.default_rng(1).uniform(0, 1e-3, t.size)
    assert creep_lag(jittered, load, drift)[at_30, 0] == pytest.approx(c[at_30, 0], rel=2e-3)


def test_zero_and_span_drift_follow_the_temperature_linearly():
    drift = Drift(zero_per_C=5e-5, span_per_C=5e-5, adc_offset_V_per_C=6e-9, adc_gain_per_C=5e-6, creep=0.0,
                  warmup=0.0)  # fmt: skip
    rated = 4.3e6
    t = np.linspace(0.0, 100.0, 11)
    temperature = 20.0 + 0.5 * t / 10.0  # +5 degC over the span
    signal = np.full((t.size, 2), 2e5)
    signs = np.array([[1.0, 1.0, 1.0], [-1.0, -1.0, 1.0]])
    d = drifted(t, signal, temperature, drift, rated, signs)
    dT = temperature - 20.0
    zero = 5e-5 * rated + 6e-9 * HX711_COUNTS_PER_V
    assert d[:, 0] == pytest.approx(zero * dT + (5e-5 + 5e-6) * dT * 2e5, rel=1e-12)
    assert d[:, 1] == pytest.approx(-zero * dT + (-5e-5 + 5e-6) * dT * 2e5, rel=1e-12)
    assert Drift.none() == Drift(0.0, 0.0, 0.0, 0.0, 0.0, 600.0, 0.0, 600.0)
    assert not np.any(drifted(t, signal, temperature, Drift.none(), rated, signs))


def test_the_temperature_profile_warms_up_then_follows_the_room():
    p = TemperatureProfile(start_C=21.0, rise_C=4.0, rise_time_s=900.0, ramp_C_per_h=1.0)
    assert p.at(0.0) == 21.0
    assert p.at(900.0) == pytest.approx(21.0 + 4.0 * (1 - np.exp(-1.0)) + 0.25)
    assert p.at(36_000.0) == pytest.approx(21.0 + 4.0 + 10.0, rel=1e-6)


def test_releases_are_the_end_of_each_period():
    t = np.arange(0.0, 180.0, 0.5)
    free = release_mask(t, 60.0, 10.0)
    assert np.array_equal(free, np.mod(t, 60.0) >= 50.0) and free.sum() == 3 * 20
    assert not release_mask(t, 60.0, 0.0).any()


# ---- a 30-minute session ---------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cal(tmp_path_factory):
    """The rig's calibration with its dynamic term (static poses, and free motion at RATE_HZ), as a lab makes it."""
    d = tmp_path_factory.mktemp("drift")
    assert run("simulate-motion", "--session", "static", "-o", d / "static.csv").exit_code == 0
    assert run("simulate-motion", "--session", "free", "--sample-rate-hz", RATE_HZ, "-o", d / "free.csv").exit_code == 0
    assert run("calibrate", d / "static.csv", "--free-motion", d / "free.csv", "-o", d / "cal.json").exit_code == 0
    return Calibration.load(d / "cal.json")


def _force_of(cal):
    return lambda theta1, theta2, load1, load2: cal.estimate(theta1, theta2, load1, load2, static=True)[:2]


def _session(drift: Drift):
    robot = Robot()
    return therapy_session(robot, minutes=30.0, drift=drift, sample_rate_hz=RATE_HZ, seed=3, rig=1,
                           offsets=session_offsets(robot, NoiseModel(), 1))  # fmt: skip


def _rms(fx, fy, status, truth) -> float:
    ok = status == 0
    return float(np.sqrt(np.mean((fx[ok] - truth[ok, 0]) ** 2 + (fy[ok] - truth[ok, 1]) ** 2)))


def test_a_30_minute_session_re_zeroed_is_within_1_5x_of_a_drift_free_one(cal):
    clean, drifting = _session(Drift.none()), _session(Drift())
    errors, events = {}, {}
    for name, s in (("drift-free", clean), ("drift", drifting)):
        r = s.recording
        fx, fy, status, _ = estimate_moving(cal, cal.dynamics, r.t, *r.theta.T, *r.loads.T, dt=1.0 / RATE_HZ)
        errors[name] = _rms(fx, fy, status, r.force)
        if name == "drift":
            for contact in (None, s.contact):
                zero = ReZero(_force_of(cal), tuple(cal.offsets))
                out = zero.process(r.t, *r.theta.T, fx, fy, status, contact)
                key = "re-zero" if contact is None else "re-zero, contact column"
                errors[key], events[key] = _rms(out["fx_N"], out["fy_N"], status, r.force), zero.events
                assert out["rezero"].sum() == sum(e.applied for e in zero.events)
    print("force error rms [N]:", {k: round(v, 4) for k, v in errors.items()})
    assert np.abs(drifting.drift_counts).max() > 1500  # the drift is real: a quarter newton in each cell
    assert errors["drift"] > 2.5 * errors["drift-free"]  # and it matters...
    for key in ("re-zero", "re-zero, contact column"):
        assert errors[key] <= TARGET_RATIO * errors["drift-free"], errors  # ...until the re-zero follows it
        made = [e for e in events[key] if e.applied]
        assert len(made) >= 20 and not any(not e.applied for e in events[key])  # about one per release
        # every window that re-zeroed lay in a release: nobody held the handle then
        window = ReZeroPolicy().window_s
        assert all(np.mod(e.t_s - window, 60.0) >= 50.0 - 1e-9 and np.mod(e.t_s, 60.0) <= 60.0 for e in made)


def _held_still(cal, push_N: float, tremor_N: float = 0.0, seconds: float = 30.0):
    """A still arm, a hand pushing steadily with ``push_N`` along x: (t, theta, fx, fy, status)."""
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    theta = np.tile([np.radians(80.0), np.radians(10.0)], (t.size, 1))
    rng = np.random.default_rng(4)
    fx = push_N + tremor_N * rng.normal(size=t.size)
    fy = 0.002 * rng.normal(size=t.size)
    return t, theta, fx, fy, np.zeros(t.size, np.int8)


def test_a_steady_push_is_refused_and_a_contact_blocks_every_decision(cal):
    t, theta, fx, fy, status = _held_still(cal, push_N=3.0)
    zero = ReZero(_force_of(cal), tuple(cal.offsets))
    out = zero.process(t, *theta.T, fx, fy, status)
    assert [e.applied for e in zero.events] == [False]  # logged once for the quiet stretch, not every window
    assert "steady hand" in zero.events[0].reason and not np.any(zero.delta) and not out["rezero"].any()
    assert np.array_equal(out["fx_N"], fx)
    # a small, quiet residual would be re-zeroed, but the contact switch says a hand is there
    t, theta, fx, fy, status = _held_still(cal, push_N=0.2)
    zero = ReZero(_force_of(cal), tuple(cal.offsets))
    zero.process(t, *theta.T, fx, fy, status, np.ones(t.size))
    assert zero.events == [] and not np.any(zero.delta)
    # a hand's tremor is never quiet
    t, theta, fx, fy, status = _held_still(cal, push_N=0.2, tremor_N=0.3)
    zero = ReZero(_force_of(cal), tuple(cal.offsets))
    zero.process(t, *theta.T, fx, fy, status)
    assert zero.events == []


def test_a_free_handle_is_re_zeroed_exactly_and_a_drift_beyond_the_limit_is_refused(cal):
    t, theta, fx, fy, status = _held_still(cal, push_N=0.4)  # a free handle whose offsets drifted: 0.4 N of residual
    zero = ReZero(_force_of(cal), tuple(cal.offsets))
    out = zero.process(t, *theta.T, fx, fy, status)
    first = zero.events[0]
    assert first.applied and first.step_N == pytest.approx(0.4, abs=1e-3)
    begins = int(np.flatnonzero(out["rezero"])[0])
    assert t[begins] == pytest.approx(first.t_s)  # new offsets from the next block's first row
    assert np.abs(out["fx_N"][begins:]).mean() < 0.005  # zero after it
    # the offsets' change reads, through the estimate, as the residual it removed
    gx, gy = _force_of(cal)(theta[:1, 0], theta[:1, 1], np.array([cal.offsets[0] + zero.delta[0]]),
                            np.array([cal.offsets[1] + zero.delta[1]]))  # fmt: skip
    assert gx[0] == pytest.approx(0.4, abs=2e-3) and abs(gy[0]) < 2e-3
    # the drift goes on: 0.4 N more, a step within the limit, but 0.8 N in all is beyond it
    t, theta, fx, fy, status = _held_still(cal, push_N=0.4)
    fx = np.where(t < 15.0, fx, fx + 0.4)
    zero = ReZero(_force_of(cal), tuple(cal.offsets), ReZeroPolicy(max_step_N=0.5, max_total_N=0.6))
    zero.process(t, *theta.T, fx, fy, status)
    assert [e.applied for e in zero.events] == [True, False] and "recalibrate" in zero.events[1].reason
    assert zero.events[1].total_N == pytest.approx(0.8, abs=5e-3)


def test_estimate_rezero_on_the_command_line(cal, tmp_path):
    s = run("simulate-motion", "--session", "therapy", "--minutes", "3", "--sample-rate-hz", RATE_HZ, "-o", tmp_path / "th.csv")
    assert s.exit_code == 0, s.output
    cal.save(tmp_path / "cal.json")
    out = run("estimate", "--calibration", tmp_path / "cal.json", tmp_path / "th.csv", "-o", tmp_path / "est.csv",
              "--rezero", "--rezero-log", tmp_path / "log.csv")  # fmt: skip
    assert out.exit_code == 0, out.output
    header = open(tmp_path / "est.csv").readline().strip().split(",")
    assert header[-4:] == ["offset1", "offset2", "rezero", "status"]
    log = list(csv.DictReader(open(tmp_path / "log.csv")))
    rows = list(csv.DictReader(open(tmp_path / "est.csv")))
    assert f"re-zero: {len(log)} made, 0 refused" in out.output, out.output
    # three releases (the contact column says when): at least one re-zero in each, none outside
    assert {int(float(e["t_s"]) // 60) for e in log} == {0, 1, 2}
    assert all(np.mod(float(e["t_s"]) - 2.0, 60.0) >= 50.0 - 1e-9 for e in log)
    assert sum(r["rezero"] == "1" for r in rows) == len(log)
    # the column marks the row where each logged re-zero's offsets begin
    marked = [r for r in rows if r["rezero"] == "1"]
    assert [float(r["offset1"]) - cal.offsets[0] for r in marked] == pytest.approx([float(e["delta1"]) for e in log])


def test_rezero_options_fail_in_one_line(cal, tmp_path):
    cal.save(tmp_path / "cal.json")
    (tmp_path / "still.csv").write_text("theta1_deg,theta2_deg,load1,load2\n80,10,1000,2000\n")
    no_time = run("estimate", "--calibration", tmp_path / "cal.json", tmp_path / "still.csv", "-o", tmp_path / "o.csv", "--rezero")
    assert no_time.exit_code != 0 and "needs t_s" in no_time.output and not (tmp_path / "o.csv").exists()
    alone = run("estimate", "--calibration", tmp_path / "cal.json", tmp_path / "still.csv", "-o", tmp_path / "o.csv",
                "--rezero-log", tmp_path / "log.csv")  # fmt: skip
    assert alone.exit_code == 2 and "give --rezero too" in alone.output
    with pytest.raises(Exception, match="min_step_N <= max_step_N"):
        ReZeroPolicy(max_step_N=10.0, max_total_N=5.0)


# ---- temperature: identified in the calibration, compensated in the estimate --------------------------------------


def _warm_session(path, temperature, seed: int):
    """A pulley-and-weights session whose cells sit at ``temperature(n)`` [°C] (zero and span drift only, the
    datasheet defaults), with a temperature_C column: (the truth's coefficients, rows)."""
    from sailforce.drift import cell_signs
    from sailforce.synthetic import HX711_COUNTS_PER_MV_V, calibration_session

    robot = Robot()
    noise = NoiseModel()
    offsets = session_offsets(robot, noise, 1)
    t1, t2, fx, fy, counts, _ = calibration_session(robot, seed=seed, noise=noise, offsets=offsets)
    celsius = temperature(t1.size)
    drift = Drift(creep=0.0, warmup=0.0)
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    signs = cell_signs(1)
    loads = np.round(counts + drifted(np.zeros(t1.size), counts - offsets, celsius, drift, rated, signs))
    with open(path, "w") as out:
        out.write("theta1_deg,theta2_deg,load1,load2,fx_N,fy_N,temperature_C\n")
        for row in zip(np.degrees(t1), np.degrees(t2), *loads.T, fx, fy, celsius):
            out.write(",".join(repr(float(v)) for v in row) + "\n")
    zero = signs[:, 0] * (drift.zero_per_C * rated + drift.adc_offset_V_per_C * HX711_COUNTS_PER_V)
    span = signs[:, 1] * drift.span_per_C + drift.adc_gain_per_C
    return zero, span


def test_temperature_coefficients_are_identified_and_compensated(tmp_path):
    rng = np.random.default_rng(5)
    zero, span = _warm_session(tmp_path / "cal.csv", lambda n: rng.uniform(18.0, 32.0, n), seed=1)
    assert run("calibrate", tmp_path / "cal.csv", "--model", "matrix", "-o", tmp_path / "cal.json").exit_code == 0
    cal = Calibration.load(tmp_path / "cal.json")
    t = cal.temperature
    assert t is not None and 18.0 < t.reference_C < 32.0
    # the datasheet coefficients back, each within three of its standard errors; the zero's to a few per cent
    se = cal.metrics["temperature_se"]
    assert np.all(np.abs(np.asarray(t.zero_per_C) - zero) <= 3 * np.asarray(se["zero_per_C"]))
    assert np.all(np.abs(np.asarray(t.span_per_C) - span) <= 3 * np.asarray(se["span_per_C"]))
    assert np.asarray(se["zero_per_C"]) == pytest.approx(0.0, abs=0.05 * np.abs(zero).min())
    # held-out readings at 30 °C: compensated, as good as at the reference; the same calibration blind to it, not
    _warm_session(tmp_path / "warm.csv", lambda n: np.full(n, 30.0), seed=7)
    blind = tmp_path / "blind.csv"
    rows = [line.rsplit(",", 1)[0] for line in open(tmp_path / "warm.csv").read().splitlines()]
    blind.write_text("\n".join(rows) + "\n")
    errors = {}
    for name, table in (("compensated", tmp_path / "warm.csv"), ("blind", blind)):
        out = run("estimate", "--calibration", tmp_path / "cal.json", table, "-o", tmp_path / f"{name}.out.csv")
        assert out.exit_code == 0 and ("no temperature_C column" in out.output) == (name == "blind"), out.output
        d = np.genfromtxt(tmp_path / f"{name}.out.csv", delimiter=",", names=True, dtype=None, encoding=None)
        errors[name] = float(np.sqrt(np.mean((d["fx_N"] - d["fx_N_1"]) ** 2 + (d["fy_N"] - d["fy_N_1"]) ** 2)))
    fit = cal.metrics["fit_rmse_N"]
    print("force error rms [N] at 30 degC:", errors, "fit", fit)
    # the cells' noise floor is the fit's RMSE; 5 degC from the reference, the zero drift alone doubles the error
    assert errors["compensated"] < 1.25 * fit and errors["blind"] > 2 * fit
    assert cal.metrics["fit_rmse_uncompensated_N"] > 1.5 * fit


def test_a_narrow_temperature_span_identifies_nothing_and_says_so(tmp_path):
    _warm_session(tmp_path / "cal.csv", lambda n: np.linspace(22.0, 23.0, n), seed=1)
    out = run("calibrate", tmp_path / "cal.csv", "--model", "matrix", "-o", tmp_path / "cal.json")
    assert out.exit_code == 0 and "spans 1 degC, under 2" in out.output, out.output
    assert Calibration.load(tmp_path / "cal.json").temperature is None


def test_a_calibration_file_keeps_its_temperature_and_refuses_a_wrong_one(tmp_path):
    import json

    from sailforce.drift import TemperatureCompensation
    from sailforce.errors import CalibrationFileError

    _warm_session(tmp_path / "cal.csv", lambda n: np.linspace(15.0, 35.0, n), seed=1)
    assert run("calibrate", tmp_path / "cal.csv", "--model", "matrix", "-o", tmp_path / "cal.json").exit_code == 0
    cal = Calibration.load(tmp_path / "cal.json")
    cal.save(tmp_path / "again.json")
    assert Calibration.load(tmp_path / "again.json").temperature == cal.temperature
    bad = cal.to_dict()
    bad["temperature"]["span_per_C"] = [0.5, 0.0]
    from sailforce.calibration.file import checksum

    bad["checksum"] = checksum({k: v for k, v in bad.items() if k != "checksum"})
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    with pytest.raises(CalibrationFileError, match="not a load cell's"):
        Calibration.load(tmp_path / "bad.json")
    with pytest.raises(Exception, match="finite"):
        TemperatureCompensation(20.0, (1.0, float("nan")), (0.0, 0.0))
