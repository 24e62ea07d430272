"""Identification of physical parameters from a Table 4 (issue 12, in progress): recovery and identifiability."""

from __future__ import annotations

import numpy as np
import pytest

from sailforce.identify import IdentifyError, identify_table4, with_parameter
from sailforce.robot import Joint, Joints, Robot
from sailforce.study import table4

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
    """With bonded joints the spring stiffness changes nothing: its Jacobian column is zero."""
    bonded = Robot().with_joints("bonded")
    fit = identify_table4(bonded, table4(bonded), ["joints.stiffness"], starts=1)
    assert not fit.identifiable[0]


def test_unknown_parameters_and_grids_are_refused():
    with pytest.raises(IdentifyError, match="unknown parameter 'joints.P4.stiffness'"):
        identify_table4(Robot(), table4(Robot()), ["joints.P4.stiffness"])
    with pytest.raises(IdentifyError, match="nothing to fit"):
        identify_table4(Robot(), table4(Robot()), [])
    with pytest.raises(IdentifyError, match="the target's Table 4 has delta"):
        identify_table4(Robot().with_joints("spring"), table4(Robot())[:4], ["joints.stiffness"], starts=1)
