"""Differential tests: the same CSV bytes through file mode, stream mode and the Python API give the same rows.

File mode reads in chunks (random sizes here, so that chunk edges fall
anywhere and Arrow's fast parser and the line-by-line parser both run);
stream mode reads line by line.  Their output must be byte-identical, hold
one row per input line, and carry the statuses that
:meth:`Calibration.estimate` gives for the values the reader parsed.
"""

from __future__ import annotations

import io
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sailforce.io.tables as tables
import sailforce.stream.output as output
from sailforce.calibration.file import Calibration
from sailforce.estimate.estimator import INVALID, STATUS_NAMES
from sailforce.io.tables import READING_COLUMNS, read_chunks, read_line
from sailforce.kinematics import sin_delta_from_trig
from sailforce.stream.pipeline import estimate_lines, stream_estimate

ROOT = Path(__file__).resolve().parents[1]
CAL_PATH = ROOT / "c" / "examples" / "calibration.json"
CAL = Calibration.load(CAL_PATH)
HEADER = b"theta1_deg,theta2_deg,load1,load2,note"


@contextmanager
def chunk_bytes(size: int):
    saved, tables.CHUNK_BYTES = tables.CHUNK_BYTES, size
    try:
        yield
    finally:
        tables.CHUNK_BYTES = saved


_number = st.one_of(
    st.integers(-200, 200).map(str),
    st.floats(-1e7, 1e7, allow_nan=False).map(repr),
    st.sampled_from(["", "nan", "inf", "-Infinity", " 12 ", "1e400", "1_0", "0x1", "+.5", "1.", "abc"]),
)
_junk = st.text(alphabet=st.sampled_from(list('ab ,"\r\x00é;\t1.')), max_size=12).map(str.encode) | st.sampled_from(
    [b"\xff\xfe", b'"unclosed', b'"a,""b"', b"x" * (tables.MAX_FIELD_CHARS + 5)])  # fmt: skip


@st.composite
def csv_bytes(draw) -> bytes:
    """A header and up to 30 lines: mostly readings, some ragged, blank, quoted, junk or over-long."""
    end = draw(st.sampled_from([b"\n", b"\r\n"]))
    lines = [draw(st.sampled_from([b"", b"\xef\xbb\xbf"])) + HEADER]
    for _ in range(draw(st.integers(1, 30))):
        kind = draw(st.sampled_from(["reading"] * 6 + ["ragged", "blank", "junk"]))
        if kind == "blank":
            lines.append(b"")
        elif kind == "junk":
            lines.append(draw(_junk))
        else:
            fields = [draw(_number).encode() for _ in range(4)] + [draw(_junk)]
            if kind == "ragged":
                fields = fields[: draw(st.integers(1, 6))] + [b"extra"] * draw(st.integers(0, 2))
            lines.append(b",".join(fields))
    return end.join(lines) + draw(st.sampled_from([end, b""]))


def _file_mode(data: bytes, folder: Path, size: int) -> bytes:
    (folder / "in.csv").write_bytes(data)
    with chunk_bytes(size):
        stream_estimate(CAL, folder / "in.csv", folder / "out.csv")
    return (folder / "out.csv").read_bytes()


def _stream_mode(data: bytes) -> bytes:
    source, sink = io.BytesIO(data), io.BytesIO()
    estimate_lines(CAL, iter(lambda: read_line(source), b""), lambda: sink)
    return sink.getvalue()


def _api_statuses(folder: Path, size: int) -> np.ndarray:
    with chunk_bytes(size):
        chunks = list(read_chunks(folder / "in.csv", READING_COLUMNS))
    values = {n: np.concatenate([c.values[n] for c in chunks]) for n in READING_COLUMNS}
    malformed = np.concatenate([c.malformed for c in chunks])
    _, _, status = CAL.estimate(np.radians(values["theta1_deg"]), np.radians(values["theta2_deg"]),
                                values["load1"], values["load2"])  # fmt: skip
    status[malformed] = INVALID
    return status


def _data_lines(data: bytes) -> int:
    body = data.split(b"\n", 1)[1] if b"\n" in data else b""
    return body.count(b"\n") + (bool(body) and not body.endswith(b"\n"))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=csv_bytes(), size=st.sampled_from([16, 64, 300, 4096, 1 << 20]))
def test_file_stream_and_api_agree(tmp_path_factory, data, size):
    folder = tmp_path_factory.mktemp("diff")
    n_lines = _data_lines(data)
    if n_lines == 0:
        return  # a header alone: both modes refuse it (tests/test_corpus.py)
    from_file = _file_mode(data, folder, size)
    from_stream = _stream_mode(data)
    assert from_file == from_stream
    rows = from_file.split(b"\n")
    assert rows[-1] == b"" and len(rows) - 2 == n_lines  # the header, one row per line, the final line end
    statuses = [row.rsplit(b",", 1)[1].decode() for row in rows[1:-1]]
    assert statuses == [STATUS_NAMES[s] for s in _api_statuses(folder, size)]


