"""Is the prediction honest?  Calibrations fitted to simulated recordings of a plan, repeated over noise draws.

Each draw hangs the plan's forces on the robot file's frame model (the
truth the plan was made for, :func:`sailforce.synthetic.recording`), adds
each hold's reading noise (:func:`sailforce.plan.protocol.reading_noise`),
and fits the plan's model with the fitter ``sail calibrate`` uses
(:func:`sailforce.fit.identify.identify` for physics, a least-squares
series of the plan's order for matrix).  The fitted calibration then
estimates noise-free readings of the map's forces; the RMS over draws of
that error is the *simulated spread*, the quantity
:func:`sailforce.plan.design.predicted_map` predicts from the linearised
model alone.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..estimate.estimator import estimate_force
from ..fit.identify import ReadingsTarget, identify
from ..fit.matrix import fit_matrix_at_order
from ..fit.physics import DEFAULT_TRANSDUCTION, force_from_map
from ..synthetic import NoiseModel, recording
from .design import MAP_DIRECTIONS, ErrorMap, covariance, map_b, map_deltas, map_points
from .protocol import Plan

#: Noise draws unless told.
DEFAULT_DRAWS = 40


def simulated_errors(plan: Plan, draws: int = DEFAULT_DRAWS, seed: int = 0, progress=None) -> tuple[np.ndarray, np.ndarray]:
    """Each draw's force error at the map's points [N], ``(draws, deltas * directions, 2)``: from the fitted
    calibration, and as the linearised model has it (``-B dphi``, ``dphi`` the weighted least-squares response to the
    same noise: :mod:`sailforce.plan.design`).  Points run over deltas, then directions."""
    model, force = plan.model, plan.predicted.force_N
    # a hold k times as long gives k times the rows (each a hold's worth of conversions), as a recording does
    repeats = np.maximum(1, np.round(plan.conversions / plan.conversions_per_hold)).astype(int)
    rows = plan.holds.take(np.repeat(np.arange(len(plan.holds)), repeats))
    holds = replace(rows, sigma=rows.sigma * np.sqrt(np.repeat(repeats, repeats)))
    robot = model.robot
    quiet = NoiseModel(noise_fraction=0.0, quantize=False)
    offsets = np.zeros(2)
    clean = recording(robot, holds.theta1, holds.theta2, holds.fx, holds.fy, noise=quiet, offsets=offsets)[0]
    d, fx, fy = map_points(force)
    zero = np.zeros_like(d)
    truth = recording(robot, d, zero, fx, fy, noise=quiet, offsets=offsets)[0]
    a = model.regressor(holds.theta1, holds.theta2, holds.fx, holds.fy) / holds.sigma[:, None, None]
    b = map_b(model, force)  # (points, 2, p)
    sigma = covariance(model, holds)
    rng = np.random.default_rng(seed)
    fitted, linear = np.empty((draws, d.size, 2)), np.empty((draws, d.size, 2))
    for draw in range(draws):
        unit = rng.normal(0.0, 1.0, clean.shape)
        loads = clean + unit * holds.sigma[:, None]
        if model.model == "physics":
            target = ReadingsTarget(holds.theta1, holds.theta2, holds.fx, holds.fy, loads[:, 0], loads[:, 1],
                                    DEFAULT_TRANSDUCTION)  # fmt: skip
            fit = identify(robot, target, model.free, starts=0)
            fx_hat, fy_hat = force_from_map(fit.robot, fit.gains, fit.offsets, d, zero, truth[:, 0], truth[:, 1],
                                            DEFAULT_TRANSDUCTION)  # fmt: skip
        else:
            series, fitted_offsets = fit_matrix_at_order(robot.arm, holds.theta1, holds.theta2, holds.fx, holds.fy,
                                                         loads[:, 0], loads[:, 1], model.order, model.delta_range)  # fmt: skip
            fx_hat, fy_hat, _ = estimate_force(series, d, zero, truth[:, 0] - fitted_offsets[0],
                                               truth[:, 1] - fitted_offsets[1], on_singular="mask")  # fmt: skip
        fitted[draw] = np.column_stack([fx_hat - fx, fy_hat - fy])
        dphi = sigma @ np.einsum("nip,ni->p", a, unit)  # the weighted least-squares response to this noise
        linear[draw] = -(b @ dphi)
        if progress:
            progress(draw + 1, draws)
    return fitted, linear


def as_map(errors: np.ndarray, force_N: float) -> ErrorMap:
    """An :class:`~sailforce.plan.design.ErrorMap` from errors ``(draws, points, 2)``: the RMS over draws."""
    delta = map_deltas()
    var = np.mean(np.sum(errors**2, axis=-1), axis=0).reshape(delta.size, MAP_DIRECTIONS)
    return ErrorMap(delta, np.sqrt(var.max(axis=1)), np.sqrt(var.mean(axis=1)), force_N)


def simulated_spread(plan: Plan, draws: int = DEFAULT_DRAWS, seed: int = 0, progress=None) -> ErrorMap:
    """The force error of calibrations fitted to ``draws`` simulated recordings of ``plan`` (module docstring)."""
    return as_map(simulated_errors(plan, draws, seed, progress)[0], plan.predicted.force_N)
