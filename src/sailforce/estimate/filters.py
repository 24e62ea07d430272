"""A causal low-pass filter for load-cell readings whose state carries across chunks.

A Butterworth low-pass of ``order`` at ``cutoff_hz`` for samples at
``sample_rate_hz``, run as second-order sections (scipy.signal.butter,
``output="sos"``; sosfilt with its state ``zi``).  Filtering a stream in
chunks gives exactly the output of one pass over the whole stream.  The
state starts at the first valid sample's steady state, so a raw offset does
not ring.  Readings flagged invalid are skipped: they neither enter the
filter nor advance it, and their output is NaN.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import FilterError


@dataclass
class LowPass:
    """Butterworth low-pass over the last axis of ``(n, channels)`` blocks; mutable state, one instance per stream."""

    cutoff_hz: float
    sample_rate_hz: float
    order: int = 2
    sos: np.ndarray = field(init=False, repr=False)
    state: np.ndarray | None = field(init=False, default=None, repr=False)

    def __post_init__(self) -> None:
        nyquist = 0.5 * self.sample_rate_hz
        if not (self.sample_rate_hz > 0 and 0 < self.cutoff_hz < nyquist):
            raise FilterError(
                f"low-pass cutoff {self.cutoff_hz:g} Hz must lie between 0 and the Nyquist frequency "
                f"{nyquist:g} Hz of the {self.sample_rate_hz:g} Hz sample rate"
            )
        if not 1 <= self.order <= 8:
            raise FilterError(f"low-pass order {self.order} must be 1 to 8")
        from scipy import signal  # imported here: scipy.signal takes over a second to load

        self.sos = signal.butter(self.order, self.cutoff_hz, fs=self.sample_rate_hz, output="sos")

    def process(self, block: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """Filter ``block`` ``(n, channels)``; rows where ``valid`` is False are skipped and come out NaN."""
        out = np.full(block.shape, np.nan)
        x = block[valid]
        if x.shape[0] == 0:
            return out
        from scipy import signal

        if self.state is None:  # steady state at the first valid sample
            zi = signal.sosfilt_zi(self.sos)  # (sections, 2)
            self.state = zi[:, :, None] * x[0][None, None, :]
        y, self.state = signal.sosfilt(self.sos, x, axis=0, zi=self.state)
        out[valid] = y
        return out
