"""libsail's Python side: `sail export-c`, constants shared with sail.h, and the C stream example against `sail estimate`.

The C library's own tests (analytic, and the shared vectors of
c/tests/make_vectors.py in float and double) run under CTest: `make c-test`.
"""

from __future__ import annotations

import io
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce import SINGULAR_SIN_DELTA, Arm
from sailforce.calibration.file import Calibration
from sailforce.cli import cli
from sailforce.estimate.estimator import DELTA_RANGE_SLACK, STATUS_NAMES
from sailforce.export_c import MAX_HALF_WINDOW, MAX_SECTIONS, MAX_TERMS, ExportError, calibration_header
from sailforce.motion.differentiate import GAP_FACTOR
from sailforce.sensing.maps import AmplitudePhaseCompensator, MatrixCompensator
from sailforce.sensing.polynomial import PolynomialFit
from sailforce.stream.pipeline import estimate_lines

ROOT = Path(__file__).resolve().parents[1]

#: A committed header's numbers may differ from a fresh export in their last digits, with the machine's BLAS and
#: numpy (a dynamic term's shear model is a least-squares fit): 7e-14 relative was measured between two machines.
HEADER_RTOL = 1e-11
_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def _same_header(made: str, committed: str) -> bool:
    """The same text, and the same numbers to :data:`HEADER_RTOL`."""
    if _NUMBER.split(made) != _NUMBER.split(committed):
        return False
    a = np.array([float(v) for v in _NUMBER.findall(made)])
    b = np.array([float(v) for v in _NUMBER.findall(committed)])
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=HEADER_RTOL, atol=1e-300))
HEADER = (ROOT / "c" / "include" / "sail.h").read_text()


def _define(name: str) -> str:
    match = re.search(rf"^#define {name} (\S+)", HEADER, re.MULTILINE)
    assert match, f"sail.h lacks #define {name}"
    return match.group(1)


def test_device_status_bits_match_the_sketch():
    """The frames' status bits mean in Python what the sketch's acquisition sets (sail_acq.h's SAIL_ACQ_*)."""
    from sailforce.io.frames import DEVICE_STATUS, TICK

    header = (ROOT / "c" / "examples" / "arduino" / "sail_hx711" / "sail_acq.h").read_text()
    bits = {int(value, 16): name.lower() for name, value in re.findall(r"^#define SAIL_ACQ_([A-Z]+) (0x[0-9A-F]+)u", header,
                                                                        re.MULTILINE)}  # fmt: skip
    assert bits == DEVICE_STATUS
    frame = (ROOT / "c" / "examples" / "arduino" / "sail_hx711" / "sail_frame.h").read_text()
    assert int(re.search(r"#define SAIL_FRAME_TICK_BYTES (\d+)", frame).group(1)) == TICK.size


def test_header_constants_match_python():
    assert float(_define("SAIL_SINGULAR_SIN_DELTA")) == pytest.approx(SINGULAR_SIN_DELTA, rel=1e-15)
    assert float(_define("SAIL_DELTA_RANGE_SLACK")) == pytest.approx(DELTA_RANGE_SLACK, rel=1e-15)
    assert int(_define("SAIL_MAX_TERMS")) == MAX_TERMS
    assert int(_define("SAIL_MAX_SECTIONS")) == MAX_SECTIONS
    statuses = re.search(r"enum sail_status \{\s*(SAIL_OK.*?)\};", HEADER, re.DOTALL).group(1)
    names = [n.lower().replace("_", "-") for n in re.findall(r"SAIL_([A-Z_]+),?\s*/\*", statuses)]
    assert names == list(STATUS_NAMES)
    assert int(_define("SAIL_MAX_HALF_WINDOW")) == MAX_HALF_WINDOW
    assert float(_define("SAIL_GAP_FACTOR")) == GAP_FACTOR
    from sailforce.estimate import multirate
    from sailforce.export_c import MAX_SINC_ORDER

    assert int(_define("SAIL_MAX_SINC_ORDER")) == MAX_SINC_ORDER == 8  # the ADC model's largest sinc_order
    assert int(_define("SAIL_PERIOD_MEMORY")) == multirate.PERIOD_MEMORY
    assert float(_define("SAIL_MISSED_CONVERSION")) == multirate.MISSED_CONVERSION
    assert float(_define("SAIL_GAP_STEPS")) == multirate.GAP_STEPS
    assert int(_define("SAIL_HISTORY")) == multirate.HISTORY


