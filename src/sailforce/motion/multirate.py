"""A simulated rig with real ADCs: the plant integrated finely, each cell converting on its own clock, encoders at the tick.

The recording is in the **multi-rate format** (docs/reference/multirate.md):
one row per control tick with ``t_s, theta1_deg, theta2_deg``; ``load1`` and
``load2`` only on the first tick at or after that cell's conversion became
ready (empty on the others); ``load1_t_s``, ``load2_t_s`` the conversions'
data-ready instants.  Two conversions of one cell that become ready within
one tick keep the newer (the firmware reads the register once a tick).

The plant (the links' inertia, gravity and the hand's force, seed-style
shears of :mod:`sailforce.motion.dynamics`) is sampled at
``plant_rate_hz`` (>= :data:`sailforce.adc.conversions.MIN_PLANT_RATE_HZ`);
a conversion is its filter's average of the cell's counts over its window
(:func:`sailforce.adc.conversions.filtered_at`), plus the cell's noise of
:class:`sailforce.synthetic.NoiseModel` and the ADC's input noise, in
quadrature, then rounded to whole counts.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..adc import ADC
from ..adc.conversions import MIN_PLANT_RATE_HZ, Clock, clocks, filtered_at
from ..errors import InputError
from ..kinematics import forward
from ..robot import Robot
from ..synthetic import HX711_COUNTS_PER_MV_V, NoiseModel
from .reaching import JointMotion, cell_counts, reaching


@dataclass(frozen=True)
class Conversions:
    """One cell's conversions: data-ready instants [s] and raw readings [counts], and the tick each lands on."""

    times: np.ndarray
    readings: np.ndarray
    tick: np.ndarray  #: index of the first tick at or after each conversion
    clock: Clock
    overwritten: int  #: conversions lost because a newer one became ready within the same tick


@dataclass(frozen=True)
class MultiRateRecording:
    """What the lab records, in the multi-rate format, and the truth behind it."""

    t: np.ndarray  #: ``(n,)`` control ticks [s]
    theta: np.ndarray  #: ``(n, 2)`` encoder angles [rad], quantized
    loads: np.ndarray  #: ``(n, 2)`` raw counts on the ticks a conversion lands on, NaN elsewhere
    load_t: np.ndarray  #: ``(n, 2)`` those conversions' data-ready instants [s], NaN elsewhere
    force: np.ndarray  #: ``(n, 2)`` the hand's true force at each tick [N]
    cells: tuple[Conversions, Conversions]
    motion: JointMotion  #: the true joint states at the plant's rate
    offsets: np.ndarray  #: ``(2,)`` the cells' zero offsets [counts]
    gain: float  #: counts per newton of shear
    adc: ADC


def multirate_columns(recording: MultiRateRecording | HoldRecording,
                      force: tuple[str, str] | None = ("true_fx_N", "true_fy_N")) -> dict[str, np.ndarray]:
    """A recording as the multi-rate format's columns (docs/reference/multirate.md): ``t_s``, the angles [deg], the
    conversions and their data-ready times, and the force under the names ``force`` (None: without it)."""
    columns = {"t_s": recording.t, "theta1_deg": np.degrees(recording.theta[:, 0]),
               "theta2_deg": np.degrees(recording.theta[:, 1]), "load1": recording.loads[:, 0],
               "load2": recording.loads[:, 1], "load1_t_s": recording.load_t[:, 0], "load2_t_s": recording.load_t[:, 1]}  # fmt: skip
    if force is not None:
        columns |= {force[0]: recording.force[:, 0], force[1]: recording.force[:, 1]}
    return columns


def noise_counts(robot: Robot, adc: ADC, noise: NoiseModel) -> float:
    """The 1-sigma noise of one conversion [counts]: the cell's (:class:`NoiseModel`) and the ADC's, in quadrature."""
    rated = robot.loadcell.rated_output_mV_V * HX711_COUNTS_PER_MV_V
    return float(np.hypot(noise.noise_fraction * rated, adc.noise_mV_V * HX711_COUNTS_PER_MV_V))


