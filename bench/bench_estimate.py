"""Calibration.estimate throughput and `sail estimate` end to end, each beside a plain pandas baseline."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
from _timing import best_of

from sailforce import kernel
from sailforce.arm import Arm
from sailforce.calibration.file import Calibration
from sailforce.sensing.maps import MatrixCompensator

N_CALL = 1_000_000
N_ROWS = int(os.environ.get("SAIL_BENCH_ROWS", 10_000_000))  #: issue 5: a 10-million-row CSV
TARGET_CALL = 20e6  #: samples/s
TARGET_ROWS = 1e6  #: rows/s end to end
TARGET_MB = 300.0


def _calibration() -> Calibration:
    arm = Arm()
    rng = np.random.default_rng(0)
    c = rng.normal(scale=1e-5, size=(7, 2, 2))  # order 6, as the study's matrix compensator
    c[0] = np.diag([2.0, 2.4])
    return Calibration(arm=arm, model=MatrixCompensator(arm, c, (0.26, 2.88)), offsets=(100.0, -50.0),
                       capacity=(4e6, 4e6), delta_range=(0.26, 2.88), load_range=((-4e6, 4e6), (-4e6, 4e6)))  # fmt: skip


def _pandas_baseline(cal: Calibration, source: Path, destination: Path) -> None:
    import pandas as pd

    frame = pd.read_csv(source)
    fx, fy, status = cal.estimate(np.radians(frame["theta1_deg"].to_numpy()), np.radians(frame["theta2_deg"].to_numpy()),
                                  frame["load1"].to_numpy(), frame["load2"].to_numpy())  # fmt: skip
    frame["fx_N"], frame["fy_N"], frame["status"] = fx, fy, status
    frame.to_csv(destination, index=False)


def _child_peak_mb(command: list[str]) -> tuple[float, float]:
    """Wall time [s] and peak RSS [MB] of ``command``, a Python script run by this interpreter.

    The peak is the child's own VmHWM (/proc/self/status), read at its exit:
    Linux carries ru_maxrss across exec, so a child forked from this large
    process would otherwise report the parent's size.
    """
    wrapper = ("import runpy, sys\n"
               "sys.argv = sys.argv[1:]\n"
               "try:\n    runpy.run_path(sys.argv[0], run_name='__main__')\n"
               "finally:\n"
               "    hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]\n"
               "    print('PEAK_KB', hwm, file=sys.stderr)\n")  # fmt: skip
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", wrapper, *command], check=True, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    peak_kb = int(done.stderr.rsplit("PEAK_KB", 1)[1].split()[0])
    return elapsed, peak_kb / 1024.0


def run() -> list[tuple[str, str]]:
    cal = _calibration()
    rng = np.random.default_rng(1)
    t2 = rng.uniform(-1, 1, N_CALL)
    t1 = t2 + rng.uniform(0.3, 2.8, N_CALL)
    l1, l2 = rng.uniform(-1e6, 1e6, N_CALL), rng.uniform(-1e6, 1e6, N_CALL)
    with kernel.use_backend("numpy"):
        t_numpy = best_of(3, lambda: cal.estimate(t1, t2, l1, l2))
    with kernel.use_backend("compiled"):  # by name: a call of 1e6 is below the default's size rule (kernel.COMPILED_MIN_POSES)
        t_call = best_of(3, lambda: cal.estimate(t1, t2, l1, l2))
    rows = [("Calibration.estimate, order-6 matrix model, 1e6 samples (compiled)",
             f"{N_CALL / t_call / 1e6:10.2f} M samples/s"),
            ("Calibration.estimate, the same on numpy", f"{N_CALL / t_numpy / 1e6:10.2f} M samples/s"),
            ("ratio compiled / numpy (same run)", f"{t_numpy / t_call:10.1f} x"),
            ("target", f">= {TARGET_CALL / 1e6:g} M samples/s: {'met' if N_CALL / t_call >= TARGET_CALL else 'NOT met'}")]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cal.save(tmp / "cal.json")
        n = N_ROWS
        theta2_deg = rng.uniform(-60, 60, n).round(4)
        table = pa.table({"time_s": np.arange(n) * 1e-3, "theta1_deg": (theta2_deg + rng.uniform(20, 160, n)).round(4),
                          "theta2_deg": theta2_deg, "load1": rng.integers(-10**6, 10**6, n),
                          "load2": rng.integers(-10**6, 10**6, n)})  # fmt: skip
        pacsv.write_csv(table, tmp / "in.csv")
        del table, theta2_deg
        sail = str(Path(sys.executable).with_name("sail"))  # the console script: a Python file
        pa.default_memory_pool().release_unused()
        ours, ours_mb = _child_peak_mb([sail, "estimate", "--calibration", str(tmp / "cal.json"), str(tmp / "in.csv"),
                                        "-o", str(tmp / "out.csv")])  # fmt: skip
        script = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
                  "from bench_estimate import _pandas_baseline, _calibration; from pathlib import Path; "
                  f"_pandas_baseline(_calibration(), Path({str(tmp / 'in.csv')!r}), Path({str(tmp / 'pd.csv')!r}))")  # fmt: skip
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", script], check=True, capture_output=True)
        base = time.perf_counter() - start
    rows += [
        (f"sail estimate, {n:,}-row CSV, end to end", f"{n / ours / 1e6:10.2f} M rows/s, peak {ours_mb:.0f} MB"),
        ("pandas read_csv -> estimate -> to_csv, same file", f"{n / base / 1e6:10.2f} M rows/s ({base / ours:.2f}x our time)"),
        ("target", f">= 1 M rows/s and <= {TARGET_MB:g} MB: "
                   f"{'met' if n / ours >= TARGET_ROWS and ours_mb <= TARGET_MB else 'NOT met'}"),
    ]  # fmt: skip
    return rows
