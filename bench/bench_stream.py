"""sail estimate - (issue 32): a 1 kHz stream with the dynamic term, paced line by line into stdin.

The motion guide's task recording (t_s, angles and loads at 1 kHz) is written
into `sail estimate - --calibration dynamic.json` at its own pace, one line
per millisecond, for MEASURE_S seconds after a warm-up.  Measured side by
side, with `--block-ms 10` (the default: blocks of about ten lines) and
`--block-ms 0` (each line as it comes), and `--block-ms 50`:

- the CPU time of the process per row (user + system, /proc), amortised
  over the measured rows (target <= 0.2 ms a row);
- each row's added latency: from its line's write to its row's read, less
  the dynamic term's own delay (half the rate window, which a row waits for
  the readings after it);
- that the output bytes of both are those of the file estimated at once.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from sailforce.calibration.file import Calibration
from sailforce.cli import cli
from sailforce.live.browser import cpu_seconds

TARGET_MS_PER_ROW = 0.2  #: issue 32: the amortised CPU cost of a row, dynamic term on, from stdin at 1 kHz
RATE_HZ = 1000
WARM_S, MEASURE_S = 2.0, 8.0


def _files(d: Path) -> tuple[Path, Path]:
    run = lambda *args: CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    run("simulate-motion", "--session", "static", "--rig", "1", "-o", d / "static.csv")
    run("simulate-motion", "--session", "task", "--rig", "1", "-o", d / "task.csv")
    run("calibrate", d / "static.csv", "--model", "matrix", "-q", "--dynamics", "prior", "-o", d / "dynamic.json")
    return d / "task.csv", d / "dynamic.json"


def _paced(task: Path, cal: Path, block_ms: float, rows: int) -> tuple[float, np.ndarray, bytes]:
    """CPU ms a row over the measured rows, each row's latency [ms], and the output."""
    lines = task.read_bytes().splitlines(keepends=True)
    header, data = lines[0], lines[1 : rows + 1]
    sail = Path(sys.executable).with_name("sail")
    process = subprocess.Popen([str(sail), "estimate", "-", "--calibration", str(cal), "--block-ms", str(block_ms), "-q"],
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)  # fmt: skip
    written = np.full(len(data), np.nan)
    read = np.full(len(data), np.nan)
    out: list[bytes] = []
    marks: dict[str, float] = {}

    def reader() -> None:
        assert process.stdout is not None
        out.append(process.stdout.readline())  # the header
        for k in range(len(data)):
            line = process.stdout.readline()
            if not line:
                return
            read[k] = time.monotonic()
            out.append(line)

    thread = threading.Thread(target=reader)
    thread.start()
    assert process.stdin is not None
    process.stdin.write(header)
    process.stdin.flush()
    time.sleep(1.5)  # the interpreter's start-up, not a row's cost
    start = time.monotonic()
    warm = int(WARM_S * RATE_HZ)
    for k, line in enumerate(data):
        due = start + k / RATE_HZ
        pause = due - time.monotonic()
        if pause > 0:
            time.sleep(pause)
        if k == warm:
            marks["cpu"], marks["k"] = cpu_seconds(process.pid), k
        process.stdin.write(line)
        process.stdin.flush()
        written[k] = time.monotonic()
    cpu = cpu_seconds(process.pid) - marks["cpu"]
    process.stdin.close()
    thread.join()
    process.wait()
    measured = len(data) - marks["k"]
    return 1e3 * cpu / measured, 1e3 * (read - written)[warm:], b"".join(out)


def run() -> list[tuple[str, str]]:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        task, cal = _files(d)
        rows = int((WARM_S + MEASURE_S) * RATE_HZ)
        lines = task.read_bytes().splitlines(keepends=True)
        (d / "part.csv").write_bytes(b"".join(lines[: rows + 1]))
        CliRunner().invoke(cli, ["estimate", str(d / "part.csv"), "--calibration", str(cal), "-q", "-o", str(d / "file.csv")],
                           catch_exceptions=False)  # fmt: skip
        expected = (d / "file.csv").read_bytes()
        delay_ms = 1e3 * Calibration.load(cal).dynamics.differentiator.window_s / 2
        figures = []
        results = {block: _paced(task, cal, block, rows) for block in (10.0, 0.0, 50.0)}
        for block, (ms_per_row, latency, output) in results.items():
            added = latency - delay_ms
            verdict = "met" if ms_per_row <= TARGET_MS_PER_ROW else "NOT met"
            label = f"--block-ms {block:g}" + {10.0: " (the default)", 0.0: " (each line as it comes)"}.get(block, "")
            figures += [
                (f"{label}: CPU per row, dynamic term on, 1 kHz from stdin",
                 f"{ms_per_row:8.3f} ms   (target <= {TARGET_MS_PER_ROW}: {verdict})"),
                (f"  {label}: added latency, median / 95th percentile (beyond the {delay_ms:g} ms rate window)",
                 f"{np.nanmedian(added):8.1f} / {np.nanpercentile(added, 95):.1f} ms"),
                (f"  {label}: output bytes those of the file", f"{'yes' if output == expected else 'NO'}"),
            ]  # fmt: skip
        ratio = results[0.0][0] / results[10.0][0]
        figures.append(("CPU per row, each line as it comes / in 10 ms blocks", f"{ratio:8.2f}x"))
    return figures
