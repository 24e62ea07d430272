"""Regression tests for the second hardening round: one test per defect, named after it.

Each test fails on the code before its fix (the defect is described in its
docstring) and passes after it.  The bad-input cases that only need the real
command's exit code and message are in tests/test_corpus.py; the live
server's are in tests/test_live_security.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sailforce.calibration.export_c import calibration_header, comment_text
from sailforce.calibration.file import TEXT_FIELDS, Calibration, CalibrationFileError, checksum
from sailforce.io.files import OutputPathError, atomic_writer

ROOT = Path(__file__).resolve().parents[1]
SAIL = Path(sys.executable).parent / "sail"
CAL_PATH = ROOT / "c" / "examples" / "calibration.json"


def _resealed(data: dict) -> dict:
    """``data`` with its checksum recomputed, as anyone can do to a calibration file."""
    data = {k: v for k, v in data.items() if k != "checksum"}
    return data | {"checksum": checksum(data)}


def _write(path: Path, data: dict) -> Path:
    path.write_text(json.dumps(data))
    return path


# -- C injection through `sail export-c` ------------------------------------------------------------------------
INJECTION = "x */ static const int injected = 1; /*"


@pytest.mark.parametrize("field", ["created", "software", "data_sha256", "units.load"])
def test_export_c_injection_is_refused_at_load(tmp_path, field):
    """A calibration whose text field closes the C comment was accepted; each such field is now refused at load."""
    data = json.loads(CAL_PATH.read_text())
    if field == "units.load":
        data["units"]["load"] = INJECTION
    else:
        data[field] = INJECTION
    path = _write(tmp_path / "cal.json", _resealed(data))
    with pytest.raises(CalibrationFileError, match=field.replace(".", r"\.")):
        Calibration.load(path)
    result = subprocess.run([str(SAIL), "export-c", str(path), "-o", str(tmp_path / "h.h")], capture_output=True, text=True)
    assert result.returncode == 1 and field in result.stderr and "Traceback" not in result.stderr
    assert not (tmp_path / "h.h").exists()


def test_export_c_injection_is_escaped_in_the_header(tmp_path):
    """A Calibration made in Python (never loaded) with hostile text still gives a header that declares nothing extra."""
    cal = Calibration.load(CAL_PATH)
    hostile = replace(cal, created=INJECTION, software=INJECTION, data_sha256=INJECTION, load_unit=INJECTION)
    header = calibration_header(hostile, "sail_cal", source="in */ int also_injected; /*.json")
    (tmp_path / "h.h").write_text(header)
    comment_end = header.index("*/")
    assert "injected" not in header[comment_end:]  # the only */ is the one that ends the comment
    (tmp_path / "probe.c").write_text('#include "h.h"\nint main(void) { return injected + also_injected; }\n')
    compiled = subprocess.run(["cc", "-std=c99", f"-I{ROOT / 'c' / 'include'}", f"-I{tmp_path}", "-c", "probe.c", "-o", "probe.o"],
                              cwd=tmp_path, capture_output=True, text=True)  # fmt: skip
    assert compiled.returncode != 0 and "injected" in compiled.stderr  # undeclared: the comment held it
    (tmp_path / "ok.c").write_text('#include "h.h"\nint main(void) { return (int)sail_cal.l2; }\n')
    assert subprocess.run(["cc", "-std=c99", f"-I{ROOT / 'c' / 'include'}", "-c", "ok.c", "-o", "ok.o"], cwd=tmp_path).returncode == 0


def test_comment_text_keeps_ordinary_text():
    assert comment_text("sailforce 0.1.0 (dev)") == "sailforce 0.1.0 (dev)"
    assert comment_text("2026-12-01T20:17:26+00:00") == "2026-12-01T20:17:26+00:00"
    assert "*/" not in comment_text("*/") and "\n" not in comment_text("a\nb")


def test_schema_patterns_are_the_loaders():
    """calibration.schema.json states the same text rules that loading enforces."""
    from importlib.resources import files

    schema = json.loads(files("sailforce.calibration").joinpath("calibration.schema.json").read_text())
    props = schema["properties"]
    where = {"created": props["created"], "software": props["software"], "data_sha256": props["data_sha256"],
             "units.load": props["units"]["properties"]["load"]}  # fmt: skip
    for name, (pattern, _) in TEXT_FIELDS.items():
        assert where[name]["pattern"] == "^" + pattern.pattern.replace("\\Z", "$")


# -- Loading a calibration does not bound its numbers ------------------------------------------------------------
@pytest.mark.parametrize("edit, message", [
    (lambda d: d["model"].__setitem__("coefficients", (np.asarray(d["model"]["coefficients"]) * 1e-300).tolist()),
     "not invertible|full cell"),
    (lambda d: d["model"].__setitem__("coefficients", (np.asarray(d["model"]["coefficients"]) * 1e300).tolist()), "full cell"),
    (lambda d: d.__setitem__("capacity", [1e308, 1e308]), "within"),
    (lambda d: d.__setitem__("load_range", [[5.0, -5.0], [0.0, 1.0]]), "min <= max"),
    (lambda d: d.__setitem__("schema_version", True), "schema_version"),
    (lambda d: d.__setitem__("offsets", [1e300, 0.0]), "within"),
])  # fmt: skip
def test_calibration_numbers_are_bounded_at_load(tmp_path, edit, message):
    """An amplitude of 1e-300, a capacity of 1e308, a reversed load range and schema_version = true were all accepted."""
    data = json.loads(CAL_PATH.read_text())
    edit(data)
    with pytest.raises(CalibrationFileError, match=message):
        Calibration.load(_write(tmp_path / "cal.json", _resealed(data)))


def test_the_shipped_calibrations_still_load():
    assert Calibration.load(CAL_PATH).kind == "matrix"


# -- Outputs replace device nodes, FIFOs and symlink targets -----------------------------------------------------
def test_outputs_never_replace_a_device_node(tmp_path):
    """`sail tare ... -o dev/null`, dev/null a character device, exited 0 and left a regular file in its place."""
    device = tmp_path / "null"
    try:
        os.mknod(device, 0o666 | 0o020000, os.makedev(1, 3))
    except PermissionError:
        os.symlink("/dev/null", device)  # not root: a link to the real one tests the same refusal
    before = os.stat(device).st_rdev
    with pytest.raises(OutputPathError, match="character device"), atomic_writer(device) as stream:
        stream.write("x")
    assert os.stat(device).st_rdev == before and not list(tmp_path.glob(".*.tmp"))
    noload = tmp_path / "n.csv"
    noload.write_text("load1,load2\n" + "".join(f"{-42809 + i % 3},{76765 - i % 2}\n" for i in range(40)))
    result = subprocess.run([str(SAIL), "tare", str(CAL_PATH), str(noload), "-o", str(device)], capture_output=True, text=True)
    assert result.returncode == 1 and "character device" in result.stderr and "Traceback" not in result.stderr
    assert not os.path.isfile(device) and os.stat(device).st_rdev == before


def test_outputs_never_replace_a_fifo_or_a_folder(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(OutputPathError, match="FIFO"), atomic_writer(fifo) as stream:
        stream.write("x")
    folder = tmp_path / "folder"
    folder.mkdir()
    os.symlink(folder, tmp_path / "to-folder")
    with pytest.raises(OutputPathError, match="folder"), atomic_writer(tmp_path / "to-folder") as stream:
        stream.write("x")
    assert fifo.is_fifo() and folder.is_dir()


def test_symlinked_output_replaces_its_regular_target_and_stays_a_link(tmp_path):
    """The documented meaning of a symlinked output: the link stays, its regular target gets the new content."""
    (tmp_path / "real.txt").write_text("old\n")
    os.symlink("real.txt", tmp_path / "link.txt")
    with atomic_writer(tmp_path / "link.txt") as stream:
        stream.write("new\n")
    assert (tmp_path / "link.txt").is_symlink() and (tmp_path / "real.txt").read_text() == "new\n"
