"""Fuzz every reader of user files with random bytes: nothing may crash, and no row may be lost.

    .venv/bin/python bench/fuzz_readers.py [CASES]      # `make fuzz`; CASES defaults to 100,000

The readers and what each case checks:

- measurement tables (``sailforce.io.tables``, what ``sail estimate`` and
  ``sail calibrate`` read), in file mode at a random chunk size and in
  stream mode: either a :class:`TableError` for the header, or one row per
  line in both, with the same malformed flags and values;
- numeric tables (``sail fit-poly``): a table or a :class:`TableError`;
- robot files (``sail robot``): a robot or a :class:`RobotFileError`;
- calibration files (``sail estimate --calibration``): a calibration or a
  :class:`CalibrationFileError`.

Any other exception is a crash: the case is printed and the run fails.
Inputs are random bytes from hypothesis, mixed with mutations of valid
files so that the readers get past their first checks.
"""

from __future__ import annotations

import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import sailforce.io.tables as tables
from sailforce.calibration.file import Calibration, CalibrationFileError
from sailforce.errors import SailError
from sailforce.io.files import TableError, read_numeric_csv
from sailforce.io.robotfile import load_robot_file

ROOT = Path(__file__).resolve().parents[1]
VALID = {
    "table": b"theta1_deg,theta2_deg,load1,load2,note\n90,0,-41809,76266,a\n80,10,1,2,\"b,c\"\n",
    "numeric": b"x,y\n1,2\n2,4\n3,6\n",
    "robot": b"[links]\nl1 = 0.2\nl2 = 0.3\nl3 = 0.45\nl4 = 0.3\n[joints]\nmodel = \"spring\"\n",
    "calibration": (ROOT / "c" / "examples" / "calibration.json").read_bytes(),
}
ALPHABET = b'0123456789.,-+eE"\r\n \t\x00\xff\xef\xbb\xbfabcnai=[]{}:'


@st.composite
def mutated(draw, kind: str) -> bytes:
    """A valid file with random bytes flipped, inserted, deleted or duplicated; or pure random bytes."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=300))
    data = bytearray(VALID[kind])
    for _ in range(draw(st.integers(1, 6))):
        at = draw(st.integers(0, len(data)))
        action = draw(st.sampled_from(["insert", "delete", "replace", "repeat"]))
        byte = bytes([draw(st.sampled_from(ALPHABET))])
        if action == "insert":
            data[at:at] = byte * draw(st.integers(1, 4))
        elif action == "delete":
            del data[at : at + draw(st.integers(1, 8))]
        elif action == "replace" and at < len(data):
            data[at] = byte[0]
        else:
            data[at:at] = data[max(0, at - 20) : at] * draw(st.integers(1, 3))
    return bytes(data)


RUN = {"table": 0, "numeric": 0, "robot": 0, "calibration": 0}  #: cases actually run, by reader


def _table_case(folder: Path, data: bytes, chunk: int) -> None:
    RUN["table"] += 1
    path = folder / "t.csv"
    path.write_bytes(data)
    tables.CHUNK_BYTES = chunk
    try:
        chunks = list(tables.read_chunks(path, tables.READING_COLUMNS))
    except TableError:
        return
    lines = data.split(b"\n", 1)[1] if b"\n" in data else b""
    expected = lines.count(b"\n") + (bool(lines) and not lines.endswith(b"\n"))
    assert sum(c.num_rows for c in chunks) == expected, "file mode lost or invented rows"
    source = io.BytesIO(data)
    header = tables.read_header("stdin", tables.read_line(source), tables.READING_COLUMNS)
    blocks = (line if line.endswith(b"\n") else line + b"\n" for line in iter(lambda: tables.read_line(source), b""))
    streamed = list(tables.csv_chunks("stdin", header, tables.READING_COLUMNS, blocks, fast=False))
    assert sum(c.num_rows for c in streamed) == expected, "stream mode lost or invented rows"
    if not expected:
        return
    for name in tables.READING_COLUMNS:
        a = np.concatenate([c.values[name] for c in chunks])
        b = np.concatenate([c.values[name] for c in streamed])
        assert np.array_equal(a, b, equal_nan=True), f"file and stream mode read {name} differently"
    assert np.array_equal(np.concatenate([c.malformed for c in chunks]), np.concatenate([c.malformed for c in streamed]))


def _file_case(folder: Path, data: bytes, kind: str) -> None:
    RUN[kind] += 1
    path = folder / {"numeric": "n.csv", "robot": "r.toml", "calibration": "c.json"}[kind]
    path.write_bytes(data)
    try:
        if kind == "numeric":
            read_numeric_csv(path, min_columns=2)
        elif kind == "robot":
            load_robot_file(path)
        else:
            Calibration.load(path)
    except (SailError, CalibrationFileError):
        pass


def main(cases: int) -> int:
    folder = Path(tempfile.mkdtemp(prefix="sail-fuzz-"))
    shares = {"table": 0.6, "numeric": 0.15, "robot": 0.15, "calibration": 0.1}
    start = time.perf_counter()
    for kind, share in shares.items():
        n = int(round(cases * share))
        common = settings(max_examples=n, deadline=None, database=None, derandomize=False,
                          suppress_health_check=list(HealthCheck))  # fmt: skip
        if kind == "table":
            test = common(given(mutated("table"), st.sampled_from([7, 64, 1024, 1 << 20]))(
                lambda data, chunk: _table_case(folder, data, chunk)))  # fmt: skip
        else:
            test = common(given(mutated(kind), st.just(kind))(lambda data, kind: _file_case(folder, data, kind)))
        try:
            test()
        except Exception as exc:  # hypothesis prints the falsifying example
            print(f"fuzz: the {kind} reader failed: {type(exc).__name__}: {exc}", file=sys.stderr)
            return 1
    elapsed = time.perf_counter() - start
    total = sum(RUN.values())
    detail = ", ".join(f"{k} {v:,}" for k, v in RUN.items())
    print(f"fuzz: {total:,} cases ({detail}) in {elapsed:.0f} s, 0 crashes, 0 rows lost")
    return 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000))
