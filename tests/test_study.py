"""The reproduced study: physics checks on its tables, and ``sail reproduce`` end to end."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce.cli import cli
from sailforce.paper.study import TABLE4_AGREEMENT, TABLE4_COLUMNS, Protocol, run_study, table4
from sailforce.robot import Robot
from sailforce.sensing.maps import torque_rows

#: The frame solve is accurate to ~1e-12 relative (cond(K) ~1e7 times eps);
#: quantities that physics makes exactly equal are compared at 1e-9.
FE_RTOL = 1e-9


@pytest.fixture(scope="module")
def bonded():
    return run_study(Robot().with_joints("bonded"))


@pytest.fixture(scope="module")
def pin():
    return run_study(Robot().with_joints("pin"))


def test_protocol_is_the_errata_protocol():
    p = Protocol()
    assert len(p.phi_deg) == 24 and p.phi_deg[-1] == 345.0
    assert p.sweep1_theta1_deg == (15.0, 30.0, 45.0, 60.0, 75.0, 90.0, 105.0, 120.0)
    assert p.sweep2_theta2_deg == (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0, 105.0)
    assert p.valid1_theta1_deg[0] == 22.5 and p.valid1_theta1_deg[-1] == 127.5
    assert p.valid2_theta2_deg[0] == -7.5 and p.valid2_theta2_deg[-1] == 97.5
    assert p.stress_phi_deg == (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)


def test_pin_joints_leave_nothing_to_compensate(pin):
    """Determinate linkage (docs/errata.md): signals exactly proportional to torques, so A = k and P = 0."""
    table = pin.table4
    np.testing.assert_allclose(table[:, 1], pin.prescale[0], rtol=FE_RTOL)
    np.testing.assert_allclose(table[:, 3], pin.prescale[1], rtol=FE_RTOL)
    np.testing.assert_allclose(table[:, [2, 4]], 0.0, atol=FE_RTOL)
    assert pin.rmse_before.mean < FE_RTOL * pin.torque_amplitude[1]
    assert all(fit.order == 0 for fit in pin.regressors.values())
    assert pin.matrix_compensator.order == 0


@pytest.mark.parametrize("joints,transduction", [("bonded", "deflection"), ("spring", "bridge")])
def test_lean_table4_is_the_studys_sinusoid_fit(joints, transduction):
    """:func:`table4` (rows off the unit solution, both sweeps in one solve) is the study's Table 4 (sinusoid fits)."""
    robot = Robot().with_joints(joints)
    study = run_study(robot, transduction)
    lean = table4(robot, transduction)
    np.testing.assert_array_equal(lean[:, 0], study.table4[:, 0])
    np.testing.assert_allclose(lean[:, [1, 3]], study.table4[:, [1, 3]], rtol=TABLE4_AGREEMENT)
    phase_scale = np.abs(study.table4[:, [2, 4]]).max()
    np.testing.assert_allclose(lean[:, [2, 4]], study.table4[:, [2, 4]], rtol=0, atol=TABLE4_AGREEMENT * max(phase_scale, 1.0))


def test_pin_prescale_matches_the_determinate_shear(pin):
    """Each driven link carries the constant shear T_i / l_i; the cell's far face deflects by its beam law."""
    response = pin.sweeps[0]
    unit = response.unit_signal[:, 0]  # deflection per unit F of cell 1
    rows = torque_rows(pin.robot.arm, response.theta1, response.theta2)[:, 0]
    ratio = np.hypot(*rows.T) / np.hypot(*unit.T)
    np.testing.assert_allclose(ratio, pin.prescale[0], rtol=FE_RTOL)


def test_delta_only_dependence(bonded):
    assert bonded.delta_only_discrepancy["amplitude_relative"] < FE_RTOL
    assert bonded.delta_only_discrepancy["phase_deg"] < FE_RTOL


def test_table4_fit_matches_peak_picking(bonded):
    """Independent check of the least-squares sinusoid: amplitude ratio and peak shift on a 0.001 deg grid."""
    fine = np.radians(np.arange(0.0, 360.0, 0.001))
    k = 4  # delta = 75 deg in sweep 1
    sweep = bonded.sweeps[0]
    row = sweep.unit_signal[k, 0]
    j = torque_rows(bonded.robot.arm, sweep.theta1[k], sweep.theta2[k])[0]
    signal = row[0] * np.cos(fine) + row[1] * np.sin(fine)
    torque = j[0] * np.cos(fine) + j[1] * np.sin(fine)
    amplitude = torque.max() / signal.max()
    shift = np.degrees(fine[np.argmax(torque)] - fine[np.argmax(signal)])
    assert bonded.table4[k, 0] == 75.0
    assert bonded.table4[k, 1] == pytest.approx(amplitude, rel=1e-9)
    assert bonded.table4[k, 2] == pytest.approx(shift, abs=0.002)


