"""Compensators: amplitude/phase conventions, the run-time 2x2 estimator, the matrix model."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sailforce import Arm, SingularPoseError
from sailforce.estimate.estimator import estimate_force
from sailforce.fit.matrix import fit_matrix_compensator
from sailforce.report.results import SEED_REGRESSORS
from sailforce.sensing.maps import (
    AmplitudePhaseCompensator,
    CompensationError,
    MatrixCompensator,
    TorqueScale,
    amplitude_phase,
    rows_from_amplitude_phase,
    sinusoid_rows,
    torque_rows,
)
from sailforce.sensing.polynomial import PolynomialFit, select_order
from sailforce.statics import end_effector_force, joint_torques

#: Closed-form round trips in float64 lose a few ulps per operation; 1e-9
#: relative leaves room for the 2x2 solve's conditioning (cond <~ 30 here).
EXACT_RTOL = 1e-9

PHI = np.radians(np.arange(0.0, 360.0, 15.0))  # the seed's 24 force angles


def _seed_fit(name: str) -> PolynomialFit:
    coefficients = SEED_REGRESSORS[name]
    return PolynomialFit(len(coefficients) - 1, coefficients, 1.0, 1.0, "adj-r2", 0.999, True)


def seed_compensator(arm=Arm()) -> AmplitudePhaseCompensator:
    """The seed's published regressors as a compensator."""
    return AmplitudePhaseCompensator(
        arm,
        (_seed_fit("amplitude_1"), _seed_fit("amplitude_2")),
        (_seed_fit("phase_1_deg"), _seed_fit("phase_2_deg")),
        (np.radians(15.0), np.radians(120.0)),
    )


@given(st.floats(-10, 10), st.floats(-10, 10), st.floats(0.01, 1e3), st.floats(-3.1, 3.1))
def test_amplitude_phase_round_trip(jx, jy, amplitude, phase):
    j = np.array([jx, jy])
    if np.hypot(jx, jy) < 1e-3:
        return
    r = rows_from_amplitude_phase(j, amplitude, phase)
    a, p = amplitude_phase(r, j)
    assert a == pytest.approx(amplitude, rel=1e-12)
    assert np.angle(np.exp(1j * (p - phase))) == pytest.approx(0.0, abs=1e-12)


def test_convention_compensated_curve_equals_torque():
    """The documented convention: A s(phi - P) = T(phi) for every force angle."""
    arm, theta1, theta2, force = Arm(), 1.1, 0.3, 10.0
    amplitude, phase = 740.0, np.radians(6.0)
    j = torque_rows(arm, theta1, theta2)[0]
    r = rows_from_amplitude_phase(j, amplitude, phase)
    shifted = PHI - phase
    compensated = amplitude * force * (r[0] * np.cos(shifted) + r[1] * np.sin(shifted))
    t1, _ = joint_torques(arm, theta1, theta2, force * np.cos(PHI), force * np.sin(PHI))
    np.testing.assert_allclose(compensated, t1, rtol=0, atol=1e-12 * force)
    # A positive P means the load-cell curve peaks earlier in phi than the torque.
    fine = np.radians(np.arange(0.0, 360.0, 0.01))
    peak_signal = fine[np.argmax(r[0] * np.cos(fine) + r[1] * np.sin(fine))]
    peak_torque = fine[np.argmax(j[0] * np.cos(fine) + j[1] * np.sin(fine))]
    assert np.degrees(peak_torque - peak_signal) == pytest.approx(6.0, abs=0.01)


def test_sinusoid_rows_exact_and_batched():
    rows = np.array([[1.5, -0.25], [0.0, 2.0], [-3.0, 1.0]])
    curves = 10.0 * (rows[:, :1] * np.cos(PHI) + rows[:, 1:] * np.sin(PHI))
    np.testing.assert_allclose(sinusoid_rows(PHI, 10.0, curves), rows, rtol=1e-13, atol=1e-14)
    with pytest.raises(CompensationError):
        sinusoid_rows(np.array([0.3, 0.3 + np.pi]), 10.0, curves[:, :2])


