"""The winding-temperature sensor of a timeseries session (a KTY/PT1000 in the winding).

The sensor sees the true winding temperature of :mod:`bench.synth.true_signals`
through a first-order lag (its thermal contact), plus white noise, quantized to
the DAQ's resolution. It draws from its own random stream, so adding it left every
other logged channel unchanged.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

#: Kelvin at 0 degC
KELVIN_AT_0C = 273.15


class WindingSensor:
    """Chunked readings of the lagged, noisy winding sensor.

    Parameters
    ----------
    theta0_c : float
        True (and sensed) winding temperature at the session start [degC].
    lag_s : float
        First-order time constant of the sensor [s].
    noise_k : float
        White-noise standard deviation [K].
    rate_hz : float
        Sample rate [Hz].
    rng : numpy.random.Generator
        The sensor's own random stream.
    """

    def __init__(self, theta0_c: float, lag_s: float, noise_k: float, rate_hz: float,
                 rng: np.random.Generator):
        self._a = float(np.exp(-1.0 / (lag_s * rate_hz)))
        self._state = np.array([self._a * float(theta0_c)])
        self._noise_k = noise_k
        self._rng = rng

    def read(self, theta_c: np.ndarray) -> np.ndarray:
        """Sensed temperature [degC] for the next samples of the true ``theta_c`` [degC]."""
        lagged, self._state = lfilter([1.0 - self._a], [1.0, -self._a],
                                      np.asarray(theta_c, dtype=float), zi=self._state)
        return lagged + self._noise_k * self._rng.standard_normal(lagged.size)
