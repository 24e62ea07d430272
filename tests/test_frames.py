"""The rig's binary frames (sailforce.io.frames): the CRC and COBS as specified, and frames with a lost and a corrupt
one through a pseudo-terminal into `sail estimate --serial`: the bytes of the file path on the same samples, the
losses accounted for."""

from __future__ import annotations

import array
import csv
import fcntl
import os
import subprocess
import sys
import termios
import threading
import time
import tty

import pytest

from sailforce.io.frames import COLUMNS, FrameDecoder, Tick, crc16, encode_hello, encode_tick


def test_the_crc_is_ccitt_false_and_frames_hold_no_zero():
    assert crc16(b"123456789") == 0x29B1  # the CRC catalogue's check value for CRC-16/CCITT-FALSE
    frame = encode_tick(Tick(1, 2, (0, -1), (True, False), (0, 0), (0, 0)))
    assert frame.endswith(b"\x00") and b"\x00" not in frame[:-1]


def test_the_decoder_counts_what_it_cannot_read_and_unwraps_time():
    ticks = [Tick(65534 + i, (2**32 - 1500 + 1000 * i) % 2**32, (2**22 * i, 0), (i % 2 == 0, True), (i, -i), (-100, 0))
             for i in range(5)]  # fmt: skip
    data = [encode_tick(t) for t in ticks]
    data[2] = b""  # lost
    damaged = bytearray(data[3])
    damaged[5] ^= 0xFF  # corrupt
    decoder = FrameDecoder()
    lines = decoder.feed(b"junk of a frame joined late\x00" + encode_hello((2**22, 2**22)) + b"".join(data[:3]) + bytes(damaged) + data[4])
    rows = list(csv.DictReader([decoder.header().decode(), *(line.decode() for line in lines)]))
    assert [r["frame"] for r in rows] == ["ok", "ok", "lost", "lost", "resync"]
    assert (decoder.frames, decoder.lost, decoder.corrupt) == (3, 2, 1)
    assert float(rows[1]["t_s"]) == pytest.approx((2**32 - 500) * 1e-6) and float(rows[4]["t_s"]) == pytest.approx((2**32 + 2500) * 1e-6)
    assert float(rows[1]["theta1_deg"]) == pytest.approx(360.0)  # 2^22 counts of a 2^22-count turn (the hello's)
    assert rows[0]["load1"] == "0.0" and rows[1]["load1"] == ""
    assert float(rows[0]["load1_t_s"]) == pytest.approx(float(rows[0]["t_s"]) - 1e-4)


def test_frames_through_a_serial_port_give_the_file_mode_s_bytes(cals, tmp_path):
    d, static, _ = cals
    o1, o2 = (int(x) for x in static.offsets)
    n, dropped, corrupted = 300, 120, 200
    ticks = [Tick(i, 5_000_000 + 1000 * i, (int(80 / 360 * 2**24) + 40 * i, int(10 / 360 * 2**24)), (True, i % 3 == 0),
                  (o1 + 900 * i, o2 - 400 * i), (-250, -10)) for i in range(n)]  # fmt: skip
    frames = [encode_tick(t) for t in ticks]
    frames[dropped] = b""
    damaged = bytearray(frames[corrupted])
    damaged[3] ^= 0x55
    frames[corrupted] = bytes(damaged)
    data = encode_hello((2**24, 2**24)) + b"".join(frames)
    # the same samples as a file, written here from the ticks themselves (not by the decoder)
    lines = [",".join(COLUMNS)]
    for i, t in enumerate(ticks):
        if i in (dropped, corrupted):
            lines.append(",,,,,,,,lost")
            continue
        s = t.time_us * 1e-6
        loads = [repr(float(t.load[k])) if t.new[k] else "" for k in (0, 1)]
        ready = [repr(s + t.ready_us[k] * 1e-6) if t.new[k] else "" for k in (0, 1)]
        lines.append(",".join([repr(s), repr(360.0 * t.theta_counts[0] / 2**24), repr(360.0 * t.theta_counts[1] / 2**24),
                               *loads, *ready, "0", "resync" if i == corrupted + 1 else "ok"]))  # fmt: skip
    (tmp_path / "same.csv").write_text("\n".join(lines) + "\n")
    sail = [sys.executable, "-c", "from sailforce.cli import main; main()", "estimate", "--calibration", str(d / "static.json")]
    assert subprocess.run([*sail, str(tmp_path / "same.csv"), "-o", str(tmp_path / "file.csv")], capture_output=True).returncode == 0
    master, slave = os.openpty()
    tty.setraw(slave)
    process = subprocess.Popen([*sail, "--serial", os.ttyname(slave), "-o", str(tmp_path / "serial.csv")],
                               stderr=subprocess.PIPE, text=True)  # fmt: skip

    def opened() -> bool:  # pyserial flushes what came before its open(): wait until the command holds the port
        fds = f"/proc/{process.pid}/fd"
        try:
            return any(os.path.realpath(os.path.join(fds, fd)) == os.ttyname(slave) for fd in os.listdir(fds))
        except OSError:
            return False

    def send() -> None:
        deadline = time.monotonic() + 30
        while not opened() and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.2)  # and past its flush
        for start in range(0, len(data), 512):
            os.write(master, data[start : start + 512])
            time.sleep(0.005)
        waiting = array.array("i", [1])
        while waiting[0]:
            fcntl.ioctl(slave, termios.FIONREAD, waiting)
            time.sleep(0.01)
        time.sleep(0.2)
        os.close(master)  # the hang-up ends the stream

    sender = threading.Thread(target=send)
    sender.start()
    try:
        assert process.wait(60) == 0, process.stderr.read()
    finally:
        process.kill()
        sender.join(30)
        os.close(slave)
    stderr = process.stderr.read()
    assert "298 ticks, 2 lost" in stderr and "1 corrupt" in stderr, stderr
    assert (tmp_path / "serial.csv").read_bytes() == (tmp_path / "file.csv").read_bytes()
    rows = list(csv.DictReader(open(tmp_path / "serial.csv")))
    assert len(rows) == n and [r["status"] for r in rows if r["frame"] == "lost"] == ["invalid", "invalid"]
