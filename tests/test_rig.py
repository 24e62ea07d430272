"""sail check-rig (sailforce.rig): a simulated rig's recording is fit; each fault put into it is found and said."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce.adc import PRESETS
from sailforce.cli import cli
from sailforce.rig import check_rig
from sailforce.rig.check import FULL_SCALE_CODE


def run(*args):
    return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """Two HX711s at 80 SPS, one 1 % fast and one slow as the simulation draws them, 1 kHz ticks: (path, rows)."""
    d = tmp_path_factory.mktemp("rig")
    assert run("simulate-motion", "--session", "task", "--reaches", "2", "--adc", "hx711-80", "-o", d / "rec.csv").exit_code == 0
    with open(d / "rec.csv") as f:
        rows = list(csv.reader(f))
    return d / "rec.csv", rows


def _write(path, rows):
    path.write_text("".join(",".join(r) + "\n" for r in rows))
    return path


def test_a_simulated_rig_is_fit_and_its_clocks_are_measured(recording, tmp_path):
    path, rows = recording
    header = rows[0]
    data = np.array([[float(v) if v else np.nan for v in r] for r in rows[1:]])
    result = check_rig(path, PRESETS["hx711-80"])
    assert result.fit, result.problems
    assert result.tick_Hz == pytest.approx(1000.0, rel=1e-9) and result.gaps == result.steps_back == 0
    for i, cell in enumerate(result.cells):
        ready = data[:, header.index(f"load{i + 1}_t_s")]
        ready = ready[np.isfinite(ready)]
        assert cell.conversions == ready.size and cell.stamped
        assert cell.rate_Hz == pytest.approx(1 / np.median(np.diff(ready)), rel=1e-12)  # an independent median
        assert abs(cell.rate_error) <= PRESETS["hx711-80"].rate_tolerance and cell.missed == cell.saturated == 0
    assert result.skew_drift == pytest.approx(result.cells[1].rate_Hz / result.cells[0].rate_Hz - 1)
    assert abs(result.skew_s) <= 0.5 / 80
    cli_run = run("check-rig", path, "--adc", "hx711-80", "--json", tmp_path / "rig.json")
    assert cli_run.exit_code == 0 and "fit" in cli_run.output
    saved = json.loads((tmp_path / "rig.json").read_text())
    assert saved["fit"] is True and saved["cells"][0]["conversions"] == result.cells[0].conversions


def test_each_fault_is_found_and_said(recording, tmp_path):
    path, rows = recording
    header, body = rows[0], [list(r) for r in rows[1:]]
    load1, t_col, theta1 = header.index("load1"), header.index("t_s"), header.index("theta1_deg")
    conversions = [i for i, r in enumerate(body) if r[load1]]
    faults = {}
    dropped = [list(r) for r in body]
    for i in conversions[::10]:  # every tenth conversion of cell 1 never read
        dropped[i][load1] = ""
        dropped[i][header.index("load1_t_s")] = ""
    faults["missed"] = (dropped, "cell 1 missed")
    jumped = [list(r) for r in body]
    jumped[500][theta1] = repr(float(jumped[500][theta1]) + 10.0)  # a glitch of 10 degrees for one tick
    faults["jump"] = (jumped, "angle jumps faster than")
    saturated = [list(r) for r in body]
    for i in conversions[:5]:
        saturated[i][load1] = str(FULL_SCALE_CODE)
    faults["saturated"] = (saturated, "cell 1 saturated 5 times")
    rng = np.random.default_rng(0)
    jittery = [list(r) for r in body]
    for r in jittery:
        r[t_col] = repr(float(r[t_col]) + rng.uniform(-3e-4, 3e-4))
    faults["jitter"] = (jittery, "the ticks wander")
    backwards = [list(r) for r in body]
    backwards[700][t_col] = repr(float(backwards[699][t_col]) - 0.01)
    faults["back"] = (backwards, "t_s steps back")
    for name, (fault_rows, said) in faults.items():
        bad = _write(tmp_path / f"{name}.csv", [header, *fault_rows])
        result = run("check-rig", bad, "--adc", "hx711-80")
        assert result.exit_code == 1, (name, result.output)
        assert said in " ".join(result.output.split()), (name, result.output)
    wrong = run("check-rig", path, "--adc", "hx711-10")  # a chip at the other rate-pin setting
    assert wrong.exit_code == 1 and "from hx711-10's 10 Hz" in " ".join(wrong.output.split())


def test_bad_input_gets_a_one_line_error(tmp_path):
    (tmp_path / "no_time.csv").write_text("theta1_deg,theta2_deg,load1,load2\n80,10,1,2\n")
    result = CliRunner().invoke(cli, ["check-rig", str(tmp_path / "no_time.csv"), "--adc", "hx711-80"])
    assert result.exit_code == 1 and "needs t_s" in result.output and "Traceback" not in result.output
    result = CliRunner().invoke(cli, ["check-rig", str(tmp_path / "no_time.csv"), "--adc", "hx711-80",
                                      "--calibration", str(tmp_path / "c.json")])  # fmt: skip
    assert result.exit_code == 2 and "not both" in result.output
