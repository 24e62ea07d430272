"""Timing helpers shared by the benchmarks."""

from __future__ import annotations

import time

import numpy as np


def best_of(repeats: int, func) -> float:
    """The fastest of ``repeats`` wall-clock runs of ``func()`` [s]; the least disturbed by a shared machine."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - start)
    return best