@pytest.mark.parametrize("delta_deg", [15.0, 37.0, 90.0, 127.5])
def test_seed_compensator_recovers_force_from_synthesized_readings(delta_deg):
    """Readings made from a known amplitude/phase table are inverted exactly by the 2x2 solve."""
    comp = seed_compensator()
    theta2 = np.radians(np.array([-20.0, 0.0, 35.0]))[:, None]
    theta1 = theta2 + np.radians(delta_deg)
    fx, fy = 10.0 * np.cos(PHI), 10.0 * np.sin(PHI)
    delta_d = np.full(theta1.shape, delta_deg)
    amplitude = np.stack([np.polyval(SEED_REGRESSORS["amplitude_1"], delta_d),
                          np.polyval(SEED_REGRESSORS["amplitude_2"], delta_d)], axis=-1)  # fmt: skip
    phase = np.radians(np.stack([np.polyval(SEED_REGRESSORS["phase_1_deg"], delta_d),
                                 np.polyval(SEED_REGRESSORS["phase_2_deg"], delta_d)], axis=-1))  # fmt: skip
    rows = rows_from_amplitude_phase(torque_rows(Arm(), theta1, theta2), amplitude, phase)  # (3, 1, 2, 2)
    load1 = rows[..., 0, 0] * fx + rows[..., 0, 1] * fy
    load2 = rows[..., 1, 0] * fx + rows[..., 1, 1] * fy
    fx_hat, fy_hat = estimate_force(comp, theta1, theta2, load1, load2)
    np.testing.assert_allclose(fx_hat, np.broadcast_to(fx, fx_hat.shape), rtol=0, atol=EXACT_RTOL * 10)
    np.testing.assert_allclose(fy_hat, np.broadcast_to(fy, fy_hat.shape), rtol=0, atol=EXACT_RTOL * 10)


def test_compensator_from_fitted_table_recovers_force():
    """Table of exact polynomials -> select_order -> compensator -> exact force."""
    delta_deg = np.arange(15.0, 121.0, 15.0)
    a1, p1 = 700 + 0.02 * (delta_deg - 60) ** 2, 2.0 + 0.05 * delta_deg
    a2, p2 = 520 + 1.5 * delta_deg, -0.3 * delta_deg
    fits = [select_order(delta_deg, col) for col in (a1, p1, a2, p2)]
    assert [f.order for f in fits] == [2, 1, 1, 1]
    comp = AmplitudePhaseCompensator(Arm(), (fits[0], fits[2]), (fits[1], fits[3]), (np.radians(15), np.radians(120)))
    theta1, theta2 = np.radians(80.0), np.radians(10.0)
    amplitude, phase = comp.parameters(theta1 - theta2)
    assert amplitude.tolist() == pytest.approx([700 + 0.02 * 10**2, 520 + 1.5 * 70], rel=1e-12)
    m = comp.sensing_matrix(theta1, theta2)
    force = np.array([3.0, -7.0])
    fx, fy = estimate_force(comp, theta1, theta2, *(m @ force))
    assert (float(fx), float(fy)) == pytest.approx((3.0, -7.0), rel=EXACT_RTOL)


def test_torque_scale_is_the_corrected_statics():
    arm = Arm()
    theta1, theta2 = np.array([0.4, 1.9, 2.5]), np.array([-0.2, 0.5, 0.1])
    t1, t2 = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -1.2])
    fx, fy = estimate_force(TorqueScale(arm, (1.0, 1.0)), theta1, theta2, t1, t2)
    fx_ref, fy_ref = end_effector_force(arm, theta1, theta2, t1, t2)
    np.testing.assert_allclose([fx, fy], [fx_ref, fy_ref], rtol=1e-12)


