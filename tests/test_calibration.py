"""Calibration from noisy synthetic recordings, the calibration file, and the estimator's statuses."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sailforce.calibration.file import Calibration, CalibrationFileError, checksum
from sailforce.estimate.estimator import EXTRAPOLATED, INVALID, OK, SATURATED, SINGULAR
from sailforce.fem.model import build_model
from sailforce.fem.response import simulate_model
from sailforce.fit.calibration import equivalent_capacity, fit_calibration
from sailforce.robot import Robot
from sailforce.sensing.maps import CompensationError, MatrixCompensator
from sailforce.synthetic import HX711_COUNTS_PER_MV_V, NoiseModel, calibration_session, recording

#: The calibrated estimator's force error must stay within this factor of the noise floor.
NOISE_FLOOR_FACTOR = 1.5

ROBOT = Robot().with_joints("spring")  # moment-carrying joints: a delta-dependent map to calibrate


def calibration_set(seed=1, step_deg=7.5, directions=12):
    """Poses every ``step_deg`` over delta = 15..165 deg at random theta2, ``directions`` 20 N forces each."""
    return calibration_session(ROBOT, seed=seed, step_deg=step_deg, directions=directions)


@pytest.fixture(scope="module")
def fitted():
    t1, t2, fx, fy, counts, offsets = calibration_set()
    model, fitted_offsets, report = fit_calibration(ROBOT.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1])
    capacity = equivalent_capacity(model, ROBOT.arm, ROBOT.loadcell.capacity_N, report.delta_range)
    cal = Calibration(arm=ROBOT.arm, model=model, offsets=tuple(fitted_offsets), capacity=tuple(capacity),
                      delta_range=report.delta_range)
    return cal, offsets, report


def test_calibrated_error_within_noise_floor(fitted):
    """Force error of the calibrated estimator against the noise floor on fresh test readings.

    The noise floor is the error of the *true* map (the simulation's, with the
    true offsets) applied to the same noisy counts: no estimator can do better.
    """
    cal, true_offsets, _ = fitted
    rng = np.random.default_rng(7)
    n = 3000
    t2 = rng.uniform(-1.0, 1.0, n)
    t1 = t2 + np.radians(rng.uniform(20.0, 160.0, n))
    phi, magnitude = rng.uniform(0, 2 * np.pi, n), rng.uniform(5.0, 30.0, n)
    fx, fy = magnitude * np.cos(phi), magnitude * np.sin(phi)
    counts, _, _ = recording(ROBOT, t1, t2, fx, fy, seed=11, offsets=true_offsets)
    fx_hat, fy_hat, status = cal.estimate(t1, t2, counts[:, 0], counts[:, 1])
    assert np.all(status == OK)
    error = np.sqrt(np.mean((fx_hat - fx) ** 2 + (fy_hat - fy) ** 2))
    true_map = simulate_model(build_model(ROBOT), t1, t2).signal("bridge") * HX711_COUNTS_PER_MV_V
    s = counts - true_offsets
    f_true = np.linalg.solve(true_map, s[..., None])[..., 0]
    floor = np.sqrt(np.mean((f_true[:, 0] - fx) ** 2 + (f_true[:, 1] - fy) ** 2))
    assert floor > 0.01  # the noise model is active: 0.01% of rated output is tens of mN here
    assert error <= NOISE_FLOOR_FACTOR * floor, (error, floor)


def test_offsets_recovered(fitted):
    cal, true_offsets, report = fitted
    rated = ROBOT.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    # 252 samples of 1e-4 rated noise: the offset's standard error is ~1e-5 rated; allow 10x.
    np.testing.assert_allclose(cal.offsets, true_offsets, atol=1e-4 * rated)
    assert report.n_deltas == 21 and report.n_samples == 252


def test_seed_and_matrix_models_both_fit_and_auto_picks_better():
    t1, t2, fx, fy, counts, _ = calibration_set(seed=3)
    reports = {}
    for kind in ("seed", "matrix", "auto"):
        model, _, reports[kind] = fit_calibration(ROBOT.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind=kind)
        assert reports[kind].cv_rmse_N < 0.5  # of 20 N
    assert reports["auto"].kind == min(reports["auto"].cv_rmse_by_kind, key=reports["auto"].cv_rmse_by_kind.get)


@pytest.mark.parametrize("case, message", [
    ("two_deltas", "distinct delta"),
    ("narrow", "span delta"),
    ("collinear", "collinear"),
    ("one_direction", "two force directions"),
])  # fmt: skip
def test_refuses_undetermined_data(case, message):
    t1, t2, fx, fy, counts, _ = calibration_set()
    if case == "two_deltas":
        keep = np.isin(np.round(np.degrees(t1 - t2), 3), np.round(np.degrees((t1 - t2)[[0, 12]]), 3))
        t1, t2, fx, fy, counts = t1[keep], t2[keep], fx[keep], fy[keep], counts[keep]
        t1 = t2 + np.where(np.isclose(t1 - t2, (t1 - t2)[0]), 0.3, 1.5)
    elif case == "narrow":
        t1 = t2 + 0.5 + 0.1 * (t1 - t2) / 3
    elif case == "collinear":
        fx, fy = 20.0 * np.cos(t2), 20.0 * np.sin(t2)  # always along link 2
    kind = "seed" if case == "one_direction" else "auto"
    if case == "one_direction":
        fx, fy = np.where(np.arange(fx.size) % 12 < 6, fx, fx[0]), np.where(np.arange(fy.size) % 12 < 6, fy, fy[0])
        fx[:12], fy[:12] = 20.0, 0.0
    with pytest.raises(CompensationError, match=message):
        fit_calibration(ROBOT.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind=kind)


def _simple_calibration() -> Calibration:
    arm = ROBOT.arm
    c = np.zeros((2, 2, 2))
    c[0] = np.diag([1 / 740, 1 / 528])
    c[1] = [[1e-5, 2e-6], [0.0, -1e-5]]
    return Calibration(arm=arm, model=MatrixCompensator(arm, c, (0.25, 2.1)), offsets=(10.0, -5.0), capacity=(1.0, 1.0),
                       delta_range=(0.25, 2.1), load_range=((-1.0, 1.0), (-1.0, 1.0)), load_unit="counts",
                       metrics={"cv_rmse_N": 0.1}, data_sha256="ab" * 32, created="2026-01-01T00:00:00+00:00")  # fmt: skip


def test_file_round_trip(tmp_path):
    cal = _simple_calibration()
    path = tmp_path / "cal.json"
    cal.save(path)
    loaded = Calibration.load(path)
    assert loaded.to_dict() == cal.to_dict()
    args = (np.array([1.0, 1.4]), np.array([0.1, -0.2]), np.array([10.002, 9.99]), np.array([-5.001, -4.997]))
    np.testing.assert_array_equal(np.array(loaded.estimate(*args)), np.array(cal.estimate(*args)))
    data = json.loads(path.read_text())
    assert data["checksum"] == checksum({k: v for k, v in data.items() if k != "checksum"})


def test_seed_model_file_round_trip(tmp_path):
    t1, t2, fx, fy, counts, _ = calibration_set(seed=4)
    model, offsets, report = fit_calibration(ROBOT.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="seed")
    cal = Calibration(arm=ROBOT.arm, model=model, offsets=tuple(offsets), capacity=(5e6, 5e6),
                      delta_range=report.delta_range, load_range=((-5e6, 5e6), (-5e6, 5e6)))
    cal.save(tmp_path / "s.json")
    loaded = Calibration.load(tmp_path / "s.json")
    assert loaded.kind == "seed"
    np.testing.assert_allclose(loaded.estimate(t1, t2, counts[:, 0], counts[:, 1])[:2],
                               cal.estimate(t1, t2, counts[:, 0], counts[:, 1])[:2], rtol=1e-12)  # fmt: skip


def _rewrite(path, edit, fix_checksum=True):
    data = json.loads(path.read_text())
    edit(data)
    if fix_checksum:
        data["checksum"] = checksum({k: v for k, v in data.items() if k != "checksum"})
    path.write_text(json.dumps(data))


@pytest.mark.parametrize("edit, fix, message", [
    (lambda d: d.update(schema_version=2), True, "schema_version 2 is not supported"),
    (lambda d: d.pop("offsets"), True, "missing field(s) offsets"),
    (lambda d: d.update(offsets=[1.0, "x"]), True, "offsets"),
    (lambda d: d.update(capacity=[1.0, -1.0]), True, "capacity"),
    (lambda d: d.update(delta_range=[2.0, 1.0]), True, "delta_range"),
    (lambda d: d["model"].update(kind="neural"), True, "model.kind"),
    (lambda d: d["model"].update(coefficients=[[1, 2]]), True, "coefficients"),
    (lambda d: d["robot"].update(l3=0.1), True, "robot"),
    (lambda d: d.update(offsets=[11.0, -5.0]), False, "checksum does not match"),
])  # fmt: skip
def test_load_rejects_bad_files(tmp_path, edit, fix, message):
    path = tmp_path / "cal.json"
    _simple_calibration().save(path)
    _rewrite(path, edit, fix)
    with pytest.raises(CalibrationFileError, match=message.replace("(", r"\(").replace(")", r"\)")):
        Calibration.load(path)


def test_load_rejects_corrupt_and_missing(tmp_path):
    (tmp_path / "c.json").write_bytes(b'{"schema_version": 1, "offs')
    with pytest.raises(CalibrationFileError, match="invalid JSON"):
        Calibration.load(tmp_path / "c.json")
    with pytest.raises(CalibrationFileError, match="no such"):
        Calibration.load(tmp_path / "absent.json")


def test_every_status():
    cal = _simple_calibration()
    theta1 = np.array([1.0, 1.0, 0.5, 1.0, 2.5, np.nan, 1.0])
    theta2 = np.array([0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0])
    load1 = np.array([10.001, 12.0, 10.0, 10.0, 10.0, 10.0, np.inf])
    load2 = np.array([-5.0, -5.0, -5.0, -5.0, -5.0, -5.0, -5.0])
    fx, fy, status = cal.estimate(theta1, theta2, load1, load2)
    assert status.tolist() == [OK, SATURATED, SINGULAR, OK, EXTRAPOLATED, INVALID, INVALID]
    assert np.isnan(fx[[2, 5, 6]]).all() and np.isfinite(fx[[0, 1, 3, 4]]).all()
    assert fx[3] == 0.0 and fy[3] == 0.0  # tared zero reading is zero force


def test_noise_model_quantizes_to_counts():
    counts, _, clean = recording(ROBOT, 1.2, 0.1, 3.0, 4.0, noise=NoiseModel(noise_fraction=0.0))
    np.testing.assert_array_equal(counts, np.round(clean))


def test_files_follow_the_published_schema(tmp_path):
    """calibration.schema.json describes what `sail calibrate` writes: matrix, seed and dynamic files validate,
    its required fields are the loader's, and structurally broken files fail both."""
    from dataclasses import replace
    from importlib.resources import files

    import jsonschema

    from sailforce.calibration import file as calfile
    from sailforce.fit.dynamic import prior_term

    schema = json.loads(files("sailforce.calibration").joinpath("calibration.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    assert tuple(schema["required"]) == calfile.REQUIRED
    t1, t2, fx, fy, counts, _ = calibration_set(seed=4)
    seed_model, offsets, _ = fit_calibration(ROBOT.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="seed")
    matrix = _simple_calibration()
    for cal in (matrix, replace(matrix, model=seed_model), replace(matrix, dynamics=prior_term(ROBOT), dynamics_source="prior")):
        cal.save(tmp_path / "cal.json")
        data = json.loads((tmp_path / "cal.json").read_text())
        jsonschema.validate(data, schema)
        assert Calibration.from_dict(data).kind == cal.kind
    broken = matrix.to_dict()
    broken["model"]["kind"] = "cubic"
    broken["checksum"] = checksum({k: v for k, v in broken.items() if k != "checksum"})
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, schema)
    with pytest.raises(CalibrationFileError, match="model.kind"):
        Calibration.from_dict(broken)
