"""Independent tasks run here or on a Dask cluster: the engine behind sweeps that outgrow one machine.

:func:`run_tasks` maps a picklable function over items and returns one
:class:`Outcome` per item, in the items' order, whatever happens:

- with neither ``workers`` nor ``scheduler``, in this process;
- with ``workers=N``, on a :class:`dask.distributed.LocalCluster` of N
  single-threaded worker processes, started and stopped here;
- with ``scheduler="tcp://HOST:PORT"``, on an existing cluster, started with
  ``dask scheduler`` and ``dask worker tcp://HOST:PORT`` (every worker needs
  sailforce installed).

Dask moves the tasks of a worker that dies to the others, and retries a task
that raises up to ``retries`` times.  A task that still fails comes back as an
``Outcome`` with its error, never dropped: the caller reports it.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any

from ._signals import signals_deferred
from .errors import ClusterError

#: Times Dask retries a task that raised, before its error is reported.
DEFAULT_RETRIES = 2
#: Seconds to wait for an existing scheduler to answer.
CONNECT_TIMEOUT_S = 10



@dataclass(frozen=True)
class Outcome:
    """What one task gave: its ``value``, or the ``error`` that stopped it."""

    value: Any = None
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


def _dask():
    try:
        from dask import distributed
    except ImportError:
        raise ClusterError("--workers and --scheduler need Dask: pip install 'sailforce[distributed]'") from None
    return distributed


def run_tasks(fn: Callable[[Any], Any], items: Sequence[Any], *, workers: int | None = None, scheduler: str | None = None,
              retries: int = DEFAULT_RETRIES, advance: Callable[[float], None] | None = None) -> list[Outcome]:  # fmt: skip
    """``fn`` over ``items``, one :class:`Outcome` each in order; ``advance(1)`` after each (module docstring)."""
    advance = advance or (lambda amount: None)
    if workers is not None and scheduler is not None:
        raise ClusterError("give --workers N (a cluster on this machine) or --scheduler ADDRESS (an existing one), not both")
    if workers is None and scheduler is None:
        outcomes = []
        for item in items:
            try:
                outcomes.append(Outcome(fn(item)))
            except Exception as exc:  # reported with its item, as on a cluster
                outcomes.append(Outcome(error=f"{type(exc).__name__}: {exc}"))
            advance(1)
        return outcomes
    if workers is not None and workers < 1:
        raise ClusterError(f"--workers {workers}: expected at least 1")
    distributed = _dask()
    if scheduler is not None:
        try:
            client = distributed.Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError, ValueError) as exc:  # ValueError: an address dask cannot read (file://...)
            raise ClusterError(
                f"cannot reach the Dask scheduler at {scheduler} ({exc}); start one with `dask scheduler` and "
                "workers with `dask worker ADDRESS`"
            ) from None
        with client:
            return _on(client, distributed, fn, items, retries, advance)
    import dask

    # Dask sets MALLOC_TRIM_THRESHOLD_ in its workers, which fixes glibc's mmap threshold: every array over 128 kB is
    # then mapped and unmapped afresh, and a sweep's workers spend a third of their time in page faults (measured:
    # 0.21 s per variant against 0.13 s).  Its other settings (one BLAS thread per worker) stay.
    environ = {k: v for k, v in dask.config.get("distributed.nanny.pre-spawn-environ").items() if k != "MALLOC_TRIM_THRESHOLD_"}
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}), ExitStack() as stack:
        with signals_deferred():  # Ctrl-C while the workers start left a half-made cluster that Dask's atexit choked on
            cluster = stack.enter_context(distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                                   dashboard_address=None, silence_logs=logging.CRITICAL))
            client = stack.enter_context(distributed.Client(cluster))
        return _on(client, distributed, fn, items, retries, advance)


def _on(client, distributed, fn, items, retries: int, advance) -> list[Outcome]:
    futures = client.map(fn, list(items), retries=retries, pure=False)
    where = {future.key: i for i, future in enumerate(futures)}
    outcomes: list[Outcome | None] = [None] * len(futures)
    for future in distributed.as_completed(futures):
        i = where[future.key]
        try:
            outcomes[i] = Outcome(future.result())
        except Exception as exc:  # a task's own error or a worker lost too often: reported with its item
            outcomes[i] = Outcome(error=f"{type(exc).__name__}: {exc}")
        advance(1)
    return [o if o is not None else Outcome(error="no result came back") for o in outcomes]
