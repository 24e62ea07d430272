"""``sail calibrate``, ``sail tare`` and ``sail estimate`` end to end; chunking, filtering, formats, streams."""

from __future__ import annotations

import csv
import io
import json
import os
import threading

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import signal

from sailforce.calibration.file import Calibration
from sailforce.cli import cli
from sailforce.estimate.filters import FilterError, LowPass
from sailforce.io.tables import READING_COLUMNS, read_chunks
from sailforce.stream.pipeline import estimate_lines, stream_estimate

from .test_calibration import calibration_set


def run(*args, input=None):
    return CliRunner().invoke(cli, [str(a) for a in args], input=input, catch_exceptions=False)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cal")
    t1, t2, fx, fy, counts, offsets = calibration_set()
    with open(d / "cal.csv", "w") as f:
        f.write("sample_id,theta1_deg,theta2_deg,load1,load2,fx_N,fy_N\n")
        for i in range(t1.size):
            f.write(f"{i},{np.degrees(t1[i]):.17g},{np.degrees(t2[i]):.17g},{counts[i, 0]:.0f},{counts[i, 1]:.0f},"
                    f"{fx[i]:.17g},{fy[i]:.17g}\n")
    result = run("calibrate", d / "cal.csv", "-o", d / "cal.json")
    assert result.exit_code == 0, result.output
    rows = [("0.00", "80", "10", f"{offsets[0] + 1000:.0f}", f"{offsets[1] - 500:.0f}"),
            ("0.01", "80", "80", "0", "0"),            # singular
            ("0.02", "80", "10", "1e9", "0"),          # saturated
            ("0.03", "175", "0", f"{offsets[0]:.0f}", f"{offsets[1]:.0f}"),  # extrapolated (delta 175)
            ("0.04", "80", "10", "abc", "0"),          # invalid: not a number
            ("0.05", "80", "", "0", "0"),              # invalid: missing field
            ("0.06", "80", "10", "nan", "0"),          # invalid: non-finite
            ("0.07", "80", "10", "0"),                 # invalid: short row
            ("0.08", "80", "10", f"{offsets[0]:.0f}", f"{offsets[1]:.0f}")]  # fmt: skip
    (d / "in.csv").write_text("time_s,theta1_deg,theta2_deg,load1,load2\n" + "".join(",".join(r) + "\n" for r in rows))
    return d, offsets


def _read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_estimate_statuses_and_pass_through(files):
    d, _ = files
    result = run("estimate", "--calibration", d / "cal.json", d / "in.csv", "-o", d / "out.csv")
    assert result.exit_code == 0, result.output
    rows = _read(d / "out.csv")
    assert [r["status"] for r in rows] == ["ok", "singular", "saturated", "extrapolated", "invalid", "invalid",
                                           "invalid", "invalid", "ok"]  # fmt: skip
    assert [r["time_s"] for r in rows] == [f"0.0{i}" for i in range(9)]
    assert rows[-1]["fx_N"] not in ("",) and abs(float(rows[-1]["force_N"])) < 0.05  # tared zero: no force
    assert rows[1]["fx_N"] == "" and rows[4]["fx_N"] == ""
    assert "9 rows: ok 2, singular 1, saturated 1, extrapolated 1, invalid 4" in result.output


