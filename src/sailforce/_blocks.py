"""Running a function over the blocks of a range, on threads when there are several (numpy releases the GIL)."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor


def for_each_block(n: int, block: int, threads: int, run: Callable[[int], None]) -> None:
    """Call ``run(start)`` for ``start`` in ``0, block, 2 block, ... < n``; on ``threads`` threads if several blocks."""
    starts = range(0, n, block)
    if len(starts) > 1 and threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            list(pool.map(run, starts))
    else:
        for start in starts:
            run(start)
