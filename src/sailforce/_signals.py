"""Interrupts that wait for a consistent state: Ctrl-C and SIGTERM between rows, never inside one."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: The signals that end a command (``sail``'s SIGTERM handler raises like Ctrl-C).
DEFERRED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then act on them as their handlers would.

    A row taken from a motion stage but not yet written would be lost if
    Ctrl-C struck in between; inside this block it cannot.  Signals reach
    only the main thread, so elsewhere the block runs as it is.  One
    :class:`HeldSignals` section; a loop of many uses one :class:`HeldSignals`.
    """
    with HeldSignals() as signals, signals.held():
        yield


class HeldSignals:
    """SIGINT and SIGTERM held only inside :meth:`held` sections, for a loop: the handlers are installed once.

    :func:`signals_deferred` around each block of a stream cost four
    ``signal.signal`` calls a block, about 5 % of a 10-line block's work.
    Here a signal outside a section acts at once, as its own handler would;
    inside one it waits for the section's end.  Signals reach only the main
    thread, so elsewhere nothing is installed and a section runs as it is.
    """

    def __init__(self) -> None:
        self._holding = False
        self._caught: list[int] = []
        self._previous: dict[int, object] = {}

    def __enter__(self) -> HeldSignals:
        if threading.current_thread() is threading.main_thread():
            self._previous = {s: signal.signal(s, self._handle) for s in DEFERRED_SIGNALS}
        return self

    def __exit__(self, *exc) -> None:
        for s, handler in self._previous.items():
            signal.signal(s, handler)  # type: ignore[arg-type]

    @contextmanager
    def held(self) -> Iterator[None]:
        self._holding = True
        try:
            yield
        finally:
            self._holding = False
            caught, self._caught = self._caught, []
            for s in dict.fromkeys(caught):
                self._act(s)

    def _handle(self, signum: int, frame) -> None:
        if self._holding:
            self._caught.append(signum)
        else:
            self._act(signum)

    def _act(self, signum: int) -> None:
        handler = self._previous[signum]
        if callable(handler):
            handler(signum, None)
        elif handler == signal.SIG_DFL:
            signal.signal(signum, signal.SIG_DFL)
            signal.raise_signal(signum)
