"""The bad-input corpus: every case runs the real ``sail`` command in a fresh folder.

Each case states the exit code and a phrase of the one-line message, and the
test asserts, beyond those: no traceback; no file that existed before was
changed (content hashes, and symlinks stay symlinks), except the output the
case names; and, for ``sail estimate``, one output row per input line.
These are the promises of docs/reference/guarantees.md.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

ROOT = Path(__file__).resolve().parents[1]
SAIL = Path(sys.executable).parent / "sail"
CAL = (ROOT / "c" / "examples" / "calibration.json").read_bytes()
OFFSETS = (-42809.444444444474, 76765.55952380953)  #: c/examples/calibration.json's offsets

HEADER = b"theta1_deg,theta2_deg,load1,load2,note\n"


def reading(theta1=90, theta2=0, load1=OFFSETS[0] + 1000, load2=OFFSETS[1] - 500, note="x") -> bytes:
    return f"{theta1},{theta2},{load1:.0f},{load2:.0f},{note}\n".encode()


GOOD = HEADER + b"".join(reading(theta1=60 + i) for i in range(20))
NOLOAD = b"load1,load2\n" + b"".join(f"{OFFSETS[0] + i % 3:.0f},{OFFSETS[1] - i % 2:.0f}\n".encode() for i in range(40))
ROBOT_TOML = b"[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n"

def _resealed(edit) -> bytes:
    """c/examples/calibration.json edited by ``edit(data)`` and its checksum recomputed, as anyone can."""
    from sailforce.calibration.file import checksum

    data = json.loads(CAL)
    edit(data)
    data.pop("checksum")
    return json.dumps(data | {"checksum": checksum(data)}).encode()


def _set(*path_value):
    def edit(data):
        *path, key, value = path_value
        node = data
        for part in path:
            node = node[part]
        node[key] = value

    return edit


def _scaled_model(factor):
    def edit(data):
        data["model"]["coefficients"] = [[[c * factor for c in row] for row in m] for m in data["model"]["coefficients"]]

    return edit


MS_TABLE = b"t_s,theta1_deg,theta2_deg,load1,load2\n" + b"".join(
    f"{k},{80 + 0.01 * k:.4f},10,{OFFSETS[0] + 900:.0f},{OFFSETS[1] - 400:.0f}\n".encode() for k in range(300))



@dataclass(frozen=True)
class Case:
    """One invocation: the files it starts with, its arguments, and what must come out."""

    name: str
    args: tuple[str, ...]
    code: int
    phrase: str = ""  #: a fragment of the one-line message (stderr), or of stdout on success
    files: dict[str, bytes] = field(default_factory=dict)
    links: dict[str, str] = field(default_factory=dict)  #: symlink name -> target
    stdin: bytes = b""
    output: str | None = None  #: the one file the command may create or replace
    rows_of: tuple[str, str] | None = None  #: (input, output) whose line counts must match


def _base(**files: bytes) -> dict[str, bytes]:
    return {"cal.json": CAL, "in.csv": GOOD, **files}


CASES = [
    # 1. An unclosed quote must not swallow the rows after it (file mode and stream mode).
    Case("unclosed quote, file", ("estimate", "--calibration", "cal.json", "q.csv", "-o", "out.csv"), 0,
         files=_base(**{"q.csv": HEADER + reading() + reading(note='"open') + reading() * 3000}),
         output="out.csv", rows_of=("q.csv", "out.csv")),
    Case("unclosed quote, stdin", ("estimate", "--calibration", "cal.json", "-", "-o", "out.csv"), 0,
         files=_base(), stdin=HEADER + reading() + reading(note='"open') + reading() * 50, output="out.csv"),
    # 2. simulate's sidecar never replaces another file; data and sidecar never coincide.
    Case("simulate beside a calibration", ("simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "cal.csv"), 0,
         files={"cal.json": CAL}, output="cal.csv"),
    Case("simulate -o x.json", ("simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "x.json"), 1, "unknown table format"),
    # 3. Live mode leaves an existing output alone until the stream is known to be a table.
    Case("live, empty stdin", ("estimate", "--calibration", "cal.json", "-", "-o", "keep.csv"), 1, "ended before its header",
         files=_base(**{"keep.csv": b"precious\n"})),
    Case("live, bad header", ("estimate", "--calibration", "cal.json", "-", "-o", "keep.csv"), 1, "missing column",
         files=_base(**{"keep.csv": b"precious\n"}), stdin=b"a,b,c\n1,2,3\n"),
    Case("live, header only", ("estimate", "--calibration", "cal.json", "-", "-o", "keep.csv"), 1, "no data rows",
         files=_base(**{"keep.csv": b"precious\n"}), stdin=HEADER),
    Case("file, header only", ("estimate", "--calibration", "cal.json", "h.csv", "-o", "keep.csv"), 1, "no data rows",
         files=_base(**{"keep.csv": b"precious\n", "h.csv": HEADER})),
    Case("live, mistyped serial port", ("estimate", "--calibration", "cal.json", "--serial", "/dev/nonexistent-tty", "-o", "keep.csv"),
         1, "cannot open", files=_base(**{"keep.csv": b"precious\n"})),
    # 4. An output that is an input is refused, however it is spelt.
    Case("estimate -o IN", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "in.csv"), 1, "input table", files=_base()),
    Case("estimate -o ./IN", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "./sub/../in.csv"), 1, "input table",
         files=_base(**{"sub/.keep": b""})),
    Case("estimate -o link to IN", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "link.csv"), 1, "input table",
         files=_base(), links={"link.csv": "in.csv"}),
    Case("estimate -o hard link to IN", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "hard.csv"), 1, "input table",
         files=_base(), links={"hard.csv": "hard:in.csv"}),
    Case("estimate -o CAL", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "cal.json"), 1, "--calibration file",
         files=_base()),
    Case("estimate -o CAL as csv", ("estimate", "--calibration", "c.csv", "in.csv", "-o", "c.csv"), 1, "--calibration",
         files={"c.csv": CAL, "in.csv": GOOD}),
    Case("live -o IN", ("estimate", "--calibration", "cal.json", "-", "-o", "in.csv"), 0, files=_base(), stdin=GOOD,
         output="in.csv"),  # stdin is not a file: writing in.csv is what was asked
    Case("calibrate -o DATA", ("calibrate", "in.csv", "-o", "in.csv"), 1, "calibration data", files=_base()),
    Case("tare -o NOLOAD", ("tare", "cal.json", "n.csv", "-o", "n.csv"), 1, "no-load recording",
         files=_base(**{"n.csv": NOLOAD})),
    Case("tare -o CAL", ("tare", "cal.json", "n.csv", "-o", "cal.json"), 1, "calibration CAL.json",
         files=_base(**{"n.csv": NOLOAD})),
    Case("tare -o hard link to CAL", ("tare", "cal.json", "n.csv", "-o", "hard.json"), 1, "calibration CAL.json",
         files=_base(**{"n.csv": NOLOAD}), links={"hard.json": "hard:cal.json"}),
    Case("calibrate -o -", ("calibrate", "d.csv", "-o", "-"), 2, "a file",
         files={"d.csv": b"theta1_deg,theta2_deg,load1,load2,fx_N,fy_N\n90,0,1,2,1,0\n"}),
    Case("tare -o -", ("tare", "cal.json", "n.csv", "-o", "-"), 2, "a file", files=_base(**{"n.csv": NOLOAD})),
    Case("simulate sidecar not ours", ("simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "s.csv"), 1,
         "not a sidecar", files={"s.csv.json": b'{"my": "notes"}'}),
    Case("simulate sidecar a link to CAL", ("simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "s.csv"), 1,
         "symlink", files={"cal.json": CAL}, links={"s.csv.json": "cal.json"}),
    Case("simulate sidecar of an earlier run", ("simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "s.csv"), 0,
         files={"s.csv.json": b'{"software": "sailforce 0.1.0", "rows": 24}'}, output="s.csv"),
    Case("simulate-motion sidecar not ours", ("simulate-motion", "--session", "static", "-o", "m.csv"), 1,
         "not a sidecar", files={"m.csv.json": b"precious"}),
    Case("solid-sweep over its --protocol", ("solid-sweep", "--protocol", "out/poses.csv", "-o", "out"), 1,
         "--protocol file", files={"out/poses.csv": b"theta1_deg,theta2_deg\n60,20\n"}),
    Case("tare -o a link to /dev/null", ("tare", "cal.json", "n.csv", "-o", "null.json"), 1, "character device",
         files=_base(**{"n.csv": NOLOAD}), links={"null.json": "/dev/null"}),
    Case("estimate -o a link to /dev/null", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "dev.csv"), 1,
         "not a regular file", files=_base(), links={"dev.csv": "/dev/null"}),
    # Round two: the calibration file's authority, motion data, the robot file, the sweeps.
    Case("export-c injected comment", ("export-c", "c.json", "-o", "h.h"), 1, "created",
         files={"c.json": _resealed(_set("created", "x */ static const int injected = 1; /*"))}),
    Case("export-c injected load unit", ("export-c", "c.json", "-o", "h.h"), 1, "units.load",
         files={"c.json": _resealed(_set("units", "load", "raw */ int x; /*"))}),
    Case("calibration amplitude 1e-300", ("estimate", "--calibration", "c.json", "in.csv", "-o", "o.csv"), 1, "model",
         files={"c.json": _resealed(_scaled_model(1e-300)), "in.csv": GOOD}),
    Case("calibration capacity 1e308", ("estimate", "--calibration", "c.json", "in.csv", "-o", "o.csv"), 1, "capacity",
         files={"c.json": _resealed(_set("capacity", [1e308, 1e308])), "in.csv": GOOD}),
    Case("calibration reversed load range", ("estimate", "--calibration", "c.json", "in.csv", "-o", "o.csv"), 1,
         "load_range", files={"c.json": _resealed(_set("load_range", [[5.0, -5.0], [0.0, 1.0]])), "in.csv": GOOD}),
    Case("calibration schema_version true", ("estimate", "--calibration", "c.json", "in.csv", "-o", "o.csv"), 1,
         "schema_version", files={"c.json": _resealed(_set("schema_version", True)), "in.csv": GOOD}),
    Case("export-c 10,000-character name", ("export-c", "cal.json", "--name", "a" * 10_000, "-o", "h.h"), 1,
         "characters", files=_base()),
    Case("deeply nested robot TOML", ("robot", "show", "--robot", "r.toml"), 1, "nested too deeply",
         files={"r.toml": ROBOT_TOML + b"[x]\ny = " + b"[" * 5000 + b"]" * 5000 + b"\n"}),
    Case("--scheduler file://", ("design", "-o", "d", "--grid", "4", "--sweep", "loadcells.position=0.3,0.6",
                                 "--scheduler", "file:///tmp/nowhere"), 1, "cannot reach the Dask scheduler"),
    Case("--sweep key twice", ("design", "-o", "d", "--grid", "4", "--sweep", "loadcells.position=0.3,0.6",
                               "--sweep", "loadcells.position=0.4"), 1, "given twice"),
    Case("robot reading unknown", ("robot", "show", "--robot", "r.toml"), 1, "reading",
         files={"r.toml": ROBOT_TOML + b'[loadcells]\nreading = "strain"\n'}),
    Case("--columns without --serial", ("estimate", "--calibration", "cal.json", "-", "--columns", "a,b"), 2, "--serial",
         files=_base()),
    Case("simulate -o ROBOT", ("simulate", "--robot", "r.csv", "--theta1-deg=90", "--theta2-deg=0", "-o", "r.csv"), 1,
         "--robot", files={"r.csv": ROBOT_TOML}),
    Case("symlinked output stays a link", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "link.csv"), 0,
         files=_base(**{"real.csv": b"old\n"}), links={"link.csv": "real.csv"}, output="real.csv",
         rows_of=("in.csv", "real.csv")),
    # 5. One long line is one invalid row, in every mode.
    Case("200 KB field, file", ("estimate", "--calibration", "cal.json", "long.csv", "-o", "out.csv"), 0,
         files=_base(**{"long.csv": HEADER + reading(note="a" * 200_000) + reading()}), output="out.csv",
         rows_of=("long.csv", "out.csv")),
    Case("200 KB quoted field, stdin", ("estimate", "--calibration", "cal.json", "-"), 0, "invalid 1",
         files=_base(), stdin=HEADER + reading(note='"' + "a" * 200_000) + reading()),
    Case("3 MB line, file", ("estimate", "--calibration", "cal.json", "long.csv", "-o", "out.csv"), 0,
         files=_base(**{"long.csv": HEADER + reading() + b"9" * 3_000_000 + b"\n" + reading()}), output="out.csv",
         rows_of=("long.csv", "out.csv")),
    # 6. A table named .parquet is Parquet, or refused.
    Case("live to .parquet", ("estimate", "--calibration", "cal.json", "-", "-o", "o.parquet"), 1, "name it .csv",
         files=_base(), stdin=GOOD),
    Case("simulate to .parquet", ("simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "s.parquet"), 0, output="s.parquet"),
    Case("estimate to unknown format", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "o.xlsx"), 1,
         "unknown table format", files=_base()),
    # 7. One-line errors where tracebacks were.
    Case("binary robot file", ("robot", "show", "--robot", "r.toml"), 1, "not a text file",
         files={"r.toml": bytes(range(256))}),
    Case("links of 1e200 m", ("robot", "show", "--robot", "r.toml"), 1, "must lie between",
         files={"r.toml": b"[links]\nl1 = 1e200\nl2 = 1e200\nl3 = 2e200\nl4 = 1e200\n"}),
    Case("calibration data near 1e300", ("calibrate", "d.csv", "-o", "c.json"), 1, "within",
         files={"d.csv": b"theta1_deg,theta2_deg,load1,load2,fx_N,fy_N\n" + b"90,0,1e300,2e300,1,0\n" * 30}),
    Case("stray CR in a line", ("estimate", "--calibration", "cal.json", "cr.csv", "-o", "out.csv"), 0,
         files=_base(**{"cr.csv": HEADER + b"90,0,1\r2,3,x\n" + reading()}), output="out.csv", rows_of=("cr.csv", "out.csv")),
    Case("calibration file with 1e999", ("estimate", "--calibration", "c.json", "in.csv", "-o", "o.csv"), 1, "out of range",
         files={"c.json": CAL.replace(b'"capacity": [', b'"capacity": [1e999, '), "in.csv": GOOD}),  # found by make fuzz
    Case("calibration file with NaN", ("estimate", "--calibration", "c.json", "in.csv", "-o", "o.csv"), 1, "NaN",
         files={"c.json": CAL.replace(b'"capacity": [', b'"capacity": [NaN, '), "in.csv": GOOD}),
    Case("serial URL foo://", ("estimate", "--calibration", "cal.json", "--serial", "foo://"), 1, "cannot open", files=_base()),
    Case("stress -o x.xyz", ("stress", "-o", "x.xyz"), 2, "unknown image format"),
    Case("NaN force", ("statics", "--theta1-deg=90", "--theta2-deg=0", "--force-N=nan", "--phi-deg=0"), 2, "--force-N"),
    Case("singular statics", ("statics", "--theta1-deg=30", "--theta2-deg=30", "--t1-Nm=1", "--t2-Nm=1"), 1, "singular pose"),
    # 8. Huge grids are refused before memory runs out.
    Case("huge simulate grid", ("simulate", "--theta1-deg=0:180:0.001", "--theta2-deg=-90:90:0.01", "--phi-deg=0:359:0.001",
                                "-o", "s.csv"), 2, "--max-rows"),
    Case("huge stress panels", ("stress", "--phi-deg=0:359.9:0.001", "-o", "s.png"), 2, "at most"),
    # 10. export-c names.
    Case("export-c --name int", ("export-c", "cal.json", "--name", "int", "-o", "h.h"), 1, "C keyword", files=_base()),
    Case("export-c --name sail_reading", ("export-c", "cal.json", "--name", "sail_reading", "-o", "h.h"), 1, "sail.h",
         files=_base()),
    Case("export-c low-pass name clash", ("export-c", "cal.json", "--name", "sail", "--lowpass-Hz", "5", "--sample-rate-Hz", "80",
                                          "-o", "h.h"), 1, "sail_lowpass", files=_base()),
    Case("export-c -o CAL", ("export-c", "cal.json", "-o", "cal.json"), 1, "calibration file", files=_base()),
    # 11. stress names what it wrote.
    Case("stress without extension", ("stress", "-o", "fig"), 0, "wrote fig.png", output="fig.png"),
    # 12. tare.
    Case("tare from one sample", ("tare", "cal.json", "n.csv", "-o", "t.json"), 1, "at least 10",
         files=_base(**{"n.csv": b"load1,load2\n1,2\n"})),
    Case("tare far from the offsets", ("tare", "cal.json", "n.csv", "-o", "t.json"), 1, "--force",
         files=_base(**{"n.csv": b"load1,load2\n" + b"3900000,76765\n" * 20})),
    Case("tare far from the offsets, forced", ("tare", "cal.json", "n.csv", "-o", "t.json", "--force"), 0, "wrote t.json",
         files=_base(**{"n.csv": b"load1,load2\n" + b"3900000,76765\n" * 20}), output="t.json"),
    Case("tare error names the recording", ("tare", "cal.json", "n.csv", "-o", "t.json"), 1, "no-load recording must be clean",
         files=_base(**{"n.csv": b"load1,load2\n" + b"1,x\n" * 20})),
    # 13. A byte-order mark is not part of a name; header-only input is an error in every mode.
    Case("BOM on stdin", ("estimate", "--calibration", "cal.json", "-"), 0, "ok 20", files=_base(), stdin=b"\xef\xbb\xbf" + GOOD),
    Case("BOM in a robot file", ("robot", "show", "--robot", "r.toml"), 0, "0.45", files={"r.toml": b"\xef\xbb\xbf" + ROBOT_TOML}),
    Case("BOM in fit-poly", ("fit-poly", "t.csv"), 0, "y", files={"t.csv": b"\xef\xbb\xbfx,y\n1,2\n2,4\n3,6\n4,8\n"}),
    # 14. Messages name the user's flags and files, not internals.
    Case("output folder missing", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "nodir/out.csv"), 1, "nodir/out.csv",
         files=_base()),
    # Frictions: options that would be ignored are refused.
    Case("--serial with a file", ("estimate", "--calibration", "cal.json", "in.csv", "--serial", "loop://"), 2, "not both",
         files=_base()),
    Case("--sample-rate-Hz alone", ("estimate", "--calibration", "cal.json", "in.csv", "-o", "o.csv", "--sample-rate-Hz", "80"),
         2, "--lowpass-Hz", files=_base()),
    Case("SPEC 0:0:0", ("simulate", "--theta1-deg=90:90:0", "--theta2-deg=0:0:0", "--phi-deg=0", "-o", "s.csv"), 0,
         "wrote 1 rows", output="s.csv"),
    Case("old flag spellings", ("statics", "--theta1-deg=90", "--theta2-deg=0", "--t1=1", "--t2=1", "--json"), 0, "fx_N"),
]  # fmt: skip


def _snapshot(folder: Path) -> dict[str, str]:
    """Every entry under ``folder``: a symlink's target, a file's SHA-256."""
    state = {}
    for path in sorted(folder.rglob("*")):
        key = str(path.relative_to(folder))
        if path.is_symlink():
            state[key] = "link -> " + os.readlink(path)
        elif path.is_file():
            state[key] = hashlib.sha256(path.read_bytes()).hexdigest()
    return state


def _lines(path: Path) -> int:
    data = path.read_bytes()
    return data.count(b"\n") + (not data.endswith(b"\n"))


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_corpus(case: Case, tmp_path: Path):
    for name, content in case.files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(content)
    for name, target in case.links.items():
        if target.startswith("hard:"):
            os.link(tmp_path / target[5:], tmp_path / name)
        else:
            os.symlink(target, tmp_path / name)
    before = _snapshot(tmp_path)
    result = subprocess.run([str(SAIL), *case.args], cwd=tmp_path, input=case.stdin, capture_output=True, timeout=120)
    stderr = result.stderr.decode(errors="replace")
    assert "Traceback" not in stderr, stderr
    assert result.returncode == case.code, (result.returncode, stderr[-2000:])
    after = _snapshot(tmp_path)
    changed = {k for k in before if before[k] != after.get(k)}
    created = set(after) - set(before)
    allowed = {case.output, f"{case.output}.json"} if case.output else set()
    assert changed <= allowed and created <= allowed, (changed, created)
    if result.returncode:
        message = [line for line in stderr.splitlines() if line.strip()]
        assert len(message) == 1, stderr
        assert case.phrase in message[0], message[0]
        assert "np.float64" not in message[0] and ".tmp" not in message[0] and "on_singular" not in message[0]
    else:
        assert case.phrase in stderr + result.stdout.decode(errors="replace"), (stderr, result.stdout[-500:])
    if case.output and result.returncode == 0:
        assert case.output in created | changed
    if case.rows_of:
        assert _lines(tmp_path / case.rows_of[1]) == _lines(tmp_path / case.rows_of[0])
    for name, target in case.links.items():
        if not target.startswith("hard:"):
            assert (tmp_path / name).is_symlink()


def test_unclosed_quote_keeps_every_row_and_marks_nothing_silently(tmp_path):
    """Regression for the 26,168 lost rows: 400,001 lines, a quote opened and never closed near the top."""
    rows = [reading(theta1=60 + i % 60) for i in range(400_000)]
    rows[7] = reading(note='"never closed')
    (tmp_path / "cal.json").write_bytes(CAL)
    (tmp_path / "in.csv").write_bytes(HEADER + b"".join(rows))
    result = subprocess.run([str(SAIL), "estimate", "--calibration", "cal.json", "in.csv", "-o", "out.csv", "-q"],
                            cwd=tmp_path, capture_output=True)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "400,000 rows: ok 400,000" in result.stderr.decode()
    out = (tmp_path / "out.csv").read_bytes().splitlines()
    assert len(out) == 400_001
    assert out[8].startswith(rows[7].rstrip(b"\n") + b",") and out[8].endswith(b",ok")


def test_parquet_output_is_parquet_with_numeric_pass_through(tmp_path):
    (tmp_path / "cal.json").write_bytes(CAL)
    (tmp_path / "in.csv").write_bytes(b"t_ms,theta1_deg,theta2_deg,load1,load2,gain,tag\n" + b"".join(
        f"{i},{60 + i},0,{OFFSETS[0] + 10 * i:.0f},{OFFSETS[1]:.0f},{0.5 * i},t{i}\n".encode() for i in range(50)))  # fmt: skip
    result = subprocess.run([str(SAIL), "estimate", "--calibration", "cal.json", "in.csv", "-o", "o.parquet"], cwd=tmp_path,
                            capture_output=True)  # fmt: skip
    assert result.returncode == 0, result.stderr
    table = pq.read_table(tmp_path / "o.parquet")
    assert table.schema.field("t_ms").type == pa.int64() and table.schema.field("gain").type == pa.float64()
    assert table.schema.field("tag").type == pa.string() and table.schema.field("load1").type == pa.float64()
    assert table.column("t_ms").to_pylist() == list(range(50)) and table.num_rows == 50
    simulated = subprocess.run([str(SAIL), "simulate", "--theta1-deg=90", "--theta2-deg=0", "-o", "s.parquet"], cwd=tmp_path,
                               capture_output=True)  # fmt: skip
    assert simulated.returncode == 0 and pq.read_table(tmp_path / "s.parquet").num_rows == 24


def test_parquet_struct_column(tmp_path):
    (tmp_path / "cal.json").write_bytes(CAL)
    values = {"theta1_deg": [90.0], "theta2_deg": [0.0], "load1": [OFFSETS[0]], "load2": [OFFSETS[1]]}
    pq.write_table(pa.table({**values, "meta": [{"a": 1}]}), tmp_path / "s.parquet")
    to_csv = subprocess.run([str(SAIL), "estimate", "--calibration", "cal.json", "s.parquet", "-o", "o.csv"], cwd=tmp_path,
                            capture_output=True)  # fmt: skip
    assert to_csv.returncode == 1 and b"cannot be written as CSV" in to_csv.stderr and not (tmp_path / "o.csv").exists()
    to_parquet = subprocess.run([str(SAIL), "estimate", "--calibration", "cal.json", "s.parquet", "-o", "o.parquet"],
                                cwd=tmp_path, capture_output=True)  # fmt: skip
    assert to_parquet.returncode == 0 and pq.read_table(tmp_path / "o.parquet").column("meta").to_pylist() == [{"a": 1}]
    pq.write_table(pa.table({**values, "load1": [{"a": 1.0}]}), tmp_path / "n.parquet")
    needed = subprocess.run([str(SAIL), "estimate", "--calibration", "cal.json", "n.parquet", "-o", "o2.csv"], cwd=tmp_path,
                            capture_output=True)  # fmt: skip
    assert needed.returncode == 1 and b"not numbers" in needed.stderr


def test_csv_to_parquet_refuses_text_in_a_numeric_column(tmp_path):
    """The first chunk makes the column numeric; a word far below is refused, naming its line, and nothing is written."""
    import sailforce.io.tables as tables
    from sailforce.calibration.file import Calibration
    from sailforce.stream.pipeline import stream_estimate

    lines = [b"theta1_deg,theta2_deg,load1,load2,gain\n"] + [b"90,0,1,1,0.5\n"] * 3000 + [b"90,0,1,1,high\n"]
    (tmp_path / "in.csv").write_bytes(b"".join(lines))
    (tmp_path / "cal.json").write_bytes(CAL)
    saved, tables.CHUNK_BYTES = tables.CHUNK_BYTES, 4096
    try:
        with pytest.raises(tables.TableError, match="line 3002, column 'gain'"):
            stream_estimate(Calibration.load(tmp_path / "cal.json"), tmp_path / "in.csv", tmp_path / "o.parquet")
    finally:
        tables.CHUNK_BYTES = saved
    assert not (tmp_path / "o.parquet").exists() and not list(tmp_path.glob(".*tmp"))


@pytest.mark.parametrize("signum, code", [(2, 130), (15, 143)])
def test_interrupt_removes_the_half_written_output(tmp_path, signum, code):
    """Ctrl-C (SIGINT) and SIGTERM in the middle of a large estimate leave no file behind, and exit 130 / 143."""
    import time

    (tmp_path / "cal.json").write_bytes(CAL)
    block = b"".join(reading(theta1=60 + i % 60) for i in range(100_000))
    (tmp_path / "in.csv").write_bytes(HEADER + block * 40)  # 4 M rows: several seconds of work
    process = subprocess.Popen([str(SAIL), "estimate", "--calibration", "cal.json", "in.csv", "-o", "out.csv", "-q"],
                               cwd=tmp_path, stderr=subprocess.PIPE)  # fmt: skip
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob(".out.csv.*.tmp")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    assert process.poll() is None, "the estimate ended before it could be interrupted"
    process.send_signal(signum)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == code, stderr
    assert "Traceback" not in stderr.decode()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json", "in.csv"]


def test_live_interrupt_keeps_the_recording(tmp_path):
    """A live recording stopped by Ctrl-C is kept: it cannot be recorded again."""
    import signal
    import time

    (tmp_path / "cal.json").write_bytes(CAL)
    process = subprocess.Popen([str(SAIL), "estimate", "--calibration", "cal.json", "-", "-o", "rec.csv"], cwd=tmp_path,
                               stdin=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    process.stdin.write(HEADER + reading() * 5)
    process.stdin.flush()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        tmp = list(tmp_path.glob(".rec.csv.*.tmp"))
        if tmp and tmp[0].read_bytes().count(b"\n") == 6:
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    process.communicate(timeout=30)
    assert process.returncode == 130
    assert (tmp_path / "rec.csv").read_bytes().count(b"\n") == 6


def test_estimate_help_and_docs_are_current():
    fit_help = subprocess.run([str(SAIL), "fit-poly", "--help"], capture_output=True, text=True).stdout
    assert "python -c" not in fit_help and "--seed-table4" in fit_help
    simulate_help = subprocess.run([str(SAIL), "simulate", "--help"], capture_output=True, text=True).stdout
    assert "OUT.parquet" in simulate_help
    statics_help = subprocess.run([str(SAIL), "statics", "--help"], capture_output=True, text=True).stdout
    assert "--t1-Nm" in statics_help and "--t1 " not in statics_help  # the old spelling works but is not shown
    assert (ROOT / "docs" / "errata.md").is_file()
    cited = subprocess.run(["grep", "-rn", "ERRATA" ".md", "README.md", "src", "tests"], cwd=ROOT, capture_output=True, text=True)
    assert all("docs/errata.md" in line for line in cited.stdout.splitlines())


def test_panel_labels_stay_letters():
    from sailforce.report.stress_figure import panel_label

    assert [panel_label(k) for k in (0, 25, 26, 27, 51, 52, 701, 702)] == [
        "(a)", "(z)", "(aa)", "(ab)", "(az)", "(ba)", "(zz)", "(aaa)"]  # fmt: skip


def test_exit_codes_are_documented():
    text = (ROOT / "docs" / "reference" / "guarantees.md").read_text()
    for code in ("130", "143", "70"):
        assert code in text
