"""Short commands: what a `sail` process costs before and around its work (start-up, imports), side by side.

Each command runs as a user runs it, a fresh process, several times
alternately with its comparison, and the median wall time is quoted:

- `sail --version`; `sail estimate` of one row; `sail calibrate` of the
  simulated static session (a physics fit among the candidates);
- the same `sail estimate` with ``SAIL_PANDAS=1``, which lets pyarrow import
  pandas (the ``sail`` process keeps it out: sailforce.cli._without_pandas).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SAIL = str(Path(sys.executable).with_name("sail"))
REPEATS = 7
CAL = str(ROOT / "c" / "examples" / "calibration.json")


def _wall(command: list[str], cwd: Path, env: dict[str, str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, cwd=cwd, env=env, check=True, capture_output=True)
    return time.perf_counter() - start


def _medians(commands: dict[str, tuple[list[str], dict[str, str]]], cwd: Path, repeats: int) -> dict[str, float]:
    """Each command's median wall time [s], the commands run in turn, ``repeats`` rounds."""
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(repeats):
        for name, (command, env) in commands.items():
            times[name].append(_wall(command, cwd, env))
    return {name: statistics.median(t) for name, t in times.items()}


def run() -> list[tuple[str, str]]:
    env = {k: v for k, v in os.environ.items() if k != "SAIL_PANDAS"}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "in.csv").write_text("theta1_deg,theta2_deg,load1,load2\n90,10,-41809,76265\n")
        subprocess.run([SAIL, "simulate-motion", "--session", "static", "-o", "static.csv"], cwd=d, check=True,
                       capture_output=True)  # fmt: skip
        estimate = [SAIL, "estimate", "in.csv", "--calibration", CAL, "-o", "out.csv", "-q"]
        short = _medians({"version": ([SAIL, "--version"], env), "estimate": (estimate, env),
                          "estimate, pandas": (estimate, {**env, "SAIL_PANDAS": "1"})}, d, REPEATS)  # fmt: skip
        fit = _medians({"calibrate": ([SAIL, "calibrate", "static.csv", "-o", "cal.json", "-q"], env)}, d, 3)
    return [
        ("sail --version, median wall", f"{short['version']:8.2f} s"),
        ("sail estimate, one row, median wall", f"{short['estimate']:8.2f} s"),
        ("  the same with SAIL_PANDAS=1 (pyarrow imports pandas)", f"{short['estimate, pandas']:8.2f} s"),
        ("  ratio with pandas / without (same run)", f"{short['estimate, pandas'] / short['estimate']:8.2f} x"),
        ("sail calibrate, the static session (252 rows, --model auto), median wall", f"{fit['calibrate']:8.2f} s"),
    ]
