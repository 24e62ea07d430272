"""Statics: T = J^T F (seed Eqs. 3, 6-7) and its corrected inverse (docs/errata.md)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from sailforce import SINGULAR_SIN_DELTA, Arm, SingularPoseError
from sailforce.paper import seed
from sailforce.statics import cartesian, end_effector_force, joint_torques, polar

from .conftest import angles, arms

#: The issue's round-trip bound: F -> T -> F to 1e-12 relative.  Cancellation
#: costs a factor ~ cond(J) ~ 1/|sin delta|, so the property test keeps
#: |sin delta| >= 0.1 where cond(J) <= ~40 and 1e-12 leaves two orders of margin.
ROUND_TRIP_RTOL = 1e-12
ROUND_TRIP_MIN_SIN = 0.1

forces = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)


def test_torques_match_erratum_closed_form():
    # docs/errata.md: Eq. 7 reduces to T1 = l3 F sin(phi - th1), T2 = l2 F sin(phi - th2).
    arm = Arm()
    theta1, theta2 = np.radians(75.0), np.radians(10.0)
    phi = np.radians(np.arange(0.0, 360.0, 15.0))
    t1, t2 = arm.joint_torques(theta1, theta2, *cartesian(10.0, phi))
    np.testing.assert_allclose(t1, arm.l3 * 10.0 * np.sin(phi - theta1), atol=1e-14)
    np.testing.assert_allclose(t2, arm.l2 * 10.0 * np.sin(phi - theta2), atol=1e-14)


def test_torques_are_j_transpose_f():
    arm = Arm()
    J = arm.jacobian(0.9, -0.2)
    t = J.T @ np.array([3.0, -7.0])
    np.testing.assert_allclose(arm.joint_torques(0.9, -0.2, 3.0, -7.0), t, rtol=1e-15)


def test_torques_are_moments_of_the_force():
    # Virtual work: a force through B along a link does no work on that link's angle.
    arm = Arm()
    t1, t2 = arm.joint_torques(0.6, 0.0, np.cos(0.6), np.sin(0.6))
    assert t1 == pytest.approx(0.0, abs=1e-16)
    assert t2 == pytest.approx(arm.l2 * np.sin(0.6), rel=1e-15)


@given(arm=arms(), theta1=angles, theta2=angles, fx=forces, fy=forces)
def test_force_torque_force_round_trip(arm, theta1, theta2, fx, fy):
    assume(abs(np.sin(theta1 - theta2)) >= ROUND_TRIP_MIN_SIN)
    assume(np.hypot(fx, fy) > 1e-6)
    t1, t2 = arm.joint_torques(theta1, theta2, fx, fy)
    gx, gy = arm.end_effector_force(theta1, theta2, t1, t2)
    scale = np.hypot(fx, fy)
    assert abs(gx - fx) <= ROUND_TRIP_RTOL * scale
    assert abs(gy - fy) <= ROUND_TRIP_RTOL * scale


@given(arm=arms(), theta1=angles, theta2=angles)
def test_inverse_times_jt_is_identity(arm, theta1, theta2):
    assume(abs(np.sin(theta1 - theta2)) >= ROUND_TRIP_MIN_SIN)
    J = arm.jacobian(theta1, theta2)
    columns = [arm.end_effector_force(theta1, theta2, *J.T[:, k]) for k in range(2)]
    np.testing.assert_allclose(np.array(columns).T, np.eye(2), atol=1e-12)


def test_seed_printed_eq10_fails_the_round_trip():
    """Regression guard (docs/errata.md): the seed's Eq. 10 is the transpose of (J^T)^-1.

    If someone "fixes" statics.end_effector_force back to the paper, the
    round-trip tests above fail; this test pins down that the paper's
    matrix is indeed not an inverse, and that ours is.
    """
    arm = Arm()
    theta1, theta2 = np.radians(75.0), 0.0
    JT = arm.jacobian(theta1, theta2).T
    printed = seed.printed_inverse_jt(arm, theta1, theta2)
    assert np.max(np.abs(printed @ JT - np.eye(2))) > 0.2  # 0.39 here; rounding is 1e-16
    np.testing.assert_allclose(printed.T @ JT, np.eye(2), atol=1e-12)  # it is the transpose
    t1, t2 = arm.joint_torques(theta1, theta2, 0.0, 10.0)
    fx, fy = seed.printed_end_effector_force(arm, theta1, theta2, t1, t2)
    assert np.hypot(fx, fy - 10.0) > 1.0
    gx, gy = arm.end_effector_force(theta1, theta2, t1, t2)
    assert np.hypot(gx, gy - 10.0) < 1e-13


def test_erratum_explicit_components():
    # docs/errata.md: Fx = (-l2 c2 T1 + l3 c1 T2) / (l2 l3 sin d), Fy likewise.
    arm = Arm()
    th1, th2, T1, T2 = 1.3, 0.25, 0.7, -1.9
    den = arm.l2 * arm.l3 * np.sin(th1 - th2)
    fx, fy = arm.end_effector_force(th1, th2, T1, T2)
    assert fx == pytest.approx((-arm.l2 * np.cos(th2) * T1 + arm.l3 * np.cos(th1) * T2) / den, rel=1e-14)
    assert fy == pytest.approx((-arm.l2 * np.sin(th2) * T1 + arm.l3 * np.sin(th1) * T2) / den, rel=1e-14)


@pytest.mark.parametrize("delta_deg", [0.0, 1.0, 180.0, -179.5, 360.0])
def test_singular_poses_raise(delta_deg):
    with pytest.raises(SingularPoseError, match="below the threshold 0.0349"):
        Arm().end_effector_force(np.radians(30.0 + delta_deg), np.radians(30.0), 1.0, 1.0)


def test_singular_message_names_the_pose():
    theta1 = np.radians([60.0, 31.0, 90.0])
    with pytest.raises(SingularPoseError, match=r"1 singular pose\(s\) \(first at index \(1,\)\): theta1 = 31 deg"):
        Arm().end_effector_force(theta1, np.radians(30.0), 1.0, 1.0)


def test_just_outside_the_threshold_is_accepted():
    delta = np.arcsin(SINGULAR_SIN_DELTA) * (1 + 1e-9)
    fx, fy = Arm().end_effector_force(delta, 0.0, 1.0, 1.0)
    assert np.isfinite(fx) and np.isfinite(fy)


def test_masking_returns_nan_and_mask():
    arm = Arm()
    theta1 = np.radians([90.0, 30.0, 45.0])
    fx, fy, singular = arm.end_effector_force(theta1, np.radians(30.0), 1.0, 2.0, on_singular="mask")
    np.testing.assert_array_equal(singular, [False, True, False])
    assert np.isnan(fx[1]) and np.isnan(fy[1])
    gx, gy = arm.end_effector_force(theta1[[0, 2]], np.radians(30.0), 1.0, 2.0)
    np.testing.assert_array_equal(fx[[0, 2]], gx)
    np.testing.assert_array_equal(fy[[0, 2]], gy)


def test_masking_without_singular_poses():
    fx, fy, singular = Arm().end_effector_force(1.0, 0.0, 1.0, 2.0, on_singular="mask")
    assert not singular and np.isfinite(fx) and np.isfinite(fy)


def test_threshold_is_configurable():
    arm = Arm()
    with pytest.raises(SingularPoseError, match="threshold 0.5"):
        arm.end_effector_force(np.radians(20.0), 0.0, 1.0, 1.0, min_sin_delta=0.5)


def test_bad_on_singular_is_refused():
    with pytest.raises(ValueError, match="on_singular"):
        Arm().end_effector_force(1.0, 0.0, 1.0, 1.0, on_singular="ignore")


@pytest.mark.parametrize("shape", [(), (7,), (2, 3, 4)])
def test_batched_equals_scalar(shape):
    rng = np.random.default_rng(11)
    arm = Arm()
    theta2 = rng.uniform(-np.pi, np.pi, shape)
    theta1 = theta2 + rng.uniform(0.3, 2.8, shape)
    fx, fy = rng.normal(size=shape), rng.normal(size=shape)
    t1, t2 = joint_torques(arm, theta1, theta2, fx, fy)
    gx, gy = end_effector_force(arm, theta1, theta2, t1, t2)
    assert np.shape(gx) == shape
    for idx in np.ndindex(shape):
        s = [float(a[idx]) for a in (theta1, theta2, fx, fy)]
        st1, st2 = joint_torques(arm, *s)
        assert (st1, st2) == (t1[idx], t2[idx])
        sgx, sgy = end_effector_force(arm, s[0], s[1], st1, st2)
        assert (sgx, sgy) == (gx[idx], gy[idx])


def test_polar_round_trip():
    m, phi = polar(*cartesian(np.array([1.0, 2.5]), np.radians([30.0, -120.0])))
    np.testing.assert_allclose(m, [1.0, 2.5], rtol=1e-15)
    np.testing.assert_allclose(np.degrees(phi), [30.0, -120.0], rtol=1e-13)


def test_blocks_report_the_global_index_and_mask_across_blocks():
    from sailforce.statics import BLOCK

    arm = Arm()
    n = 2 * BLOCK + 10
    theta1 = np.full(n, np.radians(80.0))
    bad = BLOCK + 7  # in the second block
    theta1[bad] = 0.0
    with pytest.raises(SingularPoseError, match=rf"1 singular pose\(s\) \(first at index \({bad},\)\)"):
        arm.end_effector_force(theta1, 0.0, 1.0, 2.0)
    fx, fy, singular = arm.end_effector_force(theta1, 0.0, 1.0, 2.0, on_singular="mask")
    assert np.flatnonzero(singular).tolist() == [bad]
    assert np.isnan(fx[bad]) and np.all(np.isfinite(np.delete(fx, bad)))
    single = arm.end_effector_force(np.radians(80.0), 0.0, 1.0, 2.0)
    np.testing.assert_array_equal(fx[-1], single[0])
