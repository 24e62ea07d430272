"""libsail: instructions per sail_estimate call under callgrind (x86-64, -O2) and native calls per second.

Both model kinds, float and double.  The matrix model is the default
calibration (c/examples/sail_calibration.h); the seed model comes from
c/tests/make_vectors.py's synthetic session.  Instructions are counted
inside sail_estimate and its callees only (callgrind --toggle-collect).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from pathlib import Path

from _vectors import write_vectors

ROOT = Path(__file__).resolve().parents[1]
C = ROOT / "c"
TARGET_INSTRUCTIONS = 300
#: Issue 11: the motion step (rate filter, dynamic term and estimate) in a float build.
TARGET_MOTION_INSTRUCTIONS = 600
CALLGRIND_CALLS = 10_000
NATIVE_CALLS = 20_000_000


def _bench_header(header: Path, destination: Path) -> None:
    name = re.search(r"static const sail_calibration (\w+) =", header.read_text()).group(1)
    destination.write_text(f'#include "{header}"\n#define BENCH_CAL {name}\n')


def _build(tmp: Path, header: Path, double: bool) -> Path:
    _bench_header(header, tmp / "bench_cal.h")
    exe = tmp / f"bench_{header.stem}_{'double' if double else 'float'}"
    command = ["gcc", "-std=c99", "-O2", *(["-DSAIL_DOUBLE"] if double else []), f"-I{C / 'include'}", f"-I{tmp}",
               *map(str, sorted((C / "src").glob("*.c"))), str(C / "bench" / "bench_estimate.c"), "-lm", "-o", str(exe)]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True)
    return exe


def _build_motion(tmp: Path, header: Path, double: bool) -> Path:
    (tmp / "bench_cal.h").write_text(f'#include "{header}"\n#define BENCH_CAL sail_cal_motion\n'
                                     "#define BENCH_DYN sail_cal_motion_dynamics\n")  # fmt: skip
    exe = tmp / f"bench_motion_{'double' if double else 'float'}"
    command = ["gcc", "-std=c99", "-O2", *(["-DSAIL_DOUBLE"] if double else []), f"-I{C / 'include'}", f"-I{tmp}",
               *map(str, sorted((C / "src").glob("*.c"))), str(C / "bench" / "bench_motion.c"), "-lm", "-o", str(exe)]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True)
    return exe


def _instructions_per_call(exe: Path, tmp: Path, function: str = "sail_estimate") -> float:
    out = tmp / "callgrind.out"
    run = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", f"--toggle-collect={function}",
                          str(exe), str(CALLGRIND_CALLS)], check=True, capture_output=True, text=True)  # fmt: skip
    collected = int(re.search(r"Collected : (\d+)", run.stderr).group(1))
    return collected / CALLGRIND_CALLS


def _calls_per_second(exe: Path, calls: int = NATIVE_CALLS) -> float:
    out = subprocess.run([str(exe), str(calls)], check=True, capture_output=True, text=True).stdout
    return float(re.search(r"s: (\S+) (?:calls|steps)/s", out).group(1))


def run() -> list[tuple[str, str]]:
    if not shutil.which("gcc"):
        return [("libsail", "gcc not found: skipped")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        vectors = write_vectors(tmp)
        headers = {"matrix (default calibration)": C / "examples" / "sail_calibration.h", "seed": vectors / "cal_seed.h"}
        for label, header in headers.items():
            for double in (False, True):
                exe = _build(tmp, header, double)
                real = "double" if double else "float"
                native = _calls_per_second(exe)
                if shutil.which("valgrind"):
                    ir = _instructions_per_call(exe, tmp)
                    verdict = ""
                    if header == headers["matrix (default calibration)"] and not double:  # the target: default build
                        verdict = f"   (target <= {TARGET_INSTRUCTIONS}: {'met' if ir <= TARGET_INSTRUCTIONS else 'NOT met'})"
                    rows.append((f"sail_estimate, {label}, {real}: instructions/call", f"{ir:10.0f}{verdict}"))
                else:
                    rows.append((f"sail_estimate, {label}, {real}: instructions/call", "valgrind not installed"))
                rows.append((f"sail_estimate, {label}, {real}: native", f"{native / 1e6:10.1f} M calls/s"))
        motion = vectors / "cal_motion.h"  # 1 kHz, 0.1 s window: 101 samples
        for double in (False, True):
            exe = _build_motion(tmp, motion, double)
            real = "double" if double else "float"
            if shutil.which("valgrind"):
                ir = _instructions_per_call(exe, tmp, "sail_motion_step")
                verdict = "" if double else f"   (target <= {TARGET_MOTION_INSTRUCTIONS}: " + (
                    "met)" if ir <= TARGET_MOTION_INSTRUCTIONS else "NOT met)")  # fmt: skip
                rows.append((f"sail_motion_step, 1 kHz, 101-sample window, {real}: instructions/step", f"{ir:10.0f}{verdict}"))
            native = _calls_per_second(exe, NATIVE_CALLS // 10)
            rows.append((f"sail_motion_step, 1 kHz, 101-sample window, {real}: native", f"{native / 1e6:10.2f} M steps/s"))
    return rows
