"""The load-cell ADC: its conversion rate, its digital filter, its delay and its noise.

A delta-sigma bridge ADC converts on its own clock at ``rate_Hz`` (period
``T = 1 / rate_Hz``).  Its digital filter, a sinc^N decimator, makes each
conversion a weighted average of the input over the last ``N T``:

    r_k = integral of h(tau) s(t_k - tau) dtau,   h = (1/T) box(0, T) * ... * box(0, T)   (N boxes),

so ``h`` is the cardinal B-spline of order N stretched to ``[0, N T]``
(Oppenheim & Schafer, *Discrete-Time Signal Processing*, 3rd ed., 2010,
Sec. 4.6 on CIC/sinc decimators; Hogenauer, *IEEE Trans. ASSP* 29(2), 1981).
Its frequency response is ``H(f) = (sin(pi f T) / (pi f T))^N e^{-i pi N f T}``:

- the **settling time** is ``N T`` (a step is fully seen after N conversions);
- the **group delay** is ``N T / 2`` (linear phase: the reading is the input
  at the window's centroid, to second order);
- the **-3 dB bandwidth** solves ``|sin(pi f T) / (pi f T)|^N = 1 / sqrt(2)``.

``ideal`` is the sensor sailforce assumed before ADCs were modelled: a
reading at every control tick, of the input at that instant, no filter.
The presets take their rate, filter, noise and clocking from the parts'
datasheets (docs/reference/adc.md cites each).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError

#: The bridge excitation [V] the noise figures refer to: the datasheets' 5 V analog supply (HX711's AVDD).
EXCITATION_V = 5.0

#: How far |sinc|^N may stand from 1/sqrt(2) at the bandwidth found (bisection tolerance on f T).
BANDWIDTH_XTOL = 1e-12


@dataclass(frozen=True)
class ADC:
    """One load-cell ADC (module docstring).  ``rate_Hz`` 0 is the ideal sensor: a reading at every control tick."""

    model: str = "ideal"
    rate_Hz: float = 0.0  #: conversions per second; 0: every control tick, unfiltered
    sinc_order: int = 0  #: the digital filter: sinc^N over N conversion periods (0: none)
    noise_nV: float = 0.0  #: input-referred noise per conversion at this rate, rms [nV] (gain 128)
    simultaneous: bool = False  #: both cells on one chip and one clock (else two chips, each its own clock)
    rate_tolerance: float = 0.0  #: the clock's tolerance, a fraction of the nominal rate (each chip within it)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_Hz) and self.rate_Hz >= 0):
            raise InputError(f"adc.rate_Hz = {self.rate_Hz!r}: expected a rate >= 0 [Hz] (0: the ideal sensor)")
        if isinstance(self.sinc_order, bool) or not isinstance(self.sinc_order, int) or not 0 <= self.sinc_order <= 8:
            raise InputError(f"adc.sinc_order = {self.sinc_order!r}: expected a whole number 0..8 (the sinc filter's order)")
        if self.rate_Hz == 0 and self.sinc_order:
            raise InputError("adc.sinc_order needs adc.rate_Hz: a filter averages over conversion periods")
        if not (math.isfinite(self.noise_nV) and self.noise_nV >= 0):
            raise InputError(f"adc.noise_nV = {self.noise_nV!r}: expected a noise >= 0 [nV rms]")
        if not (math.isfinite(self.rate_tolerance) and 0 <= self.rate_tolerance < 0.5):
            raise InputError(f"adc.rate_tolerance = {self.rate_tolerance!r}: expected a fraction in [0, 0.5)")
        if not isinstance(self.simultaneous, bool):
            raise InputError(f"adc.simultaneous = {self.simultaneous!r}: expected true or false")

    @property
    def ideal(self) -> bool:
        """True for the ideal sensor: a reading at every control tick, of that instant."""
        return self.rate_Hz == 0

    @property
    def period_s(self) -> float:
        """The conversion period T [s] (0 for the ideal sensor)."""
        return 0.0 if self.ideal else 1.0 / self.rate_Hz

    @property
    def settling_s(self) -> float:
        """How long a step takes to be fully seen, N T [s]: the filter's window."""
        return self.sinc_order * self.period_s

    @property
    def group_delay_s(self) -> float:
        """N T / 2 [s]: a conversion reads the input at its window's centroid."""
        return 0.5 * self.settling_s

    @property
    def bandwidth_Hz(self) -> float:
        """The -3 dB frequency of |H(f)| [Hz]; infinite without a filter."""
        if self.sinc_order == 0:
            return math.inf
        target = 2.0 ** (-0.5 / self.sinc_order)  # |sinc(x)| at the -3 dB point
        low, high = 0.0, 1.0  # |sinc| falls from 1 at x = 0 to 0 at x = 1
        while high - low > BANDWIDTH_XTOL:
            mid = 0.5 * (low + high)
            low, high = (mid, high) if np.sinc(mid) > target else (low, mid)
        return 0.5 * (low + high) * self.rate_Hz

    @property
    def noise_mV_V(self) -> float:
        """The input noise as a bridge output [mV/V] on :data:`EXCITATION_V`."""
        return self.noise_nV * 1e-6 / EXCITATION_V

    def weights(self, tau) -> np.ndarray:
        """The filter's impulse response h(tau) [1/s] at lags ``tau`` [s] (>= 0): integrates to 1 over [0, N T]."""
        tau = np.asarray(tau, dtype=float)
        if self.sinc_order == 0:
            raise InputError("an unfiltered ADC has no window: it reads the input at the conversion instant")
        from scipy.interpolate import BSpline

        spline = BSpline.basis_element(np.arange(self.sinc_order + 1), extrapolate=False)
        values = np.nan_to_num(spline(tau / self.period_s), nan=0.0)
        return values / self.period_s

    def window(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Lags ``tau`` [s] on a grid of step ``dt`` covering the window, and weights summing to 1 (trapezoid exact)."""
        if self.sinc_order == 0:
            return np.zeros(1), np.ones(1)
        lags = np.arange(0.0, self.settling_s + 0.5 * dt, dt)
        weights = self.weights(lags)
        return lags, weights / weights.sum()


#: The presets: each part's rate, filter, input noise at gain 128 and that rate, and clocking (docs/reference/adc.md).
PRESETS: dict[str, ADC] = {
    "ideal": ADC(),
    # Avia HX711: on-chip oscillator, 10 or 80 SPS (RATE pin); settling 400 ms / 50 ms = 4 conversions;
    # input noise 50 / 90 nV rms at gain 128.  One chip per cell: two free-running clocks.
    "hx711-10": ADC("hx711-10", 10.0, 4, 50.0, False, 0.03),
    "hx711-80": ADC("hx711-80", 80.0, 4, 90.0, False, 0.03),
    # TI ADS1232: 10/80 SPS from its internal oscillator, sinc4 (settling 4 conversions); one chip per cell.
    "ads1232-80": ADC("ads1232-80", 80.0, 4, 44.0, False, 0.02),
    # Nuvoton NAU7802: RC oscillator, 10-320 SPS, sinc3 filter; one chip per cell (one I2C address each).
    "nau7802-320": ADC("nau7802-320", 320.0, 3, 200.0, False, 0.05),
    # TI ADS131M02: two simultaneous channels on one clock (8.192 MHz crystal), OSR 4096: 1 kSPS, sinc3.
    "ads131m02-1000": ADC("ads131m02-1000", 1000.0, 3, 600.0, True, 1e-4),
}

#: The robot-file keys of ``[adc]``.
ADC_KEYS = ("model", "rate_Hz", "sinc_order", "noise_nV", "simultaneous", "rate_tolerance")


def adc_model(name: str) -> ADC:
    """The preset ``name`` (one of :data:`PRESETS`)."""
    try:
        return PRESETS[name]
    except KeyError:
        raise InputError(f"ADC model {name!r}: expected one of {', '.join(PRESETS)}, or explicit [adc] keys") from None


def adc_from_table(table: dict) -> ADC:
    """An ADC from a robot file's ``[adc]`` table: a preset (``model``), its keys overridden by explicit ones."""
    named = "model" in table and not str(table["model"]).startswith("custom")
    base = adc_model(table["model"]) if named else ADC(model="custom")
    values = {k: table[k] for k in ADC_KEYS if k in table and k != "model"}
    if values and named:
        values["model"] = f"{table['model']} (modified)"
    if "sinc_order" in values and isinstance(values["sinc_order"], float) and values["sinc_order"].is_integer():
        values["sinc_order"] = int(values["sinc_order"])
    return replace(base, **values)
