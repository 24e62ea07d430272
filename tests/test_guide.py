"""The guided calibration (``sail live --calibrate``): a plan walked through on the simulated rig, in the pipeline and
in Chromium; the recording, the fitted calibration against the true force, and the achieved map; the robot file's
nominal calibration."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce.calibration.file import Calibration
from sailforce.cli import cli
from sailforce.errors import SailError, TableError
from sailforce.io.tables import READING_COLUMNS, REFERENCE_COLUMNS, read_clean
from sailforce.live import sources
from sailforce.live.guide import RECORDING_COLUMNS, Guide, read_plan
from sailforce.live.pipeline import LivePipeline
from sailforce.robot import Robot
from sailforce.synthetic import NoiseModel, calibration_session, session_offsets
from sailforce.workflows import nominal_calibration

#: The simulated rig runs this many times real time in the pipeline test.
SPEED = 10.0
#: ... and in the page's test: fast enough to walk twelve holds in seconds, slow enough that a click lands in its hold.
PAGE_SPEED = 3.0
#: Every wait on the guide ends after this long [s] (the physics fit at the end takes about 7 s alone).
WAIT_S = 120.0
#: The guided calibration's true force error may reach this many times the achieved map's 1-sigma worst direction
#: at each delta (a 3-sigma bound: the map is a standard deviation, the error one draw).
SIGMAS = 3.0
#: The nominal map is the frame model itself at unit gains: on a noise-free session of that model its force error
#: is the stored series' own (stored_map's 1e-6 relative), far below this [N] at 20 N.
NOMINAL_TOL_N = 1e-3


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory) -> Path:
    """An 12-hold physics plan for an HX711 at 80 SPS over delta = 30..120 deg (``sail plan-calibration``)."""
    d = tmp_path_factory.mktemp("plan")
    result = CliRunner().invoke(cli, ["plan-calibration", "--model", "physics", "--holds", "12", "--adc", "hx711-80",
                                      "-q", "-o", str(d)], catch_exceptions=False)  # fmt: skip
    assert result.exit_code == 0, result.output
    return d


def _true_error(cal: Calibration, robot: Robot, rig: int = 1):
    """Deltas [deg] and the force error [N] of ``cal`` on a noise-free pulley session of the simulated rig."""
    noise = NoiseModel(noise_fraction=0.0, quantize=False)
    t1, t2, fx, fy, counts, _ = calibration_session(robot, noise=noise, offsets=session_offsets(robot, NoiseModel(), rig))
    fxe, fye, _ = cal.estimate(t1, t2, counts[:, 0], counts[:, 1])
    return np.degrees(t1 - t2), np.hypot(fxe - fx, fye - fy)


def _wait(guide: Guide, phases, timeout=WAIT_S) -> dict:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        info = guide.info()
        if info["phase"] in phases:
            return info
        time.sleep(0.01)
    pytest.fail(f"the guide never reached {phases}: {guide.info()}")


def test_nominal_calibration_is_the_robot_file_s_map():
    robot = Robot()
    cal = nominal_calibration(robot)
    assert cal.offsets == (0.0, 0.0)
    noise = NoiseModel(noise_fraction=0.0, offset_fraction=0.0, quantize=False)
    t1, t2, fx, fy, counts, _ = calibration_session(robot, noise=noise)
    fxe, fye, _ = cal.estimate(t1, t2, counts[:, 0], counts[:, 1])
    assert np.max(np.hypot(fxe - fx, fye - fy)) < NOMINAL_TOL_N


def test_a_plan_is_read_with_its_model_and_prediction_and_bad_plans_are_refused(plan_dir, tmp_path):
    plan = read_plan(plan_dir / "plan.csv")
    info = json.loads((plan_dir / "plan.json").read_text())
    assert plan.model == "physics" and plan.adc == "hx711-80" and len(plan) == info["holds"]
    assert plan.free == ("joints.P1.stiffness", "joints.P2.stiffness", "joints.P3.stiffness")
    assert plan.planned is not None and plan.planned.worst_N.max() == pytest.approx(info["errors"]["plan"]["worst_N"])
    (tmp_path / "no-force.csv").write_text("theta1_deg,theta2_deg,fx_N,fy_N\n60,0,0,0\n")
    with pytest.raises(TableError, match="hold 1 has no force"):
        read_plan(tmp_path / "no-force.csv")
    (tmp_path / "columns.csv").write_text("theta1_deg,theta2_deg\n60,0\n")
    with pytest.raises(TableError, match="fx_N"):
        read_plan(tmp_path / "columns.csv")


def test_the_guide_walks_the_plan_on_the_simulated_rig_and_fits_it(plan_dir, tmp_path):
    """Tare, every hold (one redone, one skipped), the recording, the calibration against the true force, the maps."""
    robot = Robot()
    plan = read_plan(plan_dir / "plan.csv")
    holder: dict = {}
    guide = Guide(plan, robot, tmp_path, lambda n: holder["pipeline"].tare(n))
    pipeline = holder["pipeline"] = LivePipeline(nominal_calibration(robot), sources.guided_arm(robot, guide.want, speed=SPEED),
                                                 source="simulated rig", also=("t_s",))  # fmt: skip
    pipeline.listen(guide)
    with pytest.raises(SailError, match="nothing to redo"):
        guide.redo()
    pipeline.start()
    try:
        _wait(guide, ("move", "hang", "settle"))
        # the nominal map's zero offsets were measured first: the rig's, within the cells' noise
        offsets = session_offsets(robot, NoiseModel(), 1)
        assert guide.tared is not None and np.allclose(guide.tared, offsets, atol=100), (guide.tared, offsets)
        while guide.info()["recorded"] < 2:
            time.sleep(0.01)
        redone = guide.done[-1]
        assert guide.redo() == {"redo": redone + 1} and guide.index == redone
        assert guide.info()["recorded"] == 1 and redone not in guide.records
        while guide.info()["recorded"] < 3:
            time.sleep(0.01)
        skipped = guide.skip()["skipped"]
        info = _wait(guide, ("done", "failed"))
    finally:
        pipeline.stop()
    assert info["phase"] == "done", info
    result = guide.result
    assert result is not None and result.holds == len(plan) - 1 and result.skipped == 1
    assert redone in guide.records and skipped - 1 not in guide.records
    # an ordinary calibration recording: the columns sail calibrate reads, each hold at one pose and one force
    rows = read_clean(result.recording, READING_COLUMNS + REFERENCE_COLUMNS + ("hold",), "the recording")
    assert set(np.unique(rows["hold"]).astype(int)) == {k + 1 for k in guide.records}
    for k in guide.records:
        mine = rows["hold"] == k + 1
        assert np.ptp(rows["fx_N"][mine]) == 0 and rows["fx_N"][mine][0] == pytest.approx(plan.fx[k])
        assert np.ptp(rows["theta1_deg"][mine]) == 0
        assert abs(rows["theta1_deg"][mine][0] - np.degrees(plan.theta1[k])) <= 1e-6  # the rig holds the pose exactly
    assert list(np.genfromtxt(result.recording, delimiter=",", names=True, max_rows=1).dtype.names) == list(RECORDING_COLUMNS)
    # the fitted calibration against the rig's true force, inside the achieved map's bound at every delta
    cal = Calibration.load(result.calibration)
    delta, error = _true_error(cal, robot)
    bound = np.interp(delta, np.degrees(result.achieved.delta), result.achieved.worst_N)
    assert np.all(error <= SIGMAS * bound), (delta[error > SIGMAS * bound], error[error > SIGMAS * bound])
    assert result.fit_rmse_N < 0.05 and result.cv_rmse_N < 0.05
    # the page's maps: achieved from the holds as made, planned from the plan's predicted.csv
    assert result.planned is plan.planned
    shown = guide.info()["result"]["map"]
    assert len(shown["achieved_N"]) == len(shown["planned_N"]) == len(shown["delta_deg"]) == result.achieved.delta.size
    with pytest.raises(SailError, match="ended"):
        guide.skip()


def test_live_calibrate_needs_a_calibration_or_a_plan(plan_dir):
    result = CliRunner().invoke(cli, ["live", "--simulate"])
    assert result.exit_code == 2 and "--calibrate PLAN.csv" in result.output


def test_guided_calibration_in_chromium(plan_dir, tmp_path):
    """``sail live --simulate --calibrate PLAN.csv``: the page shows each hold, redo and skip work, and the end shows
    the maps and the files."""
    from sailforce.live.browser import browser_page, live_process, system_chromium

    if system_chromium() is None:
        pytest.fail("no Chromium on this machine: `make test` installs Debian's (`make chromium`)")
    record = tmp_path / "rec"
    with live_process(["--simulate", "--calibrate", plan_dir / "plan.csv", "--record-dir", record, "--speed", PAGE_SPEED]) as live:
        with browser_page(live.url) as page:
            page.wait_for_selector("#guide-panel:not([hidden])", timeout=WAIT_S * 1e3)
            page.wait_for_function("['move', 'hang', 'settle', 'record'].includes(document.getElementById('guide-phase').textContent)",
                                   timeout=WAIT_S * 1e3)  # fmt: skip
            holds = len(read_plan(plan_dir / "plan.csv"))
            assert re.fullmatch(rf"hold \d+ of {holds} · \d+ recorded", page.text_content("#guide-count"))
            page.wait_for_function("!/ 0 recorded/.test(document.getElementById('guide-count').textContent)", timeout=WAIT_S * 1e3)
            page.click("#guide-redo")
            page.wait_for_function("document.getElementById('message').textContent.startsWith('redoing hold')", timeout=WAIT_S * 1e3)
            page.click("#guide-skip")
            page.wait_for_function("/skipped/.test(document.getElementById('message').textContent)", timeout=WAIT_S * 1e3)
            page.wait_for_function("document.getElementById('guide-phase').textContent === 'done'", timeout=WAIT_S * 1e3)
            text = page.text_content("#guide-result")
            assert text.startswith("calibrated from") and "1 skipped" in page.text_content("#guide-count")
            assert page.is_visible("#guide-map")
            page.screenshot(path=str(tmp_path / "guided.png"), full_page=True)
    names = text.split("wrote ")[1].split(", ")
    assert all((record / name).is_file() for name in names), names
    cal = Calibration.load(record / names[1])
    _, error = _true_error(cal, Robot())
    assert np.sqrt(np.mean(error**2)) < 0.05
