"""Driving the live page from scripts: a ``sail live`` process, the page in the system's Chromium, its latency.

For tests, benchmarks and labs' own automation (a screenshot per session,
a check that the force reads zero before a block starts).  The browser is
Debian's ``chromium`` (``make test`` installs it), driven by Playwright
(the ``dev`` extra) with ``executable_path`` set: nothing is downloaded.
"""

from __future__ import annotations

import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import ToolError

#: Names the system's Chromium goes by.
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

#: How long ``sail live`` may take to start serving [s].
START_TIMEOUT_S = 60.0

_SERVING = re.compile(r"serving (http://\S+/)")


def system_chromium() -> str | None:
    """The path of the system's Chromium, or None."""
    for name in CHROMIUM_NAMES:
        if path := shutil.which(name):
            return path
    return None


class LiveProcess:
    """A running ``sail live``: its URL, its process, and what it has written to stderr so far."""

    def __init__(self, url: str, process: subprocess.Popen, stderr: list[str]) -> None:
        self.url, self.process, self._stderr = url, process, stderr

    @property
    def stderr(self) -> str:
        return "".join(self._stderr)


def _drain(stream, sink) -> None:
    for line in stream:
        sink(line)


@contextmanager
def live_process(args: list[str], *, cwd: str | Path | None = None, stdin: bool = False) -> Iterator[LiveProcess]:
    """``sail live ARGS --port 0`` in a process of its own; stopped (SIGTERM) on exit.

    Both its outputs are read on threads, so that it never blocks on a full pipe.  With ``stdin``, its standard
    input is a pipe, ``process.stdin`` (text; bytes through its ``buffer``), for a source ``-`` that the caller writes
    as it goes.
    """
    command = [sys.executable, "-c", "from sailforce.cli import main; main()", "live", *map(str, args), "--port", "0"]
    process = subprocess.Popen(command, cwd=cwd, stdin=subprocess.PIPE if stdin else None, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)  # fmt: skip
    lines: queue.Queue = queue.Queue()
    stderr: list[str] = []
    threading.Thread(target=_drain, args=(process.stdout, lines.put), daemon=True).start()
    threading.Thread(target=_drain, args=(process.stderr, stderr.append), daemon=True).start()
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while True:
            try:
                line = lines.get(timeout=0.2)
            except queue.Empty:
                if process.poll() is not None or time.monotonic() > deadline:
                    time.sleep(0.2)  # the rest of its stderr
                    raise ToolError(f"sail live did not start serving: {''.join(stderr).strip()}") from None
                continue
            if match := _SERVING.search(line):
                break
        yield LiveProcess(match.group(1), process, stderr)
    finally:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


@contextmanager
def browser_page(url: str, *, width: int = 1200, height: int = 900):
    """The page at ``url`` in the system's Chromium (headless), through Playwright's sync API."""
    executable = system_chromium()
    if executable is None:
        raise ToolError("no Chromium on this machine: `make chromium` installs Debian's (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=executable, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.goto(url)
            yield page
        finally:
            browser.close()


def latencies_ms(page) -> np.ndarray:
    """Each shown row's latency [ms]: when the page drew it, less when it was read (the page's ``sailLatency``)."""
    return np.asarray(page.evaluate("window.sailLatency"), dtype=float)


def cpu_seconds(pid: int) -> float:
    """A process's CPU time so far (user + system) [s], from /proc (Linux)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