def convert(adc: ADC, clock: Clock, t_fine: np.ndarray, counts: np.ndarray, ticks: np.ndarray, sigma: float,
            rng: np.random.Generator, quantize: bool) -> Conversions:  # fmt: skip
    """The conversions of one cell's ``counts`` (sampled at ``t_fine``) whose windows lie in the recording."""
    chip = replace(adc, rate_Hz=clock.rate_Hz)  # the chip's own clock sets its window too
    times = clock.times(t_fine[0] + chip.settling_s, min(t_fine[-1], ticks[-1]))
    readings = filtered_at(chip, t_fine, counts, times) + rng.normal(0.0, sigma, times.size)
    if quantize:
        readings = np.round(readings)
    tick = np.searchsorted(ticks, times - 1e-12, side="left")
    keep = np.append(tick[1:] != tick[:-1], True)  # the newest of several ready within one tick
    return Conversions(times[keep], readings[keep], tick[keep], clock, int((~keep).sum()))


def on_ticks(n: int, cells: tuple[Conversions, Conversions]) -> tuple[np.ndarray, np.ndarray]:
    """``(n, 2)`` loads and data-ready instants on the ticks each conversion lands on, NaN elsewhere."""
    loads, load_t = np.full((n, 2), np.nan), np.full((n, 2), np.nan)
    for i, cell in enumerate(cells):
        loads[cell.tick, i] = cell.readings
        load_t[cell.tick, i] = cell.times
    return loads, load_t


#: A hand does not step its force: the pull toward a new target rises over this long [s] (a minimum-jerk blend).
HAND_RISE_S = 0.1


def hand_anchor(t: np.ndarray, target: np.ndarray, rise_s: float) -> np.ndarray:
    """The point the hand pulls toward ``(n, 2)``: each new target blended in from the last over ``rise_s`` [s]."""
    anchor = np.array(target, dtype=float)
    changes = np.flatnonzero(np.any(np.diff(target, axis=0) != 0, axis=1)) + 1
    for k in changes:
        s = np.clip((t[k:] - t[k]) / rise_s, 0.0, 1.0)[:, None] if rise_s > 0 else np.ones((t.size - k, 1))
        blend = 10 * s**3 - 15 * s**4 + 6 * s**5
        anchor[k:] = target[k - 1] + (target[k:] - target[k - 1]) * blend
        anchor[k:][s[:, 0] >= 1.0] = target[k:][s[:, 0] >= 1.0]
    return anchor


def record_multirate(robot: Robot, adc: ADC, *, reach: float = 0.3, reaches: int = 8, peak_speed: float = 0.75,
                     dwell: float = 0.3, hand_stiffness: float = 0.0, hand_rise_s: float = HAND_RISE_S,
                     control_rate_hz: float = 1000.0,
                     plant_rate_hz: float = MIN_PLANT_RATE_HZ, noise: NoiseModel = NoiseModel(),
                     counts_per_rev: int = 1 << 16, seed: int = 0, offsets=None) -> MultiRateRecording:  # fmt: skip
    """Reaching movements recorded through ``adc`` (module docstring).

    The hand pulls toward the current reach's end point with ``hand_stiffness``
    [N/m] as in :func:`~sailforce.motion.reaching.record`, except that a new
    target's pull rises over ``hand_rise_s`` (:func:`hand_anchor`): a filtered
    ADC cannot follow a step, and no hand makes one.
    """
    if adc.ideal:
        raise InputError("the ideal ADC reads at every tick: record it with sailforce.motion.reaching.record")
    ratio = plant_rate_hz / control_rate_hz
    if plant_rate_hz < MIN_PLANT_RATE_HZ or abs(ratio - round(ratio)) > 1e-9:
        raise InputError(f"the plant's rate {plant_rate_hz:g} Hz must be at least {MIN_PLANT_RATE_HZ:g} Hz and a whole "
                         f"multiple of the control rate {control_rate_hz:g} Hz")  # fmt: skip
    rng = np.random.default_rng(seed)
    motion = reaching(robot, reach=reach, reaches=reaches, peak_speed=peak_speed, dwell=dwell, sample_rate_hz=plant_rate_hz)
    anchor = hand_anchor(motion.t, motion.target, hand_rise_s)
    force = hand_stiffness * (anchor - np.column_stack(forward(robot.arm, motion.q[:, 0], motion.q[:, 1])))
    counts, offsets, gain = cell_counts(robot, motion, force, offsets, rng, noise)
    step = int(round(ratio))
    ticks = slice(0, None, step)
    t = motion.t[ticks]
    sigma = noise_counts(robot, adc, noise)
    cells = tuple(convert(adc, clock, motion.t, counts[:, i], t, sigma, rng, noise.quantize)
                  for i, clock in enumerate(clocks(adc, rng)))  # fmt: skip
    loads, load_t = on_ticks(t.size, cells)  # type: ignore[arg-type]
    angle_step = 2 * np.pi / counts_per_rev
    theta = np.round(motion.q[ticks] / angle_step) * angle_step
    return MultiRateRecording(t, theta, loads, load_t, force[ticks], cells, motion,  # type: ignore[arg-type]
                              np.asarray(offsets, float), gain, adc)  # fmt: skip


