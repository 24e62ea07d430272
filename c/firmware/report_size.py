"""Print the Cortex-M flash sizes of the `make cross` build (arm-none-eabi-size, Berkeley format).

Usage: python3 c/firmware/report_size.py BUILD_DIR

Flash = .text + .data, RAM = .data + .bss.  The sketch is built twice: on the
default calibration (static estimate, text lines) and on c/examples/hx711's
(the multi-rate estimator with its dynamic term, binary frames).  The cost of sail_estimate with the default
calibration is probe_estimate.elf minus probe_base.elf: the same program
with and without the call (the target: at most 4 KiB).
"""

import subprocess
import sys
from pathlib import Path

TARGET_BYTES = 4096


SKETCHES = ("sail_hx711_static", "sail_hx711_multirate")


def flash(elf: Path) -> int:
    return sum(_size(elf)[:2])


def ram(elf: Path) -> int:
    """.data + .bss: the RAM the program's statics take (the stack and heap come on top)."""
    return sum(_size(elf)[1:])


def _size(elf: Path) -> tuple[int, int, int]:
    out = subprocess.run(["arm-none-eabi-size", "-B", str(elf)], check=True, capture_output=True, text=True).stdout
    text, data, bss = out.splitlines()[1].split()[:3]
    return int(text), int(data), int(bss)


def main(build: Path) -> int:
    firmware = build / "firmware"
    sizes = {name: flash(firmware / f"{name}.elf") for name in (*SKETCHES, "probe_base", "probe_estimate")}
    cost = sizes["probe_estimate"] - sizes["probe_base"]
    symbols = subprocess.run(["arm-none-eabi-nm", "--size-sort", "-S", str(firmware / "probe_estimate.elf")],
                             check=True, capture_output=True, text=True).stdout.split("\n")  # fmt: skip
    print("Cortex-M4F, -Os, newlib-nano (arm-none-eabi-size: text + data)")
    for name in SKETCHES:
        print(f"  sketch {name + '.elf':32} {sizes[name]:7d} bytes flash, {ram(firmware / f'{name}.elf'):6d} bytes RAM")
    print(f"  sail_estimate + default calibration     {cost:7d} bytes "
          f"(target <= {TARGET_BYTES}: {'met' if cost <= TARGET_BYTES else 'NOT met'})")
    print("  largest symbols in probe_estimate.elf:")
    for line in [s for s in symbols if s.strip()][-8:]:
        _, size, kind, name = line.split(maxsplit=3)
        print(f"    {int(size, 16):6d}  {kind}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))
