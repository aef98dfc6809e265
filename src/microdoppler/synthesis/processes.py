"""Random processes shared by the emulator's reality knobs and the model extensions."""

from __future__ import annotations

import zlib

import numpy as np
from scipy.signal import lfilter


def ou_process(n: int, dt_s: float, std: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary Ornstein-Uhlenbeck process: float64 [n] at spacing ``dt_s`` [s],
    standard deviation ``std``, correlation time ``tau_s`` [s] (exact AR(1)
    discretisation; the first sample is drawn from the stationary law)."""
    if n <= 0:
        return np.zeros(0)
    a = np.exp(-dt_s / tau_s)
    w = rng.standard_normal(n) * std * np.sqrt(1 - a * a)
    w[0] = rng.standard_normal() * std
    return lfilter([1.0], [1.0, -a], w)


#: sampling interval of the slow gain processes before interpolation [s]
GAIN_DT_S = 0.01


class SlowGain:
    """A dB gain process sampled every :data:`GAIN_DT_S` and interpolated to any time
    (the emulator's knobs and natural variations).

    ``amplitude(t_s)`` returns 10^(x(t)/20) as float32.
    """

    def __init__(self, duration_s: float, std_db: float, tau_s: float, rng: np.random.Generator, t0_s: float = 0.0):
        n = int(np.ceil(duration_s / GAIN_DT_S)) + 3
        self.t0_s = t0_s
        self.x_db = ou_process(n, GAIN_DT_S, std_db, tau_s, rng)

    def db(self, t_s: np.ndarray) -> np.ndarray:
        grid = self.t0_s + GAIN_DT_S * np.arange(len(self.x_db))
        return np.interp(t_s, grid, self.x_db)

    def amplitude(self, t_s: np.ndarray) -> np.ndarray:
        return (10.0 ** (self.db(t_s) / 20.0)).astype(np.float32)


class GainHook:
    """``hook(i0, i1, t_s, x)`` multiplying ``x`` by a slow dB gain process (the
    twins' fluctuation extensions)."""

    def __init__(self, duration_s: float, std_db: float, tau_s: float, rng: np.random.Generator):
        n = int(np.ceil(duration_s / GAIN_DT_S)) + 3
        self.x_db = ou_process(n, GAIN_DT_S, std_db, tau_s, rng)
        self.grid = GAIN_DT_S * np.arange(n)

    def amplitude(self, t_s: np.ndarray) -> np.ndarray:
        return (10.0 ** (np.interp(t_s, self.grid, self.x_db) / 20.0)).astype(np.float32)

    def __call__(self, i0, i1, t_s, x):
        x *= self.amplitude(t_s)


def stable_seed(*parts) -> int:
    """A seed from ``parts`` (ints, strings) that is the same in every process.

    Python's ``hash`` of a string changes between runs; CRC32 does not.
    """
    return zlib.crc32("/".join(str(p) for p in parts).encode()) & 0x7FFFFFFF
