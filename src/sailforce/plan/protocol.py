"""A calibration protocol for a real rig: its candidate holds, the optimal ones in a short order, and the baselines.

A *hold* is a pose with a weight of a known mass hung over a pulley in one
direction, kept still until the ADC has given :data:`DEFAULT_CONVERSIONS`
settled conversions.  Its hold time is the ADC's settling (its filter
refills after the move, :attr:`sailforce.adc.ADC.settling_s`), a
:data:`STILL_S` pause for the weight to stop swinging, and the conversions;
its reading noise is one conversion's (:func:`sailforce.motion.multirate.noise_counts`:
the cell's and the ADC's in quadrature) over the root of their number.

The plan is compared with two protocols of the same number of holds, at the
largest mass every one of their holds can take:

- **the seed's grid** reduced evenly: theta2 = 0, deltas evenly over the
  rig's range, forces every 45 deg (the seed's protocol, Sec. III);
- **a uniform grid**: the same deltas, more of them, with forces every 90 deg.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..adc import ADC, adc_model
from ..errors import InputError
from ..loadcell import STANDARD_GRAVITY
from ..motion.multirate import noise_counts
from ..robot import Robot
from ..synthetic import HX711_COUNTS_PER_MV_V, NoiseModel
from .design import DEFAULT_FORCE_N, Candidates, ErrorMap, noise_floor, optimal_holds, predicted_map, seen_map
from .linear import Linearised, linearise

#: Settled conversions averaged in each hold.
DEFAULT_CONVERSIONS = 10
#: The pause after a weight is hung, for it and the arm to come to rest [s].
STILL_S = 1.0
#: The ADC a plan is made for when the robot file has the ideal one (no conversions, no settling): the sketch's chip.
FALLBACK_ADC = "hx711-10"
#: A hold may load a cell up to this fraction of its rated output.
CAPACITY_USE = 0.8
#: The planned deltas' spacing among the candidates [deg].
DEFAULT_DELTA_STEP_DEG = 5.0
#: The seed grid's and the uniform grid's force directions [deg].
SEED_DIRECTIONS_DEG = tuple(range(0, 360, 45))
UNIFORM_DIRECTIONS_DEG = (0.0, 90.0, 180.0, 270.0)


@dataclass(frozen=True)
class Rig:
    """What the rig can do: the poses it can hold (deltas and theta2 [rad]), its pulleys' directions [rad] in the
    world frame, and the masses [kg] on the shelf."""

    delta_range: tuple[float, float] = (math.radians(30.0), math.radians(120.0))
    theta2: tuple[float, ...] = (0.0,)
    delta_step: float = math.radians(DEFAULT_DELTA_STEP_DEG)
    directions: tuple[float, ...] = tuple(math.radians(d) for d in SEED_DIRECTIONS_DEG)
    masses_kg: tuple[float, ...] = (0.5, 1.0, 2.0)

    def __post_init__(self) -> None:
        low, high = self.delta_range
        if not (0.0 < low < high < math.pi):
            raise InputError(f"the delta range {math.degrees(low):g}..{math.degrees(high):g} deg must lie inside "
                             "0..180 deg, low below high (delta = 0 and 180 deg are singular)")  # fmt: skip
        if not self.directions or not self.theta2:
            raise InputError("the rig needs at least one pulley direction and one theta2")
        if not self.masses_kg or min(self.masses_kg) <= 0:
            raise InputError(f"the masses must be positive, got {', '.join(f'{m:g}' for m in self.masses_kg)} kg")
        if not self.delta_step > 0:
            raise InputError("the deltas' step must be positive")

    def deltas(self) -> np.ndarray:
        low, high = self.delta_range
        count = max(2, int(round((high - low) / self.delta_step)) + 1)
        return np.linspace(low, high, count)


@dataclass(frozen=True)
class Plan:
    """An ordered calibration protocol, its predicted force error, and the baselines' (module docstring)."""

    holds: Candidates  #: in the order to make them (sigma: each hold's reading noise, its conversions averaged)
    hold_s: np.ndarray  #: each hold's time [s]
    conversions: np.ndarray  #: each hold's settled conversions
    budget: int  #: the holds asked for, of ``conversions_per_hold`` each; the baselines have as many
    conversions_per_hold: int
    adc: ADC
    model: Linearised
    rig: Rig
    predicted: ErrorMap
    seed_grid: ErrorMap
    uniform: ErrorMap
    seed_holds: Candidates
    uniform_holds: Candidates
    floor_N: np.ndarray  #: the noise-floor oracle at the map's deltas [N]: one run-time conversion's noise, exact map
    notes: tuple[str, ...] = field(default=())

    def seen(self, calibration: ErrorMap) -> ErrorMap:
        """``calibration``'s error as seen at run time: with one conversion's noise (:func:`~.design.seen_map`)."""
        return seen_map(calibration, self.floor_N)

    @property
    def floor(self) -> ErrorMap:
        """The noise-floor oracle as a map (the same error in every direction)."""
        return ErrorMap(self.predicted.delta, self.floor_N, self.floor_N, self.predicted.force_N)

    def extrapolation(self, calibration: ErrorMap) -> float:
        """How much worse the worst error over the whole map is than over the planned deltas."""
        return float(calibration.worst_N.max()) / calibration.worst_within(*self.rig.delta_range)

    def over_floor(self, calibration: ErrorMap) -> float:
        """The seen error against the noise-floor oracle, worst over the map's deltas."""
        return float(np.max(self.seen(calibration).worst_N / self.floor_N))

    @property
    def total_s(self) -> float:
        """The holds' time, moves excluded [s]."""
        return float(np.sum(self.hold_s))


