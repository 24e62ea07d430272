"""Lab Streaming Layer (pylsl, whose wheel bundles liblsl): the force as an outlet, the readings from an inlet.

- **Outlet** (``--lsl-out NAME``): one stream of type ``Force``, irregular
  rate, ``double64``, channels ``fx_N, fy_N, force_N, angle_deg, status``.
  A row without a force (singular, invalid) sends NaN for it.  ``status`` is
  the code of :data:`sailforce.estimate.estimator.STATUS_NAMES`, whose
  names the stream's description lists (``desc/status_codes``), so
  LabRecorder's XDF files carry them.  Each sample is stamped with its
  reading's time, on LSL's clock.
- **Inlet** (``--lsl-in NAME``): a stream with channels ``theta1_deg,
  theta2_deg, load1, load2`` (and ``t_s``), labelled in its description or
  in that order; without a ``t_s`` channel, each sample's LSL timestamp is
  its ``t_s``.  The stream ends when its outlet closes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator

import numpy as np

from .._extras import require
from ..errors import InputError, ToolError
from ..estimate.estimator import STATUS_NAMES
from ..io.tables import READING_COLUMNS
from .pipeline import Rows
from .sources import Block

OUTLET_CHANNELS = (("fx_N", "N"), ("fy_N", "N"), ("force_N", "N"), ("angle_deg", "degrees"), ("status", "code"))

#: An inlet's channels when its description does not label them: the readings, then t_s.
INLET_COLUMNS = (*READING_COLUMNS, "t_s")

#: How long ``--lsl-in`` looks for its stream before giving up [s].
RESOLVE_TIMEOUT_S = 10.0

#: An inlet is polled this often for new samples [s].
PULL_TIMEOUT_S = 0.05

#: liblsl's log level: errors only (its INFO lines would fill a terminal).
_LOG_CONFIG = "[log]\nlevel = -2\n"
_configured = False


def _pylsl(flag: str):
    """pylsl, configured once (before liblsl's first call), or an error naming the extra that brings it."""
    global _configured
    pylsl = require("pylsl", "live", flag)
    if not _configured:
        _configured = True
        try:
            pylsl.util.set_config_content(_LOG_CONFIG)
        except Exception:  # liblsl already started (a test's outlet): keep its configuration
            pass
    return pylsl


def _clock_offset(pylsl) -> float:
    """LSL's clock less the wall clock [s]."""
    return pylsl.local_clock() - time.time()


class Outlet:
    """The live force as an LSL outlet; a pipeline listener (see the module docstring)."""

    def __init__(self, name: str, source_id: str | None = None) -> None:
        pylsl = _pylsl("--lsl-out")
        info = pylsl.StreamInfo(name, "Force", len(OUTLET_CHANNELS), pylsl.IRREGULAR_RATE, pylsl.cf_double64,
                                source_id or f"sailforce-{name}")  # fmt: skip
        channels = info.desc().append_child("channels")
        for label, unit in OUTLET_CHANNELS:
            channel = channels.append_child("channel")
            channel.append_child_value("label", label)
            channel.append_child_value("unit", unit)
        codes = info.desc().append_child("status_codes")
        for code, status in enumerate(STATUS_NAMES):
            codes.append_child("code").append_child_value("value", str(code)).append_child_value("name", status)
        info.desc().append_child_value("software", "sailforce")
        self.name = name
        self._outlet = pylsl.StreamOutlet(info)
        self._offset = _clock_offset(pylsl)

    def __call__(self, rows: Rows) -> None:
        data = np.column_stack([rows.columns["fx_N"], rows.columns["fy_N"], rows.columns["force_N"],
                                rows.columns["angle_deg"], rows.status.astype(float)])  # fmt: skip
        self._outlet.push_chunk(data, (rows.stamps + self._offset).tolist())


def _labels(info) -> list[str]:
    channel = info.desc().child("channels").child("channel")
    labels = []
    while not channel.empty():
        labels.append(channel.child_value("label"))
        channel = channel.next_sibling()
    return labels


def inlet_blocks(name: str, *, timeout: float = RESOLVE_TIMEOUT_S) -> Iterator[Block]:
    """The readings of the LSL stream ``name`` as blocks of stamped CSV lines (:mod:`sailforce.live.sources`).

    The stream is found and its channels checked at once (the error comes
    here, not on a reader's thread).
    """
    pylsl = _pylsl("--lsl-in")
    found = pylsl.resolve_byprop("name", name, 1, timeout)
    if not found:
        raise ToolError(f"--lsl-in {name}: no Lab Streaming Layer stream of that name answered within {timeout:g} s; "
                        "is its outlet running, on this machine or this network?")  # fmt: skip
    inlet = pylsl.StreamInlet(found[0], recover=False, processing_flags=pylsl.proc_clocksync)
    info = inlet.info(timeout)
    count = info.channel_count()
    labels = _labels(info)
    if len(labels) != count or not set(READING_COLUMNS) <= set(labels):
        if count not in (len(READING_COLUMNS), len(INLET_COLUMNS)):
            raise InputError(f"--lsl-in {name}: {count} channels labelled {', '.join(labels) or '(none)'}; expected "
                            f"{', '.join(INLET_COLUMNS)} (t_s optional), labelled or in that order")  # fmt: skip
        labels = list(INLET_COLUMNS[:count])
    stamp_column = "t_s" not in labels
    header = ",".join(labels + (["t_s"] if stamp_column else [])) + "\n"

    def blocks() -> Iterator[Block]:
        yield [(header.encode(), time.time())]
        offset = _clock_offset(pylsl)
        while True:
            try:
                samples, stamps = inlet.pull_chunk(timeout=PULL_TIMEOUT_S)
            except pylsl.util.LostError:
                return  # the outlet has closed: the stream has ended
            if not samples:
                continue
            block = []
            for sample, stamp in zip(samples, stamps):
                values = list(sample) + ([stamp] if stamp_column else [])
                line = ",".join("" if not math.isfinite(v) else repr(float(v)) for v in values) + "\n"
                block.append((line.encode(), stamp - offset))
            yield block

    return blocks()
