"""Shared strategies and fixtures."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import strategies as st

from sailforce import Arm

# `sail reproduce` fits on one process per core by default; the suite already runs a test on every core, and the
# timing tests (a 1 kHz link, LSL stamps within 2 ms) failed when a fit's pool took their core (CI on 385608e).  The
# pool itself is tested in tests/test_seed_model.py (two workers, two small families).  Subprocesses inherit this.
os.environ.setdefault("SAIL_WORKERS", "1")

# The commands' caches (the seed model's fits, solved solid poses) in one folder for the session, never the user's
# ~/.cache: a run is the same on a fresh machine (CI) as here.  xdist's workers inherit the controller's environment,
# so the workers and the commands they run share it, and a fit one test computes serves the next, as a user's second
# run would be served.  Tests of the caches themselves give their own folders.
if "SAIL_CACHE_DIR" not in os.environ:
    os.environ["SAIL_CACHE_DIR"] = tempfile.mkdtemp(prefix="sail-test-cache-")
    atexit.register(shutil.rmtree, os.environ["SAIL_CACHE_DIR"], ignore_errors=True)

#: Angles drawn for property tests [rad]; wider than a turn to exercise wrapping.
angles = st.floats(min_value=-2 * np.pi, max_value=2 * np.pi, allow_nan=False)

#: Link lengths [m] of plausible desk-top to floor-standing arms.
lengths = st.floats(min_value=0.05, max_value=2.0, allow_nan=False)


@st.composite
def arms(draw) -> Arm:
    """A random valid arm: l4 = l2 and l3 > l1."""
    l1 = draw(lengths)
    l2 = draw(lengths)
    l3 = l1 + draw(st.floats(min_value=0.01, max_value=1.0))
    return Arm(l1=l1, l2=l2, l3=l3, l4=l2)


@pytest.fixture(scope="session", autouse=True)
def _force_kernel_loaded():
    """The compiled force kernel's first use loads numba and its compiled code (about 0.6 s): done once, before any
    test, so that a property test's time limit (hypothesis' deadline) measures its examples, not the loading.  Once
    loaded it serves every call of the process, whatever its size (sailforce.kernel.COMPILED_MIN_POSES), as before."""
    from sailforce import kernel
    from sailforce.errors import MissingExtraError

    try:
        with kernel.use_backend("compiled"):
            Arm().end_effector_force(0.5, 0.1, 1.0, 2.0)
    except MissingExtraError:  # without numba the numpy path serves, with nothing to load
        pass


@pytest.fixture(scope="session")
def cals(tmp_path_factory):
    """A static and a dynamic calibration of simulated rig 1, made as `make live` makes them: (folder, static, dynamic)."""
    from sailforce.calibration.file import Calibration
    from sailforce.cli import cli

    def run(*args):
        return CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)

    d = tmp_path_factory.mktemp("live")
    assert run("simulate-motion", "--session", "static", "--rig", "1", "-o", d / "static.csv").exit_code == 0
    for name, extra in (("static.json", ()), ("dynamic.json", ("--dynamics", "prior"))):
        result = run("calibrate", d / "static.csv", "--model", "matrix", "-q", "-o", d / name, *extra)
        assert result.exit_code == 0, result.output
    return d, Calibration.load(d / "static.json"), Calibration.load(d / "dynamic.json")