@pytest.mark.parametrize("variable", ["EXPORT_DEFAULT", "EXPORT_HX711"])
def test_example_headers_are_current(tmp_path, variable):
    """c/examples' headers are what `sail export-c` makes of their calibration.json (the Makefile's EXPORT_*)."""
    line = re.search(rf"^{variable} := (.+)$", (ROOT / "Makefile").read_text(), re.MULTILINE).group(1)
    args = shlex.split(line)
    committed = ROOT / args[args.index("-o") + 1]
    args[args.index("-o") + 1] = str(tmp_path / committed.name)
    args[0] = str(ROOT / args[0])
    result = CliRunner().invoke(cli, ["export-c", *args])
    assert result.exit_code == 0, result.output
    assert _same_header((tmp_path / committed.name).read_text(), committed.read_text()), "run `make c-default`"


def _matrix_cal(terms: int) -> Calibration:
    arm = Arm()
    c = np.zeros((terms, 2, 2))
    c[0] = np.diag([74000.0, 52800.0])
    return Calibration(arm=arm, model=MatrixCompensator(arm, c, (0.3, 2.8)), offsets=(1.0, 2.0), capacity=(4e6, 4e6),
                       delta_range=(0.3, 2.8))


def _seed_cal(amplitude_terms: int) -> Calibration:
    arm = Arm()
    fit = lambda coefficients: PolynomialFit(len(coefficients) - 1, tuple(coefficients), 1.0, 1.0, "cv", 0.0, True)
    model = AmplitudePhaseCompensator(arm, (fit([1e-6] * amplitude_terms), fit([2e-5])), (fit([0.1, 3.0]), fit([-2.0])), (0.3, 2.8))
    return Calibration(arm=arm, model=model, offsets=(1.0, 2.0), capacity=(4e6, 4e6), delta_range=(0.3, 2.8))


def test_export_writes_every_member_of_each_kind():
    matrix = calibration_header(_matrix_cal(3), "cal_m")
    assert "static const sail_calibration cal_m = {" in matrix and ".kind = SAIL_MODEL_MATRIX" in matrix
    assert ".n_terms = 3," in matrix and "SAIL_REAL(74000.0)" in matrix
    assert matrix.count("{{SAIL_REAL(") == MAX_TERMS  # the Chebyshev array is padded to SAIL_MAX_TERMS
    seed = calibration_header(_seed_cal(4), "cal_s")
    assert ".kind = SAIL_MODEL_SEED" in seed
    assert ".amplitude_terms = {4, 1}," in seed and ".phase_terms = {2, 1}," in seed
    for member in ("l2", "l3", "offset", "capacity", "delta_min", "delta_max"):
        assert f".{member} = " in matrix and f".{member} = " in seed


@pytest.mark.parametrize(
    ("cal", "name", "message"),
    [
        (_matrix_cal(MAX_TERMS + 1), "sail_cal", f"order {MAX_TERMS}"),
        (_seed_cal(MAX_TERMS + 1), "sail_cal", f"order {MAX_TERMS}"),
        (_matrix_cal(1), "2cal", "not a C identifier"),
        (_matrix_cal(1), "cal-x", "not a C identifier"),
    ],
)
def test_export_refuses_what_libsail_cannot_hold(cal, name, message):
    with pytest.raises(ExportError, match=message):
        calibration_header(cal, name)


def test_export_cli_errors(tmp_path):
    runner = CliRunner()
    missing = runner.invoke(cli, ["export-c", str(tmp_path / "none.json")])
    assert missing.exit_code == 1 and "no such calibration file" in missing.output
    _matrix_cal(2).save(tmp_path / "cal.json")
    no_rate = runner.invoke(cli, ["export-c", str(tmp_path / "cal.json"), "--lowpass-hz", "5"])
    assert no_rate.exit_code == 2 and "--sample-rate-Hz" in no_rate.output
    bad_name = runner.invoke(cli, ["export-c", str(tmp_path / "cal.json"), "--name", "a b", "-o", str(tmp_path / "x.h")])
    assert bad_name.exit_code == 1 and "not a C identifier" in bad_name.output and not (tmp_path / "x.h").exists()