def test_chunked_equals_whole_and_parquet(files, tmp_path):
    d, offsets = files
    cal = Calibration.load(d / "cal.json")
    rng = np.random.default_rng(0)
    n = 5000
    lines = ["theta1_deg,theta2_deg,load1,load2,tag"]
    for i in range(n):
        lines.append(f"{rng.uniform(30, 150):.4f},{rng.uniform(-10, 10):.4f},{rng.integers(-4e5, 4e5)},{rng.integers(-4e5, 4e5)},t{i}")
    (tmp_path / "big.csv").write_text("\n".join(lines) + "\n")
    import sailforce.io.tables as tables

    whole = stream_estimate(cal, tmp_path / "big.csv", tmp_path / "whole.csv")
    small = tables.CHUNK_BYTES
    try:
        tables.CHUNK_BYTES = 4096  # many chunks, splitting lines anywhere
        chunks = list(read_chunks(tmp_path / "big.csv", READING_COLUMNS, chunk_bytes=4096))
        assert len(chunks) > 20 and sum(c.table.num_rows for c in chunks) == n
    finally:
        tables.CHUNK_BYTES = small
    assert whole["ok"] + whole["extrapolated"] + whole["saturated"] == n
    out = _read(tmp_path / "whole.csv")
    assert [r["tag"] for r in out] == [f"t{i}" for i in range(n)]
    stream_estimate(cal, tmp_path / "big.csv", tmp_path / "out.parquet")
    table = pq.read_table(tmp_path / "out.parquet")
    np.testing.assert_allclose(table.column("fx_N").to_numpy(), [float(r["fx_N"]) for r in out], rtol=1e-12)
    pq.write_table(pa.table({"theta1_deg": [80.0], "theta2_deg": [10.0], "load1": [offsets[0]], "load2": [offsets[1]]}),
                   tmp_path / "in.parquet")  # fmt: skip
    counts = stream_estimate(cal, tmp_path / "in.parquet", tmp_path / "o2.csv")
    assert counts["ok"] == 1


def test_filter_state_carries_across_chunks():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(1000, 2)) + 5.0
    valid = rng.uniform(size=1000) > 0.05
    whole = LowPass(10.0, 200.0, 3).process(x, valid)
    chunked = LowPass(10.0, 200.0, 3)
    parts = [chunked.process(x[a:b], valid[a:b]) for a, b in ((0, 1), (1, 333), (333, 700), (700, 1000))]
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=1e-13, atol=1e-13)
    # Reference: scipy over the valid samples alone, started at the first sample's steady state.
    sos = signal.butter(3, 10.0, fs=200.0, output="sos")
    zi = signal.sosfilt_zi(sos)[:, :, None] * x[valid][0]
    reference = signal.sosfilt(sos, x[valid], axis=0, zi=zi)[0]
    np.testing.assert_allclose(whole[valid], reference, rtol=1e-13)
    assert np.isnan(whole[~valid]).all()
    with pytest.raises(FilterError):
        LowPass(150.0, 200.0)


def test_estimate_with_lowpass_cli(files):
    d, _ = files
    result = run("estimate", "--calibration", d / "cal.json", d / "in.csv", "-o", d / "f.csv", "--lowpass-hz", "5",
                 "--sample-rate-hz", "100")  # fmt: skip
    assert result.exit_code == 0 and len(_read(d / "f.csv")) == 9
    bad = run("estimate", "--calibration", d / "cal.json", d / "in.csv", "-o", d / "g.csv", "--lowpass-hz", "5")
    assert bad.exit_code == 2 and "--sample-rate-Hz" in bad.output


def test_tare(files):
    d, offsets = files
    rng = np.random.default_rng(4)
    lines = ["load1,load2"] + [f"{offsets[0] + 300 + rng.normal(0, 50):.0f},{offsets[1] - 200 + rng.normal(0, 50):.0f}" for _ in range(400)]
    (d / "noload.csv").write_text("\n".join(lines) + "\n")
    result = run("tare", d / "cal.json", d / "noload.csv", "-o", d / "cal2.json")
    assert result.exit_code == 0, result.output
    new = Calibration.load(d / "cal2.json")
    np.testing.assert_allclose(new.offsets, [offsets[0] + 300, offsets[1] - 200], atol=15)  # 3 standard errors of 50/20
    assert "spread" in result.output and "warning" not in result.output
    noisy = ["load1,load2"] + [f"{offsets[0] + rng.normal(0, 1e5):.0f},{offsets[1]:.0f}" for _ in range(50)]
    (d / "noisy.csv").write_text("\n".join(noisy) + "\n")
    assert "warning" in run("tare", d / "cal.json", d / "noisy.csv", "-o", d / "cal3.json").output


