"""Load-cell ADCs: conversion rates, digital filters, delays and noise, and the conversions a rig makes.

- :class:`ADC` and :data:`PRESETS` (``hx711-10``, ``hx711-80``, ``ads1232-80``, ``nau7802-320``,
  ``ads131m02-1000``, ``ideal``): rate, sinc filter, group delay, bandwidth, noise;
- :func:`conversions`: each cell's conversions of a finely sampled signal, on its own clock.
"""

from .models import ADC, ADC_KEYS, EXCITATION_V, PRESETS, adc_from_table, adc_model

__all__ = ["ADC", "ADC_KEYS", "EXCITATION_V", "PRESETS", "adc_from_table", "adc_model"]
