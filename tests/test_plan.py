"""Calibration planning: hold times, the predicted error against simulated calibrations, the
plan against the seed's grid and a uniform grid, the order of the holds, bad input and the command."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from sailforce import Robot
from sailforce.adc import adc_model
from sailforce.cli import cli
from sailforce.errors import InputError
from sailforce.motion.multirate import noise_counts
from sailforce.plan import Rig, hold_time, plan_calibration
from sailforce.plan.design import MAP_DIRECTIONS, map_deltas
from sailforce.plan.verify import as_map, simulated_errors
from sailforce.robot import Joint, Joints
from sailforce.synthetic import NoiseModel, recording

#: The issue's arm: three joints that are springs of different stiffness [N m/rad].
SPRINGS = Robot(joints=Joints("spring", 50.0, P1=Joint("spring", 80.0), P2=Joint("spring", 300.0), P3=Joint("spring", 40.0)))
#: The issue's agreement of the predicted uncertainty with the simulated spread.
HONEST_RTOL = 0.2
#: The issue's extrapolation bounds: the worst error over the map against the worst inside the planned deltas, and
#: against the noise-floor oracle.
EXTRAPOLATION, OVER_FLOOR = 3.0, 1.5
#: Monte Carlo draws for the noise floor, and its agreement (the RMS of 4e4 draws: 0.35 % one sigma).
FLOOR_DRAWS, FLOOR_RTOL = 40_000, 0.015


def _inside(plan) -> np.ndarray:
    """The map's points (deltas x directions) inside the planned deltas."""
    delta = np.repeat(map_deltas(), MAP_DIRECTIONS)
    low, high = plan.rig.delta_range
    return (delta >= low - 1e-9) & (delta <= high + 1e-9)


def test_a_hold_lasts_the_filters_settling_the_pause_and_its_conversions():
    # HX711 at 80 SPS: sinc^4 settles in 4 periods (50 ms, its datasheet), then 1 s still, then 10 x 12.5 ms
    assert hold_time(adc_model("hx711-80"), 10) == pytest.approx(0.05 + 1.0 + 0.125)
    assert hold_time(adc_model("hx711-10"), 10) == pytest.approx(0.4 + 1.0 + 1.0)
    plan = plan_calibration(Robot(), "matrix", holds=12, adc="hx711-80")
    assert plan.conversions.sum() == 12 * plan.conversions_per_hold  # a hold chosen k times is one k times as long
    np.testing.assert_allclose(plan.hold_s, [hold_time(plan.adc, int(c)) for c in plan.conversions])


def test_a_linear_models_predicted_error_is_each_calibrations_error():
    """The matrix model is linear in its parameters: beyond its own bias, each noise draw's fitted calibration errs
    as the linearised model says, to first order in the error (measured: 0.5 % apart, the error being 0.6 % of the
    force), so the regressor and the covariance are the fitter's."""
    plan = plan_calibration(Robot(), "matrix", holds=16, adc="hx711-80")
    fitted, linear = simulated_errors(plan, draws=5, seed=3)
    # the series' own bias (the frame's map is not exactly a cubic in delta): the same fit with no noise
    quiet = replace(plan, holds=replace(plan.holds, sigma=plan.holds.sigma * 1e-9))
    bias = simulated_errors(quiet, draws=1, seed=3)[0]
    # what remains is second order, dM dF: as large, relative to the error, as the error is relative to the force
    second_order = 3.0 * np.sqrt(np.mean(linear**2)) / plan.predicted.force_N
    assert np.sqrt(np.mean((fitted - bias - linear) ** 2)) <= second_order * np.sqrt(np.mean(linear**2))


def test_the_predicted_error_matches_the_spread_of_simulated_calibrations():
    """300 noise draws of the matrix plan, each fitted: the spread at every delta of the planned range, and averaged
    over the whole map, within 20 % of the prediction."""
    plan = plan_calibration(Robot(), "matrix", holds=24, adc="hx711-80")
    simulated = as_map(simulated_errors(plan, draws=300, seed=1)[0], plan.predicted.force_N)
    inside = _inside(plan)[::MAP_DIRECTIONS]
    ratio = simulated.rms_N[inside] / plan.predicted.rms_N[inside]
    assert np.all(np.abs(ratio - 1.0) <= HONEST_RTOL), ratio
    overall = math.sqrt(np.mean(simulated.rms_N**2) / np.mean(plan.predicted.rms_N**2))
    assert abs(overall - 1.0) <= HONEST_RTOL


