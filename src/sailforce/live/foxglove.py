"""A Foxglove live view (``sail live --foxglove [PORT]``): the wrench, the joint states and the status, served with
``foxglove-sdk`` (the ``ros`` extra) over Foxglove's WebSocket protocol on 127.0.0.1.

Foxglove Studio connects to ``ws://127.0.0.1:PORT`` ("Open connection",
"Foxglove WebSocket") and shows the arm's force beside the rest of a ROS
lab's data.  Three JSON channels, one message per row, logged at the row's
time (:func:`sailforce.live.sources.now`, in nanoseconds since the epoch, as
Foxglove's timeline wants):

- ``/sail/wrench``: ``timestamp`` (``sec``, ``nsec``), ``frame_id``
  (:data:`sailforce.io.rosbag.FRAME_ID`), ``force`` and ``torque``
  (``x, y, z`` [N], [N m]; torque zero), ``t_s`` (the row's own time, null
  without one);
- ``/sail/joint_states``: ``timestamp``, ``name`` (``theta1``, ``theta2``),
  ``position`` [rad];
- ``/sail/status``: ``timestamp``, ``code`` and ``name`` (:data:`sailforce.status.STATUS_NAMES`).

A force that is not a number (a singular or invalid row) is sent as null.
"""

from __future__ import annotations

import math

import numpy as np

from .._extras import require
from ..io.rosbag import FRAME_ID, JOINT_NAMES, Topics
from ..status import STATUS_NAMES
from .pipeline import Rows

#: Foxglove's customary port.
DEFAULT_PORT = 8765

_TIME = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_VECTOR = {"type": "object", "properties": {axis: {"type": ["number", "null"]} for axis in "xyz"}}
#: The channels' JSON schemas.
SCHEMAS = {
    "wrench": {"title": "sail.Wrench", "type": "object", "properties": {
        "timestamp": _TIME, "frame_id": {"type": "string"}, "force": _VECTOR, "torque": _VECTOR,
        "t_s": {"type": ["number", "null"]}}},
    "joints": {"title": "sail.JointState", "type": "object", "properties": {
        "timestamp": _TIME, "name": {"type": "array", "items": {"type": "string"}},
        "position": {"type": "array", "items": {"type": ["number", "null"]}}}},
    "status": {"title": "sail.Status", "type": "object", "properties": {
        "timestamp": _TIME, "code": {"type": "integer"}, "name": {"type": "string", "enum": list(STATUS_NAMES)}}},
}  # fmt: skip


def _number(x: float) -> float | None:
    return x if math.isfinite(x) else None


class FoxgloveView:
    """A pipeline listener serving each block of rows to Foxglove (see the module docstring); ``close()`` stops it."""

    def __init__(self, port: int = DEFAULT_PORT, *, topics: Topics | None = None) -> None:
        foxglove = require("foxglove", "ros", "--foxglove")
        topics = topics or Topics()
        self._context = foxglove.Context()
        self._server = foxglove.start_server(name="sailforce", host="127.0.0.1", port=port, context=self._context)
        self._wrench = foxglove.Channel(topics.wrench, schema=SCHEMAS["wrench"], context=self._context)
        self._joints = foxglove.Channel(topics.joints, schema=SCHEMAS["joints"], context=self._context)
        self._status = foxglove.Channel(topics.status, schema=SCHEMAS["status"], context=self._context)

    @property
    def port(self) -> int:
        return int(self._server.port)

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    def __call__(self, rows: Rows) -> None:
        ns = np.round(rows.stamps * 1e9).astype(np.int64)
        t = rows.values.get("t_s")
        q = np.radians(np.column_stack([rows.values["theta1_deg"], rows.values["theta2_deg"]]))
        fx, fy = rows.columns["fx_N"], rows.columns["fy_N"]
        for i in range(len(rows)):
            stamp = {"sec": int(ns[i] // 1_000_000_000), "nsec": int(ns[i] % 1_000_000_000)}
            log_time = int(ns[i])
            self._wrench.log({"timestamp": stamp, "frame_id": FRAME_ID,
                              "force": {"x": _number(float(fx[i])), "y": _number(float(fy[i])), "z": 0.0},
                              "torque": {"x": 0.0, "y": 0.0, "z": 0.0},
                              "t_s": None if t is None else _number(float(t[i]))}, log_time=log_time)  # fmt: skip
            self._joints.log({"timestamp": stamp, "name": list(JOINT_NAMES),
                              "position": [_number(float(q[i, 0])), _number(float(q[i, 1]))]}, log_time=log_time)  # fmt: skip
            code = int(rows.status[i])
            self._status.log({"timestamp": stamp, "code": code, "name": STATUS_NAMES[code]}, log_time=log_time)

    def close(self) -> None:
        self._server.stop()