@pytest.fixture(scope="module")
def stream_example(tmp_path_factory):
    """The host example sail_stream, built in double with the default calibration."""
    assert shutil.which("cmake") and (shutil.which("cc") or shutil.which("gcc")), "make test needs cmake and a C compiler"
    build = tmp_path_factory.mktemp("libsail")
    subprocess.run(["cmake", "-S", str(ROOT / "c"), "-B", str(build), "-DSAIL_DOUBLE=ON", "-DSAIL_BUILD_TESTS=OFF"],
                   check=True, capture_output=True)  # fmt: skip
    subprocess.run(["cmake", "--build", str(build)], check=True, capture_output=True)
    return build / "examples" / "sail_stream"


def test_stream_example_matches_sail_estimate(stream_example):
    """Line for line, the C example and `sail estimate -` give the same statuses and forces (double build)."""
    cal = Calibration.load(ROOT / "c" / "examples" / "calibration.json")
    rng = np.random.default_rng(3)
    lines = ["time_s,theta1_deg,theta2_deg,load1,load2"]
    for i in range(200):
        theta2 = rng.uniform(-40, 40)
        loads = np.asarray(cal.offsets) + rng.uniform(-0.8, 0.8, 2) * np.asarray(cal.capacity)
        lines.append(f"{i * 0.0125:.4f},{theta2 + rng.uniform(3, 177):.4f},{theta2:.4f},{loads[0]:.0f},{loads[1]:.0f}")
    lines += ["9.1,1,0,5,5", "9.2,90,0,1e12,0", "9.3,nan,0,1,1", "9.4,90,x,1,1", "9.5,90,0", "", "9.6,90,0,inf,1"]
    text = "\n".join(lines) + "\n"
    c_out = subprocess.run([str(stream_example)], input=text, capture_output=True, text=True, check=True).stdout
    py_out = io.BytesIO()
    estimate_lines(cal, iter(text.encode().splitlines(keepends=True)), lambda: py_out)
    c_rows = [r.split(",") for r in c_out.splitlines()]
    py_rows = [r.split(",") for r in py_out.getvalue().decode().splitlines()]
    assert len(c_rows) == len(py_rows) == len(lines)
    assert c_rows[0] == py_rows[0]
    statuses = {r[-1] for r in py_rows[1:]}
    assert statuses == set(STATUS_NAMES[:5])  # the static statuses: the stream example has no dynamic term
    for c_row, py_row in zip(c_rows[1:], py_rows[1:]):
        assert c_row[:-5] == py_row[:-5] and c_row[-1] == py_row[-1]
        for c_field, py_field in zip(c_row[-5:-1], py_row[-5:-1]):
            assert (c_field == "") == (py_field == "")
            if c_field:
                assert float(c_field) == pytest.approx(float(py_field), rel=1e-8, abs=1e-9)


def test_df2t_export_runs_cmsis_difference_equation_like_scipy():
    """<name>_lowpass_df2T, run through CMSIS-DSP's documented df2T recursion, filters as scipy's sosfilt does."""
    from scipy import signal

    from sailforce.estimate.filters import LowPass

    lowpass = LowPass(10.0, 200.0, 4)
    header = calibration_header(_matrix_cal(1), "cal_m", lowpass=lowpass)
    stages = int(re.search(r"#define CAL_M_LOWPASS_STAGES (\d+)", header).group(1))
    body = re.search(r"cal_m_lowpass_df2T\[5 \* \d+\] = \{(.*)\};", header).group(1)
    coefficients = np.array([float(v) for v in re.findall(r"SAIL_REAL\(([^)]*)\)", body)]).reshape(stages, 5)
    assert stages == 2
    x = np.random.default_rng(0).normal(size=400) + 3.0
    y = x.copy()
    for b0, b1, b2, a1, a2 in coefficients:  # arm_biquad_cascade_df2T_f32, stage by stage, zero state
        d1 = d2 = 0.0
        out = np.empty_like(y)
        for n, xn in enumerate(y):
            out[n] = b0 * xn + d1
            d1 = b1 * xn + a1 * out[n] + d2
            d2 = b2 * xn + a2 * out[n]
        y = out
    np.testing.assert_allclose(y, signal.sosfilt(np.asarray(lowpass.sos), x), rtol=1e-12, atol=1e-12)
