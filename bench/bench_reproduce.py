"""`sail reproduce`: the seed's study without plotting, and the whole command with figures and report."""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import best_of

from sailforce.paper.study import run_study
from sailforce.robot import Robot

STUDY_TARGET_S = 2.0  #: issue 4: both joint models, no plotting
TOTAL_TARGET_S = 30.0  #: issue 4: both joint models, all figures and the report


def run() -> list[tuple[str, str]]:
    robots = [Robot().with_joints("bonded"), Robot().with_joints("pin")]
    run_study(robots[0])  # warm-up: imports and first-call overheads
    study = best_of(5, lambda: [run_study(r) for r in robots])
    sail = Path(sys.executable).with_name("sail")
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        subprocess.run([str(sail), "reproduce", "-o", out], check=True, capture_output=True)
        total = time.perf_counter() - start
    return [
        ("study, bonded + pin joints, no plotting (best of 5)", f"{study:10.3f} s"),
        ("sail reproduce, both passes, figures + report (wall)", f"{total:10.1f} s"),
        ("target", f"study <= {STUDY_TARGET_S:g} s and total <= {TOTAL_TARGET_S:g} s: "
                   f"{'met' if study <= STUDY_TARGET_S and total <= TOTAL_TARGET_S else 'NOT met'}"),
    ]  # fmt: skip
