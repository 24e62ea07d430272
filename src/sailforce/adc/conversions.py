"""What an ADC makes of a signal: conversions on each chip's own clock, each its filter's average of the input.

Each chip converts at ``rate (1 + e)`` with ``e`` within the datasheet's
tolerance and a phase of its own, so two chips drift apart; one two-channel
chip (``simultaneous``) converts both cells at the same instants.  A
conversion that becomes ready at ``t_k`` reads

    r_k = sum_j h(t_k - t_j) s(t_j) dt / sum_j h(t_k - t_j) dt      (the input sampled finely at t_j),

the filter's window (:meth:`sailforce.adc.ADC.weights`) over a finely sampled
input, plus the ADC's noise.  An ideal ADC reads the input at each control tick.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .models import ADC

#: The plant is integrated at least this fast [Hz] so that a window of the fastest preset holds many samples.
MIN_PLANT_RATE_HZ = 10_000.0


@dataclass(frozen=True)
class Clock:
    """One chip's conversion clock: conversion k is ready at ``phase_s + k / rate_Hz``."""

    rate_Hz: float
    phase_s: float

    def times(self, start: float, stop: float) -> np.ndarray:
        """The data-ready instants within [start, stop] [s]."""
        first = np.ceil((start - self.phase_s) * self.rate_Hz)
        last = np.floor((stop - self.phase_s) * self.rate_Hz)
        return self.phase_s + np.arange(first, last + 1) / self.rate_Hz


def clocks(adc: ADC, rng: np.random.Generator) -> tuple[Clock, Clock]:
    """The two cells' clocks: each chip within the rate tolerance and at a random phase; one clock if simultaneous."""
    if adc.ideal:
        raise InputError("the ideal ADC has no clock of its own: it reads at every control tick")
    rates = adc.rate_Hz * (1.0 + rng.uniform(-adc.rate_tolerance, adc.rate_tolerance, 2))
    phases = rng.uniform(0.0, 1.0, 2) / rates
    if adc.simultaneous:
        return Clock(float(rates[0]), float(phases[0])), Clock(float(rates[0]), float(phases[0]))
    return Clock(float(rates[0]), float(phases[0])), Clock(float(rates[1]), float(phases[1]))


def filtered_at(adc: ADC, t_fine: np.ndarray, signal: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The filter's output at conversion ``times`` [s] of ``signal`` ``(n, ...)`` sampled uniformly at ``t_fine``.

    Every window must lie inside ``t_fine``.  Without a filter the signal is
    interpolated linearly at ``times``.
    """
    signal = np.asarray(signal, dtype=float)
    dt = float(t_fine[1] - t_fine[0])
    if adc.sinc_order == 0:
        flat = signal.reshape(signal.shape[0], -1)
        return np.stack([np.interp(times, t_fine, column) for column in flat.T], axis=-1).reshape((times.size,) + signal.shape[1:])
    span = adc.settling_s
    if times.size and (times.min() - span < t_fine[0] - 1e-12 or times.max() > t_fine[-1] + 1e-12):
        raise InputError(f"a conversion's {span * 1e3:g} ms window reaches outside the signal's "
                         f"{t_fine[0]:g}..{t_fine[-1]:g} s")  # fmt: skip
    taps = int(np.ceil(span / dt)) + 2
    last = np.floor((times - t_fine[0]) / dt).astype(int)  # the fine sample at or before each conversion
    index = last[:, None] - np.arange(taps)[None, :]  # (m, taps), newest first
    valid = index >= 0
    index = np.clip(index, 0, signal.shape[0] - 1)
    weights = adc.weights(times[:, None] - t_fine[index]) * valid
    weights /= weights.sum(axis=1, keepdims=True)
    return np.einsum("mk,mk...->m...", weights, signal[index])
