"""The force kernel: the compiled back-end against the numpy reference, and the back-end switch."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sailforce import SINGULAR_SIN_DELTA, Arm, kernel
from sailforce.calibration.file import Calibration
from sailforce.errors import SailError
from sailforce.estimate.estimator import estimate_force
from sailforce.sensing.maps import MatrixCompensator, TorqueScale
from sailforce.status import INVALID, SATURATED, SINGULAR

compiled = pytest.importorskip("sailforce.kernel._compiled", reason="numba is not installed")

#: The compiled path's forces against numpy's, relative to the force's magnitude at the pose: rounding only
#: (1-ulp sines and cosines, sums in another order), amplified by the 2x2 solve's condition (<~30 at 2 deg)
#: and, far outside a calibrated range, by the Chebyshev series' cancellation (T_6(3.6) ~ 6e4): measured
#: 2e-12 at worst, 5e-15 at the 99.9th percentile.
FORCE_RTOL = 1e-11


def _both(function, *args, **kwargs):
    with kernel.use_backend("compiled"):
        fast = function(*args, **kwargs)
    with kernel.use_backend("numpy"):
        reference = function(*args, **kwargs)
    return fast, reference


def _assert_forces_close(fast, reference):
    (fx, fy), (gx, gy) = fast, reference
    np.testing.assert_array_equal(np.isnan(fx), np.isnan(gx))
    ok = ~np.isnan(gx)
    scale = np.hypot(gx[ok], gy[ok]) + 1e-300
    assert np.all(np.abs(fx[ok] - gx[ok]) <= FORCE_RTOL * scale)
    assert np.all(np.abs(fy[ok] - gy[ok]) <= FORCE_RTOL * scale)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-1.5e6, 1.5e6, allow_nan=False), min_size=1, max_size=200))
def test_sincos_is_within_one_ulp_of_libm(values):
    x = np.array(values)
    s, c = np.empty_like(x), np.empty_like(x)
    compiled.sincos_array(x, s, c)
    assert np.all(np.abs(s - np.sin(x)) <= np.spacing(1.0)) and np.all(np.abs(c - np.cos(x)) <= np.spacing(1.0))


def test_sincos_beyond_the_reduction_limit_is_libm():
    x = np.array([2e6, -1e9, 1e300, np.inf, np.nan])
    s, c = np.empty_like(x), np.empty_like(x)
    compiled.sincos_array(x, s, c)
    with np.errstate(invalid="ignore"):  # sin(inf) is NaN
        np.testing.assert_array_equal(s, np.sin(x))
        np.testing.assert_array_equal(c, np.cos(x))


def _poses(n, seed):
    rng = np.random.default_rng(seed)
    theta2 = rng.uniform(-np.pi, np.pi, n)
    delta = rng.uniform(-np.pi, np.pi, n)
    edge = np.arcsin(SINGULAR_SIN_DELTA) + rng.uniform(-1e-13, 1e-13, n)  # straddling the threshold
    delta[: n // 4] = np.where(rng.uniform(size=n // 4) < 0.5, edge[: n // 4], np.pi - edge[: n // 4])
    theta1 = theta2 + delta
    theta1[n // 4 : n // 4 + 5] += 1e7  # beyond the polynomial's range: numpy settles these
    return theta1, theta2, rng


def test_end_effector_force_compiled_equals_numpy():
    theta1, theta2, rng = _poses(100_003, 3)  # several blocks, the last one short
    t1, t2 = rng.normal(size=(2, theta1.size))
    fast, reference = _both(Arm().end_effector_force, theta1, theta2, t1, t2, on_singular="mask")
    np.testing.assert_array_equal(fast[2], reference[2])  # every verdict, also within 1e-13 of the threshold
    assert 0.05 < reference[2].mean() < 0.25
    _assert_forces_close(fast[:2], reference[:2])


def _calibration(coefficients) -> Calibration:
    arm = Arm()
    return Calibration(arm=arm, model=MatrixCompensator(arm, coefficients, (0.3, 2.8)), offsets=(100.0, -50.0),
                       capacity=(4e5, 4e5), delta_range=(0.3, 2.8), load_range=((-4e5, 4e5), (-4e5, 4e5)))  # fmt: skip


@pytest.mark.parametrize("order", [0, 1, 6])
def test_calibration_estimate_compiled_equals_numpy(order):
    rng = np.random.default_rng(order)
    coefficients = rng.normal(scale=0.1, size=(order + 1, 2, 2))
    coefficients[0] += np.diag([2.0, 2.4])
    cal = _calibration(coefficients)
    theta1, theta2, rng = _poses(50_000, order)
    loads = cal.offsets + rng.normal(0.0, 2e5, (theta1.size, 2))
    loads[::97, 0] = np.nan  # invalid
    theta2[::101] = np.inf
    fast, reference = _both(cal.estimate, theta1, theta2, loads[:, 0], loads[:, 1])
    np.testing.assert_array_equal(fast[2], reference[2])
    counts = np.bincount(reference[2], minlength=5)
    assert counts[INVALID] > 0 and counts[SINGULAR] > 0 and counts[SATURATED] > 0 and counts[0] > 0
    _assert_forces_close(fast[:2], reference[:2])


def test_a_degenerate_map_is_singular_on_both():
    cal = _calibration(np.zeros((1, 2, 2)))
    fast, reference = _both(cal.estimate, np.array([1.5]), np.array([0.2]), np.array([1.0]), np.array([2.0]))
    assert fast[2][0] == reference[2][0] == SINGULAR and np.isnan(fast[0][0])


def test_torque_scale_series_is_its_sensing_map():
    arm = Arm()
    model = TorqueScale(arm, (0.5, 2.0))
    theta1, theta2 = np.array([1.2, 2.0, -0.4]), np.array([0.1, 0.3, -2.0])
    loads = np.array([[0.3, -1.0], [2.0, 0.5], [-0.2, 0.1]])
    fast, reference = _both(estimate_force, model, theta1, theta2, loads[:, 0], loads[:, 1])
    _assert_forces_close(fast, reference)
    fx, fy = reference
    t1, t2 = arm.joint_torques(theta1, theta2, fx, fy)
    np.testing.assert_allclose(np.stack([t1 / 0.5, t2 / 2.0], axis=-1), loads, rtol=1e-12)  # s_i = T_i / k_i


def test_an_unknown_backend_is_refused(monkeypatch):
    with pytest.raises(SailError, match="expected one of compiled, numpy"):
        with kernel.use_backend("fortran"):
            pass
    monkeypatch.setattr(kernel, "_chosen", None)
    monkeypatch.setenv(kernel.BACKEND_ENV, "gpu")
    with pytest.raises(SailError, match="SAILFORCE_KERNEL='gpu'"):
        kernel.backend()


def test_without_numba_the_numpy_path_serves(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_numba(name, *args, **kwargs):
        if name == "numba" or name.startswith("numba."):
            raise ImportError("No module named 'numba'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_numba)
    monkeypatch.setattr(kernel, "_module", None)
    monkeypatch.setattr(kernel, "_chosen", None)
    monkeypatch.delitem(__import__("sys").modules, "sailforce.kernel._compiled")
    monkeypatch.delattr(kernel, "_compiled")
    monkeypatch.delenv(kernel.BACKEND_ENV, raising=False)
    assert kernel.backend() == "numpy"
    fx, fy = Arm().end_effector_force(np.pi / 2, 0.0, 0.0, 3.0)
    assert abs(fy - 10.0) < 1e-12
    with pytest.raises(SailError, match="needs numba"):
        with kernel.use_backend("compiled"):
            pass


def test_sail_estimate_does_not_load_numba(tmp_path):
    """`sail estimate` prefers numpy: numba's LLVM would cost ~116 MB of its 300 MB budget (bench_estimate)."""
    import subprocess
    import sys

    from sailforce.fit.calibration import fit_calibration
    from sailforce.robot import Robot
    from sailforce.synthetic import calibration_session

    robot = Robot()
    t1, t2, fx, fy, counts, _ = calibration_session(robot, seed=1, step_deg=15, directions=8)
    model, offsets, _ = fit_calibration(robot.arm, t1, t2, fx, fy, counts[:, 0], counts[:, 1], kind="matrix")
    Calibration(arm=robot.arm, model=model, offsets=tuple(offsets), capacity=(4e6, 4e6), delta_range=model.delta_range,
                load_range=((-4e6, 4e6), (-4e6, 4e6))).save(tmp_path / "cal.json")
    (tmp_path / "in.csv").write_text("theta1_deg,theta2_deg,load1,load2\n90,10,1000,2000\n")
    code = ("import sys; from sailforce.cli import main; sys.argv = ['sail', 'estimate', '--calibration', sys.argv[1], "
            "sys.argv[2], '-o', sys.argv[3], '-q']\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
            "print('numba' in sys.modules)")
    env = {k: v for k, v in __import__("os").environ.items() if k != kernel.BACKEND_ENV}
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "cal.json"), str(tmp_path / "in.csv"),
                           str(tmp_path / "out.csv")], capture_output=True, text=True, env=env, check=True)  # fmt: skip
    assert done.stdout.strip().endswith("False") and (tmp_path / "out.csv").read_text().count("\n") == 2


