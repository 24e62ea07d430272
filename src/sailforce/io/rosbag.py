"""ROS 2 bags: estimates out as MCAP in ROS 2's message encoding (CDR), readings in from MCAP files and rosbag2 folders.

Written with the ``mcap`` and ``mcap-ros2-support`` packages (the ``ros``
extra); no ROS installation is needed.  ``rosbags`` and ``ros2 bag`` open
the file as a rosbag2 MCAP bag, Foxglove Studio plays it.

**Out** (:class:`BagWriter`, ``sail estimate … --mcap-out FILE.mcap``), one
message per row on each topic (:class:`Topics`), each logged at the row's
``t_s`` (the input's own seconds, no epoch added):

- ``geometry_msgs/msg/WrenchStamped`` (``/sail/wrench``): the force in the
  base frame (:data:`FRAME_ID`), torque zero, NaN where the row has no force;
  ``header.stamp`` the estimate's own instant: ``force_t_s`` for a
  multi-rate recording (the conversion's centroid; the row's ``t_s`` before
  the first estimate), else ``t_s``;
- ``sensor_msgs/msg/JointState`` (``/sail/joint_states``): ``theta1``,
  ``theta2`` in radians, with the rates (``omega1_dps``, ``omega2_dps``:
  measured, or derived by the dynamic term's differentiator) as velocities
  when there are any;
- ``std_msgs/msg/Float64MultiArray`` (``/sail/loads``): ``[load1, load2]``,
  the raw readings (NaN where the row has no conversion);
- ``std_msgs/msg/UInt8`` (``/sail/status``): the status code of
  :data:`sailforce.status.STATUS_NAMES`.  The codes' names are in the file's
  metadata record ``sailforce.status_codes`` (code -> name): mcap-ros2's
  writer registers its channels without metadata.

Rows without a time (``t_s`` not a number) are not in the bag: the writer
counts them (:attr:`BagWriter.untimed`) and the command says how many.

**In** (:func:`read_bag`): ``sensor_msgs/msg/JointState`` on ``/joint_states``
(positions in radians, named ``theta1`` and ``theta2``, or the first two in
that order) and the loads as ``std_msgs/msg/Float64MultiArray`` ``[load1,
load2]`` on ``/sail/loads``, each pair of the same stamp one row (the joint
state's ``header.stamp``, the loads' publish time): the table of
:data:`BAG_COLUMNS` in the order of the stamps.  A message without its pair
is counted (:attr:`BagReadings.unpaired`), never silently lost.  For
``sail calibrate``, a reference force sensor's
``geometry_msgs/msg/WrenchStamped`` (``/sail/reference_wrench``) joins each
pair at its ``header.stamp`` as ``fx_N, fy_N``.
"""

from __future__ import annotations

import struct
import sys
from collections.abc import Iterable, Mapping
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from .._extras import require
from ..errors import InputError
from ..status import STATUS_NAMES
from .files import atomic_writer

#: The wrench's frame: the robot's base (the frame of the kinematics, sailforce.kinematics), x and y in the plane.
FRAME_ID = "sail_base"
#: The joint names of the joint states written, and looked for in those read.
JOINT_NAMES = ("theta1", "theta2")
#: The table :func:`read_bag` gives, as ``sail estimate`` reads it.
BAG_COLUMNS = ("theta1_deg", "theta2_deg", "load1", "load2", "t_s")
NS_PER_S = 1_000_000_000

_RULE = "=" * 80 + "\n"
_TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
_HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
#: ROS 2 message definitions (common_interfaces, Humble and later), dependencies after the type, as rosbag2 stores them.
MESSAGE_DEFINITIONS = {
    "geometry_msgs/msg/WrenchStamped": "std_msgs/Header header\nWrench wrench\n" + _RULE + _HEADER + _RULE + _TIME
    + _RULE + "MSG: geometry_msgs/Wrench\nVector3 force\nVector3 torque\n"
    + _RULE + "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
    "sensor_msgs/msg/JointState": "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
    "float64[] effort\n" + _RULE + _HEADER + _RULE + _TIME,
    "std_msgs/msg/Float64MultiArray": "MultiArrayLayout layout\nfloat64[] data\n"
    + _RULE + "MSG: std_msgs/MultiArrayLayout\nMultiArrayDimension[] dim\nuint32 data_offset\n"
    + _RULE + "MSG: std_msgs/MultiArrayDimension\nstring label\nuint32 size\nuint32 stride\n",
    "std_msgs/msg/UInt8": "uint8 data\n",
}  # fmt: skip


