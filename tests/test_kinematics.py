"""Kinematics: seed Eqs. 1 and 4, inverse kinematics, workspace."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sailforce import Arm, UnreachablePointError
from sailforce.errors import NonFiniteInputError, ShapeError
from sailforce.kinematics import (
    jacobian_condition,
    joint_positions,
    sin_delta,
    workspace,
)

from .conftest import angles, arms

#: Central differences with h = 1e-6 rad carry O(h^2 * l) ~ 1e-12 m truncation
#: and O(eps * l / h) ~ 1e-10 rounding error, so 1e-8 m is a comfortable bound.
FD_STEP = 1e-6
FD_ATOL = 1e-8

#: IK -> FK round trips lose a few ulps through arccos near the boundary; 1e-9 m
#: on a metre-scale arm is a nanometre.
IK_ATOL = 1e-9


def test_forward_matches_eq1_by_hand():
    # Eq. 1 at theta1 = 90 deg, theta2 = 0: A = (l2, l3).
    arm = Arm()
    x, y = arm.forward(np.pi / 2, 0.0)
    assert x == pytest.approx(arm.l2, abs=1e-15)
    assert y == pytest.approx(arm.l3, abs=1e-15)


def test_joint_positions_form_a_parallelogram():
    arm = Arm()
    p = joint_positions(arm, 1.1, 0.3)
    np.testing.assert_allclose(np.linalg.norm(p["P1"]), arm.l1, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(p["P2"]), arm.l2, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(p["P3"] - p["P1"]), arm.l4, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(p["P3"] - p["P2"]), arm.l1, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(p["A"] - p["P2"]), arm.l3, rtol=1e-14)
    np.testing.assert_allclose(p["A"], np.stack(arm.forward(1.1, 0.3)), rtol=1e-15)


@given(arm=arms(), theta1=angles, theta2=angles)
def test_jacobian_matches_finite_difference(arm, theta1, theta2):
    J = arm.jacobian(theta1, theta2)
    for j, (d1, d2) in enumerate(((FD_STEP, 0.0), (0.0, FD_STEP))):
        plus = np.array(arm.forward(theta1 + d1, theta2 + d2))
        minus = np.array(arm.forward(theta1 - d1, theta2 - d2))
        np.testing.assert_allclose(J[:, j], (plus - minus) / (2 * FD_STEP), atol=FD_ATOL)


@given(arm=arms(), theta1=angles, theta2=angles)
def test_jacobian_determinant_is_eq9(arm, theta1, theta2):
    det = np.linalg.det(arm.jacobian(theta1, theta2))
    assert det == pytest.approx(-arm.l2 * arm.l3 * np.sin(theta1 - theta2), abs=1e-12)


@given(arm=arms(), theta1=angles, theta2=angles)
def test_condition_matches_numpy(arm, theta1, theta2):
    if abs(np.sin(theta1 - theta2)) < 1e-3:
        return  # near-singular: both sides are huge and numpy's SVD loses digits
    expected = np.linalg.cond(arm.jacobian(theta1, theta2))
    assert jacobian_condition(arm, theta1, theta2) == pytest.approx(expected, rel=1e-8)


def test_condition_is_infinite_when_singular():
    assert jacobian_condition(Arm(), 0.4, 0.4) == np.inf


@pytest.mark.parametrize("branch", [1, -1])
@given(arm=arms(), theta1=angles, theta2=angles)
def test_inverse_round_trips_on_both_branches(branch, arm, theta1, theta2):
    x, y = arm.forward(theta1, theta2)
    t1, t2 = arm.inverse(x, y, branch=branch)
    assert branch * np.sin(t1 - t2) >= -1e-12
    np.testing.assert_allclose(arm.forward(t1, t2), (x, y), atol=IK_ATOL)


def test_inverse_recovers_the_pose_on_its_own_branch():
    arm = Arm()
    theta1 = np.radians([15.0, 60.0, 120.0, 170.0])
    theta2 = np.radians([0.0, -20.0, 30.0, 10.0])
    t1, t2 = arm.inverse(*arm.forward(theta1, theta2))
    np.testing.assert_allclose(t1, theta1, atol=1e-12)
    np.testing.assert_allclose(t2, theta2, atol=1e-12)
    m1, m2 = arm.inverse(*arm.forward(theta1, theta2), branch=-1)
    assert np.all(np.sin(m1 - m2) < 0)


def test_inverse_rejects_unreachable_points_with_a_clear_message():
    arm = Arm()
    with pytest.raises(UnreachablePointError, match=r"r = 0.8 m.*0.15 m <= r <= 0.75 m"):
        arm.inverse([0.5, 0.8], [0.0, 0.0])
    with pytest.raises(UnreachablePointError, match="outside the workspace"):
        arm.inverse(0.1, 0.0)  # inside the inner radius |l2 - l3| = 0.15 m


def test_inverse_accepts_the_boundary():
    arm = Arm()
    t1, t2 = arm.inverse(arm.l2 + arm.l3, 0.0)
    assert t1 == pytest.approx(0.0, abs=1e-7)
    assert t2 == pytest.approx(0.0, abs=1e-7)


def test_inverse_rejects_a_bad_branch():
    with pytest.raises(ShapeError, match="branch"):
        Arm().inverse(0.3, 0.4, branch=0)


def test_sin_delta_measures_the_collapse():
    assert sin_delta(0.7, 0.7) == 0.0
    assert sin_delta(np.pi / 2, 0.0) == 1.0


def test_workspace_spans_the_annulus():
    arm = Arm()
    ws = workspace(arm, theta1_range=(-np.pi, np.pi), theta2_range=(-np.pi, np.pi), n=91)
    r = np.hypot(ws.x, ws.y)
    inner, outer = arm.reach
    assert r.max() == pytest.approx(outer, rel=1e-12)
    assert r.min() == pytest.approx(inner, rel=1e-12)
    assert ws.condition.shape == (91, 91)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_angles_are_refused(bad):
    with pytest.raises(NonFiniteInputError, match="theta2: expected finite numbers"):
        Arm().forward([0.1, 0.2], [0.0, bad])


def test_shapes_that_do_not_broadcast_are_refused():
    with pytest.raises(ShapeError, match=r"theta1 \(2,\), theta2 \(3,\)"):
        Arm().jacobian(np.zeros(2), np.zeros(3))


@pytest.mark.parametrize("shape", [(), (5,), (2, 3, 4)])
def test_batched_equals_scalar(shape):
    rng = np.random.default_rng(7)
    arm = Arm()
    theta1 = rng.uniform(-np.pi, np.pi, shape)
    theta2 = rng.uniform(-np.pi, np.pi, shape)
    x, y = arm.forward(theta1, theta2)
    J = arm.jacobian(theta1, theta2)
    assert np.shape(x) == shape and J.shape == shape + (2, 2)
    for idx in np.ndindex(shape):
        xs, ys = arm.forward(float(theta1[idx]), float(theta2[idx]))
        assert (x[idx], y[idx]) == (xs, ys)
        np.testing.assert_array_equal(J[idx], arm.jacobian(float(theta1[idx]), float(theta2[idx])))


def test_broadcasting_adds_axes():
    arm = Arm()
    x, _ = arm.forward(np.zeros((3, 1)), np.zeros((1, 4)))
    assert x.shape == (3, 4)


@given(st.lists(angles, min_size=1, max_size=5))
def test_inverse_output_is_wrapped(values):
    arm = Arm()
    t1, t2 = arm.inverse(*arm.forward(np.array(values), 0.0))
    assert np.all((t1 > -np.pi - 1e-15) & (t1 <= np.pi + 1e-15))
    assert np.all((t2 > -np.pi - 1e-15) & (t2 <= np.pi + 1e-15))