def hold_time(adc: ADC, conversions: int = DEFAULT_CONVERSIONS) -> float:
    """A hold's time [s]: the filter's settling, :data:`STILL_S`, and ``conversions`` periods."""
    return adc.settling_s + STILL_S + conversions * adc.period_s


def reading_noise(robot: Robot, adc: ADC, conversions: int = DEFAULT_CONVERSIONS) -> float:
    """A hold's reading noise [counts], 1 sigma: one conversion's over sqrt(conversions)."""
    return noise_counts(robot, adc, NoiseModel()) / math.sqrt(conversions)


def _within_capacity(model: Linearised, holds: Candidates) -> np.ndarray:
    """Whether each hold keeps both cells within :data:`CAPACITY_USE` of their rated output."""
    signal = (model.sensing(holds.theta1, holds.theta2) @ np.stack([holds.fx, holds.fy], axis=-1)[..., None])[..., 0]
    rated = model.robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    return np.all(np.abs(signal) <= CAPACITY_USE * rated, axis=1)


def _holds(delta, theta2, direction, mass, sigma: float) -> Candidates:
    delta, theta2, direction, mass = (np.asarray(a, float) for a in np.broadcast_arrays(delta, theta2, direction, mass))
    force = mass * STANDARD_GRAVITY
    return Candidates(delta + theta2, theta2.copy(), force * np.cos(direction), force * np.sin(direction), mass,
                      np.full(delta.shape, sigma))  # fmt: skip


def candidates(model: Linearised, rig: Rig, sigma: float) -> Candidates:
    """Every hold the rig can make within the cells' capacity: deltas x theta2 x directions x masses."""
    d, t2, u, m = (a.ravel() for a in np.meshgrid(rig.deltas(), rig.theta2, rig.directions, rig.masses_kg, indexing="ij"))
    every = _holds(d, t2, u, m, sigma)
    fits = _within_capacity(model, every)
    if not fits.any():
        raise InputError(f"every mass ({', '.join(f'{m:g}' for m in rig.masses_kg)} kg) loads a cell beyond "
                         f"{CAPACITY_USE:.0%} of its rated output: use lighter masses")  # fmt: skip
    return every.take(np.flatnonzero(fits))


def _grid(model: Linearised, rig: Rig, n: int, directions_deg: Sequence[float], sigma: float) -> Candidates:
    """``n`` holds taken evenly from deltas x directions (theta2 = the rig's first), at the largest mass that fits."""
    poses = max(2, math.ceil(n / len(directions_deg)))
    low, high = rig.delta_range
    d, u = (a.ravel() for a in np.meshgrid(np.linspace(low, high, poses), np.radians(directions_deg), indexing="ij"))
    keep = np.unique(np.round(np.linspace(0, d.size - 1, n)).astype(int)) if n < d.size else np.arange(d.size)
    for mass in sorted(rig.masses_kg, reverse=True):
        grid = _holds(d[keep], rig.theta2[0], u[keep], mass, sigma)
        if _within_capacity(model, grid).all():
            return grid
    raise InputError("no mass on the shelf keeps every hold of the baseline grids within the cells' capacity")


def seed_grid(model: Linearised, rig: Rig, n: int, sigma: float) -> Candidates:
    """The seed's grid (theta2 = 0, forces every 45 deg) reduced evenly to ``n`` holds."""
    return _grid(model, Rig(rig.delta_range, (0.0,), rig.delta_step, rig.directions, rig.masses_kg), n,
                 SEED_DIRECTIONS_DEG, sigma)  # fmt: skip