@dataclass(frozen=True)
class Topics:
    """The topics a bag is written with (``--wrench-topic`` …)."""

    wrench: str = "/sail/wrench"
    joints: str = "/sail/joint_states"
    loads: str = "/sail/loads"
    status: str = "/sail/status"

    def __post_init__(self) -> None:
        names = (self.wrench, self.joints, self.loads, self.status)
        for name in names:
            if not name.startswith("/") or name.endswith("/") or " " in name:
                raise InputError(f"{name!r} is not a ROS topic name: give an absolute name such as /sail/wrench")
        if len(set(names)) != len(names):
            raise InputError(f"the four topics must differ: {', '.join(names)}")


def _mcap_ros2(feature: str):
    require("mcap", "ros", feature)
    return require("mcap_ros2.writer", "ros", feature)


def _stamp(ns: int) -> dict[str, int]:
    """builtin_interfaces/Time of ``ns`` nanoseconds (a negative time's sec is floored, nanosec in [0, 1e9))."""
    return {"sec": ns // NS_PER_S, "nanosec": ns % NS_PER_S}


def _nanoseconds(seconds: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(seconds, dtype=float) * NS_PER_S).astype(np.int64)


class BagWriter:
    """An MCAP file being written, row by row (see the module docstring); a context manager.

    The file appears only when closed without error (atomic write); an
    interrupt keeps what was written (a live recording).
    """

    def __init__(self, path: str | Path, topics: Topics = Topics(), *, frame_id: str = FRAME_ID) -> None:
        ros = _mcap_ros2("--mcap-out")
        self.path = Path(path)
        self.topics = topics
        self.frame_id = frame_id
        self.rows = 0
        self.untimed = 0  #: rows left out: their t_s is not a number
        self._files = ExitStack()
        stream = self._files.enter_context(atomic_writer(self.path, "wb", keep_on_interrupt=True))
        try:
            self._writer = ros.Writer(stream)
            self._schemas = {name: self._writer.register_msgdef(name, text) for name, text in MESSAGE_DEFINITIONS.items()}
            self._writer.add_metadata("sailforce.status_codes", {str(code): name for code, name in enumerate(STATUS_NAMES)})
            self._writer.add_metadata("sailforce.topics", {"wrench": topics.wrench, "joint_states": topics.joints,
                                                          "loads": topics.loads, "status": topics.status,
                                                          "frame_id": frame_id})  # fmt: skip
        except BaseException:
            self._files.__exit__(*sys.exc_info())
            raise
        self._open = True

    def write(self, values: Mapping[str, np.ndarray], columns: Mapping[str, np.ndarray], status: np.ndarray) -> None:
        """One block of rows: the input's numbers (theta1_deg, theta2_deg, load1, load2, t_s; omega1_dps, omega2_dps
        if measured) and the estimate's columns (fx_N, fy_N, force_t_s if multi-rate) and status codes."""
        if "t_s" not in values:
            raise InputError("--mcap-out stamps every message with the row's time: the input needs a t_s column [s]")
        t = np.asarray(values["t_s"], dtype=float)
        timed = np.isfinite(t)
        if np.any(t[timed] < 0):
            raise InputError(f"t_s = {t[timed].min():g} s: MCAP's log times start at 0, so --mcap-out needs t_s >= 0")
        self.untimed += int(np.count_nonzero(~timed))
        log = _nanoseconds(np.where(timed, t, 0.0))
        force_t = np.asarray(columns.get("force_t_s", t), dtype=float)
        at = _nanoseconds(np.where(np.isfinite(force_t), force_t, np.where(timed, t, 0.0)))
        q = np.radians(np.column_stack([values["theta1_deg"], values["theta2_deg"]]))
        rates = (np.radians(np.column_stack([values["omega1_dps"], values["omega2_dps"]]))
                 if "omega1_dps" in values and "omega2_dps" in values else None)  # fmt: skip
        loads = np.column_stack([values["load1"], values["load2"]])
        fx, fy = np.asarray(columns["fx_N"], dtype=float), np.asarray(columns["fy_N"], dtype=float)
        write, schema, topics = self._writer.write_message, self._schemas, self.topics
        layout = {"dim": [{"label": "cell", "size": 2, "stride": 2}], "data_offset": 0}
        for i in np.flatnonzero(timed):
            ns = int(log[i])
            header = {"stamp": _stamp(ns), "frame_id": self.frame_id}
            write(topics.wrench, schema["geometry_msgs/msg/WrenchStamped"],
                  {"header": {"stamp": _stamp(int(at[i])), "frame_id": self.frame_id},
                   "wrench": {"force": {"x": float(fx[i]), "y": float(fy[i]), "z": 0.0},
                              "torque": {"x": 0.0, "y": 0.0, "z": 0.0}}}, log_time=ns, sequence=self.rows)
            write(topics.joints, schema["sensor_msgs/msg/JointState"],
                  {"header": header, "name": list(JOINT_NAMES), "position": [float(q[i, 0]), float(q[i, 1])],
                   "velocity": [] if rates is None else [float(rates[i, 0]), float(rates[i, 1])], "effort": []},
                  log_time=ns, sequence=self.rows)
            write(topics.loads, schema["std_msgs/msg/Float64MultiArray"],
                  {"layout": layout, "data": [float(loads[i, 0]), float(loads[i, 1])]}, log_time=ns, sequence=self.rows)
            write(topics.status, schema["std_msgs/msg/UInt8"], {"data": int(status[i])}, log_time=ns, sequence=self.rows)
            self.rows += 1

    def close(self, error: BaseException | None = None) -> None:
        """Finish the file (its summary and index) and put it into place; after an ``error``, as the atomic writer
        does (nothing, or, after an interrupt, what was written)."""
        if not self._open:
            return
        self._open = False
        if error is None or isinstance(error, KeyboardInterrupt):
            self._writer.finish()
        self._files.__exit__(type(error) if error else None, error, error.__traceback__ if error else None)

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, kind, error, traceback) -> None:
        self.close(error)


