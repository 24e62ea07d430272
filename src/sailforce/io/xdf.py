"""XDF recordings (Lab Streaming Layer's file format, written by LabRecorder), read with ``pyxdf`` (the ``ros`` extra).

:func:`read_xdf` gives one stream of a file as a table of readings:

- its channel labels (``desc/channels/channel/label``) are the column names:
  ``theta1_deg, theta2_deg, load1, load2`` and any others, which pass
  through (``fx_N, fy_N`` for ``sail calibrate``); a stream without labels
  takes :data:`sailforce.io.tables.READING_COLUMNS` in that order when it has
  four channels;
- ``t_s`` is pyxdf's timestamp of each sample in LSL time, with pyxdf's
  default clock synchronisation and dejittering applied, and not shifted to
  the first sample.  A channel of the stream that is itself labelled ``t_s``
  (a device's own time) is kept as ``t_s_stream``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa

from .._extras import require
from ..errors import InputError
from .tables import READING_COLUMNS

#: The column of pyxdf's timestamps.
TIME_COLUMN = "t_s"
#: A stream's own channel named like the timestamps' column is kept under this name.
STREAM_TIME_COLUMN = "t_s_stream"


def is_xdf(path: str | Path) -> bool:
    return Path(path).suffix.lower() in (".xdf", ".xdfz")


def _first(info: dict, key: str, default: str = "") -> str:
    value = info.get(key)
    return str(value[0]) if isinstance(value, list) and value and value[0] is not None else default


def _labels(info: dict) -> list[str]:
    """The stream's channel labels, or [] when its description has none."""
    desc = info.get("desc")
    try:
        channels = desc[0]["channels"][0]["channel"]
        return [str(channel["label"][0]) for channel in channels]
    except (TypeError, KeyError, IndexError):
        return []


def stream_names(path: str | Path) -> list[str]:
    """The names of the streams in an XDF file (its headers only)."""
    pyxdf = require("pyxdf", "ros", "reading an XDF file")
    try:
        return [str(s.get("name") or "") for s in pyxdf.resolve_streams(str(path))]
    except Exception as exc:  # pyxdf raises bare Exceptions on a file that is not XDF
        raise InputError(f"{path}: not a readable XDF file ({exc})") from None


def read_xdf(path: str | Path, stream: str) -> pa.Table:
    """Stream ``stream`` of the XDF file ``path`` as a table (see the module docstring)."""
    pyxdf = require("pyxdf", "ros", "reading an XDF file")
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        streams, _ = pyxdf.load_xdf(str(path))
    except Exception as exc:  # a truncated or foreign file: pyxdf raises Exception, struct.error, ValueError ...
        raise InputError(f"{path}: not a readable XDF file ({exc})") from None
    names = [_first(s["info"], "name") for s in streams]
    chosen = [s for s, name in zip(streams, names) if name == stream]
    if len(chosen) != 1:
        found = ", ".join(repr(n) for n in names) or "none"
        what = "no stream" if not chosen else f"{len(chosen)} streams"
        raise InputError(f"{path}: {what} named {stream!r} (its streams: {found}); --stream names one")
    info, series, stamps = chosen[0]["info"], chosen[0]["time_series"], np.asarray(chosen[0]["time_stamps"], dtype=float)
    if _first(info, "channel_format") == "string":
        raise InputError(f"{path}: stream {stream!r} holds text (markers), not readings")
    values = np.asarray(series, dtype=float).reshape(len(stamps), -1)
    labels = _labels(info)
    if len(labels) != values.shape[1]:
        if values.shape[1] != len(READING_COLUMNS):
            raise InputError(f"{path}: stream {stream!r} has {values.shape[1]} channels and no labels; label them "
                             f"{', '.join(READING_COLUMNS)} (and any others), or send those four in that order")  # fmt: skip
        labels = list(READING_COLUMNS)
    missing = [c for c in READING_COLUMNS if c not in labels]
    if missing:
        raise InputError(f"{path}: stream {stream!r} has the channels {', '.join(labels)}; "
                         f"{', '.join(missing)} missing (the readings are {', '.join(READING_COLUMNS)})")  # fmt: skip
    if len(set(labels)) != len(labels):
        raise InputError(f"{path}: stream {stream!r} labels two channels alike: {', '.join(labels)}")
    columns = {STREAM_TIME_COLUMN if label == TIME_COLUMN else label: values[:, i] for i, label in enumerate(labels)}
    return pa.table({**columns, TIME_COLUMN: stamps})
