"""A reference F/T sensor at the handle: its frame, its clock, a calibration against it, and validation."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce.calibration.file import Calibration
from sailforce.cli import cli
from sailforce.errors import InputError, TableError
from sailforce.kernel import inverse_entries, torque_entries
from sailforce.motion.reaching import reaching, record
from sailforce.motion.session import PUSH_BAND_HZ, tremor
from sailforce.reference import (
    ReferenceRecording,
    ReferenceSensor,
    align_clocks,
    read_reference,
    rotate,
    sensor_angle,  # fmt: skip
    simulate_reference,
    to_base,
)
from sailforce.reference.validate import LIMITS_SD, MIN_BIN_SAMPLES, agreement, by_bins
from sailforce.robot import Robot
from sailforce.synthetic import HX711_COUNTS_PER_MV_V, NoiseModel, session_offsets
from sailforce.workflows import calibrate, reference_calibration_run, reference_rows, validation

ROBOT = Robot()
#: A sensor unlike the defaults: its mount, clock offset (not a whole number of either recording's samples) and rate.
SENSOR = ReferenceSensor(rate_Hz=500.0, noise_N=0.05, mount_rad=np.radians(-37.3), clock_offset_s=0.3137,
                         offsets_N=(1.2, -0.7))  # fmt: skip

#: The targets (issue "calibrate a real arm in an afternoon"): the mount within 0.2 deg, the clock within one
#: sample of the reference.
MOUNT_TOLERANCE_RAD = np.radians(0.2)


def _session(seed: int, sensor: ReferenceSensor = SENSOR, reaches: int = 8):
    """A push session (the hand pushing the handle about while the robot moves it) and the sensor's recording."""
    motion = reaching(ROBOT, reaches=reaches, dwell=1.5)
    force = tremor(motion.t, 10.0, np.random.default_rng([seed, 1]), PUSH_BAND_HZ)
    rec = record(ROBOT, motion, force=force, seed=seed, offsets=session_offsets(ROBOT, NoiseModel(), 1))
    data = {"t_s": rec.t, "theta1_deg": np.degrees(rec.theta[:, 0]), "theta2_deg": np.degrees(rec.theta[:, 1]),
            "load1": rec.loads[:, 0], "load2": rec.loads[:, 1]}  # fmt: skip
    ref = simulate_reference(rec.t, rec.motion.q[:, 0], rec.force, sensor, seed=seed + 2)
    return data, ReferenceRecording(ref["t_s"], np.column_stack([ref["fx"], ref["fy"]])), rec


@pytest.fixture(scope="module")
def sessions():
    return _session(0), _session(1)


def _write(path, columns: dict) -> None:
    names = list(columns)
    np.savetxt(path, np.column_stack([columns[n] for n in names]), delimiter=",", header=",".join(names),
               comments="", fmt="%.10g")  # fmt: skip


def test_the_sensor_frame_turns_the_force_and_back():
    """F_sensor = R(-phi) F + b; on the link phi = mount + theta1 (l3 is parallel to l1), on the base phi = mount."""
    f = np.array([[3.0, 4.0]])
    assert np.allclose(rotate(np.pi / 2, f), [[-4.0, 3.0]])
    assert np.allclose(sensor_angle(0.1, np.array([0.5]), "link"), 0.6)
    assert np.allclose(sensor_angle(0.1, np.array([0.5]), "base"), 0.1)
    t = np.arange(0.0, 1.0, 1e-3)
    theta1 = np.full(t.size, np.radians(60.0))
    quiet = replace(SENSOR, noise_N=0.0, clock_offset_s=0.0)
    ref = simulate_reference(t, theta1, np.tile(f, (t.size, 1)), quiet)
    f_sensor = np.column_stack([ref["fx"], ref["fy"]])
    phi = np.radians(60.0 - 37.3)
    expected = [3.0 * np.cos(phi) + 4.0 * np.sin(phi) + 1.2, -3.0 * np.sin(phi) + 4.0 * np.cos(phi) - 0.7]
    assert np.allclose(f_sensor, expected)
    assert np.allclose(to_base(f_sensor, phi, quiet.offsets_N), f)
    assert np.allclose(np.diff(ref["t_s"]), 1 / 500.0)