@pytest.fixture(scope="module")
def springs_plan():
    """The issue's plan: 24 holds over delta = 30..120 deg on the three-spring arm, HX711 at 80 SPS."""
    return plan_calibration(SPRINGS, "physics", holds=24, adc="hx711-80")


@pytest.fixture(scope="module")
def springs_draws(springs_plan):
    """Six noise draws of that plan, each fitted as ``sail calibrate --model physics`` would: (fitted, linearised)."""
    return simulated_errors(springs_plan, draws=6, seed=2)


def test_the_physics_prediction_holds_over_the_planned_deltas(springs_plan, springs_draws):
    """The three springs' fitted stiffnesses are uncertain by factors (their logs' standard errors are 0.6-5), so
    the fit is not linear in them.  Over the same noise draws, the fitted calibrations' error spread matches the
    linearised model's within 20 % at every delta of the planned range and over the whole map (measured: 0.89-1.05
    from 25 to 155 deg, and 0.74-0.79 at 15 and 165 deg, where the prediction is conservative)."""
    plan = springs_plan
    fitted, linear = springs_draws
    by_delta = lambda e: np.mean(np.sum(e**2, -1), 0).reshape(-1, MAP_DIRECTIONS).mean(axis=1)
    ratio = np.sqrt(by_delta(fitted) / by_delta(linear))
    inside = _inside(plan)[::MAP_DIRECTIONS]
    assert np.all(np.abs(ratio[inside] - 1.0) <= HONEST_RTOL), ratio[inside]
    overall = math.sqrt(np.mean(fitted**2) / np.mean(linear**2))
    assert overall <= 1.0 + HONEST_RTOL, overall


def test_the_plan_beats_the_seeds_grid_and_a_uniform_grid_of_as_many_holds(springs_plan):
    """The issue's target on the three-spring arm: a predicted worst force error over delta = 15..165 deg at most
    0.9 of the seed's grid's (theta2 = 0, forces every 45 deg) and at most a uniform grid's, 24 holds each."""
    plan = springs_plan
    assert len(plan.seed_holds) == len(plan.uniform_holds) == 24
    assert np.all(plan.seed_holds.theta2 == 0.0)
    directions = np.degrees(np.arctan2(plan.seed_holds.fy, plan.seed_holds.fx)) % 360.0
    np.testing.assert_allclose(np.round(directions / 45.0) * 45.0, directions, atol=1e-9)
    worst = plan.predicted.worst_N.max()
    assert worst <= 0.9 * plan.seed_grid.worst_N.max()
    assert worst <= plan.uniform.worst_N.max()
    low, high = plan.rig.delta_range
    delta = plan.holds.theta1 - plan.holds.theta2
    assert np.all((delta >= low - 1e-12) & (delta <= high + 1e-12))  # only what the rig can hold


def test_the_noise_floor_is_one_conversions_noise_through_the_frames_own_map(springs_plan):
    """The noise-floor oracle (an exactly calibrated arm): Monte Carlo noise on both cells, one HX711 conversion's
    (the cell's and the ADC's in quadrature), solved through the frame model's map (unit forces through
    :func:`sailforce.synthetic.recording`, not the planner's linearisation), at every delta of the map."""
    plan = springs_plan
    delta = map_deltas()
    quiet = NoiseModel(noise_fraction=0.0, quantize=False)
    zero = np.zeros_like(delta)
    columns = [recording(SPRINGS, delta, zero, fx, fy, noise=quiet, offsets=np.zeros(2))[0] for fx, fy in ((1, 0), (0, 1))]
    m = np.stack(columns, axis=-1)  # (deltas, cell, force) counts per N
    sigma = noise_counts(SPRINGS, adc_model("hx711-80"), NoiseModel())
    noise = np.random.default_rng(7).normal(0.0, sigma, (FLOOR_DRAWS, delta.size, 2))
    error = np.linalg.solve(m[None], noise[..., None])[..., 0]
    floor = np.sqrt(np.mean(np.sum(error**2, axis=-1), axis=0))
    np.testing.assert_allclose(plan.floor_N, floor, rtol=FLOOR_RTOL)