#: How long each pulley-and-weights hold lasts by default [s]: the slowest preset settles in 0.4 s, and a
#: person needs a moment to hang the next weight.
HOLD_S = 1.0


@dataclass(frozen=True)
class HoldRecording:
    """A pulley-and-weights session through an ADC: held poses and forces, in the multi-rate format."""

    t: np.ndarray  #: ``(n,)`` control ticks [s]
    theta: np.ndarray  #: ``(n, 2)`` encoder angles [rad] (constant within a hold)
    force: np.ndarray  #: ``(n, 2)`` the applied force [N] (constant within a hold)
    loads: np.ndarray  #: ``(n, 2)`` conversions on the ticks they land on, NaN elsewhere
    load_t: np.ndarray  #: ``(n, 2)`` their data-ready instants [s]
    cells: tuple[Conversions, Conversions]
    offsets: np.ndarray


def record_holds(robot: Robot, adc: ADC, theta1, theta2, fx, fy, *, hold_s: float = HOLD_S, control_rate_hz: float = 1000.0,
                 plant_rate_hz: float = MIN_PLANT_RATE_HZ, noise: NoiseModel = NoiseModel(), counts_per_rev: int = 1 << 16,
                 seed: int = 0, offsets=None) -> HoldRecording:  # fmt: skip
    """Each (pose, force) held for ``hold_s`` in turn, the arm stepping between them, recorded through ``adc``.

    A conversion whose window straddles a step mixes two holds: the calibration
    keeps only those whose whole window lies inside one hold.
    """
    from ..synthetic import recording

    if adc.ideal:
        raise InputError("the ideal ADC reads at every tick: a static session without an ADC has no time")
    theta1, theta2, fx, fy = np.broadcast_arrays(*(np.asarray(a, float) for a in (theta1, theta2, fx, fy)))
    rng = np.random.default_rng(seed)
    clean = recording(robot, theta1, theta2, fx, fy, noise=replace(noise, noise_fraction=0.0, quantize=False), seed=seed,
                      offsets=offsets)  # fmt: skip
    counts, offsets = clean[2], clean[1]
    step = int(round(plant_rate_hz / control_rate_hz))
    fine_t = np.arange(int(round(theta1.size * hold_s * plant_rate_hz))) / plant_rate_hz
    hold = np.minimum((fine_t / hold_s).astype(int), theta1.size - 1)
    t = fine_t[::step]
    sigma = noise_counts(robot, adc, noise)
    cells = tuple(convert(adc, clock, fine_t, counts[hold, i], t, sigma, rng, noise.quantize)
                  for i, clock in enumerate(clocks(adc, rng)))  # fmt: skip
    loads, load_t = on_ticks(t.size, cells)  # type: ignore[arg-type]
    angle_step = 2 * np.pi / counts_per_rev
    tick_hold = hold[::step]
    theta = np.round(np.column_stack([theta1, theta2])[tick_hold] / angle_step) * angle_step
    return HoldRecording(t, theta, np.column_stack([fx, fy])[tick_hold], loads, load_t, cells, offsets)  # type: ignore[arg-type]
