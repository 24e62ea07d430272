"""How a cell's reading drifts over a session: temperature, creep and warm-up (docs/reference/drift.md).

A bridge load cell read by a 24-bit ADC reads, in counts,

    r = o + z(t) + (1 + s(t)) g V + c(t),

with ``o`` the offset at the calibration, ``g V`` the signal of the shear
``V``, and three slow terms:

- **zero drift with temperature**, ``z = a (T - T0) + w (1 - exp(-t / tau_w))``:
  the cell's temperature effect on zero (``zero_per_C``, a fraction of its
  rated output per degree) and the ADC's input offset drift
  (``adc_offset_V_per_C``, volts at the input per degree: 6 nV/°C for the
  HX711 at gain 128, Avia HX711 datasheet, "Temperature drift"), plus the
  warm-up after power-up (``warmup``, a fraction of rated output, reached
  with time constant ``warmup_time_s``);
- **span drift with temperature**, ``s = (b_cell + b_adc) (T - T0)``: the
  cell's temperature effect on span and the ADC's gain drift (5 ppm/°C for
  the HX711);
- **creep** under load, ``c``: the reading of a constant load grows by
  ``creep`` of it over 30 minutes (the datasheets' "creep (30 min)"), a
  first-order lag ``tau dc/dt = k g V - c`` with ``k = creep / (1 -
  exp(-1800 / tau))``, and recovers when the load goes.

The cell-side defaults are those of a cheap aluminium bar cell's datasheet
(TAL220 class: zero and span 0.05 % of rated output per 10 °C, creep 0.05 %
in 30 min); each is a field to set from the lab's own.  The signs of each
cell's coefficients are its own (:func:`cell_signs`): two cells do not
drift together.

The temperature follows :class:`TemperatureProfile`: the cells and the board
warm up by ``rise_C`` with time constant ``rise_time_s`` after power-up,
and the room drifts by ``ramp_C_per_h``.

**Compensation.**  With a ``temperature_C`` column, a calibration whose data
span at least :data:`MIN_TEMPERATURE_SPAN_C` identifies each cell's zero and
span coefficients (:func:`fit_temperature`) and the estimate undoes them
(:meth:`TemperatureCompensation.corrected`):

    r' = o + (r - o - a (T - T_ref)) / (1 + b (T - T_ref)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError

#: Creep is specified over this long [s] (OIML R60's and the datasheets' 30 minutes).
CREEP_SPAN_S = 1800.0
#: The HX711's full-scale input at gain 128 and 5 V excitation: +-20 mV over +-2^23 counts (Avia HX711 datasheet).
HX711_COUNTS_PER_V = 2**23 / 0.020


@dataclass(frozen=True)
class Drift:
    """One cell's slow terms (see the module docstring); fractions of the cell's rated output unless named."""

    zero_per_C: float = 5e-5  #: the cell's temperature effect on zero [rated output / °C]
    span_per_C: float = 5e-5  #: the cell's temperature effect on span [1 / °C]
    adc_offset_V_per_C: float = 6e-9  #: the ADC's input offset drift [V / °C]
    adc_gain_per_C: float = 5e-6  #: the ADC's gain drift [1 / °C]
    creep: float = 5e-4  #: a constant load's reading grows by this fraction of it in 30 min
    creep_time_s: float = 600.0  #: creep's time constant [s]
    warmup: float = 3e-4  #: the zero's shift as the cell and board warm up [rated output]
    warmup_time_s: float = 600.0  #: its time constant [s]

    def __post_init__(self) -> None:
        if not (self.creep_time_s > 0 and self.warmup_time_s > 0):
            raise InputError(f"drift time constants must be positive: {self}")

    @classmethod
    def none(cls) -> Drift:
        """No drift at all: the reference session."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 600.0, 0.0, 600.0)


@dataclass(frozen=True)
class TemperatureProfile:
    """The cells' temperature over a session [°C]: a warm-up after power-up and the room's slow drift."""

    start_C: float = 22.0
    rise_C: float = 4.0  #: the cells and board warm up by this much
    rise_time_s: float = 900.0
    ramp_C_per_h: float = 1.0  #: the room

    def at(self, t) -> np.ndarray:
        t = np.asarray(t, float)
        return self.start_C + self.rise_C * (1.0 - np.exp(-t / self.rise_time_s)) + self.ramp_C_per_h * t / 3600.0


#: Calibration data must span at least this many degrees for its temperature coefficients to be identified.
MIN_TEMPERATURE_SPAN_C = 2.0


@dataclass(frozen=True)
class TemperatureCompensation:
    """Each cell's zero [raw / °C] and span [1 / °C] coefficients about ``reference_C`` (the module docstring)."""

    reference_C: float
    zero_per_C: tuple[float, float]
    span_per_C: tuple[float, float]

    def __post_init__(self) -> None:
        values = (self.reference_C, *self.zero_per_C, *self.span_per_C)
        if len(self.zero_per_C) != 2 or len(self.span_per_C) != 2 or not all(np.isfinite(values)):
            raise InputError(f"temperature coefficients must be finite numbers, two of each: {self}")

    def corrected(self, loads, temperature, offsets) -> np.ndarray:
        """``(n, 2)`` loads as they would read at ``reference_C``, from ``loads`` ``(n, 2)`` at ``temperature``
        ``(n,)`` [°C]; a row whose temperature is not a number keeps NaN loads (its estimate is invalid)."""
        loads = np.asarray(loads, float)
        dT = (np.asarray(temperature, float) - self.reference_C)[:, None]
        o = np.asarray(offsets, float)
        return o + (loads - o - np.asarray(self.zero_per_C) * dT) / (1.0 + np.asarray(self.span_per_C) * dT)


