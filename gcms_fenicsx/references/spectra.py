"""The frequency of a recorded signal's largest spectral peak, to a small fraction of a bin."""
from __future__ import annotations

import numpy as np


def peak_frequency_hz(x: np.ndarray, dt: float, pad: int = 8) -> float:
    """Frequency (Hz) of the largest peak of the samples x (spacing dt): Hann window, zero
    padding ×``pad``, and a parabola through the log-magnitudes of the three bins at the
    peak (exact for a Gaussian peak, a few hundredths of a bin for the Hann window's)."""
    x = np.asarray(x, float) - np.mean(x)
    n = pad * len(x)
    X = np.abs(np.fft.rfft(x * np.hanning(len(x)), n))
    k = int(np.argmax(X[1:])) + 1
    a, b, c = np.log(X[k - 1:k + 2])
    return (k + 0.5 * (a - c) / (a - 2 * b + c)) / (n * dt)
