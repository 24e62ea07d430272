"""Shared strategies and fixtures."""

from __future__ import annotations

import os

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import strategies as st

from sailforce import Arm

# `sail reproduce` fits on one process per core by default; the suite already runs a test on every core, and the
# timing tests (a 1 kHz link, LSL stamps within 2 ms) failed when a fit's pool took their core (CI on 385608e).  The
# pool itself is tested in tests/test_seed_model.py (two workers, two small families).  Subprocesses inherit this.
os.environ.setdefault("SAIL_WORKERS", "1")

#: The slowest tests, measured by `make test`'s --durations on the 2-core machine [s]: they are handed out first, so
#: that the workers do not finish on one long test each after the short ones are gone (longest first: Graham 1969).
#: Keys are node-id prefixes; refresh them when --durations shows a new slow test.
SLOW_FIRST = {
    "tests/test_docs.py::test_every_example_runs[docs/guide/reproduce.md]": 39.2,
    "tests/test_docs.py::test_every_example_runs[docs/guide/design.md]": 37.2,
    "tests/test_study.py::test_reproduce_end_to_end": 27.2,
    "tests/test_guide.py::test_guided_calibration_in_chromium": 26.6,
    "tests/test_solid.py::test_reproduce_solid_adds_the_solids_table4_to_the_report": 24.6,
    "tests/test_live.py::test_page_in_chromium_shows_the_force_tares_records_and_flags_singular": 23.7,
    "tests/test_adc.py::test_a_file_and_a_live_stream_give_the_same_bytes": 20.7,
    "tests/test_docs.py::test_every_example_runs[docs/guide/ros-lsl.md]": 17.5,
    "tests/test_design_sweep.py::test_a_killed_worker_loses_no_variant": 17.5,
    "tests/test_docs.py::test_every_example_runs[docs/guide/calibrate.md]": 14.9,
    "tests/test_solid.py::test_a_killed_worker_loses_no_pose": 13.8,
    "tests/test_docs.py::test_every_example_runs[docs/reference/libsail.md]": 13.7,
    "tests/test_docs.py::test_every_example_runs[docs/guide/estimate.md]": 12.8,
    "tests/test_docs.py::test_every_example_runs[docs/reference/drift.md]": 12.6,
    "tests/test_docs.py::test_every_example_runs[docs/guide/reference.md]": 10.4,
    "tests/test_docs.py::test_every_example_runs[docs/reference/multirate.md]": 9.8,
    "tests/test_rig.py::test_a_live_port_is_measured_with_its_lost_and_corrupt_frames": 9.0,
    "tests/test_rig.py::test_a_live_port_too_slow_for_its_tick_is_said": 8.7,
    "tests/test_ros.py::test_sail_live_serves_foxglove_clients_the_wrench_joints_and_status": 8.3,
    "tests/test_differential.py::test_file_stream_and_api_agree": 8.0,
    "tests/test_ros.py::test_an_xdf_file_labrecorder_wrote_from_an_lsl_stream_estimates_as_the_stream": 7.8,
    "tests/test_docs.py::test_every_example_runs[docs/guide/identify.md]": 7.5,
    "tests/test_docs.py::test_every_example_runs[docs/guide/motion.md]": 7.1,
    "tests/test_docs.py::test_site_builds_strictly": 6.8,
    "tests/test_drift.py::test_a_30_minute_session_re_zeroed_is_within_1_5x_of_a_drift_free_one": 6.2,
}


def pytest_collection_modifyitems(session, config, items):
    """The slowest tests first (:data:`SLOW_FIRST`), the rest in their collected order."""
    def seconds(item) -> float:
        return next((s for prefix, s in SLOW_FIRST.items() if item.nodeid.startswith(prefix)), 0.0)

    items.sort(key=lambda item: -seconds(item))  # stable: equal keys keep the collected order


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
    """The force kernel's first call loads numba and its compiled code (about a second): done once, before any test,
    so that a property test's time limit (hypothesis' deadline) measures its examples, not the loading."""
    Arm().end_effector_force(0.5, 0.1, 1.0, 2.0)


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