@pytest.mark.parametrize("content, message", [
    ("theta1_deg,load1\n1,2\n", "missing column"),
    ("theta1_deg,theta2_deg,load1,load2,fx_N,fy_N\n80,10,1,2,3\n", "line 2"),
])  # fmt: skip
def test_calibrate_refuses_bad_tables(tmp_path, content, message):
    (tmp_path / "d.csv").write_text(content)
    result = run("calibrate", tmp_path / "d.csv", "-o", tmp_path / "c.json")
    assert result.exit_code == 1 and message in result.output and not (tmp_path / "c.json").exists()


def test_estimate_refuses_tampered_calibration(files, tmp_path):
    d, _ = files
    data = json.loads((d / "cal.json").read_text())
    data["offsets"][0] += 1
    (tmp_path / "t.json").write_text(json.dumps(data))
    result = run("estimate", "--calibration", tmp_path / "t.json", d / "in.csv", "-o", tmp_path / "o.csv")
    assert result.exit_code == 1 and "checksum" in result.output and not (tmp_path / "o.csv").exists()


def test_live_stdin(files):
    d, _ = files
    text = (d / "in.csv").read_text()
    result = run("estimate", "--calibration", d / "cal.json", "-", input=text)
    assert result.exit_code == 0
    out_rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert [r["status"] for r in out_rows][:4] == ["ok", "singular", "saturated", "extrapolated"]
    assert len(out_rows) == 9


def test_live_serial_through_pty(files):
    """pyserial reads a pseudo-terminal; each estimate appears as its line arrives."""
    import serial
    d, offsets = files
    cal = Calibration.load(d / "cal.json")
    master, slave = os.openpty()
    import tty

    tty.setraw(slave)
    port = serial.Serial(os.ttyname(slave), timeout=2)
    out = io.BytesIO()
    seen = []

    def lines():
        while True:
            raw = port.readline()
            if not raw:
                return
            seen.append(out.getvalue().count(b"\n"))
            yield raw

    os.write(master, b"theta1_deg,theta2_deg,load1,load2\n")
    worker = threading.Thread(target=lambda: estimate_lines(cal, lines(), lambda: out))
    worker.start()
    for _ in range(3):
        os.write(master, f"80,10,{offsets[0]:.0f},{offsets[1]:.0f}\n".encode())
    worker.join(timeout=10)
    port.close()
    os.close(master)
    os.close(slave)
    rows = list(csv.DictReader(io.StringIO(out.getvalue().decode())))
    assert [r["status"] for r in rows] == ["ok"] * 3
    # Output lines already written as each input line arrives: none at the header, then the header
    # and every earlier estimate, so nothing waits for a buffer to fill.
    assert seen == [0, 1, 2, 3]


_field = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(alphabet="0123456789.-eE xa", max_size=6))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.lists(_field, min_size=3, max_size=6), min_size=1, max_size=40))
def test_csv_reader_never_crashes_or_loses_rows(tmp_path_factory, rows):
    path = tmp_path_factory.mktemp("fuzz") / "f.csv"
    body = [",".join(f.replace(",", "") for f in r) for r in rows]
    body = [line for line in body if line.strip()]
    path.write_text("theta1_deg,theta2_deg,load1,load2,extra\n" + "".join(line + "\n" for line in body))
    chunks = list(read_chunks(path, READING_COLUMNS, chunk_bytes=64))
    assert sum(c.table.num_rows for c in chunks) == len(body)
    values = {k: np.concatenate([c.values[k] for c in chunks]) for k in READING_COLUMNS}
    malformed = np.concatenate([c.malformed for c in chunks])
    for i, line in enumerate(body):
        fields = line.split(",")
        if len(fields) == 5:
            assert not malformed[i]
            for k, name in enumerate(READING_COLUMNS):
                try:
                    expected = float(fields[k])
                except ValueError:
                    expected = np.nan
                got = values[name][i]
                assert (np.isnan(expected) and np.isnan(got)) or got == expected
        else:
            assert malformed[i]