def test_a_small_call_stays_on_numpy_until_the_compiled_module_is_loaded():
    """The size rule: numba loads for a call of COMPILED_MIN_POSES poses, and then serves every call."""
    import os
    import subprocess
    import sys

    code = """
import sys, numpy as np
from sailforce import kernel
from sailforce.calibration.file import Calibration
cal = Calibration.load(sys.argv[1])
kernel.COMPILED_MIN_POSES = 2000
def call(n):
    theta = np.full(n, 1.2)
    return cal.estimate(theta, theta - 1.0, np.full(n, 5e4), np.full(n, -3e4))
call(1999)
print('numba' in sys.modules, kernel.compiled(10) is None)
call(2000)
print('numba' in sys.modules, kernel.compiled(10) is None)
"""
    env = {k: v for k, v in os.environ.items() if k != kernel.BACKEND_ENV}
    cal = str(Path(__file__).resolve().parents[1] / "c" / "examples" / "calibration.json")
    done = subprocess.run([sys.executable, "-c", code, cal], capture_output=True, text=True, env=env, check=True)
    assert done.stdout.split() == ["False", "True", "True", "False"]


def test_a_backend_chosen_by_name_serves_calls_of_any_size(monkeypatch):
    monkeypatch.delenv(kernel.BACKEND_ENV, raising=False)
    with kernel.use_backend("compiled"):
        assert kernel.compiled(1) is not None
    with kernel.use_backend("numpy"):
        assert kernel.compiled(10 * kernel.COMPILED_MIN_POSES) is None