@dataclass(frozen=True)
class BagReadings:
    """What :func:`read_bag` found: the readings' table and what could not be paired."""

    table: pa.Table  #: :data:`BAG_COLUMNS`, one row per pair, in the order of the stamps
    unpaired: dict[str, int]  #: topic -> messages without a partner of the same stamp


def bag_files(path: str | Path) -> list[Path]:
    """The MCAP files of a bag: the file itself, or a rosbag2 folder's ``*.mcap`` in name order."""
    path = Path(path)
    if path.is_dir():
        files = sorted(path.glob("*.mcap"))
        if not files:
            raise InputError(f"{path}: a folder without .mcap files is not a rosbag2 MCAP bag (a .db3 bag: convert it "
                             "with `ros2 bag convert` or rosbags-convert)")  # fmt: skip
        return files
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    return [path]


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` names an MCAP file or a rosbag2 folder (by its suffix or its metadata.yaml)."""
    path = Path(path)
    return path.suffix.lower() == ".mcap" or (path.is_dir() and (path / "metadata.yaml").exists())


def _messages(files: Iterable[Path], topics: list[str]):
    require("mcap", "ros", "reading an MCAP bag")
    decoder = require("mcap_ros2.decoder", "ros", "reading an MCAP bag")
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    for file in files:
        try:
            with open(file, "rb") as stream:
                reader = make_reader(stream, decoder_factories=[decoder.DecoderFactory()])
                yield from reader.iter_decoded_messages(topics=topics, log_time_order=True)
        except (McapError, ValueError, KeyError, EOFError, OSError, struct.error) as exc:
            raise InputError(f"{file}: not a readable MCAP file ({exc})") from None


def _topics_of(files: Iterable[Path]) -> dict[str, str]:
    """Topic -> message type of every channel the files' summaries list."""
    from mcap.reader import make_reader

    topics = {}
    for file in files:
        with open(file, "rb") as stream:
            summary = make_reader(stream).get_summary()
        if summary is not None:
            for channel in summary.channels.values():
                schema = summary.schemas.get(channel.schema_id)
                topics[channel.topic] = schema.name if schema is not None else "no schema"
    return topics


def read_bag(path: str | Path, joint_topic: str = "/joint_states", load_topic: str = "/sail/loads",
             force_topic: str | None = None) -> BagReadings:  # fmt: skip
    """The readings of an MCAP bag (see the module docstring): angles in degrees, loads as recorded, t_s the stamp.

    With ``force_topic`` (``sail calibrate --force-topic``), each row also
    pairs the ``geometry_msgs/msg/WrenchStamped`` of the same
    ``header.stamp`` there, a reference sensor's force in the base frame, as
    ``fx_N, fy_N``.
    """
    joints: dict[int, tuple[float, float]] = {}
    loads: dict[int, tuple[float, float]] = {}
    forces: dict[int, tuple[float, float]] = {}
    wanted = {joint_topic: "sensor_msgs/msg/JointState", load_topic: "std_msgs/msg/Float64MultiArray"}
    if force_topic is not None:
        wanted[force_topic] = "geometry_msgs/msg/WrenchStamped"
    options = {joint_topic: "--joint-topic", load_topic: "--load-topic", force_topic: "--force-topic"}
    for schema, channel, message, decoded in _messages(bag_files(path), list(wanted)):
        topic = channel.topic
        kind = schema.name if schema is not None else "(no schema)"
        if kind != wanted[topic]:
            raise InputError(f"{path}: {topic} carries {kind}, not {wanted[topic]} ({options[topic]} names "
                             "the topic)")  # fmt: skip
        if topic == joint_topic:
            names, position = list(decoded.name), list(decoded.position)
            if all(name in names for name in JOINT_NAMES):
                picked = [position[names.index(name)] for name in JOINT_NAMES]
            elif len(position) >= 2:
                picked = position[:2]
            else:
                raise InputError(f"{path}: a joint state on {joint_topic} has {len(position)} position(s); "
                                 "theta1 and theta2 are needed")  # fmt: skip
            joints[decoded.header.stamp.sec * NS_PER_S + decoded.header.stamp.nanosec] = (picked[0], picked[1])
        elif topic == load_topic:
            data = list(decoded.data)
            if len(data) != 2:
                raise InputError(f"{path}: a message on {load_topic} holds {len(data)} values; [load1, load2] expected")
            loads[message.publish_time or message.log_time] = (data[0], data[1])
        else:
            stamp = decoded.header.stamp.sec * NS_PER_S + decoded.header.stamp.nanosec
            forces[stamp] = (decoded.wrench.force.x, decoded.wrench.force.y)
    found = {joint_topic: joints, load_topic: loads} | ({force_topic: forces} if force_topic is not None else {})
    for topic, messages in found.items():
        if not messages:
            held = _topics_of(bag_files(path))
            seen = f" (it has {', '.join(f'{t} ({kind})' for t, kind in sorted(held.items()))})" if held else " (it is empty)"
            raise InputError(f"{path}: no messages on {topic}{seen}; {options[topic]} names the topic")
    common = set(joints) & set(loads) & (set(forces) if force_topic is not None else set(joints))
    stamps = np.array(sorted(common), dtype=np.int64)
    if stamps.size == 0:
        raise InputError(f"{path}: no stamp is on every one of {', '.join(found)}: each row pairs their messages at "
                         "the same stamp")  # fmt: skip
    q = np.degrees(np.array([joints[s] for s in stamps.tolist()]))
    r = np.array([loads[s] for s in stamps.tolist()])
    columns = {"theta1_deg": q[:, 0], "theta2_deg": q[:, 1], "load1": r[:, 0], "load2": r[:, 1]}
    if force_topic is not None:
        f = np.array([forces[s] for s in stamps.tolist()])
        columns |= {"fx_N": f[:, 0], "fy_N": f[:, 1]}
    table = pa.table(columns | {"t_s": stamps / NS_PER_S})
    return BagReadings(table, {topic: len(messages) - stamps.size for topic, messages in found.items()})