def test_the_push_force_is_steady_from_its_first_second():
    """Band-limited noise is drawn past its filter's start-up: unpadded, a 0.1 Hz band put most of its power there."""
    t = np.arange(0.0, 36.0, 1e-3)
    f = tremor(t, 10.0, np.random.default_rng(3), PUSH_BAND_HZ)
    assert np.allclose(np.sqrt(np.mean(f**2, axis=0)), 10.0)
    for part in (f[: t.size // 6], f[-t.size // 6 :]):
        assert np.all(np.sqrt(np.mean(part**2, axis=0)) < 20.0)


def test_clocks_are_aligned_within_one_reference_sample(sessions):
    (data, ref, _), _ = sessions
    loads = np.column_stack([data["load1"], data["load2"]])
    coarse = align_clocks(data["t_s"], loads, ref, theta1=np.radians(data["theta1_deg"]), on="link")
    assert abs(coarse.offset_s - SENSOR.clock_offset_s) <= 2 / SENSOR.rate_Hz and coarse.score > coarse.second_score
    rows = reference_rows(data, ref, robot=ROBOT)
    assert abs(rows.alignment.offset_s - SENSOR.clock_offset_s) <= 1 / SENSOR.rate_Hz, rows.alignment
    assert abs(rows.frame.mount_rad - SENSOR.mount_rad) <= MOUNT_TOLERANCE_RAD
    assert all(abs(b - t) <= 4 * se for b, t, se in zip(rows.frame.offsets_N, SENSOR.offsets_N, rows.frame.offsets_se_N))
    # the force it gives is the hand's, to the sensor's noise (interpolated between its samples: at most its sigma)
    true = rows_true(rows, sessions[0][2])
    assert np.sqrt(np.mean((rows.force - true) ** 2)) <= SENSOR.noise_N


def rows_true(rows, rec) -> np.ndarray:
    index = np.searchsorted(rec.t, rows.t)
    assert np.allclose(rec.t[index], rows.t)
    return rec.force[index]


def test_a_sensor_on_the_base_is_registered_too():
    sensor = replace(SENSOR, on="base", mount_rad=np.radians(100.0), clock_offset_s=-1.7)
    data, ref, _ = _session(2, sensor, reaches=6)
    rows = reference_rows(data, ref, robot=ROBOT, on="base")
    assert abs(rows.alignment.offset_s - sensor.clock_offset_s) <= 1 / sensor.rate_Hz
    assert abs(rows.frame.mount_rad - sensor.mount_rad) <= MOUNT_TOLERANCE_RAD


def test_unrelated_recordings_are_refused(sessions):
    (data, _, _), (_, other, _) = sessions
    noise = ReferenceRecording(other.t, np.random.default_rng(0).normal(size=other.force.shape))
    with pytest.raises(InputError, match="share too little"):
        reference_rows(data, noise, robot=ROBOT)
    late = ReferenceRecording(other.t + 100.0, other.force)
    with pytest.raises(InputError, match="never overlap"):
        reference_rows(data, late, robot=ROBOT)


def test_a_reference_calibration_matches_a_pulley_calibration_within_the_noise(sessions, tmp_path):
    """Calibrated on one push session against the sensor, and with weights over pulleys, both estimate a second
    session's true force alike: within 10 % RMS of each other, at the cells' noise floor."""
    (data, ref, _), (data2, ref2, rec2) = sessions
    run = reference_calibration_run(data, ref, robot=ROBOT, model="matrix")
    cal = run.run.calibration
    assert cal.dynamics_source == "reference" and run.dynamic_fit is not None
    cal.save(tmp_path / "ref.json")
    assert Calibration.load(tmp_path / "ref.json").dynamics_source == "reference"
    from sailforce.synthetic import calibration_session

    t1, t2, fx, fy, counts, _ = calibration_session(ROBOT, seed=2, offsets=session_offsets(ROBOT, NoiseModel(), 1))
    pulley = calibrate({"theta1_deg": np.degrees(t1), "theta2_deg": np.degrees(t2), "load1": counts[:, 0],
                        "load2": counts[:, 1], "fx_N": fx, "fy_N": fy}, robot=ROBOT, model="matrix", dynamics="prior")  # fmt: skip
    errors = {}
    for name, c in (("reference", cal), ("pulley", pulley)):
        v = validation(data2, ref2, c)
        true = rows_true(v.rows, rec2)
        e = (v.estimate - true)[v.used]
        errors[name] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
        # the validation's own RMS holds the sensor's noise too: in quadrature, about
        assert v.overall.rmse_N**2 == pytest.approx(errors[name] ** 2 + np.mean(np.sum((v.rows.force - true)[v.used] ** 2, 1)), rel=0.1)
    assert errors["reference"] == pytest.approx(errors["pulley"], rel=0.1), errors
    # the floor: the cells' noise (sigma counts each) through the inverse map, at the session's poses
    rated = ROBOT.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    sigma = NoiseModel().noise_fraction * rated
    theta = np.radians(np.column_stack([data2["theta1_deg"], data2["theta2_deg"]]))
    s1, c1, s2, c2 = np.sin(theta[:, 0]), np.cos(theta[:, 0]), np.sin(theta[:, 1]), np.cos(theta[:, 1])
    inverse = inverse_entries(pulley.model.sensing_entries(theta[:, 0] - theta[:, 1],
                                                           torque_entries(ROBOT.arm.l2, ROBOT.arm.l3, s1, c1, s2, c2)))  # fmt: skip
    floor = sigma * np.sqrt(np.mean(sum(m**2 for m in inverse)))
    assert floor < max(errors.values()) < 1.3 * floor, (errors, floor)


def test_agreement_is_bland_altman():
    rng = np.random.default_rng(1)
    reference = rng.normal(size=(1000, 2))
    d = np.column_stack([np.full(1000, 0.3), rng.normal(0.0, 0.2, 1000)])
    a = agreement(reference + d, reference)
    assert a.bias_N[0] == pytest.approx(0.3) and a.sd_N[0] == pytest.approx(0.0, abs=1e-12)
    assert a.bias_N[1] == pytest.approx(d[:, 1].mean()) and a.sd_N[1] == pytest.approx(d[:, 1].std(ddof=1))
    assert a.limits_N[1] == pytest.approx((a.bias_N[1] - LIMITS_SD * a.sd_N[1], a.bias_N[1] + LIMITS_SD * a.sd_N[1]))
    assert a.rmse_N == pytest.approx(np.sqrt(np.mean(np.sum(d**2, 1))))
    keys = np.repeat([5.0, 20.0, 40.0], [1000 - 300 - (MIN_BIN_SAMPLES - 1), 300, MIN_BIN_SAMPLES - 1])
    binned = by_bins(reference + d, reference, keys, 15.0)
    assert binned.edges == ((0.0,), (15.0,)) and [b.samples for b in binned.agreements] == [601 - MIN_BIN_SAMPLES + 100, 300]
    with pytest.raises(InputError):
        agreement(reference[:, :1], reference[:, :1])


def test_cli_calibrates_against_the_reference_and_validates(tmp_path):
    runner = CliRunner()
    run = lambda *a: runner.invoke(cli, [str(v) for v in a])
    for seed, name in ((0, "a"), (1, "b")):
        result = run("simulate-motion", "--session", "push", "--reaches", 6, "--seed", seed, "--reference",
                     tmp_path / f"{name}_ref.csv", "-o", tmp_path / f"{name}.csv")  # fmt: skip
        assert result.exit_code == 0, result.output
    truth = json.loads((tmp_path / "a.csv.json").read_text())["reference"]
    result = run("calibrate", tmp_path / "a.csv", "--reference", tmp_path / "a_ref.csv", "--model", "matrix", "-q",
                 "-o", tmp_path / "cal.json")  # fmt: skip
    assert result.exit_code == 0, result.output
    meta = Calibration.load(tmp_path / "cal.json").metrics["reference"]
    assert abs(meta["mount_deg"] - truth["mount_deg"]) <= 0.2
    assert abs(meta["clock_offset_s"] - truth["clock_offset_s"]) <= 1 / truth["rate_Hz"]
    result = run("validate", tmp_path / "b.csv", "--reference", tmp_path / "b_ref.csv", "--calibration",
                 tmp_path / "cal.json", "-o", tmp_path / "val")  # fmt: skip
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "val" / "validation.json").read_text())
    assert summary["dynamic_term"] and summary["overall"]["rmse_N"] < 0.15
    assert summary["overall"]["samples"] == summary["statuses"]["ok"]
    by_delta = np.genfromtxt(tmp_path / "val" / "by_delta.csv", delimiter=",", names=True)
    assert by_delta["samples"].sum() == summary["overall"]["samples"]
    for figure in ("bland_altman.png", "error_map.png"):
        assert (tmp_path / "val" / figure).stat().st_size > 10_000


