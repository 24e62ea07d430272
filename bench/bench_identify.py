"""Identification and the physics calibration (issue 12): speed of the fits, and how far each model extrapolates."""

from __future__ import annotations

import time

import numpy as np

from sailforce.estimate.estimator import estimate_force
from sailforce.fit.matrix import fit_matrix_with_offsets
from sailforce.fit.physics import fit_physics
from sailforce.loadcell import LoadCell
from sailforce.paper.table4_fit import identify_table4
from sailforce.report.results import seed_table4
from sailforce.robot import Joint, Joints, Robot
from sailforce.synthetic import NoiseModel, recording

TABLE4_TARGET_S = 10.0  #: issue 12: five parameters against a Table 4
RECORDING_TARGET_S = 30.0  #: issue 12: a 20,000-row calibration recording
FIVE = ("joints.P1.stiffness", "joints.P2.stiffness", "joints.P3.stiffness", "links.l3", "loadcells.position")
#: The extrapolation case: joints that differ, cells rated 1.9 mV/V where the model assumes 2.
TRUTH = Robot(joints=Joints("spring", 50.0, P1=Joint("spring", 2000.0), P2=Joint("spring", 500.0), P3=Joint("spring", 8000.0)))
OFFSETS = np.array([1000.0, -2000.0])


def _session(robot: Robot, low: float, high: float, step: float, directions: int, noise: NoiseModel, seed: int):
    """Poses every ``step`` deg of delta over low..high at random theta2, ``directions`` forces of 20 N at each."""
    rng = np.random.default_rng(seed)
    delta = np.radians(np.arange(low, high + 1e-9, step))
    theta2 = rng.uniform(-0.5, 0.5, delta.size)
    phi = np.radians(np.arange(0.0, 360.0, 360.0 / directions))
    t1, t2 = np.repeat(delta + theta2, phi.size), np.repeat(theta2, phi.size)
    fx, fy = np.tile(20.0 * np.cos(phi), delta.size), np.tile(20.0 * np.sin(phi), delta.size)
    counts, _, clean = recording(robot, t1, t2, fx, fy, noise=noise, seed=seed, offsets=OFFSETS)
    return t1, t2, fx, fy, counts, clean


def _extrapolation(noise: NoiseModel) -> tuple[float, float, float, float]:
    """Calibrate on delta = 30..120 deg, test noise-free on 15..165: worst force error inside and over all, physics and matrix."""
    truth = Robot(joints=TRUTH.joints, loadcell=LoadCell(rated_output_mV_V=1.9))
    t1, t2, fx, fy, counts, _ = _session(truth, 30.0, 120.0, 2.5, 24, noise, 1)
    physics = fit_physics(Robot(), t1, t2, fx, fy, counts[:, 0], counts[:, 1], cross_validate=False)
    matrix, offsets = fit_matrix_with_offsets(truth.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1])
    s1, s2, gx, gy, _, clean = _session(truth, 15.0, 165.0, 1.0, 24, noise, 9)
    inside = (np.degrees(s1 - s2) >= 30.0 - 1e-9) & (np.degrees(s1 - s2) <= 120.0 + 1e-9)
    worst = []
    for model, o in ((physics.compensator, physics.offsets), (matrix, offsets)):
        ex, ey = estimate_force(model, s1, s2, clean[:, 0] - o[0], clean[:, 1] - o[1])
        error = np.hypot(ex - gx, ey - gy)
        worst += [float(error[inside].max()), float(error.max())]
    return tuple(worst)  # type: ignore[return-value]


def run() -> list[tuple[str, str]]:
    start = time.perf_counter()
    fit = identify_table4(Robot(), seed_table4(), FIVE)
    table4_s = time.perf_counter() - start
    t1, t2, fx, fy, counts, _ = _session(TRUTH, 30.0, 120.0, 90.0 / 832, 24, NoiseModel(), 3)
    rows = t1.size
    start = time.perf_counter()
    fit_physics(Robot(), t1, t2, fx, fy, counts[:, 0], counts[:, 1])
    recording_s = time.perf_counter() - start
    figures = [
        (f"identify: 5 parameters against the seed's Table 4 ({fit.starts} starts)", f"{table4_s:10.2f} s"),
        ("  its phase RMS [deg], cell 1 / cell 2", f"{fit.phase_rms_deg[0]:10.2f} / {fit.phase_rms_deg[1]:.2f}"),
        (f"physics calibration of {rows:,} rows, with cross-validation", f"{recording_s:10.2f} s"),
        ("target", f"Table 4 <= {TABLE4_TARGET_S:g} s and recording <= {RECORDING_TARGET_S:g} s: "
                   f"{'met' if table4_s <= TABLE4_TARGET_S and recording_s <= RECORDING_TARGET_S else 'NOT met'}"),
    ]  # fmt: skip
    for label, noise in (("noise 1e-5 of rated", NoiseModel(1e-5, 0.0)), ("noise 1e-4 of rated", NoiseModel(1e-4, 0.0))):
        p_in, p_all, m_in, m_all = _extrapolation(noise)
        figures += [
            (f"extrapolation, {label}: physics worst in 30-120 / 15-165 [N]", f"{p_in:10.4f} / {p_all:.4f} ({p_all / p_in:.1f}x)"),
            ("  matrix worst in 30-120 / 15-165 [N]", f"{m_in:10.4f} / {m_all:.4f} (matrix / physics outside {m_all / p_all:.1f}x)"),
        ]  # fmt: skip
    return figures
