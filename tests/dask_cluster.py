"""A real Dask cluster on 127.0.0.1 for the tests: `dask scheduler` and `dask worker` processes, started and stopped here."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: Seconds the scheduler gets to listen before the workers connect.
SCHEDULER_START_S = 1.0


@contextmanager
def local_cluster(logs: Path, workers: int = 2) -> Iterator[tuple[str, list[subprocess.Popen]]]:
    """Yield the scheduler's address and the worker processes (each in its own session, so it can be SIGKILLed).

    The workers import test modules (PYTHONPATH holds the repository root); their output goes to ``logs``.
    """
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    bin_dir = Path(sys.executable).parent
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent.parent) + os.pathsep + os.environ.get("PYTHONPATH", "")}

    def spawn(name: str, *args: str) -> subprocess.Popen:
        return subprocess.Popen([str(bin_dir / "dask"), *args], stdout=(logs / name).open("w"), stderr=subprocess.STDOUT,
                                env=env, start_new_session=True)  # fmt: skip

    processes = [spawn("scheduler", "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")]
    try:
        time.sleep(SCHEDULER_START_S)
        started = [spawn(f"worker{i}", "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                         "--host", "127.0.0.1") for i in range(workers)]  # fmt: skip
        processes += started
        yield address, started
    finally:  # the workers first: stopped after their scheduler, a run took 17 s instead of 7 about every other time
        for stage in (processes[1:], processes[:1]):
            for process in stage:
                if process.poll() is None:
                    os.killpg(process.pid, signal.SIGTERM)
            for process in stage:
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    os.killpg(process.pid, signal.SIGKILL)