def test_cli_file_and_stdin_give_the_same_bytes(tmp_path):
    """The real command: `sail estimate FILE -o OUT` and `sail estimate - < FILE` write the same bytes."""
    tricky = b"\r\n".join([
        b"\xef\xbb\xbf" + HEADER,
        b"90,0,-41809,76266,plain", b'90,0,-41809,76266,"quoted, with comma"', b"", b"90,0", b'80,0,1,2,"open',
        b"80,0,1\r2,3,cr", b"85,0,-41809,76266,\xff\xfebad utf8", b"30,30,1,2,singular", b"90,0,9e9,0,saturated",
        b"175,0,-42809,76765,extrapolated", b"90,0,-41809,76266,x" + b"y" * 140_000, b"91,0,-41809,76266,last",
    ])  # fmt: skip
    (tmp_path / "in.csv").write_bytes(tricky)
    sail = Path(sys.executable).parent / "sail"
    file_mode = subprocess.run([str(sail), "estimate", "--calibration", str(CAL_PATH), "in.csv", "-o", "out.csv"],
                               cwd=tmp_path, capture_output=True)  # fmt: skip
    stdin_mode = subprocess.run([str(sail), "estimate", "--calibration", str(CAL_PATH), "-"], cwd=tmp_path,
                                input=tricky, capture_output=True)  # fmt: skip
    assert file_mode.returncode == stdin_mode.returncode == 0, (file_mode.stderr, stdin_mode.stderr)
    assert (tmp_path / "out.csv").read_bytes() == stdin_mode.stdout
    statuses = [row.rsplit(b",", 1)[1] for row in stdin_mode.stdout.split(b"\n")[1:-1]]
    assert statuses == [b"ok", b"ok", b"invalid", b"invalid", b"ok", b"invalid", b"ok", b"singular", b"saturated",
                        b"extrapolated", b"invalid", b"ok"]  # fmt: skip


def test_one_singularity_verdict_at_the_threshold():
    """Poses within 1e-12 of the threshold get one verdict from every entry point (there were 54 disagreements in 200,000)."""
    from sailforce import SINGULAR_SIN_DELTA, Arm
    from sailforce.estimate.estimator import SINGULAR, estimate_force
    from sailforce.sensing.maps import TorqueScale
    from sailforce.statics import end_effector_force, singular_poses
    from sailforce.sweep import check_not_singular

    rng = np.random.default_rng(15)
    n = 200_000
    theta2 = rng.uniform(-np.pi, np.pi, n)
    delta = np.arcsin(SINGULAR_SIN_DELTA) + rng.uniform(-1e-12, 1e-12, n)
    delta = np.where(rng.uniform(size=n) < 0.5, delta, np.pi - delta)
    theta1 = theta2 + delta
    trig = np.sin(theta1), np.cos(theta1), np.sin(theta2), np.cos(theta2)
    expected = np.abs(sin_delta_from_trig(*trig)) < SINGULAR_SIN_DELTA
    assert 0.2 < expected.mean() < 0.8  # the sample straddles the threshold
    arm = Arm()
    _, _, statics_mask = end_effector_force(arm, theta1, theta2, 1.0, 1.0, on_singular="mask")
    _, _, compensation_mask = estimate_force(TorqueScale(arm, (1.0, 1.0)), theta1, theta2, 1.0, 1.0, on_singular="mask")
    _, _, status = CAL.estimate(theta1, theta2, CAL.offsets[0], CAL.offsets[1])
    np.testing.assert_array_equal(singular_poses(theta1, theta2), expected)
    np.testing.assert_array_equal(statics_mask, expected)
    np.testing.assert_array_equal(compensation_mask, expected)
    np.testing.assert_array_equal(status == SINGULAR, expected)
    check_not_singular(theta1[~expected], theta2[~expected])
    with pytest.raises(ValueError, match="singular pose"):
        check_not_singular(theta1[expected][:1], theta2[expected][:1])


_ROW_VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.0, -0.0, 1e-300, 5e-324, 1e16, 123456789.0]))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 3 * output.SMALL_BLOCK_ROWS), columns=st.integers(0, 7), data=st.data())
def test_a_few_rows_are_joined_as_arrow_joins_many(n, columns, data):
    """csv_rows joins a live block's few rows in Python and a file's many through Arrow: the same bytes either way,
    for any numbers (NaN and infinities, signed zeros, subnormals, large and exact values), statuses and lines."""
    lines = pa.array(data.draw(st.lists(st.binary(max_size=12).filter(lambda b: b"\n" not in b), min_size=n, max_size=n)),
                     pa.binary())  # fmt: skip
    values = {f"c{k}": np.array(data.draw(st.lists(_ROW_VALUES, min_size=n, max_size=n))) for k in range(columns)}
    status = np.array(data.draw(st.lists(st.integers(0, len(STATUS_NAMES) - 1), min_size=n, max_size=n)), np.int8)
    saved = output.SMALL_BLOCK_ROWS
    try:
        output.SMALL_BLOCK_ROWS = 0
        by_arrow = output.csv_rows(lines, values, status)
        output.SMALL_BLOCK_ROWS = n
        by_python = output.csv_rows(lines, values, status)
    finally:
        output.SMALL_BLOCK_ROWS = saved
    assert by_python == by_arrow
    assert by_python.count(b"\n") == n  # one row a line