def test_beyond_the_planned_deltas_the_force_error_stays_near_the_noise_floor(springs_plan, springs_draws):
    """The issue's extrapolation target, on the force error a lab sees at run time (the calibration's and one
    conversion's noise): over delta = 15..165 deg the worst is at most 3 times the worst inside the planned 30..120
    and at most 1.5 times the noise-floor oracle's at every delta, predicted and from the six fitted calibrations.
    (The calibration's own error grows about fivefold beyond the range: measured 4.98, and a minimax design of the
    same holds 5.13; docs/guide/calibrate.md.)"""
    plan = springs_plan
    simulated = as_map(springs_draws[0], plan.predicted.force_N)
    for calibration in (plan.predicted, simulated):
        seen = plan.seen(calibration)
        assert plan.extrapolation(seen) <= EXTRAPOLATION, plan.extrapolation(seen)
        assert np.all(seen.worst_N <= OVER_FLOOR * plan.floor_N), np.max(seen.worst_N / plan.floor_N)
        assert plan.over_floor(calibration) == pytest.approx(np.max(seen.worst_N / plan.floor_N))
    # the floor is what makes it hold: the calibration's own error is a fraction of it, more so inside the range
    inside = np.isin(map_deltas(), map_deltas()[_inside(plan)[::MAP_DIRECTIONS]])
    assert np.all(plan.predicted.worst_N < plan.floor_N)
    assert np.max(plan.predicted.worst_N[inside] / plan.floor_N[inside]) < np.max(plan.predicted.worst_N / plan.floor_N)


def test_each_poses_holds_come_together():
    rig = Rig(theta2=(0.0, math.radians(20.0)))
    plan = plan_calibration(SPRINGS, "physics", holds=30, rig=rig, adc="hx711-80")
    poses = [(round(a, 9), round(b, 9)) for a, b in zip(plan.holds.theta1, plan.holds.theta2)]
    runs = [p for k, p in enumerate(poses) if k == 0 or p != poses[k - 1]]
    assert len(runs) == len(set(poses))  # no pose is visited twice


@pytest.mark.parametrize("kwargs, message", [
    ({"model": "spline"}, "unknown calibration model"),
    ({"model": "matrix", "free": ["joints.P1.stiffness"]}, "--free is for the physics model"),
    ({"free": ["plane.tilt_deg"]}, "cannot be identified from static measurements"),
    ({"rig": Rig(masses_kg=(500.0,))}, "beyond 80% of its rated output"),
    ({"adc": "ideal"}, "the ideal ADC has no conversions"),
    ({"holds": 0}, "at least one hold"),
    ({"model": "matrix", "order": 8, "holds": 3}, "cannot determine"),
])  # fmt: skip
def test_bad_plans_are_refused_with_the_reason(kwargs, message):
    args = {"model": "physics", **kwargs}
    with pytest.raises(InputError, match=message):
        plan_calibration(Robot(), args.pop("model"), **args)


def test_a_rig_that_cannot_be_is_refused():
    with pytest.raises(InputError, match="inside 0..180 deg"):
        Rig(delta_range=(math.radians(30.0), math.radians(190.0)))
    with pytest.raises(InputError, match="masses must be positive"):
        Rig(masses_kg=(-1.0,))


def test_the_command_writes_the_protocol_its_checklist_and_the_maps(tmp_path):
    out = tmp_path / "plan"
    result = CliRunner().invoke(cli, ["plan-calibration", "--holds", "12", "--masses-kg", "1,2", "--adc", "hx711-80",
                                      "-q", "-o", str(out)])  # fmt: skip
    assert result.exit_code == 0, result.output
    head = (out / "plan.csv").read_text().splitlines()[0].split(",")
    assert {"theta1_deg", "theta2_deg", "fx_N", "fy_N", "hold_s"} <= set(head)
    table = np.genfromtxt(out / "plan.csv", delimiter=",", names=True)
    summary = json.loads((out / "plan.json").read_text())
    assert summary["budget_holds"] == 12 and table.size == summary["holds"]
    assert table["conversions"].sum() == 12 * summary["conversions_per_hold"]
    np.testing.assert_allclose(np.hypot(table["fx_N"], table["fy_N"]) / 9.80665, table["mass_kg"])
    np.testing.assert_allclose(table["start_s"][1:], np.cumsum(table["hold_s"])[:-1])
    assert summary["errors"]["plan"]["worst_N"] <= summary["errors"]["seed_grid"]["worst_N"]
    checklist = (out / "checklist.md").read_text()
    assert checklist.count("| ☐ |") == table.size
    predicted = np.genfromtxt(out / "predicted.csv", delimiter=",", names=True)
    assert predicted.size == map_deltas().size and (out / "plan.png").stat().st_size > 10_000


def test_the_command_says_what_is_wrong(tmp_path):
    result = CliRunner().invoke(cli, ["plan-calibration", "--masses-kg", "heavy", "-o", str(tmp_path)])
    assert result.exit_code == 2 and "expected masses in kg" in result.output
    result = CliRunner().invoke(cli, ["plan-calibration", "--delta-range", "30:200", "-o", str(tmp_path)])
    assert result.exit_code == 2 and "inside 0..180 deg" in result.output
    assert "Traceback" not in result.output