def test_estimate_force_singular_pose():
    model = TorqueScale(Arm(), (1.0, 1.0))
    with pytest.raises(SingularPoseError, match="collapsed"):
        estimate_force(model, [0.5, 1.0], [0.5, 0.0], 1.0, 1.0)
    fx, fy, singular = estimate_force(model, [0.5, 1.0], [0.5, 0.0], 1.0, 1.0, on_singular="mask")
    assert singular.tolist() == [True, False] and np.isnan(fx[0]) and np.isfinite(fx[1])


def _synthetic_samples(arm, correction):
    """Samples from the exact model s = C(delta) J^T F on the seed's sweep poses."""
    delta = np.radians(np.arange(15.0, 121.0, 15.0))
    theta2 = np.concatenate([np.zeros(8), np.radians(120.0) - delta])
    theta1 = theta2 + np.concatenate([delta, delta])
    t1, t2 = np.repeat(theta1, PHI.size), np.repeat(theta2, PHI.size)
    fx, fy = np.tile(10 * np.cos(PHI), 16), np.tile(10 * np.sin(PHI), 16)
    m = correction(t1 - t2) @ torque_rows(arm, t1, t2)
    return t1, t2, fx, fy, m[:, 0, 0] * fx + m[:, 0, 1] * fy, m[:, 1, 0] * fx + m[:, 1, 1] * fy


def test_matrix_compensator_recovers_a_polynomial_map():
    arm = Arm()

    def correction(delta):
        d = np.asarray(delta)[..., None, None]
        return np.array([[2e-3, 1e-4], [-5e-5, 3e-3]]) + d * np.array([[1e-4, 0.0], [2e-5, -4e-4]]) + d**2 * 1e-5

    samples = _synthetic_samples(arm, correction)
    comp = fit_matrix_compensator(arm, *samples)
    assert comp.order == 2
    delta = np.radians(np.linspace(15.0, 120.0, 23))
    np.testing.assert_allclose(comp.correction(delta), correction(delta), rtol=1e-8, atol=1e-14)
    fx, fy = estimate_force(comp, *samples[:2], *samples[4:])
    np.testing.assert_allclose(fx, samples[2], atol=1e-8)
    np.testing.assert_allclose(fy, samples[3], atol=1e-8)


def test_matrix_compensator_is_order_zero_for_a_determinate_linkage():
    arm = Arm()
    samples = _synthetic_samples(arm, lambda d: np.broadcast_to(np.diag([1 / 740, 1 / 528]), np.shape(d) + (2, 2)))
    comp = fit_matrix_compensator(arm, *samples)
    assert comp.order == 0
    np.testing.assert_allclose(comp.coefficients[0], np.diag([1 / 740, 1 / 528]), rtol=1e-10, atol=1e-16)


def test_matrix_compensator_refuses_undetermined_data():
    arm = Arm()
    samples = _synthetic_samples(arm, lambda d: np.broadcast_to(np.eye(2), np.shape(d) + (2, 2)))
    few = samples[0][:48] * 0 + 1.0, samples[1][:48] * 0, *(s[:48] for s in samples[2:])
    with pytest.raises(CompensationError, match="distinct delta"):
        fit_matrix_compensator(arm, *few)
    t1, t2, fx, fy, l1, l2 = samples
    with pytest.raises(CompensationError, match="collinear"):
        fit_matrix_compensator(arm, t1, t2, np.zeros_like(fx), np.zeros_like(fy), l1, l2)


def test_matrix_compensator_rotation_invariance():
    """M = C(delta) J^T obeys the delta-only law M(th1, th2) = M(delta, 0) R(-th2) (docs/errata.md, Physics)."""
    comp = MatrixCompensator(Arm(), np.random.default_rng(3).normal(size=(3, 2, 2)), (0.2, 2.0))
    from sailforce.sensing.maps import rotation

    theta2 = 0.7
    lhs = comp.sensing_matrix(1.5 + theta2, theta2)
    rhs = comp.sensing_matrix(1.5, 0.0) @ rotation(-theta2)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-12, atol=1e-14)
