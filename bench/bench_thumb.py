"""libsail on the target: Thumb-2 instructions per call on QEMU's emulated Cortex-M4F (mps2-an386), -Os as `make cross`.

The bench programs (c/bench/bench_estimate.c, bench_motion.c, bench_multirate.c) are built with
`make cross`'s flags and run under ``qemu-system-arm -singlestep -d
exec,nochain``, which logs every instruction executed; the instructions
from each entry into the function until control is back in ``main`` are
counted (callees included) and divided by the calls.  Needs
arm-none-eabi-gcc and qemu-system-arm (`make cross-test` installs them).
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
TARGET_INSTRUCTIONS = 300  #: issue 18: Thumb-2 instructions per sail_estimate, default calibration
#: issue 35: Thumb-2 instructions per control tick (the motion step; the multi-rate estimator, HX711s at 80 SPS)
TARGET_TICK_INSTRUCTIONS = 1000
#: Control ticks the multi-rate bench runs, and the first ones left out of the count: the rate window's half (50
#: ticks at 1 kHz) returns at once, and the ring of ticks fills (256 ticks).
TICKS = 1000
WARM_UP = 256
CALLS = 256
CLOCK_HZ = 168e6  #: an STM32F4-class Cortex-M4F
#: Cycles per instruction assumed for the time: single-cycle ALU and FPU operations, 2-cycle loads,
#: VDIV.F32 (14 cycles) and a few flash wait states; a rough figure, stated as such.
CPI = 1.3
CPU_FLAGS = ["-mcpu=cortex-m4", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv4-sp-d16", "-ffunction-sections", "-fdata-sections"]
LINK_FLAGS = ["--specs=nano.specs", "--specs=rdimon.specs", "-u", "_printf_float", "-Wl,--gc-sections",
              "-T", str(C / "qemu" / "mps2_an386.ld")]  # fmt: skip
TRACE_LINE = re.compile(rb"^Trace \d+: \S+ \[[0-9a-f]+/([0-9a-f]+)/")


def _build(tmp: Path, program: str, bench_cal: str, name: str, defines: tuple[str, ...] = ()) -> Path:
    (tmp / "bench_cal.h").write_text(bench_cal)
    exe = tmp / f"{name}.elf"
    command = ["arm-none-eabi-gcc", "-std=c99", "-Os", *CPU_FLAGS, "-DSAIL_BENCH_NO_CLOCK", *defines, f"-I{C / 'include'}",
               f"-I{tmp}", *map(str, sorted((C / "src").glob("*.c"))), str(C / "bench" / program),
               str(C / "qemu" / "startup.c"), *LINK_FLAGS, "-lm", "-o", str(exe)]  # fmt: skip
    subprocess.run(command, check=True, capture_output=True)
    return exe


def _symbols(exe: Path) -> dict[str, tuple[int, int]]:
    """Function name -> (start, end) addresses (the Thumb bit cleared)."""
    out = subprocess.run(["arm-none-eabi-nm", "--print-size", "--defined-only", str(exe)], check=True,
                         capture_output=True, text=True).stdout  # fmt: skip
    symbols = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[2] in "Tt":
            start = int(parts[0], 16) & ~1
            symbols[parts[3]] = (start, start + int(parts[1], 16))
    return symbols


def instructions_per_call(exe: Path, function: str, calls: int, tmp: Path, skip: int = 0) -> tuple[float, int]:
    """Instructions executed from each entry into ``function`` until control is back in ``main``: per call, and the
    most that one call took, over the calls after the first ``skip`` (a rate window filling up returns at once)."""
    symbols = _symbols(exe)
    entry = symbols[function][0]
    main_lo, main_hi = symbols["main"]
    trace = tmp / f"{exe.stem}.trace"
    subprocess.run([str(C / "qemu" / "run.sh"), str(exe), str(calls)], check=True, capture_output=True, timeout=300,
                   env={"PATH": "/usr/bin:/bin", "SAIL_QEMU_FLAGS": f"-singlestep -d exec,nochain -D {trace}"})  # fmt: skip
    inside, count, entered, this, worst = False, 0, 0, 0, 0
    with open(trace, "rb") as lines:
        for line in lines:
            match = TRACE_LINE.match(line)
            if not match:
                continue
            pc = int(match.group(1), 16)
            if not inside and pc == entry:
                inside, entered, this = True, entered + 1, 0
            if inside:
                if main_lo <= pc < main_hi:
                    inside = False
                    if entered > skip:
                        count, worst = count + this, max(worst, this)
                else:
                    this += 1
    if entered != calls:
        raise RuntimeError(f"{function} entered {entered} times, expected {calls}")
    return count / (calls - skip), worst


def run() -> list[tuple[str, str]]:
    missing = [tool for tool in ("arm-none-eabi-gcc", "qemu-system-arm") if not shutil.which(tool)]
    if missing:
        return [("libsail on Cortex-M4F", f"{', '.join(missing)} not found (make cross-test installs them): skipped")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        vectors = write_vectors(tmp)
        default = C / "examples" / "sail_calibration.h"
        name = re.search(r"static const sail_calibration (\w+) =", default.read_text()).group(1)
        cases = [
            ("sail_estimate, matrix (default calibration)", "bench_estimate.c", f'#include "{default}"\n#define BENCH_CAL {name}\n',
             "sail_estimate", TARGET_INSTRUCTIONS, CALLS, 0, ()),
            ("sail_estimate, seed", "bench_estimate.c", f'#include "{vectors / "cal_seed.h"}"\n#define BENCH_CAL sail_cal_seed\n',
             "sail_estimate", None, CALLS, 0, ()),
            ("sail_motion_step, 1 kHz, 101-sample window (per tick, the window full)", "bench_motion.c",
             f'#include "{vectors / "cal_motion.h"}"\n#define BENCH_CAL sail_cal_motion\n#define BENCH_DYN sail_cal_motion_dynamics\n',
             "sail_motion_step", TARGET_TICK_INSTRUCTIONS, CALLS + WARM_UP, WARM_UP, ()),
            ("sail_multirate_step, HX711s at 80 SPS, 1 kHz ticks (mean per tick, the ring full)", "bench_multirate.c",
             f'#include "{vectors / "cal_multirate.h"}"\n#define BENCH_CAL sail_cal_multirate\n'
             "#define BENCH_DYN sail_cal_multirate_dynamics\n#define BENCH_ADC sail_cal_multirate_adc\n",
             "sail_multirate_step", TARGET_TICK_INSTRUCTIONS, TICKS + WARM_UP, WARM_UP, ()),
            ("sail_multirate_step, the same with M and d at every tick (-DSAIL_TICK_STRIDE=1, mean per tick)",
             "bench_multirate.c", f'#include "{vectors / "cal_multirate.h"}"\n#define BENCH_CAL sail_cal_multirate\n'
             "#define BENCH_DYN sail_cal_multirate_dynamics\n#define BENCH_ADC sail_cal_multirate_adc\n",
             "sail_multirate_step", None, TICKS + WARM_UP, WARM_UP, ("-DSAIL_TICK_STRIDE=1",)),
            ("sail_multirate_step, the same without the dynamic term (mean per tick)", "bench_multirate.c",
             f'#include "{vectors / "cal_multirate.h"}"\n#define BENCH_CAL sail_cal_multirate\n'
             "#define BENCH_STATIC 1\n#define BENCH_ADC sail_cal_multirate_adc\n",
             "sail_multirate_step", None, TICKS + WARM_UP, WARM_UP, ()),
        ]  # fmt: skip
        for i, (label, program, header, function, target, calls, skip, defines) in enumerate(cases):
            exe = _build(tmp, program, header, f"case{i}", defines)
            n, worst = instructions_per_call(exe, function, calls, tmp, skip)
            verdict = f"   (target <= {target}: {'met' if n <= target else 'NOT met'})" if target else ""
            rows.append((f"{label}: Thumb-2 instructions/call", f"{n:10.0f}{verdict}"))
            rows.append(("  the costliest call", f"{worst:10d}"))
            rows.append((f"  at {CLOCK_HZ / 1e6:.0f} MHz, ~{CPI} cycles/instruction", f"{n * CPI / CLOCK_HZ * 1e6:10.2f} us/call"))
    return rows
