"""Identification of physical parameters: recovery, uncertainty, identifiability, the physics calibration."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sailforce.fit.identify import (
    Identification,
    IdentifyError,
    ReadingsTarget,
    identify,
    parameter,
    with_free_springs,
    with_parameter,
)
from sailforce.fit.physics import fit_physics
from sailforce.paper.study import table4
from sailforce.paper.table4_fit import identify_table4
from sailforce.robot import Joint, Joints, Robot
from sailforce.synthetic import NoiseModel, calibration_session

#: Noise-free recovery: the fit's own tolerances (1e-12) leave far less than this.
RECOVERY_RTOL = 1e-6


def test_one_shared_stiffness_is_recovered_noise_free():
    truth = Robot().with_joints("spring")
    truth = with_parameter(truth, "joints.stiffness", 170.0)
    fit = identify_table4(Robot().with_joints("spring"), table4(truth), ["joints.stiffness"])
    assert fit.values[0] == pytest.approx(170.0, rel=RECOVERY_RTOL)
    assert fit.identifiable.all() and max(fit.phase_rms_deg) < 1e-6 and fit.success


def test_three_joint_stiffnesses_are_recovered_but_flagged_as_correlated():
    """Table 4 sees the three springs almost only through one combination: the fit finds them without
    noise, but their correlations exceed 0.99, so they are flagged as not identifiable one by one."""
    joints = Joints("spring", 50.0, P1=Joint("spring", 80.0), P2=Joint("spring", 300.0), P3=Joint("spring", 40.0))
    free = ["joints.P1.stiffness", "joints.P2.stiffness", "joints.P3.stiffness"]
    fit = identify_table4(Robot().with_joints("spring"), table4(Robot(joints=joints)), free, starts=1)
    np.testing.assert_allclose(fit.values, [80.0, 300.0, 40.0], rtol=RECOVERY_RTOL)
    assert not fit.identifiable.any() and np.abs(fit.correlation[0, 1]) > 0.99


def test_a_parameter_the_data_cannot_see_is_flagged():
    """With locked motors the gearbox stiffness changes nothing: its Jacobian column is zero."""
    robot = Robot().with_joints("spring")
    fit = identify_table4(robot, table4(robot), ["motors.stiffness"], starts=1)
    assert not fit.identifiable[0] and np.isnan(fit.collinearity[0])


def test_unknown_parameters_and_grids_are_refused():
    with pytest.raises(IdentifyError, match="unknown parameter .joints.P4.stiffness."):
        identify_table4(Robot(), table4(Robot()), ["joints.P4.stiffness"])
    with pytest.raises(IdentifyError, match="nothing to fit"):
        identify_table4(Robot(), table4(Robot()), [])
    with pytest.raises(IdentifyError, match="the target's Table 4 has delta"):
        identify_table4(Robot().with_joints("spring"), table4(Robot())[:4], ["joints.stiffness"], starts=1)


# --- any robot-file key, readings as the target ------------------------------------------------------------------


DIFFERING = Joints("spring", 50.0, P1=Joint("spring", 2000.0), P2=Joint("spring", 500.0), P3=Joint("spring", 8000.0))
STIFFNESSES = ("joints.P1.stiffness", "joints.P2.stiffness", "joints.P3.stiffness")


def _readings(truth: Robot, noise: NoiseModel, transduction: str = "bridge", **kwargs) -> ReadingsTarget:
    t1, t2, fx, fy, counts, _ = calibration_session(truth, noise=noise, **kwargs)
    return ReadingsTarget(t1, t2, fx, fy, counts[:, 0], counts[:, 1], transduction)


def test_joint_stiffnesses_gains_and_offsets_are_recovered_from_noise_free_readings():
    truth = Robot(joints=DIFFERING, loadcell=replace(Robot().loadcell, rated_output_mV_V=1.9))
    target = _readings(truth, NoiseModel(0.0, 0.02, quantize=False))
    fit = identify(with_free_springs(Robot(), STIFFNESSES), target, STIFFNESSES)
    np.testing.assert_allclose(fit.values[:3], [2000.0, 500.0, 8000.0], rtol=RECOVERY_RTOL)
    counts_per_mV_V = 2**23 * 128 / 500.0  # synthetic.HX711_COUNTS_PER_MV_V
    # the model's cells are rated 2 mV/V, the true ones 1.9: the gains absorb the difference
    np.testing.assert_allclose(fit.gains, [counts_per_mV_V * 1.9 / 2.0] * 2, rtol=RECOVERY_RTOL)


def test_with_noise_the_shared_stiffness_lies_within_its_standard_errors():
    """Five sessions with independent noise: each estimate within 3 SE of the truth, and the SE honest
    (the spread of the estimates is of the size of the SE, not ten times it)."""
    truth = Robot(joints=Joints("spring", 900.0))
    estimates, errors = [], []
    for seed in range(1, 6):
        fit = identify(Robot(joints=Joints("spring", 50.0)), _readings(truth, NoiseModel(), seed=seed),
                       ["joints.stiffness"], starts=2)  # fmt: skip
        estimates.append(fit.values[0])
        errors.append(fit.standard_errors[0])
        assert abs(fit.values[0] - 900.0) < 3.0 * fit.standard_errors[0]
    assert 0.2 < np.std(estimates, ddof=1) / np.mean(errors) < 5.0


def test_a_cells_gain_and_compliance_under_the_deflection_reading_are_flagged():
    """On a pin-jointed arm the far-face deflection is (cell compliance + the link's share) x the shear,
    every internal force of a driven link being proportional to it: a gain and the compliance trade
    exactly, so neither is identifiable."""
    truth = Robot()
    poses = _readings(truth, NoiseModel(0.0, 0.0, quantize=False))
    clean = poses.signals(truth) * 1e8  # counts per metre of far-face deflection
    noisy = clean + np.random.default_rng(5).normal(0.0, 1e-4 * np.abs(clean).max(), clean.shape)
    target = ReadingsTarget(poses.theta1, poses.theta2, poses.fx, poses.fy, noisy[:, 0], noisy[:, 1], "deflection")
    fit = identify(truth, target, ["loadcells.rated_deflection"], starts=1)
    gains = [fit.names.index("gain1"), fit.names.index("gain2")]
    assert fit.collinearity[0] > 0.99 and (fit.collinearity[gains] > 0.99).all()
    assert not fit.identifiable[0] and not fit.identifiable[gains].any()


def test_lengths_and_the_cell_position_are_parameters_with_bounds():
    robot = Robot().with_joints("bonded")
    assert parameter(robot, "links.l3").low == pytest.approx(robot.arm.l3 / 2)
    assert parameter(robot, "loadcells.position").log is False
    truth = with_parameter(robot, "links.l3", 0.5)
    fit = identify_table4(robot, table4(truth), ["links.l3"], starts=1)
    assert fit.values[0] == pytest.approx(0.5, rel=RECOVERY_RTOL)
    with pytest.raises(IdentifyError, match="does not enter the static sensing map"):
        parameter(robot, "handle.mass")
    with pytest.raises(IdentifyError, match="is a name"):
        parameter(robot, "joints.model")
    with pytest.raises(IdentifyError, match="bounds"):
        parameter(robot, "joints.stiffness", (-1.0, 10.0))


def test_physics_on_pin_jointed_data_gives_the_pin_model():
    """Pin joints carry no moment: the fitted springs go to the lower bound, and the stored map is
    the determinate one, C(delta) = diag(g_i / (l_i F_cap) x rated output), constant over delta."""
    truth = Robot()
    t1, t2, fx, fy, counts, offsets = calibration_session(truth, noise=NoiseModel(0.0, 0.02, quantize=False))
    fit = fit_physics(Robot(), t1, t2, fx, fy, counts[:, 0], counts[:, 1], cross_validate=False)
    assert set(fit.identification.at_bound()) == set(STIFFNESSES)
    delta = np.radians(np.linspace(15.0, 165.0, 31))
    c = fit.compensator.correction(delta)
    cell = truth.loadcell
    per_torque = 2**23 * 128 / 500.0 * cell.rated_output_mV_V / cell.capacity_N / np.array([truth.arm.l1, truth.arm.l2])
    np.testing.assert_allclose(c[:, [0, 1], [0, 1]], np.broadcast_to(per_torque, (31, 2)), rtol=1e-4)
    assert np.abs(c[:, [0, 1], [1, 0]]).max() < 1e-4 * per_torque.min()
    np.testing.assert_allclose(fit.offsets, offsets, rtol=1e-9)


def test_auto_prefers_matrix_when_the_free_set_cannot_represent_the_data():
    """Joints that differ (one nearly rigid, one soft, one bonded) fitted with one shared spring: the
    physics model's cross-validated error is far above the matrix model's, and auto does not pick it."""
    from sailforce.fit.calibration import fit_calibration

    truth = Robot(joints=Joints("spring", 50.0, P1=Joint("spring", 2e4), P2=Joint("spring", 300.0), P3=Joint("bonded")))
    t1, t2, fx, fy, counts, _ = calibration_session(truth)
    _, _, report = fit_calibration(truth.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="auto", robot=Robot(),
                                   free=("joints.stiffness",))  # fmt: skip
    assert report.kind == "matrix"
    assert report.cv_rmse_by_kind["physics"] > 3 * report.cv_rmse_by_kind["matrix"]


def test_the_physics_model_needs_the_robot():
    from sailforce.fit.calibration import fit_calibration
    from sailforce.sensing.maps import CompensationError

    t1, t2, fx, fy, counts, _ = calibration_session(Robot())
    with pytest.raises(CompensationError, match="needs the robot"):
        fit_calibration(Robot().arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="physics")


def test_at_bound_is_judged_relative_to_each_bound():
    """A stiffness of 2.2 N m/rad is far from a lower bound of 0.01, however wide the range (log-fitted scales)."""
    fit = Identification(robot=Robot(), names=("k", "kk", "c"), values=np.array([2.23, 0.0100000001, 0.0]),
                         standard_errors=np.zeros(3), correlation=np.eye(3), identifiable=np.ones(3, bool),
                         collinearity=np.zeros(3), residuals=np.zeros((1, 1)), residual_columns=("r",), metrics={},
                         bounds=((0.01, 1e7), (0.01, 1e7), (0.0, 1.0)), starts=1, success=True)  # fmt: skip
    assert fit.at_bound() == ("kk", "c")


def test_many_parameters_start_from_a_latin_hypercube_the_same_every_run():
    """Beyond MAX_STARTS grid points: one start in each of MAX_STARTS equal slices of every parameter's range."""
    from sailforce.fit.identify import MAX_STARTS, _starts

    low, high = np.array([1.0, -2.0, 0.0, 10.0, 5.0]), np.array([2.0, 2.0, 1e-3, 20.0, 6.0])
    starts = _starts(low, high, 3)
    assert starts.shape == (MAX_STARTS, 5) and np.all((starts > low) & (starts < high))
    slices = np.floor((starts - low) / (high - low) * MAX_STARTS).astype(int)
    for column in slices.T:
        assert sorted(column) == list(range(MAX_STARTS))
    np.testing.assert_array_equal(starts, _starts(low, high, 3))
    assert np.corrcoef(starts.T)[np.triu_indices(5, 1)].max() < 0.9  # not the grid's diagonal: parameters are paired at random
