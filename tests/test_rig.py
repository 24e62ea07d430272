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


# ---- live: sail check-rig --serial, frames from a simulated device over pyserial's socket:// port ------------------


def _device_ticks(n: int, periods_us=(12_500, 12_563), flagged=(700, 701, 1500)):
    """A device's ticks at 1 kHz: two HX711s on their own clocks (80 and 79.6 SPS), stamped; settling for the first
    50 ms; the encoder flag on the ``flagged`` ticks."""
    from sailforce.io.frames import Tick

    ticks, next_ready = [], [50_000 + 300, 50_000 + 7_100]
    for i in range(n):
        now = 1_000 * (i + 1)
        new, ready = [False, False], [0, 0]
        for k in (0, 1):
            if next_ready[k] <= now:
                new[k], ready[k] = True, next_ready[k] - now
                next_ready[k] += periods_us[k]
        status = (0x01 if now < 50_000 else 0) | (0x04 if i in flagged else 0)
        ticks.append(Tick(i, 7_000_000 + now, (2**22, 2**20), tuple(new), (120_000 + i, -80_000 - i), tuple(ready), status))
    return ticks


def _serve(frames: list[bytes], per_s: float):
    """A TCP port that sends ``frames`` at ``per_s`` frames a second to the first client: (url, thread)."""
    import socket
    import threading
    import time

    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(30)

    def send():
        with server:
            client, _ = server.accept()
            with client:
                time.sleep(0.5)  # pyserial's open() drops what came before it (reset_input_buffer): wait past it
                start, burst = time.monotonic(), 25
                for k in range(0, len(frames), burst):
                    time.sleep(max(0.0, start + k / per_s - time.monotonic()))
                    client.sendall(b"".join(frames[k : k + burst]))
                time.sleep(6.0)  # held open until the reader's --seconds are up

    thread = threading.Thread(target=send, daemon=True)
    thread.start()
    return f"socket://127.0.0.1:{server.getsockname()[1]}", thread


def test_a_live_port_is_measured_with_its_lost_and_corrupt_frames(tmp_path):
    from sailforce.io.frames import encode_hello, encode_tick

    ticks = _device_ticks(2_400)
    frames = [encode_hello((2**24, 2**24))] + [encode_tick(t) for t in ticks]
    lost, corrupted = (next(i for i in range(start, len(ticks)) if ticks[i].new == (False, False)) for start in (900, 1200))
    frames[1 + lost] = b""  # lost on the way (ticks without a conversion: a lost conversion is a missed one)
    damaged = bytearray(frames[1 + corrupted])
    damaged[4] ^= 0x21
    frames[1 + corrupted] = bytes(damaged)
    url, sender = _serve(frames, per_s=1_000.0)
    out = run("check-rig", "--serial", url, "--seconds", "5", "--adc", "hx711-80", "--record", tmp_path / "rig.csv",
              "--json", tmp_path / "rig.json")  # fmt: skip
    sender.join(10)
    report = json.loads((tmp_path / "rig.json").read_text())
    link = report["link"]
    assert (link["binary"], link["frames"], link["lost"], link["corrupt"]) == (True, 2_398, 2, 1), out.output
    assert 900 < link["rows_per_s"] < 1_100  # 1 kHz of ticks, timed from the first byte to the last
    assert link["bytes_per_s"] == pytest.approx(33 * link["rows_per_s"], rel=0.05)
    rate1, rate2 = (c["rate_Hz"] for c in report["cells"])
    assert rate1 == pytest.approx(1e6 / 12_500, rel=1e-9) and rate2 == pytest.approx(1e6 / 12_563, rel=1e-9)
    assert report["device_status"]["encoder"] == 3 and report["device_status"]["settling"] == 49
    # 2 lost of 2,400 is within 0.1 %; the missed encoder edges are the one problem
    assert out.exit_code == 1 and report["problems"] == ["an encoder missed edges on 3 ticks: its interrupt is too slow "
                                                         "for the shaft's speed"], out.output  # fmt: skip
    assert "2,398 frames, 2 lost, 1 corrupt" in out.output
    rows = list(csv.DictReader(open(tmp_path / "rig.csv")))
    assert len(rows) == 2_400 and sum(r["frame"] == "lost" for r in rows) == 2


def test_a_live_port_too_slow_for_its_tick_is_said(tmp_path):
    from sailforce.io.frames import encode_tick

    frames = [encode_tick(t) for t in _device_ticks(1_000, flagged=())]
    url, sender = _serve(frames, per_s=450.0)  # a 115,200-baud link carries ~349 of 1,000 ticks a second
    out = run("check-rig", "--serial", url, "--seconds", "4", "--adc", "hx711-80")
    sender.join(10)
    assert out.exit_code == 1
    assert "rows/s" in out.output and "the link is too slow for the stream" in out.output, out.output


def test_check_rig_takes_a_recording_or_a_port(tmp_path):
    assert "one of them" in run("check-rig", "--adc", "hx711-80").output
    nothing = run("check-rig", "--serial", "socket://127.0.0.1:9", "--seconds", "0.5", "--adc", "hx711-80")
    assert nothing.exit_code != 0 and "cannot open it" in nothing.output and "Traceback" not in nothing.output