def test_cli_refuses_what_it_cannot_read(tmp_path):
    runner = CliRunner()
    data = {"t_s": np.arange(3.0), "theta1_deg": [90.0] * 3, "theta2_deg": [0.0] * 3, "load1": [0.0] * 3, "load2": [0.0] * 3}
    _write(tmp_path / "d.csv", data)
    _write(tmp_path / "back.csv", {"t_s": [0.0, 1.0, 0.5], "fx": [0.0] * 3, "fy": [0.0] * 3})
    with pytest.raises(TableError, match="does not increase at data row 3"):
        read_reference(tmp_path / "back.csv")
    result = runner.invoke(cli, ["calibrate", str(tmp_path / "d.csv"), "--reference", str(tmp_path / "back.csv"),
                                 "--free-motion", str(tmp_path / "d.csv"), "-o", str(tmp_path / "c.json")])  # fmt: skip
    assert result.exit_code == 2 and "leave out --free-motion" in result.output
    result = runner.invoke(cli, ["calibrate", str(tmp_path / "d.csv"), "--reference", str(tmp_path / "back.csv"),
                                 "-o", str(tmp_path / "c.json")])  # fmt: skip
    assert result.exit_code != 0 and "does not increase" in result.output and "Traceback" not in result.output
    result = runner.invoke(cli, ["simulate-motion", "--session", "static", "--reference", str(tmp_path / "r.csv"),
                                 "-o", str(tmp_path / "s.csv")])  # fmt: skip
    assert result.exit_code == 2 and "motion session" in result.output
    result = runner.invoke(cli, ["validate", str(tmp_path / "d.csv"), "--reference", str(tmp_path / "back.csv"),
                                 "--calibration", str(tmp_path / "none.json"), "--reference-offsets-N", "1", "-o",
                                 str(tmp_path / "v")])  # fmt: skip
    assert result.exit_code == 2 and "FX,FY" in result.output
