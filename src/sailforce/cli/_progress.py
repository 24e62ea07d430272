"""Progress for long jobs: a bar with time left on a terminal, a periodic line elsewhere, nothing with --quiet."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn, TimeRemainingColumn

#: Off a terminal (a log file, CI), one progress line per this many seconds: enough to see a job is alive.
PROGRESS_LINE_PERIOD_S = 10.0


@contextmanager
def progress_bar(console: Console, description: str, total: float | None, *, unit: str = "",
                 quiet: bool = False) -> Iterator[Callable[[float], None]]:  # fmt: skip
    """Yield ``advance(amount)``; ``total`` in the same unit (None if unknown)."""
    if quiet:
        yield lambda amount: None
        return
    if console.is_terminal:
        columns = (TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                   TextColumn("left"), TimeRemainingColumn())  # fmt: skip
        with Progress(*columns, console=console, transient=True) as progress:
            task = progress.add_task(description, total=total)
            yield lambda amount: progress.advance(task, amount)
        return
    start = last = time.monotonic()
    done = 0.0

    def advance(amount: float) -> None:
        nonlocal done, last
        done += amount
        now = time.monotonic()
        if now - last >= PROGRESS_LINE_PERIOD_S:
            last = now
            console.print(_line(description, done, total, unit, now - start), highlight=False)

    yield advance


def _line(description: str, done: float, total: float | None, unit: str, elapsed: float) -> str:
    if not total:
        return f"{description}: {done:,.0f} {unit} in {elapsed:.0f} s"
    fraction = min(done / total, 1.0)
    left = elapsed * (1 - fraction) / fraction if fraction > 0 else float("inf")
    return f"{description}: {fraction:.0%} of {total:,.0f} {unit}, {elapsed:.0f} s elapsed, about {left:.0f} s left"


def print_notes(console: Console, notes) -> None:
    """Each note for people (a damaged cache entry, a cache not written) as a warning line."""
    for note in notes:
        console.print(f"[bold yellow]warning:[/bold yellow] {note}", highlight=False)


def skipped_note(console, name: str):
    """What to tell of the lines dropped before a joined stream's header (:func:`sailforce.live.sources.from_header`)."""

    def note(count: int) -> None:
        if count == 1:
            console.print(f"{name} is already streaming: waiting for its next header line (a device that sends none "
                          "needs --columns)", highlight=False)  # fmt: skip
        else:
            console.print(f"skipped {count:,} lines of {name} before its header", highlight=False)

    return note