@dataclass(frozen=True)
class TemperatureFit:
    """What :func:`fit_temperature` identified: the coefficients, each cell's intercept (an offset change at the
    reference) and the coefficients' standard errors (least squares: ``s^2 (X^T X)^-1``)."""

    compensation: TemperatureCompensation
    intercept: tuple[float, float]
    zero_se: tuple[float, float]  #: [raw / °C]
    span_se: tuple[float, float]  #: [1 / °C]


def fit_temperature(temperature, loads, signal, offsets) -> TemperatureFit:
    """The coefficients that best explain ``loads - offsets - signal`` (``(n, 2)`` each: the readings, and the signal
    the calibrated map predicts for the applied forces) as ``c + a dT + b dT signal``, by least squares per cell,
    ``dT`` from the median temperature.  The span coefficient rests on ``dT signal``'s spread against the map's own
    error, so it is the less certain of the two: see its standard error."""
    temperature = np.asarray(temperature, float)
    signal = np.asarray(signal, float)
    reference = float(np.median(temperature))
    dT = temperature - reference
    residual = np.asarray(loads, float) - np.asarray(offsets, float) - signal
    coefficients, errors = np.zeros((2, 3)), np.zeros((2, 3))
    for i in range(2):
        design = np.column_stack([np.ones_like(dT), dT, dT * signal[:, i]])
        coefficients[i], rss, *_ = np.linalg.lstsq(design, residual[:, i], rcond=None)
        dof = max(dT.size - 3, 1)
        sigma2 = float(rss[0]) / dof if np.size(rss) else 0.0
        errors[i] = np.sqrt(np.diag(sigma2 * np.linalg.pinv(design.T @ design)))
    pair = lambda k, a: (float(a[0, k]), float(a[1, k]))
    return TemperatureFit(TemperatureCompensation(reference, pair(1, coefficients), pair(2, coefficients)),
                          pair(0, coefficients), pair(1, errors), pair(2, errors))  # fmt: skip


def cell_signs(seed: int) -> np.ndarray:
    """``(2, 3)``: each cell's sign of its zero, span and creep terms, drawn for the rig numbered ``seed``."""
    return np.random.default_rng([seed, 0xD81F7]).choice([-1.0, 1.0], size=(2, 3))


def creep_lag(t, signal, drift: Drift) -> np.ndarray:
    """The creep term ``(n, 2)`` [counts] of the signal ``(n, 2)`` [counts, offset removed] at times ``t``: the
    first-order lag of the module docstring, exact for a signal held between samples, from rest at ``t[0]``."""
    t = np.asarray(t, float)
    signal = np.asarray(signal, float)
    if not drift.creep or t.size == 0:
        return np.zeros_like(signal)
    k = drift.creep / (1.0 - np.exp(-CREEP_SPAN_S / drift.creep_time_s))
    steps = np.diff(t)
    if steps.size and np.allclose(steps, steps[0], rtol=1e-9, atol=0.0):  # uniform: one IIR filter
        from scipy.signal import lfilter  # here: scipy.signal takes over a second to import, and every calibration loads this module

        a = float(np.exp(-steps[0] / drift.creep_time_s))
        out = np.zeros_like(signal)
        out[1:] = lfilter([(1.0 - a) * k], [1.0, -a], signal[1:], axis=0)
        return out
    out, c = np.zeros_like(signal), np.zeros(signal.shape[1])
    for i in range(1, t.size):  # uneven steps: the recursion row by row
        a = np.exp(-(t[i] - t[i - 1]) / drift.creep_time_s)
        c = a * c + (1.0 - a) * k * signal[i]
        out[i] = c
    return out


def drifted(t, signal, temperature, drift: Drift, rated_counts: float, signs) -> np.ndarray:
    """The drift ``(n, 2)`` [counts] to add to readings whose signal (offset removed) is ``signal`` ``(n, 2)``,
    at times ``t`` [s] from power-up and temperatures ``temperature`` [°C] (the first is the calibration's)."""
    t, temperature = np.asarray(t, float), np.asarray(temperature, float)
    signal = np.asarray(signal, float)
    signs = np.asarray(signs, float)
    dT = (temperature - temperature[0])[:, None]
    zero = (drift.zero_per_C * rated_counts + drift.adc_offset_V_per_C * HX711_COUNTS_PER_V) * dT * signs[:, 0]
    warm = drift.warmup * rated_counts * (1.0 - np.exp(-t / drift.warmup_time_s))[:, None] * signs[:, 0]
    span = (drift.span_per_C * signs[:, 1] + drift.adc_gain_per_C) * dT * signal
    return zero + warm + span + creep_lag(t, signal, drift) * signs[:, 2]
