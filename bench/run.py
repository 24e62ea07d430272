"""`make bench`: run every bench_*.py here and print its figures.

Each benchmark module exposes ``run() -> list[tuple[str, str]]`` (label, figure).
Ratios are always measured side by side in one run, because this machine is
shared and absolute timings drift.  Pass module names to run a subset:
``python bench/run.py statics``.

Every figure also goes to ``build/bench/figures.json`` (``--json PATH`` for
another file): per benchmark, the date it ran, the machine (platform, cores,
Python), the commit and its figures.  A subset replaces only its own
benchmarks' entries, so the file holds the latest run of each.
"""

from __future__ import annotations

import datetime
import importlib
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: Where the figures go unless ``--json PATH`` says otherwise.
FIGURES = HERE.parent / "build" / "bench" / "figures.json"


def machine() -> dict[str, object]:
    """What the figures were measured on."""
    return {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cores": os.cpu_count(), "python": platform.python_version()}  # fmt: skip


def commit() -> str | None:
    """The repository's commit, with ``+`` when its tree has changes (None outside a git checkout)."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return head + ("+" if dirty else "")


def record(path: Path, name: str, doc: str, figures: list[tuple[str, str]], seconds: float) -> None:
    """Put one benchmark's run into the figures file, keeping the others' entries (written whole, then renamed)."""
    try:
        data = json.loads(path.read_text())
        if not isinstance(data, dict) or not isinstance(data.get("benchmarks"), dict):
            data = {}
    except (OSError, ValueError):
        data = {}
    data.setdefault("benchmarks", {})[name] = {
        "description": doc, "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "machine": machine(), "commit": commit(), "seconds": round(seconds, 1),
        "figures": [{"label": label, "figure": figure.strip()} for label, figure in figures],
    }  # fmt: skip
    data["format"] = "sailforce-bench-figures"
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    partial.replace(path)


def main(argv: list[str]) -> int:
    sys.path.insert(0, str(HERE))
    path = FIGURES
    if "--json" in argv:
        at = argv.index("--json")
        if at + 1 >= len(argv):
            print("--json needs a path", file=sys.stderr)
            return 2
        path = Path(argv[at + 1])
        argv = argv[:at] + argv[at + 2 :]
    names = argv or sorted(p.stem.removeprefix("bench_") for p in HERE.glob("bench_*.py"))
    for name in names:
        module = importlib.import_module(f"bench_{name}")
        doc = module.__doc__.strip().splitlines()[0]
        print(f"== {name}: {doc}", flush=True)
        start = time.perf_counter()
        figures = []
        for label, figure in module.run():
            print(f"  {label:<58} {figure}", flush=True)
            figures.append((label, figure))
        seconds = time.perf_counter() - start
        print(f"  ({seconds:.1f} s)", flush=True)
        record(path, name, doc, figures, seconds)
    print(f"figures in {path}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
