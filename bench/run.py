"""`make bench`: run every bench_*.py here and print its figures.

Each benchmark module exposes ``run() -> list[tuple[str, str]]`` (label, figure).
Ratios are always measured side by side in one run, because this machine is
shared and absolute timings drift.  Pass module names to run a subset:
``python bench/run.py statics``.
"""

from __future__ import annotations

import importlib
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    sys.path.insert(0, str(HERE))
    names = argv or sorted(p.stem.removeprefix("bench_") for p in HERE.glob("bench_*.py"))
    for name in names:
        module = importlib.import_module(f"bench_{name}")
        print(f"== {name}: {module.__doc__.strip().splitlines()[0]}", flush=True)
        start = time.perf_counter()
        for label, figure in module.run():
            print(f"  {label:<58} {figure}", flush=True)
        print(f"  ({time.perf_counter() - start:.1f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