def uniform_grid(model: Linearised, rig: Rig, n: int, sigma: float) -> Candidates:
    """``n`` holds on a uniform grid: deltas evenly over the range, forces every 90 deg."""
    return _grid(model, rig, n, UNIFORM_DIRECTIONS_DEG, sigma)


def in_short_order(holds: Candidates) -> Candidates:
    """The holds with each pose's together, the poses in a nearest-neighbour tour from the lowest theta1, and at one
    pose by direction, then mass: the arm moves little, and the weights are swapped at one pulley at a time."""
    poses, pose_of = np.unique(np.round(np.column_stack([holds.theta1, holds.theta2]), 12), axis=0, return_inverse=True)
    pose_of = pose_of.ravel()
    left = list(range(len(poses)))
    tour = [min(left, key=lambda i: (poses[i, 0], poses[i, 1]))]
    left.remove(tour[0])
    while left:
        here = poses[tour[-1]]
        nearest = min(left, key=lambda i: float(np.max(np.abs(poses[i] - here))))  # the slower joint sets the move
        tour.append(nearest)
        left.remove(nearest)
    direction = np.mod(np.arctan2(holds.fy, holds.fx), 2.0 * np.pi)
    rank = {pose: k for k, pose in enumerate(tour)}
    order = sorted(range(len(holds)), key=lambda h: (rank[int(pose_of[h])], round(float(direction[h]), 9), holds.mass_kg[h]))
    return holds.take(order)


def plan_calibration(robot: Robot, model: str = "physics", *, holds: int = 24, free: Sequence[str] | None = None,
                     order: int | None = None, rig: Rig = Rig(), adc: ADC | str | None = None,
                     conversions: int = DEFAULT_CONVERSIONS, force_N: float = DEFAULT_FORCE_N,
                     progress=None) -> Plan:  # fmt: skip
    """An I-optimal calibration protocol of ``holds`` holds for ``robot`` (module docstring; :mod:`sailforce.plan.design`).

    ``adc``: the ADC to plan for (a preset name or an :class:`~sailforce.adc.ADC`); default the robot file's,
    or :data:`FALLBACK_ADC` when that is the ideal one.
    """
    notes = []
    if isinstance(adc, str):
        adc = adc_model(adc)
    if adc is None:
        adc = robot.adc
        if adc.ideal:
            adc = adc_model(FALLBACK_ADC)
            notes.append(f"the robot file has the ideal ADC: the plan is for an {FALLBACK_ADC} (choose with --adc)")
    if adc.ideal:
        raise InputError("the ideal ADC has no conversions to hold for: plan for a real one (--adc hx711-10, say)")
    if conversions < 1:
        raise InputError(f"a hold needs at least one settled conversion, got {conversions}")
    if holds < 1:
        raise InputError(f"a plan needs at least one hold, got {holds}")
    linear = linearise(robot, model, free=free, order=order, delta_range=rig.delta_range)
    sigma = reading_noise(linear.robot, adc, conversions)
    pool = candidates(linear, rig, sigma)
    picked, repeats = np.unique(optimal_holds(linear, pool, holds, force_N, progress=progress), return_counts=True)
    merged = pool.take(picked)  # a candidate chosen k times: one hold of k times the conversions
    merged = Candidates(merged.theta1, merged.theta2, merged.fx, merged.fy, merged.mass_kg,
                        merged.sigma / np.sqrt(repeats), repeats.astype(float))  # fmt: skip
    chosen = in_short_order(merged)
    counts = np.round(np.asarray(chosen.weight)).astype(int) * conversions
    seed, uniform = seed_grid(linear, rig, holds, sigma), uniform_grid(linear, rig, holds, sigma)
    maps = []
    for name, protocol in (("the plan", chosen), ("the seed's grid", seed), ("the uniform grid", uniform)):
        try:
            maps.append(predicted_map(linear, protocol, force_N))
        except InputError as error:
            if protocol is chosen:
                raise
            notes.append(f"{name} cannot determine the model ({error}); its map is left out")
            maps.append(ErrorMap(maps[0].delta, np.full(maps[0].delta.shape, np.inf), np.full(maps[0].delta.shape, np.inf), force_N))
    return Plan(Candidates(chosen.theta1, chosen.theta2, chosen.fx, chosen.fy, chosen.mass_kg, chosen.sigma),
                np.array([hold_time(adc, int(c)) for c in counts]), counts, holds, conversions, adc, linear, rig,
                maps[0], maps[1], maps[2], seed, uniform, noise_floor(linear, reading_noise(linear.robot, adc, 1)),
                tuple(notes))  # fmt: skip
