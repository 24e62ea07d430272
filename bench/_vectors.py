"""libsail's shared test vectors and calibration headers (c/tests/make_vectors.py), written quietly for a benchmark."""

from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

C = Path(__file__).resolve().parents[1] / "c"


def write_vectors(directory: Path) -> Path:
    """Write the vectors and headers (cal_seed.h, cal_motion.h, ...) into ``directory/vectors``; return that folder."""
    sys.path.insert(0, str(C / "tests"))
    import make_vectors

    with contextlib.redirect_stdout(io.StringIO()):
        make_vectors.main(directory / "vectors")
    return directory / "vectors"