def test_bonded_deviations_have_the_seeds_signs(bonded):
    """Seed Table 4: P1 > 0 and P2 < 0 at every delta, |P| growing with delta (P1 up to 105 deg)."""
    p1, p2 = bonded.table4[:, 2], bonded.table4[:, 4]
    assert np.all(p1 > 0) and np.all(p2 < 0)
    assert np.all(np.diff(p1) > 0) and np.all(np.diff(p2) < 0)


def test_compensation_improves_and_matrix_beats_seed(bonded):
    assert bonded.rmse_after.t1 < 0.05 * bonded.rmse_before.t1
    assert bonded.rmse_after.t2 < 0.05 * bonded.rmse_before.t2
    assert bonded.force_rmse["matrix"] < bonded.force_rmse["seed"] < bonded.force_rmse["uncompensated"]


def test_extrapolation_is_worse_at_127_5(bonded):
    for cell in (0, 1):
        per_pose = bonded.rmse_after_per_pose(cell)
        outside = np.isclose(np.degrees(bonded.validation[cell].delta), 127.5)
        assert outside.sum() == 1
        assert per_pose[outside][0] > np.median(per_pose[~outside])


def test_reproduce_end_to_end(tmp_path):
    """One `sail reproduce` (its 80 s are the suite's costliest step: a module fixture would run it on each xdist
    worker), then each check of its outputs below, in turn."""
    result = CliRunner().invoke(cli, ["reproduce", "-o", str(tmp_path), "--dpi", "60"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    reproduced = tmp_path, result.output
    for check in (_check_every_output, _check_seed_model_section, _check_results_json_schema,
                  _check_table4_csv_matches_json, _check_report_is_self_contained_and_cites_the_seed):  # fmt: skip
        check(reproduced)


def _check_every_output(reproduced):
    out, output = reproduced
    for name in ("fig4_stress.png", "fig5_sweeps.png", "fig6_compensated.png", "table4.png", "workspace.png",
                 "table4.csv", "results.json", "report.md", "report.html"):  # fmt: skip
        assert (out / name).stat().st_size > 0, name
        assert (out / "pin" / name).exists() or name.startswith("report"), name
    for name in ("seed_model.json", "seed_model.png"):
        assert (out / name).stat().st_size > 0 and not (out / "pin" / name).exists(), name
    assert "study" in output and "report" in output


def _check_seed_model_section(reproduced):
    """Every family fitted, each with parameters within its bounds, residuals row by row, the verdict stated."""
    from sailforce.paper.seed_model import FAMILIES, TARGET_PHASE_RMS_DEG, TARGET_SHAPE_RMS

    out, _ = reproduced
    data = json.loads((out / "seed_model.json").read_text())
    assert [f["family"] for f in data["fits"]] == [f.name for f in FAMILIES]
    assert data["closest"] in [f.name for f in FAMILIES]
    for fit in data["fits"]:
        assert len(fit["residuals"]) == 8 and len(fit["table4"]) == 8
        for entry in fit["parameters"].values():
            low, high = entry["bounds"]
            assert low <= entry["value"] <= high
        shape_ok = fit["shape_rms"][0] is not None and max(fit["shape_rms"]) <= TARGET_SHAPE_RMS
        assert fit["meets_targets"] == (max(fit["phase_rms_deg"]) <= TARGET_PHASE_RMS_DEG and shape_ok)
    assert data["pin_crosstalk"]["a1_corrected_spread"] < 1e-9
    markdown = (out / "report.md").read_text()
    section = markdown[markdown.index("## What was the seed's model?"):]
    verdict = "meet" if any(f["meets_targets"] for f in data["fits"]) else "No family meets both targets"
    for needle in (verdict, "Three statements, corrected", "convention", "1/(1 − c·cot Δ)", "l3 ≈ 0.51 m",
                   "l2 ≈ 0.22 m", "Residuals", "seed_model.png"):  # fmt: skip
        assert needle in section, needle


def test_reproduce_without_the_seed_model(tmp_path):
    result = CliRunner().invoke(cli, ["reproduce", "-o", str(tmp_path), "--dpi", "50", "--compare-joints", "none",
                                      "--no-seed-model"], catch_exceptions=False)  # fmt: skip
    assert result.exit_code == 0, result.output
    assert not (tmp_path / "seed_model.json").exists()
    assert "## What was the seed's model?" not in (tmp_path / "report.md").read_text()


def _check_results_json_schema(reproduced):
    out, _ = reproduced
    data = json.loads((out / "results.json").read_text())
    assert data["joints"] == "bonded" and data["transduction"] == "deflection"
    assert data["software"].startswith("sailforce ") and "arm" in data["robot"]
    assert len(data["table4"]) == 8 and set(data["table4"][0]) == set(TABLE4_COLUMNS)
    for name in TABLE4_COLUMNS[1:]:
        entry = data["regressors"][name]
        assert {"order", "coefficients", "r2", "adj_r2"} <= set(entry)
        assert len(entry["coefficients"]) == entry["order"] + 1
    for key in ("rmse", "rmse_relative"):
        for when in ("before", "after"):
            assert set(data[key][when]) >= {"t1", "t2", "mean"}
    rmse, rel = data["rmse"]["after"], data["rmse_relative"]["after"]
    assert rel["t1"] == pytest.approx(rmse["t1"] / 4.5) and rel["t2"] == pytest.approx(rmse["t2"] / 3.0)


def _check_table4_csv_matches_json(reproduced):
    out, _ = reproduced
    with open(out / "table4.csv") as stream:
        rows = list(csv.DictReader(stream))
    data = json.loads((out / "results.json").read_text())
    assert list(rows[0]) == list(TABLE4_COLUMNS)
    for row, entry in zip(rows, data["table4"]):
        for name in TABLE4_COLUMNS:
            assert float(row[name]) == pytest.approx(entry[name], rel=1e-9)


def _check_report_is_self_contained_and_cites_the_seed(reproduced):
    out, _ = reproduced
    html = (out / "report.html").read_text()
    assert 'src="fig' not in html and html.count("data:image/png;base64,") == 6
    markdown = (out / "report.md").read_text()
    for needle in ("Errata", "Eq. 10", "919.458", "0.436", "127.5", "pin", "Δ-only", "Beyond the seed"):
        assert needle in markdown, needle


def test_reproduce_rejects_bad_robot_file(tmp_path):
    robot = tmp_path / "robot.toml"
    robot.write_text("[links]\nl1 = -1\n")
    result = CliRunner().invoke(cli, ["reproduce", "-o", str(tmp_path / "o"), "--robot", str(robot)])
    assert result.exit_code == 1 and "Traceback" not in result.output


def test_report_prose_follows_the_protocol():
    """Change every grid of the protocol: the report's words and counts change with it."""
    from sailforce.report.document import report_markdown

    protocol = Protocol(
        phi_deg=tuple(np.arange(0.0, 360.0, 30.0)), stress_phi_deg=(0.0, 90.0, 180.0, 270.0),
        stress_pose_deg=(60.0, 0.0), valid1_theta1_deg=(25.0, 55.0, 85.0, 115.0, 130.0),
        valid2_theta2_deg=(-10.0, 20.0, 50.0, 80.0), workspace_delta_deg=tuple(np.arange(20.0, 160.1, 5.0)),
        wide_calibration_delta_deg=tuple(np.arange(20.0, 160.1, 20.0)),
    )  # fmt: skip
    result = run_study(Robot().with_joints("bonded"), protocol=protocol)
    markdown = report_markdown(result, None, 1.0)
    runs = (16 * 12, (5 + 4) * 12)
    assert protocol.runs() == runs
    for needle in (f"{runs[0]} + {runs[1]} analyses", "all 12 force angles", "the 12 force angles",
                   "φ = 0…270° in 90° steps", "θ1 = 60°, θ2 = 0°", "θ2 = 0°, θ1 = 25…130°", "θ1 = 120°, θ2 = -10…80°",
                   "Δ = 20…160°", "Δ = 20…160° in 20° steps", "at Δ = 130°"):  # fmt: skip
        assert needle in markdown, needle
    for stale in ("24 force angles", "127.5", "22.5", "15…165", "384"):
        assert stale not in markdown, stale


def test_models_have_ids_and_labels_apart(bonded):
    from sailforce.paper.study import ModelId
    from sailforce.report.labels import MODEL_COLOURS, model_label

    assert set(bonded.force_rmse) == {ModelId.UNCOMPENSATED, ModelId.SEED, ModelId.MATRIX}
    assert set(bonded.workspace.relative_error) == set(ModelId) == set(MODEL_COLOURS)
    for model in ModelId:
        assert " " not in model.value and model_label(model, bonded.protocol) != model.value
    assert "15…165°" in model_label(ModelId.MATRIX_WIDE, bonded.protocol)


def test_study_result_and_calibration_are_built_by_keyword(bonded):
    from dataclasses import astuple

    from sailforce.calibration.file import Calibration
    from sailforce.paper.study import StudyResult

    with pytest.raises(TypeError):
        StudyResult(*astuple(bonded)[:21])
    with pytest.raises(TypeError):
        Calibration(bonded.robot.arm, bonded.matrix_compensator, (0.0, 0.0), (1.0, 1.0), (0.3, 2.0))


def test_report_leaves_the_matplotlib_backend_alone():
    """A library must not switch pyplot's global backend: the figures are plain ``Figure`` objects."""
    import subprocess
    import sys

    code = ("import matplotlib, sys; matplotlib.use('svg'); import sailforce.report.study_figures, "
            "sailforce.report.stress_figure, sailforce.report.document, sailforce.cli.reproduce_cmd; "
            "print(matplotlib.get_backend(), 'matplotlib.pyplot' in sys.modules)")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["svg", "False"]


def test_errata_numbers_are_computed():
    """The report's errata recompute the seed's A2 R² from its Table 4 (docs/errata.md: 0.99919 and 0.99810)."""
    from sailforce.report.document import errata

    text = " ".join(errata(Protocol()))
    assert "(0.99919)" in text and "(0.99810)" in text and "sin 2°" in text and "740 and 528" in text
    assert "θ1 = 75°" in text and "79 GPa" in text and "82 GPa" in text
